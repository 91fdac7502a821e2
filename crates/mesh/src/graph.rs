//! The vertex graph of a mesh in compressed sparse row form (thesis 2.2.2: the
//! underlying graph G_M). Neighbours of vertex `v` are
//! `neighbors[offsets[v]..offsets[v + 1]]`.

/// Vertex adjacency in CSR form; each undirected edge appears once in each
/// direction. Built by [`crate::HalfEdgeMesh::adjacency`] (neighbours in cyclic
/// order) or [`Adjacency::from_faces`] (any triangle soup, sorted neighbours).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Adjacency {
    pub offsets: Vec<usize>,
    pub neighbors: Vec<u32>,
}

impl Adjacency {
    pub fn n_vertices(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Number of undirected edges.
    pub fn n_edges(&self) -> usize {
        self.neighbors.len() / 2
    }

    pub fn neighbors(&self, v: u32) -> &[u32] {
        let v = v as usize;
        &self.neighbors[self.offsets[v]..self.offsets[v + 1]]
    }

    pub fn degree(&self, v: u32) -> usize {
        let v = v as usize;
        self.offsets[v + 1] - self.offsets[v]
    }

    /// The graph of any triangle soup over `n_vertices` vertices: every pair of
    /// distinct vertices that share a face is an edge. Neighbours are sorted.
    /// O(F log d) with d the largest degree.
    pub fn from_faces(n_vertices: usize, faces: &[[u32; 3]]) -> Adjacency {
        let mut counts = vec![0usize; n_vertices + 1];
        for f in faces {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                if a != b {
                    counts[a as usize + 1] += 1;
                    counts[b as usize + 1] += 1;
                }
            }
        }
        for v in 0..n_vertices {
            counts[v + 1] += counts[v];
        }
        let mut fill = counts.clone();
        let mut neighbors = vec![0u32; counts[n_vertices]];
        for f in faces {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                if a != b {
                    neighbors[fill[a as usize]] = b;
                    fill[a as usize] += 1;
                    neighbors[fill[b as usize]] = a;
                    fill[b as usize] += 1;
                }
            }
        }
        // Sort and deduplicate each row, compacting in place.
        let mut offsets = vec![0usize; n_vertices + 1];
        let mut write = 0;
        for v in 0..n_vertices {
            let row = &mut neighbors[counts[v]..counts[v + 1]];
            row.sort_unstable();
            let start = write;
            let mut last = None;
            for i in counts[v]..counts[v + 1] {
                let x = neighbors[i];
                if last != Some(x) {
                    neighbors[write] = x;
                    write += 1;
                    last = Some(x);
                }
            }
            offsets[v] = start;
            offsets[v + 1] = write;
        }
        neighbors.truncate(write);
        Adjacency { offsets, neighbors }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tetrahedron_is_complete_graph() {
        let faces = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let adj = Adjacency::from_faces(4, &faces);
        assert_eq!(adj.n_edges(), 6);
        for v in 0..4u32 {
            let expected: Vec<u32> = (0..4).filter(|&u| u != v).collect();
            assert_eq!(adj.neighbors(v), &expected[..]);
        }
    }

    #[test]
    fn unreferenced_vertex_has_no_neighbours() {
        let adj = Adjacency::from_faces(5, &[[0, 1, 2]]);
        assert_eq!(adj.degree(4), 0);
        assert_eq!(adj.degree(3), 0);
        assert_eq!(adj.n_edges(), 3);
    }
}
