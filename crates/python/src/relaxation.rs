//! Options of the iterative methods of thesis 5.2 (relaxation) and 5.3
//! (Alexa), and the start and weights they share with Gotsman's.

use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyBytes, PyString};
use spherify_sphere::methods::alexa::{AlexaParams, AlexaStep};
use spherify_sphere::methods::initial::Initial;
use spherify_sphere::methods::relaxation::RelaxationParams;
use spherify_sphere::Method;

use crate::errors::mesh_error;
use crate::options::Options;

/// The start of eq. 5.13: the centroid (default), `center` = "centroid" or a
/// point (x, y, z), or `initial` points (n, 3); not both.
pub fn initial(options: &Options<'_>) -> PyResult<Initial> {
    const EXPECTED: &str = "center must be 'centroid' or a point (x, y, z) of three finite numbers";
    let (center, points) = (options.take("center")?, options.take("initial")?);
    match (center, points) {
        (Some(_), Some(_)) => Err(mesh_error("give center or initial points, not both")),
        (None, Some(points)) => {
            let array = points
                .extract::<PyReadonlyArrayDyn<'_, f64>>()
                .map_err(|_| options.bad("initial", "an (n, 3) float64 array", &points))?;
            Ok(Initial::Points(crate::convert::rows::<f64, 3>(&array, "initial")?))
        }
        (None, None) => Ok(Initial::Centroid),
        (Some(c), None) => {
            if let Ok(name) = c.cast::<PyString>() {
                return match name.to_cow()?.as_ref() {
                    "centroid" => Ok(Initial::Centroid),
                    other => Err(mesh_error(format!("{EXPECTED}, got {other:?}"))),
                };
            }
            let point = if c.is_instance_of::<PyBytes>() || c.is_instance_of::<PyByteArray>() {
                None
            } else {
                c.extract::<[f64; 3]>().ok()
            };
            match point {
                Some(p) if p.iter().all(|x| x.is_finite()) => Ok(Initial::Center(p)),
                _ => Err(mesh_error(format!(
                    "{EXPECTED}, got {}",
                    c.repr().map(|r| r.to_string()).unwrap_or_default()
                ))),
            }
        }
    }
}

/// Relaxation (eq. 5.15): `weights` ("uniform", "chord" with `rho`,
/// "mean_value" or "cotangent"), `max_iter` (10000), `check_every` (10),
/// `tol` (1e-12), `strict`, and the start (`center` or `initial`).
pub fn relaxation(options: &Options<'_>) -> PyResult<Method> {
    let defaults = RelaxationParams::default();
    Ok(Method::Relaxation(RelaxationParams {
        weights: options.weights(defaults.weights)?,
        max_iter: options.count("max_iter", defaults.max_iter)?,
        check_every: options.count("check_every", defaults.check_every)?,
        tol: options.number("tol", defaults.tol)?,
        strict: options.flag("strict", defaults.strict)?,
        initial: initial(options)?,
    }))
}

/// Alexa's method (eq. 5.17-5.18): `c` = None scales each step by the
/// inverse longest edge at the vertex (eq. 5.19), a number uses that constant
/// (Alexa's robust, slow choice is 1); the rest as for relaxation.
pub fn alexa(options: &Options<'_>) -> PyResult<Method> {
    let defaults = AlexaParams::default();
    Ok(Method::Alexa(AlexaParams {
        step: options
            .optional_number("c")?
            .map_or(AlexaStep::InverseLongestEdge, AlexaStep::Constant),
        max_iter: options.count("max_iter", defaults.max_iter)?,
        check_every: options.count("check_every", defaults.check_every)?,
        tol: options.number("tol", defaults.tol)?,
        strict: options.flag("strict", defaults.strict)?,
        initial: initial(options)?,
    }))
}
