//! The fold m of the theta-phi method and its inverse (thesis eq. 6.35 and
//! 6.57): h3 of the map h, from the rectangle [0, pi] x [0, 2 pi] onto the
//! unit sphere.

use std::f64::consts::PI;

/// The fold m of eq. 6.35.
pub fn fold(u: [f64; 2]) -> [f64; 3] {
    let (st, ct) = u[0].sin_cos();
    let (sp, cp) = u[1].sin_cos();
    [st * cp, st * sp, ct]
}

/// m^-1 of eq. 6.57, with atan2 for both angles (accurate near the poles,
/// where arccos(z) loses half the digits); phi in [0, 2 pi).
pub fn unfold(p: [f64; 3]) -> [f64; 2] {
    let r = p[0].hypot(p[1]);
    let theta = r.atan2(p[2]);
    let mut phi = p[1].atan2(p[0]);
    if phi < 0.0 {
        phi += 2.0 * PI;
        if phi >= 2.0 * PI {
            phi = 0.0;
        }
    }
    [theta, phi]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fold_and_unfold_are_inverse_away_from_the_poles() {
        for &(t, p) in &[(0.3, 0.0), (1.0, 1.0), (3.0, 6.2), (1e-9, 3.0), (PI - 1e-9, 0.5)] {
            let u = unfold(fold([t, p]));
            assert!((u[0] - t).abs() < 1e-15 && (u[1] - p).abs() < 1e-12, "{u:?} vs {t} {p}");
        }
        assert_eq!(unfold([0.0, 0.0, 1.0])[0], 0.0);
        assert_eq!(unfold([0.0, 0.0, -1.0])[0], PI);
    }
}
