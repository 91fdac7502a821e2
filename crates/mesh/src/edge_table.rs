//! Grouping of the directed face edges ("corners") of a triangle soup by the
//! undirected edge they lie on. Validation, orientation and the half-edge build
//! all start from this table.
//!
//! Corner `c = 3 f + k` stands for the directed edge from `faces[f][k]` to
//! `faces[f][(k + 1) % 3]`. Corners on the same undirected edge are stored next to
//! each other. The build is a counting sort by the smaller endpoint followed by a
//! sort of each (small) bucket, so it runs in O(F log d) for largest degree d,
//! with no hashing and a deterministic result.

use rayon::prelude::*;

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
    ///
    /// Each range of [`vertex_ranges`] sorts the corners whose smaller
    /// endpoint it holds, in parallel: it scans every face (a sequential
    /// read) and writes only its own buckets, which lie next to each other.
    /// A bucket's order is (larger endpoint, corner id), unique, so the table
    /// is the same for every number of ranges (issue 27: the serial build was
    /// 0.08 s of the 1M-vertex default map's validation, the other core idle).
    pub fn new(n_vertices: usize, faces: &[[u32; 3]]) -> EdgeTable {
        EdgeTable::by_ranges(faces, &vertex_ranges(n_vertices, faces.len()))
    }

    /// [`EdgeTable::new`] with the vertex ranges given (they must cover the
    /// vertices in order).
    fn by_ranges(faces: &[[u32; 3]], ranges: &[std::ops::Range<usize>]) -> EdgeTable {
        let n_corners = faces.len() * 3;
        assert!(n_corners < NONE as usize, "too many faces for 32-bit corner ids");
        // Each range's bucket offsets, from its own first bucket, by a
        // counting pass over all faces.
        let starts: Vec<Vec<u32>> = ranges
            .par_iter()
            .map(|range| {
                let mut start = vec![0u32; range.len() + 1];
                for_each_edge(faces, range, |low, _| start[low + 1] += 1);
                for v in 0..range.len() {
                    start[v + 1] += start[v];
                }
                start
            })
            .collect();
        let mut keys = vec![0u64; starts.iter().map(|s| s[s.len() - 1] as usize).sum()];
        let mut slices = Vec::with_capacity(ranges.len());
        let mut rest = keys.as_mut_slice();
        let mut base = 0u32;
        for start in &starts {
            let (mine, others) = rest.split_at_mut(start[start.len() - 1] as usize);
            slices.push((mine, base));
            base += start[start.len() - 1];
            rest = others;
        }
        let group_ends: Vec<Vec<u32>> = slices
            .into_par_iter()
            .zip(ranges.par_iter().zip(&starts))
            .map(|((keys, base), (range, start))| {
                // Each entry packs (larger endpoint, corner id) into one u64, so
                // that a plain integer sort of a bucket orders it by edge and
                // then by corner.
                let mut fill = start.clone();
                for_each_edge(faces, range, |low, key| {
                    keys[fill[low] as usize] = key;
                    fill[low] += 1;
                });
                let mut ends = Vec::with_capacity(keys.len() / 2);
                for v in 0..range.len() {
                    let (lo, hi) = (start[v] as usize, start[v + 1] as usize);
                    let run = &mut keys[lo..hi];
                    if run.len() <= 16 {
                        insertion_sort(run);
                    } else {
                        run.sort_unstable();
                    }
                    for i in lo + 1..=hi {
                        if i == hi || keys[i] >> 32 != keys[i - 1] >> 32 {
                            ends.push(base + i as u32);
                        }
                    }
                }
                ends
            })
            .collect();
        let mut group_offsets =
            Vec::with_capacity(group_ends.iter().map(Vec::len).sum::<usize>() + 1);
        group_offsets.push(0u32);
        for ends in &group_ends {
            group_offsets.extend_from_slice(ends);
        }
        let corners = keys.par_iter().map(|&k| k as u32).collect();
        EdgeTable { corners, group_offsets }
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

/// Consecutive ranges of vertex ids, one per worker thread on meshes large
/// enough to pay for the extra scans of the faces (one range below 32k
/// faces).
pub fn vertex_ranges(n_vertices: usize, n_faces: usize) -> Vec<std::ops::Range<usize>> {
    let parts = if n_faces < 1 << 15 { 1 } else { rayon::current_num_threads().clamp(1, 16) };
    split_ranges(n_vertices, parts)
}

/// `0..n` cut into at most `parts` consecutive ranges of equal length (the
/// last shorter); none when `n` is 0.
pub fn split_ranges(n: usize, parts: usize) -> Vec<std::ops::Range<usize>> {
    let step = n.div_ceil(parts.max(1)).max(1);
    (0..n).step_by(step).map(|a| a..(a + step).min(n)).collect()
}

/// Calls `each(low - range.start, key)` for every non-loop corner, in corner
/// order, whose smaller endpoint `low` is in `range`; `key` packs its larger
/// endpoint and its corner id.
fn for_each_edge(
    faces: &[[u32; 3]],
    range: &std::ops::Range<usize>,
    mut each: impl FnMut(usize, u64),
) {
    for (fi, f) in faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            let low = a.min(b) as usize;
            if a != b && range.contains(&low) {
                each(low - range.start, (u64::from(a.max(b)) << 32) | (3 * fi + k) as u64);
            }
        }
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

    /// Every non-loop corner's (smaller endpoint, larger endpoint, corner),
    /// sorted: the table's corners in order, and its groups' sizes.
    fn reference(faces: &[[u32; 3]]) -> (Vec<u32>, Vec<usize>) {
        let mut all = Vec::new();
        for (fi, f) in faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                if a != b {
                    all.push((a.min(b), a.max(b), (3 * fi + k) as u32));
                }
            }
        }
        all.sort_unstable();
        let mut sizes = Vec::new();
        for (i, x) in all.iter().enumerate() {
            if i == 0 || (all[i - 1].0, all[i - 1].1) != (x.0, x.1) {
                sizes.push(0);
            }
            *sizes.last_mut().unwrap() += 1;
        }
        (all.iter().map(|x| x.2).collect(), sizes)
    }

    #[test]
    fn any_split_into_vertex_ranges_gives_the_reference_table() {
        // A soup with repeated, looped, non-manifold and isolated elements.
        let mut rng = crate::lcg::Lcg::new(7);
        let n = 300;
        let faces: Vec<[u32; 3]> = (0..2000).map(|_| [0; 3].map(|_| rng.below(n) as u32)).collect();
        let (corners, sizes) = reference(&faces);
        for parts in [1, 2, 3, 7, 300, 301] {
            let table = EdgeTable::by_ranges(&faces, &split_ranges(n, parts));
            assert_eq!(table.corners, corners, "{parts} ranges");
            let got: Vec<usize> = (0..table.n_edges()).map(|e| table.group(e).len()).collect();
            assert_eq!(got, sizes, "{parts} ranges");
        }
        let table = EdgeTable::new(n, &faces);
        assert_eq!(table.corners, corners);
    }

    #[test]
    fn self_loops_are_left_out() {
        let faces = [[0, 0, 1]];
        let table = EdgeTable::new(2, &faces);
        assert_eq!(table.n_edges(), 1);
        assert_eq!(table.group(0).len(), 2);
    }
}
