//! One entry point for the linear systems of spherify: [`solve`] picks or runs
//! a solver for `A x = b` with one or more right-hand sides (the `x` and `y`
//! coordinates of a Tutte embedding, thesis eq. 4.27 / 4.49) and reports what
//! it did in a [`SolveInfo`].
//!
//! Validation happens here, once (STYLE.md 5): shapes, finiteness, symmetry
//! for the solvers that need it, positive diagonal; the solver modules then
//! rely on it.
//!
//! # What `Auto` picks, and why
//!
//! Always [`SolverKind::Direct`]: sparse Cholesky when the matrix is symmetric
//! (within a relative 1e-10), sparse LU otherwise, and LU also when a
//! symmetric matrix turns out not to be positive definite (where an explicit
//! `Direct` reports [`SparseError::NotPositiveDefinite`] instead).
//!
//! A fill-reducing ordering keeps the factor of a planar Tutte system nearly
//! linear in size, so Direct beat CG and Gauss-Seidel at every size measured
//! (10k to 1M unknowns), is exact to ~1e-14 whatever `tol` says, and costs the
//! same for any right-hand side. Its limit is memory (~0.5 GB at 1M
//! unknowns): for systems far beyond that, ask for [`SolverKind::CgIc0`].
//! The timings are in docs/benchmarks.md ("Tutte system solvers").

use crate::direct::Factor;
use crate::error::SparseError;
use crate::preconditioner::{Ic0, Jacobi};
use crate::{cg, gauss_seidel, CsrMatrix, SolverKind};
use rayon::prelude::*;
use std::time::Instant;

/// Parameters of [`solve`].
#[derive(Debug, Clone)]
pub struct SolveParams {
    /// Stop when the relative residual `|b - A x| / |b|` is at most this
    /// (the absolute residual where `b = 0`). Default `1e-10`. The direct
    /// solvers use it only to decide on iterative refinement.
    pub tol: f64,
    /// Most iterations (conjugate-gradient steps or Gauss-Seidel sweeps) per
    /// right-hand side. Default 10,000.
    pub max_iter: usize,
    /// Starting guesses for the iterative solvers, one per right-hand side;
    /// zeros when `None`. Ignored by the direct solvers.
    pub x0: Option<Vec<Vec<f64>>>,
}

impl Default for SolveParams {
    fn default() -> SolveParams {
        SolveParams { tol: 1e-10, max_iter: 10_000, x0: None }
    }
}

/// What [`solve`] did.
#[derive(Debug, Clone)]
pub struct SolveInfo {
    /// The solver that ran; never [`SolverKind::Auto`].
    pub solver: SolverKind,
    /// Iterations of the slowest right-hand side; 0 for [`SolverKind::Direct`].
    pub iterations: usize,
    /// Largest final relative residual `|b - A x| / |b|` over the right-hand
    /// sides, computed from the returned solutions.
    pub residual: f64,
    /// Wall-clock time of the whole call, validation included.
    pub seconds: f64,
}

/// The result of an iterative solver on one right-hand side.
pub(crate) struct Iterate {
    pub(crate) x: Vec<f64>,
    pub(crate) iterations: usize,
    /// Relative residual of `x`, computed from `x` (not a recursive estimate).
    pub(crate) residual: f64,
    pub(crate) converged: bool,
}

/// Entries `a_ij` and `a_ji` count as equal when they differ by at most this
/// times the largest `|a_kl|`: loose enough for weights assembled from
/// floating-point sums in different orders, tight enough to catch mean-value
/// weights, whose asymmetry is of the order of the weights.
const SYMMETRY_RTOL: f64 = 1e-10;

/// Solves `A x = b` for every `b` in `rhs` with the solver `kind` and returns
/// the solutions (one per right-hand side, in order) and a [`SolveInfo`].
///
/// A direct solver factors once and solves all right-hand sides with that
/// factor; the iterative solvers run the right-hand sides in parallel on
/// rayon's pool. The same call gives the same bits on every run (each
/// right-hand side is computed independently, with fixed summation orders;
/// faer's parallel factorisation was checked run-to-run at 100k and 1M).
///
/// Errors:
/// * [`SparseError::NotSquare`], [`SparseError::LengthMismatch`] (a
///   right-hand side or starting guess of the wrong length, or a different
///   number of starting guesses than right-hand sides),
///   [`SparseError::NonFinite`] (NaN or infinity in `A`, `rhs` or `x0`),
///   [`SparseError::InvalidParameter`] (`tol` negative or NaN);
/// * [`SparseError::NotSymmetric`] for CG on a non-symmetric matrix,
///   [`SparseError::NonPositiveDiagonal`] for CG and Gauss-Seidel,
///   [`SparseError::NotPositiveDefinite`] when Cholesky or CG finds the
///   matrix indefinite, [`SparseError::Singular`] when LU finds it singular,
///   [`SparseError::Factorization`] when the direct solver fails otherwise;
/// * [`SparseError::NoConvergence`], with the last iterate of every
///   right-hand side, when an iterative solver runs out of iterations.
pub fn solve(
    a: &CsrMatrix,
    rhs: &[Vec<f64>],
    kind: SolverKind,
    params: &SolveParams,
) -> Result<(Vec<Vec<f64>>, SolveInfo), SparseError> {
    let start = Instant::now();
    validate(a, rhs, params)?;
    let (x, solver, iterations, residuals) = match kind {
        SolverKind::Auto => {
            let symmetric = find_asymmetry(a).is_none();
            let (x, residuals) = Factor::cholesky_or_lu(a, symmetric)?.solve(a, rhs, params.tol)?;
            (x, SolverKind::Direct, 0, residuals)
        }
        SolverKind::Direct => {
            let factor = match find_asymmetry(a) {
                None => Factor::cholesky(a)?,
                Some(_) => Factor::lu(a)?,
            };
            let (x, residuals) = factor.solve(a, rhs, params.tol)?;
            (x, SolverKind::Direct, 0, residuals)
        }
        SolverKind::CgJacobi | SolverKind::CgIc0 | SolverKind::GaussSeidel => {
            let iterates = solve_iterative(a, rhs, kind, params)?;
            let iterations = iterates.iter().map(|it| it.iterations).max().unwrap_or(0);
            let residuals: Vec<f64> = iterates.iter().map(|it| it.residual).collect();
            let converged = iterates.iter().all(|it| it.converged);
            let x: Vec<Vec<f64>> = iterates.into_iter().map(|it| it.x).collect();
            if !converged {
                let residual = worst(&residuals);
                return Err(SparseError::NoConvergence { iterations, residual, last: x });
            }
            (x, kind, iterations, residuals)
        }
    };
    let residual = worst(&residuals);
    let info = SolveInfo { solver, iterations, residual, seconds: start.elapsed().as_secs_f64() };
    Ok((x, info))
}

/// The largest residual, or NaN if any is NaN (a diverged iteration):
/// `f64::max` alone would drop the NaN and report the others.
fn worst(residuals: &[f64]) -> f64 {
    residuals
        .iter()
        .fold(0.0, |m: f64, &r| if r.is_nan() || m.is_nan() { f64::NAN } else { m.max(r) })
}

/// An iterative solver on one right-hand side and its starting guess.
type OneRhs<'a> = dyn Fn(&[f64], Vec<f64>) -> Result<Iterate, SparseError> + Sync + 'a;

/// Runs an iterative solver on every right-hand side in parallel.
fn solve_iterative(
    a: &CsrMatrix,
    rhs: &[Vec<f64>],
    kind: SolverKind,
    params: &SolveParams,
) -> Result<Vec<Iterate>, SparseError> {
    let n = a.n_rows();
    if matches!(kind, SolverKind::CgJacobi | SolverKind::CgIc0) {
        if let Some((row, col, value, mirror)) = find_asymmetry(a) {
            return Err(SparseError::NotSymmetric { row, col, value, mirror });
        }
    }
    let inv_diag = positive_inverse_diagonal(a)?;
    let starts: Vec<Vec<f64>> = match &params.x0 {
        Some(x0) => x0.clone(),
        None => vec![vec![0.0; n]; rhs.len()],
    };
    let (tol, max_iter) = (params.tol, params.max_iter);
    let run_all = |f: &OneRhs| {
        rhs.par_iter()
            .zip(starts.into_par_iter())
            .map(|(b, x)| f(b, x))
            .collect::<Result<Vec<Iterate>, SparseError>>()
    };
    match kind {
        SolverKind::GaussSeidel => {
            run_all(&|b, x| Ok(gauss_seidel::gauss_seidel(a, &inv_diag, b, x, tol, max_iter)))
        }
        SolverKind::CgIc0 => {
            // Factored once, shared read-only by every right-hand side.
            let ic = Ic0::new(a)?;
            run_all(&|b, x| cg::conjugate_gradient(a, &ic, b, x, tol, max_iter))
        }
        _ => {
            let jacobi = Jacobi::new(inv_diag.clone());
            run_all(&|b, x| cg::conjugate_gradient(a, &jacobi, b, x, tol, max_iter))
        }
    }
}

/// Checks everything the solvers rely on that does not depend on the solver.
pub(crate) fn validate(
    a: &CsrMatrix,
    rhs: &[Vec<f64>],
    params: &SolveParams,
) -> Result<(), SparseError> {
    let n = a.n_rows();
    if a.n_cols() != n {
        return Err(SparseError::NotSquare { n_rows: n, n_cols: a.n_cols() });
    }
    if params.tol.is_nan() || params.tol < 0.0 {
        return Err(SparseError::InvalidParameter {
            name: "tol",
            value: params.tol,
            expected: "a number >= 0",
        });
    }
    if let Some(index) = a.values().iter().position(|v| !v.is_finite()) {
        return Err(SparseError::NonFinite { what: "matrix", index });
    }
    check_vectors("rhs", rhs, n)?;
    if let Some(x0) = &params.x0 {
        if x0.len() != rhs.len() {
            return Err(SparseError::LengthMismatch {
                what: "x0 (number of starting guesses)",
                got: x0.len(),
                expected: rhs.len(),
            });
        }
        check_vectors("x0", x0, n)?;
    }
    Ok(())
}

/// Every vector `n` long and finite.
fn check_vectors(what: &'static str, vectors: &[Vec<f64>], n: usize) -> Result<(), SparseError> {
    for (k, v) in vectors.iter().enumerate() {
        if v.len() != n {
            return Err(SparseError::LengthMismatch { what, got: v.len(), expected: n });
        }
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            return Err(SparseError::NonFinite { what, index: k * n + i });
        }
    }
    Ok(())
}

/// The first stored entry (in row order) whose mirror differs by more than
/// [`SYMMETRY_RTOL`] times the largest entry, as `(row, col, a_rc, a_cr)`;
/// `None` for a symmetric matrix. O(nnz log d), rows split over rayon.
pub(crate) fn find_asymmetry(a: &CsrMatrix) -> Option<(usize, usize, f64, f64)> {
    let largest = a.values().iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let tol = SYMMETRY_RTOL * largest;
    (0..a.n_rows()).into_par_iter().with_min_len(4096).find_map_first(|i| {
        let (cols, values) = a.row(i);
        cols.iter().zip(values).find_map(|(&j, &v)| {
            let mirror = a.get(j as usize, i);
            ((v - mirror).abs() > tol).then_some((i, j as usize, v, mirror))
        })
    })
}

/// `1 / a_ii` for every row, or the first diagonal entry that is not positive.
fn positive_inverse_diagonal(a: &CsrMatrix) -> Result<Vec<f64>, SparseError> {
    let diag = a.diagonal();
    if let Some(row) = diag.iter().position(|&d| d.is_nan() || d <= 0.0) {
        return Err(SparseError::NonPositiveDiagonal { row, value: diag[row] });
    }
    Ok(diag.iter().map(|d| 1.0 / d).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::*;

    fn tight() -> SolveParams {
        SolveParams { tol: 1e-13, max_iter: 200_000, x0: None }
    }

    fn wave(n: usize, k: f64) -> Vec<f64> {
        (0..n).map(|i| (i as f64 * k).sin() + 0.25).collect()
    }

    #[test]
    fn every_solver_matches_dense_elimination() {
        let systems = [
            laplacian_1d(40),
            grid_laplacian(6, 8),
            random_spd(30, 3, 0.0),
            random_spd(45, 5, 2.0),
        ];
        for a in &systems {
            let b = wave(a.n_rows(), 0.37);
            let exact = dense_solve(a, &b);
            for kind in SolverKind::ALL {
                let (x, info) = solve(a, std::slice::from_ref(&b), kind, &tight()).unwrap();
                assert!(rel_err(&x[0], &exact) < 1e-8, "{kind:?}: {}", rel_err(&x[0], &exact));
                assert!(info.residual <= 1e-13, "{kind:?}: {}", info.residual);
                assert_ne!(info.solver, SolverKind::Auto);
                assert_eq!(info.iterations == 0, info.solver == SolverKind::Direct);
            }
        }
    }

    #[test]
    fn all_solvers_agree_on_a_60x60_grid() {
        let a = grid_laplacian(60, 60);
        let rhs = [wave(3600, 0.01), wave(3600, 0.3)];
        let (reference, _) = solve(&a, &rhs, SolverKind::Direct, &tight()).unwrap();
        for kind in SolverKind::ALL {
            let (x, info) = solve(&a, &rhs, kind, &tight()).unwrap();
            for k in 0..2 {
                assert!(rel_err(&x[k], &reference[k]) < 1e-8, "{kind:?} rhs {k}");
            }
            let expected = if kind == SolverKind::Auto { SolverKind::Direct } else { kind };
            assert_eq!(info.solver, expected);
        }
    }

    #[test]
    fn nonsymmetric_m_matrix_by_lu_and_gauss_seidel_not_cg() {
        let (a, b) = mean_value_like(300, 17);
        let exact = dense_solve(&a, &b);
        for kind in [SolverKind::Auto, SolverKind::Direct, SolverKind::GaussSeidel] {
            let (x, info) = solve(&a, std::slice::from_ref(&b), kind, &tight()).unwrap();
            assert!(rel_err(&x[0], &exact) < 1e-8, "{kind:?}");
            assert!(info.residual <= 1e-13);
        }
        for kind in [SolverKind::CgJacobi, SolverKind::CgIc0] {
            let e = solve(&a, std::slice::from_ref(&b), kind, &tight()).unwrap_err();
            assert!(matches!(e, SparseError::NotSymmetric { .. }), "{e:?}");
        }
    }

    #[test]
    fn dirichlet_identity_rows() {
        // A 1D Laplacian whose two ends are kept as identity rows holding the
        // boundary values, as a Tutte system written over all vertices is: not
        // symmetric (interior rows reach the boundary columns, not back).
        let n = 30;
        let (mut r, mut c, mut v) = (vec![0, n as u32 - 1], vec![0, n as u32 - 1], vec![1.0, 1.0]);
        for i in 1..n - 1 {
            for (j, w) in [(i - 1, -1.0), (i, 2.0), (i + 1, -1.0)] {
                r.push(i as u32);
                c.push(j as u32);
                v.push(w);
            }
        }
        let a = CsrMatrix::from_triplets(n, n, &r, &c, &v).unwrap();
        let mut b = vec![0.0; n];
        b[0] = 1.0;
        b[n - 1] = 3.0;
        for kind in [SolverKind::Auto, SolverKind::Direct, SolverKind::GaussSeidel] {
            let (x, _) = solve(&a, std::slice::from_ref(&b), kind, &tight()).unwrap();
            // The solution is the straight line from 1 to 3.
            for (i, xi) in x[0].iter().enumerate() {
                assert!((xi - (1.0 + 2.0 * i as f64 / (n - 1) as f64)).abs() < 1e-10, "{kind:?}");
            }
        }
        assert!(matches!(
            solve(&a, &[b], SolverKind::CgIc0, &tight()),
            Err(SparseError::NotSymmetric { .. })
        ));
    }

    #[test]
    fn max_iter_gives_no_convergence_with_last_iterate() {
        let a = grid_laplacian(20, 20);
        let rhs = [wave(400, 0.1), wave(400, 0.2)];
        let params = SolveParams { tol: 1e-12, max_iter: 5, x0: None };
        for kind in [SolverKind::CgJacobi, SolverKind::CgIc0, SolverKind::GaussSeidel] {
            match solve(&a, &rhs, kind, &params) {
                Err(SparseError::NoConvergence { iterations, residual, last }) => {
                    assert_eq!(iterations, 5);
                    assert!(residual > 1e-12 && residual < 1.0, "{kind:?} {residual}");
                    assert_eq!(last.len(), 2);
                    assert!(last.iter().all(|x| x.len() == 400));
                    // Restarting from the last iterate finishes the job.
                    let more = SolveParams { x0: Some(last), ..tight() };
                    assert!(solve(&a, &rhs, kind, &more).is_ok());
                }
                other => panic!("{kind:?}: {other:?}"),
            }
        }
    }

    #[test]
    fn diverging_gauss_seidel_stops_with_an_error() {
        // [[1, 3], [3, 1]] is not diagonally dominant: each sweep multiplies
        // the error by 9 until it overflows; the loop must stop there rather
        // than run out its (huge) budget, and say so with a NaN or infinite
        // residual.
        let a = CsrMatrix::from_triplets(2, 2, &[0, 0, 1, 1], &[0, 1, 0, 1], &[1.0, 3.0, 3.0, 1.0])
            .unwrap();
        let params = SolveParams { tol: 1e-10, max_iter: usize::MAX, x0: None };
        match solve(&a, &[vec![1.0, 2.0]], SolverKind::GaussSeidel, &params) {
            Err(SparseError::NoConvergence { iterations, residual, last }) => {
                assert!(iterations < 2000, "{iterations}");
                assert!(!residual.is_finite(), "{residual}");
                assert_eq!(last[0].len(), 2);
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn non_finite_input_is_an_error() {
        let a = grid_laplacian(3, 3);
        let mut b = vec![1.0; 9];
        b[4] = f64::NAN;
        for kind in SolverKind::ALL {
            let e = solve(&a, &[vec![1.0; 9], b.clone()], kind, &tight()).unwrap_err();
            assert_eq!(e, SparseError::NonFinite { what: "rhs", index: 9 + 4 });
        }
        let bad = CsrMatrix::from_triplets(2, 2, &[0, 1], &[0, 1], &[1.0, f64::INFINITY]).unwrap();
        for kind in SolverKind::ALL {
            let e = solve(&bad, &[vec![1.0; 2]], kind, &tight()).unwrap_err();
            assert_eq!(e, SparseError::NonFinite { what: "matrix", index: 1 });
        }
        let x0 = SolveParams { x0: Some(vec![vec![f64::NAN; 9]]), ..tight() };
        let e = solve(&a, &[vec![1.0; 9]], SolverKind::GaussSeidel, &x0).unwrap_err();
        assert_eq!(e, SparseError::NonFinite { what: "x0", index: 0 });
        let nan_tol = SolveParams { tol: f64::NAN, ..tight() };
        let e = solve(&a, &[vec![1.0; 9]], SolverKind::CgJacobi, &nan_tol).unwrap_err();
        assert!(matches!(e, SparseError::InvalidParameter { name: "tol", .. }));
    }

    #[test]
    fn shape_errors() {
        let a = grid_laplacian(3, 3);
        for kind in SolverKind::ALL {
            let e = solve(&a, &[vec![1.0; 8]], kind, &tight()).unwrap_err();
            assert_eq!(e, SparseError::LengthMismatch { what: "rhs", got: 8, expected: 9 });
        }
        let rect = CsrMatrix::from_triplets(2, 3, &[], &[], &[]).unwrap();
        let e = solve(&rect, &[vec![0.0; 2]], SolverKind::Auto, &tight()).unwrap_err();
        assert_eq!(e, SparseError::NotSquare { n_rows: 2, n_cols: 3 });
        let two_starts = SolveParams { x0: Some(vec![vec![0.0; 9]; 2]), ..tight() };
        let e = solve(&a, &[vec![1.0; 9]], SolverKind::CgIc0, &two_starts).unwrap_err();
        assert!(matches!(e, SparseError::LengthMismatch { got: 2, expected: 1, .. }));
        let short_start = SolveParams { x0: Some(vec![vec![0.0; 4]]), ..tight() };
        let e = solve(&a, &[vec![1.0; 9]], SolverKind::CgIc0, &short_start).unwrap_err();
        assert_eq!(e, SparseError::LengthMismatch { what: "x0", got: 4, expected: 9 });
    }

    #[test]
    fn non_positive_diagonal_and_indefinite() {
        // Symmetric, zero diagonal entry: iterative solvers refuse; Auto's
        // Cholesky fails and LU takes over.
        let a = CsrMatrix::from_triplets(2, 2, &[0, 0, 1], &[0, 1, 0], &[1.0, 2.0, 2.0]).unwrap();
        for kind in [SolverKind::CgJacobi, SolverKind::CgIc0, SolverKind::GaussSeidel] {
            let e = solve(&a, &[vec![1.0, 1.0]], kind, &tight()).unwrap_err();
            assert_eq!(e, SparseError::NonPositiveDiagonal { row: 1, value: 0.0 });
        }
        let e = solve(&a, &[vec![1.0, 1.0]], SolverKind::Direct, &tight()).unwrap_err();
        assert!(matches!(e, SparseError::NotPositiveDefinite { .. }));
        let (x, info) = solve(&a, &[vec![3.0, 4.0]], SolverKind::Auto, &tight()).unwrap();
        // [[1, 2], [2, 0]] x = [3, 4]: x = [2, 0.5].
        assert!((x[0][0] - 2.0).abs() < 1e-14 && (x[0][1] - 0.5).abs() < 1e-14);
        assert_eq!(info.solver, SolverKind::Direct);
        // Positive diagonal but indefinite: CG detects the negative curvature.
        let ind =
            CsrMatrix::from_triplets(2, 2, &[0, 0, 1, 1], &[0, 1, 0, 1], &[1.0, 3.0, 3.0, 1.0])
                .unwrap();
        let e = solve(&ind, &[vec![1.0, -1.0]], SolverKind::CgJacobi, &tight()).unwrap_err();
        assert!(matches!(e, SparseError::NotPositiveDefinite { .. }), "{e:?}");
    }

    #[test]
    fn two_right_hand_sides_equal_one_at_a_time() {
        let a = grid_laplacian(15, 17);
        let (b1, b2) = (wave(255, 0.2), wave(255, 1.3));
        for kind in SolverKind::ALL {
            let (both, _) = solve(&a, &[b1.clone(), b2.clone()], kind, &tight()).unwrap();
            let (one, _) = solve(&a, std::slice::from_ref(&b1), kind, &tight()).unwrap();
            let (two, _) = solve(&a, std::slice::from_ref(&b2), kind, &tight()).unwrap();
            assert!(rel_err(&both[0], &one[0]) < 1e-14, "{kind:?}");
            assert!(rel_err(&both[1], &two[0]) < 1e-14, "{kind:?}");
            // And the same call twice gives the same bits (DESIGN.md).
            let (again, _) = solve(&a, &[b1.clone(), b2.clone()], kind, &tight()).unwrap();
            assert_eq!(both, again, "{kind:?}");
        }
    }

    #[test]
    fn trivial_cases() {
        let a = grid_laplacian(4, 4);
        for kind in SolverKind::ALL {
            let (x, info) = solve(&a, &[], kind, &tight()).unwrap();
            assert!(x.is_empty());
            assert_eq!(info.residual, 0.0);
            let (x, info) = solve(&a, &[vec![0.0; 16]], kind, &tight()).unwrap();
            assert_eq!(x, vec![vec![0.0; 16]]);
            assert_eq!(info.residual, 0.0);
        }
        let empty = CsrMatrix::from_triplets(0, 0, &[], &[], &[]).unwrap();
        for kind in SolverKind::ALL {
            let (x, _) = solve(&empty, &[vec![]], kind, &tight()).unwrap();
            assert_eq!(x, vec![Vec::<f64>::new()]);
        }
    }

    #[test]
    fn a_good_start_needs_no_iteration() {
        let a = grid_laplacian(10, 10);
        let b = wave(100, 0.5);
        let (x, _) = solve(&a, std::slice::from_ref(&b), SolverKind::Direct, &tight()).unwrap();
        let params = SolveParams { tol: 1e-10, max_iter: 0, x0: Some(x) };
        for kind in [SolverKind::CgJacobi, SolverKind::CgIc0, SolverKind::GaussSeidel] {
            let (_, info) = solve(&a, std::slice::from_ref(&b), kind, &params).unwrap();
            assert_eq!(info.iterations, 0);
        }
    }
}
