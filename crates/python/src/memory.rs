//! `embed_need`, `check_memory` and `check_application`: the core's memory policy
//! (`spherify_sphere::memory_budget`) for Python callers that check before
//! they build a mesh (the command line's generated shapes) or that allocate
//! in numpy with an estimate of their own (`spherify.datasets`). The
//! estimates of the core's calls and the check itself stay in the core.

use std::str::FromStr;

use pyo3::prelude::*;
use pyo3::types::PyDict;
use spherify_sphere::memory_budget::{self, Application, Need};
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

/// check_application(name, n_vertices, n_faces, items) -> None.
///
/// The core's memory check of an application whose work is numpy's
/// (`geometry_image`, `UVLayout.bake`, `texture.uv`, `remesh`, `morph`,
/// `register`, `correspond`), by the core's table of rates: ResourceError
/// naming the call, its items, the vertex count and the bytes when it cannot
/// fit; MeshError for a name the table does not hold.
#[pyfunction]
pub fn check_application(
    name: &str,
    n_vertices: usize,
    n_faces: usize,
    items: usize,
) -> PyResult<()> {
    let app = Application::from_name(name)
        .ok_or_else(|| mesh_error(format!("no memory rate for the call {name:?}")))?;
    check_app(app, n_vertices, n_faces, items)
}

/// The memory policy's check of `app` on a mesh of this size with `items`
/// of its items, before it starts: a `ResourceError` when it cannot fit.
pub fn check_app(
    app: Application,
    n_vertices: usize,
    n_faces: usize,
    items: usize,
) -> PyResult<()> {
    memory_budget::check(&memory_budget::application_need(app, n_vertices, n_faces, items))
        .map_err(resource_error)
}
