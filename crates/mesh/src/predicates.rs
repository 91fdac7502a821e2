//! Exact orientation predicates: the signs on which validity decisions rest.
//!
//! The orientation test of thesis 3.4.1 accepts a spherical triangle when
//! `sign[(v_i x v_j) . v_k] = 1` (eq. 3.9, 3.10). Evaluated naively in f64 this
//! sign is wrong or zero for nearly degenerate triangles, which is exactly where a
//! map is close to folding over. These functions return the sign of the exact
//! real-number determinant of the f64 inputs, using Shewchuk's adaptive
//! predicates as implemented by the `robust` crate: a fast float filter, and exact
//! expansion arithmetic only when the filter cannot decide.
//!
//! Limits (those of Shewchuk's predicates): exactness holds unless intermediate
//! products overflow or underflow, i.e. for coordinates of magnitude roughly
//! between 1e-50 and 1e50 (and exact zeros); points on or near the unit sphere
//! are far inside that range. A non-finite coordinate (NaN or infinity) has no
//! meaningful orientation and gives [`Sign::Zero`], which the validity tests treat
//! as a failing (degenerate) triangle.

use robust::{Coord, Coord3D};

/// The sign of a determinant (thesis eq. 3.10: -1, 0, 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Sign {
    /// Clockwise / inward-facing / below.
    Negative,
    /// Degenerate: collinear or coplanar.
    Zero,
    /// Counter-clockwise / outward-facing / above.
    Positive,
}

impl Sign {
    /// The sign of `x`; NaN maps to [`Sign::Zero`].
    pub fn of(x: f64) -> Sign {
        if x > 0.0 {
            Sign::Positive
        } else if x < 0.0 {
            Sign::Negative
        } else {
            Sign::Zero
        }
    }

    /// The opposite sign (what swapping two arguments of a predicate gives).
    pub fn reversed(self) -> Sign {
        match self {
            Sign::Negative => Sign::Positive,
            Sign::Zero => Sign::Zero,
            Sign::Positive => Sign::Negative,
        }
    }

    /// -1, 0 or 1, as the thesis writes the sign function (3.10).
    pub fn to_i32(self) -> i32 {
        match self {
            Sign::Negative => -1,
            Sign::Zero => 0,
            Sign::Positive => 1,
        }
    }
}

fn finite<const N: usize>(points: &[[f64; N]]) -> bool {
    points.iter().flatten().all(|x| x.is_finite())
}

/// Exact sign of the signed area of triangle `abc` in the plane:
/// [`Sign::Positive`] when `a, b, c` run counter-clockwise (`c` left of the
/// directed line `ab`), [`Sign::Negative`] when clockwise, [`Sign::Zero`] when
/// exactly collinear (or a coordinate is not finite). Used for the 2D Tutte
/// embeddings of thesis ch. 4 and the theta-phi plane of ch. 6.
pub fn orient2d(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> Sign {
    if !finite(&[a, b, c]) {
        return Sign::Zero;
    }
    let p = |q: [f64; 2]| Coord { x: q[0], y: q[1] };
    // robust::orient2d is positive for counter-clockwise: the same convention.
    Sign::of(robust::orient2d(p(a), p(b), p(c)))
}

/// Exact sign of `det[a; b; c] = (a x b) . c` (rows `a, b, c`), thesis eq. 3.9.
/// [`Sign::Positive`] when `a, b, c` appear counter-clockwise seen from the side
/// of their plane away from the origin; for a triangle on a sphere centred at
/// the origin that is "counter-clockwise seen from outside", i.e. correctly
/// oriented. [`Sign::Zero`] when `a, b, c` and the origin are exactly coplanar
/// (or a coordinate is not finite).
pub fn det3_sign(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> Sign {
    if !finite(&[a, b, c]) {
        return Sign::Zero;
    }
    let p = |q: [f64; 3]| Coord3D { x: q[0], y: q[1], z: q[2] };
    // Shewchuk's orient3d(a, b, c, d) is det[a - d; b - d; c - d], positive when d
    // lies on the side of plane abc from which a, b, c look clockwise. With d the
    // origin the subtractions are exact and it is det[a; b; c] itself; the tests
    // pin the convention down on (e_x, e_y, e_z), whose determinant is +1.
    Sign::of(robust::orient3d(p(a), p(b), p(c), p([0.0; 3])))
}

/// Shewchuk's first error bound for a sum of three terms `z (p - q)` with
/// `p`, `q` products of inputs (orient3d's `o3derrboundA`, Shewchuk 1997,
/// "Adaptive Precision Floating-Point Arithmetic and Fast Robust Geometric
/// Predicates", section 4.3), with epsilon = 2^-53.
const DET3_BOUND: f64 = (7.0 + 56.0 * f64::EPSILON / 2.0) * (f64::EPSILON / 2.0);

/// Below this permanent the filter of [`det3_and_sign`] does not decide: its
/// bound is then not above the error of products that underflow.
const DET3_SMALLEST_PERMANENT: f64 = 1e-200;

/// The rounded determinant `(a x b) . c`, bit for bit as
/// `spherify_mesh::vec3::dot(cross(a, b), c)` computes it, and the exact sign
/// of det[a; b; c] ([`det3_sign`]'s answer). The rounded value decides the
/// sign when it lies beyond Shewchuk's error bound on its own permanent (the
/// same sum of three terms `c_i (p_i - q_i)` as orient3d's first stage, whose
/// bound holds for that form); otherwise [`det3_sign`] decides. For callers
/// that need both (the certificate's smallest det and its orientation test):
/// one determinant a face instead of two.
#[inline]
pub fn det3_and_sign(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> (f64, Sign) {
    let (m0, n0) = (a[1] * b[2], a[2] * b[1]);
    let (m1, n1) = (a[2] * b[0], a[0] * b[2]);
    let (m2, n2) = (a[0] * b[1], a[1] * b[0]);
    let det = (m0 - n0) * c[0] + (m1 - n1) * c[1] + (m2 - n2) * c[2];
    let permanent = (m0.abs() + n0.abs()) * c[0].abs()
        + (m1.abs() + n1.abs()) * c[1].abs()
        + (m2.abs() + n2.abs()) * c[2].abs();
    // Not-finite inputs make `permanent` infinite or NaN: no comparison holds.
    let bound = DET3_BOUND * permanent;
    if permanent >= DET3_SMALLEST_PERMANENT && (det > bound || -det > bound) {
        (det, Sign::of(det))
    } else {
        (det, det3_sign(a, b, c))
    }
}

/// Whether `a, b, c` lie exactly on one line in space (including coincident
/// points). The components of `(b - a) x (c - a)` are the signed areas of the
/// projections onto the yz, zx and xy planes, so the points are collinear exactly
/// when all three exact 2D orientations vanish. A non-finite coordinate gives
/// `false`: such points are not on any line.
pub fn collinear3(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> bool {
    if !finite(&[a, b, c]) {
        return false;
    }
    let zero =
        |i: usize, j: usize| orient2d([a[i], a[j]], [b[i], b[j]], [c[i], c[j]]) == Sign::Zero;
    zero(1, 2) && zero(2, 0) && zero(0, 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lcg::Lcg;

    const E: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

    fn naive_orient2d(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> Sign {
        Sign::of((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
    }

    #[test]
    fn det3_and_sign_is_the_rounded_det_and_the_exact_sign() {
        use crate::vec3::{cross, dot};
        let mut rng = Lcg::new(7);
        let mut undecided = 0;
        for k in 0..20_000 {
            let mut p = [[0.0; 3]; 3];
            for q in &mut p {
                *q = [rng.between(-1.0, 1.0), rng.between(-1.0, 1.0), rng.between(-1.0, 1.0)];
            }
            if k % 2 == 1 {
                // Nearly coplanar with the origin: c a combination of a and b
                // plus a rounding-size nudge, where the filter must pass on.
                let (s, t) = (rng.between(-1.0, 1.0), rng.between(-1.0, 1.0));
                let nudge = rng.between(-1e-16, 1e-16);
                p[2] = [0, 1, 2].map(|i| s * p[0][i] + t * p[1][i] + nudge);
            }
            let (det, sign) = det3_and_sign(p[0], p[1], p[2]);
            assert_eq!(det.to_bits(), dot(cross(p[0], p[1]), p[2]).to_bits());
            assert_eq!(sign, det3_sign(p[0], p[1], p[2]));
            undecided += usize::from(k % 2 == 1 && Sign::of(det) != sign);
        }
        // The near-coplanar half has rounded signs that are wrong.
        assert!(undecided > 0);
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert_eq!(det3_and_sign([bad, 0.0, 0.0], E[1], E[2]).1, Sign::Zero);
        }
        assert_eq!(det3_and_sign(E[0], E[1], E[2]), (1.0, Sign::Positive));
        assert_eq!(det3_and_sign(E[1], E[0], E[2]), (-1.0, Sign::Negative));
        let tiny = [E[0].map(|x| x * 1e-120), E[1].map(|x| x * 1e-120), E[2]];
        assert_eq!(det3_and_sign(tiny[0], tiny[1], tiny[2]).1, Sign::Positive);
    }

    fn naive_det3(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> Sign {
        let cross =
            [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
        Sign::of(cross[0] * c[0] + cross[1] * c[1] + cross[2] * c[2])
    }

    fn ulps(x: f64, k: i64) -> f64 {
        f64::from_bits((x.to_bits() as i64 + k) as u64)
    }

    #[test]
    fn simple_orientations() {
        assert_eq!(orient2d([0.0, 0.0], [1.0, 0.0], [0.0, 1.0]), Sign::Positive);
        assert_eq!(orient2d([0.0, 0.0], [0.0, 1.0], [1.0, 0.0]), Sign::Negative);
        assert_eq!(orient2d([0.0, 0.0], [1.0, 1.0], [3.0, 3.0]), Sign::Zero);
        assert_eq!(orient2d([1.0, 1.0], [1.0, 1.0], [1.0, 1.0]), Sign::Zero);
        // The convention: (e_x x e_y) . e_z = +1, and the triangle e_x, e_y, e_z
        // is counter-clockwise seen from outside the unit sphere (from (1,1,1)).
        assert_eq!(det3_sign(E[0], E[1], E[2]), Sign::Positive);
        assert_eq!(det3_sign(E[0], E[2], E[1]), Sign::Negative);
        assert_eq!(det3_sign(E[0], E[1], [1.0, 1.0, 0.0]), Sign::Zero);
        assert_eq!(det3_sign(E[0], E[0], E[2]), Sign::Zero);
        assert_eq!(Sign::of(f64::NAN), Sign::Zero);
        assert_eq!(orient2d([f64::NAN, 0.0], [1.0, 0.0], [0.0, 1.0]), Sign::Zero);
        assert_eq!(det3_sign([f64::INFINITY, 0.0, 0.0], E[1], E[2]), Sign::Zero);
        assert_eq!(Sign::Negative.to_i32() + Sign::Positive.to_i32(), 0);
    }

    #[test]
    fn octahedron_faces_are_positive() {
        // The unit octahedron, faces counter-clockwise seen from outside.
        let v = [E[0], E[1], E[2], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]];
        let faces = [
            [0, 1, 2],
            [1, 3, 2],
            [3, 4, 2],
            [4, 0, 2],
            [1, 0, 5],
            [3, 1, 5],
            [4, 3, 5],
            [0, 4, 5],
        ];
        for f in faces {
            assert_eq!(det3_sign(v[f[0]], v[f[1]], v[f[2]]), Sign::Positive, "{f:?}");
            // Cyclic rotations keep the sign; reversing flips it.
            assert_eq!(det3_sign(v[f[1]], v[f[2]], v[f[0]]), Sign::Positive);
            assert_eq!(det3_sign(v[f[2]], v[f[1]], v[f[0]]), Sign::Negative);
        }
        // A small triangle near the north pole, counter-clockwise seen from above.
        let (s, c) = (1e-9f64, (1.0f64 - 1e-18).sqrt());
        assert_eq!(det3_sign([s, 0.0, c], [0.0, s, c], [-s, -s, c]), Sign::Positive);
    }

    #[test]
    fn orient2d_exact_where_naive_fails() {
        // Kettner et al.'s classroom example: nearly collinear points perturbed
        // by a few ulps. All coordinates are multiples of 2^-53 below 2^5, so
        // scaled by 2^53 they are integers below 2^58 and the determinant is
        // exact in i128: an independent reference.
        let exact = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
            let i = |x: f64| (x * 2f64.powi(53)) as i128;
            let d = (i(b[0]) - i(a[0])) * (i(c[1]) - i(a[1]))
                - (i(b[1]) - i(a[1])) * (i(c[0]) - i(a[0]));
            Sign::of(d as f64)
        };
        let (b, c) = ([12.0, 12.0], [24.0, 24.0]);
        let mut naive_wrong = 0;
        for kx in 0..64 {
            for ky in 0..64 {
                let a = [ulps(0.5, kx), ulps(0.5, ky)];
                let truth = exact(a, b, c);
                assert_eq!(orient2d(a, b, c), truth, "{a:?}");
                assert_eq!(orient2d(b, a, c), truth.reversed());
                assert_eq!(orient2d(b, c, a), truth);
                naive_wrong += usize::from(naive_orient2d(a, b, c) != truth);
            }
        }
        assert!(naive_wrong > 1000, "naive was wrong only {naive_wrong} times");
        // One case spelled out: with a one ulp (d) above the line y = x the
        // determinant is 11.5 (23.5 - d) - (11.5 - d) 23.5 = 12 d > 0.
        let a = [0.5, ulps(0.5, 1)];
        assert_eq!(orient2d(a, b, c), Sign::Positive);
        assert!(collinear3([0.5, 0.5, 0.0], [12.0, 12.0, 0.0], [24.0, 24.0, 0.0]));
        assert!(!collinear3([0.5, a[1], 0.0], [12.0, 12.0, 0.0], [24.0, 24.0, 0.0]));
    }

    #[test]
    fn det3_exact_where_naive_fails() {
        // a, b near-unit vectors on a 2^-30 grid, so c = (a + b) / 2 is exact and
        // det[a; b; c] = 0 exactly. Nudging c_k by one ulp d gives
        // det = d * (a x b)_k by linearity: the true sign is sign((a x b)_k).
        let mut rng = Lcg::new(99);
        let grid = |x: f64| (x * 2f64.powi(30)).round() / 2f64.powi(30);
        let (mut naive_wrong, mut cases) = (0, 0);
        while cases < 2000 {
            let mut value = || rng.between(-1.0, 1.0);
            let p = [value(), value(), value()];
            let q = [p[0] + 1e-3 * value(), p[1] + 1e-3 * value(), p[2]];
            let (np, nq) = (
                p.iter().map(|x| x * x).sum::<f64>().sqrt(),
                q.iter().map(|x| x * x).sum::<f64>().sqrt(),
            );
            if np < 0.1 {
                continue;
            }
            let a = p.map(|x| grid(x / np));
            let b = q.map(|x| grid(x / nq));
            let mid = [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0, (a[2] + b[2]) / 2.0];
            let cross =
                [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
            // The midpoint is exactly on segment ab, hence also coplanar with 0.
            assert_eq!(det3_sign(a, b, mid), Sign::Zero);
            assert!(collinear3(a, b, mid));
            for k in 0..3 {
                // The float cross product is reliable far above its rounding error.
                if cross[k].abs() < 1e-9 || mid[k] == 0.0 {
                    continue;
                }
                let mut c = mid;
                c[k] = ulps(mid[k], 1);
                let delta_sign = Sign::of(c[k] - mid[k]);
                let truth =
                    if delta_sign == Sign::of(cross[k]) { Sign::Positive } else { Sign::Negative };
                assert_eq!(det3_sign(a, b, c), truth);
                assert!(!collinear3(a, b, c));
                assert_eq!(det3_sign(b, a, c), truth.reversed());
                assert_eq!(det3_sign(a, c, b), truth.reversed());
                assert_eq!(det3_sign(c, b, a), truth.reversed());
                assert_eq!(det3_sign(c, a, b), truth);
                naive_wrong += usize::from(naive_det3(a, b, c) != truth);
                cases += 1;
            }
        }
        assert!(naive_wrong > cases / 4, "naive was wrong only {naive_wrong} of {cases} times");
    }

    #[test]
    fn collinear_in_space() {
        assert!(collinear3([1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [-1.0, -2.0, -3.0]));
        assert!(collinear3([1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [5.0, -2.0, 0.5]));
        assert!(!collinear3(E[0], E[1], E[2]));
        // Collinear in the xy projection only.
        assert!(!collinear3([0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [2.0, 2.0, 1.0]));
        // One ulp off the line through the origin along (1, 1, 1) / 10.
        let t = [0.1, 0.1, 0.1];
        assert!(collinear3([0.0; 3], t, [0.3, 0.3, 0.3]));
        assert!(!collinear3([0.0; 3], t, [0.3, 0.3, ulps(0.3, 1)]));
        assert!(!collinear3([f64::NAN; 3], [f64::NAN; 3], [f64::NAN; 3]));
    }
}
