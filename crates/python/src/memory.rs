//! `embed_need` and `check_memory`: the core's memory policy
//! (`spherify_sphere::memory_budget`) for Python callers that check before
//! they build a mesh (the command line's generated shapes) or that allocate
//! in numpy with an estimate of their own (`spherify.datasets`). The
//! estimates of the core's calls and the check itself stay in the core.

use std::str::FromStr;

use pyo3::prelude::*;
use pyo3::types::PyDict;
use spherify_sphere::memory_budget::{self, Need};
use spherify_sphere::MethodName;

use crate::errors::{mesh_error, resource_error};
use crate::options::Options;

/// embed_need(method, options: dict | None, n_vertices, n_faces, landmarks=False) -> int.
///
/// The bytes `embed(mesh, method, options)` is estimated to take at its peak
/// for a mesh of this size, margin included (what `embed` checks first).
#[pyfunction]
#[pyo3(signature = (method, options, n_vertices, n_faces, landmarks=false))]
pub fn embed_need(
    py: Python<'_>,
    method: &str,
    options: Option<&Bound<'_, PyDict>>,
    n_vertices: usize,
    n_faces: usize,
    landmarks: bool,
) -> PyResult<u64> {
    let name = MethodName::from_str(method).map_err(|e| mesh_error(e.to_string()))?;
    let options = Options::new(py, name, options)?;
    let method = crate::embed::method(name, &options)?;
    options.finish()?;
    Ok(memory_budget::embed_need(&method, n_vertices, n_faces, landmarks).bytes)
}

/// check_memory(call: str, n_vertices: int, bytes: int) -> None.
///
/// ResourceError naming `call`, `n_vertices` and the bytes when `bytes`
/// more do not fit in what the process can still get (its address-space
/// limit less what it holds, and the machine's available memory).
#[pyfunction]
pub fn check_memory(call: &str, n_vertices: usize, bytes: u64) -> PyResult<()> {
    memory_budget::check(&Need { call: call.to_string(), n_vertices, bytes })
        .map_err(resource_error)
}
