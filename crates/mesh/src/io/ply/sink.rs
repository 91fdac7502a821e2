//! Where both PLY readers put what they parse: positions and attributes by
//! value slot, corners gathered into faces and fan-triangulated, with the
//! checks (finite positions, indices in range) whose messages both share.

use super::header::Layout;
use crate::error::MeshError;
use crate::io::{
    finish, polygon_too_large, LoadedMesh, Triangles, VertexAttributes, MAX_POLYGON_CORNERS,
};

/// Where parsed values go.
pub(super) struct Sink {
    pub(super) nv: u64,
    layout: Layout,
    positions: Vec<[f64; 3]>,
    sphere: Vec<[f64; 3]>,
    uv: Vec<[f64; 2]>,
    pub(super) triangles: Triangles,
    /// Notes from the body readers (data after the declared elements).
    pub(super) notes: Vec<String>,
    corners: Vec<u32>,
}

impl Sink {
    pub(super) fn new(nv: u64, nf: u64, layout: Layout) -> Self {
        // Both counts were checked against the file size, so these allocations are
        // bounded by it.
        let n = nv as usize;
        Sink {
            nv,
            layout,
            positions: Vec::with_capacity(n),
            sphere: Vec::with_capacity(if layout.sphere { n } else { 0 }),
            uv: Vec::with_capacity(if layout.uv { n } else { 0 }),
            triangles: Triangles::with_capacity(nf as usize),
            notes: Vec::new(),
            corners: Vec::with_capacity(8),
        }
    }

    /// Stores one vertex; returns the offending value if a position is not finite.
    #[inline]
    pub(super) fn vertex(&mut self, v: &[f64; 8]) -> Result<(), f64> {
        if let Some(&bad) = v[..3].iter().find(|x| !x.is_finite()) {
            return Err(bad);
        }
        self.positions.push([v[0], v[1], v[2]]);
        if self.layout.sphere {
            self.sphere.push([v[3], v[4], v[5]]);
        }
        if self.layout.uv {
            self.uv.push([v[6], v[7]]);
        }
        Ok(())
    }

    /// Adds a corner index; the message says what is wrong with a bad one.
    #[inline]
    pub(super) fn corner(&mut self, index: i64) -> Result<(), String> {
        if index < 0 || index as u64 >= self.nv {
            return Err(format!(
                "vertex index {index} is out of range: the file has {} vertices",
                self.nv
            ));
        }
        if self.corners.len() == MAX_POLYGON_CORNERS {
            return Err(polygon_too_large(format!("more than {MAX_POLYGON_CORNERS}")));
        }
        self.corners.push(index as u32);
        Ok(())
    }

    pub(super) fn end_face(&mut self) -> Result<(), String> {
        if self.corners.len() < 3 {
            return Err(format!(
                "a face needs at least 3 vertices, this one has {}",
                self.corners.len()
            ));
        }
        self.triangles.push(&self.corners);
        self.corners.clear();
        Ok(())
    }

    pub(super) fn into_mesh(self, name: &str) -> Result<LoadedMesh, MeshError> {
        let attributes = VertexAttributes {
            sphere: self.layout.sphere.then_some(self.sphere),
            uv: self.layout.uv.then_some(self.uv),
        };
        let mut notes: Vec<String> = self.triangles.note().into_iter().collect();
        notes.extend(self.notes);
        finish(name, self.positions, self.triangles.faces, attributes, notes)
    }
}
