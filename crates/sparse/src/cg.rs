//! Preconditioned conjugate gradients (Hestenes and Stiefel 1952; the
//! preconditioned form as in Saad, *Iterative Methods for Sparse Linear
//! Systems*, 2nd ed., Alg. 9.1) for symmetric positive definite systems: the
//! Tutte systems of thesis 4.3 with symmetric weights, written as `B = D A`
//! (thesis eq. 4.53), which is SPD by Prop. 4.10.
//!
//! CG is only correct for SPD matrices, so the dispatcher refuses
//! non-symmetric input before we get here, and a non-positive curvature
//! `p^T A p` met on the way (the matrix is symmetric but not definite) is an
//! error rather than a silent wrong answer.
//!
//! Stopping: the recursively updated residual `r` drifts from the true
//! `b - A x` in floating point, so when it says "converged" we recompute the
//! true residual with a mat-vec, and if that is not small enough we restart
//! from it (the next iterations then work on the true residual). Each pass of
//! the loop either converges or performs one iteration, so `max_iter` bounds
//! the work.

use crate::error::SparseError;
use crate::preconditioner::Preconditioner;
use crate::solve::Iterate;
use crate::vector::{dot, norm, residual_into, residual_scale};
use crate::CsrMatrix;

/// Conjugate gradients on one right-hand side from `x` until the relative
/// residual `|b - A x| / |b|` is at most `tol` or `max_iter` iterations are
/// done. Inputs were validated by [`crate::solve`].
///
/// Errors: [`SparseError::NotPositiveDefinite`] when a curvature `p^T A p` or
/// a preconditioned residual norm `r^T M^{-1} r` is not positive.
pub(crate) fn conjugate_gradient(
    a: &CsrMatrix,
    m: &impl Preconditioner,
    b: &[f64],
    mut x: Vec<f64>,
    tol: f64,
    max_iter: usize,
) -> Result<Iterate, SparseError> {
    let n = b.len();
    let scale = residual_scale(b);
    let mut r = vec![0.0; n];
    let mut z = vec![0.0; n];
    let mut q = vec![0.0; n];
    residual_into(a, b, &x, &mut r, scale);
    let mut p = vec![0.0; n];
    let mut rz = restart(m, &r, &mut z, &mut p)?;
    let mut iterations = 0;
    loop {
        let rel = norm(&r) / scale;
        if !rel.is_finite() {
            break;
        }
        if rel <= tol {
            // The recursive residual claims convergence: check the true one.
            let residual = residual_into(a, b, &x, &mut r, scale);
            if residual <= tol {
                return Ok(Iterate { x, iterations, residual, converged: true });
            }
            rz = restart(m, &r, &mut z, &mut p)?;
        }
        if iterations == max_iter {
            break;
        }
        if a.mul_vec(&p, &mut q).is_err() {
            break;
        }
        let curvature = dot(&p, &q);
        if curvature.is_nan() || curvature <= 0.0 {
            return Err(SparseError::NotPositiveDefinite {
                method: "conjugate gradient curvature p^T A p",
            });
        }
        let alpha = rz / curvature;
        for i in 0..n {
            x[i] += alpha * p[i];
            r[i] -= alpha * q[i];
        }
        m.apply(&r, &mut z);
        let rz_next = dot(&r, &z);
        let beta = rz_next / rz;
        for i in 0..n {
            p[i] = z[i] + beta * p[i];
        }
        rz = rz_next;
        iterations += 1;
    }
    let residual = residual_into(a, b, &x, &mut r, scale);
    Ok(Iterate { x, iterations, residual, converged: residual <= tol })
}

/// Starts (or restarts) the search direction at `p = z = M^{-1} r` and returns
/// `r^T z`. Zero only when `r = 0`, which the convergence test catches first.
fn restart(
    m: &impl Preconditioner,
    r: &[f64],
    z: &mut [f64],
    p: &mut [f64],
) -> Result<f64, SparseError> {
    m.apply(r, z);
    p.copy_from_slice(z);
    let rz = dot(r, z);
    if rz < 0.0 || rz.is_nan() {
        return Err(SparseError::NotPositiveDefinite { method: "preconditioner r^T M^-1 r" });
    }
    Ok(rz)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::preconditioner::{Ic0, Jacobi};
    use crate::test_support::{dense_solve, grid_laplacian, random_spd, rel_err};

    fn inv_diag(a: &CsrMatrix) -> Vec<f64> {
        a.diagonal().iter().map(|d| 1.0 / d).collect()
    }

    #[test]
    fn jacobi_and_ic0_match_dense_solution() {
        for a in [grid_laplacian(9, 11), random_spd(60, 4, 1.0)] {
            let n = a.n_rows();
            let b: Vec<f64> = (0..n).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
            let exact = dense_solve(&a, &b);
            let jac = Jacobi::new(inv_diag(&a));
            let it = conjugate_gradient(&a, &jac, &b, vec![0.0; n], 1e-12, 1000).unwrap();
            assert!(it.converged && rel_err(&it.x, &exact) < 1e-8);
            let ic = Ic0::new(&a).unwrap();
            let it2 = conjugate_gradient(&a, &ic, &b, vec![0.0; n], 1e-12, 1000).unwrap();
            assert!(it2.converged && rel_err(&it2.x, &exact) < 1e-8);
        }
    }

    #[test]
    fn ic0_needs_fewer_iterations_than_jacobi() {
        let a = grid_laplacian(40, 40);
        let b = vec![1.0; a.n_rows()];
        let x0 = vec![0.0; a.n_rows()];
        let jac = conjugate_gradient(&a, &Jacobi::new(inv_diag(&a)), &b, x0.clone(), 1e-10, 1000);
        let ic = conjugate_gradient(&a, &Ic0::new(&a).unwrap(), &b, x0, 1e-10, 1000);
        let (jac, ic) = (jac.unwrap(), ic.unwrap());
        assert!(jac.converged && ic.converged);
        assert!(ic.iterations * 3 < jac.iterations * 2, "{} vs {}", ic.iterations, jac.iterations);
    }

    #[test]
    fn indefinite_matrix_is_refused() {
        // diag(1, -1) with Jacobi would divide by a negative diagonal; take the
        // identity as preconditioner so the curvature test is what fires.
        let a = CsrMatrix::from_triplets(2, 2, &[0, 1], &[0, 1], &[1.0, -1.0]).unwrap();
        let id = Jacobi::new(vec![1.0, 1.0]);
        let e = conjugate_gradient(&a, &id, &[0.0, 1.0], vec![0.0; 2], 1e-10, 10);
        assert!(matches!(e, Err(SparseError::NotPositiveDefinite { .. })));
    }

    #[test]
    fn stops_at_max_iter_with_last_iterate() {
        let a = grid_laplacian(30, 30);
        let b = vec![1.0; 900];
        let it = conjugate_gradient(&a, &Jacobi::new(inv_diag(&a)), &b, vec![0.0; 900], 1e-12, 3)
            .unwrap();
        assert!(!it.converged);
        assert_eq!((it.iterations, it.x.len()), (3, 900));
    }
}
