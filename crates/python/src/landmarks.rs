//! Landmarks of `embed` and `improve` (arrays -> the core's `Landmarks`, the
//! energy they are pinned with), `move_towards`, the soft moves of
//! `spherify._landmarks`, and `pull_towards`, the warp's energy sweeps with a
//! data term (`spherify._warp`): all are `spherify_sphere::methods::progressive`'s.

use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;
use spherify_sphere::methods::progressive::distortion_energy::Energy;
use spherify_sphere::methods::progressive::landmarks::{Landmarks, PinParams};
use spherify_sphere::methods::progressive::move_towards::TowardsParams;
use spherify_sphere::methods::progressive::target_pull::PullParams;
use spherify_sphere::{
    move_towards_embedding, pull_towards_embedding, GenusZeroMesh, Method, SphereError,
};

use crate::convert::rows;
use crate::errors::{mesh_error, sphere_error};
use crate::sphere_map::{genus_zero, CoreSphereMap};

/// Landmark ids `(k,)` and points `(k, 3)` as given; checked by the core
/// (`Landmarks::new`) once the mesh is known.
pub type Given = (Vec<i64>, Vec<[f64; 3]>);

/// The `landmark_ids` / `landmark_points` pair of `embed` and `improve`:
/// both or neither.
pub fn given(
    ids: Option<PyReadonlyArrayDyn<'_, i64>>,
    points: Option<PyReadonlyArrayDyn<'_, f64>>,
) -> PyResult<Option<Given>> {
    match (ids, points) {
        (None, None) => Ok(None),
        (Some(ids), Some(points)) => {
            let view = ids.as_array();
            if view.ndim() != 1 {
                return Err(mesh_error(format!(
                    "landmark ids must have shape (k,), got {:?}",
                    view.shape()
                )));
            }
            Ok(Some((view.iter().copied().collect(), rows::<f64, 3>(&points, "landmark points")?)))
        }
        _ => Err(mesh_error("landmark ids and points are given together")),
    }
}

/// The core's landmarks for `mesh`.
pub fn landmarks(mesh: &GenusZeroMesh, given: &Given) -> Result<Landmarks, SphereError> {
    Landmarks::new(mesh.n_vertices(), &given.0, &given.1)
}

/// Landmarks are pinned with the map's own energy: the progressive method's,
/// or isometric for the methods that have none.
pub fn pin_params(method: &Method) -> PinParams {
    match method {
        Method::Progressive(p) => PinParams { energy: p.energy, ..PinParams::default() },
        _ => PinParams::default(),
    }
}

/// The same for `improve`'s energy, and its bound on a layout's vertices.
pub fn pin_params_for(energy: Energy, max_vertices: Option<usize>) -> PinParams {
    PinParams { energy, max_vertices, ..PinParams::default() }
}

/// move_towards(sphere_map, targets (n, 3) float64, weights (n,) float64,
/// fixed (f,) int64, energy_sweeps, progress) -> CoreSphereMap.
///
/// Every vertex with a weight moves along its great circle towards its
/// target (a fraction min(weight, 1) of the way) as far as its star stays
/// positive; the fixed ones never move; then `energy_sweeps` isometric
/// sweeps with the fixed ones held. Certified in the core, GIL released.
#[pyfunction]
#[pyo3(signature = (sphere_map, targets, weights, fixed, energy_sweeps=3, progress=None))]
pub fn move_towards(
    py: Python<'_>,
    sphere_map: &CoreSphereMap,
    targets: PyReadonlyArrayDyn<'_, f64>,
    weights: PyReadonlyArrayDyn<'_, f64>,
    fixed: PyReadonlyArrayDyn<'_, i64>,
    energy_sweeps: usize,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<CoreSphereMap> {
    let targets = rows::<f64, 3>(&targets, "targets")?;
    let (weights, fixed) = (weights.as_array(), fixed.as_array());
    if weights.ndim() != 1 || fixed.ndim() != 1 {
        return Err(mesh_error("weights and fixed must be one-dimensional"));
    }
    let weights: Vec<f64> = weights.iter().copied().collect();
    let fixed: Vec<i64> = fixed.iter().copied().collect();
    let params = TowardsParams { energy_sweeps, ..TowardsParams::default() };
    let shared = sphere_map.shared_mesh();
    let topology = sphere_map.topology();
    let start = sphere_map.embedding().clone();
    let result = crate::progress::run_detachable(py, progress, move |report| {
        let mesh = genus_zero(&topology, shared)?;
        let embedding =
            move_towards_embedding(&mesh, &start, &targets, &weights, &fixed, &params, report)?;
        Ok::<_, SphereError>(embedding)
    })?;
    let embedding = result.map_err(|e| sphere_error(py, e))?;
    Ok(sphere_map.with_embedding(embedding))
}

/// pull_towards(sphere_map, targets (n, 3) float64, weights (n,) float64,
/// fixed (f,) int64, rest (n, 3) float64 or None, energy, sweeps, tolerance,
/// progress) -> CoreSphereMap.
///
/// Sweeps of flip-free Newton moves lowering `energy` (a distortion of the
/// chord triangles against `rest`, or against the mesh when None) plus
/// sum_i weights[i] |x_i - targets[i]|^2, the fixed vertices held.
/// Certified in the core, GIL released.
#[pyfunction]
#[pyo3(signature = (sphere_map, targets, weights, fixed, rest=None, energy="isometric",
                    sweeps=10, tolerance=1e-4, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn pull_towards(
    py: Python<'_>,
    sphere_map: &CoreSphereMap,
    targets: PyReadonlyArrayDyn<'_, f64>,
    weights: PyReadonlyArrayDyn<'_, f64>,
    fixed: PyReadonlyArrayDyn<'_, i64>,
    rest: Option<PyReadonlyArrayDyn<'_, f64>>,
    energy: &str,
    sweeps: usize,
    tolerance: f64,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<CoreSphereMap> {
    let targets = rows::<f64, 3>(&targets, "targets")?;
    let rest = rest.map(|r| rows::<f64, 3>(&r, "rest")).transpose()?;
    let (weights, fixed) = (weights.as_array(), fixed.as_array());
    if weights.ndim() != 1 || fixed.ndim() != 1 {
        return Err(mesh_error("weights and fixed must be one-dimensional"));
    }
    let energy = Energy::from_name(energy).ok_or_else(|| {
        mesh_error(format!("energy = {energy:?}: expected one of {}", Energy::NAMES.join(", ")))
    })?;
    let weights: Vec<f64> = weights.iter().copied().collect();
    let fixed: Vec<i64> = fixed.iter().copied().collect();
    let params = PullParams { energy, sweeps, tolerance };
    let shared = sphere_map.shared_mesh();
    let topology = sphere_map.topology();
    let start = sphere_map.embedding().clone();
    let result = crate::progress::run_detachable(py, progress, move |report| {
        let mesh = genus_zero(&topology, shared)?;
        let embedding = pull_towards_embedding(
            &mesh,
            &start,
            rest.as_deref(),
            &targets,
            &weights,
            &fixed,
            &params,
            report,
        )?;
        Ok::<_, SphereError>(embedding)
    })?;
    let embedding = result.map_err(|e| sphere_error(py, e))?;
    Ok(sphere_map.with_embedding(embedding))
}
