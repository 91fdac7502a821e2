//! Validity of a GC-drawing on the sphere (thesis 3.4).
//!
//! The orientation test (3.9) evaluates sign det[v_i, v_j, v_k] for every face
//! with an exact predicate: positive means counter-clockwise seen from outside.
//! The sign does not change when a point is scaled by a positive factor, so the
//! test speaks about the normalised points even when the input is a little off
//! the unit sphere. The area test (3.11) sums signed spherical triangle areas,
//! E = 2 atan2(det[a, b, c], 1 + a.b + b.c + c.a) (Van Oosterom and Strackee
//! 1983), which stays accurate for tiny and for large triangles. When every face
//! is positively oriented the drawing covers the sphere a whole number k of
//! times and the sum is 4 pi k; k = 1 together with the orientation test proves
//! a GC-embedding. The sum only has to be accurate to within 2 pi to decide k.

use rayon::prelude::*;
use spherify_mesh::predicates::{det3_and_sign, Sign};
use spherify_mesh::vec3::{cross, dot, norm, scale};

/// What [`check_sphere`] finds.
#[derive(Debug, Clone, PartialEq)]
pub struct SphereReport {
    /// Every face positively oriented, the areas sum to 4 pi (covering degree 1),
    /// and every point finite and away from the origin.
    pub valid: bool,
    pub n_positive: usize,
    pub n_negative: usize,
    pub n_zero: usize,
    /// Faces with det <= 0 (upside down or collapsed), in increasing order.
    pub flipped_faces: Vec<u32>,
    /// Sum of signed spherical triangle areas of the normalised points.
    pub area_sum: f64,
    /// |area_sum - 4 pi|.
    pub area_error: f64,
    /// How many times the drawing covers the sphere: round(area_sum / 4 pi).
    pub covering_degree: i64,
    /// Largest | |p| - 1 | over the points.
    pub max_norm_error: f64,
    /// Points that are NaN, infinite or at the origin (no direction).
    pub bad_points: Vec<u32>,
    /// Smallest det[a, b, c] over the faces, in floating point (its sign is
    /// decided exactly above): how close the map is to a flip.
    pub min_det: f64,
    /// Smallest signed spherical triangle area over the mean, 4 pi / F: how far
    /// the map is from the double-precision floor (about 1e-16 at unit scale).
    pub min_area_ratio: f64,
}

/// Runs the orientation and area tests. `faces` index into `points`, which must
/// have one entry per vertex (the caller checks lengths). O(F), in parallel.
pub fn check_sphere(faces: &[[u32; 3]], points: &[[f64; 3]]) -> SphereReport {
    let bad_points: Vec<u32> = points
        .iter()
        .enumerate()
        .filter(|(_, p)| !p.iter().all(|x| x.is_finite()) || p == &&[0.0; 3])
        .map(|(v, _)| v as u32)
        .collect();
    // One norm a point for its distance from the sphere and its direction.
    let (unit, norm_errors): (Vec<[f64; 3]>, Vec<f64>) = points
        .par_iter()
        .map(|&p| {
            let length = norm(p);
            (scale(p, 1.0 / length), (length - 1.0).abs())
        })
        .unzip();
    let max_norm_error =
        norm_errors.iter().fold(0.0, |a: f64, &b: &f64| if b.is_nan() || b > a { b } else { a });
    // The rounded det of the points (the smallest is reported) decides the
    // exact sign too when it lies beyond its error bound (det3_and_sign).
    let (signs, (areas, dets)): (Vec<Sign>, (Vec<f64>, Vec<f64>)) = faces
        .par_iter()
        .map(|&[a, b, c]| {
            let (pa, pb, pc) = (points[a as usize], points[b as usize], points[c as usize]);
            let (ua, ub, uc) = (unit[a as usize], unit[b as usize], unit[c as usize]);
            let (det, sign) = det3_and_sign(pa, pb, pc);
            (sign, (area_with_sign(ua, ub, uc, sign), det))
        })
        .unzip();
    let smallest = |values: &[f64]| values.iter().copied().fold(f64::INFINITY, f64::min);
    let mean_area = 4.0 * std::f64::consts::PI / faces.len().max(1) as f64;
    let mut report = SphereReport {
        valid: false,
        n_positive: 0,
        n_negative: 0,
        n_zero: 0,
        flipped_faces: Vec::new(),
        area_sum: areas.iter().sum(),
        area_error: 0.0,
        covering_degree: 0,
        max_norm_error,
        bad_points,
        min_det: smallest(&dets),
        min_area_ratio: smallest(&areas) / mean_area,
    };
    for (f, sign) in signs.iter().enumerate() {
        match sign {
            Sign::Positive => report.n_positive += 1,
            Sign::Negative => report.n_negative += 1,
            Sign::Zero => report.n_zero += 1,
        }
        if *sign != Sign::Positive {
            report.flipped_faces.push(f as u32);
        }
    }
    let full = 4.0 * std::f64::consts::PI;
    report.area_error = (report.area_sum - full).abs();
    report.covering_degree =
        if report.area_sum.is_finite() { (report.area_sum / full).round() as i64 } else { 0 };
    report.valid = report.flipped_faces.is_empty()
        && report.bad_points.is_empty()
        && report.covering_degree == 1;
    report
}

/// [`signed_area`] with the sign of the determinant that the exact test
/// found. On a face at the double-precision floor the rounded determinant can
/// have the other sign, and then the rounded area is off by 4 pi: a tiny
/// positive triangle whose corners lie almost on one great circle has area
/// near 0 or near 2 pi, never near -2 pi. The area sum, and so the covering
/// degree, must speak of the same triangles as the orientation test.
fn area_with_sign(a: [f64; 3], b: [f64; 3], c: [f64; 3], sign: Sign) -> f64 {
    let det = dot(cross(a, b), c);
    let det = match sign {
        Sign::Positive if det <= 0.0 => 0.0,
        Sign::Negative if det >= 0.0 => -0.0,
        _ => det,
    };
    2.0 * det.atan2(1.0 + dot(a, b) + dot(b, c) + dot(c, a))
}

/// Signed area of the spherical triangle of unit vectors a, b, c: positive when
/// counter-clockwise seen from outside.
pub fn signed_area(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let det = dot(cross(a, b), c);
    2.0 * det.atan2(1.0 + dot(a, b) + dot(b, c) + dot(c, a))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn octahedron() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let (p, f) = (
            spherify_mesh::solids::OCTAHEDRON_POSITIONS.to_vec(),
            spherify_mesh::solids::OCTAHEDRON_FACES.to_vec(),
        );
        (p, f)
    }

    #[test]
    fn octahedron_is_a_valid_embedding() {
        let (p, f) = octahedron();
        let r = check_sphere(&f, &p);
        assert!(r.valid, "{r:?}");
        assert_eq!((r.n_positive, r.n_negative, r.n_zero), (8, 0, 0));
        assert!(r.area_error < 1e-12);
        // Each octant has area 4 pi / 8.
        assert!((signed_area(p[0], p[2], p[4]) - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
    }

    #[test]
    fn areas_take_the_exact_sign_so_a_double_covering_at_the_floor_is_caught() {
        // A Gotsman map of a 7-vertex mesh (issue 13's point-map fuzzer, seed
        // 20730) whose points come in near-coincident pairs: every face is
        // positive in exact arithmetic, but face 8's rounded determinant is
        // negative, and its rounded area read -2 pi where the exact sign says
        // +2 pi. The sum then said "covers once" of a double covering.
        let points: [[f64; 3]; 7] = [
            [
                f64::from_bits(0xbfc5caa255608fa7),
                f64::from_bits(0x3f47371b7d2ce63e),
                f64::from_bits(0xbfef88683ddb99e0),
            ],
            [
                f64::from_bits(0x3fb117910af10634),
                f64::from_bits(0x3feb4842511bbcba),
                f64::from_bits(0xbfe09627e7ff433f),
            ],
            [
                f64::from_bits(0xbfce566adad96041),
                f64::from_bits(0xbfeb42748a3da8ce),
                f64::from_bits(0xbfdde480abb6f8e0),
            ],
            [
                f64::from_bits(0x3fc5caa25561ed7e),
                f64::from_bits(0xbf47371b7581fc5f),
                f64::from_bits(0x3fef88683ddb8b1e),
            ],
            [
                f64::from_bits(0x3fce566adad8b191),
                f64::from_bits(0x3feb42748a3f10de),
                f64::from_bits(0x3fdde480abb203c9),
            ],
            [
                f64::from_bits(0x3fc5caa25560ef15),
                f64::from_bits(0xbf47371b7b157540),
                f64::from_bits(0x3fef88683ddb95d9),
            ],
            [
                f64::from_bits(0xbfce566adad820d9),
                f64::from_bits(0xbfeb42748a403b35),
                f64::from_bits(0xbfdde480abade846),
            ],
        ];
        let faces: [[u32; 3]; 10] = [
            [6, 4, 3],
            [6, 0, 4],
            [0, 3, 1],
            [2, 3, 4],
            [2, 4, 0],
            [3, 2, 5],
            [2, 1, 5],
            [5, 1, 3],
            [3, 0, 6],
            [2, 0, 1],
        ];
        let r = check_sphere(&faces, &points);
        assert_eq!((r.n_positive, r.n_negative, r.n_zero), (10, 0, 0));
        assert_eq!(r.covering_degree, 2, "{r:?}");
        assert!(!r.valid);
        // Every positive face's area is in [0, 2 pi]: the margin is not negative.
        assert!(r.min_area_ratio >= 0.0, "{r:?}");
    }

    #[test]
    fn swapped_vertices_and_inward_faces_are_caught() {
        let (mut p, f) = octahedron();
        p.swap(0, 2);
        let r = check_sphere(&f, &p);
        assert!(!r.valid && r.n_negative > 0);
        let (p, f) = octahedron();
        let inward: Vec<[u32; 3]> = f.iter().map(|&[a, b, c]| [a, c, b]).collect();
        let r = check_sphere(&inward, &p);
        assert_eq!((r.n_negative, r.covering_degree), (8, -1));
        assert!(!r.valid);
    }

    #[test]
    fn scaling_points_keeps_the_verdict_and_collapse_is_zero() {
        let (p, f) = octahedron();
        let scaled: Vec<[f64; 3]> =
            p.iter().enumerate().map(|(i, &q)| scale(q, 1.0 + i as f64)).collect();
        let r = check_sphere(&f, &scaled);
        assert!(r.valid && r.max_norm_error > 1.0);
        let mut collapsed = p.clone();
        collapsed[4] = collapsed[0];
        let r = check_sphere(&f, &collapsed);
        assert!(!r.valid && r.n_zero > 0);
        let mut nan = p;
        nan[3][1] = f64::NAN;
        let r = check_sphere(&f, &nan);
        assert!(!r.valid && r.bad_points == vec![3]);
    }
}
