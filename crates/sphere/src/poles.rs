//! Pole selection for the theta-phi method (thesis 6.2.1-6.2.3).
//!
//! * [`physical`]: the farthest pair of vertices in space (eq. 6.1-6.2), found
//!   exactly without the O(N^2) double loop of the thesis: after a few
//!   farthest-point sweeps give a long pair (p, q) of length d, a pair longer
//!   than d needs |x - c| + |y - c| > d for the midpoint c, so only vertices far
//!   from c can take part; those are scanned in order of decreasing |x - c| with
//!   the bound |x - c| + |y - c| cutting each scan short. Exact; O(N log N) in
//!   practice, O(N^2) only for point sets whose far points all lie on a sphere
//!   around c much larger than the rest.
//! * [`graph`]: the exact graph diameter (eq. 6.5) by Dijkstra from every vertex,
//!   in parallel. O(N^2 log N): minutes for 10^5 vertices.
//! * [`fast_graph`]: two Dijkstra sweeps (eq. 6.6-6.7, after Brechbuehler et al.).

use rayon::prelude::*;
use spherify_mesh::dijkstra::{dijkstra, EdgeWeights};
use spherify_mesh::Adjacency;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// A pole pair and how far apart it is (in the measure that chose it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Poles {
    pub north: u32,
    pub south: u32,
    pub distance: f64,
}

fn dist2(a: [f64; 3], b: [f64; 3]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)
}

/// Farthest vertex from `from`; ties go to the smaller index.
fn farthest_point(positions: &[[f64; 3]], from: [f64; 3]) -> (u32, f64) {
    let mut best = (0u32, -1.0);
    for (i, &p) in positions.iter().enumerate() {
        let d = dist2(p, from);
        if d > best.1 {
            best = (i as u32, d);
        }
    }
    best
}

/// The exact farthest pair of `positions` (thesis 6.2.1), ties broken towards
/// smaller indices. Needs at least two points.
pub fn physical(positions: &[[f64; 3]]) -> Option<Poles> {
    if positions.len() < 2 {
        return None;
    }
    // A few sweeps: each farthest-point step can only lengthen the pair.
    let (mut a, _) = farthest_point(positions, positions[0]);
    let (mut b, mut best) = farthest_point(positions, positions[a as usize]);
    for _ in 0..4 {
        let (c, d) = farthest_point(positions, positions[b as usize]);
        if d <= best {
            break;
        }
        (a, b, best) = (b, c, d);
    }
    let (pa, pb) = (positions[a as usize], positions[b as usize]);
    let centre = [(pa[0] + pb[0]) / 2.0, (pa[1] + pb[1]) / 2.0, (pa[2] + pb[2]) / 2.0];
    let mut by_reach: Vec<(f64, u32)> =
        positions.iter().enumerate().map(|(i, &p)| (dist2(p, centre).sqrt(), i as u32)).collect();
    by_reach.sort_unstable_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
    let r_max = by_reach[0].0;
    let mut pair = (a.min(b), a.max(b), best);
    // Rounding in the radii must not prune a true winner: widen the bound a little.
    let slack = 1.0 + 1e-12;
    for (k, &(rx, x)) in by_reach.iter().enumerate() {
        if (rx + r_max) * slack < pair.2.sqrt() {
            break;
        }
        for &(ry, y) in &by_reach[k + 1..] {
            if (rx + ry) * slack < pair.2.sqrt() {
                break;
            }
            let d = dist2(positions[x as usize], positions[y as usize]);
            let (lo, hi) = (x.min(y), x.max(y));
            if d > pair.2 || (d == pair.2 && (lo, hi) < (pair.0, pair.1)) {
                pair = (lo, hi, d);
            }
        }
    }
    Some(Poles { north: pair.0, south: pair.1, distance: pair.2.sqrt() })
}

/// Two sweeps (thesis eq. 6.6-6.7): the farthest vertex n from `start`, then the
/// farthest vertex s from n. Returns `None` for an out-of-range start.
pub fn fast_graph(graph: &Adjacency, start: u32, weights: EdgeWeights) -> Option<Poles> {
    fast_graph_with_path(graph, start, weights).map(|(poles, _)| poles)
}

/// [`fast_graph`] and a shortest path from n to s, both included: the one
/// the second sweep's tree holds, which is the path a search from n stopped
/// at s finds (a search settles the same vertices in the same order up to s,
/// and a settled vertex's predecessor never changes), so the cut path
/// (6.2.4) costs no third search.
pub fn fast_graph_with_path(
    graph: &Adjacency,
    start: u32,
    weights: EdgeWeights,
) -> Option<(Poles, Vec<u32>)> {
    let first = dijkstra(graph, start, weights)?;
    let (north, _) = first.farthest()?;
    drop(first);
    let second = dijkstra(graph, north, weights)?;
    let (south, distance) = second.farthest()?;
    let path = second.path_to(south)?;
    Some((Poles { north, south, distance }, path))
}

/// [`graph`] stopped early because its progress callback returned `false`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cancelled {
    /// Sources finished when it stopped.
    pub done: usize,
    pub total: usize,
}

/// The exact graph diameter (thesis eq. 6.5): Dijkstra from every vertex, in
/// parallel. `progress(done, total)` is called as sources finish (from worker
/// threads, in no particular order of `done`; keep it cheap). When it returns
/// `false`, no further source is started and the call ends with [`Cancelled`]
/// once the running ones finish (one Dijkstra each, O(N log N)). Ties go to
/// the lexicographically smallest pair.
pub fn graph(
    graph: &Adjacency,
    weights: EdgeWeights,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<Option<Poles>, Cancelled> {
    let n = graph.n_vertices();
    let done = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let best = (0..n as u32)
        .into_par_iter()
        .filter_map(|source| {
            // rayon offers no early exit from a parallel reduction; skipping
            // the remaining sources costs one load each.
            if stop.load(Ordering::Relaxed) {
                return None;
            }
            let paths = dijkstra(graph, source, weights)?;
            // Farthest reachable vertex with a larger index: each pair counted once.
            let mut best: Option<(u32, f64)> = None;
            for (v, &d) in paths.distances.iter().enumerate().skip(source as usize + 1) {
                if d.is_finite() && best.is_none_or(|(_, b)| d > b) {
                    best = Some((v as u32, d));
                }
            }
            if !progress(done.fetch_add(1, Ordering::Relaxed) + 1, n) {
                stop.store(true, Ordering::Relaxed);
            }
            best.map(|(v, d)| Poles { north: source, south: v, distance: d })
        })
        .reduce_with(|p, q| {
            if q.distance > p.distance
                || (q.distance == p.distance && (q.north, q.south) < (p.north, p.south))
            {
                q
            } else {
                p
            }
        });
    if stop.load(Ordering::Relaxed) {
        return Err(Cancelled { done: done.load(Ordering::Relaxed), total: n });
    }
    Ok(best)
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::lcg::Lcg;

    fn brute_force(p: &[[f64; 3]]) -> (u32, u32, f64) {
        let mut best = (0, 0, -1.0);
        for i in 0..p.len() {
            for j in i + 1..p.len() {
                let d = dist2(p[i], p[j]);
                if d > best.2 {
                    best = (i as u32, j as u32, d);
                }
            }
        }
        best
    }

    #[test]
    fn physical_matches_brute_force() {
        let mut rng = Lcg::new(7);
        for trial in 0..200 {
            let n = 2 + trial % 60;
            let shape = [1.0 + 3.0 * rng.next_f64(), 1.0, 0.2 + rng.next_f64()];
            let p: Vec<[f64; 3]> = (0..n)
                .map(|_| {
                    let mut v = [rng.next_f64() - 0.5, rng.next_f64() - 0.5, rng.next_f64() - 0.5];
                    if trial % 3 == 0 {
                        // Points on a sphere: the hard case for pruning.
                        let r = dist2(v, [0.0; 3]).sqrt();
                        v = [v[0] / r, v[1] / r, v[2] / r];
                    }
                    [v[0] * shape[0], v[1] * shape[1], v[2] * shape[2]]
                })
                .collect();
            let poles = physical(&p).unwrap();
            let (i, j, d) = brute_force(&p);
            assert_eq!(poles.distance, d.sqrt(), "trial {trial}");
            assert_eq!((poles.north, poles.south), (i, j), "trial {trial}");
        }
        assert!(physical(&[[0.0; 3]]).is_none());
    }

    /// A path graph 0 - 1 - ... - (n-1) with a spur: diameter between the ends.
    fn path_with_spur(n: usize) -> Adjacency {
        // Degenerate "faces" (a, b, b) contribute just the edge a - b.
        let mut faces: Vec<[u32; 3]> = (0..n as u32 - 1).map(|i| [i, i + 1, i + 1]).collect();
        faces.push([2, n as u32, n as u32]);
        Adjacency::from_faces(n + 1, &faces)
    }

    #[test]
    fn graph_diameter_and_two_sweeps() {
        let adj = path_with_spur(10);
        let exact = graph(&adj, EdgeWeights::Uniform, &|_, _| true).unwrap().unwrap();
        assert_eq!((exact.north, exact.south, exact.distance), (0, 9, 9.0));
        let fast = fast_graph(&adj, 5, EdgeWeights::Uniform).unwrap();
        assert_eq!(fast.distance, 9.0);
        let calls = AtomicUsize::new(0);
        let seen = std::sync::Mutex::new(Vec::new());
        graph(&adj, EdgeWeights::Uniform, &|done, total| {
            assert_eq!(total, 11);
            calls.fetch_add(1, Ordering::Relaxed);
            seen.lock().unwrap().push(done);
            true
        })
        .unwrap();
        assert_eq!(calls.load(Ordering::Relaxed), 11);
        let mut seen = seen.into_inner().unwrap();
        seen.sort();
        assert_eq!(seen, (1..=11).collect::<Vec<_>>());
        assert!(fast_graph(&adj, 99, EdgeWeights::Uniform).is_none());
    }

    #[test]
    fn graph_stops_when_progress_says_so() {
        let adj = path_with_spur(2000);
        let calls = AtomicUsize::new(0);
        let stopped = graph(&adj, EdgeWeights::Uniform, &|done, _| {
            calls.fetch_add(1, Ordering::Relaxed);
            done < 10
        });
        let Err(Cancelled { done, total }) = stopped else {
            panic!("expected Cancelled, got {stopped:?}");
        };
        assert_eq!(total, 2001);
        // Sources already running when the flag went up still finish, one
        // per worker thread at most.
        let workers = rayon::current_num_threads();
        assert!((10..10 + workers).contains(&done), "done {done} with {workers} threads");
        assert_eq!(calls.load(Ordering::Relaxed), done);
    }
}
