//! Core errors -> the Python exceptions of DESIGN.md: the one module that
//! maps errors. The exception classes are defined in `spherify/_errors.py`
//! (they inherit from both `SpherifyError` and the matching builtin,
//! `ValueError`, `RuntimeError`, `OSError` or `MemoryError`, which a class
//! made in Rust cannot) and declared here once with PyO3's `import_exception!`.

use pyo3::prelude::*;
use pyo3::types::PyDict;
use spherify_mesh::{Location, MeshError, UnknownName};
use spherify_sparse::tutte::TutteError;
use spherify_sparse::SparseError;
use spherify_sphere::applications::harmonics::HarmonicsError;
use spherify_sphere::applications::metrics::QualityError;
use spherify_sphere::memory_budget::ResourceError;
use spherify_sphere::point_map::PointMapError;
use spherify_sphere::{SphereEmbedding, SphereError};

use crate::convert::to_numpy;

/// The classes of `spherify._errors`, imported once (on first use).
pub mod class {
    pyo3::import_exception!(spherify._errors, SpherifyError);
    pyo3::import_exception!(spherify._errors, MeshError);
    pyo3::import_exception!(spherify._errors, TopologyError);
    pyo3::import_exception!(spherify._errors, FormatError);
    pyo3::import_exception!(spherify._errors, ConvergenceError);
    pyo3::import_exception!(spherify._errors, MapError);
    pyo3::import_exception!(spherify._errors, FileError);
    pyo3::import_exception!(spherify._errors, ResourceError);
}

/// A bad argument or bad data: `MeshError(message)`.
pub fn mesh_error(message: impl Into<String>) -> PyErr {
    class::MeshError::new_err(message.into())
}

/// A failure that is neither the mesh's nor an argument's (no worker
/// thread could be started, a call from inside a progress callable).
pub fn spherify_error(message: impl Into<String>) -> PyErr {
    class::SpherifyError::new_err(message.into())
}

/// A call that does not fit in memory (`spherify_sphere::memory_budget`):
/// `ResourceError(message, bytes, available)`, also a `MemoryError`.
pub fn resource_error(err: ResourceError) -> PyErr {
    class::ResourceError::new_err((err.to_string(), err.bytes(), err.available()))
}

/// A name the core does not know (a weight, an encoding, a method).
pub fn unknown_name(err: UnknownName) -> PyErr {
    mesh_error(err.to_string())
}

/// The errno of an `io::ErrorKind` the operating system gave without one.
fn errno_of_kind(kind: std::io::ErrorKind) -> Option<i32> {
    use std::io::ErrorKind;
    Some(match kind {
        ErrorKind::NotFound => libc::ENOENT,
        ErrorKind::PermissionDenied => libc::EACCES,
        ErrorKind::AlreadyExists => libc::EEXIST,
        ErrorKind::IsADirectory => libc::EISDIR,
        ErrorKind::NotADirectory => libc::ENOTDIR,
        _ => return None,
    })
}

/// `FileError(errno, strerror, filename)`, which `FileError` turns into
/// the subclass that is also the builtin of that errno (`FileNotFoundError`,
/// ...), as `OSError` does; without an errno, `FileError("path: message")`.
fn file_error(path: &str, source: &std::io::Error) -> PyErr {
    match source.raw_os_error().or_else(|| errno_of_kind(source.kind())) {
        Some(code) => {
            // std writes an OS error as "<strerror> (os error N)"; Python's
            // own OSError says only the strerror.
            let text = std::io::Error::from_raw_os_error(code).to_string();
            let suffix = format!(" (os error {code})");
            let strerror = text.strip_suffix(&suffix).unwrap_or(&text).to_string();
            class::FileError::new_err((code, strerror, path.to_string()))
        }
        None => class::FileError::new_err(format!("{path}: {source}")),
    }
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
            class::FormatError::new_err((f.to_string(), f.path.clone(), line, offset))
        }
        // `FileError`: a SpherifyError and the builtin OSError subclass of the cause.
        MeshError::Io { path, source } => file_error(&path, &source),
        MeshError::Topology(t) => {
            let report = match crate::validate::report_to_py(py, &t.report) {
                Ok(report) => report.unbind(),
                Err(e) => return e,
            };
            class::TopologyError::new_err((t.to_string(), report))
        }
        other => mesh_error(other.to_string()),
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
        Ok(()) => class::ConvergenceError::new_err((message, state.unbind())),
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
        SphereError::Resource(r) => resource_error(r),
        SphereError::InvalidStart { .. } | SphereError::LandmarkConflict { .. } => {
            class::MapError::new_err(err.to_string())
        }
        SphereError::Insertion { .. } => convergence_error(
            py,
            err.to_string(),
            py.None().into_bound(py),
            0,
            None,
            "insertion_failed",
        ),
        other => mesh_error(other.to_string()),
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
                Err(e) => return mesh_error(e.to_string()),
            };
            let message = err.to_string();
            convergence_error(py, message, points, iterations, Some(residual), "max_iterations")
        }
        SparseError::OutOfMemory { what, bytes } => {
            resource_error(ResourceError::Allocation { what, bytes })
        }
        other => mesh_error(other.to_string()),
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
        other => mesh_error(other.to_string()),
    }
}

/// `h^-1` of a map that is not a certified bijection is a `MapError`; bad
/// query rows are `MeshError`s.
pub fn point_map_error(err: PointMapError) -> PyErr {
    match err {
        PointMapError::NotBijective(_) => class::MapError::new_err(err.to_string()),
        PointMapError::Resource(e) => resource_error(e),
        other => mesh_error(other.to_string()),
    }
}

/// A spherical-harmonic transform's error: a map that is not a bijection is
/// a `MapError`, a bad degree or size a `MeshError`.
pub fn harmonics_error(err: HarmonicsError) -> PyErr {
    match err {
        HarmonicsError::Map(e) => point_map_error(e),
        HarmonicsError::Resource(e) => resource_error(e),
        other => mesh_error(other.to_string()),
    }
}

/// A distortion measure's error (points that do not fit the mesh).
pub fn quality_error(err: QualityError) -> PyErr {
    mesh_error(err.to_string())
}
