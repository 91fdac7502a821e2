//! Preconditioners for the conjugate-gradient solver ([`crate::cg`]): Jacobi
//! (diagonal scaling) and IC(0), the zero-fill incomplete Cholesky
//! factorisation of Meijerink and van der Vorst (Math. Comp. 31, 1977).
//!
//! Both approximate `A^{-1}` by a symmetric positive definite `M^{-1}` that is
//! cheap to apply; CG then runs on the better-conditioned `M^{-1} A`. Jacobi
//! costs one multiply per unknown and helps only with badly scaled rows; IC(0)
//! costs two sparse triangular solves and typically cuts the iteration count
//! several-fold on Laplacian-like (Tutte) systems.

use crate::error::SparseError;
use crate::CsrMatrix;

/// `z = M^{-1} r`, for a symmetric positive definite `M`.
pub(crate) trait Preconditioner: Sync {
    fn apply(&self, r: &[f64], z: &mut [f64]);
}

/// Jacobi: `M = diag(A)`.
pub(crate) struct Jacobi {
    inv_diag: Vec<f64>,
}

impl Jacobi {
    /// From `1 / a_ii`, which the dispatcher computed when it checked the
    /// diagonal positive.
    pub(crate) fn new(inv_diag: Vec<f64>) -> Jacobi {
        Jacobi { inv_diag }
    }
}

impl Preconditioner for Jacobi {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        for ((zi, ri), di) in z.iter_mut().zip(r).zip(&self.inv_diag) {
            *zi = ri * di;
        }
    }
}

/// First relative diagonal shift tried when IC(0) breaks down, and how many
/// doublings are tried before giving up (1e-3 * 2^40 ~ 1e9: by then the
/// shifted matrix is so diagonally dominant that a failure means the diagonal
/// itself is unusable).
const FIRST_SHIFT: f64 = 1e-3;
const MAX_SHIFT_DOUBLINGS: u32 = 40;

/// IC(0): `M = L L^T` with `L` lower triangular on exactly the lower-triangle
/// pattern of `A` (no fill), such that `(L L^T)_ij = a_ij` on that pattern.
///
/// For an M-matrix (every Tutte system with positive weights is one) the
/// factorisation exists (Meijerink-van der Vorst, Thm. 2.3). For a general SPD
/// matrix a pivot can come out non-positive; then we factor
/// `A + alpha diag(A)` instead, with `alpha` from 1e-3 doubling until it works
/// (Manteuffel's shifted incomplete Cholesky, Math. Comp. 34, 1980). The shift
/// only weakens the preconditioner; CG still solves the unshifted system.
pub(crate) struct Ic0 {
    /// Strictly lower part of `L`, row by row (CSR, columns increasing).
    offsets: Vec<usize>,
    cols: Vec<u32>,
    vals: Vec<f64>,
    /// `1 / l_ii`.
    inv_diag: Vec<f64>,
    /// The `alpha` that was needed (0 when the plain factorisation worked).
    shift: f64,
}

impl Ic0 {
    /// Factors `A` (square, symmetric, finite, positive diagonal: checked by the
    /// dispatcher). O(Σ_i d_i^2) for row lengths `d_i`.
    pub(crate) fn new(a: &CsrMatrix) -> Result<Ic0, SparseError> {
        let mut ic = Ic0::pattern(a);
        let mut shift = 0.0;
        for attempt in 0..=MAX_SHIFT_DOUBLINGS {
            if ic.factor(a, shift) {
                ic.shift = shift;
                return Ok(ic);
            }
            shift = FIRST_SHIFT * f64::powi(2.0, attempt as i32);
        }
        Err(SparseError::NotPositiveDefinite {
            method: "incomplete Cholesky, even with a diagonal shift",
        })
    }

    /// The relative diagonal shift the factorisation needed.
    #[cfg_attr(not(test), allow(dead_code))]
    pub(crate) fn shift(&self) -> f64 {
        self.shift
    }

    /// The strictly lower pattern of `A`, values still to be computed.
    fn pattern(a: &CsrMatrix) -> Ic0 {
        let n = a.n_rows();
        let mut offsets = Vec::with_capacity(n + 1);
        offsets.push(0);
        let mut cols = Vec::with_capacity(a.nnz() / 2 + 1);
        for i in 0..n {
            let (row_cols, _) = a.row(i);
            cols.extend(row_cols.iter().take_while(|&&j| (j as usize) < i));
            offsets.push(cols.len());
        }
        let vals = vec![0.0; cols.len()];
        Ic0 { offsets, cols, vals, inv_diag: vec![0.0; n], shift: 0.0 }
    }

    /// Row-by-row (left-looking) IC(0) of `A + shift diag(A)`:
    /// `l_ik = (a_ik - Σ_{j<k} l_ij l_kj) / l_kk` for `k < i` in the pattern,
    /// then `l_ii = sqrt(a_ii (1 + shift) - Σ_k l_ik^2)`. The sums run over the
    /// pattern only, which is what "zero fill" means. Returns false on a
    /// non-positive or non-finite pivot.
    fn factor(&mut self, a: &CsrMatrix, shift: f64) -> bool {
        let n = a.n_rows();
        for i in 0..n {
            let (a_cols, a_vals) = a.row(i);
            let start = self.offsets[i];
            let end = self.offsets[i + 1];
            // The strictly lower entries of row i of A are the first end - start.
            for p in start..end {
                let k = self.cols[p] as usize;
                let mut s = a_vals[p - start];
                // Σ_{j<k} l_ij l_kj: merge row i (entries before p) with row k.
                let (mut q, q_end) = (self.offsets[k], self.offsets[k + 1]);
                let mut t = start;
                while t < p && q < q_end {
                    let (ci, ck) = (self.cols[t], self.cols[q]);
                    if ci == ck {
                        s -= self.vals[t] * self.vals[q];
                        t += 1;
                        q += 1;
                    } else if ci < ck {
                        t += 1;
                    } else {
                        q += 1;
                    }
                }
                self.vals[p] = s * self.inv_diag[k];
            }
            let a_ii = match a_cols.get(end - start) {
                Some(&j) if j as usize == i => a_vals[end - start],
                _ => 0.0,
            };
            let d = a_ii * (1.0 + shift) - self.vals[start..end].iter().map(|l| l * l).sum::<f64>();
            if d.is_nan() || d <= 0.0 || d == f64::INFINITY {
                return false;
            }
            self.inv_diag[i] = 1.0 / d.sqrt();
        }
        true
    }
}

impl Preconditioner for Ic0 {
    /// `z = (L L^T)^{-1} r`: forward substitution with `L` by rows, then back
    /// substitution with `L^T` done column-wise over the same rows of `L`, so
    /// no transposed copy is stored.
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        let n = z.len();
        for i in 0..n {
            let mut s = r[i];
            for p in self.offsets[i]..self.offsets[i + 1] {
                s -= self.vals[p] * z[self.cols[p] as usize];
            }
            z[i] = s * self.inv_diag[i];
        }
        for i in (0..n).rev() {
            let zi = z[i] * self.inv_diag[i];
            z[i] = zi;
            for p in self.offsets[i]..self.offsets[i + 1] {
                z[self.cols[p] as usize] -= self.vals[p] * zi;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{dense, grid_laplacian, random_spd};

    /// (L L^T)_ij for the stored factor, densely.
    #[allow(clippy::needless_range_loop)] // index loops read as the formulas
    fn llt(ic: &Ic0, n: usize) -> Vec<Vec<f64>> {
        let mut l = vec![vec![0.0; n]; n];
        for i in 0..n {
            for p in ic.offsets[i]..ic.offsets[i + 1] {
                l[i][ic.cols[p] as usize] = ic.vals[p];
            }
            l[i][i] = 1.0 / ic.inv_diag[i];
        }
        let mut m = vec![vec![0.0; n]; n];
        for i in 0..n {
            for j in 0..n {
                m[i][j] = (0..n).map(|k| l[i][k] * l[j][k]).sum();
            }
        }
        m
    }

    #[test]
    fn ic0_matches_a_on_its_pattern() {
        let a = grid_laplacian(5, 6);
        let n = a.n_rows();
        let ic = Ic0::new(&a).unwrap();
        assert_eq!(ic.shift(), 0.0);
        let m = llt(&ic, n);
        let ad = dense(&a);
        for i in 0..n {
            for j in 0..n {
                if ad[i][j] != 0.0 {
                    assert!((m[i][j] - ad[i][j]).abs() < 1e-12, "{i} {j}");
                }
            }
        }
    }

    #[test]
    fn ic0_of_a_tridiagonal_is_exact() {
        // No fill is possible in a tridiagonal matrix, so IC(0) is the Cholesky
        // factor and M^{-1} r solves A z = r.
        let a = grid_laplacian(1, 30);
        let ic = Ic0::new(&a).unwrap();
        let r: Vec<f64> = (0..30).map(|i| (i as f64).sin()).collect();
        let mut z = vec![0.0; 30];
        ic.apply(&r, &mut z);
        let mut az = vec![0.0; 30];
        a.mul_vec(&z, &mut az).unwrap();
        assert!(az.iter().zip(&r).all(|(u, v)| (u - v).abs() < 1e-12));
    }

    #[test]
    fn ic0_of_random_spd_is_positive_definite() {
        // Random SPD matrices are not M-matrices, so IC(0) may or may not need
        // its shift; either way M^{-1} must come out positive definite.
        let a = random_spd(40, 5, 0.0);
        let ic = Ic0::new(&a).unwrap();
        let r = vec![1.0; 40];
        let mut z = vec![0.0; 40];
        ic.apply(&r, &mut z);
        assert!(z.iter().all(|v| v.is_finite()));
        assert!(crate::vector::dot(&r, &z) > 0.0);
    }

    #[test]
    fn forced_breakdown_then_shift() {
        // [[1, 2], [2, 1]] is indefinite: the second pivot (1 + alpha) -
        // 4 / (1 + alpha) is positive only for alpha > 1, which the doubling
        // sequence 1e-3 * 2^k first passes at 1.024.
        let a = CsrMatrix::from_triplets(2, 2, &[0, 0, 1, 1], &[0, 1, 0, 1], &[1.0, 2.0, 2.0, 1.0])
            .unwrap();
        let ic = Ic0::new(&a).unwrap();
        assert_eq!(ic.shift(), 1.024);
    }

    #[test]
    fn jacobi_scales() {
        let j = Jacobi::new(vec![0.5, 0.25]);
        let mut z = vec![0.0; 2];
        j.apply(&[2.0, 8.0], &mut z);
        assert_eq!(z, vec![1.0, 2.0]);
    }
}
