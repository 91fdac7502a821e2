//! The loop that relaxation (thesis 5.2, eq. 5.15) and Alexa's method (5.3,
//! eq. 5.17-5.19) share: initial points, a parallel Jacobi-style sweep, the
//! exact validity check of 3.4 every few sweeps, stopping rules, timing, and
//! the certificate that the points have collapsed for good.
//!
//! The certificate: if every point lies in an open hemisphere `n . v > 0`, a
//! convex combination of them does too, and so does its projection; the points
//! can then never leave it, and a valid drawing, which covers the whole sphere,
//! can no longer be reached (thesis 5.2, 7.3). `n` is the mean direction of the
//! points and the measure is the angular radius of the cap about `n` that
//! holds them all (below 90 degrees: collapsed).

use spherify_mesh::vec3::add;
use std::time::Instant;

use rayon::prelude::*;

use crate::certificate::validity::{check_sphere, SphereReport};
use crate::embedding::{normalize, SphereEmbedding, Status};
use crate::error::SphereError;

/// The controls both relaxation methods share, checked.
pub(crate) struct Controls {
    pub max_iter: usize,
    pub check_every: usize,
    pub tol: f64,
    pub strict: bool,
}

impl Controls {
    pub fn new(
        max_iter: usize,
        check_every: usize,
        tol: f64,
        strict: bool,
    ) -> Result<Controls, SphereError> {
        if check_every == 0 {
            return Err(SphereError::InvalidParameter {
                name: "check_every",
                value: "0".into(),
                expected: "at least 1",
            });
        }
        if !(tol >= 0.0 && tol.is_finite()) {
            return Err(SphereError::InvalidParameter {
                name: "tol",
                value: tol.to_string(),
                expected: "a finite number >= 0",
            });
        }
        Ok(Controls { max_iter, check_every, tol, strict })
    }
}

/// How far the points may spread and still be certain never to become valid.
#[derive(Debug, Clone, Copy)]
pub(crate) enum CapLimit {
    /// No certificate: updates that are not convex combinations can leave any cap.
    None,
    /// Any open hemisphere (updates are convex combinations).
    Hemisphere,
    /// A cap of angular radius at most `asin(s)`, `s < 1`: within it the update is
    /// a convex combination (Alexa's method with a large constant step).
    SinRadius(f64),
}

/// Margin on the hemisphere test, far above the rounding of one update (~1e-16)
/// so that rounding cannot undo the certificate.
const HEMISPHERE_MARGIN: f64 = 1e-9;

/// Points per parallel task. Fixed, so that per-chunk sums are added in the same
/// order on any number of threads (a work-stealing float reduction is not).
const CHUNK: usize = 1024;

/// Sum of the points, chunk by chunk, deterministically.
pub(crate) fn point_sum(points: &[[f64; 3]]) -> [f64; 3] {
    let partial: Vec<[f64; 3]> =
        points.par_chunks(CHUNK).map(|c| c.iter().fold([0.0; 3], |s, &p| add(s, p))).collect();
    partial.into_iter().fold([0.0; 3], add)
}

/// One Jacobi sweep, `next[i] = update(points, i)` for every vertex in parallel.
/// Returns the largest move of a point and the sum of the new points (for the
/// collapse test), computed in the same pass.
fn sweep<F>(points: &[[f64; 3]], next: &mut [[f64; 3]], update: &F) -> (f64, [f64; 3])
where
    F: Fn(&[[f64; 3]], usize) -> [f64; 3] + Sync,
{
    let partial: Vec<(f64, [f64; 3])> = next
        .par_chunks_mut(CHUNK)
        .enumerate()
        .map(|(c, out)| {
            let (mut moved, mut sum) = (0.0f64, [0.0; 3]);
            for (k, slot) in out.iter_mut().enumerate() {
                let i = c * CHUNK + k;
                let (p, old) = (update(points, i), points[i]);
                let d =
                    ((p[0] - old[0]).powi(2) + (p[1] - old[1]).powi(2) + (p[2] - old[2]).powi(2))
                        .sqrt();
                moved = moved.max(d);
                sum = add(sum, p);
                *slot = p;
            }
            (moved, sum)
        })
        .collect();
    partial.into_iter().fold((0.0, [0.0; 3]), |(m, s), (dm, ds)| (m.max(dm), add(s, ds)))
}

/// The cap about the mean direction that holds every point: `(cos of its
/// angular radius, |mean of the points|)`, or `None` when the mean is zero.
/// `sum` is the sum of the points.
pub(crate) fn enclosing_cap(points: &[[f64; 3]], sum: [f64; 3]) -> Option<(f64, f64)> {
    let n = normalize(sum)?;
    let resultant =
        (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt() / points.len() as f64;
    // min is exact, so the parallel reduction is deterministic.
    let cos = points
        .par_iter()
        .with_min_len(1 << 14)
        .map(|p| n[0] * p[0] + n[1] * p[1] + n[2] * p[2])
        .reduce(|| f64::INFINITY, f64::min);
    Some((cos, resultant))
}

fn collapsed(cap: CapLimit, cos: f64) -> bool {
    match cap {
        CapLimit::None => false,
        CapLimit::Hemisphere => cos > HEMISPHERE_MARGIN,
        CapLimit::SinRadius(s) => cos > (1.0 - s * s).max(0.0).sqrt() + HEMISPHERE_MARGIN,
    }
}

/// Why the points are collapsing: they lie within a cap of cosine `cos`
/// after `r` iterations, `resultant` the length of their mean.
fn collapse_message(method: &str, r: usize, cos: f64, resultant: f64) -> String {
    let radius = cos.clamp(-1.0, 1.0).acos().to_degrees();
    let (when, advice) = if r == 0 {
        (
            "the initial points already lie".to_string(),
            "; choose a centre inside the mesh, or other initial points",
        )
    } else {
        (format!("after {r} iterations all points lie"), "")
    };
    format!(
        "{method}: {when} within {radius:.3} degrees of one direction (mean resultant length \
         {resultant:.4}), in an open hemisphere that the update never leaves and that holds no \
         valid embedding: the drawing is collapsing towards one point (thesis 5.2){advice}"
    )
}

/// What is still wrong after the last of `r` iterations.
fn max_iter_message(method: &str, r: usize, n_faces: usize, report: &SphereReport) -> String {
    let flipped = report.flipped_faces.len();
    format!(
        "{method}: no valid embedding after {r} iterations (max_iter): {flipped} of {} faces fail \
         the orientation test, covering degree {}",
        n_faces, report.covering_degree
    )
}

/// The loop both methods share: `update(points, i)` is the new position of
/// vertex `i` from the previous iterate (a Jacobi step). Tests for collapse
/// after every iteration (O(N), fused with the sweep), for validity every
/// `check_every` iterations, when the moves fall below `tol`, and at the end.
/// Calls `progress(iterations, max_iter)` before every iteration (one sweep,
/// milliseconds even at 10^6 vertices), stops with [`SphereError::Cancelled`]
/// on `false`, and reports `(max_iter, max_iter)` once it has ended.
#[allow(clippy::too_many_arguments)]
pub(crate) fn iterate<F>(
    faces: &[[u32; 3]],
    mut points: Vec<[f64; 3]>,
    controls: &Controls,
    cap: CapLimit,
    setup_seconds: f64,
    method: &'static str,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
    update: F,
) -> Result<SphereEmbedding, SphereError>
where
    F: Fn(&[[f64; 3]], usize) -> [f64; 3] + Sync,
{
    let start = Instant::now();
    let mut next = points.clone();
    let mut sum = point_sum(&points);
    let mut r = 0usize;
    let mut settled_checked = false;
    let (status, message) = loop {
        // Reports the iterations done of at most `max_iter` (issue 24: a bar
        // for the iterative methods); the end reports `max_iter` below.
        if !progress(r, controls.max_iter) {
            return Err(SphereError::Cancelled {
                stage: method,
                done: r,
                total: controls.max_iter,
            });
        }
        if let Some((cos, resultant)) = enclosing_cap(&points, sum) {
            if collapsed(cap, cos) {
                break (Status::Collapsed, collapse_message(method, r, cos, resultant));
            }
        }
        let scheduled = r % controls.check_every == 0 || r == controls.max_iter;
        if scheduled {
            let report = check_sphere(faces, &points);
            if report.valid {
                break (
                    Status::Converged,
                    format!("{method}: the exact validity test of thesis 3.4 passed after {r} iterations"),
                );
            }
            if r == controls.max_iter {
                break (Status::MaxIterations, max_iter_message(method, r, faces.len(), &report));
            }
        }
        let (moved, new_sum) = sweep(&points, &mut next, &update);
        std::mem::swap(&mut points, &mut next);
        sum = new_sum;
        r += 1;
        // A settled iteration is tested once (until it moves again); if it is
        // not valid it may still drift, so the schedule goes on.
        if moved < controls.tol {
            if !settled_checked && r % controls.check_every != 0 && r != controls.max_iter {
                settled_checked = true;
                if check_sphere(faces, &points).valid {
                    break (
                        Status::Converged,
                        format!(
                            "{method}: the iteration settled (largest move {moved:.3e} < tol) and the exact \
                             validity test of thesis 3.4 passed after {r} iterations"
                        ),
                    );
                }
            }
        } else {
            settled_checked = false;
        }
    };
    // The run is over, however it ended: a bar is drawn to its end. What
    // the callable answers no longer matters.
    progress(controls.max_iter, controls.max_iter);
    let embedding = SphereEmbedding {
        points,
        iterations: r,
        status,
        message,
        seconds: vec![("setup", setup_seconds), ("iterate", start.elapsed().as_secs_f64())],
    };
    if controls.strict && status != Status::Converged {
        return Err(SphereError::NoConvergence { last: Box::new(embedding) });
    }
    Ok(embedding)
}
