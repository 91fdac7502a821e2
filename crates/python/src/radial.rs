//! Options of radial projection from a point, the vertex mean or the kernel
//! (thesis 3.5, eq. 3.17).

use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyBytes, PyString};
use spherify_sphere::methods::radial::Center;
use spherify_sphere::Method;

use crate::errors::mesh_error;
use crate::options::Options;

const EXPECTED: &str =
    "center must be 'kernel', 'centroid' or a point (x, y, z) of three finite numbers";

/// "kernel", "centroid", or any length-3 sequence of numbers (a tuple, list or
/// 1-D array); anything else is a MeshError.
fn center_choice(center: &Bound<'_, PyAny>) -> PyResult<Center> {
    if let Ok(name) = center.cast::<PyString>() {
        return match name.to_cow()?.as_ref() {
            "kernel" => Ok(Center::Kernel),
            "centroid" => Ok(Center::Centroid),
            other => Err(mesh_error(format!("{EXPECTED}, got {other:?}"))),
        };
    }
    // Bytes are sequences of small ints; as a centre they are surely a mistake.
    if center.is_instance_of::<PyBytes>() || center.is_instance_of::<PyByteArray>() {
        return Err(mesh_error(format!("{EXPECTED}, got bytes")));
    }
    let bad = || {
        mesh_error(format!(
            "{EXPECTED}, got {}",
            center.repr().map(|r| r.to_string()).unwrap_or_default()
        ))
    };
    let mut point = Vec::with_capacity(3);
    for item in center.try_iter().map_err(|_| bad())? {
        point.push(item.and_then(|x| x.extract::<f64>()).map_err(|_| bad())?);
        if point.len() > 3 {
            return Err(bad());
        }
    }
    match point[..] {
        [x, y, z] if point.iter().all(|v| v.is_finite()) => Ok(Center::Point([x, y, z])),
        _ => Err(bad()),
    }
}

/// Radial projection's options: `center` = "kernel" (default: the deepest
/// point of the kernel, found by a linear program; MeshError "not star-shaped"
/// when the kernel is empty), "centroid" (the vertex mean, eq. 3.18) or a
/// point (x, y, z).
pub fn method(options: &Options<'_>) -> PyResult<Method> {
    Ok(Method::Radial(match options.take("center")? {
        Some(c) => center_choice(&c)?,
        None => Center::default(),
    }))
}
