//! Cutting a closed genus-0 mesh open along a path (thesis 6.3, Alg. 6.1).
//!
//! The path P = (n, p_1, ..., p_k, s) becomes a slit: every interior path vertex
//! p_i gets a duplicate with label N + k - i + 1 (thesis eq. 6.22), placed at the
//! same point, so that the boundary cycle of the cut mesh is
//! B = (n, p_1, ..., p_k, s, N + 1, ..., N + k) (eq. 6.30), in the direction of the
//! faces (counter-clockwise). Alg. 6.1 finds the faces on one side of P by
//! walking from face to face; here the half-edge rotation around each p_i does
//! the same walk: the faces met turning clockwise from (p_i -> p_{i+1}) to
//! (p_i -> p_{i-1}) lie to the right of P, and their corner at p_i is moved to
//! the duplicate. Only corners are relabelled, never whole faces, so a face
//! touching P at two vertices is handled per vertex. O(F + |P| d).

use crate::error::{TopologyError, TopologyProblem};
use crate::halfedge::HalfEdgeMesh;
use crate::mesh::Mesh;
use crate::validate;

/// A mesh cut open along a path.
#[derive(Debug, Clone)]
pub struct CutMesh {
    /// N + k vertices: the original ones, then the duplicates (eq. 6.22).
    pub mesh: Mesh,
    /// The boundary cycle B of eq. 6.30.
    pub boundary: Vec<u32>,
    /// For every vertex of the cut mesh, the original vertex it stands for.
    pub original: Vec<u32>,
    /// The path that was cut, as given.
    pub path: Vec<u32>,
}

/// Why a path cannot be cut.
#[derive(Debug, thiserror::Error)]
pub enum CutError {
    #[error(transparent)]
    Mesh(#[from] crate::error::MeshError),
    #[error(transparent)]
    Topology(#[from] TopologyError),
    #[error("the cut path needs at least 3 vertices (one between the poles), got {0}")]
    TooShort(usize),
    #[error("the cut path visits vertex {0} twice")]
    NotSimple(u32),
    #[error("vertices {0} and {1} follow each other on the cut path but share no edge")]
    NotAdjacent(u32, u32),
    #[error("vertex {0} of the cut path is out of range")]
    OutOfRange(u32),
}

/// The half-edge from `a` to `b`, if they share an edge.
pub fn half_edge_between(he: &HalfEdgeMesh, a: u32, b: u32) -> Option<u32> {
    he.rotation(a).find(|&h| he.head(h) == b)
}

/// Cuts a closed genus-0 mesh open along `path` (thesis 6.3).
pub fn cut_open(mesh: &Mesh, path: &[u32]) -> Result<CutMesh, CutError> {
    cut_open_with(mesh, &HalfEdgeMesh::new(mesh)?, path)
}

/// [`cut_open`] with the half-edge structure of `mesh` already built (the
/// theta-phi method has one from choosing the poles, and a second build is
/// a tenth of the cut's cost at a million vertices). A `he` that plainly
/// belongs to another mesh (other vertex or face count) is rebuilt.
pub fn cut_open_with(mesh: &Mesh, he: &HalfEdgeMesh, path: &[u32]) -> Result<CutMesh, CutError> {
    if he.n_vertices() != mesh.n_vertices() || he.n_faces() != mesh.n_faces() {
        return cut_open(mesh, path);
    }
    let euler = he.n_vertices() as i64 - he.n_edges() as i64 + he.n_faces() as i64;
    if !he.boundary_loops().is_empty() || euler != 2 {
        return Err(TopologyError {
            problem: TopologyProblem::NotSphere,
            report: Box::new(validate::check(mesh)),
        }
        .into());
    }
    if path.len() < 3 {
        return Err(CutError::TooShort(path.len()));
    }
    let n = mesh.n_vertices();
    let mut on_path = vec![false; n];
    for &v in path {
        let slot = on_path.get_mut(v as usize).ok_or(CutError::OutOfRange(v))?;
        if *slot {
            return Err(CutError::NotSimple(v));
        }
        *slot = true;
    }
    let mut steps = Vec::with_capacity(path.len() - 1);
    for pair in path.windows(2) {
        steps.push(
            half_edge_between(he, pair[0], pair[1])
                .ok_or(CutError::NotAdjacent(pair[0], pair[1]))?,
        );
    }
    let k = path.len() - 2;
    let mut faces = mesh.faces().to_vec();
    let mut positions = mesh.positions().to_vec();
    positions.reserve(k);
    let mut original: Vec<u32> = (0..n as u32).collect();
    for i in 1..=k {
        let p = path[i];
        let duplicate = (n + k - i) as u32; // label N + k - i + 1, 0-based
                                            // Turn clockwise from (p -> p_{i+1}) until (p -> p_{i-1}); each step
                                            // crosses a face on the right of the path.
        let forward = steps[i];
        let backward = he.twin(steps[i - 1]);
        let mut h = forward;
        while h != backward {
            let right = he.twin(h);
            if let Some(f) = he.face(right) {
                for corner in faces[f as usize].iter_mut() {
                    if *corner == p {
                        *corner = duplicate;
                    }
                }
            }
            h = he.next(right);
        }
    }
    // Label N + j - 1 (0-based) duplicates p_{k - j + 1} (eq. 6.22).
    for j in 1..=k {
        let p = path[k + 1 - j];
        original.push(p);
        positions.push(mesh.positions()[p as usize]);
    }
    let mut boundary = path.to_vec();
    boundary.extend((0..k).map(|j| (n + j) as u32));
    let mesh = Mesh::new(positions, faces)?;
    Ok(CutMesh { mesh, boundary, original, path: path.to_vec() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::validate::check;

    fn octahedron() -> Mesh {
        let (p, f) = (
            crate::solids::OCTAHEDRON_POSITIONS.to_vec(),
            crate::solids::OCTAHEDRON_FACES.to_vec(),
        );
        Mesh::new(p, f).unwrap()
    }

    fn assert_disk(cut: &CutMesh, k: usize, n: usize) {
        let report = check(&cut.mesh);
        assert!(report.manifold && report.connected && report.consistently_oriented, "{report:?}");
        assert_eq!(report.euler_characteristic, 1);
        assert_eq!(report.boundary_loops.total, 1);
        assert_eq!(cut.mesh.n_vertices(), n + k);
        assert_eq!(cut.boundary.len(), 2 * k + 2);
        // The boundary cycle runs in the faces' direction: B[i] -> B[i+1] is a face edge.
        let he = HalfEdgeMesh::new(&cut.mesh).unwrap();
        for i in 0..cut.boundary.len() {
            let (a, b) = (cut.boundary[i], cut.boundary[(i + 1) % cut.boundary.len()]);
            let h = half_edge_between(&he, a, b).unwrap();
            assert!(he.face(h).is_some() && he.face(he.twin(h)).is_none(), "edge {a}->{b}");
        }
        for (v, &o) in cut.original.iter().enumerate() {
            assert_eq!(cut.mesh.positions()[v], cut.mesh.positions()[o as usize]);
        }
    }

    #[test]
    fn octahedron_cut_along_a_meridian() {
        let mesh = octahedron();
        // North 4, through 0 and 5... 4 - 0 - 5 has k = 1; 4 - 0 - 3 - 5 has k = 2.
        let cut = cut_open(&mesh, &[4, 0, 3, 5]).unwrap();
        assert_disk(&cut, 2, 6);
        assert_eq!(cut.boundary, vec![4, 0, 3, 5, 6, 7]);
        assert_eq!(&cut.original[6..], &[3, 0]);
        let cut = cut_open(&mesh, &[4, 0, 5]).unwrap();
        assert_disk(&cut, 1, 6);
    }

    #[test]
    fn tetrahedron_cut_along_a_hamiltonian_path() {
        let mesh = Mesh::new(
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        )
        .unwrap();
        let cut = cut_open(&mesh, &[0, 1, 2, 3]).unwrap();
        assert_disk(&cut, 2, 4);
    }

    #[test]
    fn bad_paths() {
        let mesh = octahedron();
        assert!(matches!(cut_open(&mesh, &[4, 5]), Err(CutError::TooShort(2))));
        assert!(matches!(cut_open(&mesh, &[4, 0, 4]), Err(CutError::NotSimple(4))));
        assert!(matches!(cut_open(&mesh, &[4, 0, 1]), Err(CutError::NotAdjacent(0, 1))));
        assert!(matches!(cut_open(&mesh, &[4, 0, 9]), Err(CutError::OutOfRange(9))));
    }
}
