//! Global steps of the stretch and balanced energies: limited-memory BFGS
//! over every vertex at once, on the sphere, preconditioned by the energy's
//! own Dirichlet term.
//!
//! Why: the flip-free vertex moves of [`crate::methods::progressive::flip_free`] are a
//! nonlinear Gauss-Seidel iteration, which removes local error quickly and
//! smooth, far-reaching error (how much of the sphere a long limb gets, how
//! a nearly round shape is centred) only very slowly; on tubes and on nearly
//! round meshes the sweeps stop far from the energy's minimum (issue 22).
//!
//! The energy is the one the sweeps lower (Sander et al. 2001's L2 stretch,
//! as Praun and Hoppe 2003 minimise it, with or without the balanced area
//! term; see [`crate::methods::progressive::distortion_energy`]), summed over
//! every face once, with the area scale k held fixed for the whole run.
//!
//! The iteration is L-BFGS (Nocedal and Wright, Numerical Optimization, 2nd
//! ed., 2006: Algorithm 7.4, the two-loop recursion, and Algorithm 7.5) on
//! the product of spheres: gradients are projected onto each point's tangent
//! plane, a step moves every point along its tangent direction and
//! normalises it (a retraction), and the curvature pairs (s, y) are kept as
//! plain 3n-vectors, the usual cheap vector transport for small steps
//! (Absil, Mahony and Sepulchre 2008, ch. 8). The initial inverse Hessian
//! H0 is not a multiple of the identity but gamma K^-1, with K the Hessian
//! of the faces' Dirichlet terms area * f_a * a (a = |J|_F^2, a cotangent
//! Laplacian of the surface weighted per face, the same for x, y and z) plus
//! the sphere's curvature term -(g . p) per vertex (the Hessian of a function
//! restricted to the unit sphere is P H P - (g . p) P), factored once per
//! [`REFACTOR_EVERY`] iterations (in practice once per run): a Sobolev preconditioner in the manner of
//! Kovalsky et al. 2016 (accelerated quadratic proxy) and Rabinovich et al.
//! 2017 (SLIM), which moves a whole limb as far as its gradient asks in one
//! step. gamma = s^T K s / s^T y is Nocedal and Wright's scaling (7.20) for
//! this H0.
//!
//! Line search: backtracking from the step t = 1 (cut to half the step at
//! which a face's determinant, linearised in t, would reach zero) until
//! Armijo's condition holds (N&W 3.4) and every face is positive under the
//! exact predicate. The energies grow without bound as a face's area goes to
//! zero, so they are barriers: no accepted state has a collapsed face. At
//! the end the exact certificate ([`check_sphere`]: orientation of every face
//! and the area sum, covering degree 1) must pass, or the points go back to
//! where the run started: a run never returns an uncertified map from a
//! certified one.
//!
//! Deterministic: every sum over faces or vertices is taken in fixed chunks
//! of [`CHUNK`] in a fixed order, and the factorisation is the sparse crate's
//! (the same on every thread count).

use std::collections::VecDeque;

use rayon::prelude::*;
use spherify_mesh::predicates::{det3_sign, Sign};
use spherify_mesh::vec3::{add, det3, dot, scale, sub};
use spherify_sparse::{CsrMatrix, Factorization, SparseError};

use crate::certificate::validity::check_sphere;
use crate::embedding::normalize;
use crate::methods::progressive::chord_area::{self, chord_area};
use crate::methods::progressive::distortion_energy::{Energy, Reference};
use crate::methods::progressive::flip_free::{Problem, Stopped};
use crate::methods::progressive::star_lanes::{self, FaceGradients};

/// Curvature pairs kept (N&W suggest 3-20; each costs 6 doubles per vertex).
pub const MEMORY: usize = 6;
/// Iterations between factorisations of the preconditioner K, whose face
/// weights f_a change as the map moves. Factoring once per run did better
/// than every 20 iterations (horse, 100 iterations: energy 2.669 against
/// 2.707 per unit area, a fifth of the factoring time).
pub const REFACTOR_EVERY: usize = 1000;
/// Sums over faces and vertices are taken over chunks of this many, in order.
const CHUNK: usize = 4096;
/// Armijo's constant c1 (N&W 3.4).
const ARMIJO: f64 = 1e-4;
/// Halvings of the step before the iteration gives up on a direction.
const MAX_HALVINGS: usize = 40;
/// Fraction of the linearised flip-free step a first trial may take.
const SAFE_FRACTION: f64 = 0.5;
/// Diagonal shift of K relative to its own diagonal, so that K stays
/// positive definite where the curvature term is not positive.
const SHIFT: f64 = 1e-8;

/// How many iterations, and when to stop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LbfgsParams {
    pub max_iter: usize,
    /// Stop when an iteration lowers the energy by less than this fraction.
    pub tolerance: f64,
}

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LbfgsRun {
    pub iterations: usize,
    /// Energy per unit of scaled surface area at the start and at the end,
    /// with the chord-area term where it applies.
    pub start: f64,
    pub end: f64,
    /// The last iteration lowered the energy by less than the tolerance.
    pub converged: bool,
    /// The certificate failed at the end and the points went back to the
    /// start (not seen in the runs measured; kept as the guarantee).
    pub fell_back: bool,
    /// Seconds spent factorising the preconditioner.
    pub factor_seconds: f64,
    /// Seconds spent solving with it.
    pub solve_seconds: f64,
    /// Energy evaluations of the line search.
    pub trials: usize,
}

/// Every face once (from its smallest corner, as the rings order it), its
/// surface reference, and each vertex's (face, corner) incidences in face
/// order.
struct Faces {
    corners: Vec<[u32; 3]>,
    refs: Vec<Reference>,
    incidence_start: Vec<usize>,
    incidence: Vec<u32>,
}

/// A curvature pair of L-BFGS: the step s, the change of gradient y, and
/// 1 / (s . y).
type Pair = (Vec<[f64; 3]>, Vec<[f64; 3]>, f64);

/// What one evaluation of the gradient gives.
struct Evaluation {
    energy: f64,
    /// Tangent part of each vertex's gradient.
    gradient: Vec<[f64; 3]>,
    /// Each vertex's g . p (the radial part of the gradient).
    radial: Vec<f64>,
    /// Each face's f_a, the weight of its Dirichlet term, which the
    /// preconditioner is built from at these same points.
    dirichlet_weight: Vec<f64>,
}

impl Faces {
    /// The faces of `rings` and their total surface area.
    fn new(problem: &Problem<'_>, rings: &[Vec<u32>]) -> (Faces, f64) {
        let stars = problem.stars(rings);
        let mut corners = Vec::new();
        let mut refs = Vec::new();
        let mut surface = 0.0;
        for i in 0..rings.len() as u32 {
            let (ring, r) = (stars.ring(i), stars.refs(i));
            let m = ring.len();
            for j in 0..m {
                let (a, b) = (ring[j], ring[(j + 1) % m]);
                if i < a && i < b {
                    corners.push([i, a, b]);
                    refs.push(r[j]);
                    surface += r[j].area;
                }
            }
        }
        let n = rings.len();
        let mut incidence_start = vec![0usize; n + 1];
        for f in &corners {
            for &v in f {
                incidence_start[v as usize + 1] += 1;
            }
        }
        for v in 0..n {
            incidence_start[v + 1] += incidence_start[v];
        }
        let mut fill = incidence_start.clone();
        let mut incidence = vec![0u32; 3 * corners.len()];
        for (f, c) in corners.iter().enumerate() {
            for (corner, &v) in c.iter().enumerate() {
                incidence[fill[v as usize]] = (3 * f + corner) as u32;
                fill[v as usize] += 1;
            }
        }
        (Faces { corners, refs, incidence_start, incidence }, surface)
    }

    fn incident(&self, v: usize) -> &[u32] {
        &self.incidence[self.incidence_start[v]..self.incidence_start[v + 1]]
    }

    /// The area scale k: image area (det / 2) over surface area.
    fn area_scale(&self, points: &[[f64; 3]], surface: f64) -> f64 {
        let image = chunked_sum(&self.corners, |&[a, b, c]| {
            0.5 * det3(points[a as usize], points[b as usize], points[c as usize])
        });
        if surface > 0.0 && image > 0.0 {
            image / surface
        } else {
            1.0
        }
    }

    /// Sum of the faces' chord areas.
    fn chord_total(&self, points: &[[f64; 3]]) -> f64 {
        chunked_sum(&self.corners, |&[a, b, c]| {
            chord_area(points[a as usize], points[b as usize], points[c as usize])
        })
    }

    /// The energy plus `mu` times the chord areas (see
    /// [`crate::methods::progressive::chord_area`]).
    fn energy(&self, energy: Energy, k: f64, mu: f64, points: &[[f64; 3]]) -> f64 {
        // Each chunk's faces in order, four at a time where the energy has
        // lanes (`star_lanes::faces_energy`, the same bits as one at a time).
        let per_chunk: Vec<f64> = self
            .corners
            .par_chunks(CHUNK)
            .zip(self.refs.par_chunks(CHUNK))
            .map(|(fs, rs)| star_lanes::faces_energy(energy, k, mu, points, fs, rs))
            .collect();
        per_chunk.iter().sum()
    }

    fn evaluate(&self, energy: Energy, k: f64, mu: f64, points: &[[f64; 3]]) -> Evaluation {
        // Per face, four at a time where the energy has lanes
        // (`star_lanes::face_gradients`, the same bits as one at a time).
        let mut per_face: Vec<FaceGradients> = vec![(0.0, [[0.0; 3]; 3], 0.0); self.corners.len()];
        per_face
            .par_chunks_mut(1024)
            .zip(self.corners.par_chunks(1024).zip(self.refs.par_chunks(1024)))
            .for_each(|(out, faces)| star_lanes::face_gradients(energy, k, mu, points, faces, out));
        let per_chunk: Vec<f64> =
            per_face.par_chunks(CHUNK).map(|c| c.iter().map(|x| x.0).sum::<f64>()).collect();
        let energy: f64 = per_chunk.iter().sum();
        let (gradient, radial): (Vec<[f64; 3]>, Vec<f64>) = (0..points.len())
            .into_par_iter()
            .with_min_len(1024)
            .map(|v| {
                let mut g = [0.0; 3];
                for &fc in self.incident(v) {
                    g = add(g, per_face[fc as usize / 3].1[fc as usize % 3]);
                }
                let p = points[v];
                let radial = dot(g, p);
                (sub(g, scale(p, radial)), radial)
            })
            .unzip();
        let dirichlet_weight = per_face.iter().map(|x| x.2).collect();
        Evaluation { energy, gradient, radial, dirichlet_weight }
    }

    /// K: the Dirichlet terms' Hessian, weighted per face by area * f_a at
    /// the points `eval` was taken at, plus each vertex's curvature term
    /// max(-(g . p), 0) and a small shift; the same matrix for x, y and z.
    fn preconditioner(
        &self,
        k: f64,
        eval: &Evaluation,
    ) -> Result<(CsrMatrix, Factorization), SparseError> {
        let (n, radial) = (eval.radial.len(), &eval.radial);
        // Per face: the off-diagonal entries of (0, 1), (0, 2), (1, 2).
        let off: Vec<[f64; 3]> = self
            .refs
            .par_iter()
            .zip(eval.dirichlet_weight.par_iter())
            .with_min_len(1024)
            .map(|(r, &f_a)| {
                let [g00, g01, g11] = r.gram;
                let w = 2.0 * k * r.area * f_a / (k * (g00 * g11 - g01 * g01));
                [w * (g01 - g11), w * (g01 - g00), -w * g01]
            })
            .collect();
        // The diagonal: minus each row's off-diagonal sum (every constant
        // is in the Dirichlet term's kernel).
        const PAIRS: [[usize; 2]; 3] = [[0, 1], [0, 2], [1, 2]];
        let diag: Vec<f64> = (0..n)
            .into_par_iter()
            .with_min_len(1024)
            .map(|v| {
                let mut d = 0.0;
                for &fc in self.incident(v) {
                    let (f, corner) = (fc as usize / 3, fc as usize % 3);
                    for (pair, [i, j]) in PAIRS.iter().enumerate() {
                        if corner == *i || corner == *j {
                            d -= off[f][pair];
                        }
                    }
                }
                d
            })
            .collect();
        let mut rows = Vec::with_capacity(6 * off.len() + n);
        let mut cols = Vec::with_capacity(6 * off.len() + n);
        let mut values = Vec::with_capacity(6 * off.len() + n);
        for (corners, w) in self.corners.iter().zip(&off) {
            for (pair, [i, j]) in PAIRS.iter().enumerate() {
                let (a, b) = (corners[*i], corners[*j]);
                rows.extend([a, b]);
                cols.extend([b, a]);
                values.extend([w[pair], w[pair]]);
            }
        }
        for v in 0..n {
            let curvature = (-radial[v]).max(0.0);
            let d = diag[v] + curvature + SHIFT * diag[v];
            rows.push(v as u32);
            cols.push(v as u32);
            values.push(if d > 0.0 && d.is_finite() { d } else { 1.0 });
        }
        let k_matrix = CsrMatrix::from_triplets(n, n, &rows, &cols, &values)?;
        let factor = Factorization::new(&k_matrix)?;
        Ok((k_matrix, factor))
    }

    /// Largest t at which no face's determinant, linearised in t along
    /// `points + t step`, reaches zero.
    fn safe_step(&self, points: &[[f64; 3]], step: &[[f64; 3]]) -> f64 {
        self.corners
            .par_iter()
            .with_min_len(1024)
            .map(|&[a, b, c]| {
                let [pa, pb, pc] = [a, b, c].map(|v| points[v as usize]);
                let [da, db, dc] = [a, b, c].map(|v| step[v as usize]);
                let rate = det3(da, pb, pc) + det3(pa, db, pc) + det3(pa, pb, dc);
                if rate < 0.0 {
                    -det3(pa, pb, pc) / rate
                } else {
                    f64::INFINITY
                }
            })
            .reduce(|| f64::INFINITY, f64::min)
    }

    fn all_positive(&self, points: &[[f64; 3]]) -> bool {
        self.corners.par_iter().with_min_len(1024).all(|&[a, b, c]| {
            det3_sign(points[a as usize], points[b as usize], points[c as usize]) == Sign::Positive
        })
    }
}

/// The preconditioner applied to a tangent field: P K^-1 v, per coordinate.
fn precondition(
    k_matrix: &CsrMatrix,
    factor: &Factorization,
    points: &[[f64; 3]],
    v: &[[f64; 3]],
) -> Result<Vec<[f64; 3]>, SparseError> {
    let mut columns: Vec<Vec<f64>> = (0..3).map(|c| v.iter().map(|x| x[c]).collect()).collect();
    factor.solve_in_place(k_matrix, &mut columns)?;
    Ok(points
        .par_iter()
        .enumerate()
        .with_min_len(1024)
        .map(|(i, &p)| {
            let z = [columns[0][i], columns[1][i], columns[2][i]];
            sub(z, scale(p, dot(z, p)))
        })
        .collect())
}

/// s^T K s, per coordinate.
fn k_norm(k_matrix: &CsrMatrix, s: &[[f64; 3]]) -> Result<f64, SparseError> {
    let mut total = 0.0;
    let mut ks = vec![0.0; s.len()];
    for c in 0..3 {
        let column: Vec<f64> = s.iter().map(|x| x[c]).collect();
        k_matrix.mul_vec(&column, &mut ks)?;
        total += chunked_sum_pairs(&column, &ks);
    }
    Ok(total)
}

fn chunked_sum<T: Sync>(items: &[T], f: impl Fn(&T) -> f64 + Sync) -> f64 {
    let per_chunk: Vec<f64> =
        items.par_chunks(CHUNK).map(|c| c.iter().map(&f).sum::<f64>()).collect();
    per_chunk.iter().sum()
}

fn chunked_sum_pairs(a: &[f64], b: &[f64]) -> f64 {
    let per_chunk: Vec<f64> = a
        .par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(x, y)| x.iter().zip(y).map(|(x, y)| x * y).sum::<f64>())
        .collect();
    per_chunk.iter().sum()
}

/// u . v over every vertex, in fixed chunks.
fn inner(u: &[[f64; 3]], v: &[[f64; 3]]) -> f64 {
    let per_chunk: Vec<f64> = u
        .par_chunks(CHUNK)
        .zip(v.par_chunks(CHUNK))
        .map(|(x, y)| x.iter().zip(y).map(|(x, y)| dot(*x, *y)).sum::<f64>())
        .collect();
    per_chunk.iter().sum()
}

/// u + c v, vertex by vertex.
fn axpy(u: &mut [[f64; 3]], c: f64, v: &[[f64; 3]]) {
    u.par_iter_mut().zip(v.par_iter()).with_min_len(1024).for_each(|(x, y)| {
        *x = add(*x, scale(*y, c));
    });
}

/// Lowers `problem`'s energy over the faces of `rings` with L-BFGS steps
/// moving every vertex that has a ring (see the module docs). `points` must
/// be a certified map of `rings`' mesh; it stays one. `stop()` is asked before
/// every iteration.
///
/// # Errors
/// [`Stopped`] when `stop()` says so (the points are then a valid state,
/// but uncertified: the caller abandons them).
pub fn lbfgs(
    problem: &Problem<'_>,
    rings: &[Vec<u32>],
    points: &mut [[f64; 3]],
    params: &LbfgsParams,
    stop: &(dyn Fn() -> bool + Sync),
) -> Result<LbfgsRun, Stopped> {
    let (faces, surface) = Faces::new(problem, rings);
    let energy = problem.energy;
    let k = faces.area_scale(points, surface);
    // The chord-area weight, fixed for the run as k is.
    let density = faces.energy(energy, k, 0.0, points);
    let mu = chord_area::weight(chord_area::applies(energy), density, faces.chord_total(points));
    let per_area = |e: f64| e / (k * surface).max(f64::MIN_POSITIVE);
    let mut eval = faces.evaluate(energy, k, mu, points);
    let mut run = LbfgsRun {
        iterations: 0,
        start: per_area(eval.energy),
        end: per_area(eval.energy),
        converged: false,
        fell_back: false,
        factor_seconds: 0.0,
        solve_seconds: 0.0,
        trials: 0,
    };
    if faces.corners.is_empty() || !eval.energy.is_finite() || params.max_iter == 0 {
        return Ok(run);
    }
    let start_points = points.to_vec();
    let moving: Vec<bool> = rings.iter().map(|r| !r.is_empty()).collect();
    let factorise = |eval: &Evaluation, run: &mut LbfgsRun| {
        let started = std::time::Instant::now();
        let pre = faces.preconditioner(k, eval).ok();
        run.factor_seconds += started.elapsed().as_secs_f64();
        pre
    };
    let Some(mut pre) = factorise(&eval, &mut run) else {
        return Ok(run);
    };
    // (s, y, 1 / s.y), oldest first.
    let mut memory: VecDeque<Pair> = VecDeque::new();
    let mut gamma = 1.0;
    let mut since_factor = 0;
    while run.iterations < params.max_iter {
        if stop() {
            return Err(Stopped);
        }
        if since_factor == REFACTOR_EVERY {
            since_factor = 0;
            match factorise(&eval, &mut run) {
                Some(p) => pre = p,
                None => break,
            }
        }
        since_factor += 1;
        // Two-loop recursion (N&W Algorithm 7.4).
        let mut q = eval.gradient.clone();
        let mut alphas = Vec::with_capacity(memory.len());
        for (s, y, rho) in memory.iter().rev() {
            let alpha = rho * inner(s, &q);
            axpy(&mut q, -alpha, y);
            alphas.push(alpha);
        }
        let solve_started = std::time::Instant::now();
        let Ok(mut r) = precondition(&pre.0, &pre.1, points, &q) else { break };
        run.solve_seconds += solve_started.elapsed().as_secs_f64();
        r.par_iter_mut().for_each(|x| *x = scale(*x, gamma));
        for ((s, y, rho), alpha) in memory.iter().zip(alphas.iter().rev()) {
            let beta = rho * inner(y, &r);
            axpy(&mut r, alpha - beta, s);
        }
        // The pairs are chords and differences of gradients at other
        // points, not tangents here: the direction is projected back.
        let mut direction: Vec<[f64; 3]> = r
            .par_iter()
            .zip(points.par_iter())
            .with_min_len(1024)
            .map(|(x, p)| scale(sub(*x, scale(*p, dot(*x, *p))), -1.0))
            .collect();
        let mut slope = inner(&eval.gradient, &direction);
        if slope.is_nan() || slope >= 0.0 {
            // Not a descent direction: forget the pairs, take K^-1 g.
            memory.clear();
            let Ok(r) = precondition(&pre.0, &pre.1, points, &eval.gradient) else { break };
            direction = r.par_iter().map(|x| scale(*x, -gamma)).collect();
            slope = inner(&eval.gradient, &direction);
            if slope.is_nan() || slope >= 0.0 {
                break;
            }
        }
        let mut t = (SAFE_FRACTION * faces.safe_step(points, &direction)).min(1.0);
        let mut accepted = None;
        for _ in 0..MAX_HALVINGS {
            let trial: Vec<[f64; 3]> = points
                .par_iter()
                .zip(direction.par_iter())
                .zip(moving.par_iter())
                .with_min_len(1024)
                .map(
                    |((&p, &d), &m)| {
                        if m {
                            normalize(add(p, scale(d, t))).unwrap_or(p)
                        } else {
                            p
                        }
                    },
                )
                .collect();
            let e = faces.energy(energy, k, mu, &trial);
            run.trials += 1;
            if e.is_finite() && e <= eval.energy + ARMIJO * t * slope && faces.all_positive(&trial)
            {
                accepted = Some(trial);
                break;
            }
            t *= 0.5;
        }
        let Some(trial) = accepted else {
            if memory.is_empty() {
                break;
            }
            memory.clear();
            continue;
        };
        let next = faces.evaluate(energy, k, mu, &trial);
        let s: Vec<[f64; 3]> =
            trial.par_iter().zip(points.par_iter()).map(|(a, b)| sub(*a, *b)).collect();
        let y: Vec<[f64; 3]> = next
            .gradient
            .par_iter()
            .zip(eval.gradient.par_iter())
            .map(|(a, b)| sub(*a, *b))
            .collect();
        let sy = inner(&s, &y);
        let change = (eval.energy - next.energy) / eval.energy.abs().max(f64::MIN_POSITIVE);
        if sy > 1e-12 * inner(&s, &s).sqrt() * inner(&y, &y).sqrt() {
            if let Ok(sks) = k_norm(&pre.0, &s) {
                if sks > 0.0 && sks.is_finite() {
                    gamma = sks / sy;
                }
            }
            if memory.len() == MEMORY {
                memory.pop_front();
            }
            memory.push_back((s, y, 1.0 / sy));
        }
        points.copy_from_slice(&trial);
        eval = next;
        run.iterations += 1;
        if change < params.tolerance {
            run.converged = true;
            break;
        }
    }
    // Vertices without a ring (removed on a coarse level) are on no face;
    // the certificate speaks of the faces, so they stand anywhere on the
    // sphere for it.
    let placed: Vec<[f64; 3]> =
        points.iter().zip(&moving).map(|(&p, &m)| if m { p } else { [0.0, 0.0, 1.0] }).collect();
    if !check_sphere(&faces.corners, &placed).valid {
        points.copy_from_slice(&start_points);
        run.fell_back = true;
        eval.energy = faces.energy(energy, k, mu, points);
    }
    run.end = per_area(eval.energy);
    Ok(run)
}

#[cfg(test)]
mod tests;
