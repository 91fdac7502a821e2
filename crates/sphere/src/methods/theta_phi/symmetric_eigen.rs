//! Eigen-decomposition of a symmetric 3x3 matrix by cyclic Jacobi rotations.
//!
//! The symmetry method (thesis 6.2.5, eq. 6.15) needs C = Q Lambda Q^T for the
//! 3x3 weighted covariance matrix C of eq. 6.12. Jacobi's method is the
//! simplest routine that is accurate for every symmetric matrix, including
//! ones with repeated eigenvalues (a sphere's covariance is a multiple of the
//! identity): each rotation zeroes one off-diagonal entry, the off-diagonal
//! mass falls quadratically once it is small, and the product of the
//! rotations is orthogonal to rounding. For 3x3 matrices a handful of sweeps
//! reach machine precision.

/// Eigenvalues in ascending order and the matching unit eigenvectors as the
/// columns of `q` (`q[row][col]`), so that `a = q diag(values) q^T`.
///
/// Each eigenvector's sign is fixed so that its component of largest magnitude
/// is positive (the first such component on ties), which makes the result
/// deterministic for callers that turn eigenvectors into planes.
/// Non-finite entries give non-finite output; callers check the input.
pub fn symmetric_eigen(a: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    // Work on the symmetric part, so that a slightly asymmetric input (rounding
    // in the caller's accumulation) is treated consistently.
    let mut m = [[0.0; 3]; 3];
    for (r, row) in m.iter_mut().enumerate() {
        for (c, x) in row.iter_mut().enumerate() {
            *x = 0.5 * (a[r][c] + a[c][r]);
        }
    }
    let mut q = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..64 {
        let off = m[0][1] * m[0][1] + m[0][2] * m[0][2] + m[1][2] * m[1][2];
        let diag = m[0][0] * m[0][0] + m[1][1] * m[1][1] + m[2][2] * m[2][2];
        if off == 0.0 || off <= 1e-36 * diag || !off.is_finite() {
            break;
        }
        for (p, r) in [(0, 1), (0, 2), (1, 2)] {
            rotate(&mut m, &mut q, p, r);
        }
    }
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| m[i][i].total_cmp(&m[j][j]).then(i.cmp(&j)));
    let values = [m[order[0]][order[0]], m[order[1]][order[1]], m[order[2]][order[2]]];
    let mut vectors = [[0.0; 3]; 3];
    for (col, &k) in order.iter().enumerate() {
        let mut v = [q[0][k], q[1][k], q[2][k]];
        let mut lead = 0;
        for i in 1..3 {
            if v[i].abs() > v[lead].abs() {
                lead = i;
            }
        }
        if v[lead] < 0.0 {
            v = [-v[0], -v[1], -v[2]];
        }
        for (row, x) in v.into_iter().enumerate() {
            vectors[row][col] = x;
        }
    }
    (values, vectors)
}

/// One Jacobi rotation J in the (p, r) plane chosen so that (J^T M J)[p][r] = 0;
/// M <- J^T M J and Q <- Q J. With cot(2 phi) = (m_rr - m_pp) / (2 m_pr) the
/// smaller root t = tan(phi) of t^2 + 2 t cot(2 phi) - 1 = 0 keeps the rotation
/// angle at most pi / 4, which is what makes the cyclic method converge.
fn rotate(m: &mut [[f64; 3]; 3], q: &mut [[f64; 3]; 3], p: usize, r: usize) {
    let apr = m[p][r];
    if apr == 0.0 {
        return;
    }
    let theta = (m[r][r] - m[p][p]) / (2.0 * apr);
    let t = if theta.abs() > 1e150 {
        // theta^2 would overflow; t ~ 1 / (2 theta) there.
        0.5 / theta
    } else {
        let t = 1.0 / (theta.abs() + (theta * theta + 1.0).sqrt());
        if theta < 0.0 {
            -t
        } else {
            t
        }
    };
    let c = 1.0 / (t * t + 1.0).sqrt();
    let s = t * c;
    let mut j = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    j[p][p] = c;
    j[r][r] = c;
    j[p][r] = s;
    j[r][p] = -s;
    let mj = mul(m, &j);
    *m = mul(&transpose(&j), &mj);
    // Exactly zero by construction; rounding would leave a tiny residue.
    m[p][r] = 0.0;
    m[r][p] = 0.0;
    *q = mul(q, &j);
}

fn mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut out = [[0.0; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (k, x) in row.iter_mut().enumerate() {
            *x = a[i][0] * b[0][k] + a[i][1] * b[1][k] + a[i][2] * b[2][k];
        }
    }
    out
}

fn transpose(a: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut out = [[0.0; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (k, x) in row.iter_mut().enumerate() {
            *x = a[k][i];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reconstruct(values: [f64; 3], q: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
        let mut out = [[0.0; 3]; 3];
        for (i, row) in out.iter_mut().enumerate() {
            for (k, x) in row.iter_mut().enumerate() {
                *x = (0..3).map(|j| q[i][j] * values[j] * q[k][j]).sum();
            }
        }
        out
    }

    fn assert_decomposes(a: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let (values, q) = symmetric_eigen(a);
        let scale = a.iter().flatten().fold(1e-300f64, |m, x| m.max(x.abs()));
        let back = reconstruct(values, q);
        for i in 0..3 {
            for k in 0..3 {
                assert!((back[i][k] - a[i][k]).abs() <= 1e-13 * scale, "{a:?}: {back:?}");
                let dot: f64 = (0..3).map(|j| q[j][i] * q[j][k]).sum();
                let want = if i == k { 1.0 } else { 0.0 };
                assert!((dot - want).abs() < 1e-14, "Q^T Q at ({i}, {k}) = {dot}");
            }
        }
        assert!(values[0] <= values[1] && values[1] <= values[2]);
        (values, q)
    }

    #[test]
    fn known_matrices() {
        // diag(3, 1, 2): eigenvalues sorted, eigenvectors the axes.
        let (values, q) = assert_decomposes([[3.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 2.0]]);
        assert_eq!(values, [1.0, 2.0, 3.0]);
        assert_eq!([q[0][0], q[1][0], q[2][0]], [0.0, 1.0, 0.0]);
        assert_eq!([q[0][2], q[1][2], q[2][2]], [1.0, 0.0, 0.0]);
        // [[2, 1, 0], [1, 2, 0], [0, 0, 5]]: eigenvalues 1, 3, 5 with
        // eigenvectors (1, -1, 0) / sqrt 2, (1, 1, 0) / sqrt 2, (0, 0, 1).
        let (values, q) = assert_decomposes([[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 5.0]]);
        let h = std::f64::consts::FRAC_1_SQRT_2;
        for (got, want) in values.iter().zip([1.0, 3.0, 5.0]) {
            assert!((got - want).abs() < 1e-14);
        }
        let columns = [[h, -h, 0.0], [h, h, 0.0], [0.0, 0.0, 1.0]];
        for (col, want) in columns.iter().enumerate() {
            for row in 0..3 {
                assert!((q[row][col] - want[row]).abs() < 1e-14, "column {col}: {q:?}");
            }
        }
        // The all-ones matrix: eigenvalues 0, 0, 3, the last along (1, 1, 1).
        let (values, q) = assert_decomposes([[1.0; 3]; 3]);
        assert!(values[0].abs() < 1e-15 && values[1].abs() < 1e-15);
        assert!((values[2] - 3.0).abs() < 1e-14);
        let third = 1.0 / 3f64.sqrt();
        for row in q.iter() {
            assert!((row[2] - third).abs() < 1e-14);
        }
        // A multiple of the identity needs no rotation at all.
        let (values, q) = assert_decomposes([[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]]);
        assert_eq!(values, [2.0; 3]);
        assert_eq!(q, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    }

    #[test]
    fn rotated_diagonal_matrices() {
        // R diag(l) R^T for rotations R built from two angles: eigenvalues and
        // eigenvectors (up to sign) come back.
        let mut rng = spherify_mesh::lcg::Lcg::new(17);
        let mut next = || rng.next_f64();
        for _ in 0..200 {
            let (a, b, c) = (6.3 * next(), 6.3 * next(), 6.3 * next());
            let rz = [[a.cos(), -a.sin(), 0.0], [a.sin(), a.cos(), 0.0], [0.0, 0.0, 1.0]];
            let rx = [[1.0, 0.0, 0.0], [0.0, b.cos(), -b.sin()], [0.0, b.sin(), b.cos()]];
            let ry = [[c.cos(), 0.0, c.sin()], [0.0, 1.0, 0.0], [-c.sin(), 0.0, c.cos()]];
            let r = mul(&mul(&rz, &rx), &ry);
            let l = [1e-3 + next(), 2.0 + next(), 4.0 + 1e3 * next()];
            let a = reconstruct(l, r);
            let (values, q) = assert_decomposes(a);
            for k in 0..3 {
                assert!((values[k] - l[k]).abs() < 1e-12 * l[2]);
                let dot: f64 = (0..3).map(|i| q[i][k] * r[i][k]).sum();
                assert!((dot.abs() - 1.0).abs() < 1e-10, "eigenvector {k}: {dot}");
            }
        }
    }
}
