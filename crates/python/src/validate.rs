//! `check`, `check_raw`, `orient` and `weld`: reports become `spherify.MeshReport`.

use numpy::{IntoPyArray, PyArray1, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use spherify_mesh::{orient as orient_mod, validate, weld as weld_mod, MeshReport};

use crate::convert::rows;
use spherify_sphere::memory_budget::Application;

use crate::errors::to_py;
use crate::memory::check_app;
use crate::mesh::CoreMesh;

/// check(mesh) -> MeshReport.
#[pyfunction]
pub fn check<'py>(py: Python<'py>, mesh: &CoreMesh) -> PyResult<Bound<'py, PyAny>> {
    check_memory(mesh.mesh.n_vertices(), mesh.mesh.n_faces())?;
    let report = crate::progress::run_on_mesh(py, mesh, validate::check)?;
    report_to_py(py, &report)
}

/// The memory policy's check of validating a mesh of this size.
fn check_memory(n_vertices: usize, n_faces: usize) -> PyResult<()> {
    check_app(Application::Check, n_vertices, n_faces, 0)
}

/// check_raw(vertices, faces) -> MeshReport for arrays that may hold NaN or
/// out-of-range indices (those are reported instead of raised).
#[pyfunction]
pub fn check_raw<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArrayDyn<'_, f64>,
    faces: PyReadonlyArrayDyn<'_, i64>,
) -> PyResult<Bound<'py, PyAny>> {
    // Before the rows are copied (elements over 3).
    check_memory(vertices.as_array().len() / 3, faces.as_array().len() / 3)?;
    let positions = rows::<f64, 3>(&vertices, "vertices")?;
    let faces = rows::<i64, 3>(&faces, "faces")?;
    let size = faces.len();
    let report =
        crate::progress::run_sized(py, size, move || validate::check_raw(&positions, &faces))?;
    report_to_py(py, &report)
}

/// orient(mesh) -> (CoreMesh, info dict); raises TopologyError.
#[pyfunction]
pub fn orient<'py>(py: Python<'py>, mesh: &CoreMesh) -> PyResult<(CoreMesh, Bound<'py, PyDict>)> {
    check_app(Application::Orient, mesh.mesh.n_vertices(), mesh.mesh.n_faces(), 0)?;
    let (oriented, info) = crate::progress::run_on_mesh(py, mesh, orient_mod::orient)?
        .map_err(|e| to_py(py, e.into()))?;
    let dict = PyDict::new(py);
    dict.set_item("flipped_faces", info.flipped_faces)?;
    dict.set_item("components", info.components)?;
    dict.set_item("components_turned_outward", info.components_turned_outward)?;
    Ok((CoreMesh { mesh: oriented.into() }, dict))
}

/// weld(mesh) -> (CoreMesh, kept): vertices at one position merged
/// (`spherify_mesh::weld`); `kept[i]` is the input vertex of new vertex `i`.
#[pyfunction]
pub fn weld<'py>(
    py: Python<'py>,
    mesh: &CoreMesh,
) -> PyResult<(CoreMesh, Bound<'py, PyArray1<i64>>)> {
    let welded = crate::progress::run_on_mesh(py, mesh, weld_mod::weld)?;
    let kept: Vec<i64> = welded.kept.iter().map(|&v| i64::from(v)).collect();
    Ok((CoreMesh { mesh: welded.mesh.into() }, kept.into_pyarray(py)))
}

fn pairs<'py>(py: Python<'py>, items: &[[u32; 2]]) -> PyResult<Bound<'py, PyList>> {
    PyList::new(
        py,
        items
            .iter()
            .map(|p| PyTuple::new(py, p.iter()).map(|t| t.unbind()))
            .collect::<PyResult<Vec<_>>>()?,
    )
}

/// Builds `spherify.MeshReport(**fields)`.
pub fn report_to_py<'py>(py: Python<'py>, r: &MeshReport) -> PyResult<Bound<'py, PyAny>> {
    let d = PyDict::new(py);
    d.set_item("n_vertices", r.n_vertices)?;
    d.set_item("n_faces", r.n_faces)?;
    d.set_item("n_edges", r.n_edges)?;
    d.set_item("is_sphere_topology", r.is_sphere_topology)?;
    d.set_item("closed", r.closed)?;
    d.set_item("manifold", r.manifold)?;
    d.set_item("connected", r.connected)?;
    d.set_item("n_components", r.n_components)?;
    d.set_item("euler_characteristic", r.euler_characteristic)?;
    d.set_item("genus", r.genus)?;
    d.set_item("n_boundary_edges", r.boundary_edges)?;
    d.set_item("boundary_loops", r.boundary_loops.items.clone())?;
    d.set_item("n_boundary_loops", r.boundary_loops.total)?;
    d.set_item("nonmanifold_edges", pairs(py, &r.nonmanifold_edges.items)?)?;
    d.set_item("n_nonmanifold_edges", r.nonmanifold_edges.total)?;
    d.set_item("nonmanifold_vertices", r.nonmanifold_vertices.items.clone())?;
    d.set_item("n_nonmanifold_vertices", r.nonmanifold_vertices.total)?;
    d.set_item("degenerate_faces", r.degenerate_faces.items.clone())?;
    d.set_item("n_degenerate_faces", r.degenerate_faces.total)?;
    d.set_item("duplicate_faces", r.duplicate_faces.items.clone())?;
    d.set_item("n_duplicate_faces", r.duplicate_faces.total)?;
    d.set_item("unreferenced_vertices", r.unreferenced_vertices.items.clone())?;
    d.set_item("n_unreferenced_vertices", r.unreferenced_vertices.total)?;
    d.set_item("non_finite_vertices", r.non_finite_vertices.items.clone())?;
    d.set_item("n_non_finite_vertices", r.non_finite_vertices.total)?;
    d.set_item("out_of_range_faces", r.out_of_range_faces.items.clone())?;
    d.set_item("n_out_of_range_faces", r.out_of_range_faces.total)?;
    d.set_item("consistently_oriented", r.consistently_oriented)?;
    d.set_item("inconsistent_edges", pairs(py, &r.inconsistent_edges.items)?)?;
    d.set_item("n_inconsistent_edges", r.inconsistent_edges.total)?;
    d.set_item("outward", r.outward)?;
    d.set_item("signed_volume", r.signed_volume)?;
    d.set_item("problems", r.problems.clone())?;
    d.set_item("notes", r.notes.clone())?;
    let class = py.import("spherify._report")?.getattr("MeshReport")?;
    class.call((), Some(&d))
}
