//! Pole selection for the theta-phi method (thesis 6.2.1-6.2.3).
//!
//! * [`physical`]: the farthest pair of vertices in space (eq. 6.1-6.2), found
//!   exactly without the O(N^2) double loop of the thesis: a few farthest-point
//!   sweeps give a long pair (p, q), and [`farthest_pair`] (a k-d tree search
//!   from each vertex that can still beat it) finishes. O(N log N) in
//!   practice, round shapes included.
//! * [`graph`]: the exact graph diameter (eq. 6.5) by Dijkstra from every vertex,
//!   in parallel. O(N^2 log N): minutes for 10^5 vertices.
//! * [`fast_graph`]: two Dijkstra sweeps (eq. 6.6-6.7, after Brechbuehler et al.).

mod farthest_pair;

use farthest_pair::{farthest_pair, Pair};
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
    let start = Pair { lo: a.min(b), hi: a.max(b), length2: best };
    let pair = farthest_pair(positions, start, centre);
    Some(Poles { north: pair.lo, south: pair.hi, distance: pair.length2.sqrt() })
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
    use super::farthest_pair::{farthest_pair, Pair};
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

    #[test]
    fn physical_matches_brute_force_on_awkward_sets() {
        // Bumpy spheres far from the origin, points at the centre, two
        // clusters, a segment, repeated points: every branch of the search.
        let mut rng = Lcg::new(29);
        for trial in 0..40 {
            let n = 200 + 97 * trial;
            let family = trial % 5;
            let shift = [0.0, 1e3, 1e6, 1e9][trial % 4];
            let mut p: Vec<[f64; 3]> = (0..n)
                .map(|i| {
                    let v = [rng.next_f64() - 0.5, rng.next_f64() - 0.5, rng.next_f64() - 0.5];
                    let r = dist2(v, [0.0; 3]).sqrt().max(1e-9);
                    let u = [v[0] / r, v[1] / r, v[2] / r];
                    let s = match family {
                        0 => 1.0 + 0.05 * rng.next_f64(),         // a bumpy sphere
                        1 if i % 7 == 0 => 1e-3 * rng.next_f64(), // some points at the centre
                        1 => 1.0,
                        2 => 0.1 * rng.next_f64(), // two small clusters far apart
                        3 => 1.0,                  // a segment (below)
                        _ => 1.0,                  // (repeated below)
                    };
                    let mut q = [s * u[0], s * u[1], s * u[2]];
                    if family == 2 {
                        q[0] += if i % 2 == 0 { 5.0 } else { -5.0 };
                    }
                    if family == 3 {
                        q = [rng.next_f64(), 0.0, 0.0];
                    }
                    [q[0] + shift, q[1] - shift, q[2] + 0.5 * shift]
                })
                .collect();
            if family == 4 {
                let copies: Vec<[f64; 3]> = p.iter().step_by(3).copied().collect();
                p.extend(copies);
            }
            let poles = physical(&p).unwrap();
            let (i, j, d) = brute_force(&p);
            assert_eq!(
                (poles.north, poles.south, poles.distance),
                (i, j, d.sqrt()),
                "trial {trial}"
            );
        }
    }

    #[test]
    fn farthest_pair_is_exact_from_any_start_and_centre() {
        // The bound holds for any centre and any start pair, however poor:
        // a centre outside the set, on a point, or far away makes points
        // central, or as far from the centre as the pair is long.
        let mut rng = Lcg::new(41);
        for trial in 0..300 {
            let n = 2 + trial % 150;
            let p: Vec<[f64; 3]> = (0..n)
                .map(|_| {
                    let v = [rng.next_f64() - 0.5, rng.next_f64() - 0.5, rng.next_f64() - 0.5];
                    let r = if trial % 2 == 0 { dist2(v, [0.0; 3]).sqrt() } else { 1.0 };
                    [v[0] / r, 0.3 * v[1] / r, v[2] / r]
                })
                .collect();
            let (a, b) = ((trial * 7) % n, (trial * 13 + 1) % n);
            let start =
                Pair { lo: a.min(b) as u32, hi: a.max(b) as u32, length2: dist2(p[a], p[b]) };
            let centre = match trial % 3 {
                0 => p[trial % n],
                1 => [3.0 * rng.next_f64(), -2.0, 0.5],
                _ => [0.0; 3],
            };
            let got = farthest_pair(&p, start, centre);
            let (i, j, d) = brute_force(&p);
            let want = if a == b && d == 0.0 { (start.lo, start.hi, 0.0) } else { (i, j, d) };
            assert_eq!((got.lo, got.hi, got.length2), want, "trial {trial}");
        }
    }

    #[test]
    fn physical_on_round_shapes_matches_brute_force() {
        // Large round point sets: every point is a candidate, and exact ties
        // (centrally symmetric sets) must go to the smallest index pair.
        let mut rng = Lcg::new(11);
        for (trial, n) in [400usize, 1500, 3000].into_iter().enumerate() {
            let mut p: Vec<[f64; 3]> = (0..n)
                .map(|_| {
                    let v = [rng.next_f64() - 0.5, rng.next_f64() - 0.5, rng.next_f64() - 0.5];
                    let r = dist2(v, [0.0; 3]).sqrt();
                    [v[0] / r, v[1] / r, v[2] / r]
                })
                .collect();
            if trial > 0 {
                // Add the antipode of every point: many pairs of length exactly 2.
                let mirrored: Vec<[f64; 3]> = p.iter().map(|v| [-v[0], -v[1], -v[2]]).collect();
                p.extend(mirrored);
            }
            let poles = physical(&p).unwrap();
            let (i, j, d) = brute_force(&p);
            assert_eq!((poles.north, poles.south, poles.distance), (i, j, d.sqrt()), "n {n}");
        }
        // The eight corners of a cube: four diagonals of the same length.
        let cube: Vec<[f64; 3]> = (0..8)
            .map(|k| [(k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64])
            .collect();
        let poles = physical(&cube).unwrap();
        assert_eq!((poles.north, poles.south), (0, 7));
        // The sweeps from point 0 end on the diagonal (3, 4); the other
        // diagonal, (1, 2), is exactly as long and has smaller indices.
        let square =
            [[0.0, 0.5, 0.0], [1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0]];
        let poles = physical(&square).unwrap();
        assert_eq!((poles.north, poles.south, poles.distance), (1, 2, 2.0));
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
