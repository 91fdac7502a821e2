//! `quality`: the distortion measures of `spherify_sphere::applications::metrics` as a dict.

use numpy::{IntoPyArray, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use spherify_sphere::applications::metrics;

use crate::convert::rows;
use spherify_sphere::memory_budget::{self, Application};

use crate::errors::{quality_error, resource_error};
use crate::mesh::CoreMesh;

/// The memory policy's check of a measure of `mesh`, before the points are copied.
fn check_quality(mesh: &CoreMesh) -> PyResult<()> {
    let (n, f) = (mesh.mesh.n_vertices(), mesh.mesh.n_faces());
    memory_budget::check(&memory_budget::application_need(Application::Quality, n, f, 0))
        .map_err(resource_error)
}

/// quality(mesh, points (n, 3) float64) -> dict of str to float (counts as
/// int); MeshError for wrong shapes, non-finite points or all faces degenerate.
#[pyfunction]
pub fn quality<'py>(
    py: Python<'py>,
    mesh: &CoreMesh,
    points: PyReadonlyArrayDyn<'_, f64>,
) -> PyResult<Bound<'py, PyDict>> {
    check_quality(mesh)?;
    let points = rows::<f64, 3>(&points, "points")?;
    let q = crate::progress::run_on_mesh(py, mesh, move |mesh| metrics::quality(mesh, &points))?
        .map_err(quality_error)?;
    let d = PyDict::new(py);
    for (name, value) in q.fields() {
        d.set_item(name, value)?;
    }
    d.set_item("degenerate_faces", q.degenerate_faces)?;
    d.set_item("n_faces", q.n_faces)?;
    Ok(d)
}

/// face_quality(mesh, points (n, 3) float64) -> dict of (m,) float64 arrays:
/// `angle_max_deg`, `conformal`, `area_log`, `stretch` per face (NaN where
/// degenerate); MeshError as `quality`.
#[pyfunction]
pub fn face_quality<'py>(
    py: Python<'py>,
    mesh: &CoreMesh,
    points: PyReadonlyArrayDyn<'_, f64>,
) -> PyResult<Bound<'py, PyDict>> {
    check_quality(mesh)?;
    let points = rows::<f64, 3>(&points, "points")?;
    let f =
        crate::progress::run_on_mesh(py, mesh, move |mesh| metrics::face_measures(mesh, &points))?
            .map_err(quality_error)?;
    let d = PyDict::new(py);
    d.set_item("angle_max_deg", f.angle_max_deg.into_pyarray(py))?;
    d.set_item("conformal", f.conformal.into_pyarray(py))?;
    d.set_item("area_log", f.area_log.into_pyarray(py))?;
    d.set_item("stretch", f.stretch.into_pyarray(py))?;
    Ok(d)
}
