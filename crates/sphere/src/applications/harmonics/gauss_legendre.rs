//! Gauss-Legendre quadrature on [-1, 1]: the nodes in cos(theta) of the
//! spherical-harmonic transform (thesis 8.3). `n` nodes integrate every
//! polynomial of degree below `2n` exactly, so `lmax + 1` nodes integrate the
//! product of two harmonics of degree at most `lmax` exactly.
//!
//! Each node is the root of the Legendre polynomial `P_n` found by Newton's
//! method from Tricomi's first-order estimate `cos(pi (i + 3/4) / (n + 1/2))`,
//! `P_n` and `P_n'` from the three-term recurrence; the weight is
//! `2 / ((1 - x^2) P_n'(x)^2)` (Abramowitz and Stegun 25.4.29). Only the
//! nodes in (0, 1] are computed; the rest are their mirror images, so the rule
//! is exactly symmetric.

/// `(P_n(x), P_n'(x))` by the three-term recurrence.
fn legendre_and_derivative(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    for k in 2..=n {
        let k = k as f64;
        let p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
    }
    if n == 0 {
        return (1.0, 0.0);
    }
    // (1 - x^2) P_n' = n (P_{n-1} - x P_n); nodes are never at +-1.
    (p1, n as f64 * (p0 - x * p1) / (1.0 - x * x))
}

/// The `n >= 1` nodes in decreasing order (from near 1 to near -1) and their
/// weights, which sum to 2. O(n^2).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    let nf = n as f64;
    for i in 0..n.div_ceil(2) {
        let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
        if 2 * i + 1 == n {
            z = 0.0; // the middle node of an odd rule is exactly 0
        }
        for _ in 0..100 {
            let (p, d) = legendre_and_derivative(n, z);
            let step = p / d;
            z -= step;
            if step.abs() <= 1e-16 * z.abs().max(1.0) {
                break;
            }
        }
        // The derivative at the converged node, for the weight.
        let d = legendre_and_derivative(n, z).1;
        let weight = 2.0 / ((1.0 - z * z) * d * d);
        x[i] = z;
        w[i] = weight;
        x[n - 1 - i] = -z;
        w[n - 1 - i] = weight;
    }
    (x, w)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrates_polynomials_below_degree_2n_exactly() {
        for n in [1, 2, 3, 8, 51, 200] {
            let (x, w) = gauss_legendre(n);
            assert!(x.windows(2).all(|p| p[0] > p[1]), "n {n}: nodes not decreasing");
            for k in 0..2 * n {
                let got: f64 = x.iter().zip(&w).map(|(&x, &w)| w * x.powi(k as i32)).sum();
                let want = if k % 2 == 1 { 0.0 } else { 2.0 / (k as f64 + 1.0) };
                assert!((got - want).abs() < 1e-13, "n {n}, x^{k}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn the_rule_is_symmetric_and_the_nodes_are_roots() {
        let (x, w) = gauss_legendre(101);
        assert_eq!(x[50], 0.0);
        for i in 0..101 {
            assert_eq!(x[i], -x[100 - i]);
            assert_eq!(w[i], w[100 - i]);
            // A root to the last bit or two: the next Newton step is below 1 ulp of 1.
            let (p, d) = legendre_and_derivative(101, x[i]);
            assert!((p / d).abs() < 3e-16, "node {i}: step {}", p / d);
        }
    }
}
