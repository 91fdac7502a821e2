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

use super::ring_mesh::{collapse_keeps_manifold, prefetch, Collapse, RingMesh, AHEAD};

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
/// area of its faces.
fn vertex_quadrics(mesh: &RingMesh, positions: &[[f64; 3]]) -> Vec<(Quadric, f64)> {
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
        .collect()
}

/// Collapses `mesh` down to four vertices, calling `report(removed)` after
/// each round; it returns `false` to stop (then `None`).
pub fn decimate(
    mesh: &mut RingMesh,
    positions: &[[f64; 3]],
    report: &mut dyn FnMut(usize) -> bool,
) -> Option<Hierarchy> {
    let n = mesh.rings.len();
    let per_vertex = vertex_quadrics(mesh, positions);
    // A fixed order of summation: the same weight on every thread count.
    let total_area: f64 = per_vertex.iter().map(|x| x.1).sum();
    // Each face is seen from its three corners, in the area sum too.
    let n_corners: usize = mesh.rings.iter().map(Vec::len).sum();
    let mut quadrics: Vec<Quadric> = per_vertex.into_iter().map(|x| x.0).collect();
    let length_weight = LENGTH_WEIGHT * total_area / n_corners.max(1) as f64;
    let mut alive: Vec<u32> = (0..n as u32).collect();
    // Below REMOVED and above every round number: not locked yet.
    let mut locked = vec![REMOVED - 1; n];
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
        // The round's decisions, in score order, on the rings as they were
        // at its start: each is taken on the mesh the earlier ones left,
        // which [`Round`] reads off the original rings (see its notes). The
        // edits follow, vertex by vertex in parallel.
        let mut chosen: Vec<(u32, u32)> = Vec::new();
        let mut n_alive = mesh.n_alive;
        let mut rv = Vec::new();
        for (index, &(_, u, v)) in taken.iter().enumerate() {
            if n_alive <= 4 {
                break;
            }
            prefetch_ahead(mesh, &quadrics, &locked, round, &taken, index);
            // No vertex of a ring collapsed this round collapses itself in
            // the same round. So an unlocked `u` was no neighbour of any
            // vertex removed before it, and its ring is the one it was
            // scored with; `v`'s may have grown, so the degree and link
            // condition are asked again.
            let ring = &mesh.rings[u as usize];
            if locked[u as usize] == round {
                continue;
            }
            let now = Round { rings: &mesh.rings, locked: &locked, chosen: &chosen };
            now.ring(v, &mut rv);
            if careful && rv.len() + ring.len() - 4 > MAX_DEGREE {
                continue;
            }
            if !collapse_keeps_manifold(n_alive, ring, v, &rv, |x| now.degree(x)) {
                continue;
            }
            for &r in ring {
                locked[r as usize] = round;
            }
            locked[u as usize] = REMOVED | chosen.len() as u32;
            let qu = quadrics[u as usize];
            for (x, y) in quadrics[v as usize].iter_mut().zip(qu) {
                *x += y;
            }
            chosen.push((u, v));
            n_alive -= 1;
        }
        apply_round(mesh, &mut hierarchy, &chosen, &locked, round);
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

/// The tag of a vertex removed in the current round in `locked` (whose other
/// entries are round numbers, far below it), over its place in the round's
/// list of collapses.
const REMOVED: u32 = 1 << 31;

/// The mesh in the middle of a round, read off the rings as they were at its
/// start: the collapses chosen so far are not applied yet. Each edit of a
/// collapse `e -> t` (with `e`'s ring `[t, r1, .., rk]`) replaces the entry
/// `e` in one neighbour's list: by `r2 .. r(k-1)` in `t`'s, by nothing in
/// `r1`'s and `rk`'s, by `t` in the others' ([`RingMesh::collapse`]). No
/// two vertices removed in a round are neighbours, so every entry a round
/// edits is a vertex it removes, each list loses, gains or renames distinct
/// entries, and the current list of `x` is its list at the start of the
/// round with each removed entry replaced so: the edits of a round commute,
/// and are made afterwards, vertex by vertex in parallel ([`apply_round`]).
struct Round<'a> {
    rings: &'a [Vec<u32>],
    /// Per vertex: the round that locked it, or [`REMOVED`] and its collapse.
    locked: &'a [u32],
    chosen: &'a [(u32, u32)],
}

impl Round<'_> {
    /// What the removed entry `e` of `x`'s list stands for now.
    fn replaced(&self, x: u32, e: u32, out: &mut impl FnMut(u32)) {
        let (_, t) = self.chosen[(self.locked[e as usize] & !REMOVED) as usize];
        let re = &self.rings[e as usize];
        let m = re.len();
        let at = re.iter().position(|&y| y == t).expect("a collapse's target is in its ring");
        let turned = |i: usize| re[(at + i) % m];
        if x == t {
            (2..m - 1).for_each(|i| out(turned(i)));
        } else if x != turned(1) && x != turned(m - 1) {
            out(t);
        }
    }

    /// `x`'s current ring, into `out`.
    fn ring(&self, x: u32, out: &mut Vec<u32>) {
        out.clear();
        for &e in &self.rings[x as usize] {
            if self.locked[e as usize] & REMOVED == 0 {
                out.push(e);
            } else {
                self.replaced(x, e, &mut |y| out.push(y));
            }
        }
    }

    /// The length of `x`'s current ring.
    fn degree(&self, x: u32) -> usize {
        let mut n = 0;
        for &e in &self.rings[x as usize] {
            if self.locked[e as usize] & REMOVED == 0 {
                n += 1;
            } else {
                self.replaced(x, e, &mut |_| n += 1);
            }
        }
        n
    }
}

/// Makes the collapses `chosen` (in this order) of round `round`, whose
/// removed vertices carry [`REMOVED`] and their place in `chosen` in
/// `locked` and whose rings' vertices carry `round`: each removed ring,
/// turned to start at its target, goes to `hierarchy` as [`RingMesh::collapse`]
/// leaves it, then every locked vertex's list is edited on its own, in
/// parallel (see [`Round`]): the same lists, entry for entry, as the
/// collapses made one after the other.
fn apply_round(
    mesh: &mut RingMesh,
    hierarchy: &mut Hierarchy,
    chosen: &[(u32, u32)],
    locked: &[u32],
    round: u32,
) {
    let first = hierarchy.collapses.len();
    for &(u, v) in chosen {
        let mut ring = std::mem::take(&mut mesh.rings[u as usize]);
        let at = ring.iter().position(|&x| x == v).expect("v is a neighbour of u");
        ring.rotate_left(at);
        hierarchy.collapses.push(Collapse { u, v, ring });
    }
    mesh.n_alive -= chosen.len();
    let made = &hierarchy.collapses[first..];
    mesh.rings.par_iter_mut().enumerate().with_min_len(1024).for_each_init(
        Vec::new,
        |edited: &mut Vec<u32>, (x, list)| {
            if locked[x] != round {
                return;
            }
            edited.clear();
            for &e in list.iter() {
                let tag = locked[e as usize];
                if tag & REMOVED == 0 {
                    edited.push(e);
                    continue;
                }
                let c = &made[(tag & !REMOVED) as usize];
                let k = c.ring.len() - 1; // c.ring = [v, r1, .., rk]
                if x as u32 == c.v {
                    edited.extend_from_slice(&c.ring[2..k]);
                } else if x as u32 != c.ring[1] && x as u32 != c.ring[k] {
                    edited.push(c.v);
                }
            }
            list.clear();
            list.extend_from_slice(edited);
        },
    );
}

/// Asks the processor to fetch what the collapse loop will read for the
/// candidates a few places further down `taken`, in three stages so that
/// each stage's addresses come from memory the stage before fetched: their
/// locks, rings' headers and quadrics; then, for those not yet locked, their
/// rings; then their neighbours' rings' headers. Only a hint: it changes no
/// result.
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
            }
        }
    }
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
        .map_init(Vec::new, |candidates: &mut Vec<(f64, u32)>, &u| {
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
            candidates.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            candidates.iter().find_map(|&(cost, v)| {
                let legal = (!careful
                    || (mesh.rings[v as usize].len() + ring.len() - 4 <= MAX_DEGREE
                        && keeps_normals(positions, u, v, ring)))
                    && mesh.can_collapse(u, v);
                legal.then_some((cost, u, v))
            })
        })
        .flatten()
        .collect();
    scored.par_sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    scored
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::solids::{bumpy, helix};

    #[test]
    fn a_round_applied_at_once_gives_the_lists_of_its_collapses_made_one_by_one() {
        for mesh in [bumpy(3), helix(8, 160, 0.1, 3.0, 0.8)] {
            let (positions, faces) = (mesh.positions(), mesh.faces());
            let mut at_once = RingMesh::from_faces(positions.len(), faces).unwrap();
            let hierarchy = decimate(&mut at_once, positions, &mut |_| true).unwrap();
            assert_eq!(at_once.n_alive, 4);
            assert!(hierarchy.rounds.len() > 3, "{} rounds", hierarchy.rounds.len());
            let mut one_by_one = RingMesh::from_faces(positions.len(), faces).unwrap();
            for round in &hierarchy.rounds {
                for c in &hierarchy.collapses[round.clone()] {
                    assert!(one_by_one.can_collapse(c.u, c.v), "{} -> {}", c.u, c.v);
                    assert_eq!(&one_by_one.collapse(c.u, c.v), c);
                }
            }
            assert_eq!(one_by_one.rings, at_once.rings);
        }
    }
}
