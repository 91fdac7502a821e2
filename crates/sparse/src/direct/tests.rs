//! Tests of the direct solvers (Cholesky and LU) against dense solves, beside them.

use super::*;
use crate::test_support::{dense_solve, grid_laplacian, mean_value_like, random_spd, rel_err};

#[test]
fn cholesky_matches_dense() {
    for a in [grid_laplacian(7, 9), random_spd(50, 4, 0.5)] {
        let n = a.n_rows();
        let b1: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).cos()).collect();
        let b2: Vec<f64> = (0..n).map(|i| (i % 3) as f64).collect();
        let narrow = Factor::cholesky(&a).unwrap();
        assert!(matches!(narrow, Factor::Cholesky32 { .. }));
        for f in [narrow, Factor::cholesky_wide(&a).unwrap()] {
            let (x, res) = f.solve(&a, &[b1.clone(), b2.clone()], 1e-12).unwrap();
            assert!(rel_err(&x[0], &dense_solve(&a, &b1)) < 1e-10);
            assert!(rel_err(&x[1], &dense_solve(&a, &b2)) < 1e-10);
            assert!(res.iter().all(|&r| r < 1e-12));
        }
    }
}

#[test]
fn small_systems_keep_the_smaller_predicted_factor() {
    for a in [grid_laplacian(40, 40), grid_laplacian(300, 4), random_spd(300, 5, 0.5)] {
        let col_ptr: Vec<u32> = a.row_offsets().iter().map(|&o| o as u32).collect();
        let m = SymbolicSparseColMatRef::new_checked(
            a.n_rows(),
            a.n_rows(),
            &col_ptr,
            None,
            a.col_indices(),
        );
        let amd =
            symbolic_llt(m, Ordering::Amd, Supernodal::FaerChooses).unwrap().unwrap().len_val();
        let perm = nested_dissection(a.row_offsets(), a.col_indices());
        let nd = symbolic_llt(m, Ordering::Custom(&perm), Supernodal::FaerChooses)
            .unwrap()
            .unwrap()
            .len_val();
        let Factor::Cholesky32 { symbolic, .. } = Factor::cholesky(&a).unwrap() else {
            panic!("expected a 32-bit Cholesky factor");
        };
        assert_eq!(symbolic.len_val(), amd.min(nd));
    }
}

#[test]
fn lu_matches_dense_on_nonsymmetric() {
    let (a, b) = mean_value_like(80, 5);
    let f = Factor::lu(&a).unwrap();
    let (x, _) = f.solve(&a, std::slice::from_ref(&b), 1e-12).unwrap();
    assert!(rel_err(&x[0], &dense_solve(&a, &b)) < 1e-10);
}

#[test]
fn indefinite_cholesky_and_singular_lu_are_errors() {
    let a = CsrMatrix::from_triplets(2, 2, &[0, 1], &[0, 1], &[1.0, -1.0]).unwrap();
    assert!(matches!(Factor::cholesky(&a), Err(SparseError::NotPositiveDefinite { .. })));
    // Structurally singular: row 1 is empty.
    let s = CsrMatrix::from_triplets(2, 2, &[0, 0], &[0, 1], &[1.0, 1.0]).unwrap();
    let r = Factor::lu(&s).and_then(|f| f.solve(&s, &[vec![1.0, 1.0]], 1e-10));
    assert!(matches!(r, Err(SparseError::Singular { .. })), "{r:?}");
    // Numerically singular: two equal rows.
    let s = CsrMatrix::from_triplets(2, 2, &[0, 0, 1, 1], &[0, 1, 0, 1], &[1.0, 2.0, 1.0, 2.0])
        .unwrap();
    let r = Factor::lu(&s).and_then(|f| f.solve(&s, &[vec![1.0, 1.0]], 1e-10));
    assert!(matches!(r, Err(SparseError::Singular { .. })), "{r:?}");
}

#[test]
fn solving_in_place_is_solving() {
    // The whole factor and the two halves (the grid is large enough to cut).
    for a in [grid_laplacian(20, 30), grid_laplacian(400, 12)] {
        let n = a.n_rows();
        let rhs: Vec<Vec<f64>> =
            (0..2).map(|j| (0..n).map(|i| ((i * (j + 2)) as f64 * 0.31).sin()).collect()).collect();
        let mut factors = vec![Factorization::new(&a).unwrap()];
        if let Some(halves) = bordered::factor(&a).unwrap() {
            let factor = Factor::Bordered(Box::new(halves));
            factors.push(Factorization { factor, n, pattern: None, reuses: 0 });
        }
        for f in &factors {
            let x = f.solve(&a, &rhs).unwrap();
            let mut y = rhs.clone();
            f.solve_in_place(&a, &mut y).unwrap();
            assert_eq!(x, y);
            for (xj, b) in x.iter().zip(&rhs) {
                let mut ax = vec![0.0; n];
                a.mul_vec(xj, &mut ax).unwrap();
                assert!(rel_err(&ax, b) < 1e-10);
            }
            let mut short = vec![vec![0.0; n - 1]];
            assert!(matches!(
                f.solve_in_place(&a, &mut short),
                Err(SparseError::LengthMismatch { .. })
            ));
        }
        if n == 4800 {
            assert_eq!(factors.len(), 2, "the long grid cuts in two");
        }
    }
}

/// `a` with every value scaled by `1 + k (i + j) / 100`: the same pattern,
/// still symmetric and positive definite (`a` is diagonally dominant and the
/// off-diagonal entries stay at most as large relative to the diagonal).
fn rescaled(a: &CsrMatrix, k: f64) -> CsrMatrix {
    let n = a.n_rows();
    let (mut rows, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n {
        let (c, v) = a.row(i);
        for (&j, &x) in c.iter().zip(v) {
            rows.push(i as u32);
            cols.push(j);
            let j = j as usize;
            let scale = if i == j { 2.0 + k } else { 1.0 + k * ((i + j) % 7) as f64 / 100.0 };
            vals.push(x * scale);
        }
    }
    CsrMatrix::from_triplets(n, n, &rows, &cols, &vals).unwrap()
}

#[test]
fn refactoring_gives_the_bits_of_a_new_factor() {
    // The whole factor (small grid), the two halves (above the size where
    // Factor::cholesky cuts in two) and a new pattern.
    for a in [grid_laplacian(20, 30), grid_laplacian(460, 460)] {
        let n = a.n_rows();
        let rhs: Vec<Vec<f64>> = vec![(0..n).map(|i| (i as f64 * 0.31).sin()).collect()];
        let mut f = Factorization::reusable(&a).unwrap();
        for k in [0.5, 1.5] {
            let b = rescaled(&a, k);
            f = f.refactor(&b).unwrap();
            let fresh = Factorization::new(&b).unwrap();
            assert_eq!(f.solve(&b, &rhs).unwrap(), fresh.solve(&b, &rhs).unwrap());
            let mut bx = vec![0.0; n];
            b.mul_vec(&f.solve(&b, &rhs).unwrap()[0], &mut bx).unwrap();
            assert!(rel_err(&bx, &rhs[0]) < 1e-10);
        }
        assert_eq!(f.reuses(), 2, "both refactorisations reused the analysis");
        if n > 200_000 {
            assert!(matches!(f.factor, Factor::Bordered(_)), "the large grid cuts in two");
        }
    }
    // Another pattern of the same size: factored anew, never reused.
    let (a, b) = (grid_laplacian(7, 9), grid_laplacian(9, 7));
    assert_eq!((a.n_rows(), a.nnz()), (b.n_rows(), b.nnz()));
    let f = Factorization::reusable(&a).unwrap().refactor(&b).unwrap();
    assert_eq!(f.reuses(), 0);
    // A factor made without its pattern is never reused either.
    assert_eq!(Factorization::new(&a).unwrap().refactor(&rescaled(&a, 2.0)).unwrap().reuses(), 0);
    let rhs = vec![(0..63).map(|i| i as f64).collect::<Vec<f64>>()];
    assert!(rel_err(&f.solve(&b, &rhs).unwrap()[0], &dense_solve(&b, &rhs[0])) < 1e-10);
}
