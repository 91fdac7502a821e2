//! `boundary_loop` and `tutte` (thesis ch. 4).

use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use spherify_mesh::HalfEdgeMesh;
use spherify_sparse::tutte::{self as core_tutte, BoundaryShape, TutteParams};
use spherify_sparse::SolveParams;

use crate::convert::{rows, to_numpy};
use crate::errors::{mesh_error, to_py, tutte_error, unknown_name};
use crate::mesh::CoreMesh;

/// boundary_loop(mesh) -> (k,) int64, counter-clockwise; TopologyError unless a disk.
#[pyfunction]
pub fn boundary_loop<'py>(py: Python<'py>, mesh: &CoreMesh) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let result = crate::pool::detach(py, || {
        let he = HalfEdgeMesh::new(&mesh.mesh)?;
        core_tutte::boundary_loop(&mesh.mesh, &he)
    })?;
    let cycle = result.map_err(|e| to_py(py, e.into()))?;
    Ok(cycle.into_iter().map(i64::from).collect::<Vec<_>>().into_pyarray(py))
}

/// tutte(mesh, weights, rho, boundary, polygon, solver, tol, max_iter) -> (uv, info dict).
#[pyfunction]
#[pyo3(signature = (mesh, weights="uniform", rho=1.0, boundary="circle", polygon=None, solver="auto", tol=1e-10, max_iter=10000))]
#[allow(clippy::too_many_arguments)]
pub fn tutte<'py>(
    py: Python<'py>,
    mesh: &CoreMesh,
    weights: &str,
    rho: f64,
    boundary: &str,
    polygon: Option<PyReadonlyArrayDyn<'_, f64>>,
    solver: &str,
    tol: f64,
    max_iter: usize,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyDict>)> {
    crate::memory::check_app(
        spherify_sphere::memory_budget::Application::Tutte,
        mesh.mesh.n_vertices(),
        mesh.mesh.n_faces(),
        0,
    )?;
    let boundary = match (boundary, polygon) {
        ("circle", None) => BoundaryShape::Circle,
        ("circle_length", None) => BoundaryShape::CircleByLength,
        ("polygon", Some(points)) => {
            BoundaryShape::Polygon(rows::<f64, 2>(&points, "boundary polygon")?)
        }
        (other, _) => {
            return Err(mesh_error(format!(
            "boundary must be 'circle', 'circle_length' or a (k, 2) array of points, got {other:?}"
        )))
        }
    };
    let params = TutteParams {
        weights: crate::convert::weights(weights, rho)?,
        boundary,
        solver: solver.parse().map_err(unknown_name)?,
        solve: SolveParams { tol, max_iter, x0: None },
    };
    // Detachable: Ctrl-C inside one long factorisation (seconds at a million
    // vertices) answers at once (issue 13, item 2).
    let shared = std::sync::Arc::clone(&mesh.mesh);
    let embedding =
        crate::progress::run_detachable(py, None, move |_| core_tutte::tutte(&shared, &params))?
            .map_err(|e| tutte_error(py, e))?;
    let info = PyDict::new(py);
    info.set_item("solver", embedding.info.solver.as_str())?;
    info.set_item("iterations", embedding.info.iterations)?;
    info.set_item("residual", embedding.info.residual)?;
    info.set_item("seconds", embedding.info.seconds)?;
    let ids = |v: &[u32]| v.iter().map(|&x| i64::from(x)).collect::<Vec<_>>();
    info.set_item("boundary", ids(&embedding.boundary).into_pyarray(py))?;
    info.set_item("flipped_faces", ids(&embedding.inverted.flipped).into_pyarray(py))?;
    info.set_item("degenerate_faces", ids(&embedding.inverted.degenerate).into_pyarray(py))?;
    info.set_item("negative_weights", embedding.negative_weights)?;
    Ok((to_numpy(py, &embedding.uv), info))
}
