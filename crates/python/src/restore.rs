//! `restore_map`: a `CoreSphereMap` rebuilt from stored parts (a
//! `.spheremap.npz`, a pickle) by `spherify_sphere::point_map::restore`, which computes
//! every certificate again. Nothing here decides validity.

use std::str::FromStr;
use std::sync::Arc;

use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;
use spherify_sphere::memory_budget;
use spherify_sphere::point_map::restore::{
    restore, status_from_name, RestoreError, StoredMap, StoredThetaPhi,
};
use spherify_sphere::{GenusZeroMesh, MethodName, SphereError};

use crate::convert::rows;
use crate::errors::{mesh_error, sphere_error};
use crate::mesh::CoreMesh;
use crate::sphere_map::{CoreSphereMap, Refinement};

/// The mesh is not genus 0, or the parts do not fit it.
enum Failed {
    Mesh(SphereError),
    Parts(RestoreError),
}

fn vertex_ids(array: &PyReadonlyArrayDyn<'_, i64>, what: &str) -> PyResult<Vec<u32>> {
    let view = array.as_array();
    if view.ndim() != 1 {
        return Err(mesh_error(format!("{what} must have shape (k,), got {:?}", view.shape())));
    }
    view.iter()
        .map(|&v| {
            u32::try_from(v).map_err(|_| mesh_error(format!("{what} holds {v}, not a vertex id")))
        })
        .collect()
}

/// restore_map(mesh, method, points, iterations, status, message, poles=None,
/// cut_path=None, theta_phi=None, refinements=0, re_embedded=(False, False),
/// refinement=None) -> CoreSphereMap. The theta-phi parts are given exactly
/// for a theta-phi map. `refinement`: (input mesh, faces (n,) int64,
/// barycentric (n, 3) float64) for a map laid out on a refined mesh, checked
/// against the mesh by `spherify._persist` before it comes here; only the
/// sizes are checked again. TopologyError when the mesh is not genus 0;
/// MeshError when the parts do not fit the mesh or each other.
#[pyfunction]
#[pyo3(signature = (mesh, method, points, iterations, status, message, poles=None, cut_path=None,
                    theta_phi=None, refinements=0, re_embedded=(false, false),
                    refinement=None))]
#[allow(clippy::too_many_arguments)]
pub fn restore_map(
    py: Python<'_>,
    mesh: &CoreMesh,
    method: &str,
    points: PyReadonlyArrayDyn<'_, f64>,
    iterations: usize,
    status: &str,
    message: String,
    poles: Option<(i64, i64)>,
    cut_path: Option<PyReadonlyArrayDyn<'_, i64>>,
    theta_phi: Option<PyReadonlyArrayDyn<'_, f64>>,
    refinements: usize,
    re_embedded: (bool, bool),
    refinement: Option<StoredRefinement<'_>>,
) -> PyResult<CoreSphereMap> {
    // "points" (a map given to from_points) is no method embed runs, so
    // from_str does not know it; it is stored all the same.
    let method = match method {
        "points" => MethodName::Points,
        "improve" => MethodName::Improve,
        name => MethodName::from_str(name).map_err(|e| mesh_error(e.to_string()))?,
    };
    let status =
        status_from_name(status).ok_or_else(|| mesh_error(format!("unknown status {status:?}")))?;
    let points = rows::<f64, 3>(&points, "points")?;
    let theta_phi = match (poles, cut_path, theta_phi) {
        (None, None, None) => None,
        (Some((north, south)), Some(path), Some(uv)) => {
            let pole = |v: i64| {
                u32::try_from(v).map_err(|_| mesh_error(format!("pole {v} is not a vertex id")))
            };
            Some(StoredThetaPhi {
                poles: [pole(north)?, pole(south)?],
                cut_path: vertex_ids(&path, "cut_path")?,
                theta_phi: rows::<f64, 2>(&uv, "theta_phi")?,
                refinements,
                re_embedded: [re_embedded.0, re_embedded.1],
            })
        }
        _ => return Err(mesh_error("poles, cut_path and theta_phi come together or not at all")),
    };
    let stored = StoredMap { method, points, iterations, status, message, theta_phi };
    let caller = Arc::clone(&mesh.mesh);
    let refinement = refinement
        .map(|(input, faces, barycentric)| refinement_of(mesh, input, &faces, &barycentric))
        .transpose()?;
    let shared = Arc::clone(&mesh.mesh);
    let restored = crate::pool::detach(py, || {
        let need =
            memory_budget::certify_need("restoring a map", shared.n_vertices(), shared.n_faces());
        memory_budget::check(&need).map_err(|e| Failed::Mesh(e.into()))?;
        let mesh = GenusZeroMesh::new(shared).map_err(|e| Failed::Mesh(e.into()))?;
        let embedding = restore(&mesh, stored).map_err(Failed::Parts)?;
        Ok((mesh, embedding))
    })?;
    let (mesh, embedding) = restored.map_err(|e| match e {
        Failed::Mesh(err) => sphere_error(py, err),
        Failed::Parts(err) => mesh_error(err.to_string()),
    })?;
    let map = CoreSphereMap::new(mesh.shared_mesh(), caller, embedding, mesh.reoriented_faces());
    Ok(match refinement {
        None => map,
        Some(refinement) => map.with_refinement(refinement),
    })
}

/// The stored map back to the input: (input mesh, faces, barycentric).
type StoredRefinement<'py> =
    (PyRef<'py, CoreMesh>, PyReadonlyArrayDyn<'py, i64>, PyReadonlyArrayDyn<'py, f64>);

/// A stored refinement whose sizes fit the refined mesh and the input: one
/// row per refined vertex, each naming a face of the input.
fn refinement_of(
    refined: &CoreMesh,
    input: PyRef<'_, CoreMesh>,
    faces: &PyReadonlyArrayDyn<'_, i64>,
    barycentric: &PyReadonlyArrayDyn<'_, f64>,
) -> PyResult<Refinement> {
    let faces = vertex_ids(faces, "refinement faces")?;
    let barycentric = rows::<f64, 3>(barycentric, "refinement barycentric")?;
    let n = refined.mesh.n_vertices();
    if faces.len() != n || barycentric.len() != n {
        return Err(mesh_error(format!(
            "the refinement has {} faces and {} weights for {n} vertices",
            faces.len(),
            barycentric.len()
        )));
    }
    let input_faces = input.mesh.n_faces();
    if let Some(&f) = faces.iter().find(|&&f| f as usize >= input_faces) {
        return Err(mesh_error(format!(
            "the refinement names face {f}; the input has {input_faces}"
        )));
    }
    Ok(Refinement { input: Arc::clone(&input.mesh), faces, barycentric })
}
