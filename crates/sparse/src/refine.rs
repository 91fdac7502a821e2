//! Iterative refinement with residuals in double-double arithmetic.
//!
//! A direct solve in double precision leaves an error of about cond(A) * eps
//! in the solution. Where an embedding's triangles are thinner than that
//! error (the long limbs and spikes of Tutte-type maps), the rounding can
//! flip them. Refinement computes r = b - A x with every product and sum
//! carried exactly in two doubles (Dekker's TwoProduct with Veltkamp's split,
//! and Knuth's TwoSum), rounds r once, solves A d = r with the existing factor
//! and updates x += d. Each step shrinks the error by about cond(A) * eps until
//! x is the double nearest the exact solution, give or take an ulp: the best a
//! double can hold (Wilkinson 1963; Higham, "Accuracy and Stability", ch. 12).

use crate::direct::Factorization;
use crate::error::SparseError;
use crate::CsrMatrix;
use rayon::prelude::*;

/// Sum s = a + b as an unevaluated pair (hi, lo) with hi + lo exact (Knuth).
#[inline]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// Veltkamp's split of `a` into two halves of 26 significant bits each, whose
/// products with another half are exact.
#[inline]
fn split(a: f64) -> (f64, f64) {
    const FACTOR: f64 = 134_217_729.0; // 2^27 + 1
    let c = FACTOR * a;
    let hi = c - (c - a);
    (hi, a - hi)
}

/// Product p = a * b and its rounding error e, with p + e = a * b exactly
/// (Dekker's TwoProduct). Written without `f64::mul_add`: unless the crate is
/// built for a CPU with FMA, `mul_add` is an out-of-line software routine,
/// which made this residual slower than the factorisation it refines. The
/// split is exact barring overflow (|a|, |b| above 2^995) or underflow of the
/// error term, neither of which a Tutte system's entries come near; and a
/// slightly inexact residual would only slow refinement, never decide
/// validity (the exact predicates do that).
#[inline]
fn two_product(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    let (ah, al) = split(a);
    let (bh, bl) = split(b);
    (p, ((ah * bh - p) + ah * bl + al * bh) + al * bl)
}

/// b - A x for one row, in double-double, rounded to double at the end.
fn residual_row(a: &CsrMatrix, i: usize, b: f64, x: &[f64]) -> f64 {
    let (cols, vals) = a.row(i);
    let (mut hi, mut lo) = (b, 0.0);
    for (&j, &v) in cols.iter().zip(vals) {
        let (p, e) = two_product(v, x[j as usize]);
        let (s, t) = two_sum(hi, -p);
        hi = s;
        lo += t - e;
    }
    hi + lo
}

/// The residual b - A x with each row computed in double-double. O(nnz), parallel.
pub fn residual_double_double(
    a: &CsrMatrix,
    b: &[f64],
    x: &[f64],
) -> Result<Vec<f64>, SparseError> {
    if b.len() != a.n_rows() || x.len() != a.n_cols() {
        return Err(SparseError::LengthMismatch {
            what: "refinement vectors",
            got: b.len().min(x.len()),
            expected: a.n_rows(),
        });
    }
    Ok((0..a.n_rows()).into_par_iter().map(|i| residual_row(a, i, b[i], x)).collect())
}

/// One refinement step for every right-hand side: x += A^{-1} (b - A x), the
/// residual taken in double-double. Returns how many entries of `x` changed.
///
/// Zero means `x` is a fixed point of the step: the next step would compute
/// the same residual and the same correction and change nothing again, so a
/// caller that stops there ends on the same bits as one that goes on. (The
/// size of the correction cannot tell this: at the correctly rounded solution
/// it stays around half an ulp, which adding to `x` rounds away.)
pub fn refine_step(
    a: &CsrMatrix,
    factor: &Factorization,
    rhs: &[Vec<f64>],
    x: &mut [Vec<f64>],
) -> Result<usize, SparseError> {
    let mut corrections = rhs
        .iter()
        .zip(x.iter())
        .map(|(b, xi)| residual_double_double(a, b, xi))
        .collect::<Result<Vec<_>, _>>()?;
    // The residuals become the corrections where they are (no copy).
    factor.solve_in_place(a, &mut corrections)?;
    let mut changed = 0;
    for (xi, d) in x.iter_mut().zip(&corrections) {
        for (v, dv) in xi.iter_mut().zip(d) {
            let next = *v + dv;
            changed += usize::from(next.to_bits() != v.to_bits());
            *v = next;
        }
    }
    Ok(changed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_product_error_is_exact() {
        // (1 + 2^-30)^2 = 1 + 2^-29 + 2^-60: the last term is below double
        // precision next to 1 and must come back as the error.
        let a = 1.0 + 2f64.powi(-30);
        let (p, e) = two_product(a, a);
        assert_eq!(p, 1.0 + 2f64.powi(-29));
        assert_eq!(e, 2f64.powi(-60));
        for (a, b) in [(0.1, 3.7), (-1e10, 7.3e-5), (std::f64::consts::PI, -std::f64::consts::E)] {
            let (p, e) = two_product(a, b);
            assert_eq!(p, a * b);
            assert_eq!(e, a.mul_add(b, -p), "{a} * {b}");
        }
    }

    #[test]
    fn double_double_residual_sees_what_double_cannot() {
        // Row [1, 1] with x = [1e16, 1]: in double, 1e16 + 1 rounds to 1e16, so
        // b - A x for b = 1e16 + 2 (= 1e16 + 2 exactly) is 1 exactly.
        let a = CsrMatrix::from_triplets(1, 2, &[0, 0], &[0, 1], &[1.0, 1.0]).unwrap();
        let r = residual_double_double(&a, &[1e16 + 2.0], &[1e16, 1.0]).unwrap();
        assert_eq!(r, vec![1.0]);
    }

    #[test]
    fn refinement_reaches_the_nearest_doubles_on_an_ill_conditioned_system() {
        // A 1D Laplacian chain with a tiny coupling at one end: badly conditioned.
        let n = 200;
        let (mut rows, mut cols, mut vals) = (vec![], vec![], vec![]);
        for i in 0..n {
            let w_right = if i + 1 == n { 1e-9 } else { 1.0 };
            rows.push(i as u32);
            cols.push(i as u32);
            vals.push(1.0 + w_right);
            if i > 0 {
                rows.push(i as u32);
                cols.push(i as u32 - 1);
                vals.push(-1.0);
            }
            if i + 1 < n {
                rows.push(i as u32);
                cols.push(i as u32 + 1);
                vals.push(-1.0);
            }
        }
        let a = CsrMatrix::from_triplets(n, n, &rows, &cols, &vals).unwrap();
        let mut b = vec![0.0; n];
        b[0] = 1.0;
        let f = Factorization::new(&a).unwrap();
        let mut x = f.solve(&a, &[b.clone()]).unwrap();
        let before = residual_double_double(&a, &b, &x[0])
            .unwrap()
            .iter()
            .fold(0.0f64, |m, r| m.max(r.abs()));
        for _ in 0..3 {
            refine_step(&a, &f, &[b.clone()], &mut x).unwrap();
        }
        let after = residual_double_double(&a, &b, &x[0])
            .unwrap()
            .iter()
            .fold(0.0f64, |m, r| m.max(r.abs()));
        assert!(after <= before, "{after} > {before}");
        assert!(after < 1e-14, "{after}");
    }

    #[test]
    fn a_step_that_changes_nothing_is_a_fixed_point() {
        // Refine a chain Laplacian (condition number about 1.6e6): each step
        // reports exactly how many entries it changed, the first changes
        // some (the plain solve is not yet correctly rounded), and once a
        // step changes none, further steps leave every bit where it is.
        let n = 2000;
        let a = crate::test_support::laplacian_1d(n);
        let b: Vec<Vec<f64>> =
            (0..2).map(|k| (0..n).map(|i| ((i * (k + 3)) % 11) as f64 - 5.0).collect()).collect();
        let f = Factorization::new(&a).unwrap();
        let mut x = f.solve(&a, &b).unwrap();
        let mut steps = 0;
        loop {
            let before = x.clone();
            let changed = refine_step(&a, &f, &b, &mut x).unwrap();
            let really = before
                .iter()
                .flatten()
                .zip(x.iter().flatten())
                .filter(|(p, q)| p.to_bits() != q.to_bits())
                .count();
            assert_eq!(changed, really, "step {steps}");
            if changed == 0 {
                break;
            }
            steps += 1;
            assert!(steps < 20, "refinement did not settle");
        }
        assert!(steps >= 1, "the plain solve was already a fixed point: nothing was tested");
        let settled = x.clone();
        for _ in 0..3 {
            assert_eq!(refine_step(&a, &f, &b, &mut x).unwrap(), 0);
            assert_eq!(x, settled);
        }
    }
}
