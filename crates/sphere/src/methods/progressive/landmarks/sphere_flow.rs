//! A smooth flow of the sphere that carries the landmarks towards their
//! targets and every other vertex along with them, in small increments.
//!
//! Each increment is a tangent velocity field interpolating the landmarks'
//! displacements (a fraction of the log map towards each target) with
//! Gaussian radial basis functions, one per landmark, whose width is half
//! the distance to the nearest other landmark (so that landmarks that move
//! differently do not drag each other) and at most one radian, plus an
//! affine part `b + M x` from eight landmarks on (see [`interpolate`]), so
//! that what lies between landmarks moves with their common motion. Every
//! landmark moves the same fraction of its way per increment, so that they
//! arrive together. Every vertex moves to `normalize(x + v(x))` at once,
//! and the increment is kept only if the whole map passes the exact test of
//! thesis 3.4; otherwise the corners of the faces it turns over stay behind
//! for that increment (a few rounds), then the step is halved, and after a
//! few halvings the flow stops and leaves the rest to the drag. A field
//! whose step is small against its widths is a diffeomorphism, so the flow
//! keeps triangles in proportion where the landmarks agree, which the
//! one-vertex drag cannot.

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
/// Rounds of holding back the corners of faces an increment turns over
/// before the increment is halved.
const LOCAL_RESETS: usize = 4;
/// Largest angle a landmark moves in one increment (radians), and largest
/// displacement against its basis function's width.
const STEP: f64 = 0.1;
const STEP_PER_WIDTH: f64 = 0.4;
/// Basis function widths (chord lengths) are clamped to this range.
const WIDTH: (f64, f64) = (0.02, 1.0);
/// Below this angle to every target the flow has nothing left to do.
const DONE: f64 = 1e-6;
/// Landmarks from which the field has an affine part (see [`interpolate`]):
/// four in general position determine it, a few more keep it from
/// following one landmark's move alone.
const AFFINE_FROM: usize = 8;
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
        // Every landmark moves the same fraction of its way left, the
        // largest that keeps each landmark's move within [`STEP`] and a
        // fraction of its basis function's width: the landmarks arrive
        // together, and the one farthest behind its limit sets the pace (so
        // the flow does not converge geometrically: 64 increments of a
        // fixed fraction left 10 of 45 degrees on a 2000-vertex `tentacles`
        // with 32 landmarks). A fixed angle per landmark, as before, let
        // near landmarks arrive early and others late, which shears what is
        // between them: a face of three landmarks 40 degrees long on a
        // 2000-vertex `tentacles` (64 landmarks, a swirl) turned upside down
        // on the way though it is positive at the start and at the targets,
        // and no increment could pass it. `gear` halves the whole field
        // after a refused increment and recovers after a kept one.
        let fraction = logs
            .iter()
            .zip(&widths)
            .map(|(d, w)| {
                let len = norm(*d);
                if len > 0.0 {
                    STEP.min(STEP_PER_WIDTH * w) / len
                } else {
                    f64::INFINITY
                }
            })
            .fold(1.0f64, f64::min);
        let mut accepted = false;
        for _ in 0..=HALVINGS {
            let velocity: Vec<[f64; 3]> = logs.iter().map(|&d| scale(d, fraction * gear)).collect();
            let Some(coefficients) = interpolate(&centres, &widths, &velocity) else {
                return Ok(kept);
            };
            let mut moved: Vec<[f64; 3]> = points
                .par_iter()
                .map(|&x| {
                    let v = field(x, &centres, &widths, &coefficients);
                    // The tangent part: the radial part only rescales.
                    let v = sub(v, scale(x, dot(v, x)));
                    normalize(add(x, v)).unwrap_or(x)
                })
                .collect();
            let mut rep = check_sphere(faces, &moved);
            // A few faces the field turns over (faces far longer than the
            // widths, whose corners the field moves apart): their corners
            // stay where they are for this increment, and so do those of the
            // faces that this turns over, a few times; what passes the exact test
            // is kept. A landmark held back this way is behind the others
            // and sets the pace of the next increments.
            for _ in 0..LOCAL_RESETS {
                if rep.valid || rep.flipped_faces.is_empty() {
                    break;
                }
                for &f in &rep.flipped_faces {
                    for v in faces[f as usize] {
                        moved[v as usize] = points[v as usize];
                    }
                }
                rep = check_sphere(faces, &moved);
            }
            if rep.valid {
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
    // The affine part, when the system has one: b + M x.
    if let [b, m0, m1, m2] = coefficients[centres.len()..] {
        v = add(v, add(b, add(scale(m0, x[0]), add(scale(m1, x[1]), scale(m2, x[2])))));
    }
    v
}

/// Coefficients `a_k`, and with [`AFFINE_FROM`] landmarks or more an affine
/// part `b + M x`, with `sum_k a_k phi_k(c_j) + b + M c_j = v_j` for every
/// landmark `j` and `sum_k a_k = 0`, `sum_k a_k c_k = 0`: Gaussian
/// interpolation with linear polynomial precision (the augmented system of
/// Micchelli 1986; Wendland, "Scattered Data Approximation", 2005, ch. 8,
/// there with one width; here each centre has its own, and a singular
/// system is reported, not ruled out).
/// Gaussian elimination with partial pivoting on the (k + 4) x (k + 4)
/// system, three right-hand sides. `None` when the system is singular.
///
/// Without the affine part the field falls to zero between landmarks a
/// width apart, whatever they agree on: where the map's triangles are
/// longer than the widths (the body of a 2000-vertex `tentacles` is a few
/// faces 30 to 60 degrees long, its landmarks' widths are 7 to 14 degrees)
/// a face with landmarks at two corners and a vertex in that gap is
/// sheared flat, and the flow stopped with 30 of 45 degrees left. The
/// affine part moves that gap with the landmarks' common motion.
fn interpolate(
    centres: &[[f64; 3]],
    widths: &[f64],
    velocity: &[[f64; 3]],
) -> Option<Vec<[f64; 3]>> {
    let n = centres.len();
    let k = if n >= AFFINE_FROM { n + 4 } else { n };
    let mut a: Vec<Vec<f64>> = vec![vec![0.0; k]; k];
    for j in 0..n {
        for m in 0..n {
            a[j][m] = basis(centres[j], centres[m], widths[m]);
        }
        if k > n {
            let c = centres[j];
            for (i, value) in [1.0, c[0], c[1], c[2]].into_iter().enumerate() {
                a[j][n + i] = value;
                a[n + i][j] = value;
            }
        }
    }
    let mut b: Vec<[f64; 3]> = velocity.to_vec();
    b.resize(k, [0.0; 3]);
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
