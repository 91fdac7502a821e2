//! numpy <-> core arrays. Shape checks live here because they are about the
//! conversion; content checks (finite, in range) are the core's, but for the
//! bare surfaces of registration, which are no `CoreMesh` ([`surface_rows`]).

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use spherify_sparse::weights::Weights;

use crate::errors::mesh_error;

/// Copies an `(n, K)` array into rows, or raises `MeshError` naming `what`.
pub fn rows<T: numpy::Element + Copy + Default, const K: usize>(
    array: &PyReadonlyArrayDyn<'_, T>,
    what: &str,
) -> PyResult<Vec<[T; K]>> {
    let view = array.as_array();
    let shape = view.shape();
    if shape.len() != 2 || shape[1] != K {
        return Err(mesh_error(format!("{what} must have shape (n, {K}), got {shape:?}")));
    }
    // A C-contiguous array (what the Python side always passes) is copied
    // as one slice: walking it row by row through ndarray's iterators cost
    // more than the exact validity test that reads the result.
    if let Some(flat) = view.as_slice() {
        return Ok(flat
            .chunks_exact(K)
            .map(|c| {
                let mut row = [T::default(); K];
                row.copy_from_slice(c);
                row
            })
            .collect());
    }
    let mut out = vec![[T::default(); K]; shape[0]];
    for (row, src) in out.iter_mut().zip(view.outer_iter()) {
        for (dst, &x) in row.iter_mut().zip(src.iter()) {
            *dst = x;
        }
    }
    Ok(out)
}

/// `MeshError` naming the first row of `rows` that is not finite ("`what`
/// N is not finite").
pub fn finite_rows(rows: &[[f64; 3]], what: &str) -> PyResult<()> {
    match rows.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
        Some(bad) => Err(mesh_error(format!("{what} {bad} is not finite"))),
        None => Ok(()),
    }
}

/// A bare triangle surface: vertex positions and faces.
pub type SurfaceRows = (Vec<[f64; 3]>, Vec<[u32; 3]>);

/// The rows of `(n, 3)` vertices that must be finite and `(m, 3)` faces whose
/// ids must name them, as core arrays, or `MeshError` naming the first bad
/// vertex or face: a triangle surface that is not a `CoreMesh` (any vertex
/// positions, no validation of the topology), as registration's shapes are.
pub fn surface_rows(
    vertices: &PyReadonlyArrayDyn<'_, f64>,
    faces: &PyReadonlyArrayDyn<'_, i64>,
) -> PyResult<SurfaceRows> {
    let positions = rows::<f64, 3>(vertices, "vertices")?;
    let corners = rows::<i64, 3>(faces, "faces")?;
    finite_rows(&positions, "vertex")?;
    let n = positions.len() as i64;
    let mut out = Vec::with_capacity(corners.len());
    for (k, f) in corners.iter().enumerate() {
        if f.iter().any(|&v| v < 0 || v >= n) {
            return Err(mesh_error(format!("face {k} names a vertex out of range 0..{}", n - 1)));
        }
        out.push([f[0] as u32, f[1] as u32, f[2] as u32]);
    }
    Ok((positions, out))
}

/// Rows as a new `(n, K)` numpy array.
pub fn to_numpy<'py, T: numpy::Element + Copy, const K: usize>(
    py: Python<'py>,
    data: &[[T; K]],
) -> Bound<'py, PyArray2<T>> {
    let flat: Vec<T> = data.iter().flatten().copied().collect();
    Array2::from_shape_vec((data.len(), K), flat)
        .expect("row count times K equals the flat length")
        .into_pyarray(py)
}

/// Indices as int64 rows for Python (the core uses u32).
pub fn to_i64_rows<const K: usize>(data: &[[u32; K]]) -> Vec<[i64; K]> {
    data.iter().map(|r| r.map(i64::from)).collect()
}

/// The weights named `name` (with exponent `rho` for "chord"); which weights
/// a method accepts is decided in the core.
pub fn weights(name: &str, rho: f64) -> PyResult<Weights> {
    let weights = Weights::from_name(name, rho).map_err(|e| mesh_error(e.to_string()))?;
    if matches!(weights, Weights::Chord { .. }) && !rho.is_finite() {
        return Err(mesh_error(format!("rho must be finite, got {rho}")));
    }
    Ok(weights)
}
