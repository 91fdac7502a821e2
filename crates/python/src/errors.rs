//! Core errors -> the Python exceptions of DESIGN.md, which are defined in
//! `spherify/_errors.py` so that they can inherit from both `SpherifyError` and
//! the matching builtin (`ValueError`, `RuntimeError`).

use pyo3::call::PyCallArgs;
use pyo3::exceptions::{
    PyFileExistsError, PyFileNotFoundError, PyIsADirectoryError, PyNotADirectoryError, PyOSError,
    PyPermissionError,
};
use pyo3::prelude::*;
use spherify_mesh::{Location, MeshError};

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
        MeshError::Io { path, source } => {
            let message = format!("{path}: {source}");
            match source.kind() {
                std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(message),
                std::io::ErrorKind::PermissionDenied => PyPermissionError::new_err(message),
                std::io::ErrorKind::AlreadyExists => PyFileExistsError::new_err(message),
                std::io::ErrorKind::IsADirectory => PyIsADirectoryError::new_err(message),
                std::io::ErrorKind::NotADirectory => PyNotADirectoryError::new_err(message),
                _ => PyOSError::new_err(message),
            }
        }
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
