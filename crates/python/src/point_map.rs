//! `CorePointMap`: h and h^-1 of a spherical map (thesis 3.3, 6.6) for
//! `SphereMap.to_sphere` / `SphereMap.to_surface`.

use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use spherify_sphere::point_map::{PointMap, PointMapError};

use crate::convert::{rows, to_numpy};
use crate::errors::{mesh_error, spherify_error};
use crate::mesh::CoreMesh;

fn point_map_error(py: Python<'_>, err: PointMapError) -> PyErr {
    match err {
        PointMapError::NotBijective(_) => spherify_error(py, "MapError", (err.to_string(),)),
        other => mesh_error(py, other.to_string()),
    }
}

fn u32_id(py: Python<'_>, id: i64, what: &str, n: usize) -> PyResult<u32> {
    if id < 0 || id as usize >= n {
        return Err(mesh_error(py, format!("{what} {id} is out of range (0..{n})")));
    }
    Ok(id as u32)
}

/// The point-location structure of one spherical map.
#[pyclass(frozen, module = "spherify._core")]
pub struct CorePointMap {
    map: PointMap,
}

/// point_map_theta_phi(mesh, cut_faces (m, 3) int64, theta_phi (n + k, 2), poles, tp_valid).
#[pyfunction]
pub fn point_map_theta_phi(
    py: Python<'_>,
    mesh: &CoreMesh,
    cut_faces: PyReadonlyArrayDyn<'_, i64>,
    theta_phi: PyReadonlyArrayDyn<'_, f64>,
    poles: (i64, i64),
    tp_valid: bool,
) -> PyResult<CorePointMap> {
    let cut_faces = rows::<i64, 3>(py, &cut_faces, "cut_faces")?;
    let theta_phi = rows::<f64, 2>(py, &theta_phi, "theta_phi")?;
    if cut_faces.len() != mesh.mesh.n_faces() {
        return Err(mesh_error(py, "cut_faces must have one row per face of the mesh"));
    }
    let n_cut = theta_phi.len();
    let mut faces = Vec::with_capacity(cut_faces.len());
    for row in &cut_faces {
        faces.push([
            u32_id(py, row[0], "cut vertex", n_cut)?,
            u32_id(py, row[1], "cut vertex", n_cut)?,
            u32_id(py, row[2], "cut vertex", n_cut)?,
        ]);
    }
    let n = mesh.mesh.n_vertices();
    let poles = [u32_id(py, poles.0, "pole", n)?, u32_id(py, poles.1, "pole", n)?];
    let map = py.detach(|| {
        PointMap::theta_phi(
            mesh.mesh.faces(),
            mesh.mesh.positions(),
            &faces,
            &theta_phi,
            poles,
            tp_valid,
        )
    });
    Ok(CorePointMap { map })
}

/// point_map_gc(mesh, points (n, 3), valid, flipped).
#[pyfunction]
pub fn point_map_gc(
    py: Python<'_>,
    mesh: &CoreMesh,
    points: PyReadonlyArrayDyn<'_, f64>,
    valid: bool,
    flipped: usize,
) -> PyResult<CorePointMap> {
    let points = rows::<f64, 3>(py, &points, "points")?;
    if points.len() != mesh.mesh.n_vertices() {
        return Err(mesh_error(py, "points must have one row per vertex of the mesh"));
    }
    let map = py
        .detach(|| PointMap::gc(mesh.mesh.faces(), mesh.mesh.positions(), &points, valid, flipped));
    Ok(CorePointMap { map })
}

#[pymethods]
impl CorePointMap {
    /// to_sphere(face_ids (k,) int64, bary (k, 3) float64) -> (k, 3) float64.
    fn to_sphere<'py>(
        &self,
        py: Python<'py>,
        face_ids: PyReadonlyArrayDyn<'_, i64>,
        bary: PyReadonlyArrayDyn<'_, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let ids = face_ids.as_array();
        if ids.ndim() != 1 {
            return Err(mesh_error(
                py,
                format!("face_ids must have shape (k,), got {:?}", ids.shape()),
            ));
        }
        let ids: Vec<i64> = ids.iter().copied().collect();
        let bary = rows::<f64, 3>(py, &bary, "bary")?;
        let points =
            py.detach(|| self.map.to_sphere(&ids, &bary)).map_err(|e| point_map_error(py, e))?;
        Ok(to_numpy(py, &points))
    }

    /// to_surface(points (k, 3) float64) -> (face_ids (k,) int64, bary (k, 3), xyz (k, 3)).
    #[allow(clippy::type_complexity)]
    fn to_surface<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArrayDyn<'_, f64>,
    ) -> PyResult<(Bound<'py, PyArray1<i64>>, Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>)>
    {
        let points = rows::<f64, 3>(py, &points, "points")?;
        let (faces, bary, xyz) =
            py.detach(|| self.map.to_surface(&points)).map_err(|e| point_map_error(py, e))?;
        let faces: Vec<i64> = faces.into_iter().map(i64::from).collect();
        Ok((faces.into_pyarray(py), to_numpy(py, &bary), to_numpy(py, &xyz)))
    }

    /// Why h^-1 is not defined for this map, or None.
    #[getter]
    fn not_bijective(&self) -> Option<String> {
        self.map.not_bijective().map(str::to_string)
    }
}
