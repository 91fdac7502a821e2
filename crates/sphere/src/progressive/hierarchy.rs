//! The progressive mesh (Hoppe 1996; thesis 9.3.3): half-edge collapses down
//! to a tetrahedron, in rounds of independent collapses.
//!
//! Each round scores every vertex `u` by its cheapest legal collapse `u -> v`
//! and takes collapses greedily, cheapest first, as long as their closed
//! rings (`u` and its neighbours) are disjoint from those already taken. Such
//! collapses edit disjoint neighbour lists, so within a round their order
//! does not matter, and when the progressive method undoes a round the
//! re-inserted vertices see no other vertex of the round: they can be placed
//! in parallel. The result depends on nothing but the mesh.
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

use super::ring_mesh::{Collapse, RingMesh};

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

/// Collapses `mesh` down to four vertices, calling `report(removed)` after
/// each round; it returns `false` to stop (then `None`).
pub fn decimate(
    mesh: &mut RingMesh,
    positions: &[[f64; 3]],
    report: &mut dyn FnMut(usize) -> bool,
) -> Option<Hierarchy> {
    let n = mesh.rings.len();
    let mut quadrics: Vec<Quadric> = vec![[0.0; 10]; n];
    let mut total_area = 0.0;
    let mut n_faces = 0usize;
    for (i, ring) in mesh.rings.iter().enumerate() {
        let m = ring.len();
        for j in 0..m {
            let (a, b) = (ring[j], ring[(j + 1) % m]);
            let q = plane_quadric(positions[i], positions[a as usize], positions[b as usize]);
            for (x, y) in quadrics[i].iter_mut().zip(q) {
                *x += y;
            }
            total_area += triangle_area(positions[i], positions[a as usize], positions[b as usize]);
            n_faces += 1;
        }
    }
    let length_weight = LENGTH_WEIGHT * total_area / n_faces.max(1) as f64;
    let mut alive: Vec<u32> = (0..n as u32).collect();
    let mut locked = vec![u32::MAX; n];
    let mut hierarchy = Hierarchy::default();
    let mut round = 0u32;
    while mesh.n_alive > 4 {
        let mut taken = take_round(mesh, positions, &quadrics, length_weight, &alive, true);
        if taken.is_empty() {
            taken = take_round(mesh, positions, &quadrics, length_weight, &alive, false);
        }
        let start = hierarchy.collapses.len();
        for (u, v) in greedy(mesh, taken, &mut locked, round) {
            if mesh.n_alive <= 4 {
                break;
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
        alive.retain(|&v| mesh.is_alive(v));
        round += 1;
        if !report(n - mesh.n_alive) {
            return None;
        }
    }
    Some(hierarchy)
}

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
        .with_min_len(256)
        .filter_map(|&u| {
            let ring = &mesh.rings[u as usize];
            let mut best: Option<(f64, u32, u32)> = None;
            for &v in ring {
                if careful
                    && (mesh.rings[v as usize].len() + ring.len() - 4 > MAX_DEGREE
                        || !keeps_normals(positions, u, v, ring))
                {
                    continue;
                }
                if !mesh.can_collapse(u, v) {
                    continue;
                }
                let q: Quadric =
                    std::array::from_fn(|i| quadrics[u as usize][i] + quadrics[v as usize][i]);
                let edge = sub(positions[u as usize], positions[v as usize]);
                let cost = quadric_at(&q, positions[v as usize]).max(0.0)
                    + length_weight * dot(edge, edge);
                if best.is_none_or(|(c, _, bv)| cost < c || (cost == c && v < bv)) {
                    best = Some((cost, u, v));
                }
            }
            best
        })
        .collect();
    scored.par_sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    scored
}

/// The cheapest collapses whose closed rings are pairwise disjoint.
fn greedy(
    mesh: &RingMesh,
    scored: Vec<(f64, u32, u32)>,
    locked: &mut [u32],
    round: u32,
) -> Vec<(u32, u32)> {
    let mut taken = Vec::new();
    for (_, u, v) in scored {
        let ring = &mesh.rings[u as usize];
        if locked[u as usize] == round || ring.iter().any(|&r| locked[r as usize] == round) {
            continue;
        }
        locked[u as usize] = round;
        for &r in ring {
            locked[r as usize] = round;
        }
        taken.push((u, v));
    }
    taken
}
