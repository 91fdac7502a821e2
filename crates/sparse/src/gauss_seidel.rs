//! Gauss-Seidel iteration (thesis 4.5, eq. 4.50-4.52) for the Tutte systems
//! `A x = b` of thesis 4.3.
//!
//! Splitting `C = L + D + U` (strictly lower, diagonal, strictly upper), one
//! sweep solves `(L + D) v' = d - U v` by forward substitution (eq. 4.52): row
//! `i` in increasing order sets `v_i` so that equation `i` holds with the
//! entries `v_j, j < i` already updated in this sweep.
//!
//! Why it converges. The thesis proves it for chord-length weights (Prop. 4.10):
//! `A = I - Λ` with `Λ_ij = ω_ij / wdeg(i)` is not symmetric, but `B = D A` with
//! `D = diag(wdeg)` is (eq. 4.53), and Gerschgorin (Thm. 4.9, eq. 4.54) plus the
//! non-singularity of `A` (Thm. 4.5) make `B` positive definite, for which
//! Gauss-Seidel converges from any start (Thm. 4.8). We sweep `A` itself,
//! because the iterates are the same: row `i` of `B` is row `i` of `A` times
//! `d_i > 0`, and so is `c_i = d_i b_i`, and the update
//! `v_i = (c_i - Σ_{j≠i} B_ij v_j) / B_ii` divides that common factor out. So
//! the proof for `B` covers the sweep on `A`, and no caller has to form `D A`.
//! For weights without a symmetrising `D` (mean-value weights, thesis 4.4.3)
//! the thesis gives no proof; there `A` is still an irreducibly diagonally
//! dominant M-matrix (the rows of `Λ` are convex combinations and every
//! interior vertex connects to the fixed boundary), for which Gauss-Seidel
//! converges too (Varga, *Matrix Iterative Analysis*, Thm. 3.10), and it is
//! what the tests exercise.
//!
//! Stopping: the relative residual `|b - A x| / |b|` costs one mat-vec, about
//! as much as a sweep, so it is checked after sweeps spaced by an eighth of the
//! sweeps done so far (1, 2, 3, ... then up to every 32): at most ~12% extra
//! work and at most ~12% extra sweeps past the point of convergence.

use crate::solve::Iterate;
use crate::vector::{residual_into, residual_scale};
use crate::CsrMatrix;

/// Longest gap between two residual checks, in sweeps.
const MAX_CHECK_GAP: usize = 32;

/// Gauss-Seidel from `x` on one right-hand side until the relative residual is
/// at most `tol` or `max_iter` sweeps are done. `inv_diag[i] = 1 / a_ii`.
/// Inputs were validated by [`crate::solve`]: square, matching lengths, finite,
/// positive diagonal.
pub(crate) fn gauss_seidel(
    a: &CsrMatrix,
    inv_diag: &[f64],
    b: &[f64],
    mut x: Vec<f64>,
    tol: f64,
    max_iter: usize,
) -> Iterate {
    let scale = residual_scale(b);
    let mut r = vec![0.0; b.len()];
    let mut residual = residual_into(a, b, &x, &mut r, scale);
    let mut sweeps = 0;
    let mut next_check = 1;
    while residual > tol && sweeps < max_iter && residual.is_finite() {
        sweep(a, inv_diag, b, &mut x);
        sweeps += 1;
        if sweeps >= next_check || sweeps == max_iter {
            residual = residual_into(a, b, &x, &mut r, scale);
            next_check = sweeps + (sweeps / 8).clamp(1, MAX_CHECK_GAP);
        }
    }
    Iterate { x, iterations: sweeps, residual, converged: residual <= tol }
}

/// One forward sweep, in place. Written as the correction
/// `x_i += (b_i - row_i . x) / a_ii`, which equals eq. 4.52's
/// `x_i = (b_i - Σ_{j≠i} a_ij x_j) / a_ii` but needs no test for `j == i`
/// in the inner loop.
fn sweep(a: &CsrMatrix, inv_diag: &[f64], b: &[f64], x: &mut [f64]) {
    let offsets = a.row_offsets();
    let cols = a.col_indices();
    let vals = a.values();
    for i in 0..x.len() {
        let mut s = b[i];
        for k in offsets[i]..offsets[i + 1] {
            s -= vals[k] * x[cols[k] as usize];
        }
        x[i] += s * inv_diag[i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{grid_laplacian, mean_value_like, rel_err};

    #[test]
    fn converges_on_grid_laplacian() {
        let a = grid_laplacian(12, 12);
        let n = a.n_rows();
        let inv: Vec<f64> = a.diagonal().iter().map(|d| 1.0 / d).collect();
        let b: Vec<f64> = (0..n).map(|i| (i % 7) as f64 - 3.0).collect();
        let it = gauss_seidel(&a, &inv, &b, vec![0.0; n], 1e-10, 10_000);
        assert!(it.converged);
        assert!(it.iterations > 10);
        let mut r = vec![0.0; n];
        assert!(residual_into(&a, &b, &it.x, &mut r, residual_scale(&b)) <= 1e-10);
    }

    #[test]
    fn converges_on_nonsymmetric_m_matrix() {
        let (a, b) = mean_value_like(200, 3);
        let inv: Vec<f64> = a.diagonal().iter().map(|d| 1.0 / d).collect();
        let it = gauss_seidel(&a, &inv, &b, vec![0.0; 200], 1e-12, 100_000);
        assert!(it.converged);
        let mut r = vec![0.0; 200];
        assert!(residual_into(&a, &b, &it.x, &mut r, residual_scale(&b)) <= 1e-12);
    }

    #[test]
    fn same_iterates_as_on_scaled_rows() {
        // The claim in the module comment: sweeping D A with D b gives the
        // same iterates as sweeping A with b.
        let (a, b) = mean_value_like(50, 9);
        let d: Vec<f64> = (0..50).map(|i| 0.5 + (i % 5) as f64).collect();
        let mut da = a.clone();
        da.scale_rows(&d).unwrap();
        let db: Vec<f64> = b.iter().zip(&d).map(|(bi, di)| bi * di).collect();
        let inv: Vec<f64> = a.diagonal().iter().map(|v| 1.0 / v).collect();
        let inv_d: Vec<f64> = da.diagonal().iter().map(|v| 1.0 / v).collect();
        let (mut x, mut y) = (vec![0.0; 50], vec![0.0; 50]);
        for _ in 0..5 {
            sweep(&a, &inv, &b, &mut x);
            sweep(&da, &inv_d, &db, &mut y);
        }
        assert!(rel_err(&x, &y) < 1e-13);
    }

    #[test]
    fn zero_start_on_zero_rhs_needs_no_sweep() {
        let a = grid_laplacian(4, 4);
        let inv: Vec<f64> = a.diagonal().iter().map(|d| 1.0 / d).collect();
        let it = gauss_seidel(&a, &inv, &[0.0; 16], vec![0.0; 16], 1e-10, 5);
        assert!(it.converged);
        assert_eq!(it.iterations, 0);
    }
}
