//! The progressive mesh (Hoppe 1996; thesis 9.3.3): half-edge collapses down
//! to a tetrahedron, in rounds of independent collapses.
//!
//! Each round scores every vertex `u` by its cheapest legal collapse `u -> v`
//! and makes collapses greedily, cheapest first, skipping any `u` that was
//! in the ring of a vertex already removed in the round. So no vertex
//! removed in a round is a neighbour of another, and each one's ring holds
//! only vertices that outlive the round: when the progressive method undoes
//! the round (last collapse first), every re-inserted vertex can be placed
//! from positions known before the round, all of them in parallel. The
//! stars the round's collapses turn into fans share no face, so the
//! insertions do not disturb one another. The result depends on nothing but
//! the mesh.
//!
//! The score is the quadric error of Garland and Heckbert (1997) accumulated
//! over collapses, plus a small multiple of the squared edge length: flat
//! regions go first, and the tips of limbs and spikes, where the planes
//! disagree, stay until the coarse levels (the flat-to-extrusive order of Hu,
//! Fu and Liu 2018), so that they receive their share of the sphere early. A
//! collapse is skipped when it would turn a surface face over or raise a
//! degree above [`MAX_DEGREE`]; only when no collapse passes these does a
//! round fall back to the link condition alone, which every sphere
//! triangulation but the tetrahedron passes for some edge (Steinitz), so the
//! hierarchy always reaches four vertices.

use rayon::prelude::*;
use spherify_mesh::vec3::{cross, dot, norm, sub, triangle_area};

use super::ring_mesh::{prefetch, Collapse, RingMesh, AHEAD};

/// Degree above which a collapse is only taken when nothing else is left.
const MAX_DEGREE: usize = 12;
/// Weight of the squared edge length (times the mean face area) in the score.
const LENGTH_WEIGHT: f64 = 1e-3;

/// Collapses in the order they were made, grouped in rounds.
#[derive(Debug, Clone, Default)]
pub struct Hierarchy {
    pub collapses: Vec<Collapse>,
    pub rounds: Vec<std::ops::Range<usize>>,
}

/// Bounds of [`Hierarchy::represented_area`]'s ratio: a coarse face aims at
/// most a hundred times more or less sphere than its own surface area.
const REPRESENTED_BOUNDS: (f64, f64) = (1e-2, 1e2);

impl Hierarchy {
    /// For every vertex alive after the first `done` collapses (whose rings
    /// are `rings`): the area of the finest surface it stands for over the
    /// area of its star at that level (a third of its faces' areas); 1 for
    /// removed vertices. Each vertex starts with a third of the area of its
    /// faces on the finest mesh, and a collapse hands what `u` stands for to
    /// the vertices of its ring in equal shares: a limb of many small faces
    /// that the hierarchy has folded into a few large ones still asks for
    /// its whole area on the coarse levels. O(n + collapsed ring sizes).
    pub fn represented_area(
        &self,
        done: usize,
        rings: &[Vec<u32>],
        surface: &[[f64; 3]],
        faces: &[[u32; 3]],
    ) -> Vec<f64> {
        let n = rings.len();
        let mut mass = vec![0.0; n];
        for &[a, b, c] in faces {
            let third =
                triangle_area(surface[a as usize], surface[b as usize], surface[c as usize]) / 3.0;
            for v in [a, b, c] {
                mass[v as usize] += third;
            }
        }
        for c in &self.collapses[..done] {
            let share = mass[c.u as usize] / c.ring.len() as f64;
            mass[c.u as usize] = 0.0;
            for &r in &c.ring {
                mass[r as usize] += share;
            }
        }
        rings
            .par_iter()
            .enumerate()
            .map(|(i, ring)| {
                let m = ring.len();
                if m == 0 {
                    return 1.0;
                }
                let p = surface[i];
                let star: f64 = (0..m)
                    .map(|j| {
                        triangle_area(
                            p,
                            surface[ring[j] as usize],
                            surface[ring[(j + 1) % m] as usize],
                        )
                    })
                    .sum::<f64>()
                    / 3.0;
                let ratio = mass[i] / star;
                if ratio.is_finite() && ratio > 0.0 {
                    ratio.clamp(REPRESENTED_BOUNDS.0, REPRESENTED_BOUNDS.1)
                } else {
                    1.0
                }
            })
            .collect()
    }
}

/// A symmetric 4x4 quadric, upper triangle by rows.
type Quadric = [f64; 10];

fn plane_quadric(p: [f64; 3], q: [f64; 3], r: [f64; 3]) -> Quadric {
    let n = cross(sub(q, p), sub(r, p));
    let twice_area = norm(n);
    if twice_area == 0.0 || !twice_area.is_finite() {
        return [0.0; 10];
    }
    let [a, b, c] = n.map(|x| x / twice_area);
    let d = -(a * p[0] + b * p[1] + c * p[2]);
    let w = 0.5 * twice_area;
    [a * a, a * b, a * c, a * d, b * b, b * c, b * d, c * c, c * d, d * d].map(|x| w * x)
}

fn quadric_at(q: &Quadric, p: [f64; 3]) -> f64 {
    let [x, y, z] = p;
    q[0] * x * x
        + 2.0 * q[1] * x * y
        + 2.0 * q[2] * x * z
        + 2.0 * q[3] * x
        + q[4] * y * y
        + 2.0 * q[5] * y * z
        + 2.0 * q[6] * y
        + q[7] * z * z
        + 2.0 * q[8] * z
        + q[9]
}

/// Whether moving `u` onto `v` keeps every remaining face of `u`'s star from
/// turning over on the surface (and from becoming degenerate).
fn keeps_normals(positions: &[[f64; 3]], u: u32, v: u32, ring: &[u32]) -> bool {
    let m = ring.len();
    let (pu, pv) = (positions[u as usize], positions[v as usize]);
    (0..m).all(|j| {
        let (a, b) = (ring[j], ring[(j + 1) % m]);
        if a == v || b == v {
            return true;
        }
        let (pa, pb) = (positions[a as usize], positions[b as usize]);
        let before = cross(sub(pa, pu), sub(pb, pu));
        let after = cross(sub(pa, pv), sub(pb, pv));
        dot(before, after) > 0.0
    })
}

/// Each vertex's quadric (the sum of its faces' plane quadrics) and the
/// area of its faces, in two arrays written in parallel (a serial copy of
/// the quadrics out of one array of pairs was 80 bytes per vertex).
fn vertex_quadrics(mesh: &RingMesh, positions: &[[f64; 3]]) -> (Vec<Quadric>, Vec<f64>) {
    mesh.rings
        .par_iter()
        .enumerate()
        .map(|(i, ring)| {
            let (mut quadric, mut area) = ([0.0; 10], 0.0);
            let m = ring.len();
            for j in 0..m {
                let [p, a, b] = [
                    positions[i],
                    positions[ring[j] as usize],
                    positions[ring[(j + 1) % m] as usize],
                ];
                for (x, y) in quadric.iter_mut().zip(plane_quadric(p, a, b)) {
                    *x += y;
                }
                area += triangle_area(p, a, b);
            }
            (quadric, area)
        })
        .unzip()
}

/// Collapses `mesh` down to four vertices, calling `report(removed)` after
/// each round; it returns `false` to stop (then `None`).
pub fn decimate(
    mesh: &mut RingMesh,
    positions: &[[f64; 3]],
    report: &mut dyn FnMut(usize) -> bool,
) -> Option<Hierarchy> {
    let n = mesh.rings.len();
    let (mut quadrics, areas) = vertex_quadrics(mesh, positions);
    // A fixed order of summation: the same weight on every thread count.
    let total_area: f64 = areas.iter().sum();
    drop(areas);
    // Each face is seen from its three corners, in the area sum too.
    let n_corners: usize = mesh.rings.iter().map(Vec::len).sum();
    let length_weight = LENGTH_WEIGHT * total_area / n_corners.max(1) as f64;
    let mut alive: Vec<u32> = (0..n as u32).collect();
    let mut locked = vec![u32::MAX; n];
    let mut hierarchy = Hierarchy::default();
    let mut round = 0u32;
    while mesh.n_alive > 4 {
        let mut careful = true;
        let mut taken = take_round(mesh, positions, &quadrics, length_weight, &alive, careful);
        if taken.is_empty() {
            careful = false;
            taken = take_round(mesh, positions, &quadrics, length_weight, &alive, careful);
        }
        let start = hierarchy.collapses.len();
        for (index, &(_, u, v)) in taken.iter().enumerate() {
            if mesh.n_alive <= 4 {
                break;
            }
            prefetch_ahead(mesh, &quadrics, &locked, round, &taken, index);
            // No vertex of a ring collapsed this round collapses itself in
            // the same round. So an unlocked `u` was no neighbour of any
            // vertex removed before it, and its ring is the one it was
            // scored with; `v`'s may have grown, so the degree and link
            // condition are asked again, unless neither `v` nor the two
            // vertices opposite the edge (all they read besides `u`'s ring)
            // is locked: a collapse edits only lists of its own ring, which
            // it locks, so theirs are as when `u -> v` was found legal.
            let ring = &mesh.rings[u as usize];
            if locked[u as usize] == round
                || (!unchanged_since_scored(&locked, round, ring, v)
                    && ((careful && mesh.rings[v as usize].len() + ring.len() - 4 > MAX_DEGREE)
                        || !mesh.can_collapse(u, v)))
            {
                continue;
            }
            for &r in ring {
                locked[r as usize] = round;
            }
            let qu = quadrics[u as usize];
            for (x, y) in quadrics[v as usize].iter_mut().zip(qu) {
                *x += y;
            }
            hierarchy.collapses.push(mesh.collapse(u, v));
        }
        if hierarchy.collapses.len() == start {
            // Cannot happen on a closed genus-0 mesh (see the module notes).
            return None;
        }
        hierarchy.rounds.push(start..hierarchy.collapses.len());
        // In parallel, in order (1M-vertex `tentacles`: 0.03 s serial over
        // the rounds).
        alive = alive.par_iter().copied().filter(|&v| mesh.is_alive(v)).collect();
        round += 1;
        if !report(n - mesh.n_alive) {
            return None;
        }
    }
    Some(hierarchy)
}

/// Whether `v` and the two vertices of `ring` beside it (those opposite the
/// edge `u -> v` of `u`'s ring `ring`) are all unlocked in round `round`:
/// then the degree and link condition of the collapse read the lists they
/// read when it was scored in the round.
fn unchanged_since_scored(locked: &[u32], round: u32, ring: &[u32], v: u32) -> bool {
    let k = ring.len();
    let Some(at) = ring.iter().position(|&x| x == v) else { return false };
    [v, ring[(at + 1) % k], ring[(at + k - 1) % k]].iter().all(|&x| locked[x as usize] != round)
}

/// Asks the processor to fetch what the collapse loop will read for the
/// candidates a few places further down `taken`, in four stages so that
/// each stage's addresses come from memory the stage before fetched: their
/// locks, rings' headers and quadrics (both cache lines); then, for those
/// not yet locked, their rings; then their neighbours' rings' headers and
/// locks; then their neighbours' lists, which the collapse edits (measured
/// on 1M-vertex `tentacles`, one thread, process CPU time of the loop: 0.54
/// s with three stages and one line of each quadric, 0.41 s with this).
/// Only a hint: it changes no result.
fn prefetch_ahead(
    mesh: &RingMesh,
    quadrics: &[Quadric],
    locked: &[u32],
    round: u32,
    taken: &[(f64, u32, u32)],
    index: usize,
) {
    if let Some(&(_, u, v)) = taken.get(index + AHEAD) {
        prefetch(&locked[u as usize]);
        prefetch(&mesh.rings[u as usize]);
        prefetch(&mesh.rings[v as usize]);
        prefetch(&quadrics[u as usize]);
        prefetch(&quadrics[v as usize]);
        // A quadric is 80 bytes: its second cache line.
        prefetch(quadrics[u as usize].as_ptr().wrapping_add(8));
        prefetch(quadrics[v as usize].as_ptr().wrapping_add(8));
    }
    if let Some(&(_, u, v)) = taken.get(index + AHEAD / 2) {
        if locked[u as usize] != round {
            prefetch(mesh.rings[u as usize].as_ptr());
            prefetch(mesh.rings[v as usize].as_ptr());
        }
    }
    if let Some(&(_, u, _)) = taken.get(index + AHEAD / 4) {
        if locked[u as usize] != round {
            for &r in &mesh.rings[u as usize] {
                prefetch(&mesh.rings[r as usize]);
                prefetch(&locked[r as usize]);
            }
        }
    }
    // The lists of the neighbours, which the collapse edits.
    if let Some(&(_, u, _)) = taken.get(index + AHEAD / 8) {
        if locked[u as usize] != round {
            for &r in &mesh.rings[u as usize] {
                prefetch(mesh.rings[r as usize].as_ptr());
            }
        }
    }
}

/// The order of a vertex's candidate collapses: by cost, then by the
/// vertex collapsed into (each candidate's own, so the order is total).
fn cheaper(a: &(f64, u32), b: &(f64, u32)) -> std::cmp::Ordering {
    a.0.total_cmp(&b.0).then(a.1.cmp(&b.1))
}

/// How far ahead in the alive vertices the scoring asks for their lists
/// (1M-vertex `tentacles`, one thread: the scoring's CPU time 1.12 s without,
/// 0.97 s with), and for their neighbours' quadrics and positions (the
/// scoring and its sort 1.06-1.07 s without, 0.96-1.01 s with, temporary
/// timers, three alternating pairs of processes at load 1.5-2).
const SCORE_AHEAD: usize = 8;

/// Every alive vertex's cheapest legal collapse, cheapest first.
fn take_round(
    mesh: &RingMesh,
    positions: &[[f64; 3]],
    quadrics: &[Quadric],
    length_weight: f64,
    alive: &[u32],
    careful: bool,
) -> Vec<(f64, u32, u32)> {
    let mut scored: Vec<(f64, u32, u32)> = alive
        .par_iter()
        .enumerate()
        .with_min_len(256)
        .map_init(Vec::new, |candidates: &mut Vec<(f64, u32)>, (x, &u)| {
            // Only hints: the list of the vertex a few places on (one block
            // of memory each, anywhere), then its neighbours' lists, which
            // the legality tests read, and their quadrics (both cache lines)
            // and positions, which the costs read.
            if let Some(&w) = alive.get(x + SCORE_AHEAD) {
                prefetch(mesh.rings[w as usize].as_ptr());
            }
            if let Some(&w) = alive.get(x + SCORE_AHEAD / 2) {
                for &r in &mesh.rings[w as usize] {
                    prefetch(mesh.rings[r as usize].as_ptr());
                    prefetch(&quadrics[r as usize]);
                    prefetch(quadrics[r as usize].as_ptr().wrapping_add(8));
                    prefetch(&positions[r as usize]);
                }
            }
            // Cost every edge first, then test legality cheapest first: the
            // cheapest edge is nearly always legal, and the legality tests
            // cost far more than the quadric.
            let ring = &mesh.rings[u as usize];
            candidates.clear();
            candidates.extend(ring.iter().map(|&v| {
                let q: Quadric =
                    std::array::from_fn(|i| quadrics[u as usize][i] + quadrics[v as usize][i]);
                let edge = sub(positions[u as usize], positions[v as usize]);
                let cost = quadric_at(&q, positions[v as usize]).max(0.0)
                    + length_weight * dot(edge, edge);
                (cost, v)
            }));
            let legal = |v: u32| {
                (!careful
                    || (mesh.rings[v as usize].len() + ring.len() - 4 <= MAX_DEGREE
                        && keeps_normals(positions, u, v, ring)))
                    && mesh.can_collapse(u, v)
            };
            // The cheapest edge first, found by one scan: when it is legal
            // (nearly always) the order of the others does not matter. Else
            // the rest in order, as sorting them all first would give.
            let cheapest = candidates.iter().copied().min_by(cheaper)?;
            if legal(cheapest.1) {
                return Some((cheapest.0, u, cheapest.1));
            }
            candidates.sort_unstable_by(cheaper);
            candidates.iter().skip(1).find_map(|&(cost, v)| legal(v).then_some((cost, u, v)))
        })
        .flatten()
        .collect();
    scored.par_sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    scored
}
