//! The validated triangle array: positions and faces that are safe to index.
//!
//! A `Mesh` is checked once, when it is built (STYLE 5): it has at least one
//! vertex and one face, every coordinate is finite and every index is in range.
//! Topology (manifoldness, genus, orientation) is *not* required here: that is what
//! [`crate::validate`] reports and [`crate::halfedge::HalfEdgeMesh`] demands.

use crate::edge_table::EdgeTable;
use crate::error::MeshError;
use std::sync::OnceLock;

/// Largest number of vertices: indices are `u32` inside the core.
pub const MAX_VERTICES: usize = u32::MAX as usize;

/// A triangle mesh as two parallel arrays: `positions[v]` is vertex `v`, and each
/// face lists three vertex indices, counter-clockwise seen from outside.
#[derive(Debug, Clone)]
pub struct Mesh {
    positions: Vec<[f64; 3]>,
    faces: Vec<[u32; 3]>,
    /// Built on first use and kept: validation, orientation and the half-edge
    /// build all start from it, and the mesh never changes.
    edge_table: OnceLock<EdgeTable>,
}

impl PartialEq for Mesh {
    fn eq(&self, other: &Mesh) -> bool {
        self.positions == other.positions && self.faces == other.faces
    }
}

impl Mesh {
    /// Builds a mesh, checking that it is non-empty, finite and in range. O(n).
    pub fn new(positions: Vec<[f64; 3]>, faces: Vec<[u32; 3]>) -> Result<Mesh, MeshError> {
        check_positions(&positions)?;
        if faces.is_empty() {
            return Err(MeshError::NoFaces);
        }
        let n = positions.len();
        if let Some((face, index)) = first_out_of_range(&faces, n) {
            return Err(MeshError::IndexOutOfRange { face, index: index as i64, n_vertices: n });
        }
        Ok(Mesh { positions, faces, edge_table: OnceLock::new() })
    }

    /// Builds a mesh from signed 64-bit indices (as numpy hands them over),
    /// rejecting negative and too large ones.
    pub fn from_signed(positions: Vec<[f64; 3]>, faces: &[[i64; 3]]) -> Result<Mesh, MeshError> {
        check_positions(&positions)?;
        if faces.is_empty() {
            return Err(MeshError::NoFaces);
        }
        let n = positions.len();
        let mut converted = Vec::with_capacity(faces.len());
        for (face, corners) in faces.iter().enumerate() {
            let mut out = [0u32; 3];
            for (slot, &index) in out.iter_mut().zip(corners) {
                if index < 0 || index as u64 >= n as u64 {
                    return Err(MeshError::IndexOutOfRange { face, index, n_vertices: n });
                }
                *slot = index as u32;
            }
            converted.push(out);
        }
        Ok(Mesh { positions, faces: converted, edge_table: OnceLock::new() })
    }

    pub fn positions(&self) -> &[[f64; 3]] {
        &self.positions
    }

    pub fn faces(&self) -> &[[u32; 3]] {
        &self.faces
    }

    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }

    pub fn n_faces(&self) -> usize {
        self.faces.len()
    }

    /// The same vertices with every face's orientation reversed where `flip[f]`.
    pub fn with_flipped_faces(&self, flip: &[bool]) -> Mesh {
        let faces = self
            .faces
            .iter()
            .zip(flip)
            .map(|(&[a, b, c], &f)| if f { [a, c, b] } else { [a, b, c] })
            .collect();
        Mesh { positions: self.positions.clone(), faces, edge_table: OnceLock::new() }
    }

    /// The faces' corners grouped by undirected edge (built once, then
    /// cached; its build runs in parallel, so through [`built_once`]).
    pub fn edge_table(&self) -> &EdgeTable {
        built_once(&self.edge_table, || EdgeTable::new(self.positions.len(), &self.faces))
    }

    /// Frees the cached edge table; the next [`Mesh::edge_table`] rebuilds it.
    /// For callers that keep the mesh through a memory peak after their last
    /// topology query (the edge table is ~36 bytes per vertex).
    pub fn forget_edge_table(&mut self) {
        self.edge_table = OnceLock::new();
    }

    pub fn into_parts(self) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        (self.positions, self.faces)
    }
}

fn check_positions(positions: &[[f64; 3]]) -> Result<(), MeshError> {
    if positions.is_empty() {
        return Err(MeshError::NoVertices);
    }
    if positions.len() > MAX_VERTICES {
        return Err(MeshError::TooManyVertices { n_vertices: positions.len(), max: MAX_VERTICES });
    }
    if let Some((vertex, value)) = first_non_finite(positions) {
        return Err(MeshError::NonFiniteCoordinate { vertex, value });
    }
    Ok(())
}

/// The first vertex with a NaN or infinite coordinate, and that coordinate.
pub fn first_non_finite(positions: &[[f64; 3]]) -> Option<(usize, f64)> {
    positions
        .iter()
        .enumerate()
        .find_map(|(v, p)| p.iter().find(|x| !x.is_finite()).map(|&x| (v, x)))
}

fn first_out_of_range(faces: &[[u32; 3]], n: usize) -> Option<(usize, u32)> {
    faces
        .iter()
        .enumerate()
        .find_map(|(f, c)| c.iter().find(|&&i| i as usize >= n).map(|&i| (f, i)))
}

/// The value in `cell`, made by `build` if there is none yet. `build` runs
/// outside the cell's initialisation: a build that runs rayon jobs may, while
/// a worker waits inside it, have that worker take up another job that asks
/// for the same cell, which would then wait forever on an initialisation held
/// further down its own stack (`OnceLock::get_or_init` blocks). Two callers
/// that race may both build; the first stored wins, so `build` must give the
/// same value each time.
pub fn built_once<T>(cell: &OnceLock<T>, build: impl FnOnce() -> T) -> &T {
    if let Some(made) = cell.get() {
        return made;
    }
    let made = build();
    cell.get_or_init(|| made)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Many first calls for one mesh's edge table at once, each from its own
    /// thread into one 2-thread pool (as concurrent `embed` calls from Python
    /// threads do): none may wait on a build that a worker left to run
    /// another caller's job (it did when the parallel build ran inside the
    /// cell's initialisation: a hang found by concurrent registrations).
    #[test]
    fn first_calls_from_many_threads_into_one_pool_all_return() {
        use std::sync::{mpsc, Arc};
        let pool = Arc::new(rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap());
        for _ in 0..12 {
            // 81,920 faces: the build runs on ranges in parallel.
            let mesh = Arc::new(crate::solids::icosphere(6));
            let (done, finished) = mpsc::channel();
            for _ in 0..6 {
                let (mesh, pool, done) = (Arc::clone(&mesh), Arc::clone(&pool), done.clone());
                std::thread::spawn(move || {
                    let edges = pool.install(|| mesh.edge_table().n_edges());
                    done.send(edges).ok();
                });
            }
            for _ in 0..6 {
                let edges = finished
                    .recv_timeout(std::time::Duration::from_secs(60))
                    .expect("a first call for the edge table never returned");
                assert_eq!(edges, 3 * 81_920 / 2);
            }
        }
    }

    #[test]
    fn rejects_empty_nan_and_out_of_range() {
        assert!(matches!(Mesh::new(vec![], vec![[0, 1, 2]]), Err(MeshError::NoVertices)));
        let p = vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert!(matches!(Mesh::new(p.clone(), vec![]), Err(MeshError::NoFaces)));
        let err = Mesh::new(p.clone(), vec![[0, 1, 3]]).unwrap_err();
        assert!(matches!(err, MeshError::IndexOutOfRange { face: 0, index: 3, n_vertices: 3 }));
        let err = Mesh::from_signed(p.clone(), &[[0, -1, 2]]).unwrap_err();
        assert!(matches!(err, MeshError::IndexOutOfRange { index: -1, .. }));
        let mut bad = p.clone();
        bad[1][2] = f64::NAN;
        let err = Mesh::new(bad, vec![[0, 1, 2]]).unwrap_err();
        assert!(matches!(err, MeshError::NonFiniteCoordinate { vertex: 1, .. }));
        assert!(Mesh::new(p, vec![[0, 1, 2]]).is_ok());
    }
}
