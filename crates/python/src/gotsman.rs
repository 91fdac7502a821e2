//! `embed_gotsman`: Gotsman, Gu and Sheffer's spherical Tutte embedding
//! (thesis 5.1, eq. 5.10), solved by sparse Newton with a dogleg trust region.

use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use spherify_sphere::gotsman::{gotsman, GotsmanParams, Initial};

use crate::convert::rows;
use crate::embed::{embedding_to_py, sphere_error};
use crate::errors::mesh_error;
use crate::mesh::CoreMesh;

/// embed_gotsman(mesh, weights="uniform", rho=1.0, max_iter=50, tol=1e-10,
/// strict=False, initial=None) -> (points (n, 3) float64, info dict).
///
/// `weights`: "uniform" or "chord" (|x_i - x_j|^rho); the system needs
/// symmetric positive weights. Converged when every equation of 5.10 holds to
/// `tol`; `info["status"]` is "converged", "max_iterations" (also when the
/// iteration stalled; see the message) or "collapsed" (the trivial solution).
/// `initial`: (n, 3) start points, default the centroid projection (5.11).
/// `strict=True` raises ConvergenceError unless converged.
#[pyfunction]
#[pyo3(signature = (mesh, weights="uniform", rho=1.0, max_iter=50, tol=1e-10, strict=false, initial=None))]
#[allow(clippy::too_many_arguments)]
pub fn embed_gotsman<'py>(
    py: Python<'py>,
    mesh: &CoreMesh,
    weights: &str,
    rho: f64,
    max_iter: i64,
    tol: f64,
    strict: bool,
    initial: Option<PyReadonlyArrayDyn<'_, f64>>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let weights = crate::convert::weights(
        py,
        weights,
        rho,
        &["uniform", "chord"],
        " (eq. 5.10 needs symmetric weights)",
    )?;
    if max_iter < 0 {
        return Err(mesh_error(py, format!("max_iter must be an integer >= 0, got {max_iter}")));
    }
    let max_iter = usize::try_from(max_iter)
        .map_err(|_| mesh_error(py, format!("max_iter = {max_iter} is too large")))?;
    let initial = match initial {
        Some(points) => Initial::Points(rows::<f64, 3>(py, &points, "initial")?),
        None => Initial::Centroid,
    };
    let params = GotsmanParams { weights, max_iter, tol, strict, initial };
    let embedding = py.detach(|| gotsman(&mesh.mesh, &params)).map_err(|e| sphere_error(py, e))?;
    embedding_to_py(py, &embedding)
}
