//! Shared conversions for the spherical methods: a core `SphereEmbedding` becomes
//! `(points, info)` for `spherify.SphereMap`, and a `SphereError` its exception.
//! Each method's `#[pyfunction]` lives in the file named after it.

use pyo3::prelude::*;
use pyo3::types::PyDict;
use spherify_sphere::{SphereEmbedding, SphereError};

use crate::convert::to_numpy;
use crate::errors::{mesh_error, spherify_error, to_py};

/// `(points (n, 3), info dict)` with iterations, status, message and seconds.
pub fn embedding_to_py<'py>(
    py: Python<'py>,
    e: &SphereEmbedding,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let info = PyDict::new(py);
    info.set_item("iterations", e.iterations)?;
    info.set_item("status", e.status.name())?;
    info.set_item("converged", e.converged())?;
    info.set_item("message", &e.message)?;
    let seconds = PyDict::new(py);
    for (stage, s) in &e.seconds {
        seconds.set_item(*stage, *s)?;
    }
    info.set_item("seconds", seconds)?;
    Ok((to_numpy(py, &e.points).into_any(), info))
}

/// Maps a spherical-method error to its Python exception.
pub fn sphere_error(py: Python<'_>, err: SphereError) -> PyErr {
    match err {
        SphereError::Topology(t) => to_py(py, t.into()),
        SphereError::NoConvergence { ref last } => {
            let message = err.to_string();
            match embedding_to_py(py, last) {
                Ok((points, info)) => match info.set_item("points", points) {
                    Ok(()) => spherify_error(py, "ConvergenceError", (message, info)),
                    Err(e) => e,
                },
                Err(e) => e,
            }
        }
        SphereError::Solve(s) => crate::tutte::sparse_error(py, s),
        other => mesh_error(py, other.to_string()),
    }
}
