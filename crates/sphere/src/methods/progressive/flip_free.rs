//! Flip-free vertex moves on the sphere (thesis 9.3.2: local updates that keep
//! every triangle positively oriented).
//!
//! A vertex `p` with ring `r_0 .. r_{m-1}` owns the faces `(p, r_j, r_j+1)`.
//! Moving it along `p + t D` changes each det[p, r_j, r_j+1] linearly in `t`,
//! so the largest step that keeps every face positive has a closed form. A
//! move is a Newton step of the vertex's share of a [`Energy`] in the tangent
//! plane (the 2x2 Hessian by differences of the exact gradient), cut to a
//! fraction of that safe step and backtracked until the energy falls (Armijo);
//! the balanced map's moves lengthen the Newton step first (over-relaxation,
//! [`OVER_RELAXATION`]).
//! The new point is normalised and its faces are then tested with the exact
//! predicate on the very doubles that are stored: a move that fails the test
//! is not taken. Vertices of one colour class share no face, so a class moves
//! in parallel and the result does not depend on the number of threads.

use rayon::prelude::*;
use spherify_mesh::predicates::{det3_sign, Sign};
use spherify_mesh::vec3::{add, cross, det3, dot, norm, scale, sub};

use crate::embedding::normalize;
use crate::methods::progressive::chord_area::{self, chord_area, chord_area_hessian};
use crate::methods::progressive::distortion_energy::{
    face_energy, face_energy_hessian, Energy, Reference,
};
use crate::methods::progressive::level_mesh::write_ascending;
use crate::methods::progressive::ring_mesh::prefetch;
use crate::methods::progressive::star_lanes;
use crate::methods::progressive::target_pull::TargetPull;

/// The energy to lower and the surface it measures against.
#[derive(Debug, Clone, Copy)]
pub struct Problem<'a> {
    pub energy: Energy,
    /// Surface positions, one per vertex.
    pub surface: &'a [[f64; 3]],
    /// Surface triangles smaller than this count as this large (see
    /// [`Reference::new`]).
    pub area_floor: f64,
    /// On a coarse level, per vertex: the area of the finest surface that
    /// the vertex stands for over the area of its own star at this level
    /// (see [`represented_area`]). A face's reference triangle is scaled by
    /// the mean over its corners, so that a face aims at the share of the
    /// sphere its part of the finest surface needs. `None`: the mesh itself.
    pub represented: Option<&'a [f64]>,
    /// A data term added to the energy: each vertex pulled towards a target
    /// ([`crate::methods::progressive::target_pull`]). `None`: the
    /// distortion alone.
    pub pull: Option<&'a TargetPull>,
}

/// Every vertex's ring and the surface reference of each face around it,
/// vertex by vertex in ring order, in three flat arrays: built once for the
/// many sweeps over one connectivity. Building the references was a quarter
/// of a move's time, and a sweep that reads rings from one array instead of
/// one allocation per vertex waits far less on memory.
#[derive(Debug, Clone)]
pub struct Stars {
    start: Vec<usize>,
    ring: Vec<u32>,
    refs: Vec<Reference>,
    /// The references' areas summed as [`Problem::area_scale`] sums them
    /// (per vertex in ring order, then over the vertices in order): fixed
    /// for the stars' life, so that each area scale between sweeps reads
    /// only the rings and points, not the references (the method's largest
    /// buffer, 192 bytes per vertex).
    surface_total: f64,
}

impl Stars {
    /// Number of vertices (removed ones have an empty ring).
    pub fn len(&self) -> usize {
        self.start.len() - 1
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn ring(&self, i: u32) -> &[u32] {
        &self.ring[self.start[i as usize]..self.start[i as usize + 1]]
    }

    /// The references of the faces `(i, r_j, r_j+1)`, in ring order.
    pub fn refs(&self, i: u32) -> &[Reference] {
        &self.refs[self.start[i as usize]..self.start[i as usize + 1]]
    }
}

/// A move shorter than this fraction of the vertex's shortest edge does not
/// wake its neighbours for the next sweep of [`Problem::optimise`].
pub const NOTICEABLE: f64 = 1e-3;
/// At a coarse level of a progressive mesh ([`Problem::at_level`]), surface
/// triangles below this fraction of the level's mean face area count as that
/// large: three nearly collinear survivors of the decimation make a face with
/// almost no area, which an isometric map would copy onto the sphere.
pub const LEVEL_AREA_FLOOR: f64 = 1e-2;
/// Backtracking halvings before a move is given up.
const MAX_HALVINGS: usize = 12;
/// Fraction of the largest flip-free step a move may take.
const SAFE_FRACTION: f64 = 0.8;
/// The Newton step of the balanced map's moves (its final and coarse-level
/// energies) is lengthened by this factor before it is cut and backtracked:
/// nonlinear successive over-relaxation. The sweeps are a Gauss-Seidel
/// iteration whose slow error on tubes falls by 0.1-0.5% per sweep; a
/// longer step goes further along it (issue 22, measured on 200k vertices,
/// L2 stretch / area with 20 final sweeps and 1.0 / 1.3: `helix_tube` 3.640 /
/// 0.758 and 3.618 / 0.765, `tentacles` 2.785 / 0.743 and 2.773 / 0.742;
/// with 1.5 on the coarse levels too, 14 sweeps and no global steps,
/// `helix_tube`'s area rose to 0.791, above SphereParam's 0.776). The other
/// energies keep 1.0 and their bits.
pub const OVER_RELAXATION: f64 = 1.3;

impl Problem<'_> {
    fn reference(&self, i: u32, a: u32, b: u32) -> Reference {
        let s = self.surface;
        let r = Reference::new(s[i as usize], s[a as usize], s[b as usize], self.area_floor);
        match self.represented {
            Some(rho) => r.scaled((rho[i as usize] + rho[a as usize] + rho[b as usize]) / 3.0),
            None => r,
        }
    }

    /// The rings and references of every vertex of `rings`.
    pub fn stars(&self, rings: &[Vec<u32>]) -> Stars {
        let (start, ring) = flat_rings(rings);
        self.stars_of(start, ring)
    }

    /// [`Problem::stars`] from the rings laid end to end in `ring`, vertex
    /// `i`'s at `start[i]..start[i + 1]`.
    pub fn stars_of(&self, start: Vec<usize>, ring: Vec<u32>) -> Stars {
        // Filled in place, block by block: collecting an iterator of
        // unknown length held every reference twice at the peak (the
        // largest buffer of the method, 192 bytes per vertex). The blocks
        // write into the buffer's unfilled capacity: filling it with zeros
        // first was a serial pass that also took every page's first-touch
        // fault on one thread (192 MB at 1M vertices, at every level).
        const BLOCK: usize = 1024;
        let n = start.len() - 1;
        let total = start[n];
        let mut refs: Vec<Reference> = Vec::with_capacity(total);
        let mut blocks = Vec::with_capacity(n.div_ceil(BLOCK));
        let mut rest = &mut refs.spare_capacity_mut()[..total];
        for first in (0..n).step_by(BLOCK) {
            let end = (first + BLOCK).min(n);
            let (block, tail) = rest.split_at_mut(start[end] - start[first]);
            blocks.push((first..end, block));
            rest = tail;
        }
        blocks.into_par_iter().for_each(|(vertices, out)| {
            let mut at = 0;
            for i in vertices {
                let r = &ring[start[i]..start[i + 1]];
                let m = r.len();
                for j in 0..m {
                    out[at].write(self.reference(i as u32, r[j], r[(j + 1) % m]));
                    at += 1;
                }
            }
            assert_eq!(at, out.len(), "a block of references left a slot unwritten");
        });
        // SAFETY: the blocks split the first `total` slots of the capacity
        // between them, and each wrote every slot of its own (asserted
        // above: a block that did not would have panicked before this).
        unsafe { refs.set_len(total) };
        let per_vertex: Vec<f64> = (0..n)
            .into_par_iter()
            .map(|i| refs[start[i]..start[i + 1]].iter().fold(0.0, |sum, r| sum + r.area))
            .collect();
        // The fold of area_scale, in the same order: the same bits.
        let surface_total = per_vertex.iter().fold(0.0, |sum, x| sum + x);
        Stars { start, ring, refs, surface_total }
    }

    /// Sum of image areas (det / 2, see [`crate::methods::progressive::distortion_energy`]) over
    /// surface areas of the current faces:
    /// the `k` that gives mesh and image equal total area.
    pub fn area_scale(&self, stars: &Stars, points: &[[f64; 3]]) -> f64 {
        let per_vertex: Vec<f64> = (0..stars.len() as u32)
            .into_par_iter()
            .map(|i| vertex_area(i, stars.ring(i), points))
            .collect();
        // A fixed order of summation: the same scale on every thread count.
        let chord = per_vertex.iter().fold(0.0, |s, x| s + x);
        scale_of(chord, stars.surface_total)
    }

    /// Total energy of the current faces, each face seen from its smallest corner.
    pub fn total_energy(&self, k: f64, stars: &Stars, points: &[[f64; 3]]) -> f64 {
        let per_vertex: Vec<f64> = (0..stars.len() as u32)
            .into_par_iter()
            .map(|i| self.vertex_energy(i, stars, points, k))
            .collect();
        // A fixed order of summation: the same total on every thread count.
        per_vertex.iter().sum::<f64>()
    }

    /// Vertex `i`'s share of [`Problem::total_energy`] at `k`: the energies
    /// of its faces that it is the smallest corner of, in ring order, plus
    /// its pull (also what [`Passes::energies`] sums).
    #[inline]
    fn vertex_energy(&self, i: u32, stars: &Stars, points: &[[f64; 3]], k: f64) -> f64 {
        let (ring, refs) = (stars.ring(i), stars.refs(i));
        let m = ring.len();
        let p = points[i as usize];
        (0..m)
            .filter(|&j| i < ring[j] && i < ring[(j + 1) % m])
            .map(|j| {
                let (a, b) = (points[ring[j] as usize], points[ring[(j + 1) % m] as usize]);
                face_energy(self.energy, &refs[j], k, p, a, b)
            })
            .sum::<f64>()
            + self.pull.map_or(0.0, |pull| pull.energy(i, p))
    }

    /// The energy of the current faces per unit of scaled surface area.
    pub fn per_area(&self, stars: &Stars, points: &[[f64; 3]]) -> f64 {
        let k = self.area_scale(stars, points);
        let energy = self.total_energy(k, stars, points);
        energy / (k * self.surface_area(stars)).max(f64::MIN_POSITIVE)
    }

    /// The surface area of the faces of `stars` (their references' areas).
    fn surface_area(&self, stars: &Stars) -> f64 {
        // The references' areas per vertex in ring order, then over the
        // vertices in order: the sum that `stars_of` kept. (This was a pass
        // over every reference, 192 bytes per vertex, at the end of every
        // optimisation. Its sums started from -0.0 where the kept one starts
        // from 0.0; the areas are non-negative (`Reference::new`), so the two
        // differ at most in the sign of a zero total, which the callers,
        // `(k * area).max(f64::MIN_POSITIVE)`, do not see.)
        stars.surface_total / 3.0
    }

    /// Sum of the current faces' chord areas (see
    /// [`crate::methods::progressive::chord_area`]), each face seen from its
    /// smallest corner, in a fixed order.
    pub fn chord_total(&self, stars: &Stars, points: &[[f64; 3]]) -> f64 {
        let per_vertex: Vec<f64> = (0..stars.len() as u32)
            .into_par_iter()
            .map(|i| vertex_chord(i, stars.ring(i), points))
            .collect();
        per_vertex.iter().sum::<f64>()
    }

    /// The chord-area weight mu of the current state (0 where the energy
    /// does not pay for chord area), see [`crate::methods::progressive::chord_area`].
    pub fn chord_weight(&self, energy: f64, stars: &Stars, points: &[[f64; 3]]) -> f64 {
        if !chord_area::applies(self.energy) {
            return 0.0;
        }
        chord_area::weight(true, energy, self.chord_total(stars, points))
    }

    /// One flip-free move of vertex `i`: the new point, or `None` when no step
    /// lowers the energy and passes the exact test. The chord-area term is
    /// left out (these moves place new or blocked vertices).
    pub fn move_vertex(
        &self,
        k: f64,
        i: u32,
        ring: &[u32],
        points: &[[f64; 3]],
    ) -> Option<[f64; 3]> {
        self.move_vertex_with(k, i, ring, points, &mut Vec::new(), &mut Vec::new())
    }

    /// [`Problem::move_vertex`] with buffers for the references of `i`'s
    /// faces and its ring's points, kept between calls (the same move).
    pub fn move_vertex_with(
        &self,
        k: f64,
        i: u32,
        ring: &[u32],
        points: &[[f64; 3]],
        refs: &mut Vec<Reference>,
        corners: &mut Vec<[f64; 3]>,
    ) -> Option<[f64; 3]> {
        // The references of the faces around `i`, in ring order.
        let m = ring.len();
        refs.clear();
        refs.extend((0..m).map(|j| self.reference(i, ring[j], ring[(j + 1) % m])));
        self.step(k, 0.0, i, ring, refs, points, corners).map(|(q, _)| q)
    }

    /// [`Problem::move_vertex`] with the references of `i`'s faces given,
    /// `chord` times the chord areas added to the energy, and a buffer for
    /// its ring's points; also returns the length of the vertex's shortest
    /// edge before the move (which also bounds the step).
    #[allow(clippy::too_many_arguments)]
    fn step(
        &self,
        k: f64,
        chord: f64,
        i: u32,
        ring: &[u32],
        refs: &[Reference],
        points: &[[f64; 3]],
        corners: &mut Vec<[f64; 3]>,
    ) -> Option<([f64; 3], f64)> {
        let p = points[i as usize];
        let star = Star::gather(refs, ring, points, corners);
        // The isometric and the stretch family's energies, with the
        // chord-area term: four faces at a time (the same bits; `None` where
        // the scalar sum was infinite, which gave up the move below).
        let lanes = star_lanes::handles(self.energy);
        let (mut e0, mut g, mut hess) = if lanes {
            star_lanes::hessian(self.energy, k, chord, p, refs, star.corners)?
        } else {
            star.hessian(self.energy, k, chord, p)
        };
        if let Some(pull) = self.pull {
            let (pe, pg, ph) = pull.vertex_term(i, p);
            e0 += pe;
            g = add(g, pg);
            for (j, row) in hess.iter_mut().enumerate() {
                row[j] += ph;
            }
        }
        if !e0.is_finite() {
            return None;
        }
        let (e1, e2) = tangent_basis(p);
        let gt = [dot(g, e1), dot(g, e2)];
        let gnorm = (gt[0] * gt[0] + gt[1] * gt[1]).sqrt();
        if gnorm == 0.0 || !gnorm.is_finite() {
            return None;
        }
        let reach = star_lanes::reach(p, star.corners);
        // Newton direction in the tangent plane: p(s) = (p + s) / |p + s|
        // = p + s - |s|^2 p / 2 + ..., so the Hessian in s is E^T H E - (g . p) I.
        let he =
            |u: [f64; 3], v: [f64; 3]| dot(u, [dot(hess[0], v), dot(hess[1], v), dot(hess[2], v)]);
        let radial = dot(g, p);
        let (h00, h11, h01) = (he(e1, e1) - radial, he(e2, e2) - radial, he(e1, e2));
        let mut dir = None;
        let det = h00 * h11 - h01 * h01;
        if det > 0.0 && h00 > 0.0 {
            let omega = match self.energy {
                Energy::BalancedWeighted(_) | Energy::CoarseBalanced => OVER_RELAXATION,
                _ => 1.0,
            };
            let d = [-(h11 * gt[0] - h01 * gt[1]) / det, -(h00 * gt[1] - h01 * gt[0]) / det];
            let d = [omega * d[0], omega * d[1]];
            let len = (d[0] * d[0] + d[1] * d[1]).sqrt();
            if len.is_finite() && len > 0.0 {
                let cap = (0.5 * reach / len).min(1.0);
                dir = Some([d[0] * cap, d[1] * cap]);
            }
        }
        let d = dir.unwrap_or([-gt[0] * 0.25 * reach / gnorm, -gt[1] * 0.25 * reach / gnorm]);
        let slope = gt[0] * d[0] + gt[1] * d[1];
        if slope >= 0.0 {
            return None;
        }
        let step = add(scale(e1, d[0]), scale(e2, d[1]));
        // det[p + t step, a, b] = det[p, a, b] + t det[step, a, b].
        let t_safe = star_lanes::safe_step(p, step, star.corners);
        let mut t = (SAFE_FRACTION * t_safe).min(1.0);
        for _ in 0..MAX_HALVINGS {
            if let Some(q) = normalize(add(p, scale(step, t))) {
                let mut e = if lanes {
                    star_lanes::energy(self.energy, k, chord, q, refs, star.corners)
                } else {
                    star.energy(self.energy, k, chord, q)
                };
                if let Some(pull) = self.pull {
                    e += pull.energy(i, q);
                }
                if e <= e0 + 1e-4 * t * slope && star_lanes::positive_fan(q, star.corners) {
                    return Some((q, reach));
                }
            }
            t *= 0.5;
        }
        None
    }

    /// One pass over `classes` (vertex sets of which no two share a face),
    /// lowering the energy plus `chord` times the chord areas,
    /// class after class, the vertices of a class in parallel, skipping those
    /// not `active` (all, when `None`). Returns the vertices that moved by
    /// more than `wake` (usually [`NOTICEABLE`]) of their shortest edge;
    /// `stop()` is asked between classes.
    #[allow(clippy::too_many_arguments)]
    fn sweep(
        &self,
        k: f64,
        chord: f64,
        classes: &[Vec<u32>],
        stars: &Stars,
        points: &mut [[f64; 3]],
        active: Option<&[bool]>,
        wake: f64,
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<Vec<u32>, Stopped> {
        let mut moved = Vec::new();
        // One buffer for the moves of every class (a fresh one per class
        // took its pages' first-touch faults again).
        let mut found: Vec<Option<([f64; 3], bool)>> = Vec::new();
        for class in classes {
            if stop() {
                return Err(Stopped);
            }
            let shared: &[[f64; 3]] = points;
            class
                .par_iter()
                .enumerate()
                .with_min_len(64)
                .map_init(Vec::new, |corners, (x, &i)| {
                    prefetch_ahead(stars, shared, class, active, x);
                    if active.is_some_and(|a| !a[i as usize]) {
                        return None;
                    }
                    let (ring, refs) = (stars.ring(i), stars.refs(i));
                    let (q, shortest) = self.step(k, chord, i, ring, refs, shared, corners)?;
                    Some((q, norm(sub(q, shared[i as usize])) > wake * shortest))
                })
                .collect_into_vec(&mut found);
            // A class of colour_stars is ascending: written back in
            // parallel blocks of the points.
            write_ascending(points, class, |x| found[x].map(|(q, _)| q));
            moved.par_extend(
                class
                    .par_iter()
                    .zip(found.par_iter())
                    .filter_map(|(&i, q)| matches!(q, Some((_, true))).then_some(i)),
            );
        }
        Ok(moved)
    }
}

/// Moves ahead in a class whose memory [`Problem::sweep`] asks for early:
/// the ring and references of the vertex [`SWEEP_AHEAD`] places on, the
/// ring's points of the one half as far (its ring fetched by then).
const SWEEP_AHEAD: usize = 8;

/// Asks the processor for what the moves a few places further down `class`
/// will read (see [`SWEEP_AHEAD`]). Only a hint: it changes no result.
fn prefetch_ahead(
    stars: &Stars,
    points: &[[f64; 3]],
    class: &[u32],
    active: Option<&[bool]>,
    x: usize,
) {
    let awake = |v: u32| active.is_none_or(|a| a[v as usize]);
    if let Some(&v) = class.get(x + SWEEP_AHEAD) {
        let at = stars.start[v as usize];
        prefetch(stars.ring.as_ptr().wrapping_add(at));
        prefetch(stars.refs.as_ptr().wrapping_add(at));
    }
    if let Some(&v) = class.get(x + SWEEP_AHEAD / 2) {
        if awake(v) {
            for &r in stars.ring(v) {
                prefetch(&points[r as usize]);
            }
        }
    }
}

/// The faces around one vertex: each face's surface reference, and the
/// ring's points gathered once for the several evaluations of a move.
struct Star<'a> {
    refs: &'a [Reference],
    corners: &'a [[f64; 3]],
}

impl<'a> Star<'a> {
    fn gather(
        refs: &'a [Reference],
        ring: &[u32],
        points: &[[f64; 3]],
        corners: &'a mut Vec<[f64; 3]>,
    ) -> Star<'a> {
        corners.clear();
        corners.extend(ring.iter().map(|&r| points[r as usize]));
        Star { refs, corners }
    }

    fn energy(&self, energy: Energy, k: f64, chord: f64, p: [f64; 3]) -> f64 {
        star_energy(energy, k, chord, p, self.refs, self.corners)
    }

    fn hessian(
        &self,
        energy: Energy,
        k: f64,
        chord: f64,
        p: [f64; 3],
    ) -> (f64, [f64; 3], [[f64; 3]; 3]) {
        star_hessian(energy, k, chord, p, self.refs, self.corners)
    }
}

/// The energy of the faces `(p, corners[j], corners[j + 1])` with references
/// `refs[j]`, plus `chord` times their chord areas, one face at a time in
/// ring order (what [`crate::methods::progressive::star_lanes`] matches bit
/// for bit, four faces at a time).
pub(crate) fn star_energy(
    energy: Energy,
    k: f64,
    chord: f64,
    p: [f64; 3],
    refs: &[Reference],
    corners: &[[f64; 3]],
) -> f64 {
    let m = corners.len();
    refs.iter()
        .enumerate()
        .map(|(j, r)| {
            star_lanes::face_energy_one(energy, r, k, chord, [p, corners[j], corners[(j + 1) % m]])
        })
        .sum()
}

/// [`star_energy`] with its gradient and Hessian at `p`, one face at a time
/// in ring order.
pub(crate) fn star_hessian(
    energy: Energy,
    k: f64,
    chord: f64,
    p: [f64; 3],
    refs: &[Reference],
    corners: &[[f64; 3]],
) -> (f64, [f64; 3], [[f64; 3]; 3]) {
    let m = corners.len();
    let mut total = (0.0, [0.0; 3], [[0.0; 3]; 3]);
    for (j, r) in refs.iter().enumerate() {
        let (a, b) = (corners[j], corners[(j + 1) % m]);
        let (mut e, mut g, mut h) = face_energy_hessian(energy, r, k, p, a, b);
        if chord != 0.0 && e.is_finite() {
            let (ca, cg, ch) = chord_area_hessian(p, a, b);
            e += chord * ca;
            g = add(g, scale(cg, chord));
            for (row, c_row) in h.iter_mut().zip(ch) {
                *row = add(*row, scale(c_row, chord));
            }
        }
        total.0 += e;
        total.1 = add(total.1, g);
        for (row, h_row) in total.2.iter_mut().zip(h) {
            *row = add(*row, h_row);
        }
    }
    total
}

/// Refuses a stopping tolerance that is negative or not finite.
pub fn check_tolerance(tolerance: f64) -> Result<(), crate::error::SphereError> {
    if tolerance >= 0.0 && tolerance.is_finite() {
        return Ok(());
    }
    Err(crate::error::SphereError::InvalidParameter {
        name: "tolerance",
        value: tolerance.to_string(),
        expected: "a finite number >= 0",
    })
}

/// A sweep was asked to stop.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stopped;

/// Whether every face `(p, r_j, r_j+1)` is positively oriented, exactly.
pub fn positive_star(p: [f64; 3], ring: &[u32], points: &[[f64; 3]]) -> bool {
    all_positive(p, ring.len(), |j| points[ring[j] as usize])
}

fn all_positive(p: [f64; 3], m: usize, corner: impl Fn(usize) -> [f64; 3]) -> bool {
    (0..m).all(|j| det3_sign(p, corner(j), corner((j + 1) % m)) == Sign::Positive)
}

/// An orthonormal basis of the plane orthogonal to the unit vector `p`.
pub fn tangent_basis(p: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let axis = if p[0].abs() <= p[1].abs() && p[0].abs() <= p[2].abs() {
        [1.0, 0.0, 0.0]
    } else if p[1].abs() <= p[2].abs() {
        [0.0, 1.0, 0.0]
    } else {
        [0.0, 0.0, 1.0]
    };
    let e1 = cross(p, axis);
    let e1 = scale(e1, 1.0 / norm(e1));
    (e1, cross(p, e1))
}

/// The rings laid end to end, as [`Problem::stars_of`] takes them: vertex
/// `i`'s at `start[i]..start[i + 1]`.
pub fn flat_rings(rings: &[Vec<u32>]) -> (Vec<usize>, Vec<u32>) {
    let mut start = Vec::with_capacity(rings.len() + 1);
    start.push(0);
    for ring in rings {
        start.push(start[start.len() - 1] + ring.len());
    }
    (start, rings.concat())
}

/// Greedy colouring of the vertices with non-empty rings, in index order:
/// each class holds vertices no two of which are neighbours (so no two share
/// a face). Deterministic.
pub fn colour_classes(rings: &[Vec<u32>]) -> Vec<Vec<u32>> {
    greedy_colouring(rings.len(), |i| &rings[i])
}

/// [`colour_classes`] of the rings laid end to end (vertex `i`'s at
/// `ring[start[i]..start[i + 1]]`, as [`flat_rings`] gives them).
pub fn colour_flat(start: &[usize], ring: &[u32]) -> Vec<Vec<u32>> {
    greedy_colouring(start.len() - 1, |i| &ring[start[i]..start[i + 1]])
}

/// [`colour_classes`] of the rings of `stars`.
pub fn colour_stars(stars: &Stars) -> Vec<Vec<u32>> {
    greedy_colouring(stars.len(), |i| stars.ring(i as u32))
}

fn greedy_colouring<'r>(n: usize, ring_of: impl Fn(usize) -> &'r [u32]) -> Vec<Vec<u32>> {
    const NONE: u16 = u16::MAX;
    let mut colour = vec![NONE; n];
    let mut classes: Vec<Vec<u32>> = Vec::new();
    let mut used: Vec<bool> = Vec::new();
    for i in 0..n {
        let ring = ring_of(i);
        if ring.is_empty() {
            continue;
        }
        used.iter_mut().for_each(|u| *u = false);
        for &r in ring {
            let c = colour[r as usize];
            if c != NONE {
                used[c as usize] = true;
            }
        }
        let c = used.iter().position(|u| !u).unwrap_or(used.len());
        if c == used.len() {
            used.push(false);
            classes.push(Vec::new());
        }
        colour[i] = c as u16;
        classes[c].push(i as u32);
    }
    classes
}

/// How [`Problem::optimise`] ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Optimised {
    pub sweeps: usize,
    /// Total energy per unit of (scaled) surface area at the end.
    pub energy: f64,
    /// Relative fall of the energy in the last sweep.
    pub last_change: f64,
    pub converged: bool,
    /// The area scale `k` of the last sweep (see [`Problem::area_scale`]).
    pub scale: f64,
    /// Vertices active over all sweeps (each tried once in its sweep).
    pub moves: usize,
}

/// The per-vertex sums of [`Problem::optimise_waking`]'s passes between
/// sweeps, in two buffers kept for all its sweeps (a fresh vector a pass
/// took its pages' first-touch faults again each time).
#[derive(Default)]
struct Passes {
    first: Vec<f64>,
    second: Vec<f64>,
}

/// What a pass of [`Passes::geometry`] also sets: each vertex's activity
/// flag for the next sweep, from the vertices moved and the free ones.
type WakeFlags<'a> = (&'a mut [bool], &'a [bool], &'a (dyn Fn(u32) -> bool + Sync));

impl Passes {
    /// One pass over the rings and points: the area scale `k` of `points`
    /// ([`Problem::area_scale`]), the chord-area sum ([`Problem::chord_total`])
    /// when `chord`, and, with `flags`, each vertex's activity (moved, or
    /// free and next to a moved one). The same sums in the same order as
    /// those functions.
    fn geometry(
        &mut self,
        stars: &Stars,
        points: &[[f64; 3]],
        chord: bool,
        flags: Option<WakeFlags<'_>>,
    ) -> (f64, Option<f64>) {
        let sums = |i: u32| -> (f64, f64) {
            let ring = stars.ring(i);
            (vertex_area(i, ring, points), if chord { vertex_chord(i, ring, points) } else { 0.0 })
        };
        let (first, second) = (&mut self.first, &mut self.second);
        match flags {
            Some((active, moved, free)) => {
                let each = active.par_iter_mut().enumerate().with_min_len(1024).map(|(x, a)| {
                    *a = moved[x]
                        || (free(x as u32)
                            && stars.ring(x as u32).iter().any(|&r| moved[r as usize]));
                    sums(x as u32)
                });
                fill(each, chord, first, second);
            }
            None => {
                let each = (0..stars.len() as u32).into_par_iter().with_min_len(1024).map(sums);
                fill(each, chord, first, second);
            }
        }
        // Fixed orders of summation: the same on every thread count.
        let area = first.iter().fold(0.0, |s, x| s + x);
        (scale_of(area, stars.surface_total), chord.then(|| second.iter().sum::<f64>()))
    }

    /// One pass over the stars: [`Problem::total_energy`] at `k`, and at
    /// `also` when given, the same sums in the same order.
    fn energies(
        &mut self,
        problem: &Problem<'_>,
        k: f64,
        also: Option<f64>,
        stars: &Stars,
        points: &[[f64; 3]],
    ) -> (f64, Option<f64>) {
        let each = (0..stars.len() as u32).into_par_iter().with_min_len(1024).map(|i| {
            let at = |k: f64| problem.vertex_energy(i, stars, points, k);
            (at(k), also.map_or(0.0, at))
        });
        let (first, second) = (&mut self.first, &mut self.second);
        fill(each, also.is_some(), first, second);
        // Fixed orders of summation: the same totals on every thread count.
        (first.iter().sum::<f64>(), also.map(|_| second.iter().sum::<f64>()))
    }
}

/// Vertex `i`'s share of [`Problem::area_scale`]'s image area: half the
/// determinants of its faces, in ring order (each face counted from each of
/// its three corners, as the surface total counts it).
#[inline]
fn vertex_area(i: u32, ring: &[u32], points: &[[f64; 3]]) -> f64 {
    let m = ring.len();
    let mut sum = 0.0;
    for j in 0..m {
        let [p, pa, pb] = [i, ring[j], ring[(j + 1) % m]].map(|v| points[v as usize]);
        sum += 0.5 * det3(p, pa, pb);
    }
    sum
}

/// Vertex `i`'s share of [`Problem::chord_total`]: the chord areas of its
/// faces that it is the smallest corner of, in ring order.
#[inline]
fn vertex_chord(i: u32, ring: &[u32], points: &[[f64; 3]]) -> f64 {
    let m = ring.len();
    let p = points[i as usize];
    (0..m)
        .filter(|&j| i < ring[j] && i < ring[(j + 1) % m])
        .map(|j| chord_area(p, points[ring[j] as usize], points[ring[(j + 1) % m] as usize]))
        .sum::<f64>()
}

/// The per-vertex pairs of `each` into `first` and, when `both`, `second`.
fn fill(
    each: impl IndexedParallelIterator<Item = (f64, f64)>,
    both: bool,
    first: &mut Vec<f64>,
    second: &mut Vec<f64>,
) {
    if both {
        each.unzip_into_vecs(first, second);
    } else {
        each.map(|(x, _)| x).collect_into_vec(first);
    }
}

/// The area scale from the image's area sum and the surface's (see
/// [`Problem::area_scale`]).
fn scale_of(chord: f64, surface: f64) -> f64 {
    if surface > 0.0 && chord > 0.0 {
        chord / surface
    } else {
        1.0
    }
}

impl Problem<'_> {
    /// Sweeps over every vertex with a ring until the energy falls by less
    /// than `tolerance` (relative) in a sweep, or `max_sweeps` sweeps.
    pub fn optimise(
        &self,
        rings: &[Vec<u32>],
        points: &mut [[f64; 3]],
        max_sweeps: usize,
        tolerance: f64,
        stop: &(dyn Fn(usize) -> bool + Sync),
    ) -> Result<Optimised, Stopped> {
        self.optimise_holding(rings, points, max_sweeps, tolerance, None, stop)
    }

    /// [`Problem::optimise`] with the vertices marked in `held` (one flag
    /// per vertex) never moved: the landmarks of
    /// [`crate::methods::progressive::landmarks`]. With `None` it is
    /// `optimise` itself, move for move.
    pub fn optimise_holding(
        &self,
        rings: &[Vec<u32>],
        points: &mut [[f64; 3]],
        max_sweeps: usize,
        tolerance: f64,
        held: Option<&[bool]>,
        stop: &(dyn Fn(usize) -> bool + Sync),
    ) -> Result<Optimised, Stopped> {
        let stars = self.stars(rings);
        self.optimise_stars(&stars, points, max_sweeps, tolerance, held, stop)
    }

    /// [`Problem::optimise_holding`] on rings already gathered with their
    /// references ([`Problem::stars`], [`Problem::stars_of`]).
    pub fn optimise_stars(
        &self,
        stars: &Stars,
        points: &mut [[f64; 3]],
        max_sweeps: usize,
        tolerance: f64,
        held: Option<&[bool]>,
        stop: &(dyn Fn(usize) -> bool + Sync),
    ) -> Result<Optimised, Stopped> {
        self.optimise_waking(stars, points, (max_sweeps, tolerance), held, NOTICEABLE, stop)
    }

    /// [`Problem::optimise_stars`] (with `(max_sweeps, tolerance)`) where a
    /// vertex wakes itself and its neighbours for the next sweep only by
    /// moving more than `wake` of its shortest edge, instead of
    /// [`NOTICEABLE`]: with a larger `wake`, later sweeps move only where the
    /// map still changes (issue 22: the final sweeps of large limbed
    /// balanced maps, see the progressive method's `LIMBED_WAKE`).
    pub fn optimise_waking(
        &self,
        stars: &Stars,
        points: &mut [[f64; 3]],
        (max_sweeps, tolerance): (usize, f64),
        held: Option<&[bool]>,
        wake: f64,
        stop: &(dyn Fn(usize) -> bool + Sync),
    ) -> Result<Optimised, Stopped> {
        self.sweeps_until(stars, None, points, (max_sweeps, tolerance), held, wake, true, stop)
    }

    /// [`Problem::optimise_waking`] with the colour classes of `stars`
    /// already made ([`colour_flat`] of the rings that `stars` took over):
    /// the same sweeps. The colouring is serial; made before the stars, it
    /// can run beside other serial work.
    #[allow(clippy::too_many_arguments)]
    pub fn optimise_coloured(
        &self,
        stars: &Stars,
        classes: Vec<Vec<u32>>,
        points: &mut [[f64; 3]],
        (max_sweeps, tolerance): (usize, f64),
        held: Option<&[bool]>,
        wake: f64,
        stop: &(dyn Fn(usize) -> bool + Sync),
    ) -> Result<Optimised, Stopped> {
        let classes = Some(classes);
        self.sweeps_until(stars, classes, points, (max_sweeps, tolerance), held, wake, true, stop)
    }

    /// [`Problem::optimise_stars`] (nothing held) for a caller that reads
    /// only the area scale at the end (a coarse level of the progressive
    /// method): the same moves, points and scale, without the energy after
    /// the last sweep allowed, which would decide nothing.
    pub fn optimise_stars_for_scale(
        &self,
        stars: &Stars,
        points: &mut [[f64; 3]],
        max_sweeps: usize,
        tolerance: f64,
        stop: &(dyn Fn(usize) -> bool + Sync),
    ) -> Result<f64, Stopped> {
        let end = self.sweeps_until(
            stars,
            None,
            points,
            (max_sweeps, tolerance),
            None,
            NOTICEABLE,
            false,
            stop,
        )?;
        Ok(end.scale)
    }

    /// The sweeps of [`Problem::optimise_waking`]; with `report` false the
    /// energy after the last sweep allowed is not measured (the result's
    /// `energy` and `last_change` are then NaN; its `scale` is measured).
    ///
    /// Between two sweeps the mesh is read in two passes (issue 27): one
    /// over the rings and points (the area scale, the chord-area sum where
    /// it is weighed, and the next sweep's activity flags) and one over the
    /// references too (the energy at the new area scale, and at the old one
    /// where the chord term needs it); each value is the sum of the passes
    /// it replaces (`area_scale`, `chord_total`, `total_energy`), the same
    /// operations in the same order, so the same bits. The per-vertex sums
    /// go to two buffers kept for all the sweeps.
    #[allow(clippy::too_many_arguments)]
    fn sweeps_until(
        &self,
        stars: &Stars,
        classes: Option<Vec<Vec<u32>>>,
        points: &mut [[f64; 3]],
        (max_sweeps, tolerance): (usize, f64),
        held: Option<&[bool]>,
        wake: f64,
        report: bool,
        stop: &(dyn Fn(usize) -> bool + Sync),
    ) -> Result<Optimised, Stopped> {
        let weighs_chord = chord_area::applies(self.energy);
        let mut sums = Passes::default();
        // The greedy colouring is serial: it runs beside the first area
        // scale, chord-area sum and energy, which are parallel and need no
        // colours.
        let shared: &[[f64; 3]] = points;
        let mut first_sums = || {
            let (k, chord) = sums.geometry(stars, shared, weighs_chord, None);
            (k, chord, sums.energies(self, k, None, stars, shared).0)
        };
        let (classes, (mut k, mut chord, mut energy)) = match classes {
            Some(classes) => (classes, first_sums()),
            None => rayon::join(|| colour_stars(stars), first_sums),
        };
        let free = |v: u32| held.is_none_or(|h| !h[v as usize]);
        let mut active: Vec<bool> = (0..stars.len() as u32).map(free).collect();
        let mut was_moved = vec![false; stars.len()];
        let mut result = Optimised {
            sweeps: 0,
            energy,
            last_change: f64::INFINITY,
            converged: false,
            scale: k,
            moves: 0,
        };
        // `chord`: the chord-area sum C of the current points, once known:
        // the sum after a sweep is the next sweep's before it and its
        // weight's.
        while result.sweeps < max_sweeps {
            let sweeps = result.sweeps;
            // The sweep lowers E + mu C (see chord_area); its change is
            // measured on that same sum. (It was taken from 2 E, right only
            // for the full chord weight: with 0.3 of it every sweep seemed
            // to lower the sum by a third, and the sweeps never stopped
            // before their most.)
            let mu = if weighs_chord {
                let c = *chord.get_or_insert_with(|| self.chord_total(stars, points));
                chord_area::weight(true, energy, c)
            } else {
                0.0
            };
            let before = match chord {
                Some(c) if mu != 0.0 => energy + mu * c,
                _ => energy,
            };
            result.moves += active.iter().filter(|&&a| a).count();
            let moved =
                self.sweep(k, mu, &classes, stars, points, Some(&active), wake, &|| stop(sweeps))?;
            result.sweeps += 1;
            let more = result.sweeps < max_sweeps;
            if !report && !more {
                // The caller reads only the scale: the energy after the last
                // sweep allowed decides nothing.
                k = sums.geometry(stars, points, false, None).0;
                result.energy = f64::NAN;
                result.last_change = f64::NAN;
                result.scale = k;
                return Ok(result);
            }
            // Only what moved, and its neighbours, can still go down much: a
            // vertex is active when it moved or, free, is next to one that
            // did (every ring lists its neighbours, and they list it). Per
            // vertex, in parallel, in the pass of the area scale; not after
            // the last sweep allowed (nothing reads them).
            let flags = if more {
                was_moved.iter_mut().for_each(|m| *m = false);
                for &v in &moved {
                    was_moved[v as usize] = true;
                }
                Some((
                    active.as_mut_slice(),
                    was_moved.as_slice(),
                    &free as &(dyn Fn(u32) -> bool + Sync),
                ))
            } else {
                None
            };
            // The points have moved: C is known again only if measured here.
            let (next_k, next_chord) = sums.geometry(stars, points, mu != 0.0, flags);
            chord = next_chord;
            // The energy at the new scale, and the sum E + mu C at the old
            // one where C is weighed.
            let (next, at_old) =
                sums.energies(self, next_k, chord.is_some().then_some(k), stars, points);
            let after = match (chord, at_old) {
                (Some(c), Some(e)) => e + mu * c,
                _ => 0.0,
            };
            k = next_k;
            result.last_change = if mu == 0.0 {
                (energy - next).abs() / energy.abs().max(f64::MIN_POSITIVE)
            } else {
                (before - after).abs() / before.abs().max(f64::MIN_POSITIVE)
            };
            energy = next;
            if moved.is_empty() || result.last_change < tolerance {
                result.converged = true;
                break;
            }
        }
        let surface_area = self.surface_area(stars);
        result.energy = energy / (k * surface_area).max(f64::MIN_POSITIVE);
        result.scale = k;
        Ok(result)
    }

    /// This problem on a coarse level of a progressive mesh: surface triangles
    /// smaller than [`LEVEL_AREA_FLOOR`] times the level's mean face area
    /// count as that large.
    pub fn at_level(&self, rings: &[Vec<u32>]) -> Problem<'_> {
        self.at_level_of(rings.len(), &|i| &rings[i])
    }

    /// [`Problem::at_level`] on `n` vertices whose rings `ring_of` gives.
    pub fn at_level_of<'r>(
        &self,
        n: usize,
        ring_of: &(dyn Fn(usize) -> &'r [u32] + Sync),
    ) -> Problem<'_> {
        let (area, corners): (f64, usize) = (0..n)
            .into_par_iter()
            .map(|i| {
                let ring = ring_of(i);
                let m = ring.len();
                let area: f64 =
                    (0..m).map(|j| self.reference(i as u32, ring[j], ring[(j + 1) % m]).area).sum();
                (area, m)
            })
            .collect::<Vec<_>>()
            .into_iter()
            .fold((0.0, 0), |t, x| (t.0 + x.0, t.1 + x.1));
        // Each face is seen from its three corners.
        let mean = (area / 3.0) / (corners / 3).max(1) as f64;
        let floor = LEVEL_AREA_FLOOR * mean;
        Problem {
            area_floor: self.area_floor.max(if floor.is_finite() { floor } else { 0.0 }),
            ..*self
        }
    }
}
