//! A report of the fill-reducing orderings of the sparse Cholesky factor:
//! for AMD, for our nested dissection and for what [`Factor::cholesky`]
//! chooses, the size of `L`, the flops and the seconds of each. Not used by
//! the solvers; `crates/sphere/examples/orderings.rs` prints it for the
//! theta-phi systems of meshes (docs/benchmarks.md, issue 14).
//!
//! Two sizes of `L` are given. `stored` is what faer allocates: its
//! supernodes are dense blocks, relaxed (merged with a few explicit zeros)
//! to make the dense kernels larger, so it is the memory a factor takes.
//! `nnz` is the true count, `sum_j c_j` where `c_j` is the number of
//! nonzeros of column `j` of `L` (diagonal included), from the row subtrees
//! of the elimination tree (Liu 1986; `O(nnz(L))`). `flops` is
//! `sum_j c_j^2`, the usual count of a column Cholesky's floating-point
//! operations (George and Liu 1981; a dense `n x n` factor gives `n^3 / 3`).

use super::bordered;
use super::COMPARE_ORDERINGS_UP_TO;
use super::{is_long, numeric_llt, symbolic_llt, Factor, Ordering, Supernodal};
use crate::error::SparseError;
use crate::nested_dissection::nested_dissection;
use crate::CsrMatrix;
use faer::sparse::linalg::cholesky::SymbolicCholesky;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use std::time::Instant;

/// One ordering's factor of a matrix.
#[derive(Debug, Clone, PartialEq)]
pub struct OrderingStats {
    /// `"amd"`, `"nd"`, or for the factor [`Factor::cholesky`] makes,
    /// `"chosen: amd"`, `"chosen: nd"` or `"chosen: halves"` (two halves
    /// and a dense corner, `direct/bordered.rs`).
    pub name: &'static str,
    /// Values faer stores for `L`, relaxed supernodes included (for the
    /// halves: both halves' factors and the dense corner's lower triangle).
    pub stored: usize,
    /// Nonzeros of `L`, `sum_j c_j`.
    pub nnz: usize,
    /// `sum_j c_j^2`; for the halves, both halves' factors (each with its
    /// part of the separator's corner) plus `ns^3`: the two corner products
    /// `C C^T` (`ns^3 / 3` each) and the dense Cholesky (`ns^3 / 3`).
    pub flops: f64,
    /// Seconds of the ordering and the symbolic factorisation; for the
    /// chosen factor, of everything but the numeric factorisation of the
    /// whole matrix (for the halves, all of it: see `numeric_seconds`).
    pub order_seconds: f64,
    /// Seconds of the numeric factorisation (0 for the halves, whose
    /// ordering and factorisation run together on two cores: all of it is
    /// in `order_seconds`).
    pub numeric_seconds: f64,
}

/// AMD, nested dissection, and the factor [`Factor::cholesky`] chooses, of
/// `a` (symmetric positive definite, CSR with 32-bit offsets: a theta-phi
/// system up to ~100M stored entries). Each factor is computed (numeric
/// included) and dropped before the next.
///
/// Errors: [`SparseError::NotPositiveDefinite`] on a non-positive pivot,
/// [`SparseError::Factorization`] when the matrix or a factor does not fit
/// 32-bit indices.
pub fn ordering_report(a: &CsrMatrix) -> Result<Vec<OrderingStats>, SparseError> {
    let n = a.n_rows();
    let col_ptr = a
        .row_offsets()
        .iter()
        .map(|&o| u32::try_from(o))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|_| too_large())?;
    // The CSR arrays read as CSC are A^T = A (as in `Factor::cholesky`).
    let pattern = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, a.col_indices());
    let m = SparseColMatRef::new(pattern, a.values());
    let (offsets, indices) = (a.row_offsets(), a.col_indices());

    let whole = |name: &'static str, ordering: &dyn Fn() -> Option<Vec<u32>>| {
        let clock = Instant::now();
        let perm = ordering();
        let symbolic = symbolic_llt(
            pattern,
            perm.as_deref().map_or(Ordering::Amd, Ordering::Custom),
            Supernodal::FaerChooses,
        )?
        .ok_or_else(too_large)?;
        let order_seconds = clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        drop(numeric_llt(&symbolic, m)?);
        let numeric_seconds = clock.elapsed().as_secs_f64();
        let perm = perm.unwrap_or_else(|| faer_order(&symbolic));
        let counts = column_counts(offsets, indices, &perm);
        Ok::<_, SparseError>(OrderingStats {
            name,
            stored: symbolic.len_val(),
            nnz: counts.iter().sum(),
            flops: counts.iter().map(|&c| (c as f64) * (c as f64)).sum(),
            order_seconds,
            numeric_seconds,
        })
    };
    let amd = whole("amd", &|| None)?;
    let nd = whole("nd", &|| Some(nested_dissection(offsets, indices)))?;

    // What `Factor::cholesky` and `analyse` do, step by step.
    let chosen = if n > COMPARE_ORDERINGS_UP_TO {
        let clock = Instant::now();
        bordered::factor(a)?.map(|halves| halves_stats(a, &halves, clock.elapsed().as_secs_f64()))
    } else {
        None
    };
    let chosen = match chosen {
        Some(halves) => halves,
        None => {
            let nd_wins = if n <= COMPARE_ORDERINGS_UP_TO {
                // `analyse` keeps AMD only when its factor is strictly smaller.
                amd.stored >= nd.stored
            } else {
                is_long(offsets, indices)
            };
            // Time the real call; its factor is the one of the row copied.
            let clock = Instant::now();
            drop(Factor::cholesky(a)?);
            let total = clock.elapsed().as_secs_f64();
            let (name, like) = if nd_wins { ("chosen: nd", &nd) } else { ("chosen: amd", &amd) };
            OrderingStats {
                name,
                order_seconds: total - like.numeric_seconds.min(total),
                ..like.clone()
            }
        }
    };
    Ok(vec![amd, nd, chosen])
}

/// The report's figures of a two-halves factor that took `seconds` in all.
fn halves_stats(a: &CsrMatrix, halves: &bordered::Bordered, seconds: f64) -> OrderingStats {
    let ns = halves.separator_len();
    let mut stats = OrderingStats {
        name: "chosen: halves",
        stored: ns * (ns + 1) / 2,
        nnz: ns * (ns + 1) / 2,
        flops: (ns as f64).powi(3),
        order_seconds: seconds,
        numeric_seconds: 0.0,
    };
    for (rows, n_own, symbolic) in halves.halves() {
        let counts = column_counts(a.row_offsets(), a.col_indices(), rows);
        stats.stored += symbolic.len_val();
        // The corner's columns of each half are summed into the dense corner.
        stats.nnz += counts[..n_own].iter().sum::<usize>();
        stats.flops += counts.iter().map(|&c| (c as f64) * (c as f64)).sum::<f64>();
    }
    stats
}

/// faer's fill-reducing permutation of a symbolic factor: `perm[k]` = the
/// row eliminated `k`-th (the identity when it has none).
fn faer_order(symbolic: &SymbolicCholesky<u32>) -> Vec<u32> {
    match symbolic.perm() {
        Some(perm) => perm.arrays().0.to_vec(),
        None => (0..symbolic.nrows() as u32).collect(),
    }
}

fn too_large() -> SparseError {
    SparseError::Factorization { detail: "the ordering report takes 32-bit indices only".into() }
}

/// Column counts `c_j` (diagonal included) of the Cholesky factor of the
/// principal submatrix of the graph (CSR `offsets`, `indices`) on the
/// vertices `order`, eliminated in that order. Row `k` of `L` is the
/// subtree of the elimination tree spanned by the neighbours `i < k` of
/// vertex `k` and their paths up to `k` (Liu 1986); walking those paths
/// without compression counts each nonzero once and builds the tree as it
/// goes (a node with no parent yet is a root of the columns before `k`,
/// whose parent is then `k`).
pub(crate) fn column_counts(offsets: &[usize], indices: &[u32], order: &[u32]) -> Vec<usize> {
    const NONE: u32 = u32::MAX;
    let m = order.len();
    let mut local = vec![NONE; offsets.len().saturating_sub(1)];
    for (k, &v) in order.iter().enumerate() {
        local[v as usize] = k as u32;
    }
    let mut parent = vec![NONE; m];
    let mut mark = vec![NONE; m];
    let mut counts = vec![1usize; m];
    for (k, &v) in order.iter().enumerate() {
        let k = k as u32;
        mark[k as usize] = k;
        for &w in &indices[offsets[v as usize]..offsets[v as usize + 1]] {
            let mut j = local[w as usize];
            if j == NONE || j >= k {
                continue;
            }
            while mark[j as usize] != k {
                mark[j as usize] = k;
                counts[j as usize] += 1;
                if parent[j as usize] == NONE {
                    parent[j as usize] = k;
                }
                j = parent[j as usize];
            }
        }
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::grid_laplacian;

    /// Column counts by symbolic elimination with sets, for small matrices.
    fn counts_by_sets(a: &CsrMatrix, order: &[u32]) -> Vec<usize> {
        let m = order.len();
        let mut local = vec![usize::MAX; a.n_rows()];
        for (k, &v) in order.iter().enumerate() {
            local[v as usize] = k;
        }
        let mut cols: Vec<std::collections::BTreeSet<usize>> = vec![Default::default(); m];
        for (k, &v) in order.iter().enumerate() {
            for &w in a.row(v as usize).0 {
                let i = local[w as usize];
                if i != usize::MAX && i > k {
                    cols[k].insert(i);
                }
            }
        }
        let mut counts = vec![0; m];
        for k in 0..m {
            let below: Vec<usize> = cols[k].iter().copied().collect();
            counts[k] = below.len() + 1;
            if let Some((&parent, rest)) = below.split_first() {
                cols[parent].extend(rest.iter().copied());
            }
        }
        counts
    }

    #[test]
    fn column_counts_match_elimination() {
        let a = grid_laplacian(13, 11);
        let n = a.n_rows() as u32;
        // Natural, a scrambled order, and a subset (a principal submatrix).
        let natural: Vec<u32> = (0..n).collect();
        let scrambled: Vec<u32> = (0..n).map(|k| (k * 37) % n).collect();
        let subset: Vec<u32> = (0..n).filter(|k| k % 5 != 2).rev().collect();
        for order in [natural, scrambled, subset] {
            assert_eq!(
                column_counts(a.row_offsets(), a.col_indices(), &order),
                counts_by_sets(&a, &order)
            );
        }
    }

    #[test]
    fn report_rows_agree_with_each_other() {
        let a = grid_laplacian(70, 60);
        let rows = ordering_report(&a).unwrap();
        assert_eq!(rows.len(), 3);
        let (amd, nd, chosen) = (&rows[0], &rows[1], &rows[2]);
        for r in &rows {
            // Relaxed supernodes store at least the true nonzeros.
            assert!(r.stored >= r.nnz && r.nnz >= a.n_rows(), "{r:?}");
            assert!(r.flops >= r.nnz as f64);
        }
        let like = if amd.stored < nd.stored { amd } else { nd };
        assert_eq!((chosen.stored, chosen.nnz), (like.stored, like.nnz));
        assert!(chosen.name.ends_with(like.name));
    }

    #[test]
    fn halves_count_both_factors_and_the_corner() {
        let a = grid_laplacian(60, 60);
        let halves = bordered::factor(&a).unwrap().unwrap();
        let stats = halves_stats(&a, &halves, 0.0);
        let ns = halves.separator_len();
        // The same unknowns eliminated as one matrix: the halves' own
        // columns are the same, the corner is taken dense.
        let [(r1, n1, _), (r2, n2, _)] = halves.halves();
        let order: Vec<u32> = r1[..n1].iter().chain(&r2[..n2]).chain(&r1[n1..]).copied().collect();
        let whole = column_counts(a.row_offsets(), a.col_indices(), &order);
        let own: usize = whole[..n1 + n2].iter().sum();
        assert_eq!(stats.nnz, own + ns * (ns + 1) / 2);
        assert!(stats.stored >= stats.nnz);
        assert!(stats.flops > (ns as f64).powi(3));
    }
}
