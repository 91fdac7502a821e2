//! The few dense vector kernels the iterative solvers share. Each runs on one
//! thread, left to right: the solvers put their parallelism across right-hand
//! sides (and into [`crate::CsrMatrix::mul_vec`]), and a fixed summation order
//! keeps results identical from run to run (DESIGN.md "Deterministic").

/// `x . y`.
pub(crate) fn dot(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum()
}

/// Euclidean norm `|x|`.
pub(crate) fn norm(x: &[f64]) -> f64 {
    dot(x, x).sqrt()
}

/// `r = b - A x` and its norm divided by `scale` (the relative residual when
/// `scale = |b|`). `r` must be `n` long; the caller validated every length.
pub(crate) fn residual_into(
    a: &crate::CsrMatrix,
    b: &[f64],
    x: &[f64],
    r: &mut [f64],
    scale: f64,
) -> f64 {
    if a.mul_vec(x, r).is_err() {
        // Lengths were validated at the boundary; an error here means a caller
        // inside the crate broke that promise. Report "no progress" rather
        // than panic.
        return f64::INFINITY;
    }
    for (ri, bi) in r.iter_mut().zip(b) {
        *ri = bi - *ri;
    }
    norm(r) / scale
}

/// The denominator of the relative residual: `|b|`, or 1 when `b = 0` (then
/// the absolute residual is reported, and `x = 0` meets any tolerance).
pub(crate) fn residual_scale(b: &[f64]) -> f64 {
    let n = norm(b);
    if n > 0.0 {
        n
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::CsrMatrix;

    #[test]
    fn kernels() {
        assert_eq!(dot(&[1.0, 2.0, 3.0], &[4.0, 5.0, 6.0]), 32.0);
        assert_eq!(norm(&[3.0, 4.0]), 5.0);
        assert_eq!(residual_scale(&[0.0, 0.0]), 1.0);
        let a = CsrMatrix::identity(2);
        let mut r = vec![0.0; 2];
        let rel = residual_into(&a, &[3.0, 4.0], &[0.0, 0.0], &mut r, 5.0);
        assert_eq!((rel, r), (1.0, vec![3.0, 4.0]));
    }
}
