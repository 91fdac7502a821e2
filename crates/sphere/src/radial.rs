//! Radial projection (thesis 3.5, eq. 3.17) from a point, from the vertex mean
//! (eq. 3.18), or from the deepest point of the mesh's kernel.
//!
//! Every vertex moves along its ray from a centre `m` onto the unit sphere,
//! `v_i = (x_i - m) / |x_i - m|`. For face `abc` the orientation test of eq. 3.9
//! on the projected points has the sign of `det[a - m; b - m; c - m]`, which is
//! six times the signed volume of the tetrahedron `m a b c`: positive exactly
//! when `m` lies strictly on the inner side of the face's plane. So the map is
//! flip-free exactly when `m` lies in the *kernel*
//! `K = { p : n_f . (a_f - p) > 0 for every face f }` (outward normals `n_f`,
//! any vertex `a_f` of `f`), and for an embedded surface it then covers the
//! sphere once: a valid GC-embedding. The kernel is non-empty exactly when the
//! mesh is star-shaped (a self-intersecting mesh may wind around `m` more than
//! once; the exact area test of 3.4 catches that).
//!
//! The thesis takes `m` as the vertex mean and notes that this can miss the
//! kernel of a star-shaped mesh, leaving the choice of `m` open (9.3.1).
//! [`Center::Kernel`] closes it: the Chebyshev-like centre of the kernel,
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
//! [`lp`], which keeps its iterate feasible and costs one O(F) pass per pivot;
//! large meshes first solve a sample of the faces and then add only the faces
//! the sample's optimum violates (Clarkson-style), so a million faces take a
//! handful of passes. Faces whose corners are exactly collinear have no normal
//! and are left out: no centre can orient them (their projection is a
//! degenerate spherical triangle from every point), so such a mesh cannot map
//! validly and the exact check will say so.
//!
//! The LP only chooses the centre. Whether the floating-point points it yields
//! are valid is decided afterwards, exactly, by [`crate::validity::check_sphere`]
//! (the caller's `SphereMap.valid`); nothing here claims validity. With the
//! centre strictly inside the kernel every projected face is positively
//! oriented in exact arithmetic; only the rounding of the normalisation can
//! still flip a face whose projected determinant is within about 1e-16 of its
//! size. No retry from other points is made: the LP's point is already the
//! deepest one, and the tests (kernels down to 1e-4 of the mesh size) found no
//! such flips; should one happen, `SphereMap.valid` reports it.

use spherify_mesh::vec3::{cross, dot, sub};
use std::time::Instant;

use rayon::prelude::*;
use spherify_mesh::predicates::collinear3;
use spherify_mesh::Mesh;

use crate::embedding::{normalize, SphereEmbedding, Status};
use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;
use crate::initial::vertex_mean;

/// Which point [`radial`] projects from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Center {
    /// A point given by the caller (it should lie in the kernel; no check).
    Point([f64; 3]),
    /// The mean of the vertex positions (thesis eq. 3.18), as in the thesis.
    Centroid,
    /// The deepest point of the kernel, found by a linear program; an error
    /// when the mesh is not star-shaped.
    Kernel,
}

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

/// Projects every vertex radially from the chosen centre onto the unit sphere
/// (thesis eq. 3.17). O(F) for [`Center::Kernel`] (the LP), O(n) otherwise.
///
/// Faces must be counter-clockwise seen from outside (the caller orients the
/// mesh). Stages timed: `"center"`, `"project"`.
///
/// # Errors
/// [`SphereError::NotStarShaped`] for [`Center::Kernel`] on a mesh without a
/// kernel; [`SphereError::InvalidParameter`] for a non-finite point or a
/// centre that coincides with a vertex (which then has no direction).
pub fn radial(mesh: &GenusZeroMesh, center: Center) -> Result<SphereEmbedding, SphereError> {
    radial_map(mesh, center).map(|r| r.embedding)
}

/// What [`radial_map`] returns: the embedding and the centre it used.
#[derive(Debug, Clone)]
pub struct Radial {
    pub embedding: SphereEmbedding,
    /// The point `m` of eq. 3.17.
    pub center: [f64; 3],
    /// The LP's account, for [`Center::Kernel`].
    pub kernel: Option<KernelPoint>,
}

/// [`radial`], also returning the centre (and the kernel LP's account).
///
/// # Errors
/// As [`radial`].
pub fn radial_map(mesh: &GenusZeroMesh, center: Center) -> Result<Radial, SphereError> {
    let mesh = mesh.mesh();
    let started = Instant::now();
    let mut kernel_account = None;
    let (m, from) = match center {
        Center::Point(p) => {
            if !p.iter().all(|x| x.is_finite()) {
                return Err(SphereError::InvalidParameter {
                    name: "center",
                    value: format_point(p),
                    expected: "a point with finite coordinates",
                });
            }
            (p, format!("the given point {}", format_point(p)))
        }
        Center::Centroid => {
            let m = vertex_mean(mesh.positions());
            (m, format!("the vertex mean {} (eq. 3.18)", format_point(m)))
        }
        Center::Kernel => {
            let k = kernel(mesh)?;
            let mut from = format!(
                "the deepest kernel point {} at depth {:.3e} ({} LP pivots)",
                format_point(k.point),
                k.depth,
                k.pivots
            );
            if k.skipped_faces > 0 {
                from += &format!(
                    "; {} zero-area faces cannot be oriented from any point",
                    k.skipped_faces
                );
            }
            let point = k.point;
            kernel_account = Some(k);
            (point, from)
        }
    };
    let center_seconds = started.elapsed().as_secs_f64();

    let started = Instant::now();
    let projected: Vec<Option<[f64; 3]>> = mesh
        .positions()
        .par_iter()
        .map(|&x| normalize([x[0] - m[0], x[1] - m[1], x[2] - m[2]]))
        .collect();
    let mut points = Vec::with_capacity(projected.len());
    for (v, p) in projected.into_iter().enumerate() {
        match p {
            Some(p) => points.push(p),
            None => {
                return Err(SphereError::InvalidParameter {
                    name: "center",
                    value: format!("{} (vertex {v} lies there)", format_point(m)),
                    expected: "a centre that is not a vertex of the mesh",
                })
            }
        }
    }
    let embedding = SphereEmbedding {
        points,
        iterations: 0,
        status: Status::Direct,
        message: format!("radial projection (eq. 3.17) from {from}"),
        seconds: vec![("center", center_seconds), ("project", started.elapsed().as_secs_f64())],
    };
    Ok(Radial { embedding, center: m, kernel: kernel_account })
}

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

fn format_point(p: [f64; 3]) -> String {
    format!("({:.6e}, {:.6e}, {:.6e})", p[0], p[1], p[2])
}

/// A linear program in four unknowns with many constraints: maximise `c . x`
/// subject to `a_i . x <= b_i`, from a feasible start. Row `i` is stored as
/// `[a_i, b_i]`, five numbers in one array so that a pass reads one stream.
///
/// The active-set form of the primal simplex method. It keeps a feasible `x`
/// and a set of at most four linearly independent rows that are tight at `x`.
/// Each pivot either moves `x` along the projection `d` of `c` onto the null
/// space of the active rows until a new row blocks it (the ratio test, one
/// O(m) pass that runs in parallel), or, when `c` lies in the span of the
/// active rows, computes their multipliers `c = sum lambda_i a_i` and drops a
/// row with `lambda_i < 0` (all `lambda_i >= 0` proves optimality by LP
/// duality). Small QR factorisations of the active rows (modified Gram-Schmidt,
/// applied twice) give `d` and the multipliers without forming normal
/// equations.
///
/// Many rows can be tight at once (duplicate faces planes, the symmetric
/// optimum of a cube), so steps of length zero happen. After a run of them the
/// choices switch to Bland's rule (smallest row index both for the row to drop
/// and among tied blocking rows), which rules out cycling; slacks below a
/// tolerance count as zero so that ties are exact ties. The iterate stays
/// feasible throughout, so even a run cut short by the pivot limit returns a
/// feasible point.
pub mod lp {
    use rayon::prelude::*;

    /// The objective grows without bound (cannot happen with box rows).
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub struct Unbounded;

    #[derive(Debug, Clone, PartialEq)]
    pub struct Solution {
        pub x: [f64; 4],
        pub pivots: usize,
        /// Optimality proven by non-negative multipliers.
        pub optimal: bool,
        /// Rows tight at `x` whose multipliers certify the optimum.
        pub active: Vec<usize>,
    }

    /// `a . d` must exceed this times `|a| |d|` for row `a` to block a move
    /// along `d`: rows closer to parallel to the active ones (duplicate face
    /// planes) are treated as dependent, which keeps the active set well
    /// conditioned at the price of a violation of at most this relative size.
    const PARALLEL_TOL: f64 = 1e-10;
    /// Slacks below this count as exactly tight (see the module notes).
    const SLACK_TOL: f64 = 1e-14;
    /// Multipliers above `-MULT_TOL` count as non-negative.
    const MULT_TOL: f64 = 1e-12;
    /// Zero-length steps in a row before Bland's rule takes over.
    const BLAND_AFTER: usize = 8;

    pub fn maximize(
        rows: &[[f64; 5]],
        c: [f64; 4],
        start: [f64; 4],
        max_pivots: usize,
    ) -> Result<Solution, Unbounded> {
        let c_norm = norm(c);
        let mut x = start;
        let mut active: Vec<usize> = Vec::with_capacity(4);
        let mut stalled = 0usize;
        for pivot in 0..max_pivots {
            let (q, r, dependent) = qr(rows, &active);
            if let Some(j) = dependent {
                active.remove(j);
                continue;
            }
            let mut d = c;
            for _ in 0..2 {
                for qi in &q {
                    let h = dot(*qi, d);
                    d = axpy(-h, *qi, d);
                }
            }
            let d_norm = norm(d);
            if d_norm > 1e-12 * c_norm {
                let blocking = rows
                    .par_iter()
                    .enumerate()
                    .filter_map(|(i, row)| {
                        let a = lhs(row);
                        let ad = dot(a, d);
                        if ad <= PARALLEL_TOL * norm(a) * d_norm {
                            return None;
                        }
                        let s = slack(row, x);
                        let s = if s < SLACK_TOL * (1.0 + row[4].abs()) { 0.0 } else { s };
                        Some((s / ad, i))
                    })
                    .min_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)));
                let Some((step, i)) = blocking else { return Err(Unbounded) };
                x = axpy(step, d, x);
                active.push(i);
                stalled = if step == 0.0 { stalled + 1 } else { 0 };
                continue;
            }
            // c lies in the span of the active rows: c = sum_j lambda_j a_j.
            let gamma: Vec<f64> = q.iter().map(|qi| dot(*qi, c)).collect();
            let k = active.len();
            let mut lambda = vec![0.0; k];
            for i in (0..k).rev() {
                let mut s = gamma[i];
                for j in i + 1..k {
                    s -= r[i][j] * lambda[j];
                }
                lambda[i] = s / r[i][i];
            }
            let negative = (0..k).filter(|&j| lambda[j] < -MULT_TOL * c_norm);
            let drop = if stalled >= BLAND_AFTER {
                negative.min_by_key(|&j| active[j])
            } else {
                negative.min_by(|&i, &j| {
                    lambda[i].total_cmp(&lambda[j]).then(active[i].cmp(&active[j]))
                })
            };
            match drop {
                Some(j) => {
                    active.remove(j);
                }
                None => return Ok(Solution { x, pivots: pivot, optimal: true, active }),
            }
        }
        Ok(Solution { x, pivots: max_pivots, optimal: false, active })
    }

    /// Orthonormal `q` and upper-triangular `r` with `a[active[j]] = sum_{i<=j}
    /// r[i][j] q[i]`; the position of the first row that is (numerically) in
    /// the span of the earlier ones, if any.
    #[allow(clippy::type_complexity)]
    fn qr(rows: &[[f64; 5]], active: &[usize]) -> (Vec<[f64; 4]>, [[f64; 4]; 4], Option<usize>) {
        let mut q: Vec<[f64; 4]> = Vec::with_capacity(active.len());
        let mut r = [[0.0; 4]; 4];
        for (j, &row) in active.iter().enumerate() {
            let mut v = lhs(&rows[row]);
            for _ in 0..2 {
                for (i, qi) in q.iter().enumerate() {
                    let h = dot(*qi, v);
                    r[i][j] += h;
                    v = axpy(-h, *qi, v);
                }
            }
            let len = norm(v);
            if len.is_nan() || len <= PARALLEL_TOL * norm(lhs(&rows[row])) || j >= 4 {
                return (q, r, Some(j));
            }
            r[j][j] = len;
            q.push(v.map(|x| x / len));
        }
        (q, r, None)
    }

    /// `b - a . x`: non-negative when the row holds at `x`.
    pub fn slack(row: &[f64; 5], x: [f64; 4]) -> f64 {
        row[4] - dot(lhs(row), x)
    }

    fn lhs(row: &[f64; 5]) -> [f64; 4] {
        [row[0], row[1], row[2], row[3]]
    }

    fn dot(a: [f64; 4], b: [f64; 4]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
    }

    fn norm(a: [f64; 4]) -> f64 {
        dot(a, a).sqrt()
    }

    fn axpy(s: f64, x: [f64; 4], y: [f64; 4]) -> [f64; 4] {
        [y[0] + s * x[0], y[1] + s * x[1], y[2] + s * x[2], y[3] + s * x[3]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::validity::check_sphere;

    /// The method on a test mesh, validated here.
    fn radial(mesh: &Mesh, center: Center) -> Result<SphereEmbedding, SphereError> {
        super::radial(&GenusZeroMesh::new(mesh.clone())?, center)
    }

    /// A closed mesh with faces turned outward (by the sign of the volume).
    fn mesh(positions: Vec<[f64; 3]>, mut faces: Vec<[u32; 3]>) -> Mesh {
        let volume: f64 = faces
            .iter()
            .map(|&[a, b, c]| {
                let (a, b, c) =
                    (positions[a as usize], positions[b as usize], positions[c as usize]);
                dot(a, cross(b, c))
            })
            .sum();
        if volume < 0.0 {
            faces.iter_mut().for_each(|f| f.swap(1, 2));
        }
        Mesh::new(positions, faces).unwrap()
    }

    /// Latitude-longitude sphere with poles on the x axis, each vertex scaled
    /// by `radius(direction)`: star-shaped from the origin for any positive
    /// radius, since the unscaled sphere is convex round the origin and radial
    /// scaling keeps every face's orientation seen from there.
    fn uv_sphere(n_lat: usize, n_lon: usize, mut radius: impl FnMut([f64; 3]) -> f64) -> Mesh {
        let mut p = vec![[1.0, 0.0, 0.0]];
        for i in 1..n_lat {
            let theta = std::f64::consts::PI * i as f64 / n_lat as f64;
            for j in 0..n_lon {
                let phi = 2.0 * std::f64::consts::PI * j as f64 / n_lon as f64;
                p.push([theta.cos(), theta.sin() * phi.cos(), theta.sin() * phi.sin()]);
            }
        }
        p.push([-1.0, 0.0, 0.0]);
        let south = (p.len() - 1) as u32;
        let ring = |i: usize, j: usize| (1 + (i - 1) * n_lon + j % n_lon) as u32;
        let mut f = Vec::new();
        for j in 0..n_lon {
            f.push([0, ring(1, j), ring(1, j + 1)]);
            f.push([south, ring(n_lat - 1, j + 1), ring(n_lat - 1, j)]);
            for i in 1..n_lat - 1 {
                f.push([ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)]);
                f.push([ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)]);
            }
        }
        let p = p.into_iter().map(|u| u.map(|x| x * radius(u))).collect();
        mesh(p, f)
    }

    fn cube(center: [f64; 3], half: f64) -> Mesh {
        let mut p = Vec::new();
        for i in 0..8 {
            p.push([0, 1, 2].map(|k| center[k] + if i >> k & 1 == 1 { half } else { -half }));
        }
        let f = vec![
            [0, 2, 3],
            [0, 3, 1],
            [4, 5, 7],
            [4, 7, 6],
            [0, 1, 5],
            [0, 5, 4],
            [2, 6, 7],
            [2, 7, 3],
            [0, 4, 6],
            [0, 6, 2],
            [1, 3, 7],
            [1, 7, 5],
        ];
        mesh(p, f)
    }

    fn octahedron(shift: [f64; 3]) -> Mesh {
        let (p, f) = (
            spherify_mesh::solids::OCTAHEDRON_POSITIONS,
            spherify_mesh::solids::OCTAHEDRON_FACES.to_vec(),
        );
        mesh(p.iter().map(|q| [0, 1, 2].map(|k| q[k] + shift[k])).collect(), f)
    }

    /// A smooth spike of height `a` round direction `axis`, `width` radians wide.
    fn spike(u: [f64; 3], axis: [f64; 3], a: f64, width: f64) -> f64 {
        let c = dot(u, axis);
        let w = width.cos();
        if c <= w {
            0.0
        } else {
            a * ((c - w) / (1.0 - w)).powi(2)
        }
    }

    /// Star-shaped from the origin, but a long +x spike that is dense in
    /// vertices (near the pole of the latitude-longitude grid) drags the
    /// vertex mean far along +x, where the flanks of the four side spikes
    /// hide faces from it.
    fn spiky() -> Mesh {
        uv_sphere(60, 80, |u| {
            let side: f64 = [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]
                .iter()
                .map(|&axis| spike(u, axis, 4.0, 0.3))
                .sum();
            1.0 + spike(u, [1.0, 0.0, 0.0], 30.0, 0.35) + side
        })
    }

    /// A stretched sphere bent into a 286 degree arc: a fat "C", star-shaped
    /// from no point.
    fn bent() -> Mesh {
        let tube = uv_sphere(30, 24, |_| 1.0);
        mesh(bent_positions(tube.positions()), tube.faces().to_vec())
    }

    fn bent_positions(p: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let r0 = 3.2;
        p.iter()
            .map(|&[x, y, z]| {
                let (theta, r) = (8.0 * x / r0, r0 + y);
                [r * theta.sin(), r * theta.cos(), z]
            })
            .collect()
    }

    fn valid(m: &Mesh, e: &SphereEmbedding) -> bool {
        check_sphere(m.faces(), &e.points).valid
    }

    #[test]
    fn cube_and_octahedron_centre_is_found_and_maps_validly() {
        let m = cube([5.0, -3.0, 2.0], 0.5);
        let k = kernel(&m).unwrap();
        assert!((k.depth - 0.5).abs() < 1e-12, "{k:?}");
        assert!(k.optimal && k.skipped_faces == 0);
        for (got, want) in k.point.iter().zip([5.0, -3.0, 2.0]) {
            assert!((got - want).abs() < 1e-12, "{k:?}");
        }
        let e = radial(&m, Center::Kernel).unwrap();
        assert!(valid(&m, &e));
        assert_eq!((e.status, e.iterations), (Status::Direct, 0));
        assert!(
            e.message.contains("kernel") && e.seconds.iter().map(|s| s.0).eq(["center", "project"])
        );
        for p in &e.points {
            assert!((dot(*p, *p).sqrt() - 1.0).abs() < 1e-15);
        }

        let m = octahedron([100.0, 0.0, -7.0]);
        let k = kernel(&m).unwrap();
        assert!((k.depth - 1.0 / 3f64.sqrt()).abs() < 1e-12, "{k:?}");
        for center in [Center::Kernel, Center::Centroid, Center::Point([100.1, 0.2, -7.1])] {
            assert!(valid(&m, &radial(&m, center).unwrap()), "{center:?}");
        }
    }

    #[test]
    fn star_shaped_mesh_where_the_centroid_fails_maps_from_the_kernel() {
        let m = spiky();
        let centroid = radial(&m, Center::Centroid).unwrap();
        let report = check_sphere(m.faces(), &centroid.points);
        assert!(!report.valid && report.n_negative > 0, "the vertex mean should miss the kernel");
        assert!(backfacing(&m, vertex_mean(m.positions())) > 0);
        let k = kernel(&m).unwrap();
        assert!(k.depth > 0.0 && backfacing(&m, k.point) == 0, "{k:?}");
        let e = radial(&m, Center::Kernel).unwrap();
        assert!(valid(&m, &e), "{}", e.message);
        // Translating and scaling the mesh moves the kernel point along.
        let moved: Vec<[f64; 3]> = m
            .positions()
            .iter()
            .map(|p| [3.0 * p[0] + 1e3, 3.0 * p[1] - 40.0, 3.0 * p[2]])
            .collect();
        let moved = Mesh::new(moved, m.faces().to_vec()).unwrap();
        let km = kernel(&moved).unwrap();
        assert!((km.depth - 3.0 * k.depth).abs() < 1e-9 * k.depth.max(1.0));
        assert!(valid(&moved, &radial(&moved, Center::Kernel).unwrap()));
    }

    #[test]
    fn non_star_shaped_mesh_is_an_error_that_says_so() {
        let m = bent();
        let err = radial(&m, Center::Kernel).unwrap_err();
        assert!(matches!(err, SphereError::NotStarShaped { .. }));
        let text = err.to_string();
        assert!(
            text.contains("not star-shaped") && text.contains("face away from the vertex mean"),
            "{text}"
        );
        assert!(deepest_point(&m).unwrap().depth < 0.0);
        // The centroid still gives points; they are just not a valid map.
        let e = radial(&m, Center::Centroid).unwrap();
        assert!(!valid(&m, &e));
    }

    #[test]
    fn a_point_outside_gives_an_invalid_map_but_no_error() {
        let m = octahedron([0.0; 3]);
        let e = radial(&m, Center::Point([5.0, 0.5, 0.25])).unwrap();
        let r = check_sphere(m.faces(), &e.points);
        assert!(!r.valid && r.n_negative > 0);
        let err = radial(&m, Center::Point([0.0, 1.0, 0.0])).unwrap_err();
        assert!(matches!(err, SphereError::InvalidParameter { name: "center", .. }), "{err}");
        let err = radial(&m, Center::Point([f64::NAN, 0.0, 0.0])).unwrap_err();
        assert!(matches!(err, SphereError::InvalidParameter { name: "center", .. }), "{err}");
    }

    #[test]
    fn coplanar_faces_give_a_degenerate_lp_that_still_ends() {
        // Every vertex pushed out onto the cube [-1, 1]^3: thousands of
        // faces share the six face planes, so most pivots are degenerate.
        let m = uv_sphere(40, 48, |u| 1.0 / u.iter().fold(0.0, |a: f64, x| a.max(x.abs())));
        let k = kernel(&m).unwrap();
        assert!(k.optimal && k.depth > 0.5, "{k:?}");
        assert!(valid(&m, &radial(&m, Center::Kernel).unwrap()));
    }

    #[test]
    fn a_zero_area_face_is_left_out_of_the_lp() {
        // The octahedron with the midpoint M of edge A = v0, B = v2 put on one
        // side of that edge: face (A, M, B) has exactly collinear corners.
        let mut p = vec![
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ];
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
        let spiky_fine = uv_sphere(100, 110, |u| {
            1.0 + spike(u, [1.0, 0.0, 0.0], 30.0, 0.35) + spike(u, [0.0, 1.0, 0.0], 4.0, 0.3)
        });
        let tube = uv_sphere(100, 110, |_| 1.0);
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

    /// splitmix64, for reproducible random instances without a dependency.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }
        fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * self.next()
        }
    }

    /// The LP optimum by trying every vertex (every 4 rows), O(m^4).
    fn brute_force(rows: &[[f64; 5]], c: [f64; 4]) -> f64 {
        let a: Vec<[f64; 4]> = rows.iter().map(|r| [r[0], r[1], r[2], r[3]]).collect();
        let b: Vec<f64> = rows.iter().map(|r| r[4]).collect();
        let m = a.len();
        let mut best = f64::NEG_INFINITY;
        for i in 0..m {
            for j in i + 1..m {
                for k in j + 1..m {
                    for l in k + 1..m {
                        let Some(x) = solve4([a[i], a[j], a[k], a[l]], [b[i], b[j], b[k], b[l]])
                        else {
                            continue;
                        };
                        if a.iter().zip(&b).all(|(r, &bi)| lp_dot(*r, x) <= bi + 1e-9) {
                            best = best.max(lp_dot(c, x));
                        }
                    }
                }
            }
        }
        best
    }

    /// Gaussian elimination with partial pivoting; None when (nearly) singular.
    fn solve4(mut m: [[f64; 4]; 4], mut r: [f64; 4]) -> Option<[f64; 4]> {
        for col in 0..4 {
            let piv = (col..4).max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))?;
            if m[piv][col].abs() < 1e-9 {
                return None;
            }
            m.swap(col, piv);
            r.swap(col, piv);
            let pivot_row = m[col];
            for row in col + 1..4 {
                let f = m[row][col] / pivot_row[col];
                for (x, p) in m[row].iter_mut().zip(pivot_row).skip(col) {
                    *x -= f * p;
                }
                r[row] -= f * r[col];
            }
        }
        let mut x = [0.0; 4];
        for i in (0..4).rev() {
            x[i] = (r[i] - (i + 1..4).map(|k| m[i][k] * x[k]).sum::<f64>()) / m[i][i];
        }
        Some(x)
    }

    fn lp_dot(a: [f64; 4], b: [f64; 4]) -> f64 {
        a.iter().zip(b).map(|(x, y)| x * y).sum()
    }

    #[test]
    fn lp_matches_brute_force_on_random_instances() {
        let mut rng = Rng(7);
        // Vertex enumeration is O(m^5): fewer trials in unoptimised builds.
        let trials = if cfg!(debug_assertions) { 60 } else { 1000 };
        for trial in 0..trials {
            let n = 3 + trial % 10;
            let mut a = Vec::new();
            let mut b = Vec::new();
            for _ in 0..n {
                a.push([0; 4].map(|_| rng.uniform(-1.0, 1.0)));
                b.push(rng.uniform(0.05, 1.0));
            }
            // Some instances get duplicate rows and rows through one vertex,
            // which make the LP degenerate.
            if trial % 3 == 0 {
                // |r . v| < 0.16 keeps the start x = 0 feasible.
                let v = [0; 4].map(|_| rng.uniform(-0.04, 0.04));
                for _ in 0..4 {
                    let r = [0; 4].map(|_| rng.uniform(-1.0, 1.0));
                    b.push(lp_dot(r, v) + 0.2);
                    a.push(r);
                    a.push(r);
                    b.push(*b.last().unwrap());
                }
            }
            for k in 0..4 {
                let mut e = [0.0; 4];
                e[k] = 1.0;
                a.push(e);
                b.push(2.0);
                e[k] = -1.0;
                a.push(e);
                b.push(2.0);
            }
            let c = [0; 4].map(|_| rng.uniform(-1.0, 1.0));
            let rows: Vec<[f64; 5]> =
                a.iter().zip(&b).map(|(r, &bi)| [r[0], r[1], r[2], r[3], bi]).collect();
            let s = lp::maximize(&rows, c, [0.0; 4], 1000).unwrap();
            assert!(s.optimal, "trial {trial}");
            let worst = rows.iter().map(|r| -lp::slack(r, s.x)).fold(f64::MIN, f64::max);
            assert!(worst <= 1e-12, "trial {trial}: infeasible by {worst}");
            let want = brute_force(&rows, c);
            assert!(
                (lp_dot(c, s.x) - want).abs() < 1e-9,
                "trial {trial}: {} vs {want}",
                lp_dot(c, s.x)
            );
        }
    }

    #[test]
    fn kernel_lp_matches_brute_force_on_random_polyhedra() {
        // The kernel LP of random small polyhedra (random radii over an
        // octahedron-like grid), against vertex enumeration of the same rows.
        let mut rng = Rng(11);
        let trials = if cfg!(debug_assertions) { 8 } else { 200 };
        for trial in 0..trials {
            let m = uv_sphere(3, 6, |_| rng.uniform(0.3, 1.5));
            let frame = Frame::of(m.positions());
            let (rows, _) = kernel_rows(&m, &frame);
            let want = brute_force(&rows, [0.0, 0.0, 0.0, 1.0]) * frame.scale;
            let k = deepest_point(&m).unwrap();
            assert!((k.depth - want).abs() < 1e-9, "trial {trial}: {} vs {want}", k.depth);
        }
    }
}
