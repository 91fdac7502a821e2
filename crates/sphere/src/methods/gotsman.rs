//! Gotsman, Gu and Sheffer's spherical Tutte embedding (thesis 5.1, eq. 5.10;
//! Gotsman, Gu and Sheffer 2003, "Fundamentals of spherical parameterization
//! for 3D meshes").
//!
//! Every vertex sits at the radial projection of a convex combination of its
//! neighbours: with row-stochastic weights `W` (eq. 5.3-5.4) the unknowns are
//! the points `v_i` and dilations `alpha_i` of
//!
//! ```text
//! F_i = sum_j w_ij v_j - alpha_i v_i = 0      (3 equations per vertex)
//! G_i = (|v_i|^2 - 1) / 2             = 0      (1 equation per vertex)
//! ```
//!
//! `4n` equations in `4n` unknowns (eq. 5.10; `G` is halved so that its
//! Jacobian row is `v_i^T`). By Theorem 5.1 any solution whose points are
//! distinct is a valid GC-embedding; the trivial solution `v_i = q`,
//! `alpha_i = 1` is the one to avoid.
//!
//! # How it is solved
//!
//! The thesis ran MATLAB's `fsolve` with a dense Jacobian: 17 minutes for 453
//! vertices and out of memory beyond (5.1.3, 7.2). Here the Jacobian `J` is
//! a sparse `4n x 4n` [`CsrMatrix`] with about `3 (d + 2) + 3` entries per
//! vertex (`d` the degree), and the iteration is Newton's method on `(F, G)`.
//!
//! The Newton step `J delta = -(F, G)` is solved exactly, but on `2n`
//! unknowns instead of `4n`: the `G` row fixes the component of `delta v_i`
//! along `v_i`, the `F` rows projected on `v_i` give `delta alpha_i`, and
//! what remains are the two tangential components `t_i` per vertex, coupled by
//! `w_ij T_i^T T_j` (2x2 blocks, `T_i` an orthonormal tangent basis at `v_i`)
//! with `-alpha_i I` on the diagonal (`newton_step`). That matrix has the
//! sparsity of `W`, a non-zero diagonal and half the unknowns, and one sparse
//! LU of it through [`spherify_sparse::solve`] (`Auto`; it is not symmetric)
//! costs about 2.5 times less than the LU of `J` (0.7 s against 1.7 s at
//! 16k vertices; a test checks that both give the same step). `J` itself
//! is still assembled for the trust-region model below.
//!
//! Globalisation is Powell's dogleg trust region on `|F|_2` (Nocedal and
//! Wright, *Numerical Optimization*, 2nd ed., Alg. 4.1 and 11.5), the default
//! of `fsolve` that the thesis used: each step moves along the path from the
//! Cauchy point (steepest descent of `|F|^2`, `-J^T F` scaled) to the Newton
//! point, cut at the trust radius. That is the Levenberg-Marquardt curve from
//! large to zero damping, approximated by two segments, at the price of one
//! LU per iteration; true Levenberg-Marquardt needs `J^T J + lambda D`, whose
//! 2-ring sparsity fills the factor several times more, and in a prototype it
//! converged far more slowly here (the damping fights the rotation freedom
//! below). Rejected steps reuse the factorisation. When the LU finds the
//! matrix singular the step falls back to the Cauchy point.
//!
//! Why Newton and not a descent method: with symmetric weights eq. 5.10 says
//! that the tangential part of `sum_j omega_ij (v_i - v_j)` vanishes at every
//! vertex, i.e. the points are a critical point of the spring energy
//! `sum_edges omega_ij |v_i - v_j|^2` on the product of spheres. The trivial
//! solution is that energy's global minimum (zero), which is where the
//! relaxation of 5.2 drifts; the embeddings are other critical points, which
//! Newton's method finds because it looks for zeros, not for low energy.
//!
//! The solutions are not isolated: a rotation of a solution is a solution, so
//! `J` is singular at the solution and nearly singular close to it. The
//! Newton step there carries an arbitrary, large infinitesimal rotation that
//! stalls the iteration around `|F| ~ 1e-10` (seen on a 2,000-vertex blob).
//! We remove it: the part `omega x v_i` of the step that best fits a rigid
//! rotation (least squares, a 3x3 system) is subtracted. The steepest-descent
//! direction `J^T F` has no rotation part to begin with
//! (`F . (omega x F) = 0`).
//!
//! # Start
//!
//! [`Initial::Centroid`] is eq. 5.11: `v_i = (x_i - m) / |x_i - m|` with `m`
//! the mean vertex. It works when `m` sees the surface well; for shapes such
//! as a helix tube it does not (thesis 9.3.1) and the iteration stalls in a
//! local minimum of `|F|`: pass a better start ([`Initial::Points`], e.g. the
//! result of another method). The dilations start at their least-squares
//! values `alpha_i = v_i . u_i`. Eq. 5.12's `4 pi / (sqrt(3) N)` is the size of
//! `1 - alpha_i` (GGS write the system with the Laplacian `I - W`, whose
//! eigenvalue that is); measured `mean(1 - v_i . u_i)` agrees with it to 1% on
//! icospheres.
//!
//! # End
//!
//! Converged when every one of the `4n` equations holds to `tol` (the max
//! norm of `(F, G)`). The returned points are then normalised exactly: `G`
//! already puts them within about `tol` of the sphere, the normalisation only
//! removes that last error. Collapse onto the trivial solution is detected by
//! the spread of the points, `sqrt(mean |v_i - c|^2 / mean |v_i|^2)` with `c`
//! their mean: 1 for points spread evenly over the sphere, 0 for the trivial
//! solution. Below [`COLLAPSE_SPREAD`] the iteration stops with
//! [`Status::Collapsed`]: Newton's method converges quadratically onto the
//! trivial solution from there, and no valid embedding has its points that
//! close together (they cannot all lie in an open hemisphere).

use std::time::Instant;

use spherify_sparse::weights::Weights;
use spherify_sparse::CsrMatrix;

use crate::embedding::{normalize, SphereEmbedding, Status};
use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;
use crate::methods::gotsman::dogleg::{dot, resized_radius, Dogleg};
use crate::methods::initial::{initial_points, Initial};
use crate::methods::weight_matrix::{row_stochastic, Positivity};
use spherify_mesh::vec3::{cross, det3, dot as dot3, solve3};

use newton_system::{jacobian, neighbour_means, newton_step, residual, xyz};

/// Spread (see the module documentation) below which the points count as
/// collapsed: their RMS distance from their mean is below 1% of the radius.
pub const COLLAPSE_SPREAD: f64 = 1e-2;

/// Acceptance threshold on the ratio of actual to predicted reduction of
/// `|F|^2` (Nocedal and Wright's eta): any real decrease is taken.
const ACCEPT_RATIO: f64 = 1e-4;

/// The trust radius, relative to `|x|`, below which no further progress is
/// possible in double precision: the iteration has stalled.
const MIN_RADIUS: f64 = 1e-15;

/// Parameters of [`gotsman`].
#[derive(Debug, Clone, PartialEq)]
pub struct GotsmanParams {
    /// Edge weights `omega_ij` (thesis 4.4), normalised so that each row sums
    /// to 1 (eq. 5.4, 4.46). Uniform (Tutte) or chord length: they must be
    /// positive (eq. 5.3) and symmetric, `omega_ij = omega_ji`. Then
    /// `W = D^-1 Omega` and eq. 5.10 reads `(D A - Omega) V = 0` with a
    /// symmetric matrix whose 3-dimensional null space holds the points
    /// (GGS 2003); counting dimensions, the solutions form the 3-dimensional
    /// family of rotations. For non-symmetric weights (mean value) the same
    /// count leaves no solution in general, and the iteration only drifts
    /// (seen on a bumpy octahedron), so they are refused, as are the
    /// cotangent weights, which can be negative. Default uniform.
    pub weights: Weights,
    /// Most Newton (trust-region) iterations, each one sparse LU. Default 50.
    pub max_iter: usize,
    /// Converged when `max(|F_i|, |G_i|) <= tol` over all equations. Default 1e-10.
    pub tol: f64,
    /// Return [`SphereError::NoConvergence`] instead of an unconverged or
    /// collapsed embedding. Default false.
    pub strict: bool,
    /// Default [`Initial::Centroid`].
    pub initial: Initial,
}

impl GotsmanParams {
    /// The weights eq. 5.10 accepts: positive (5.3) and symmetric. Mean-value
    /// weights are not symmetric; cotangent weights can be negative.
    pub const WEIGHTS: [&'static str; 2] = ["uniform", "chord"];
}

impl Default for GotsmanParams {
    fn default() -> GotsmanParams {
        GotsmanParams {
            weights: Weights::Uniform,
            max_iter: 50,
            tol: 1e-10,
            strict: false,
            initial: Initial::Centroid,
        }
    }
}

/// Solves eq. 5.10 for a closed genus-0 mesh (see the module documentation).
/// Cost per iteration: one sparse LU of a `2n x 2n` matrix with `O(n)`
/// entries (the Newton system of the `4n x 4n` Jacobian on tangent unknowns),
/// near-linear in `n` on meshes; typically 3-4 iterations for uniform weights
/// on a star-shaped mesh, 10-30 for chord weights, whose embedding lies
/// further from the start.
///
/// Errors: [`SphereError::Topology`] unless the mesh is a closed, connected,
/// manifold, consistently oriented genus-0 surface;
/// [`SphereError::InvalidParameter`] for a bad `tol`, weights other than
/// uniform and chord or not positive and finite on this mesh, or a bad
/// initial guess;
/// [`SphereError::Solve`] if the sparse LU fails other than by singularity;
/// [`SphereError::NoConvergence`] (with the last iterate) when `strict` and the
/// iteration did not converge or collapsed.
pub fn gotsman(
    mesh: &GenusZeroMesh,
    params: &GotsmanParams,
) -> Result<SphereEmbedding, SphereError> {
    gotsman_with_progress(mesh, params, &|_, _| true)
}

/// [`gotsman`], reporting `progress(steps, max_iter)` before every Newton step
/// (and `(max_iter, max_iter)` at the end) and polling `progress(0, 0)` before
/// every trust-region trial: `false` stops it with [`SphereError::Cancelled`]
/// (Ctrl-C in Python). The sparse factorisation inside one step is not
/// interrupted.
pub fn gotsman_with_progress(
    mesh: &GenusZeroMesh,
    params: &GotsmanParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<SphereEmbedding, SphereError> {
    let start = Instant::now();
    if !(params.tol >= 0.0 && params.tol.is_finite()) {
        return Err(SphereError::InvalidParameter {
            name: "tol",
            value: params.tol.to_string(),
            expected: "a finite number >= 0",
        });
    }
    if !GotsmanParams::WEIGHTS.contains(&params.weights.name()) {
        return Err(SphereError::InvalidParameter {
            name: "weights",
            value: format!("{:?}", params.weights),
            expected: "uniform or chord: eq. 5.10 needs positive (5.3), symmetric edge weights",
        });
    }
    let n = mesh.n_vertices();
    if n > (u32::MAX / 4) as usize {
        return Err(SphereError::InvalidParameter {
            name: "mesh",
            value: format!("{n} vertices"),
            expected: "at most 2^30 vertices (4 unknowns each, 32-bit indices)",
        });
    }
    let w = row_stochastic(mesh, params.weights, Positivity::EveryWeight)?;
    let points = initial_points(mesh, &params.initial)?;
    let mut seconds = vec![("setup", start.elapsed().as_secs_f64())];

    let mut x = vec![0.0; 4 * n];
    for (i, p) in points.iter().enumerate() {
        x[4 * i..4 * i + 3].copy_from_slice(p);
    }
    // alpha_i = v_i . u_i minimises |u_i - alpha_i v_i| for the start points.
    let u = neighbour_means(&w, &x);
    for i in 0..n {
        x[4 * i + 3] = dot3(xyz(&x[4 * i..]), xyz(&u[3 * i..]));
    }

    let run = newton(&w, x, params, progress)?;
    seconds.push(("solve", run.solve_seconds));
    seconds.push(("iterate", run.iterate_seconds));
    let embedding = SphereEmbedding { seconds, ..finish(run, &points, params) };
    if params.strict && embedding.status != Status::Converged {
        return Err(SphereError::NoConvergence { last: Box::new(embedding) });
    }
    Ok(embedding)
}

/// What the iteration ended with.
struct Run {
    x: Vec<f64>,
    iterations: usize,
    rejected: usize,
    residual: f64,
    spread: f64,
    status: Status,
    stalled: bool,
    solve_seconds: f64,
    iterate_seconds: f64,
}

/// The dogleg trust-region Newton iteration (module documentation).
///
/// About 90 lines: the outer Newton loop and the inner trust-region loop
/// update the same iterate, residual, radius and counts, and read more
/// plainly together than with that state passed between two functions.
fn newton(
    w: &CsrMatrix,
    mut x: Vec<f64>,
    params: &GotsmanParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<Run, SphereError> {
    let cancelled = |iterations| SphereError::Cancelled {
        stage: "gotsman",
        done: iterations,
        total: params.max_iter,
    };
    let start = Instant::now();
    let mut solve_seconds = 0.0;
    let mut f = residual(w, &x);
    let mut f2 = dot(&f, &f);
    let mut radius = dot(&x, &x).sqrt();
    let (mut iterations, mut rejected, mut stalled) = (0, 0, false);
    let status = loop {
        if max_abs(&f) <= params.tol {
            break if spread(&x) < COLLAPSE_SPREAD { Status::Collapsed } else { Status::Converged };
        }
        if spread(&x) < COLLAPSE_SPREAD {
            break Status::Collapsed;
        }
        if iterations >= params.max_iter || stalled {
            break Status::MaxIterations;
        }
        // Reports the Newton steps taken of at most `max_iter` (issue 24: a
        // bar for the iterative methods); the end reports `max_iter` below.
        if !progress(iterations, params.max_iter) {
            return Err(cancelled(iterations));
        }
        iterations += 1;
        let jac = jacobian(w, &x)?;
        let t = Instant::now();
        // None: the reduced matrix is singular (at or near a trivial or
        // degenerate configuration); the Cauchy point still decreases |F|.
        let newton_step = newton_step(w, &x, &f)?.map(|mut p| {
            remove_rotation(&x, &mut p);
            p
        });
        solve_seconds += t.elapsed().as_secs_f64();
        let dog = Dogleg::new(&jac, &f, newton_step)?;
        loop {
            if !progress(0, 0) {
                return Err(cancelled(iterations));
            }
            let Some((p, jp)) = dog.step(radius) else {
                // The gradient J^T F vanished with F != 0: a critical point of
                // |F|^2 that is not a root.
                stalled = true;
                break;
            };
            let p_norm = dot(&p, &p).sqrt();
            let trial: Vec<f64> = x.iter().zip(&p).map(|(a, b)| a + b).collect();
            let f_trial = residual(w, &trial);
            let f2_trial = dot(&f_trial, &f_trial);
            let linear: f64 = f.iter().zip(&jp).map(|(a, b)| (a + b) * (a + b)).sum();
            let predicted = f2 - linear;
            let ratio = if predicted > 0.0 && f2_trial.is_finite() {
                (f2 - f2_trial) / predicted
            } else {
                -1.0
            };
            radius = resized_radius(radius, ratio, p_norm);
            if ratio > ACCEPT_RATIO {
                (x, f, f2) = (trial, f_trial, f2_trial);
                break;
            }
            rejected += 1;
            if radius <= MIN_RADIUS * dot(&x, &x).sqrt() {
                stalled = true;
                break;
            }
        }
    };
    // The run is over, however it ended: a bar is drawn to its end. What
    // the callable answers no longer matters.
    progress(params.max_iter, params.max_iter);
    let solve_part = solve_seconds;
    Ok(Run {
        residual: max_abs(&f),
        spread: spread(&x),
        x,
        iterations,
        rejected,
        status,
        stalled,
        solve_seconds: solve_part,
        iterate_seconds: start.elapsed().as_secs_f64() - solve_part,
    })
}

/// Subtracts from the point part of the step `p` the infinitesimal rotation
/// `omega x v_i` that fits it best in least squares:
/// `sum_i (|v_i|^2 I - v_i v_i^T) omega = sum_i v_i x p_i`. Rotating a
/// solution gives a solution, so this part of a Newton step is arbitrary
/// (J is singular along it at the solution) and only harms.
fn remove_rotation(x: &[f64], p: &mut [f64]) {
    let mut m = [[0.0; 3]; 3];
    let mut rhs = [0.0; 3];
    for (v, d) in x.chunks_exact(4).zip(p.chunks_exact(4)) {
        let vv = dot3(xyz(v), xyz(v));
        for r in 0..3 {
            for c in 0..3 {
                m[r][c] -= v[r] * v[c];
            }
            m[r][r] += vv;
        }
        let c = cross(xyz(v), xyz(d));
        (0..3).for_each(|k| rhs[k] += c[k]);
    }
    let Some(omega) = solve_psd3(m, rhs) else { return };
    for (v, d) in x.chunks_exact(4).zip(p.chunks_exact_mut(4)) {
        let r = cross(omega, xyz(v));
        (0..3).for_each(|k| d[k] -= r[k]);
    }
}

/// Cramer's rule for a symmetric positive semi-definite 3x3 system; `None`
/// when it is (nearly) singular, as for collinear points (all at one point or
/// two antipodes), where there is no rotation to remove reliably.
fn solve_psd3(m: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let d = det3(m[0], m[1], m[2]);
    let trace = m[0][0] + m[1][1] + m[2][2];
    if d.is_nan() || d <= 1e-12 * trace * trace * trace {
        return None;
    }
    Some(solve3(m, b))
}

/// `sqrt(mean |v_i - c|^2 / mean |v_i|^2)`, `c` the mean point: 1 for points
/// spread evenly over a sphere, 0 when they coincide.
fn spread(x: &[f64]) -> f64 {
    let n = (x.len() / 4).max(1) as f64;
    let (mut c, mut sq) = ([0.0; 3], 0.0);
    for v in x.chunks_exact(4) {
        (0..3).for_each(|k| c[k] += v[k] / n);
        sq += dot3(xyz(v), xyz(v)) / n;
    }
    // mean |v - c|^2 = mean |v|^2 - |c|^2.
    let s = ((sq - dot3(c, c)) / sq).max(0.0).sqrt();
    if s.is_finite() {
        s
    } else {
        0.0
    }
}

/// Unit points and the account of the run.
fn finish(run: Run, start_points: &[[f64; 3]], params: &GotsmanParams) -> SphereEmbedding {
    let n = start_points.len();
    let mut lost = 0;
    let points: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let v = [run.x[4 * i], run.x[4 * i + 1], run.x[4 * i + 2]];
            normalize(v).unwrap_or_else(|| {
                lost += 1;
                start_points[i]
            })
        })
        .collect();
    let alphas = run.x.chunks_exact(4).map(|v| v[3]);
    let (lo, hi) =
        alphas.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), a| (lo.min(a), hi.max(a)));
    let steps = format!(
        "{} Newton steps ({} trust-region rejections), max residual {:.3e}, alpha in [{lo:.6}, {hi:.6}], spread {:.3}",
        run.iterations, run.rejected, run.residual, run.spread
    );
    let mut message = match run.status {
        Status::Converged => format!("gotsman: converged to tol {:e} after {steps}", params.tol),
        Status::Collapsed => format!(
            "gotsman: collapsed towards the trivial solution (all points at one place, alpha = 1; thesis 5.1.1) after {steps}: \
             try another start or weights"
        ),
        _ if run.stalled => format!(
            "gotsman: stalled at a local minimum of the residual (the trust region shrank to nothing) after {steps}: \
             the start is too far from a solution; try initial points from another method"
        ),
        _ => format!("gotsman: reached max_iter = {} with {steps}", params.max_iter),
    };
    if lost > 0 {
        message.push_str(&format!(
            "; {lost} points reached the origin and were put back at their start"
        ));
    }
    SphereEmbedding {
        points,
        iterations: run.iterations,
        status: run.status,
        message,
        seconds: Vec::new(),
    }
}

/// Largest absolute value; NaN if any value is NaN (so that it never passes
/// `<= tol`).
fn max_abs(v: &[f64]) -> f64 {
    v.iter()
        .fold(0.0, |m: f64, &x| if x.is_nan() || m.is_nan() { f64::NAN } else { m.max(x.abs()) })
}

pub mod dogleg;
mod newton_system;
#[cfg(test)]
mod tests;
