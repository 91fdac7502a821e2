//! A smooth flow of the sphere that carries the landmarks towards their
//! targets and every other vertex along with them, in small increments.
//!
//! Each increment is a tangent velocity field interpolating the landmarks'
//! displacements (a fraction of the log map towards each target) with
//! Gaussian radial basis functions, one per landmark, whose width is half
//! the distance to the nearest other landmark (so that landmarks that move
//! differently do not drag each other) and at most one radian. Every vertex
//! moves to `normalize(x + v(x))` at once, and the increment is kept only if
//! the whole map passes the exact test of thesis 3.4; otherwise the step is
//! halved, and after a few halvings the flow stops and leaves the rest to the
//! drag. A field whose step is small against its widths is a diffeomorphism,
//! so the flow keeps triangles in proportion where the landmarks agree, which
//! the one-vertex drag cannot.

use rayon::prelude::*;
use spherify_mesh::vec3::{add, dot, norm, scale, sub};

use crate::certificate::validity::check_sphere;
use crate::embedding::normalize;
use crate::methods::progressive::flip_free::Stopped;

use super::{angle, Landmarks};

/// Landmarks beyond this count skip the flow (its solve is cubic in them).
const MAX_LANDMARKS: usize = 256;
/// Most increments tried (at [`STEP`] each, 45 degrees takes 8 or more),
/// and the halvings of one before the flow stops.
const MAX_INCREMENTS: usize = 200;
const HALVINGS: usize = 4;
/// Largest angle a landmark moves in one increment (radians), and largest
/// displacement against its basis function's width.
const STEP: f64 = 0.1;
const STEP_PER_WIDTH: f64 = 0.4;
/// Basis function widths (chord lengths) are clamped to this range.
const WIDTH: (f64, f64) = (0.02, 1.0);
/// Below this angle to every target the flow has nothing left to do.
const DONE: f64 = 1e-6;
/// exp(-36) ~ 2e-16: a basis function is zero beyond this many widths squared.
const CUTOFF: f64 = 36.0;

/// Lowers the energy of a map with the landmarks held (flip-free).
pub(super) type Relax<'a> = dyn FnMut(&mut [[f64; 3]]) -> Result<(), Stopped> + 'a;

/// Runs the flow on `points` (a valid map of `faces`, kept valid); returns
/// the increments kept. After each increment `relax` lowers the energy with
/// the landmarks held (flip-free): the flow alone piles triangles up in
/// front of each landmark (measured on a 642-vertex icosphere with 8
/// landmarks 45 degrees away: the smallest triangle fell from 0.7 to 0.03 of
/// the mean in six increments, and the next increment flipped faces), and
/// relaxing between increments spreads that out. `stop()` is asked before
/// each increment.
pub(super) fn flow(
    faces: &[[u32; 3]],
    points: &mut Vec<[f64; 3]>,
    landmarks: &Landmarks,
    relax: &mut Relax<'_>,
    stop: &(dyn Fn() -> bool + Sync),
) -> Result<usize, Stopped> {
    let k = landmarks.len();
    if k == 0 || k > MAX_LANDMARKS {
        return Ok(0);
    }
    let mut kept = 0;
    let mut tries = 0;
    let mut gear = 1.0f64;
    while tries < MAX_INCREMENTS {
        tries += 1;
        if stop() {
            return Err(Stopped);
        }
        let centres: Vec<[f64; 3]> = landmarks.ids.iter().map(|&i| points[i as usize]).collect();
        let logs: Vec<[f64; 3]> =
            centres.iter().zip(&landmarks.targets).map(|(&c, &t)| log_map(c, t)).collect();
        let far = logs.iter().map(|&d| norm(d)).fold(0.0, f64::max);
        if far < DONE {
            break;
        }
        let widths = widths(&centres);
        // Each landmark moves a fixed angle per increment (not a fraction of
        // what is left, which converged geometrically: 64 increments left 10
        // of 45 degrees on a 2000-vertex `tentacles` with 32 landmarks), at
        // most a fraction of its basis function's width; `gear` halves the
        // whole field after a refused increment and recovers after a kept one.
        let speeds: Vec<f64> = logs
            .iter()
            .zip(&widths)
            .map(|(d, w)| {
                let len = norm(*d);
                if len > 0.0 {
                    (STEP.min(STEP_PER_WIDTH * w) / len).min(1.0)
                } else {
                    0.0
                }
            })
            .collect();
        let mut accepted = false;
        for _ in 0..=HALVINGS {
            let velocity: Vec<[f64; 3]> =
                logs.iter().zip(&speeds).map(|(&d, &s)| scale(d, s * gear)).collect();
            let Some(coefficients) = interpolate(&centres, &widths, &velocity) else {
                return Ok(kept);
            };
            let moved: Vec<[f64; 3]> = points
                .par_iter()
                .map(|&x| {
                    let v = field(x, &centres, &widths, &coefficients);
                    // The tangent part: the radial part only rescales.
                    let v = sub(v, scale(x, dot(v, x)));
                    normalize(add(x, v)).unwrap_or(x)
                })
                .collect();
            if check_sphere(faces, &moved).valid {
                *points = moved;
                kept += 1;
                accepted = true;
                gear = (2.0 * gear).min(1.0);
                relax(points)?;
                break;
            }
            // Triangles piled up against the field: relax them, then try
            // half the step.
            relax(points)?;
            gear *= 0.5;
        }
        if !accepted {
            break;
        }
    }
    Ok(kept)
}

/// The tangent vector at `c` towards `t` whose length is their angle.
fn log_map(c: [f64; 3], t: [f64; 3]) -> [f64; 3] {
    let along = sub(t, scale(c, dot(c, t)));
    let len = norm(along);
    if len == 0.0 {
        return [0.0; 3];
    }
    scale(along, angle(c, t) / len)
}

/// Half the chord to the nearest other landmark, clamped to [`WIDTH`].
fn widths(centres: &[[f64; 3]]) -> Vec<f64> {
    centres
        .iter()
        .enumerate()
        .map(|(a, &c)| {
            let nearest = centres
                .iter()
                .enumerate()
                .filter(|&(b, _)| b != a)
                .map(|(_, &o)| norm(sub(c, o)))
                .fold(f64::INFINITY, f64::min);
            (0.5 * nearest).clamp(WIDTH.0, WIDTH.1)
        })
        .collect()
}

fn basis(x: [f64; 3], centre: [f64; 3], width: f64) -> f64 {
    let d = sub(x, centre);
    let r = dot(d, d) / (width * width);
    if r > CUTOFF {
        0.0
    } else {
        (-r).exp()
    }
}

fn field(x: [f64; 3], centres: &[[f64; 3]], widths: &[f64], coefficients: &[[f64; 3]]) -> [f64; 3] {
    let mut v = [0.0; 3];
    for ((&c, &w), &a) in centres.iter().zip(widths).zip(coefficients) {
        let phi = basis(x, c, w);
        if phi != 0.0 {
            v = add(v, scale(a, phi));
        }
    }
    v
}

/// Coefficients `a_k` with `sum_k a_k phi_k(c_j) = v_j` for every landmark
/// `j`: Gaussian elimination with partial pivoting on the k x k system,
/// three right-hand sides. `None` when the system is singular.
fn interpolate(
    centres: &[[f64; 3]],
    widths: &[f64],
    velocity: &[[f64; 3]],
) -> Option<Vec<[f64; 3]>> {
    let k = centres.len();
    let mut a: Vec<Vec<f64>> = (0..k)
        .map(|j| (0..k).map(|m| basis(centres[j], centres[m], widths[m])).collect())
        .collect();
    let mut b: Vec<[f64; 3]> = velocity.to_vec();
    for col in 0..k {
        let pivot = (col..k).max_by(|&r, &s| a[r][col].abs().total_cmp(&a[s][col].abs()))?;
        if a[pivot][col].abs() < 1e-12 {
            return None;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        for row in col + 1..k {
            let f = a[row][col] / a[col][col];
            if f != 0.0 {
                let (upper, lower) = a.split_at_mut(row);
                for (x, &y) in lower[0][col..].iter_mut().zip(&upper[col][col..]) {
                    *x -= f * y;
                }
                b[row] = sub(b[row], scale(b[col], f));
            }
        }
    }
    let mut x = vec![[0.0; 3]; k];
    for row in (0..k).rev() {
        let mut r = b[row];
        for m in row + 1..k {
            r = sub(r, scale(x[m], a[row][m]));
        }
        x[row] = scale(r, 1.0 / a[row][row]);
    }
    x.iter().all(|v| v.iter().all(|c| c.is_finite())).then_some(x)
}
