//! `CoreClosestPoints`: the core's closest-point tree
//! (`spherify_mesh::closest_point`) held for `spherify._nearest`.

use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use spherify_mesh::closest_point::ClosestPoints;

use crate::convert::{rows, surface_rows, to_numpy};
use crate::errors::mesh_error;

/// Closest points of one triangle mesh's surface (any vertex positions: the
/// registration's normalised shapes are not a `CoreMesh`).
#[pyclass(frozen, module = "spherify._core")]
pub struct CoreClosestPoints {
    tree: ClosestPoints,
}

#[pymethods]
impl CoreClosestPoints {
    /// CoreClosestPoints(vertices (n, 3) float64, faces (m, 3) int64).
    #[new]
    fn new(
        py: Python<'_>,
        vertices: PyReadonlyArrayDyn<'_, f64>,
        faces: PyReadonlyArrayDyn<'_, i64>,
    ) -> PyResult<Self> {
        let (positions, out) = surface_rows(&vertices, &faces)?;
        // Without the GIL, so that registration builds its two trees side by
        // side (spherify._rigid_icp); tens of milliseconds for 100k faces.
        let tree = crate::pool::detach(py, || ClosestPoints::new(positions, out))?;
        Ok(CoreClosestPoints { tree })
    }

    /// closest(points (k, 3) float64, hints (k,) int64 or None) -> (face ids
    /// (k,) int64, bary (k, 3), points (k, 3)): the exact closest point of the
    /// surface to each row; face -1 and NaN for a row that is not finite.
    /// `hints`: a face per row from an earlier call on nearby points (-1 or
    /// out of range: none), which only speeds the search (the same answers).
    #[allow(clippy::type_complexity)]
    #[pyo3(signature = (points, hints=None))]
    fn closest<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArrayDyn<'_, f64>,
        hints: Option<PyReadonlyArrayDyn<'_, i64>>,
    ) -> PyResult<(Bound<'py, PyArray1<i64>>, Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>)>
    {
        let points = rows::<f64, 3>(&points, "points")?;
        let hints: Option<Vec<u32>> = match hints {
            None => None,
            Some(h) => {
                let h = h.as_array();
                if h.ndim() != 1 || h.len() != points.len() {
                    return Err(mesh_error(format!(
                        "hints must be one face id per point ({}), got shape {:?}",
                        points.len(),
                        h.shape()
                    )));
                }
                Some(h.iter().map(|&f| u32::try_from(f).unwrap_or(u32::MAX)).collect())
            }
        };
        let tree = &self.tree;
        // Through progress::run so that Ctrl-C stops a long search.
        let hits = crate::progress::run(py, None, |go_on| {
            tree.closest_many_from(&points, hints.as_deref(), go_on)
        })?
        .ok_or_else(|| mesh_error("the closest-point search was stopped"))?;
        let faces: Vec<i64> =
            hits.iter().map(|h| if h.face == u32::MAX { -1 } else { i64::from(h.face) }).collect();
        let bary: Vec<[f64; 3]> = hits.iter().map(|h| h.bary).collect();
        let xyz: Vec<[f64; 3]> = hits.iter().map(|h| h.point).collect();
        Ok((faces.into_pyarray(py), to_numpy(py, &bary), to_numpy(py, &xyz)))
    }

    /// The number of triangles.
    fn __len__(&self) -> usize {
        self.tree.len()
    }
}
