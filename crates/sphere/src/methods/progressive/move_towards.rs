//! Soft targets, for registration: every vertex with a weight moves along
//! its great circle towards a target as far as its star stays positive, the
//! fixed vertices never move, and a few energy sweeps may follow.
//!
//! A move is the landmarks' drag ([`crate::methods::progressive::landmarks`]):
//! a chord step whose faces' dets are linear in the step, its end tested
//! exactly, so every state is a valid GC-embedding (thesis 9.3.2). Vertices
//! of one colour class share no face and move in parallel, class after
//! class: the result does not depend on the number of threads.

use std::time::Instant;

use rayon::prelude::*;

use crate::certificate::validity::SphereReport;
use crate::embedding::{normalize, SphereEmbedding, Status};
use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;
use crate::methods::progressive::distortion_energy::Energy;
use crate::methods::progressive::landmarks::{angle, drag_star, slerp, Star};
use crate::methods::progressive::{
    held_vertices, neighbourhoods_of, require_valid_points, whole_mesh_problem,
};
use spherify_mesh::vec3::{det3, dot};

#[derive(Debug, Clone, PartialEq)]
pub struct TowardsParams {
    /// Passes of drags over every weighted vertex.
    pub passes: usize,
    /// Energy sweeps afterwards with the fixed vertices held (0: none).
    pub energy_sweeps: usize,
    pub energy: Energy,
}

impl Default for TowardsParams {
    fn default() -> Self {
        TowardsParams { passes: 3, energy_sweeps: 3, energy: Energy::Isometric }
    }
}

/// Drag steps of one vertex in one pass.
const STEPS_PER_PASS: usize = 4;
/// The drags keep every face's det above this fraction of the mean (faces
/// already below it do not shrink): without it, random targets
/// crushed triangles to the double-precision floor (measured on a
/// 2000-vertex `tentacles` with every vertex 10 degrees off in its own
/// direction: smallest triangle 0.0 of the mean, in floating point).
const FLOOR: f64 = 1e-2;

/// Cosines this far above the least are weighed again by their angle in
/// [`largest_angle`]: far above the rounding of a cosine and of an angle
/// (a few units of 1e-16), so the vertex of the largest computed angle is
/// always among them.
const COSINE_REACH: f64 = 1e-12;

/// The largest [`angle`] from a point to its goal (0 without goals), the
/// same value as the largest of all the angles: only the vertices whose
/// cosine `p . g` is within [`COSINE_REACH`] of the least are given their
/// angle (an `atan2` each, which for every vertex was about a twentieth of
/// a call of the warp's rounds, for the message alone; issue 23, speed,
/// session 13).
/// The vertex of the largest computed angle has an exact angle within a
/// few rounding units of the largest exact one, so its cosine is within a
/// few rounding units of the least.
fn largest_angle(points: &[[f64; 3]], goals: &[Option<[f64; 3]>]) -> f64 {
    let cosine = |i: usize| goals[i].map(|g| dot(points[i], g));
    let least = (0..points.len()).filter_map(cosine).fold(f64::INFINITY, f64::min);
    (0..points.len())
        .filter(|&i| cosine(i).is_some_and(|c| c <= least + COSINE_REACH))
        .filter_map(|i| goals[i].map(|g| angle(points[i], g)))
        .fold(0.0, f64::max)
}

/// Moves `points` (a valid map of `mesh`) towards `targets` (one direction
/// per vertex). Vertex `i` aims at the point a fraction `min(weights[i], 1)`
/// of the way along the great circle from where it starts to `targets[i]`
/// (weight 0: it does not aim anywhere; weight >= 1: the target itself) and
/// gets as far as its star stays positive (every face above a hundredth of
/// the mean, [`FLOOR`]); the vertices in `fixed` never
/// move, not even in the energy sweeps. `progress(0, 0)` is polled.
///
/// # Errors
/// [`SphereError::InvalidStart`] for a start that is not a valid map;
/// [`SphereError::InvalidParameter`] for arrays of the wrong length, a
/// weight negative or not finite, a weighted target with no direction, a
/// fixed id out of range; cancellation.
pub fn move_towards(
    mesh: &GenusZeroMesh,
    points: &[[f64; 3]],
    targets: &[[f64; 3]],
    weights: &[f64],
    fixed: &[i64],
    params: &TowardsParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<SphereEmbedding, SphereError> {
    move_towards_from(mesh, points, None, targets, weights, fixed, params, progress)
}

/// [`move_towards`], where `certificate` (when given) is the exact test of
/// `points` on `mesh` already made ([`crate::Embedding::certificate`]): the
/// start is then not tested again. The warp's rounds call this ten times in
/// a row on maps the core has just certified, and the test of the start was
/// about a tenth of each call (a 48k mesh, issue 23, speed).
#[allow(clippy::too_many_arguments)]
pub(crate) fn move_towards_from(
    mesh: &GenusZeroMesh,
    points: &[[f64; 3]],
    certificate: Option<&SphereReport>,
    targets: &[[f64; 3]],
    weights: &[f64],
    fixed: &[i64],
    params: &TowardsParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<SphereEmbedding, SphereError> {
    let n = mesh.n_vertices();
    let invalid = |name: &'static str, value: String, expected: &'static str| {
        SphereError::InvalidParameter { name, value, expected }
    };
    if points.len() != n {
        return Err(SphereError::PointCount { points: points.len(), vertices: n });
    }
    if targets.len() != n {
        return Err(invalid("targets", format!("{} rows", targets.len()), "one row per vertex"));
    }
    if weights.len() != n {
        return Err(invalid("weights", format!("{} values", weights.len()), "one per vertex"));
    }
    if let Some(i) = weights.iter().position(|w| !(w.is_finite() && *w >= 0.0)) {
        return Err(invalid(
            "weights",
            format!("weights[{i}] = {}", weights[i]),
            "finite and >= 0",
        ));
    }
    let held = held_vertices(fixed, n)?;
    let mut goals: Vec<Option<[f64; 3]>> = vec![None; n];
    for i in 0..n {
        if weights[i] > 0.0 && !held[i] {
            let t = normalize(targets[i]).ok_or_else(|| {
                invalid(
                    "targets",
                    format!("targets[{i}] = {:?}", targets[i]),
                    "a direction (finite, not zero) where the weight is > 0",
                )
            })?;
            goals[i] = Some(if weights[i] >= 1.0 { t } else { slerp(points[i], t, weights[i]) });
        }
    }
    require_valid_points(mesh, points, certificate)?;
    let started = Instant::now();
    let total = params.passes + params.energy_sweeps;
    let cancelled = |done: usize| SphereError::Cancelled { stage: "move_towards", done, total };
    // Kept with the mesh: the warp's rounds call this ten times on one mesh.
    let neighbourhoods = neighbourhoods_of(mesh)?;
    let (rings, classes) = (&neighbourhoods.rings, &neighbourhoods.classes);
    // No drag takes a face below this fraction of the mean det at the start.
    let mean_det = mesh
        .faces()
        .iter()
        .map(|&[a, b, c]| det3(points[a as usize], points[b as usize], points[c as usize]))
        .sum::<f64>()
        / mesh.n_faces().max(1) as f64;
    let floor = FLOOR * mean_det;
    let mut points = points.to_vec();
    for pass in 0..params.passes {
        for class in classes {
            if !progress(0, 0) {
                return Err(cancelled(pass));
            }
            let shared: &[[f64; 3]] = &points;
            let moves: Vec<Option<[f64; 3]>> = class
                .par_iter()
                .with_min_len(64)
                // Each worker gathers a vertex's star once for its drags
                // (landmarks::Star: the same points to the bit).
                .map_init(Star::default, |star, &v| {
                    let goal = goals[v as usize]?;
                    let mut p = shared[v as usize];
                    if p == goal {
                        return None;
                    }
                    star.gather(&rings[v as usize], shared);
                    for _ in 0..STEPS_PER_PASS {
                        if p == goal {
                            break;
                        }
                        match drag_star(p, goal, star, floor) {
                            Some(q) => p = q,
                            None => break,
                        }
                    }
                    (p != shared[v as usize]).then_some(p)
                })
                .collect();
            for (&v, q) in class.iter().zip(moves) {
                if let Some(q) = q {
                    points[v as usize] = q;
                }
            }
        }
        progress(pass + 1, total);
    }
    let left = largest_angle(&points, &goals);
    let mut sweeps = 0;
    if params.energy_sweeps > 0 {
        let problem = whole_mesh_problem(params.energy, mesh);
        let end = problem
            .optimise_holding(rings, &mut points, params.energy_sweeps, 0.0, Some(&held), &|_| {
                !progress(0, 0)
            })
            .map_err(|_| cancelled(params.passes))?;
        sweeps = end.sweeps;
    }
    progress(total, total);
    Ok(SphereEmbedding {
        points,
        iterations: params.passes + sweeps,
        status: Status::Converged,
        message: format!(
            "{} passes of flip-free drags towards the targets (largest angle left to a goal \
             {:.3} degrees), then {} energy sweeps with {} vertices fixed",
            params.passes,
            left.to_degrees(),
            sweeps,
            fixed.len()
        ),
        seconds: vec![("move_towards", started.elapsed().as_secs_f64())],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::lcg::Lcg;

    #[test]
    fn the_largest_angle_is_that_of_every_vertex() {
        // Random pairs, pairs at nearly the same point and nearly opposite
        // (where the cosine is flat and many vertices tie in it), pairs
        // without a goal: the filtered maximum equals the plain one.
        let mut rng = Lcg::new(5);
        let mut unit = || {
            let v = [rng.next_f64() - 0.5, rng.next_f64() - 0.5, rng.next_f64() - 0.5];
            normalize(v).unwrap()
        };
        for case in 0..40 {
            let n = 500;
            let points: Vec<[f64; 3]> = (0..n).map(|_| unit()).collect();
            let goals: Vec<Option<[f64; 3]>> = points
                .iter()
                .enumerate()
                .map(|(i, &p)| {
                    let tiny = [1e-9, -3e-10, 2e-9].map(|x| x * (i % 7) as f64);
                    match (case % 4, i % 5) {
                        (_, 0) => None,
                        (0, _) => Some(unit()),
                        (1, _) => normalize([p[0] + tiny[0], p[1] + tiny[1], p[2] + tiny[2]]),
                        (2, _) => normalize([tiny[0] - p[0], tiny[1] - p[1], tiny[2] - p[2]]),
                        _ => Some(p),
                    }
                })
                .collect();
            let plain =
                (0..n).filter_map(|i| goals[i].map(|g| angle(points[i], g))).fold(0.0, f64::max);
            assert_eq!(largest_angle(&points, &goals).to_bits(), plain.to_bits(), "case {case}");
        }
        assert_eq!(largest_angle(&[[1.0, 0.0, 0.0]], &[None]), 0.0);
    }
}
