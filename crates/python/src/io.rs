//! `load` / `save`: file formats are read and written by `spherify_mesh::io`.

use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use spherify_mesh::io::{self, PlyEncoding, VertexAttributes, WriteOptions};

use crate::convert::{rows, to_numpy};
use spherify_sphere::memory_budget::{self, Application};

use crate::errors::{resource_error, to_py, unknown_name};
use crate::mesh::CoreMesh;

/// load(path) -> (CoreMesh, notes, attributes): reads OBJ, OFF, PLY or STL.
#[pyfunction]
pub fn load<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
) -> PyResult<(CoreMesh, Vec<String>, Bound<'py, PyDict>)> {
    // The memory policy by the file's size, before it is read (a file that
    // cannot be looked at is left to the reader, which names what is wrong).
    // A file larger than all that is available is left to the reader too: its
    // FileError says the file is more than the process can hold; one that can
    // be held but not parsed is refused here.
    if let Ok(meta) = std::fs::metadata(&path) {
        let bytes = usize::try_from(meta.len()).unwrap_or(usize::MAX);
        let need = memory_budget::application_need(Application::Load, 0, 0, bytes);
        if let Err(err) = memory_budget::check(&need) {
            if err.available().is_some_and(|available| meta.len() <= available) {
                return Err(resource_error(err));
            }
        }
    }
    // Detachable: parsing a large text file takes seconds and cannot poll
    // (issue 13, item 2); after Ctrl-C the parse finishes in the background.
    let loaded = crate::progress::run_detachable(py, None, move |_| io::read(&path))?
        .map_err(|e| to_py(py, e))?;
    let attributes = PyDict::new(py);
    if let Some(sphere) = &loaded.attributes.sphere {
        attributes.set_item("sphere", to_numpy(py, sphere))?;
    }
    if let Some(uv) = &loaded.attributes.uv {
        attributes.set_item("uv", to_numpy(py, uv))?;
    }
    Ok((CoreMesh { mesh: loaded.mesh.into() }, loaded.notes, attributes))
}

/// save(mesh, path, sphere=None, uv=None, ply_encoding="binary_little_endian",
/// stl_binary=True): writes to a temporary file, then renames it into place.
#[pyfunction]
#[pyo3(signature = (mesh, path, sphere=None, uv=None, ply_encoding="binary_little_endian", stl_binary=true))]
pub fn save(
    py: Python<'_>,
    mesh: &CoreMesh,
    path: std::path::PathBuf,
    sphere: Option<PyReadonlyArrayDyn<'_, f64>>,
    uv: Option<PyReadonlyArrayDyn<'_, f64>>,
    ply_encoding: &str,
    stl_binary: bool,
) -> PyResult<()> {
    let (attributes, options) = write_options(sphere, uv, ply_encoding, stl_binary)?;
    crate::pool::detach(py, || io::write(&path, &mesh.mesh, &attributes, &options))?
        .map_err(|e| to_py(py, e))
}

/// encode(mesh, path, sphere=None, uv=None, ply_encoding="binary_little_endian",
/// stl_binary=True) -> bytes: what `save` would write to `path` (the format
/// from its name; the file is not touched), for callers that write the bytes
/// themselves: the batch hashes its outputs as it writes them.
#[pyfunction]
#[pyo3(signature = (mesh, path, sphere=None, uv=None, ply_encoding="binary_little_endian", stl_binary=true))]
pub fn encode<'py>(
    py: Python<'py>,
    mesh: &CoreMesh,
    path: std::path::PathBuf,
    sphere: Option<PyReadonlyArrayDyn<'_, f64>>,
    uv: Option<PyReadonlyArrayDyn<'_, f64>>,
    ply_encoding: &str,
    stl_binary: bool,
) -> PyResult<Bound<'py, PyBytes>> {
    let (attributes, options) = write_options(sphere, uv, ply_encoding, stl_binary)?;
    let bytes = crate::pool::detach(py, || {
        let format = io::format_from_path(&path)?;
        io::write_bytes(&mesh.mesh, &attributes, format, &options, &path.display().to_string())
    })?
    .map_err(|e| to_py(py, e))?;
    Ok(PyBytes::new(py, &bytes))
}

/// write_atomic(path, data: bytes): writes `data` with the mesh writer's
/// atomic scheme (temporary beside the target, sync, rename; symbolic links
/// followed, the replaced file's mode kept, stale temporaries removed).
#[pyfunction]
pub fn write_atomic(py: Python<'_>, path: std::path::PathBuf, data: &[u8]) -> PyResult<()> {
    crate::pool::detach(py, || io::write_atomic(&path, data))?.map_err(|e| to_py(py, e))
}

/// save_textured_obj(mesh, path, corners, label, material_library=None):
/// an OBJ with one `vt` per face corner (`corners` (3 m, 2), face order),
/// written atomically; the MTL and the image are the caller's.
#[pyfunction]
#[pyo3(signature = (mesh, path, corners, label, material_library=None))]
pub fn save_textured_obj(
    py: Python<'_>,
    mesh: &CoreMesh,
    path: std::path::PathBuf,
    corners: PyReadonlyArrayDyn<'_, f64>,
    label: &str,
    material_library: Option<&str>,
) -> PyResult<()> {
    let corners = rows::<f64, 2>(&corners, "corners")?;
    crate::pool::detach(py, || {
        io::write_textured_obj(&path, &mesh.mesh, &corners, label, material_library)
    })?
    .map_err(|e| to_py(py, e))
}

/// The attributes and options of `save` and `encode`, checked.
fn write_options(
    sphere: Option<PyReadonlyArrayDyn<'_, f64>>,
    uv: Option<PyReadonlyArrayDyn<'_, f64>>,
    ply_encoding: &str,
    stl_binary: bool,
) -> PyResult<(VertexAttributes, WriteOptions)> {
    let ply_encoding: PlyEncoding = ply_encoding.parse().map_err(unknown_name)?;
    let attributes = VertexAttributes {
        sphere: sphere.map(|a| rows::<f64, 3>(&a, "sphere")).transpose()?,
        uv: uv.map(|a| rows::<f64, 2>(&a, "uv")).transpose()?,
    };
    Ok((attributes, WriteOptions { ply_encoding, stl_binary }))
}
