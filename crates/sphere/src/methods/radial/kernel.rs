//! The kernel of a star-shaped mesh: the points that see every face from
//! inside, and the deepest of them (thesis 3.5, 9.3.1).
//!
//! The kernel is `K = { p : n_f . (a_f - p) > 0 for every face f }` (outward
//! normals `n_f`, any vertex `a_f` of `f`); radial projection from a point of
//! `K` is flip-free ([`crate::methods::radial`]). The Chebyshev-like centre of the kernel,
//!
//! ```text
//! maximise t  subject to  n̂_f . (a_f - p) >= t  for every face f,  p in the bounding box,
//! ```
//!
//! with unit normals `n̂_f`, is a linear program in the four unknowns `(p, t)`.
//! Its optimum `t*` is the depth of the deepest kernel point (the radius of the
//! largest ball that stays on the inner side of every face plane); `t* <= 0`
//! means the kernel is empty and the mesh is not star-shaped from any point.
//! The LP is solved by the small active-set (primal simplex) method in
//! [`crate::methods::radial::lp`], which keeps its iterate feasible and costs one O(F) pass per
//! pivot; large meshes first solve a sample of the faces and then add only the
//! faces the sample's optimum violates (Clarkson-style), so a million faces
//! take a handful of passes. Faces whose corners are exactly collinear have no
//! normal and are left out: no centre can orient them (their projection is a
//! degenerate spherical triangle from every point), so such a mesh cannot map
//! validly and the exact check will say so.

use rayon::prelude::*;
use spherify_mesh::predicates::collinear3;
use spherify_mesh::vec3::{cross, dot, sub};
use spherify_mesh::Mesh;

use crate::error::SphereError;
use crate::methods::initial::vertex_mean;
use crate::methods::radial::lp;

/// The optimum of the kernel LP: the deepest point of the kernel when the
/// kernel is non-empty, else the point that comes nearest to seeing every face
/// from inside.
#[derive(Debug, Clone, PartialEq)]
pub struct KernelPoint {
    pub point: [f64; 3],
    /// `min_f n̂_f . (a_f - point)` in mesh units: positive inside the kernel.
    pub depth: f64,
    /// Simplex pivots the LP took (over all of its rounds).
    pub pivots: usize,
    /// Whether the LP proved its optimum (false only if it ran out of pivots).
    pub optimal: bool,
    /// Faces left out of the LP because their corners are exactly collinear:
    /// they have no normal, and no centre can orient them (their projection is
    /// a degenerate spherical triangle from every point).
    pub skipped_faces: usize,
}

/// A kernel depth at or below this fraction of the bounding box's half-size
/// counts as an empty kernel: the LP's data (unit normals of rounded vertex
/// differences) are accurate to about 1e-15 of that size, so a smaller
/// positive optimum is not evidence of a kernel.
const DEPTH_TOL: f64 = 1e-12;

/// Upper bound on simplex pivots; far above what meshes need (tens), it only
/// guards against cycling that the anti-cycling rule did not prevent.
const MAX_PIVOTS: usize = 20_000;

/// Above this many rows the LP is solved on a sample first (see [`solve`]).
const SAMPLE_ABOVE: usize = 20_000;

/// Rounds of adding violated rows to the sample before falling back to the
/// full LP (a safety net: two to four rounds are typical).
const MAX_ROUNDS: usize = 12;

/// A point strictly inside every face's inner half-space, as deep as possible
/// (the optimum of the kernel LP). O(F) per LP pivot.
///
/// # Errors
/// [`SphereError::NotStarShaped`] when the kernel is empty (a depth of at
/// most 1e-12 of the bounding box's half-size), with the best depth found
/// and the number of faces that face away from the vertex mean.
pub fn kernel_point(mesh: &Mesh) -> Result<[f64; 3], SphereError> {
    kernel(mesh).map(|k| k.point)
}

/// [`kernel_point`] with the LP's account (depth, pivots, skipped faces).
///
/// # Errors
/// As [`kernel_point`].
pub fn kernel(mesh: &Mesh) -> Result<KernelPoint, SphereError> {
    let k = deepest_point(mesh)?;
    if k.depth > DEPTH_TOL * Frame::of(mesh.positions()).scale {
        return Ok(k);
    }
    let mean = vertex_mean(mesh.positions());
    let depth = if k.depth <= 0.0 {
        format!("still lies {:.3e} outside some face's plane", -k.depth)
    } else {
        format!(
            "lies only {:.3e} inside every face's plane, within round-off of the mesh size",
            k.depth
        )
    };
    let mut detail = format!(
        ": the deepest point {} {depth}; {} of {} faces face away from the vertex mean",
        format_point(k.point),
        backfacing(mesh, mean),
        mesh.n_faces()
    );
    if !k.optimal {
        detail +=
            &format!("; the LP stopped after {} pivots without proving its optimum", k.pivots);
    }
    Err(SphereError::NotStarShaped { detail })
}

/// Solves the kernel LP and returns its optimum, whatever its sign.
///
/// # Errors
/// [`SphereError::NotStarShaped`] only when no face has a normal.
pub fn deepest_point(mesh: &Mesh) -> Result<KernelPoint, SphereError> {
    let frame = Frame::of(mesh.positions());
    let (rows, skipped_faces) = kernel_rows(mesh, &frame);
    if skipped_faces == mesh.n_faces() {
        return Err(SphereError::NotStarShaped { detail: ": no face has a non-zero area".into() });
    }
    // Start at the vertex mean; the LP pushes p away from the nearest planes.
    let start = frame.to_local(vertex_mean(mesh.positions()));
    // The box rows keep the LP bounded, so `Unbounded` cannot happen; report
    // it as an empty kernel rather than panic if it ever does.
    let solution = solve(&rows, start).map_err(|lp::Unbounded| SphereError::NotStarShaped {
        detail: ": the kernel LP is unbounded".into(),
    })?;
    let p = [solution.x[0], solution.x[1], solution.x[2]];
    // The depth of p from the data rather than the LP's t, which may carry
    // pivoting round-off; face rows hold (n̂, 1, n̂.g) / sqrt2.
    let depth = rows[..rows.len() - 6]
        .par_iter()
        .map(|r| (r[4] - (r[0] * p[0] + r[1] * p[1] + r[2] * p[2])) * std::f64::consts::SQRT_2)
        .reduce(|| f64::INFINITY, f64::min);
    Ok(KernelPoint {
        point: frame.to_world(p),
        depth: depth * frame.scale,
        pivots: solution.pivots,
        optimal: solution.optimal,
        skipped_faces,
    })
}

/// Maximises t over `rows` from `(start, t)` with the largest feasible t.
///
/// Large problems go through a sample first, in the manner of Clarkson's
/// algorithm: solve the LP on every k-th row (plus the box), add every row
/// the sample's optimum violates, and solve again until none is violated.
/// The sample's optimum is then feasible for all rows and optimal for a
/// relaxation, hence optimal. Each round costs one O(F) pass instead of one
/// pass per pivot, and few rows ever enter the small LP. The fixed stride and
/// rows taken in index order keep the result deterministic.
fn solve(rows: &[[f64; 5]], start: [f64; 3]) -> Result<lp::Solution, lp::Unbounded> {
    let objective = [0.0, 0.0, 0.0, 1.0];
    let n_face_rows = rows.len() - 6;
    if rows.len() <= SAMPLE_ABOVE {
        return lp::maximize(rows, objective, feasible_start(rows, start), MAX_PIVOTS);
    }
    let stride = n_face_rows / (SAMPLE_ABOVE / 4);
    let mut working: Vec<usize> =
        (0..n_face_rows).step_by(stride).chain(n_face_rows..rows.len()).collect();
    let mut p = start;
    let mut pivots = 0;
    for _ in 0..MAX_ROUNDS {
        let sub: Vec<[f64; 5]> = working.iter().map(|&i| rows[i]).collect();
        let s = lp::maximize(&sub, objective, feasible_start(&sub, p), MAX_PIVOTS)?;
        pivots += s.pivots;
        p = [s.x[0], s.x[1], s.x[2]];
        // Violated beyond round-off; rows the LP treats as parallel to its
        // active rows may miss by about that much and must not loop forever.
        let violated: Vec<usize> = rows
            .par_iter()
            .enumerate()
            .filter(|(_, r)| lp::slack(r, s.x) < -1e-12 * (1.0 + r[4].abs()))
            .map(|(i, _)| i)
            .collect();
        if violated.is_empty() {
            let active = s.active.iter().map(|&j| working[j]).collect();
            return Ok(lp::Solution { pivots, active, ..s });
        }
        working.extend(violated);
        working.sort_unstable();
        working.dedup();
    }
    let s = lp::maximize(rows, objective, feasible_start(rows, p), MAX_PIVOTS)?;
    Ok(lp::Solution { pivots: pivots + s.pivots, ..s })
}

/// Coordinates centred on the bounding box and scaled by its largest
/// half-extent, so that the LP's tolerances are relative to the mesh size
/// and translated or scaled copies of a mesh give the same LP.
#[derive(Debug, Clone, Copy)]
struct Frame {
    lo: [f64; 3],
    hi: [f64; 3],
    center: [f64; 3],
    scale: f64,
}

impl Frame {
    fn of(positions: &[[f64; 3]]) -> Frame {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let center = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
        let half = (0..3).map(|k| 0.5 * (hi[k] - lo[k])).fold(0.0, f64::max);
        // A single point (no extent) keeps scale 1: every face is then
        // degenerate and skipped anyway.
        let scale = if half > 0.0 && half.is_finite() { half } else { 1.0 };
        Frame { lo, hi, center, scale }
    }

    fn to_local(self, x: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|k| (x[k] - self.center[k]) / self.scale)
    }

    fn to_world(self, y: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|k| self.center[k] + self.scale * y[k])
    }
}

/// The LP's constraint rows `[a, b]` meaning `a . (p, t) <= b`, in local
/// coordinates: one per face, `(n̂, 1) . (p, t) <= n̂ . g` (g the face
/// centroid, which averages the rounding of the three corners), scaled by
/// 1/sqrt2 so that `|a| = 1`; then the six bounding-box rows. A face whose
/// corners are exactly collinear has no normal and gets the row `0 <= inf`,
/// which never binds (one array in face order keeps the pass cheap). Also
/// returns the number of such faces.
fn kernel_rows(mesh: &Mesh, frame: &Frame) -> (Vec<[f64; 5]>, usize) {
    let x = mesh.positions();
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let inv_scale = 1.0 / frame.scale;
    let mut rows: Vec<[f64; 5]> = mesh
        .faces()
        .par_iter()
        .map(|&[i, j, k]| {
            let (a, b, c) = (x[i as usize], x[j as usize], x[k as usize]);
            // Edge vectors from the input coordinates (translation does not
            // change them and the scale does not change the unit normal).
            let (e1, e2) = (sub(b, a), sub(c, a));
            let n = cross(e1, e2);
            let len = dot(n, n).sqrt();
            // A tiny cross product may be rounding on collinear corners, whose
            // "normal" would be a random direction and could cut the kernel
            // away; only the exact collinearity test may drop a face.
            let tiny = len <= 1e-12 * dot(e1, e1).sqrt() * dot(e2, e2).sqrt();
            if !(len > 0.0 && len.is_finite()) || (tiny && collinear3(a, b, c)) {
                return [0.0, 0.0, 0.0, 0.0, f64::INFINITY];
            }
            let u = n.map(|v| v / len);
            let g = [0, 1, 2].map(|q| ((a[q] + b[q] + c[q]) / 3.0 - frame.center[q]) * inv_scale);
            [u[0] * s, u[1] * s, u[2] * s, s, dot(u, g) * s]
        })
        .collect();
    let skipped = rows.par_iter().filter(|r| r[3] == 0.0).count();
    let (lo, hi) = (frame.to_local(frame.lo), frame.to_local(frame.hi));
    for k in 0..3 {
        let mut r = [0.0; 5];
        r[k] = 1.0;
        r[4] = hi[k];
        rows.push(r);
        r[k] = -1.0;
        r[4] = -lo[k];
        rows.push(r);
    }
    (rows, skipped)
}

/// `(p, t)` with the largest t that satisfies every face row at `p`.
fn feasible_start(rows: &[[f64; 5]], p: [f64; 3]) -> [f64; 4] {
    let t = rows
        .par_iter()
        .filter(|r| r[3] > 0.0)
        .map(|r| (r[4] - (r[0] * p[0] + r[1] * p[1] + r[2] * p[2])) / r[3])
        .reduce(|| f64::INFINITY, f64::min);
    [p[0], p[1], p[2], if t.is_finite() { t } else { 0.0 }]
}

/// Faces that do not face `m` from inside, decided exactly: orient3d(a, b, c, m)
/// is `det[a - m; b - m; c - m]`, the orientation of the face projected from m.
pub fn backfacing(mesh: &Mesh, m: [f64; 3]) -> usize {
    let x = mesh.positions();
    let c = |p: [f64; 3]| robust::Coord3D { x: p[0], y: p[1], z: p[2] };
    mesh.faces()
        .par_iter()
        .filter(|&&[i, j, k]| {
            robust::orient3d(c(x[i as usize]), c(x[j as usize]), c(x[k as usize]), c(m)) <= 0.0
        })
        .count()
}

pub(crate) fn format_point(p: [f64; 3]) -> String {
    format!("({:.6e}, {:.6e}, {:.6e})", p[0], p[1], p[2])
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::methods::radial::lp::tests::{brute_force, Rng};
    use spherify_mesh::solids::lat_long_sphere;

    /// A smooth spike of height `a` round direction `axis`, `width` radians wide.
    pub(crate) fn spike(u: [f64; 3], axis: [f64; 3], a: f64, width: f64) -> f64 {
        let c = dot(u, axis);
        let w = width.cos();
        if c <= w {
            0.0
        } else {
            a * ((c - w) / (1.0 - w)).powi(2)
        }
    }

    pub(crate) fn bent_positions(p: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let r0 = 3.2;
        p.iter()
            .map(|&[x, y, z]| {
                let (theta, r) = (8.0 * x / r0, r0 + y);
                [r * theta.sin(), r * theta.cos(), z]
            })
            .collect()
    }

    #[test]
    fn a_zero_area_face_is_left_out_of_the_lp() {
        // The octahedron with the midpoint M of edge A = v0, B = v2 put on one
        // side of that edge: face (A, M, B) has exactly collinear corners.
        let mut p = spherify_mesh::solids::OCTAHEDRON_POSITIONS.to_vec();
        p.push([0.5, 0.5, 0.0]);
        // (2, 0, 5) had edge 2->0 (B->A); it becomes (6, 0, 5), (2, 6, 5).
        let f = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [6, 0, 5],
            [2, 6, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
            [0, 6, 2],
        ];
        let m = Mesh::new(p, f).unwrap();
        let k = kernel(&m).unwrap();
        assert_eq!(k.skipped_faces, 1);
        assert!(k.depth > 0.1);
        assert_eq!(
            backfacing(&m, k.point),
            1,
            "only the degenerate face, whose orientation is zero"
        );
    }

    #[test]
    fn sampled_lp_agrees_with_the_full_lp_on_large_meshes() {
        let spiky_fine = lat_long_sphere(100, 110, |u| {
            1.0 + spike(u, [1.0, 0.0, 0.0], 30.0, 0.35) + spike(u, [0.0, 1.0, 0.0], 4.0, 0.3)
        });
        let tube = lat_long_sphere(100, 110, |_| 1.0);
        let bent_fine = Mesh::new(bent_positions(tube.positions()), tube.faces().to_vec()).unwrap();
        for m in [spiky_fine, bent_fine] {
            let frame = Frame::of(m.positions());
            let (rows, _) = kernel_rows(&m, &frame);
            assert!(rows.len() > SAMPLE_ABOVE);
            let start = frame.to_local(vertex_mean(m.positions()));
            let sampled = solve(&rows, start).unwrap();
            let full =
                lp::maximize(&rows, [0.0, 0.0, 0.0, 1.0], feasible_start(&rows, start), MAX_PIVOTS)
                    .unwrap();
            assert!(sampled.optimal && full.optimal);
            assert!((sampled.x[3] - full.x[3]).abs() < 1e-12, "{} vs {}", sampled.x[3], full.x[3]);
        }
    }

    #[test]
    fn kernel_lp_matches_brute_force_on_random_polyhedra() {
        // The kernel LP of random small polyhedra (random radii over an
        // octahedron-like grid), against vertex enumeration of the same rows.
        let mut rng = Rng(11);
        let trials = if cfg!(debug_assertions) { 8 } else { 200 };
        for trial in 0..trials {
            let m = lat_long_sphere(3, 6, |_| rng.uniform(0.3, 1.5));
            let frame = Frame::of(m.positions());
            let (rows, _) = kernel_rows(&m, &frame);
            let want = brute_force(&rows, [0.0, 0.0, 0.0, 1.0]) * frame.scale;
            let k = deepest_point(&m).unwrap();
            assert!((k.depth - want).abs() < 1e-9, "trial {trial}: {} vs {want}", k.depth);
        }
    }
}
