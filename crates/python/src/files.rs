//! The core's rules for files, for the writers and readers that live in
//! Python (`.npz`, FreeSurfer, GIfTI, PNG, the batch's outputs): the atomic
//! write (`spherify_mesh::io::PendingWrite`: temporary name, clean-up of dead
//! writers' temporaries, sync and rename) and the refusal of special files.
//! `spherify/_atomic.py` and `spherify/_files.py` only wrap these.

use std::ffi::OsString;
use std::path::PathBuf;

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use spherify_mesh::io::{self, PendingWrite};

use crate::errors::to_py;

/// AtomicWrite(path): a write of `path` through a file Python fills by name.
/// `temporary` is that file (beside the target, or a scratch file for a
/// device or a pipe); `commit()` puts it in place, `discard()` removes it.
#[pyclass(module = "spherify._core")]
pub struct AtomicWrite {
    /// `None` once committed or discarded.
    pending: Option<PendingWrite>,
    temporary: PathBuf,
}

#[pymethods]
impl AtomicWrite {
    #[new]
    fn new(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let pending = PendingWrite::begin(&path).map_err(|e| to_py(py, e))?;
        let temporary = pending.temporary().to_path_buf();
        Ok(AtomicWrite { pending: Some(pending), temporary })
    }

    #[getter]
    fn temporary(&self) -> PathBuf {
        self.temporary.clone()
    }

    /// Syncs the temporary and renames it over the target (links followed,
    /// mode kept), or copies it into the device or pipe. On an error the
    /// temporary is removed and the target left as it was.
    fn commit(&mut self, py: Python<'_>) -> PyResult<()> {
        let pending = self.pending.take().ok_or_else(|| {
            PyRuntimeError::new_err("this write was already committed or discarded")
        })?;
        py.detach(|| pending.commit()).map_err(|e| to_py(py, e))
    }

    /// Removes the temporary; the target is left as it was. Does nothing
    /// after `commit`.
    fn discard(&mut self) {
        self.pending = None;
    }
}

/// temporary_path(path) -> path of a temporary beside `path` (the name rule
/// of the atomic writer: `.name.tmp-PID-N`, name cut to 200 bytes).
#[pyfunction]
pub fn temporary_path(py: Python<'_>, path: PathBuf) -> PyResult<PathBuf> {
    io::temp_path(&path).map_err(|e| to_py(py, e))
}

/// is_temporary(name) -> whether a file name is one of a temporary. A name
/// need not be UTF-8 (Python hands such a name over with surrogate escapes):
/// the marks of a temporary (`.`, `.tmp-PID-N`) are ASCII, and a lossy
/// reading keeps them.
#[pyfunction]
pub fn is_temporary(name: OsString) -> bool {
    io::temporary_owner(&name.to_string_lossy()).is_some()
}

/// is_stale_temporary(name) -> whether a file name is that of a temporary
/// whose writer no longer runs (Linux, where /proc tells).
#[pyfunction]
pub fn is_stale_temporary(name: OsString) -> bool {
    io::is_stale_temporary(&name.to_string_lossy())
}

/// remove_stale_temporaries(folder): removes the temporaries of dead writers.
#[pyfunction]
pub fn remove_stale_temporaries(folder: PathBuf) {
    io::remove_stale_temporaries(&folder)
}

/// special_kind(path) -> what a path that is neither a regular file nor a
/// folder is, in words ("a FIFO (named pipe)", "a device", ...), else None.
#[pyfunction]
pub fn special_kind(path: PathBuf) -> Option<&'static str> {
    io::special_kind(&path)
}

/// require_regular_file(path): FormatError unless `path` is a regular file,
/// a folder or nothing (which the open that follows refuses).
#[pyfunction]
pub fn require_regular_file(py: Python<'_>, path: PathBuf) -> PyResult<()> {
    io::require_regular_file(&path).map_err(|e| to_py(py, e))
}
