//! Matrices and references shared by the tests of the solver modules: grid
//! and random SPD matrices, a non-symmetric Tutte-like system, and dense
//! Gaussian elimination as the reference solution.

use crate::CsrMatrix;
use spherify_mesh::lcg::Lcg;

/// The 5-point Laplacian of an `rows x cols` block of interior grid points
/// whose boundary is fixed (Dirichlet, eliminated): 4 on the diagonal, -1
/// per interior neighbour. SPD.
pub(crate) fn grid_laplacian(rows: usize, cols: usize) -> CsrMatrix {
    let (mut r, mut c, mut v) = (Vec::new(), Vec::new(), Vec::new());
    for y in 0..rows {
        for x in 0..cols {
            let i = (y * cols + x) as u32;
            r.push(i);
            c.push(i);
            v.push(4.0);
            let mut link = |j: usize| {
                r.push(i);
                c.push(j as u32);
                v.push(-1.0);
            };
            if x > 0 {
                link(y * cols + x - 1);
            }
            if x + 1 < cols {
                link(y * cols + x + 1);
            }
            if y > 0 {
                link((y - 1) * cols + x);
            }
            if y + 1 < rows {
                link((y + 1) * cols + x);
            }
        }
    }
    CsrMatrix::from_triplets(rows * cols, rows * cols, &r, &c, &v).unwrap()
}

/// The 1D Laplacian on `n` unknowns with both ends fixed: tridiag(-1, 2, -1).
pub(crate) fn laplacian_1d(n: usize) -> CsrMatrix {
    let (mut r, mut c, mut v) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n {
        for (j, w) in [(i.wrapping_sub(1), -1.0), (i, 2.0), (i + 1, -1.0)] {
            if j < n {
                r.push(i as u32);
                c.push(j as u32);
                v.push(w);
            }
        }
    }
    CsrMatrix::from_triplets(n, n, &r, &c, &v).unwrap()
}

/// `A = L L^T + boost I` with a random sparse lower-triangular `L`
/// (positive diagonal, about `per_row` off-diagonal entries a row): SPD,
/// but not an M-matrix.
#[allow(clippy::needless_range_loop)]
pub(crate) fn random_spd(n: usize, per_row: usize, boost: f64) -> CsrMatrix {
    let mut rng = Lcg::new(n as u64 * 31 + per_row as u64);
    let mut l = vec![vec![0.0; n]; n];
    for (i, row) in l.iter_mut().enumerate() {
        row[i] = 0.5 + rng.next_f64();
        for _ in 0..per_row.min(i) {
            let j = rng.below(i);
            row[j] = rng.between(-1.0, 1.0);
        }
    }
    let (mut r, mut c, mut v) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n {
        for j in 0..n {
            let mut s: f64 = (0..n).map(|k| l[i][k] * l[j][k]).sum();
            if i == j {
                s += boost;
            }
            if s != 0.0 {
                r.push(i as u32);
                c.push(j as u32);
                v.push(s);
            }
        }
    }
    CsrMatrix::from_triplets(n, n, &r, &c, &v).unwrap()
}

/// A Tutte-like system with non-symmetric rows of convex weights, as
/// mean-value weights give: `A = I - Λ` on `n` unknowns laid out in rows of
/// 10, each linked to up to 6 neighbours of a triangulated grid; positive
/// random weights normalised per row; neighbours off the grid are fixed
/// boundary vertices whose weighted positions go into `b`.
#[allow(clippy::needless_range_loop)]
pub(crate) fn mean_value_like(n: usize, seed: u64) -> (CsrMatrix, Vec<f64>) {
    let w = 10i64;
    let mut rng = Lcg::new(seed);
    let (mut r, mut c, mut v) = (Vec::new(), Vec::new(), Vec::new());
    let mut b = vec![0.0; n];
    for i in 0..n {
        let (y, x) = (i as i64 / w, i as i64 % w);
        let nbrs = [(0, -1), (0, 1), (-1, 0), (1, 0), (-1, -1), (1, 1)];
        let weights: Vec<f64> = nbrs.iter().map(|_| 0.2 + rng.next_f64()).collect();
        let total: f64 = weights.iter().sum();
        r.push(i as u32);
        c.push(i as u32);
        v.push(1.0);
        for (&(dy, dx), wt) in nbrs.iter().zip(&weights) {
            let (ny, nx) = (y + dy, x + dx);
            let j = ny * w + nx;
            if ny >= 0 && (0..w).contains(&nx) && (j as usize) < n {
                r.push(i as u32);
                c.push(j as u32);
                v.push(-wt / total);
            } else {
                // A boundary vertex at a position that depends on where it is.
                b[i] += wt / total * ((ny * 7 + nx * 3) as f64).sin();
            }
        }
    }
    (CsrMatrix::from_triplets(n, n, &r, &c, &v).unwrap(), b)
}

pub(crate) fn dense(a: &CsrMatrix) -> Vec<Vec<f64>> {
    (0..a.n_rows()).map(|i| (0..a.n_cols()).map(|j| a.get(i, j)).collect()).collect()
}

/// Reference solution by Gaussian elimination with partial pivoting.
#[allow(clippy::needless_range_loop)] // index loops read as the formulas
pub(crate) fn dense_solve(a: &CsrMatrix, b: &[f64]) -> Vec<f64> {
    let n = b.len();
    let mut m = dense(a);
    let mut x = b.to_vec();
    for k in 0..n {
        let p = (k..n).max_by(|&i, &j| m[i][k].abs().total_cmp(&m[j][k].abs())).unwrap();
        m.swap(k, p);
        x.swap(k, p);
        for i in k + 1..n {
            let f = m[i][k] / m[k][k];
            if f != 0.0 {
                for j in k..n {
                    m[i][j] -= f * m[k][j];
                }
                x[i] -= f * x[k];
            }
        }
    }
    for k in (0..n).rev() {
        let s: f64 = (k + 1..n).map(|j| m[k][j] * x[j]).sum();
        x[k] = (x[k] - s) / m[k][k];
    }
    x
}

/// `|x - y| / |y|`.
pub(crate) fn rel_err(x: &[f64], y: &[f64]) -> f64 {
    let d: f64 = x.iter().zip(y).map(|(a, b)| (a - b) * (a - b)).sum();
    let n: f64 = y.iter().map(|b| b * b).sum();
    (d / n).sqrt()
}
