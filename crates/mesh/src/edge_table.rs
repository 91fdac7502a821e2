//! Grouping of the directed face edges ("corners") of a triangle soup by the
//! undirected edge they lie on. Validation, orientation and the half-edge build
//! all start from this table.
//!
//! Corner `c = 3 f + k` stands for the directed edge from `faces[f][k]` to
//! `faces[f][(k + 1) % 3]`. Corners on the same undirected edge are stored next to
//! each other. The build is a counting sort by the smaller endpoint followed by a
//! sort of each (small) bucket, so it runs in O(F log d) for largest degree d,
//! with no hashing and a deterministic result.

/// Marker for "no corner", "no face", "no vertex".
pub const NONE: u32 = u32::MAX;

/// Corners grouped by undirected edge. Self-loop corners (a face that repeats a
/// vertex) belong to no group.
#[derive(Debug, Clone)]
pub struct EdgeTable {
    /// Corner ids, grouped by undirected edge; groups sorted by (min, max) vertex.
    pub corners: Vec<u32>,
    /// Group `e` is `corners[group_offsets[e]..group_offsets[e + 1]]`.
    pub group_offsets: Vec<u32>,
}

/// Tail and head vertex of corner `c`.
#[inline]
pub fn corner_endpoints(faces: &[[u32; 3]], c: u32) -> (u32, u32) {
    let f = (c / 3) as usize;
    let k = (c % 3) as usize;
    (faces[f][k], faces[f][(k + 1) % 3])
}

impl EdgeTable {
    /// Builds the table for `faces` over `n_vertices` vertices (indices must be in range).
    pub fn new(n_vertices: usize, faces: &[[u32; 3]]) -> EdgeTable {
        let n_corners = faces.len() * 3;
        assert!(n_corners < NONE as usize, "too many faces for 32-bit corner ids");
        // Counting sort of corners by their smaller endpoint.
        let mut bucket = vec![0u32; n_vertices + 1];
        for f in faces {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                if a != b {
                    bucket[a.min(b) as usize + 1] += 1;
                }
            }
        }
        for v in 0..n_vertices {
            bucket[v + 1] += bucket[v];
        }
        // Each entry packs (larger endpoint, corner id) into one u64, so that a
        // plain integer sort of a bucket orders it by edge and then by corner.
        let mut fill = bucket.clone();
        let mut keys = vec![0u64; bucket[n_vertices] as usize];
        for (fi, f) in faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                if a != b {
                    let slot = &mut fill[a.min(b) as usize];
                    keys[*slot as usize] = (u64::from(a.max(b)) << 32) | (3 * fi + k) as u64;
                    *slot += 1;
                }
            }
        }
        let mut group_offsets = Vec::with_capacity(keys.len() / 2 + 1);
        group_offsets.push(0u32);
        for v in 0..n_vertices {
            let (lo, hi) = (bucket[v] as usize, bucket[v + 1] as usize);
            let run = &mut keys[lo..hi];
            if run.len() <= 16 {
                insertion_sort(run);
            } else {
                run.sort_unstable();
            }
            for i in lo + 1..=hi {
                if i == hi || keys[i] >> 32 != keys[i - 1] >> 32 {
                    group_offsets.push(i as u32);
                }
            }
        }
        let sorted = keys.iter().map(|&k| k as u32).collect();
        EdgeTable { corners: sorted, group_offsets }
    }

    /// Number of undirected edges.
    pub fn n_edges(&self) -> usize {
        self.group_offsets.len() - 1
    }

    /// The corners on undirected edge `e`.
    #[inline]
    pub fn group(&self, e: usize) -> &[u32] {
        &self.corners[self.group_offsets[e] as usize..self.group_offsets[e + 1] as usize]
    }
}

/// Buckets hold a vertex's edges to higher-numbered neighbours: a handful, for
/// which insertion sort beats the general sort.
fn insertion_sort(run: &mut [u64]) {
    for i in 1..run.len() {
        let x = run[i];
        let mut j = i;
        while j > 0 && run[j - 1] > x {
            run[j] = run[j - 1];
            j -= 1;
        }
        run[j] = x;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tetrahedron_has_six_edges_of_two_corners() {
        let faces = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let table = EdgeTable::new(4, &faces);
        assert_eq!(table.n_edges(), 6);
        for e in 0..6 {
            let g = table.group(e);
            assert_eq!(g.len(), 2);
            let (a, b) = corner_endpoints(&faces, g[0]);
            let (c, d) = corner_endpoints(&faces, g[1]);
            assert_eq!((a, b), (d, c), "consistently oriented: opposite directions");
        }
    }

    #[test]
    fn self_loops_are_left_out() {
        let faces = [[0, 0, 1]];
        let table = EdgeTable::new(2, &faces);
        assert_eq!(table.n_edges(), 1);
        assert_eq!(table.group(0).len(), 2);
    }
}
