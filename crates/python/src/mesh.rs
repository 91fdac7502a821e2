//! The core mesh handle held by `spherify.Mesh`.

use std::sync::Arc;

use numpy::{PyArray2, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use spherify_mesh::Mesh;

use crate::convert::{rows, to_i64_rows, to_numpy};
use crate::errors::to_py;

/// A validated mesh inside the Rust core (finite coordinates, indices in range).
#[pyclass(frozen, module = "spherify._core")]
pub struct CoreMesh {
    /// Shared with the maps made of it (an oriented mesh is shared as is).
    pub mesh: Arc<Mesh>,
}

#[pymethods]
impl CoreMesh {
    /// CoreMesh(vertices: (n, 3) float64, faces: (m, 3) int64); raises MeshError.
    #[new]
    fn new(
        py: Python<'_>,
        vertices: PyReadonlyArrayDyn<'_, f64>,
        faces: PyReadonlyArrayDyn<'_, i64>,
    ) -> PyResult<Self> {
        let positions = rows::<f64, 3>(&vertices, "vertices")?;
        let faces = rows::<i64, 3>(&faces, "faces")?;
        let mesh = crate::pool::detach(py, || Mesh::from_signed(positions, &faces))?
            .map_err(|e| to_py(py, e))?;
        Ok(CoreMesh { mesh: Arc::new(mesh) })
    }

    /// (n, 3) float64 copy of the positions.
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        to_numpy(py, self.mesh.positions())
    }

    /// (m, 3) int64 copy of the faces.
    fn faces<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        to_numpy(py, &to_i64_rows(self.mesh.faces()))
    }

    #[getter]
    fn n_vertices(&self) -> usize {
        self.mesh.n_vertices()
    }

    #[getter]
    fn n_faces(&self) -> usize {
        self.mesh.n_faces()
    }
}
