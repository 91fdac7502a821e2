//! Core errors -> the Python exceptions of DESIGN.md, which are defined in
//! `spherify/_errors.py` so that they can inherit from both `SpherifyError` and
//! the matching builtin (`ValueError`, `RuntimeError`, `OSError`).

use pyo3::call::PyCallArgs;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use spherify_mesh::{Location, MeshError};
use spherify_sparse::tutte::TutteError;
use spherify_sparse::SparseError;
use spherify_sphere::point_map::PointMapError;
use spherify_sphere::{SphereEmbedding, SphereError};

use crate::convert::to_numpy;

/// Instantiates `spherify._errors.<name>(*args)` as a `PyErr`.
pub fn spherify_error<'py>(py: Python<'py>, name: &str, args: impl PyCallArgs<'py>) -> PyErr {
    let made = py
        .import("spherify._errors")
        .and_then(|module| module.getattr(name))
        .and_then(|class| class.call1(args));
    match made {
        Ok(instance) => PyErr::from_value(instance),
        Err(err) => err,
    }
}

pub fn mesh_error(py: Python<'_>, message: impl Into<String>) -> PyErr {
    spherify_error(py, "MeshError", (message.into(),))
}

/// Maps every core mesh error to its Python exception.
pub fn to_py(py: Python<'_>, err: MeshError) -> PyErr {
    match err {
        MeshError::Format(f) => {
            let (line, offset) = match f.location {
                Location::Line(n) => (Some(n), None),
                Location::Byte(b) => (None, Some(b)),
                Location::File => (None, None),
            };
            spherify_error(py, "FormatError", (f.to_string(), f.path.clone(), line, offset))
        }
        // `FileError`: a SpherifyError and the builtin OSError subclass of the cause.
        MeshError::Io { path, source } => spherify_error(
            py,
            "file_error",
            (source.raw_os_error(), format!("{:?}", source.kind()), source.to_string(), path),
        ),
        MeshError::Topology(t) => {
            let report = match crate::validate::report_to_py(py, &t.report) {
                Ok(report) => report,
                Err(e) => return e,
            };
            spherify_error(py, "TopologyError", (t.to_string(), report))
        }
        other => mesh_error(py, other.to_string()),
    }
}

/// The one schema of `ConvergenceError.state`: where the iteration stopped
/// (`points`: sphere points, a Tutte drawing's uv, or a solver's iterate),
/// after how many `iterations`, its `residual` where it has one (else None),
/// `status` and `message`.
fn convergence_error(
    py: Python<'_>,
    message: String,
    points: Bound<'_, PyAny>,
    iterations: usize,
    residual: Option<f64>,
    status: &str,
) -> PyErr {
    let state = PyDict::new(py);
    let filled = (|| -> PyResult<()> {
        state.set_item("points", points)?;
        state.set_item("iterations", iterations)?;
        state.set_item("residual", residual)?;
        state.set_item("status", status)?;
        state.set_item("message", &message)?;
        Ok(())
    })();
    match filled {
        Ok(()) => spherify_error(py, "ConvergenceError", (message, state)),
        Err(e) => e,
    }
}

/// A spherical method's error.
pub fn sphere_error(py: Python<'_>, err: SphereError) -> PyErr {
    match err {
        SphereError::Topology(t) => to_py(py, t.into()),
        SphereError::NoConvergence { ref last } => {
            let SphereEmbedding { points, iterations, status, .. } = last.as_ref();
            let points = to_numpy(py, points).into_any();
            convergence_error(py, err.to_string(), points, *iterations, None, status.name())
        }
        SphereError::Solve(s) => sparse_error(py, s),
        SphereError::InvalidStart { .. } => spherify_error(py, "MapError", (err.to_string(),)),
        SphereError::Insertion { .. } => convergence_error(
            py,
            err.to_string(),
            py.None().into_bound(py),
            0,
            None,
            "insertion_failed",
        ),
        other => mesh_error(py, other.to_string()),
    }
}

/// A solver failure: running out of iterations is a `ConvergenceError`
/// (with the last iterate), anything else a `MeshError`.
pub fn sparse_error(py: Python<'_>, err: SparseError) -> PyErr {
    match err {
        SparseError::NoConvergence { iterations, residual, ref last } => {
            // One column per right-hand side: (n, k) like the solution.
            let n = last.first().map_or(0, Vec::len);
            let rows: Vec<Vec<f64>> = (0..n).map(|i| last.iter().map(|c| c[i]).collect()).collect();
            let points = match numpy::PyArray2::from_vec2(py, &rows) {
                Ok(a) => a.into_any(),
                Err(e) => return mesh_error(py, e.to_string()),
            };
            let message = err.to_string();
            convergence_error(py, message, points, iterations, Some(residual), "max_iterations")
        }
        other => mesh_error(py, other.to_string()),
    }
}

/// A 2D Tutte embedding's error.
pub fn tutte_error(py: Python<'_>, err: TutteError) -> PyErr {
    match err {
        TutteError::Topology(t) => to_py(py, t.into()),
        TutteError::NoConvergence { iterations, residual, ref uv, .. } => {
            let points = to_numpy(py, uv).into_any();
            let message = err.to_string();
            convergence_error(py, message, points, iterations, Some(residual), "max_iterations")
        }
        TutteError::Solve(s) => sparse_error(py, s),
        other => mesh_error(py, other.to_string()),
    }
}

/// `h^-1` of a map that is not a certified bijection is a `MapError`; bad
/// query rows are `MeshError`s.
pub fn point_map_error(py: Python<'_>, err: PointMapError) -> PyErr {
    match err {
        PointMapError::NotBijective(_) => spherify_error(py, "MapError", (err.to_string(),)),
        other => mesh_error(py, other.to_string()),
    }
}
