//! Shortest paths on the vertex graph (thesis App. A).

use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;
use spherify_mesh::dijkstra::{self as paths, EdgeWeights};
use spherify_mesh::{Adjacency, Mesh};

use crate::errors::mesh_error;
use crate::mesh::CoreMesh;

/// Whether edges weigh their length (`"length"`) or 1 (`"uniform"`).
fn by_length(name: &str) -> PyResult<bool> {
    match name {
        "uniform" => Ok(false),
        "length" => Ok(true),
        other => Err(mesh_error(format!("weights must be 'length' or 'uniform', got {other:?}"))),
    }
}

fn weights(mesh: &Mesh, by_length: bool) -> EdgeWeights<'_> {
    if by_length {
        EdgeWeights::Length(mesh.positions())
    } else {
        EdgeWeights::Uniform
    }
}

fn check_vertex(mesh: &CoreMesh, v: i64, what: &str) -> PyResult<u32> {
    let n = mesh.mesh.n_vertices();
    if v < 0 || v as u64 >= n as u64 {
        return Err(mesh_error(format!(
            "{what} vertex {v} is out of range (the mesh has {n} vertices)"
        )));
    }
    Ok(v as u32)
}

/// Distances and predecessors, one per vertex.
type Paths<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<i64>>);

/// dijkstra(mesh, source, weights) -> (distances (n,) float64, predecessors (n,) int64).
#[pyfunction]
#[pyo3(signature = (mesh, source, weights="length"))]
pub fn dijkstra<'py>(
    py: Python<'py>,
    mesh: &CoreMesh,
    source: i64,
    weights: &str,
) -> PyResult<Paths<'py>> {
    let source = check_vertex(mesh, source, "source")?;
    let by_length = by_length(weights)?;
    let paths = crate::progress::run_on_mesh(py, mesh, move |mesh| {
        let graph = Adjacency::from_faces(mesh.n_vertices(), mesh.faces());
        paths::dijkstra(&graph, source, self::weights(mesh, by_length))
    })?;
    // The source was checked above, so the search always runs.
    let paths = paths.ok_or_else(|| mesh_error("source vertex out of range"))?;
    let pred: Vec<i64> = paths
        .predecessors
        .iter()
        .map(|&p| if p == paths::NO_VERTEX { -1 } else { i64::from(p) })
        .collect();
    Ok((paths.distances.into_pyarray(py), pred.into_pyarray(py)))
}

/// shortest_path(mesh, source, target, weights) -> (length, path (k,) int64);
/// raises MeshError when the target cannot be reached.
#[pyfunction]
#[pyo3(signature = (mesh, source, target, weights="length"))]
pub fn shortest_path<'py>(
    py: Python<'py>,
    mesh: &CoreMesh,
    source: i64,
    target: i64,
    weights: &str,
) -> PyResult<(f64, Bound<'py, PyArray1<i64>>)> {
    let source = check_vertex(mesh, source, "source")?;
    let target = check_vertex(mesh, target, "target")?;
    let by_length = by_length(weights)?;
    let found = crate::progress::run_on_mesh(py, mesh, move |mesh| {
        let graph = Adjacency::from_faces(mesh.n_vertices(), mesh.faces());
        paths::dijkstra_to(&graph, source, target, self::weights(mesh, by_length))
    })?;
    match found {
        Some((length, path)) => {
            let path: Vec<i64> = path.into_iter().map(i64::from).collect();
            Ok((length, path.into_pyarray(py)))
        }
        None => Err(mesh_error(format!("vertex {target} cannot be reached from vertex {source}: they lie in different components"))),
    }
}
