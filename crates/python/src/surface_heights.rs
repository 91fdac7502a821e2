//! `CoreSampledSurface` and `CoreFeatureNearest`: the core's descriptor pairs
//! (`spherify_mesh::surface_heights`, `spherify_mesh::feature_nearest`) for
//! `spherify._descriptors`.

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use spherify_mesh::feature_nearest::FeatureNearest;
use spherify_mesh::surface_heights::{surface_heights, SampledSurface};

use crate::convert::{finite_rows, rows, surface_rows, to_numpy};
use crate::errors::mesh_error;

fn positive(x: f64, what: &str) -> PyResult<f64> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(mesh_error(format!("{what} must be positive and finite, got {x}")))
    }
}

/// A flat (n, k) float64 array: its rows' length and values.
fn table(array: &PyReadonlyArrayDyn<'_, f64>, what: &str) -> PyResult<(usize, usize, Vec<f64>)> {
    let view = array.as_array();
    if view.ndim() != 2 {
        return Err(mesh_error(format!("{what} must have shape (n, k), got {:?}", view.shape())));
    }
    let (n, k) = (view.shape()[0], view.shape()[1]);
    Ok((n, k, view.iter().copied().collect()))
}

/// A triangle surface ready for samples and heights at several scales.
#[pyclass(frozen, module = "spherify._core")]
pub struct CoreSampledSurface {
    surface: SampledSurface,
}

#[pymethods]
impl CoreSampledSurface {
    /// CoreSampledSurface(vertices (n, 3) float64, faces (m, 3) int64).
    #[new]
    fn new(
        py: Python<'_>,
        vertices: PyReadonlyArrayDyn<'_, f64>,
        faces: PyReadonlyArrayDyn<'_, i64>,
    ) -> PyResult<Self> {
        let (positions, out) = surface_rows(&vertices, &faces)?;
        let surface = crate::pool::detach(py, || SampledSurface::new(&positions, &out))?;
        Ok(CoreSampledSurface { surface })
    }

    /// samples(spacing) -> (points (k, 3), areas (k,), unit outward normals
    /// (k, 3), faces (k,) int64): the surface about `spacing` apart, and a
    /// face near each point (a closest-point search's hint).
    #[allow(clippy::type_complexity)]
    fn samples<'py>(
        &self,
        py: Python<'py>,
        spacing: f64,
    ) -> PyResult<(
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray1<i64>>,
    )> {
        let spacing = positive(spacing, "spacing")?;
        let s = crate::pool::detach(py, || self.surface.samples(spacing))?;
        let faces: Vec<i64> = s.faces.iter().map(|&f| i64::from(f)).collect();
        Ok((
            to_numpy(py, &s.points),
            s.area.into_pyarray(py),
            to_numpy(py, &s.normals),
            faces.into_pyarray(py),
        ))
    }

    /// heights(queries (q, 3), normals (q, 3), scales (s,), source_spacing)
    /// -> (q, s) float64: the height of the surface over its neighbourhood at
    /// each scale r, the surface sampled `source_spacing` r apart.
    fn heights<'py>(
        &self,
        py: Python<'py>,
        queries: PyReadonlyArrayDyn<'_, f64>,
        normals: PyReadonlyArrayDyn<'_, f64>,
        scales: Vec<f64>,
        source_spacing: f64,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let queries = rows::<f64, 3>(&queries, "queries")?;
        let normals = rows::<f64, 3>(&normals, "normals")?;
        if normals.len() != queries.len() {
            return Err(mesh_error("one normal per query"));
        }
        for &r in &scales {
            positive(r, "scale")?;
        }
        let source_spacing = positive(source_spacing, "source_spacing")?;
        let h = crate::pool::detach(py, || {
            surface_heights(&self.surface, &queries, &normals, &scales, source_spacing)
        })?;
        let flat: Vec<f64> = h.into_iter().flatten().collect();
        Ok(Array2::from_shape_vec((queries.len(), scales.len()), flat)
            .expect("a row of heights per query")
            .into_pyarray(py))
    }
}

/// Candidates with features: the nearest in position and feature.
#[pyclass(frozen, module = "spherify._core")]
pub struct CoreFeatureNearest {
    near: FeatureNearest,
}

#[pymethods]
impl CoreFeatureNearest {
    /// CoreFeatureNearest(points (n, 3) float64, features (n, k) float64, reach).
    #[new]
    fn new(
        py: Python<'_>,
        points: PyReadonlyArrayDyn<'_, f64>,
        features: PyReadonlyArrayDyn<'_, f64>,
        reach: f64,
    ) -> PyResult<Self> {
        let points = rows::<f64, 3>(&points, "points")?;
        finite_rows(&points, "point")?;
        let (n, k, features) = table(&features, "features")?;
        if n != points.len() {
            return Err(mesh_error("one row of features per point"));
        }
        let reach = positive(reach, "reach")?;
        let near = crate::pool::detach(py, || FeatureNearest::new(points, features, k, reach))?;
        Ok(CoreFeatureNearest { near })
    }

    /// nearest(x (m, 3), features (m, k)) -> (best (m,) int64, plain (m,)
    /// int64, certain (m,) bool): per row the candidate nearest in position
    /// and feature, the one nearest in position alone (-1: none within
    /// reach), and whether both are certain.
    #[allow(clippy::type_complexity)]
    fn nearest<'py>(
        &self,
        py: Python<'py>,
        x: PyReadonlyArrayDyn<'_, f64>,
        features: PyReadonlyArrayDyn<'_, f64>,
    ) -> PyResult<(Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<bool>>)>
    {
        let x = rows::<f64, 3>(&x, "x")?;
        let (m, k, features) = table(&features, "features")?;
        if m != x.len() || k != self.near.width() {
            return Err(mesh_error(format!(
                "features must have shape ({}, {}), got ({m}, {k})",
                x.len(),
                self.near.width()
            )));
        }
        let found = crate::pool::detach(py, || self.near.nearest(&x, &features))?;
        let id = |v: Option<u32>| v.map_or(-1, i64::from);
        let best: Vec<i64> = found.iter().map(|f| id(f.best)).collect();
        let plain: Vec<i64> = found.iter().map(|f| id(f.plain)).collect();
        let certain: Vec<bool> = found.iter().map(|f| f.certain).collect();
        Ok((best.into_pyarray(py), plain.into_pyarray(py), certain.into_pyarray(py)))
    }
}
