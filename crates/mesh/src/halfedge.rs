//! Half-edge connectivity of an oriented manifold triangle mesh (thesis 2.2).
//!
//! Topology only (STYLE 4): positions and other per-vertex data stay in parallel
//! arrays. Half-edges `2e` and `2e + 1` are the two sides of edge `e`, so the twin
//! of `h` is `h ^ 1`; `2e` runs from the smaller to the larger vertex index. A
//! boundary edge has a half-edge with no face; those half-edges are linked along
//! their boundary loop by `next`. Built in O(F log d) from the edge table.

use crate::edge_table::{corner_endpoints, NONE};
use crate::error::{TopologyError, TopologyProblem};
use crate::graph::Adjacency;
use crate::mesh::Mesh;
use crate::validate;

/// Connectivity of a consistently oriented, edge- and vertex-manifold triangle mesh
/// (closed or with boundary), with every vertex used by some face.
#[derive(Debug, Clone)]
pub struct HalfEdgeMesh {
    /// Head vertex of each half-edge.
    to: Vec<u32>,
    /// Face of each half-edge, `NONE` on a boundary.
    face: Vec<u32>,
    /// Next half-edge around the same face (or boundary loop).
    next: Vec<u32>,
    /// One outgoing half-edge per vertex; the boundary one for boundary vertices.
    vertex_out: Vec<u32>,
    /// Per face, the half-edge from corner 0 to corner 1.
    face_first: Vec<u32>,
}

impl HalfEdgeMesh {
    /// Builds the connectivity, or says which requirement the mesh breaks (with the
    /// full validation report attached).
    ///
    /// One function on purpose, its steps commented: they fill the arrays of
    /// one structure in order (twins, outgoing half-edges, then the manifold
    /// check over both); split, they would hand those arrays from one to the next.
    pub fn new(mesh: &Mesh) -> Result<HalfEdgeMesh, TopologyError> {
        let faces = mesh.faces();
        let n = mesh.n_vertices();
        let fail = |problem| TopologyError { problem, report: Box::new(validate::check(mesh)) };
        for (f, &[a, b, c]) in faces.iter().enumerate() {
            if a == b || b == c || a == c {
                return Err(fail(TopologyProblem::RepeatedIndex { face: f as u32 }));
            }
        }
        let table = mesh.edge_table();
        let n_he = 2 * table.n_edges();
        let mut to = vec![NONE; n_he];
        let mut face = vec![NONE; n_he];
        let mut next = vec![NONE; n_he];
        // Half-edge of each corner 3f+k.
        let mut corner_he = vec![NONE; 3 * faces.len()];
        for e in 0..table.n_edges() {
            let group = table.group(e);
            let (a, b) = corner_endpoints(faces, group[0]);
            let (lo, hi) = (a.min(b), a.max(b));
            let mut taken = [false; 2];
            for &c in group {
                let (tail, head) = corner_endpoints(faces, c);
                let side = usize::from(tail != lo);
                if group.len() > 2 {
                    return Err(fail(TopologyProblem::NonManifoldEdge {
                        a: lo,
                        b: hi,
                        faces: group.len(),
                    }));
                }
                if taken[side] {
                    return Err(fail(TopologyProblem::InconsistentOrientation {
                        a: tail,
                        b: head,
                    }));
                }
                taken[side] = true;
                let h = 2 * e + side;
                corner_he[c as usize] = h as u32;
                to[h] = head;
                face[h] = c / 3;
            }
            // The side without a face is a boundary half-edge.
            for side in 0..2 {
                if !taken[side] {
                    to[2 * e + side] = if side == 0 { hi } else { lo };
                }
            }
        }
        for f in 0..faces.len() {
            for k in 0..3 {
                next[corner_he[3 * f + k] as usize] = corner_he[3 * f + (k + 1) % 3];
            }
        }
        // Outgoing half-edges: prefer the boundary one so rotations start there.
        let mut vertex_out = vec![NONE; n];
        let mut boundary_out = vec![NONE; n];
        for h in 0..n_he {
            let tail = to[h ^ 1] as usize;
            if face[h] == NONE {
                if boundary_out[tail] != NONE {
                    return Err(fail(TopologyProblem::NonManifoldVertex { vertex: tail as u32 }));
                }
                boundary_out[tail] = h as u32;
            }
            if vertex_out[tail] == NONE {
                vertex_out[tail] = h as u32;
            }
        }
        for h in 0..n_he {
            if face[h] == NONE {
                next[h] = boundary_out[to[h] as usize];
            }
        }
        for v in 0..n {
            if vertex_out[v] == NONE {
                return Err(fail(TopologyProblem::UnreferencedVertex { vertex: v as u32 }));
            }
            if boundary_out[v] != NONE {
                vertex_out[v] = boundary_out[v];
            }
        }
        let face_first = (0..faces.len()).map(|f| corner_he[3 * f]).collect();
        let mesh = HalfEdgeMesh { to, face, next, vertex_out, face_first };
        // Vertex-manifold: one rotation around each vertex must meet all of its
        // outgoing half-edges (thesis 2.3, condition (b): the star is one disk).
        let mut degree = vec![0u32; n];
        for h in 0..n_he {
            degree[mesh.to[h ^ 1] as usize] += 1;
        }
        for (v, &d) in degree.iter().enumerate() {
            if mesh.rotation(v as u32).count() as u32 != d {
                return Err(fail(TopologyProblem::NonManifoldVertex { vertex: v as u32 }));
            }
        }
        Ok(mesh)
    }

    pub fn n_vertices(&self) -> usize {
        self.vertex_out.len()
    }

    pub fn n_faces(&self) -> usize {
        self.face_first.len()
    }

    pub fn n_edges(&self) -> usize {
        self.to.len() / 2
    }

    pub fn n_half_edges(&self) -> usize {
        self.to.len()
    }

    #[inline]
    pub fn twin(&self, h: u32) -> u32 {
        h ^ 1
    }

    #[inline]
    pub fn next(&self, h: u32) -> u32 {
        self.next[h as usize]
    }

    /// Head vertex of `h`.
    #[inline]
    pub fn head(&self, h: u32) -> u32 {
        self.to[h as usize]
    }

    /// Tail vertex of `h`.
    #[inline]
    pub fn tail(&self, h: u32) -> u32 {
        self.to[(h ^ 1) as usize]
    }

    /// Face of `h`, or `None` for a boundary half-edge.
    #[inline]
    pub fn face(&self, h: u32) -> Option<u32> {
        let f = self.face[h as usize];
        (f != NONE).then_some(f)
    }

    pub fn is_boundary_vertex(&self, v: u32) -> bool {
        self.face[self.vertex_out[v as usize] as usize] == NONE
    }

    /// The half-edge of face `f` from its corner 0 to its corner 1.
    pub fn face_half_edge(&self, f: u32) -> u32 {
        self.face_first[f as usize]
    }

    /// Outgoing half-edges of `v` in clockwise order seen from outside, starting
    /// at the boundary half-edge for a boundary vertex: `next(twin(h))` turns
    /// clockwise for counter-clockwise faces.
    pub fn rotation(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        let start = self.vertex_out[v as usize];
        let mut current = Some(start);
        std::iter::from_fn(move || {
            let h = current?;
            let following = self.next[(h ^ 1) as usize];
            current = (following != start && following != NONE).then_some(following);
            Some(h)
        })
        .take(self.to.len())
    }

    /// Neighbours of `v` in counter-clockwise order seen from outside; for a
    /// boundary vertex the list runs from the tail of the incoming boundary edge
    /// to the head of the outgoing one.
    pub fn vertex_ring(&self, v: u32) -> Vec<u32> {
        let mut ring: Vec<u32> = self.rotation(v).map(|h| self.head(h)).collect();
        ring.reverse();
        ring
    }

    /// Faces around `v` in counter-clockwise order.
    pub fn vertex_faces(&self, v: u32) -> Vec<u32> {
        let mut faces: Vec<u32> = self.rotation(v).filter_map(|h| self.face(h)).collect();
        faces.reverse();
        faces
    }

    /// Edge list: `(a, b)` with `a < b`, edge `e` at position `e`.
    pub fn edges(&self) -> Vec<[u32; 2]> {
        (0..self.n_edges()).map(|e| [self.to[2 * e + 1], self.to[2 * e]]).collect()
    }

    /// Boundary loops, each a vertex cycle following the boundary half-edges.
    pub fn boundary_loops(&self) -> Vec<Vec<u32>> {
        let mut seen = vec![false; self.to.len()];
        let mut loops = Vec::new();
        for h0 in 0..self.to.len() {
            if self.face[h0] != NONE || seen[h0] {
                continue;
            }
            let mut cycle = Vec::new();
            let mut h = h0 as u32;
            while !seen[h as usize] {
                seen[h as usize] = true;
                cycle.push(self.tail(h));
                h = self.next(h);
            }
            loops.push(cycle);
        }
        loops
    }

    /// The vertex graph with each row in counter-clockwise cyclic order.
    pub fn adjacency(&self) -> Adjacency {
        let n = self.n_vertices();
        let mut offsets = Vec::with_capacity(n + 1);
        let mut neighbors = Vec::with_capacity(self.to.len());
        offsets.push(0);
        for v in 0..n as u32 {
            // `vertex_ring` without its allocation: the rotation, reversed in place.
            let start = neighbors.len();
            neighbors.extend(self.rotation(v).map(|h| self.head(h)));
            neighbors[start..].reverse();
            offsets.push(neighbors.len());
        }
        Adjacency { offsets, neighbors }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn octahedron() -> Mesh {
        crate::solids::octahedron()
    }

    #[test]
    fn octahedron_rings_are_ccw_cycles() {
        let m = octahedron();
        let he = HalfEdgeMesh::new(&m).unwrap();
        assert_eq!(he.n_edges(), 12);
        assert!(he.boundary_loops().is_empty());
        // Seen from above (+z), the neighbours of the top vertex 4 turn counter-clockwise.
        let ring = he.vertex_ring(4);
        assert_eq!(ring.len(), 4);
        let i = ring.iter().position(|&x| x == 0).unwrap();
        let rotated: Vec<u32> = (0..4).map(|k| ring[(i + k) % 4]).collect();
        assert_eq!(rotated, vec![0, 2, 1, 3]);
        for h in 0..he.n_half_edges() as u32 {
            assert_eq!(he.tail(he.twin(h)), he.head(h));
            assert_eq!(he.next(he.next(he.next(h))), h, "triangles close after three steps");
        }
        let adj = he.adjacency();
        assert_eq!(adj.n_edges(), 12);
        for v in 0..6 {
            assert_eq!(adj.neighbors(v), he.vertex_ring(v).as_slice());
        }
        assert!((0..6).all(|v| adj.degree(v) == 4));
    }

    #[test]
    fn open_fan_has_one_boundary_loop() {
        // Square split into four triangles around a centre vertex 4.
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.5, 0.0],
        ];
        let f = vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]];
        let he = HalfEdgeMesh::new(&Mesh::new(p, f).unwrap()).unwrap();
        let loops = he.boundary_loops();
        assert_eq!(loops.len(), 1);
        assert_eq!(loops[0].len(), 4);
        assert!(he.is_boundary_vertex(0) && !he.is_boundary_vertex(4));
        assert_eq!(he.vertex_ring(4).len(), 4);
        assert_eq!(he.vertex_ring(0).len(), 3);
        assert_eq!(he.vertex_faces(0).len(), 2);
        let adj = he.adjacency();
        for v in 0..5 {
            assert_eq!(adj.neighbors(v), he.vertex_ring(v).as_slice());
        }
    }

    #[test]
    fn rejects_broken_meshes() {
        let p = vec![[0.0; 3]; 7];
        // Two tetrahedra sharing vertex 0: a bow-tie vertex.
        let f = vec![
            [0, 2, 1],
            [0, 1, 3],
            [0, 3, 2],
            [1, 2, 3],
            [0, 5, 4],
            [0, 4, 6],
            [0, 6, 5],
            [4, 5, 6],
        ];
        let err = HalfEdgeMesh::new(&Mesh::new(p.clone(), f).unwrap()).unwrap_err();
        assert_eq!(err.problem, TopologyProblem::NonManifoldVertex { vertex: 0 });
        let f = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [3, 2, 1]];
        let err = HalfEdgeMesh::new(&Mesh::new(p.clone(), f).unwrap()).unwrap_err();
        assert!(matches!(err.problem, TopologyProblem::InconsistentOrientation { .. }));
        let f = vec![[0, 0, 1]];
        let err = HalfEdgeMesh::new(&Mesh::new(p, f).unwrap()).unwrap_err();
        assert_eq!(err.problem, TopologyProblem::RepeatedIndex { face: 0 });
    }
}
