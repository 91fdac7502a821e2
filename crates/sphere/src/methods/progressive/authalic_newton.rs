//! Global steps towards an area-preserving (authalic) map: a damped
//! Gauss-Newton iteration that moves every vertex of a valid map at once so
//! that each face's share of the sphere approaches its share of the surface.
//!
//! Why: the authalic energy's flip-free vertex moves ([`crate::methods::progressive::flip_free`])
//! stall on limbed shapes. A limb must take its area from the far side of
//! the sphere, and the thin triangles on the way allow only short local
//! steps (measured on the corpus: mean |log area ratio| 0.2-0.8 on 10 of 14
//! meshes, and lowering the angle weight did not help). A global step moves
//! the mass the whole way at once, like the density-equalising maps of
//! Gastner and Newman (2004) and, on the sphere, Lyu, Choi and Lui (2024,
//! "Spherical density-equalizing map for genus-0 closed surfaces"). Instead
//! of their diffusion, which matches areas only in the limit, this solves
//! the least-squares problem of the face areas directly (Levenberg 1944,
//! Marquardt 1963).
//!
//! The residual of face f with surface share s_f is r_f = log(E_f / (sum E)
//! / s_f), E_f the spherical triangle's area ([`signed_area`]; Van Oosterom and Strackee:
//! E = 2 atan2(det, 1 + a.b + b.c + c.a)). It is the area of the face's true
//! image under the map of thesis 3.3 (issue 10 defines the area ratio with
//! it), and it vanishes with det[a, b, c], so log E is a barrier against a
//! flip. The chord triangle's area, which `sp.quality` measures, agrees for
//! triangles small on the sphere; for a long sliver along a great circle it
//! is far larger. A second residual that kept such slivers out was tried
//! (the face's spherical over chord area): on the three coarse corpus meshes
//! (112-502 vertices), whose triangles are large on the sphere, the
//! iteration then stopped at 0.10-0.17 instead of 0.03-0.08.
//!
//! A step: linearise r in the tangent plane of every vertex (two
//! unknowns per vertex), solve (J^T J + lambda diag(J^T J)) x = -J^T r with
//! sparse Cholesky, move every vertex along its tangent x and normalise.
//! Each r_f is clamped to [-[`RESIDUAL_CLAMP`], +[`RESIDUAL_CLAMP`]] in the
//! right-hand side: the model is linear in log area, and a face ten times
//! too small would otherwise ask for a step far outside where it holds.
//!
//! Validity: no state is accepted that the exact certificate has not passed.
//! After a trial step, every vertex of a face that is not exactly positive
//! (or that fell below [`AREA_FLOOR`] of the mean) halves its own step, until
//! every face passes or it is back where it was; then [`check_sphere`] must
//! find a valid map (every face positive, covering degree 1), and the sum of
//! squared residuals must fall, or the whole step is halved. Halving only the
//! vertices near a failing face lets the rest of the mesh take the full step
//! where one thin triangle would otherwise hold everything back.

use rayon::prelude::*;
use spherify_mesh::predicates::{det3_sign, Sign};
use spherify_mesh::vec3::{add, cross, det3, dot, scale, sub, triangle_area};
use spherify_sparse::{CsrMatrix, Factorization};

use crate::certificate::validity::{check_sphere, signed_area};
use crate::embedding::normalize;
use crate::error::SphereError;
use crate::methods::progressive::flip_free::tangent_basis;

/// A moved face may not fall below this fraction of the mean face in
/// det[a, b, c] (proportional to area for small faces) unless it was
/// already smaller: area-preserving maps make thin triangles, and the map
/// must stay far from the double-precision floor (about 1e-16).
pub const AREA_FLOOR: f64 = 1e-10;
/// Largest log area change one step aims at for a face (see module docs).
pub const RESIDUAL_CLAMP: f64 = 0.5;
/// The iteration stops when a step lowers neither the sum of squared
/// residuals nor the mean |log area ratio| by this fraction. Both: a few
/// faces far from their area can hold the sum still while the mean falls
/// (measured on a coiled tube: the sum fell by 3e-4 in a step that took the
/// mean from 0.96 to 0.91).
pub const TOLERANCE: f64 = 1e-3;
/// It also stops once the mean |log area ratio| is below this: further
/// steps buy area invisible in any measure with angle distortion (measured
/// on bumpy, 1250 vertices: 0.074 -> 0.001 took the mean angle distortion
/// from 11.2 to 19.3 degrees).
pub const GOAL: f64 = 0.02;
/// Halvings of a step before the iteration stops.
const MAX_HALVINGS: usize = 8;
/// A vertex whose step has been halved this often goes back to its start.
const MAX_VERTEX_HALVINGS: usize = 6;
/// Levenberg-Marquardt damping: start, and the bounds of its adaptation.
const LAMBDA_START: f64 = 1e-2;
const LAMBDA_RANGE: (f64, f64) = (1e-6, 1e3);

/// How an iteration ended.
#[derive(Debug, Clone, PartialEq)]
pub struct AuthalicSteps {
    /// Accepted steps.
    pub steps: usize,
    /// Mean |log spherical area ratio| before and after.
    pub start: f64,
    pub end: f64,
    /// Why it stopped before `max_steps`, if the linear system failed (the
    /// map is then the last accepted one, still certified).
    pub solve_failed: Option<String>,
}

/// Runs at most `max_steps` steps on `points`, a valid map (one point per
/// vertex, on the unit sphere) of the triangles `faces` of `surface`.
/// Surface triangles smaller than `area_floor` count as that large. `stop()`
/// is asked before each step. An invalid start is left as it is (no step
/// can pass the certificate's area test from one).
///
/// # Errors
/// [`SphereError::Cancelled`] when `stop()` says so; `points` then holds the
/// last accepted (valid) state.
pub fn authalic_newton(
    faces: &[[u32; 3]],
    surface: &[[f64; 3]],
    area_floor: f64,
    points: &mut [[f64; 3]],
    max_steps: usize,
    stop: &(dyn Fn() -> bool + Sync),
) -> Result<AuthalicSteps, SphereError> {
    let target = surface_shares(faces, surface, area_floor);
    let start = mean_abs_log(faces, points, &target);
    let mut result = AuthalicSteps { steps: 0, start, end: start, solve_failed: None };
    let mut current = merit(faces, points, &target);
    if !current.is_finite() || !check_sphere(faces, points).valid {
        return Ok(result);
    }
    let (mut t, mut lambda) = (1.0, LAMBDA_START);
    let mut mean = start;
    // The last step's factor: the system's pattern is the mesh's, the same
    // at every step, so its ordering and symbolic analysis are kept.
    let mut factor: Option<Factorization> = None;
    while result.steps < max_steps && mean > GOAL {
        if stop() {
            return Err(SphereError::Cancelled {
                stage: "authalic steps",
                done: result.steps,
                total: max_steps,
            });
        }
        let u = match direction(faces, points, &target, lambda, &mut factor) {
            Ok(u) => u,
            Err(e) => {
                result.solve_failed = Some(e.to_string());
                break;
            }
        };
        let mut accepted = None;
        for _ in 0..MAX_HALVINGS {
            if let Some(q) = trial(faces, points, &u, t) {
                let next = merit(faces, &q, &target);
                if next < current {
                    accepted = Some((q, next));
                    break;
                }
            }
            t *= 0.5;
        }
        // A full step means the model holds: trust it more, and less otherwise.
        lambda = if t == 1.0 { lambda * 0.3 } else { lambda * 3.0 };
        lambda = lambda.clamp(LAMBDA_RANGE.0, LAMBDA_RANGE.1);
        let Some((q, next)) = accepted else { break };
        points.copy_from_slice(&q);
        result.steps += 1;
        let next_mean = mean_abs_log(faces, points, &target);
        let fall = ((current - next) / current).max((mean - next_mean) / mean);
        (current, mean) = (next, next_mean);
        if fall < TOLERANCE {
            break;
        }
        // Let the step grow again after a short one.
        t = (2.0 * t).min(1.0);
    }
    result.end = mean;
    Ok(result)
}

/// [`authalic_newton`] on one level of a progressive mesh, whose neighbour
/// lists (counter-clockwise; empty for vertices not yet inserted) are
/// `rings`: the faces are gathered from the rings and the vertices numbered
/// densely, so that every unknown of the linear system belongs to a face.
pub fn authalic_newton_rings(
    rings: &[Vec<u32>],
    surface: &[[f64; 3]],
    area_floor: f64,
    points: &mut [[f64; 3]],
    max_steps: usize,
    stop: &(dyn Fn() -> bool + Sync),
) -> Result<AuthalicSteps, SphereError> {
    let alive: Vec<u32> =
        (0..rings.len() as u32).filter(|&v| !rings[v as usize].is_empty()).collect();
    let mut index = vec![u32::MAX; rings.len()];
    for (k, &v) in alive.iter().enumerate() {
        index[v as usize] = k as u32;
    }
    let mut faces = Vec::new();
    for &v in &alive {
        let ring = &rings[v as usize];
        let m = ring.len();
        for j in 0..m {
            let (a, b) = (ring[j], ring[(j + 1) % m]);
            // Each face once, from its smallest corner.
            if v < a && v < b {
                faces.push([index[v as usize], index[a as usize], index[b as usize]]);
            }
        }
    }
    let level_surface: Vec<[f64; 3]> = alive.iter().map(|&v| surface[v as usize]).collect();
    let mut level_points: Vec<[f64; 3]> = alive.iter().map(|&v| points[v as usize]).collect();
    let result =
        authalic_newton(&faces, &level_surface, area_floor, &mut level_points, max_steps, stop);
    // Also after a cancellation: the level's points are a valid state.
    for (&v, p) in alive.iter().zip(level_points) {
        points[v as usize] = p;
    }
    result
}

/// Each face's share of the surface area, the small ones counted as
/// `area_floor`.
fn surface_shares(faces: &[[u32; 3]], surface: &[[f64; 3]], area_floor: f64) -> Vec<f64> {
    let areas: Vec<f64> = faces
        .par_iter()
        .map(|&f| {
            let [a, b, c] = f.map(|v| surface[v as usize]);
            let area = triangle_area(a, b, c);
            if area >= area_floor && area.is_finite() {
                area
            } else {
                area_floor
            }
        })
        .collect();
    let total: f64 = areas.iter().sum();
    areas.iter().map(|a| a / total).collect()
}

/// The residual of every face (see the module docs).
fn residuals(faces: &[[u32; 3]], points: &[[f64; 3]], target: &[f64]) -> Vec<f64> {
    let areas: Vec<f64> = faces
        .par_iter()
        .map(|&f| {
            let [a, b, c] = f.map(|v| points[v as usize]);
            signed_area(a, b, c)
        })
        .collect();
    let total: f64 = areas.iter().sum();
    areas.iter().zip(target).map(|(&e, &s)| (e / (total * s)).ln()).collect()
}

/// Half the sum of squared residuals; infinite when one is not finite.
fn merit(faces: &[[u32; 3]], points: &[[f64; 3]], target: &[f64]) -> f64 {
    let m: f64 = residuals(faces, points, target).iter().map(|r| 0.5 * r * r).sum();
    if m.is_nan() {
        f64::INFINITY
    } else {
        m
    }
}

/// Mean |log(sphere share / surface share)| over the faces.
fn mean_abs_log(faces: &[[u32; 3]], points: &[[f64; 3]], target: &[f64]) -> f64 {
    let sum: f64 = residuals(faces, points, target).iter().map(|r| r.abs()).sum();
    sum / faces.len().max(1) as f64
}

/// Per face: the six unknowns it touches (two tangent components at each
/// corner, in `basis`) and the gradient of its residual with respect to them.
fn jacobian_rows(
    faces: &[[u32; 3]],
    points: &[[f64; 3]],
    basis: &[([f64; 3], [f64; 3])],
) -> Vec<([u32; 6], [f64; 6])> {
    faces
        .par_iter()
        .map(|&face| {
            let p = face.map(|v| points[v as usize]);
            let (mut idx, mut ja) = ([0u32; 6], [0.0; 6]);
            for i in 0..3 {
                let (a, b, c) = (p[i], p[(i + 1) % 3], p[(i + 2) % 3]);
                // E = 2 atan2(N, D), N = det[a, b, c], D = 1 + a.b + b.c + c.a:
                // dE/da = 2 (D (b x c) - N (b + c)) / (N^2 + D^2).
                let (num, den) = (det3(a, b, c), 1.0 + dot(a, b) + dot(b, c) + dot(c, a));
                let e = 2.0 * num.atan2(den);
                let grad_e = scale(
                    sub(scale(cross(b, c), den), scale(add(b, c), num)),
                    2.0 / ((num * num + den * den) * e),
                );
                let (e1, e2) = basis[face[i] as usize];
                for (k, e_k) in [e1, e2].into_iter().enumerate() {
                    idx[2 * i + k] = 2 * face[i] + k as u32;
                    ja[2 * i + k] = dot(grad_e, e_k);
                }
            }
            (idx, ja)
        })
        .collect()
}

/// The faces at each vertex, with the vertex's corner: vertex `v`'s are
/// `corners[start[v]..start[v + 1]]`. The matrix is built row by row in
/// parallel from them, without a triplet list (which at 36 entries per face
/// was most of the memory).
fn vertex_corners(faces: &[[u32; 3]], n: usize) -> (Vec<usize>, Vec<(u32, usize)>) {
    let mut start = vec![0usize; n + 1];
    for face in faces {
        for &v in face {
            start[v as usize + 1] += 1;
        }
    }
    for v in 0..n {
        start[v + 1] += start[v];
    }
    let mut fill = start.clone();
    let mut corners = vec![(0u32, 0usize); 3 * faces.len()];
    for (f, face) in faces.iter().enumerate() {
        for (i, &v) in face.iter().enumerate() {
            corners[fill[v as usize]] = (f as u32, i);
            fill[v as usize] += 1;
        }
    }
    (start, corners)
}

/// The Levenberg-Marquardt step: a tangent vector per vertex. `factor` is
/// the previous step's factor, refactored with its ordering and symbolic
/// analysis ([`Factorization::refactor`]; the same bits as a new one), and
/// left with this step's.
fn direction(
    faces: &[[u32; 3]],
    points: &[[f64; 3]],
    target: &[f64],
    lambda: f64,
    factor: &mut Option<Factorization>,
) -> Result<Vec<[f64; 3]>, SphereError> {
    let n = points.len();
    let res = residuals(faces, points, target);
    let basis: Vec<([f64; 3], [f64; 3])> = points.par_iter().map(|&p| tangent_basis(p)).collect();
    let rows = jacobian_rows(faces, points, &basis);
    let (start, corners) = vertex_corners(faces, n);
    // Unknown r is component r % 2 of vertex r / 2; at a face's corner i it
    // is the face's local unknown 2 i + r % 2.
    let at = |r: usize| {
        corners[start[r / 2]..start[r / 2 + 1]]
            .iter()
            .map(move |&(f, i)| (f as usize, 2 * i + r % 2))
    };
    let diag: Vec<f64> = (0..2 * n)
        .into_par_iter()
        .map(|r| at(r).map(|(f, a)| rows[f].1[a] * rows[f].1[a]).sum())
        .collect();
    // Marquardt's scaling, plus a trace-relative shift that keeps the matrix
    // positive definite where a vertex's faces hardly constrain it.
    let mean_diag = diag.iter().sum::<f64>() / diag.len().max(1) as f64;
    let (h, rhs) = CsrMatrix::from_rows(2 * n, 2 * n, |r, entries| {
        let mut b = 0.0;
        for (f, a) in at(r) {
            let (idx, ja) = &rows[f];
            b -= ja[a] * res[f].clamp(-RESIDUAL_CLAMP, RESIDUAL_CLAMP);
            for k in 0..6 {
                entries.push((idx[k], ja[a] * ja[k]));
            }
        }
        entries.push((r as u32, lambda * diag[r] + 1e-9 * mean_diag));
        b
    })?;
    // Only the matrix and right-hand side are needed from here: the
    // Jacobian rows, the corners and the residuals (about 300 bytes per
    // vertex) go before the factor, the step's memory peak, is made.
    drop((res, rows, start, corners, diag));
    let f = match factor.take() {
        Some(f) => f.refactor(&h)?,
        None => Factorization::reusable(&h)?,
    };
    let x = f.solve(&h, &[rhs])?.remove(0);
    *factor = Some(f);
    Ok((0..n)
        .map(|v| {
            let (e1, e2) = basis[v];
            add(scale(e1, x[2 * v]), scale(e2, x[2 * v + 1]))
        })
        .collect())
}

/// `points` moved by `t u`, each vertex of a face that fails the exact test
/// (or falls below the floor) halving its own step until its faces pass or
/// it is back at its start; `None` unless a valid map results.
fn trial(faces: &[[u32; 3]], points: &[[f64; 3]], u: &[[f64; 3]], t: f64) -> Option<Vec<[f64; 3]>> {
    let mean_det = 2.0 * 4.0 * std::f64::consts::PI / faces.len().max(1) as f64;
    let floor = AREA_FLOOR * mean_det;
    let moved = |v: usize, step: f64| {
        if step == 0.0 {
            points[v]
        } else {
            normalize(add(points[v], scale(u[v], step))).unwrap_or(points[v])
        }
    };
    let mut q: Vec<[f64; 3]> = (0..points.len()).into_par_iter().map(|v| moved(v, t)).collect();
    let mut halvings = vec![0usize; points.len()];
    let passes = |q: &[[f64; 3]], f: &[u32; 3]| {
        let [a, b, c] = f.map(|v| q[v as usize]);
        let old = det3(points[f[0] as usize], points[f[1] as usize], points[f[2] as usize]);
        det3_sign(a, b, c) == Sign::Positive && det3(a, b, c) >= floor.min(old)
    };
    // Each round halves at least one vertex's step, and a vertex at its
    // start with all its faces at their start passes: this ends.
    loop {
        let failing: Vec<u32> = faces
            .par_iter()
            .filter(|f| !passes(&q, f))
            .flat_map_iter(|f| f.iter().copied())
            .collect();
        if failing.is_empty() {
            return check_sphere(faces, &q).valid.then_some(q);
        }
        let mut failing = failing;
        failing.sort_unstable();
        failing.dedup();
        let mut changed = false;
        for v in failing {
            let v = v as usize;
            if halvings[v] <= MAX_VERTEX_HALVINGS {
                halvings[v] += 1;
                let step = if halvings[v] > MAX_VERTEX_HALVINGS {
                    0.0
                } else {
                    t * 0.5f64.powi(halvings[v] as i32)
                };
                q[v] = moved(v, step);
                changed = true;
            }
        }
        if !changed {
            // Not reached from a valid start: a face whose three corners are
            // back at their start is the start's face, which passes. Refuse
            // the step rather than loop.
            return None;
        }
    }
}

#[cfg(test)]
mod tests;
