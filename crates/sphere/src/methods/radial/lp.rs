//! A linear program in four unknowns with many constraints: maximise `c . x`
//! subject to `a_i . x <= b_i`, from a feasible start. Row `i` is stored as
//! `[a_i, b_i]`, five numbers in one array so that a pass reads one stream.
//!
//! The active-set form of the primal simplex method. It keeps a feasible `x`
//! and a set of at most four linearly independent rows that are tight at `x`.
//! Each pivot either moves `x` along the projection `d` of `c` onto the null
//! space of the active rows until a new row blocks it (the ratio test, one
//! O(m) pass that runs in parallel), or, when `c` lies in the span of the
//! active rows, computes their multipliers `c = sum lambda_i a_i` and drops a
//! row with `lambda_i < 0` (all `lambda_i >= 0` proves optimality by LP
//! duality). Small QR factorisations of the active rows (modified Gram-Schmidt,
//! applied twice) give `d` and the multipliers without forming normal
//! equations.
//!
//! Many rows can be tight at once (duplicate faces planes, the symmetric
//! optimum of a cube), so steps of length zero happen. After a run of them the
//! choices switch to Bland's rule (smallest row index both for the row to drop
//! and among tied blocking rows), which rules out cycling; slacks below a
//! tolerance count as zero so that ties are exact ties. The iterate stays
//! feasible throughout, so even a run cut short by the pivot limit returns a
//! feasible point.
//!
//! Used by the kernel LP of [`mod@crate::methods::radial::kernel`] (thesis 9.3.1), but it knows
//! nothing of meshes.

use rayon::prelude::*;

/// The objective grows without bound (cannot happen with box rows).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Unbounded;

#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    pub x: [f64; 4],
    pub pivots: usize,
    /// Optimality proven by non-negative multipliers.
    pub optimal: bool,
    /// Rows tight at `x` whose multipliers certify the optimum.
    pub active: Vec<usize>,
}

/// `a . d` must exceed this times `|a| |d|` for row `a` to block a move
/// along `d`: rows closer to parallel to the active ones (duplicate face
/// planes) are treated as dependent, which keeps the active set well
/// conditioned at the price of a violation of at most this relative size.
const PARALLEL_TOL: f64 = 1e-10;
/// Slacks below this count as exactly tight (see the module notes).
const SLACK_TOL: f64 = 1e-14;
/// Multipliers above `-MULT_TOL` count as non-negative.
const MULT_TOL: f64 = 1e-12;
/// Zero-length steps in a row before Bland's rule takes over.
const BLAND_AFTER: usize = 8;

pub fn maximize(
    rows: &[[f64; 5]],
    c: [f64; 4],
    start: [f64; 4],
    max_pivots: usize,
) -> Result<Solution, Unbounded> {
    let c_norm = norm(c);
    let mut x = start;
    let mut active: Vec<usize> = Vec::with_capacity(4);
    let mut stalled = 0usize;
    for pivot in 0..max_pivots {
        let (q, r, dependent) = qr(rows, &active);
        if let Some(j) = dependent {
            active.remove(j);
            continue;
        }
        let mut d = c;
        for _ in 0..2 {
            for qi in &q {
                let h = dot(*qi, d);
                d = axpy(-h, *qi, d);
            }
        }
        let d_norm = norm(d);
        if d_norm > 1e-12 * c_norm {
            let blocking = rows
                .par_iter()
                .enumerate()
                .filter_map(|(i, row)| {
                    let a = lhs(row);
                    let ad = dot(a, d);
                    if ad <= PARALLEL_TOL * norm(a) * d_norm {
                        return None;
                    }
                    let s = slack(row, x);
                    let s = if s < SLACK_TOL * (1.0 + row[4].abs()) { 0.0 } else { s };
                    Some((s / ad, i))
                })
                .min_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)));
            let Some((step, i)) = blocking else { return Err(Unbounded) };
            x = axpy(step, d, x);
            active.push(i);
            stalled = if step == 0.0 { stalled + 1 } else { 0 };
            continue;
        }
        // c lies in the span of the active rows: c = sum_j lambda_j a_j.
        let gamma: Vec<f64> = q.iter().map(|qi| dot(*qi, c)).collect();
        let k = active.len();
        let mut lambda = vec![0.0; k];
        for i in (0..k).rev() {
            let mut s = gamma[i];
            for j in i + 1..k {
                s -= r[i][j] * lambda[j];
            }
            lambda[i] = s / r[i][i];
        }
        let negative = (0..k).filter(|&j| lambda[j] < -MULT_TOL * c_norm);
        let drop = if stalled >= BLAND_AFTER {
            negative.min_by_key(|&j| active[j])
        } else {
            negative
                .min_by(|&i, &j| lambda[i].total_cmp(&lambda[j]).then(active[i].cmp(&active[j])))
        };
        match drop {
            Some(j) => {
                active.remove(j);
            }
            None => return Ok(Solution { x, pivots: pivot, optimal: true, active }),
        }
    }
    Ok(Solution { x, pivots: max_pivots, optimal: false, active })
}

/// Orthonormal `q` and upper-triangular `r` with `a[active[j]] = sum_{i<=j}
/// r[i][j] q[i]`; the position of the first row that is (numerically) in
/// the span of the earlier ones, if any.
#[allow(clippy::type_complexity)]
fn qr(rows: &[[f64; 5]], active: &[usize]) -> (Vec<[f64; 4]>, [[f64; 4]; 4], Option<usize>) {
    let mut q: Vec<[f64; 4]> = Vec::with_capacity(active.len());
    let mut r = [[0.0; 4]; 4];
    for (j, &row) in active.iter().enumerate() {
        let mut v = lhs(&rows[row]);
        for _ in 0..2 {
            for (i, qi) in q.iter().enumerate() {
                let h = dot(*qi, v);
                r[i][j] += h;
                v = axpy(-h, *qi, v);
            }
        }
        let len = norm(v);
        if len.is_nan() || len <= PARALLEL_TOL * norm(lhs(&rows[row])) || j >= 4 {
            return (q, r, Some(j));
        }
        r[j][j] = len;
        q.push(v.map(|x| x / len));
    }
    (q, r, None)
}

/// `b - a . x`: non-negative when the row holds at `x`.
pub fn slack(row: &[f64; 5], x: [f64; 4]) -> f64 {
    row[4] - dot(lhs(row), x)
}

fn lhs(row: &[f64; 5]) -> [f64; 4] {
    [row[0], row[1], row[2], row[3]]
}

fn dot(a: [f64; 4], b: [f64; 4]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
}

fn norm(a: [f64; 4]) -> f64 {
    dot(a, a).sqrt()
}

fn axpy(s: f64, x: [f64; 4], y: [f64; 4]) -> [f64; 4] {
    [y[0] + s * x[0], y[1] + s * x[1], y[2] + s * x[2], y[3] + s * x[3]]
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// splitmix64, for reproducible random instances without a dependency.
    pub(crate) struct Rng(pub(crate) u64);
    impl Rng {
        pub(crate) fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }
        pub(crate) fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * self.next()
        }
    }

    /// The LP optimum by trying every vertex (every 4 rows), O(m^4).
    pub(crate) fn brute_force(rows: &[[f64; 5]], c: [f64; 4]) -> f64 {
        let a: Vec<[f64; 4]> = rows.iter().map(|r| [r[0], r[1], r[2], r[3]]).collect();
        let b: Vec<f64> = rows.iter().map(|r| r[4]).collect();
        let m = a.len();
        let mut best = f64::NEG_INFINITY;
        for i in 0..m {
            for j in i + 1..m {
                for k in j + 1..m {
                    for l in k + 1..m {
                        let Some(x) = solve4([a[i], a[j], a[k], a[l]], [b[i], b[j], b[k], b[l]])
                        else {
                            continue;
                        };
                        if a.iter().zip(&b).all(|(r, &bi)| lp_dot(*r, x) <= bi + 1e-9) {
                            best = best.max(lp_dot(c, x));
                        }
                    }
                }
            }
        }
        best
    }

    /// Gaussian elimination with partial pivoting; None when (nearly) singular.
    fn solve4(mut m: [[f64; 4]; 4], mut r: [f64; 4]) -> Option<[f64; 4]> {
        for col in 0..4 {
            let piv = (col..4).max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))?;
            if m[piv][col].abs() < 1e-9 {
                return None;
            }
            m.swap(col, piv);
            r.swap(col, piv);
            let pivot_row = m[col];
            for row in col + 1..4 {
                let f = m[row][col] / pivot_row[col];
                for (x, p) in m[row].iter_mut().zip(pivot_row).skip(col) {
                    *x -= f * p;
                }
                r[row] -= f * r[col];
            }
        }
        let mut x = [0.0; 4];
        for i in (0..4).rev() {
            x[i] = (r[i] - (i + 1..4).map(|k| m[i][k] * x[k]).sum::<f64>()) / m[i][i];
        }
        Some(x)
    }

    fn lp_dot(a: [f64; 4], b: [f64; 4]) -> f64 {
        a.iter().zip(b).map(|(x, y)| x * y).sum()
    }

    #[test]
    fn lp_matches_brute_force_on_random_instances() {
        let mut rng = Rng(7);
        // Vertex enumeration is O(m^5): fewer trials in unoptimised builds.
        let trials = if cfg!(debug_assertions) { 60 } else { 1000 };
        for trial in 0..trials {
            let n = 3 + trial % 10;
            let mut a = Vec::new();
            let mut b = Vec::new();
            for _ in 0..n {
                a.push([0; 4].map(|_| rng.uniform(-1.0, 1.0)));
                b.push(rng.uniform(0.05, 1.0));
            }
            // Some instances get duplicate rows and rows through one vertex,
            // which make the LP degenerate.
            if trial % 3 == 0 {
                // |r . v| < 0.16 keeps the start x = 0 feasible.
                let v = [0; 4].map(|_| rng.uniform(-0.04, 0.04));
                for _ in 0..4 {
                    let r = [0; 4].map(|_| rng.uniform(-1.0, 1.0));
                    b.push(lp_dot(r, v) + 0.2);
                    a.push(r);
                    a.push(r);
                    b.push(*b.last().unwrap());
                }
            }
            for k in 0..4 {
                let mut e = [0.0; 4];
                e[k] = 1.0;
                a.push(e);
                b.push(2.0);
                e[k] = -1.0;
                a.push(e);
                b.push(2.0);
            }
            let c = [0; 4].map(|_| rng.uniform(-1.0, 1.0));
            let rows: Vec<[f64; 5]> =
                a.iter().zip(&b).map(|(r, &bi)| [r[0], r[1], r[2], r[3], bi]).collect();
            let s = maximize(&rows, c, [0.0; 4], 1000).unwrap();
            assert!(s.optimal, "trial {trial}");
            let worst = rows.iter().map(|r| -slack(r, s.x)).fold(f64::MIN, f64::max);
            assert!(worst <= 1e-12, "trial {trial}: infeasible by {worst}");
            let want = brute_force(&rows, c);
            assert!(
                (lp_dot(c, s.x) - want).abs() < 1e-9,
                "trial {trial}: {} vs {want}",
                lp_dot(c, s.x)
            );
        }
    }

    /// The box `[-2, 2]^4` as rows, for the small LPs below.
    fn boxed(mut rows: Vec<[f64; 5]>) -> Vec<[f64; 5]> {
        for k in 0..4 {
            let mut r = [0.0; 5];
            r[k] = 1.0;
            r[4] = 2.0;
            rows.push(r);
            r[k] = -1.0;
            rows.push(r);
        }
        rows
    }

    #[test]
    fn two_variable_lp_reaches_its_known_vertex() {
        // max x + y  s.t.  x + 2y <= 2,  3x + y <= 3 (x3 = x4 = 0 fixed by
        // the objective's zero weights and the box): optimum (4/5, 3/5).
        let rows = boxed(vec![[1.0, 2.0, 0.0, 0.0, 2.0], [3.0, 1.0, 0.0, 0.0, 3.0]]);
        let s = maximize(&rows, [1.0, 1.0, 0.0, 0.0], [0.0; 4], 100).unwrap();
        assert!(s.optimal);
        assert!((s.x[0] - 0.8).abs() < 1e-12 && (s.x[1] - 0.6).abs() < 1e-12, "{s:?}");
        assert!(s.active.contains(&0) && s.active.contains(&1), "{s:?}");
        assert!(rows.iter().all(|r| slack(r, s.x) >= -1e-14));
    }

    #[test]
    fn an_unbounded_direction_is_reported() {
        // max x subject only to y <= 1: nothing stops x.
        let rows = [[0.0, 1.0, 0.0, 0.0, 1.0]];
        assert_eq!(maximize(&rows, [1.0, 0.0, 0.0, 0.0], [0.0; 4], 100), Err(Unbounded));
    }

    #[test]
    fn a_degenerate_vertex_with_redundant_tight_rows_ends_optimal() {
        // Six rows tight at the optimum (1, 1, 0, 0): x <= 1 twice, y <= 1,
        // x + y <= 2 twice and 2x + y <= 3; only two are needed.
        let rows = boxed(vec![
            [1.0, 0.0, 0.0, 0.0, 1.0],
            [1.0, 0.0, 0.0, 0.0, 1.0],
            [0.0, 1.0, 0.0, 0.0, 1.0],
            [1.0, 1.0, 0.0, 0.0, 2.0],
            [1.0, 1.0, 0.0, 0.0, 2.0],
            [2.0, 1.0, 0.0, 0.0, 3.0],
        ]);
        let s = maximize(&rows, [1.0, 1.0, 0.0, 0.0], [0.0; 4], 100).unwrap();
        assert!(s.optimal, "{s:?}");
        assert!((s.x[0] - 1.0).abs() < 1e-12 && (s.x[1] - 1.0).abs() < 1e-12, "{s:?}");
    }

    #[test]
    fn a_start_at_the_optimum_takes_no_step() {
        let rows = boxed(vec![]);
        let s = maximize(&rows, [0.0, 0.0, 0.0, 1.0], [0.5, -1.0, 0.0, 2.0], 100).unwrap();
        assert!(s.optimal);
        assert_eq!(s.x, [0.5, -1.0, 0.0, 2.0]);
    }
}
