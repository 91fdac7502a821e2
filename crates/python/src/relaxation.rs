//! `embed_relaxation` and `embed_alexa`: the iterative methods of thesis 5.2
//! and 5.3.

use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyBytes, PyDict, PyString};
use spherify_sphere::alexa::{alexa, AlexaParams, AlexaStep};
use spherify_sphere::relaxation::{relaxation, Initial, RelaxationParams};

use crate::convert::rows;
use crate::embed::{embedding_to_py, sphere_error};
use crate::errors::mesh_error;
use crate::mesh::CoreMesh;

type Embedded<'py> = (Bound<'py, PyAny>, Bound<'py, PyDict>);

/// A count from Python that must be >= `minimum` (taken as i64 so that a
/// negative value is a MeshError rather than an OverflowError).
fn count(py: Python<'_>, name: &str, value: i64, minimum: i64) -> PyResult<usize> {
    if value < minimum {
        return Err(mesh_error(py, format!("{name} must be an integer >= {minimum}, got {value}")));
    }
    usize::try_from(value).map_err(|_| mesh_error(py, format!("{name} = {value} is too large")))
}

/// The start of eq. 5.13: the centroid (default), `center` = "centroid" or a
/// point (x, y, z), or `initial` points (n, 3); not both.
fn initial(
    py: Python<'_>,
    center: Option<&Bound<'_, PyAny>>,
    points: Option<PyReadonlyArrayDyn<'_, f64>>,
) -> PyResult<Initial> {
    const EXPECTED: &str = "center must be 'centroid' or a point (x, y, z) of three finite numbers";
    match (center, points) {
        (Some(_), Some(_)) => Err(mesh_error(py, "give center or initial points, not both")),
        (None, Some(points)) => Ok(Initial::Points(rows::<f64, 3>(py, &points, "initial")?)),
        (None, None) => Ok(Initial::Centroid),
        (Some(c), None) => {
            if let Ok(name) = c.cast::<PyString>() {
                return match name.to_str()? {
                    "centroid" => Ok(Initial::Centroid),
                    other => Err(mesh_error(py, format!("{EXPECTED}, got {other:?}"))),
                };
            }
            let point = if c.is_instance_of::<PyBytes>() || c.is_instance_of::<PyByteArray>() {
                None
            } else {
                c.extract::<[f64; 3]>().ok()
            };
            match point {
                Some(p) if p.iter().all(|x| x.is_finite()) => Ok(Initial::Center(p)),
                _ => Err(mesh_error(
                    py,
                    format!(
                        "{EXPECTED}, got {}",
                        c.repr().map(|r| r.to_string()).unwrap_or_default()
                    ),
                )),
            }
        }
    }
}

/// embed_relaxation(mesh, weights="uniform", rho=1.0, max_iter=10000,
/// check_every=10, strict=False, tol=1e-12, center=None, initial=None)
/// -> (points (n, 3) float64, info dict).
///
/// Iterative relaxation (thesis 5.2, eq. 5.15). `weights`: "uniform", "chord"
/// (|x_i - x_j|^rho), "mean_value" or "cotangent". `info["status"]` is
/// "converged" (the exact validity test passed), "collapsed" (the points
/// contracted into an open hemisphere, which they cannot leave) or
/// "max_iterations"; with `strict=True` the latter two raise ConvergenceError
/// whose `state["points"]` holds the last iterate.
#[pyfunction]
#[pyo3(signature = (mesh, weights="uniform", rho=1.0, max_iter=10000, check_every=10, strict=false, tol=1e-12, center=None, initial=None))]
#[allow(clippy::too_many_arguments)]
pub fn embed_relaxation<'py>(
    py: Python<'py>,
    mesh: &CoreMesh,
    weights: &str,
    rho: f64,
    max_iter: i64,
    check_every: i64,
    strict: bool,
    tol: f64,
    center: Option<&Bound<'py, PyAny>>,
    initial: Option<PyReadonlyArrayDyn<'py, f64>>,
) -> PyResult<Embedded<'py>> {
    let params = RelaxationParams {
        weights: crate::convert::weights(py, weights, rho, &crate::convert::ALL_WEIGHTS, "")?,
        max_iter: count(py, "max_iter", max_iter, 0)?,
        check_every: count(py, "check_every", check_every, 1)?,
        tol,
        strict,
        initial: self::initial(py, center, initial)?,
    };
    let e = py.detach(|| relaxation(&mesh.mesh, &params)).map_err(|e| sphere_error(py, e))?;
    let (points, info) = embedding_to_py(py, &e)?;
    info.set_item("weights", weights)?;
    Ok((points, info))
}

/// embed_alexa(mesh, c=None, max_iter=10000, check_every=10, strict=False,
/// tol=1e-12, center=None, initial=None) -> (points (n, 3) float64, info dict).
///
/// Alexa's method (thesis 5.3, eq. 5.17-5.18). `c=None` scales each step by the
/// inverse longest edge at the vertex (eq. 5.19); a number uses that constant
/// (Alexa's robust, slow choice is 1). Status and `strict` as for
/// `embed_relaxation`.
#[pyfunction]
#[pyo3(signature = (mesh, c=None, max_iter=10000, check_every=10, strict=false, tol=1e-12, center=None, initial=None))]
#[allow(clippy::too_many_arguments)]
pub fn embed_alexa<'py>(
    py: Python<'py>,
    mesh: &CoreMesh,
    c: Option<f64>,
    max_iter: i64,
    check_every: i64,
    strict: bool,
    tol: f64,
    center: Option<&Bound<'py, PyAny>>,
    initial: Option<PyReadonlyArrayDyn<'py, f64>>,
) -> PyResult<Embedded<'py>> {
    let params = AlexaParams {
        step: c.map_or(AlexaStep::InverseLongestEdge, AlexaStep::Constant),
        max_iter: count(py, "max_iter", max_iter, 0)?,
        check_every: count(py, "check_every", check_every, 1)?,
        tol,
        strict,
        initial: self::initial(py, center, initial)?,
    };
    let e = py.detach(|| alexa(&mesh.mesh, &params)).map_err(|e| sphere_error(py, e))?;
    let (points, info) = embedding_to_py(py, &e)?;
    info.set_item("step", if c.is_some() { "constant" } else { "inverse_longest_edge" })?;
    Ok((points, info))
}
