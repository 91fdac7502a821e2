//! The few 3-vector operations every crate needs, in one place.

#[inline]
pub fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[inline]
pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
pub fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

#[inline]
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

#[inline]
pub fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// The determinant of the 3x3 matrix with rows a, b, c: a . (b x c).
pub fn det3(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    dot(a, cross(b, c))
}

/// Solves `m x = b` for a 3x3 matrix given by its rows, by Cramer's rule:
/// `x_k = det(m with column k replaced by b) / det(m)`. No check: a singular
/// `m` gives infinities or NaN, so callers test [`det3`] against their own
/// scale first.
pub fn solve3(m: [[f64; 3]; 3], b: [f64; 3]) -> [f64; 3] {
    let d = det3(m[0], m[1], m[2]);
    let mut x = [0.0; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        let mut mk = m;
        (0..3).for_each(|r| mk[r][k] = b[r]);
        *xk = det3(mk[0], mk[1], mk[2]) / d;
    }
    x
}

/// Area of the triangle `a, b, c`.
#[inline]
pub fn triangle_area(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    0.5 * norm(cross(sub(b, a), sub(c, a)))
}

/// The bounding box (lowest and highest coordinates) of the points whose
/// coordinates are all finite; infinite bounds, low above high, when none is.
pub fn finite_bounds(points: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points.iter().filter(|p| p.iter().all(|x| x.is_finite())) {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn right_handed_basis() {
        assert_eq!(cross([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]);
        assert_eq!(dot([1.0, 2.0, 3.0], [4.0, 5.0, 6.0]), 32.0);
        assert_eq!(norm([3.0, 4.0, 0.0]), 5.0);
        assert_eq!(det3([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]), 1.0);
        assert_eq!(det3([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 2.0]), -2.0);
        assert_eq!(
            add(sub([1.0, 1.0, 1.0], [1.0, 2.0, 3.0]), scale([0.0, 1.0, 2.0], 2.0)),
            [0.0, 1.0, 2.0]
        );
        let x = solve3([[2.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 4.0]], [3.0, 5.0, 5.0]);
        assert!(x.iter().all(|&v| (v - 1.0).abs() < 1e-15), "{x:?}");
        assert_eq!(
            triangle_area([1.0, 0.0, 0.0], [3.0, 0.0, 0.0], [1.0, 3.0, 5.0]),
            0.5 * 2.0 * 34f64.sqrt()
        );
    }

    #[test]
    fn the_bounds_leave_out_points_that_are_not_finite() {
        let points =
            [[1.0, -2.0, 3.0], [f64::NAN, 9.0, 9.0], [-1.0, 4.0, f64::INFINITY], [0.5, 2.0, -3.0]];
        assert_eq!(finite_bounds(&points), ([0.5, -2.0, -3.0], [1.0, 2.0, 3.0]));
        let (lo, hi) = finite_bounds(&[[f64::NAN; 3]]);
        assert!(lo.iter().zip(&hi).all(|(l, h)| l > h));
    }
}
