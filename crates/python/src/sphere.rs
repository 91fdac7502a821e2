//! `check_sphere`: the validity tests of thesis 3.4 -> `spherify.SphereReport`.

use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use spherify_sphere::{check_sphere as check, SphereReport};

use crate::convert::rows;
use crate::errors::mesh_error;
use crate::mesh::CoreMesh;

/// check_sphere(mesh, points (n, 3) float64) -> SphereReport.
#[pyfunction]
pub fn check_sphere<'py>(
    py: Python<'py>,
    mesh: &CoreMesh,
    points: PyReadonlyArrayDyn<'_, f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let points = rows::<f64, 3>(&points, "points")?;
    if points.len() != mesh.mesh.n_vertices() {
        return Err(mesh_error(format!(
            "points has {} rows, but the mesh has {} vertices",
            points.len(),
            mesh.mesh.n_vertices()
        )));
    }
    let r = crate::pool::detach(py, || check(mesh.mesh.faces(), &points))?;
    report_to_py(py, &r)
}

/// A core `SphereReport` as `spherify.SphereReport`.
pub fn report_to_py<'py>(py: Python<'py>, r: &SphereReport) -> PyResult<Bound<'py, PyAny>> {
    let d = PyDict::new(py);
    d.set_item("valid", r.valid)?;
    d.set_item("n_positive", r.n_positive)?;
    d.set_item("n_negative", r.n_negative)?;
    d.set_item("n_zero", r.n_zero)?;
    d.set_item(
        "flipped_faces",
        numpy::IntoPyArray::into_pyarray(
            r.flipped_faces.iter().map(|&f| i64::from(f)).collect::<Vec<_>>(),
            py,
        ),
    )?;
    d.set_item("area_sum", r.area_sum)?;
    d.set_item("area_error", r.area_error)?;
    d.set_item("covering_degree", r.covering_degree)?;
    d.set_item("max_norm_error", r.max_norm_error)?;
    d.set_item("min_det", r.min_det)?;
    d.set_item("min_area_ratio", r.min_area_ratio)?;
    d.set_item("bad_points", r.bad_points.iter().map(|&v| i64::from(v)).collect::<Vec<_>>())?;
    py.import("spherify._report")?.getattr("SphereReport")?.call((), Some(&d))
}
