//! Möbius centring of a sphere map: the Möbius transformation of the sphere
//! that moves the weighted centre of mass of the points to the origin.
//!
//! A conformal map of a closed genus-0 surface onto the sphere is unique only
//! up to the Möbius group, and most members of that family squeeze nearly all
//! of the surface into a small cap. Centring picks the member whose surface
//! area is balanced around the sphere (Baden, Crane and Kazhdan 2018, "Möbius
//! registration", Computer Graphics Forum 37(5); the same normalisation as
//! Gu, Wang, Chan, Thompson and Yau 2004): iterate "take the area-weighted
//! centroid `c` of the points, apply the hyperbolic translation of the ball
//! that sends `c` to the origin". Each step is conformal, so it changes no
//! angle of a conformal map, only where the area goes.
//!
//! The ball automorphism that sends `c` (|c| < 1) to the origin is
//!
//! ```text
//! phi_c(x) = ((1 - |c|^2)(x - c) - |x - c|^2 c) / (1 - 2 c.x + |c|^2 |x|^2),
//! ```
//!
//! and on the unit sphere its denominator is |x - c|^2 (Ahlfors 1981,
//! "Möbius transformations in several dimensions", ch. 2).

use rayon::prelude::*;
use spherify_mesh::vec3::{add, dot, norm, scale, sub};

/// Centring stops once the centroid is this close to the origin.
pub const CENTRED: f64 = 1e-10;
/// Most centring steps. From a map that was scaled sensibly in the plane
/// the centroid falls by orders of magnitude per step (measured on the
/// corpus: 4 to 8 steps to 1e-10).
pub const MAX_STEPS: usize = 50;

/// How [`centre`] ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Centred {
    pub steps: usize,
    /// |centroid| after the last step.
    pub offset: f64,
}

/// The centroid of `points` weighted by `weights` (one per point; their sum
/// must be positive), summed in a fixed order whatever the thread count.
pub fn centroid(points: &[[f64; 3]], weights: &[f64]) -> [f64; 3] {
    const CHUNK: usize = 4096;
    let partial: Vec<([f64; 3], f64)> = points
        .par_chunks(CHUNK)
        .zip(weights.par_chunks(CHUNK))
        .map(|(p, w)| {
            let mut s = ([0.0; 3], 0.0);
            for (p, &w) in p.iter().zip(w) {
                s.0 = add(s.0, scale(*p, w));
                s.1 += w;
            }
            s
        })
        .collect();
    let (sum, total) = partial
        .iter()
        .fold(([0.0; 3], 0.0), |(a, t), (p, w)| ([a[0] + p[0], a[1] + p[1], a[2] + p[2]], t + w));
    scale(sum, 1.0 / total)
}

/// The image of the unit vector `x` under the ball automorphism that sends
/// `c` to the origin, normalised (the formula keeps |x| = 1 up to rounding).
pub fn translate(x: [f64; 3], c: [f64; 3]) -> [f64; 3] {
    let d = sub(x, c);
    let d2 = dot(d, d);
    let c2 = dot(c, c);
    let y = sub(scale(d, 1.0 - c2), scale(c, d2));
    scale(y, 1.0 / norm(y))
}

/// Moves the points of a sphere map (unit vectors) by Möbius transformations
/// until their centroid weighted by `weights` is within [`CENTRED`] of the
/// origin, or [`MAX_STEPS`] steps. Deterministic.
pub fn centre(points: &mut [[f64; 3]], weights: &[f64]) -> Centred {
    let mut steps = 0;
    loop {
        let c = centroid(points, weights);
        let offset = norm(c);
        // An offset of 1 or more (all weight on one point) has no translation.
        if offset < CENTRED || steps == MAX_STEPS || offset.is_nan() || offset >= 1.0 {
            return Centred { steps, offset };
        }
        points.par_iter_mut().for_each(|p| *p = translate(*p, c));
        steps += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::solids::icosphere;

    #[test]
    fn along_the_axis_the_translation_is_a_dilation_of_the_stereographic_plane() {
        // For c = (0, 0, s), phi_c fixes both poles and multiplies
        // tan(theta / 2) (theta from the north pole) by (1 + s) / (1 - s):
        // at the equator the formula gives ((1 - s^2), 0, -2 s) / (1 + s^2).
        let s = 0.6;
        let lambda = (1.0 + s) / (1.0 - s);
        for (theta, phi) in [(0.3f64, 0.0f64), (1.0, 2.0), (2.0, -1.0), (2.9, 4.0)] {
            let x = [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()];
            let y = translate(x, [0.0, 0.0, s]);
            assert!((norm(y) - 1.0).abs() < 1e-15);
            let theta_y = y[2].clamp(-1.0, 1.0).acos();
            let expected = lambda * (0.5 * theta).tan();
            assert!(((0.5 * theta_y).tan() - expected).abs() < 1e-12 * expected, "{theta}");
            // The azimuth is kept.
            assert!((y[1].atan2(y[0]) - x[1].atan2(x[0])).abs() < 1e-12);
        }
        for pole in [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]] {
            let y = translate(pole, [0.0, 0.0, s]);
            assert!(norm(sub(y, pole)) < 1e-15);
        }
    }

    #[test]
    fn centring_a_squeezed_sphere_brings_its_centroid_to_the_origin() {
        let mesh = icosphere(3);
        let mut points: Vec<[f64; 3]> =
            mesh.positions().iter().map(|&p| scale(p, 1.0 / norm(p))).collect();
        let weights = vec![1.0; points.len()];
        // Squeeze most points towards the north pole.
        for p in points.iter_mut() {
            *p = translate(*p, [0.0, 0.0, -0.9]);
        }
        let before = norm(centroid(&points, &weights));
        assert!(before > 0.5, "{before}");
        let end = centre(&mut points, &weights);
        assert!(end.offset < CENTRED, "{end:?}");
        assert!(end.steps <= 30, "{end:?}");
        assert!(norm(centroid(&points, &weights)) < CENTRED);
        assert!(points.iter().all(|p| (norm(*p) - 1.0).abs() < 1e-14));
    }
}
