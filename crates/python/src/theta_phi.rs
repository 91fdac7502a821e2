//! `embed_theta_phi`: the theta-phi method (thesis ch. 6).

use numpy::IntoPyArray;
use pyo3::prelude::*;
use spherify_sphere::theta_phi::{theta_phi, PoleChoice, ThetaPhiParams};

use crate::convert::{to_i64_rows, to_numpy};
use crate::embed::{embedding_to_py, sphere_error};
use crate::errors::mesh_error;
use crate::mesh::CoreMesh;

fn pole_choice(py: Python<'_>, poles: &Bound<'_, PyAny>) -> PyResult<PoleChoice> {
    if let Ok(name) = poles.extract::<String>() {
        return match name.as_str() {
            "fast_graph" => Ok(PoleChoice::FastGraph),
            "graph" => Ok(PoleChoice::Graph),
            "physical" => Ok(PoleChoice::Physical),
            other => Err(mesh_error(
                py,
                format!("poles must be 'fast_graph', 'graph', 'physical' or a (north, south) pair of vertex ids, got {other:?}"),
            )),
        };
    }
    match poles.extract::<(i64, i64)>() {
        Ok((n, s)) if n >= 0 && s >= 0 && n <= u32::MAX as i64 && s <= u32::MAX as i64 => Ok(PoleChoice::Explicit(n as u32, s as u32)),
        _ => Err(mesh_error(py, "poles must be 'fast_graph', 'graph', 'physical' or a (north, south) pair of vertex ids")),
    }
}

/// embed_theta_phi(mesh, poles="fast_graph", weights="uniform", rho=1.0, max_refinements=8) -> (points, info).
#[pyfunction]
#[pyo3(signature = (mesh, poles=None, weights="uniform", rho=1.0, max_refinements=8))]
pub fn embed_theta_phi<'py>(
    py: Python<'py>,
    mesh: &CoreMesh,
    poles: Option<&Bound<'py, PyAny>>,
    weights: &str,
    rho: f64,
    max_refinements: usize,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, pyo3::types::PyDict>)> {
    let poles = match poles {
        Some(p) => pole_choice(py, p)?,
        None => PoleChoice::FastGraph,
    };
    let weights =
        crate::convert::weights(py, weights, rho, &["uniform", "chord", "mean_value"], "")?;
    let params = ThetaPhiParams { poles, weights, max_refinements };
    let tp = py.detach(|| theta_phi(&mesh.mesh, &params)).map_err(|e| sphere_error(py, e))?;
    let (points, info) = embedding_to_py(py, &tp.embedding)?;
    let ids = |v: &[u32]| v.iter().map(|&x| i64::from(x)).collect::<Vec<_>>();
    info.set_item("poles", (tp.poles.north, tp.poles.south))?;
    info.set_item("cut_path", ids(&tp.cut_path).into_pyarray(py))?;
    info.set_item("theta_phi", to_numpy(py, &tp.theta_phi))?;
    info.set_item("cut_vertices", to_numpy(py, tp.cut.mesh.positions()))?;
    info.set_item("cut_faces", to_numpy(py, &to_i64_rows(tp.cut.mesh.faces())))?;
    info.set_item("cut_boundary", ids(&tp.cut.boundary).into_pyarray(py))?;
    info.set_item("cut_original", ids(&tp.cut.original).into_pyarray(py))?;
    info.set_item("tp_valid", tp.tp_valid)?;
    info.set_item("tp_flipped_faces", ids(&tp.inverted.flipped).into_pyarray(py))?;
    info.set_item("tp_degenerate_faces", ids(&tp.inverted.degenerate).into_pyarray(py))?;
    info.set_item("refinements", tp.refinements)?;
    info.set_item("re_embedded", tp.re_embedded.to_vec())?;
    info.set_item("fans_monotone", tp.fans_monotone.to_vec())?;
    info.set_item("min_area_ratio", tp.min_area_ratio)?;
    Ok((points, info))
}
