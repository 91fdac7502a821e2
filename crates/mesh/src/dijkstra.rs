//! Single-source shortest paths on the vertex graph (thesis Appendix A, Alg. A.1).
//!
//! The thesis keeps every vertex in a priority queue and decreases keys in place.
//! Here the queue is a [`BinaryHeap`] with lazy deletion: an improved distance is
//! pushed as a new entry and stale entries are skipped when they surface. That is
//! O((V + E) log V) time and needs no decrease-key operation.
//!
//! Determinism: entries are ordered by (distance, vertex index), so among equal
//! distances the smaller vertex index is settled first (Figure A.1 settles vertex 3
//! before vertex 5 for the same reason), and a predecessor is only replaced by a
//! strictly shorter path. The same graph and weights therefore give the same
//! distances and predecessors bit for bit.

use crate::graph::Adjacency;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Marks "no vertex": the predecessor of the source and of unreachable vertices.
pub const NO_VERTEX: u32 = u32::MAX;

/// The weight rho_uz of each edge (thesis App. A: weights must be positive; without
/// weights every edge counts 1).
#[derive(Debug, Clone, Copy)]
pub enum EdgeWeights<'a> {
    /// Every edge has length 1: distances count edges (graph distance, thesis 2.1).
    Uniform,
    /// Euclidean edge length from vertex positions, one `[x, y, z]` per vertex.
    /// Zero-length edges are allowed. An edge whose length is NaN or infinite
    /// (non-finite coordinates) never shortens a path, so it acts as absent.
    Length(&'a [[f64; 3]]),
}

impl EdgeWeights<'_> {
    fn weight(&self, u: usize, z: usize) -> f64 {
        match self {
            EdgeWeights::Uniform => 1.0,
            EdgeWeights::Length(p) => {
                let (a, b) = (p[u], p[z]);
                // Scaled by the largest component so that squaring neither
                // overflows (coordinates near 1e154) nor underflows.
                let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
                let m = d.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                if m == 0.0 || !m.is_finite() {
                    return m;
                }
                let s = [d[0] / m, d[1] / m, d[2] / m];
                m * (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt()
            }
        }
    }
}

/// Distances and a shortest-path tree from one source vertex.
#[derive(Debug, Clone, PartialEq)]
pub struct ShortestPaths {
    /// `distances[u]`: length of a shortest source-u path; `f64::INFINITY` if u is
    /// unreachable. The source has distance 0.
    pub distances: Vec<f64>,
    /// `predecessors[u]`: the vertex before u on the chosen shortest path;
    /// [`NO_VERTEX`] for the source and for unreachable vertices.
    pub predecessors: Vec<u32>,
}

impl ShortestPaths {
    /// The shortest path from the source to `target`, both included, following
    /// the predecessors (the "labelling scheme" of App. A). `None` if `target` is
    /// out of range or unreachable. O(path length).
    pub fn path_to(&self, target: u32) -> Option<Vec<u32>> {
        let d = *self.distances.get(target as usize)?;
        if !d.is_finite() {
            return None;
        }
        let mut path = vec![target];
        let mut v = target;
        // A tree has at most n - 1 edges; the bound also guards against a
        // hand-built predecessor array that contains a cycle.
        while let Some(&p) = self.predecessors.get(v as usize) {
            if p == NO_VERTEX {
                path.reverse();
                return Some(path);
            }
            if path.len() > self.predecessors.len() {
                return None;
            }
            path.push(p);
            v = p;
        }
        None
    }

    /// The reachable vertex farthest from the source and its distance; ties go to
    /// the smallest index. `None` only if no vertex is reachable, which cannot
    /// happen for a result of [`dijkstra`] (the source is at distance 0). O(V).
    /// The theta-phi method uses this to pick poles far apart (thesis 6.2).
    pub fn farthest(&self) -> Option<(u32, f64)> {
        let mut best: Option<(u32, f64)> = None;
        for (v, &d) in self.distances.iter().enumerate() {
            if d.is_finite() && best.is_none_or(|(_, b)| d > b) {
                best = Some((v as u32, d));
            }
        }
        best
    }
}

/// A heap entry ordered so that [`BinaryHeap`] (a max-heap) pops the smallest
/// distance first, and among equal distances the smallest vertex index.
#[derive(Debug, Clone, Copy)]
struct Entry {
    dist: f64,
    vertex: u32,
}

impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        // total_cmp gives f64 a total order, so Ord is lawful even for odd values.
        other.dist.total_cmp(&self.dist).then_with(|| other.vertex.cmp(&self.vertex))
    }
}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl PartialEq for Entry {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Entry {}

/// Distances from `source` to every vertex of `graph` (thesis Alg. A.1), with the
/// predecessors of a shortest-path tree. O((V + E) log V) time, O(V + E) memory.
///
/// The caller is expected to pass `source < graph.n_vertices()` and, for
/// [`EdgeWeights::Length`], one position per vertex. Instead of panicking, the
/// function returns `None` if the source is out of range, the positions do not
/// have one entry per vertex, or the graph itself is malformed (a row of
/// `offsets` out of bounds or a neighbour index out of range; only rows that the
/// search reaches are looked at).
pub fn dijkstra(graph: &Adjacency, source: u32, weights: EdgeWeights) -> Option<ShortestPaths> {
    search(graph, source, None, weights)
}

/// The distance from `source` to `target` and a shortest path (both ends
/// included), stopping as soon as `target` is settled (Alg. A.1 removes it from
/// the queue with its final distance). `None` if `target` is unreachable or any
/// input is invalid in the sense of [`dijkstra`] (or `target` is out of range).
pub fn dijkstra_to(
    graph: &Adjacency,
    source: u32,
    target: u32,
    weights: EdgeWeights,
) -> Option<(f64, Vec<u32>)> {
    let n = graph.offsets.len().saturating_sub(1);
    if target as usize >= n {
        return None;
    }
    let paths = search(graph, source, Some(target), weights)?;
    let path = paths.path_to(target)?;
    Some((paths.distances[target as usize], path))
}

/// The neighbours of `v`, or `None` if the CSR arrays are inconsistent there.
fn row(graph: &Adjacency, v: usize) -> Option<&[u32]> {
    let (start, end) = (*graph.offsets.get(v)?, *graph.offsets.get(v + 1)?);
    graph.neighbors.get(start..end)
}

fn search(
    graph: &Adjacency,
    source: u32,
    stop_at: Option<u32>,
    weights: EdgeWeights,
) -> Option<ShortestPaths> {
    let n = graph.offsets.len().saturating_sub(1);
    if source as usize >= n {
        return None;
    }
    if let EdgeWeights::Length(p) = weights {
        if p.len() != n {
            return None;
        }
    }
    // Step 1: d(source) = 0, every other d = infinity.
    let mut distances = vec![f64::INFINITY; n];
    let mut predecessors = vec![NO_VERTEX; n];
    let mut settled = vec![false; n];
    distances[source as usize] = 0.0;
    let mut queue = BinaryHeap::new();
    queue.push(Entry { dist: 0.0, vertex: source });
    // Step 3: settle the closest unsettled vertex, then relax its edges (A.1).
    while let Some(Entry { dist, vertex }) = queue.pop() {
        let u = vertex as usize;
        if settled[u] {
            continue; // a stale entry left behind by a later improvement
        }
        settled[u] = true;
        if stop_at == Some(vertex) {
            break;
        }
        for &z in row(graph, u)? {
            let zi = z as usize;
            if zi >= n {
                return None;
            }
            if settled[zi] {
                continue;
            }
            let candidate = dist + weights.weight(u, zi);
            // Strict `<`: the first path found keeps an equal-length tie, and a
            // NaN candidate never wins.
            if candidate < distances[zi] {
                distances[zi] = candidate;
                predecessors[zi] = vertex;
                queue.push(Entry { dist: candidate, vertex: z });
            }
        }
    }
    Some(ShortestPaths { distances, predecessors })
}

#[cfg(test)]
mod tests {
    #[test]
    fn huge_edges_keep_their_length() {
        let p = [[0.0, 0.0, 0.0], [1e155, 0.0, 0.0], [0.0, 3e200, 4e200]];
        let w = super::EdgeWeights::Length(&p);
        assert_eq!(w.weight(0, 1), 1e155);
        assert!((w.weight(0, 2) / 5e200 - 1.0).abs() < 1e-15);
        let tiny = [[0.0, 0.0, 0.0], [3e-200, 4e-200, 0.0]];
        assert!((super::EdgeWeights::Length(&tiny).weight(0, 1) / 5e-200 - 1.0).abs() < 1e-15);
    }

    use super::*;

    /// An undirected graph from an edge list; neighbours sorted.
    fn graph(n: usize, edges: &[(u32, u32)]) -> Adjacency {
        let mut rows = vec![Vec::new(); n];
        for &(a, b) in edges {
            rows[a as usize].push(b);
            rows[b as usize].push(a);
        }
        let mut offsets = vec![0];
        let mut neighbors = Vec::new();
        for mut r in rows {
            r.sort_unstable();
            neighbors.extend(r);
            offsets.push(neighbors.len());
        }
        Adjacency { offsets, neighbors }
    }

    /// A w-by-h grid graph (4-neighbourhood); vertex (x, y) has index y * w + x.
    fn grid(w: u32, h: u32) -> Adjacency {
        let mut edges = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let v = y * w + x;
                if x + 1 < w {
                    edges.push((v, v + 1));
                }
                if y + 1 < h {
                    edges.push((v, v + w));
                }
            }
        }
        graph((w * h) as usize, &edges)
    }

    /// Every path step is an edge and the Euclidean/unit lengths add up.
    fn check_path(g: &Adjacency, sp: &ShortestPaths, source: u32, target: u32, w: EdgeWeights) {
        let path = sp.path_to(target).unwrap();
        assert_eq!(path[0], source);
        assert_eq!(*path.last().unwrap(), target);
        let mut length = 0.0;
        for pair in path.windows(2) {
            assert!(g.neighbors(pair[0]).contains(&pair[1]));
            length += w.weight(pair[0] as usize, pair[1] as usize);
        }
        assert!((length - sp.distances[target as usize]).abs() < 1e-12);
    }

    #[test]
    fn thesis_figure_a1() {
        // Figure A.1 reconstructed from its table, vertices 1..5 as 0..4: vertex 1
        // reaches only 2; 2 reaches 3 and 5; 3 reaches 4; 5 changes nothing, so
        // its edge to 4 does not shorten anything.
        let g = graph(5, &[(0, 1), (1, 2), (1, 4), (2, 3), (3, 4)]);
        let sp = dijkstra(&g, 0, EdgeWeights::Uniform).unwrap();
        assert_eq!(sp.distances, vec![0.0, 1.0, 2.0, 3.0, 2.0]);
        // Vertex 4 is reached through 3 and through 5 at equal length; 3 is
        // settled first (smaller index), as in the table, so it is the predecessor.
        assert_eq!(sp.predecessors, vec![NO_VERTEX, 0, 1, 2, 1]);
        assert_eq!(sp.path_to(3), Some(vec![0, 1, 2, 3]));
        assert_eq!(sp.farthest(), Some((3, 3.0)));
        assert_eq!(dijkstra_to(&g, 0, 4, EdgeWeights::Uniform), Some((2.0, vec![0, 1, 4])));
    }

    #[test]
    fn grid_uniform_is_manhattan() {
        let (w, h) = (13u32, 9u32);
        let g = grid(w, h);
        let source = 4 * w + 5;
        let sp = dijkstra(&g, source, EdgeWeights::Uniform).unwrap();
        for v in 0..w * h {
            let (x, y) = (v % w, v / w);
            let manhattan = x.abs_diff(5) + y.abs_diff(4);
            assert_eq!(sp.distances[v as usize], manhattan as f64);
            check_path(&g, &sp, source, v, EdgeWeights::Uniform);
        }
        // Corners (0,0), (12,0), (0,8), (12,8) are at 9, 11, 9, 11: tie -> (12,0).
        assert_eq!(sp.farthest(), Some((12, 11.0)));
    }

    #[test]
    fn length_weights_prefer_the_short_detour() {
        // A unit square 0-1-2-3 with a far vertex 4 on the direct route 0-4-2.
        let p =
            [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [5.0, 5.0, 0.0]];
        let g = graph(5, &[(0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (4, 2)]);
        let w = EdgeWeights::Length(&p);
        let sp = dijkstra(&g, 0, w).unwrap();
        assert_eq!(&sp.distances[..4], &[0.0, 1.0, 2.0, 1.0]);
        assert_eq!(sp.distances[4], 50f64.sqrt());
        // Two shortest routes to 2: via 1 and via 3; 1 is settled first.
        assert_eq!(sp.path_to(2), Some(vec![0, 1, 2]));
        for v in 0..5 {
            check_path(&g, &sp, 0, v, w);
        }
        // Uniform weights take the 2-edge route through 4 or 1: tie -> through 1.
        let (d, path) = dijkstra_to(&g, 0, 2, EdgeWeights::Uniform).unwrap();
        assert_eq!((d, path), (2.0, vec![0, 1, 2]));
    }

    #[test]
    fn grid_lengths_match_scaled_manhattan() {
        // A grid with spacing 0.5 in x and 2 in y: every monotone path is shortest.
        let (w, h) = (6u32, 5u32);
        let g = grid(w, h);
        let p: Vec<[f64; 3]> =
            (0..w * h).map(|v| [0.5 * (v % w) as f64, 2.0 * (v / w) as f64, 1.0]).collect();
        let sp = dijkstra(&g, 0, EdgeWeights::Length(&p)).unwrap();
        for v in 0..w * h {
            let expected = 0.5 * (v % w) as f64 + 2.0 * (v / w) as f64;
            assert_eq!(sp.distances[v as usize], expected);
            check_path(&g, &sp, 0, v, EdgeWeights::Length(&p));
        }
    }

    #[test]
    fn disconnected_vertices_are_unreachable() {
        let g = graph(6, &[(0, 1), (1, 2), (3, 4)]);
        let sp = dijkstra(&g, 1, EdgeWeights::Uniform).unwrap();
        assert_eq!(&sp.distances[..3], &[1.0, 0.0, 1.0]);
        for v in 3..6 {
            assert_eq!(sp.distances[v], f64::INFINITY);
            assert_eq!(sp.predecessors[v], NO_VERTEX);
            assert_eq!(sp.path_to(v as u32), None);
        }
        assert_eq!(sp.path_to(1), Some(vec![1]));
        assert_eq!(sp.farthest(), Some((0, 1.0)));
        assert_eq!(dijkstra_to(&g, 0, 4, EdgeWeights::Uniform), None);
        assert_eq!(dijkstra_to(&g, 5, 5, EdgeWeights::Uniform), Some((0.0, vec![5])));
    }

    #[test]
    fn bad_input_gives_none_not_a_panic() {
        let g = graph(3, &[(0, 1), (1, 2)]);
        assert!(dijkstra(&g, 3, EdgeWeights::Uniform).is_none());
        assert!(dijkstra(&g, NO_VERTEX, EdgeWeights::Uniform).is_none());
        assert!(dijkstra_to(&g, 0, 7, EdgeWeights::Uniform).is_none());
        let short = [[0.0; 3]; 2];
        assert!(dijkstra(&g, 0, EdgeWeights::Length(&short)).is_none());
        let broken = Adjacency { offsets: vec![0, 1, 2], neighbors: vec![1, 9] };
        assert!(dijkstra(&broken, 0, EdgeWeights::Uniform).is_none());
        let empty = Adjacency { offsets: vec![], neighbors: vec![] };
        assert!(dijkstra(&empty, 0, EdgeWeights::Uniform).is_none());
        assert_eq!(ShortestPaths { distances: vec![], predecessors: vec![] }.farthest(), None);
        assert_eq!(
            ShortestPaths { distances: vec![0.0], predecessors: vec![NO_VERTEX] }.path_to(1),
            None
        );
    }

    #[test]
    fn deterministic_and_early_stop_agrees() {
        // Irregular positions on a grid with diagonals: many near-ties.
        let (w, h) = (20u32, 15u32);
        let mut edges = Vec::new();
        for y in 0..h - 1 {
            for x in 0..w - 1 {
                let v = y * w + x;
                edges.extend([(v, v + 1), (v, v + w), (v, v + w + 1), (v + 1, v + w)]);
            }
            edges.push((y * w + w - 1, (y + 1) * w + w - 1));
        }
        for x in 0..w - 1 {
            edges.push(((h - 1) * w + x, (h - 1) * w + x + 1));
        }
        let g = graph((w * h) as usize, &edges);
        let mut rng = crate::lcg::Lcg::new(12345);
        let p: Vec<[f64; 3]> = (0..w * h)
            .map(|v| {
                let jitter = rng.next_f64() * 0.1;
                [(v % w) as f64 + jitter, (v / w) as f64, jitter]
            })
            .collect();
        let w8 = EdgeWeights::Length(&p);
        let a = dijkstra(&g, 7, w8).unwrap();
        let b = dijkstra(&g, 7, w8).unwrap();
        assert_eq!(a.predecessors, b.predecessors);
        assert!(a.distances.iter().zip(&b.distances).all(|(x, y)| x.to_bits() == y.to_bits()));
        for t in [0, 55, 299, 150] {
            let (d, path) = dijkstra_to(&g, 7, t, w8).unwrap();
            assert_eq!(d.to_bits(), a.distances[t as usize].to_bits());
            assert_eq!(Some(path), a.path_to(t));
            check_path(&g, &a, 7, t, w8);
        }
    }
}
