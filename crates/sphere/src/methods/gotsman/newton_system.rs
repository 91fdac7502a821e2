//! The equations of Gotsman, Gu and Sheffer's embedding (thesis eq. 5.10)
//! and their Newton step on the tangent unknowns (see the module
//! documentation of [`super`], "How it is solved").

use rayon::prelude::*;
use spherify_mesh::vec3::{cross, dot as dot3};
use spherify_sparse::{solve, CsrMatrix, SolveParams, SolverKind, SparseError};

/// `u_i = sum_j w_ij v_j` for the points of the interleaved state `x`
/// (`(v_i, alpha_i)` per vertex), as `3n` values.
pub(super) fn neighbour_means(w: &CsrMatrix, x: &[f64]) -> Vec<f64> {
    let mut u = vec![0.0; 3 * w.n_rows()];
    u.par_chunks_mut(3).enumerate().for_each(|(i, ui)| {
        let (cols, vals) = w.row(i);
        for (&j, &wij) in cols.iter().zip(vals) {
            let j = j as usize;
            (0..3).for_each(|k| ui[k] += wij * x[4 * j + k]);
        }
    });
    u
}

/// `(F_i, G_i)` for every vertex, interleaved like the unknowns.
pub(super) fn residual(w: &CsrMatrix, x: &[f64]) -> Vec<f64> {
    let u = neighbour_means(w, x);
    let mut f = vec![0.0; x.len()];
    f.par_chunks_mut(4).enumerate().for_each(|(i, fi)| {
        let (v, alpha) = (&x[4 * i..4 * i + 3], x[4 * i + 3]);
        (0..3).for_each(|k| fi[k] = u[3 * i + k] - alpha * v[k]);
        fi[3] = 0.5 * (dot3(xyz(v), xyz(v)) - 1.0);
    });
    f
}

/// The Jacobian of [`residual`]: unknowns and equations are both ordered
/// `(x_i, y_i, z_i, alpha_i)` per vertex, which keeps each vertex's block
/// together. Row `4i + k` (k < 3): `w_ij` at `4j + k`, `-alpha_i` at `4i + k`,
/// `-v_ik` at `4i + 3`; row `4i + 3`: `v_i^T` at `4i..4i + 3`.
pub(super) fn jacobian(w: &CsrMatrix, x: &[f64]) -> Result<CsrMatrix, SparseError> {
    let n = w.n_rows();
    let nnz = 3 * w.nnz() + 9 * n;
    let (mut rows, mut cols, mut values) =
        (Vec::with_capacity(nnz), Vec::with_capacity(nnz), Vec::with_capacity(nnz));
    let mut push = |r: usize, c: usize, v: f64| {
        rows.push(r as u32);
        cols.push(c as u32);
        values.push(v);
    };
    for i in 0..n {
        let (nbrs, ws) = w.row(i);
        for k in 0..3 {
            for (&j, &wij) in nbrs.iter().zip(ws) {
                push(4 * i + k, 4 * j as usize + k, wij);
            }
            push(4 * i + k, 4 * i + k, -x[4 * i + 3]);
            push(4 * i + k, 4 * i + 3, -x[4 * i + k]);
            push(4 * i + 3, 4 * i + k, x[4 * i + k]);
        }
    }
    CsrMatrix::from_triplets(4 * n, 4 * n, &rows, &cols, &values)
}

/// The Newton step `-J^-1 (F, G)` of eq. 5.10, computed on the `2n` tangent
/// unknowns instead of the `4n` of `J` (module documentation, "How it is
/// solved"). Returns `None` when the reduced matrix is singular or the step
/// is not finite.
pub(super) fn newton_step(
    w: &CsrMatrix,
    x: &[f64],
    f: &[f64],
) -> Result<Option<Vec<f64>>, SparseError> {
    let n = w.n_rows();
    let v = |i: usize| [x[4 * i], x[4 * i + 1], x[4 * i + 2]];
    // Orthonormal tangent basis (t1, t2) at each point.
    let bases: Vec<[[f64; 3]; 2]> = (0..n).into_par_iter().map(|i| tangent_basis(v(i))).collect();
    // c_i: the part of the step along v_i that the G row fixes.
    let normal: Vec<[f64; 3]> = (0..n)
        .into_par_iter()
        .map(|i| {
            let vi = v(i);
            let s = -f[4 * i + 3] / dot3(vi, vi);
            vi.map(|c| s * c)
        })
        .collect();
    // b_i = -F_i - sum_j w_ij c_j + alpha_i c_i; the right-hand side is T_i^T b_i.
    let b: Vec<[f64; 3]> = (0..n)
        .into_par_iter()
        .map(|i| {
            let (cols, ws) = w.row(i);
            let mut bi = [0.0; 3];
            for (&j, &wij) in cols.iter().zip(ws) {
                (0..3).for_each(|k| bi[k] -= wij * normal[j as usize][k]);
            }
            (0..3).for_each(|k| bi[k] += x[4 * i + 3] * normal[i][k] - f[4 * i + k]);
            bi
        })
        .collect();
    let rhs: Vec<f64> =
        (0..n).flat_map(|i| [dot3(bases[i][0], b[i]), dot3(bases[i][1], b[i])]).collect();
    let reduced = reduced_matrix(w, x, &bases)?;
    let t = match solve(&reduced, &[rhs], SolverKind::Auto, &SolveParams::default()) {
        Ok((mut t, _)) => match t.pop() {
            Some(t) if t.len() == 2 * n => t,
            _ => return Ok(None),
        },
        // Singular, or not finite because a point reached the origin (no
        // tangent plane): no Newton step here, the Cauchy point remains.
        Err(SparseError::Singular { .. } | SparseError::NonFinite { .. }) => return Ok(None),
        Err(e) => return Err(e),
    };
    // delta v_i = c_i + T_i t_i; delta alpha_i from the F row along v_i.
    let mut step = vec![0.0; 4 * n];
    for i in 0..n {
        let [t1, t2] = bases[i];
        (0..3)
            .for_each(|k| step[4 * i + k] = normal[i][k] + t[2 * i] * t1[k] + t[2 * i + 1] * t2[k]);
    }
    let alpha_steps: Vec<f64> = (0..n)
        .into_par_iter()
        .map(|i| {
            let vi = v(i);
            let (cols, ws) = w.row(i);
            let mut along = 0.0;
            for (&j, &wij) in cols.iter().zip(ws) {
                let j = j as usize;
                along += wij
                    * dot3(
                        vi,
                        [
                            step[4 * j] - normal[j][0],
                            step[4 * j + 1] - normal[j][1],
                            step[4 * j + 2] - normal[j][2],
                        ],
                    );
            }
            (along - dot3(vi, b[i])) / dot3(vi, vi)
        })
        .collect();
    for (i, a) in alpha_steps.into_iter().enumerate() {
        step[4 * i + 3] = a;
    }
    Ok(step.iter().all(|s| s.is_finite()).then_some(step))
}

/// The `2n x 2n` matrix of the tangent unknowns of [`newton_step`]: block
/// `(i, j)` is `w_ij T_i^T T_j`, and the diagonal gets `-alpha_i`.
fn reduced_matrix(
    w: &CsrMatrix,
    x: &[f64],
    bases: &[[[f64; 3]; 2]],
) -> Result<CsrMatrix, SparseError> {
    let n = w.n_rows();
    let nnz = 4 * w.nnz() + 2 * n;
    let (mut rows, mut cols, mut values) =
        (Vec::with_capacity(nnz), Vec::with_capacity(nnz), Vec::with_capacity(nnz));
    for i in 0..n {
        let (nbrs, ws) = w.row(i);
        for a in 0..2 {
            let row = (2 * i + a) as u32;
            for (&j, &wij) in nbrs.iter().zip(ws) {
                for c in 0..2 {
                    rows.push(row);
                    cols.push(2 * j + c as u32);
                    values.push(wij * dot3(bases[i][a], bases[j as usize][c]));
                }
            }
            rows.push(row);
            cols.push(row);
            values.push(-x[4 * i + 3]);
        }
    }
    CsrMatrix::from_triplets(2 * n, 2 * n, &rows, &cols, &values)
}

/// An orthonormal basis of the plane perpendicular to `v` (not zero).
pub(super) fn tangent_basis(v: [f64; 3]) -> [[f64; 3]; 2] {
    let len = dot3(v, v).sqrt();
    let u = v.map(|c| c / len);
    // Cross with the axis least aligned with u, which is never parallel to it.
    let k = (0..3).min_by(|&a, &b| u[a].abs().total_cmp(&u[b].abs())).unwrap_or(0);
    let mut axis = [0.0; 3];
    axis[k] = 1.0;
    let t1 = cross(axis, u);
    let l1 = dot3(t1, t1).sqrt();
    let t1 = t1.map(|c| c / l1);
    [t1, cross(u, t1)]
}

/// The point part `(x, y, z)` of a vertex's `(x, y, z, alpha)`.
pub(super) fn xyz(v: &[f64]) -> [f64; 3] {
    [v[0], v[1], v[2]]
}
