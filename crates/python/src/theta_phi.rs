//! `embed_theta_phi`: the theta-phi method (thesis ch. 6).

use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use spherify_sphere::symmetry::{Symmetry, SymmetryParams};
use spherify_sphere::theta_phi::{theta_phi_with_progress, PoleChoice, ThetaPhiParams};

use crate::convert::{to_i64_rows, to_numpy};
use crate::embed::{embedding_to_py, sphere_error};
use crate::errors::mesh_error;
use crate::mesh::CoreMesh;

const POLES: &str =
    "poles must be 'fast_graph', 'graph', 'physical', 'symmetry' or a (north, south) pair of vertex ids";

fn pole_choice(
    py: Python<'_>,
    poles: &Bound<'_, PyAny>,
    symmetry: SymmetryParams,
) -> PyResult<PoleChoice> {
    if let Ok(name) = poles.extract::<String>() {
        return match name.as_str() {
            "fast_graph" => Ok(PoleChoice::FastGraph),
            "graph" => Ok(PoleChoice::Graph),
            "physical" => Ok(PoleChoice::Physical),
            "symmetry" => Ok(PoleChoice::Symmetry(symmetry)),
            other => Err(mesh_error(py, format!("{POLES}, got {other:?}"))),
        };
    }
    match poles.extract::<(i64, i64)>() {
        Ok((n, s)) if n >= 0 && s >= 0 && n <= u32::MAX as i64 && s <= u32::MAX as i64 => {
            Ok(PoleChoice::Explicit(n as u32, s as u32))
        }
        _ => Err(mesh_error(py, POLES)),
    }
}

/// `info["symmetry"]`: the planes, the chosen one, the band and the fallback.
fn symmetry_to_py<'py>(py: Python<'py>, sym: &Symmetry) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("centre", sym.centre.to_vec())?;
    let planes: Vec<[f64; 3]> = sym.planes.iter().map(|p| p.normal).collect();
    d.set_item("normals", to_numpy(py, &planes))?;
    let column = |f: fn(&spherify_sphere::symmetry::Plane) -> f64| -> Vec<f64> {
        sym.planes.iter().map(f).collect()
    };
    d.set_item("variances", column(|p| p.variance))?;
    d.set_item("signed_sums", column(|p| p.signed_sum))?;
    d.set_item("balances", column(|p| p.balance))?;
    d.set_item("skews", column(|p| p.skew))?;
    d.set_item("scores", column(|p| p.score))?;
    d.set_item("chosen", sym.chosen)?;
    let chosen = sym.chosen.and_then(|k| sym.planes.get(k));
    d.set_item("normal", chosen.map(|p| p.normal.to_vec()))?;
    d.set_item("score", chosen.map(|p| p.score))?;
    d.set_item("eps", sym.eps)?;
    d.set_item("band", sym.band)?;
    d.set_item("component", sym.component)?;
    d.set_item("symmetry_poles", sym.poles.map(|p| (p.north, p.south)))?;
    d.set_item("spread", sym.spread)?;
    d.set_item("fallback", sym.fallback.map(|f| f.to_string()))?;
    Ok(d)
}

// The signature spells the default out so that Python shows it; keep it in
// step with the core's.
const _: () = assert!(spherify_sphere::symmetry::DEFAULT_MAX_SCORE == 0.05);

/// embed_theta_phi(mesh, poles="fast_graph", weights="uniform", rho=1.0,
/// max_refinements=8, symmetry_eps=None, symmetry_max_score=0.05, progress=None)
/// -> (points, info).
#[pyfunction]
#[pyo3(signature = (mesh, poles=None, weights="uniform", rho=1.0, max_refinements=8,
                    symmetry_eps=None, symmetry_max_score=0.05, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn embed_theta_phi<'py>(
    py: Python<'py>,
    mesh: &CoreMesh,
    poles: Option<&Bound<'py, PyAny>>,
    weights: &str,
    rho: f64,
    max_refinements: usize,
    symmetry_eps: Option<f64>,
    symmetry_max_score: f64,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let symmetry = SymmetryParams {
        eps: symmetry_eps,
        max_score: symmetry_max_score,
        ..SymmetryParams::default()
    };
    let poles = match poles {
        Some(p) => pole_choice(py, p, symmetry)?,
        None => PoleChoice::FastGraph,
    };
    let weights =
        crate::convert::weights(py, weights, rho, &["uniform", "chord", "mean_value"], "")?;
    let params = ThetaPhiParams { poles, weights, max_refinements };
    let core = &mesh.mesh;
    let tp = crate::progress::run(py, progress, |report| {
        theta_phi_with_progress(core, &params, report)
    })?
    .map_err(|e| sphere_error(py, e))?;
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
    if let Some(sym) = &tp.symmetry {
        info.set_item("symmetry", symmetry_to_py(py, sym)?)?;
    }
    Ok((points, info))
}
