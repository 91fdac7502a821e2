//! Sparse Cholesky in two independent halves and a dense corner: the first
//! cut of nested dissection done by block elimination, so that two cores
//! factor at once.
//!
//! faer's supernodal factorisation walks the supernodes one after the other
//! and parallelises only inside the dense kernels of each, which on a mesh's
//! factor are tiny: at a million unknowns it keeps one core busy. A vertex
//! separator `S` cuts the graph into halves `1` and `2` with no edge between
//! them (`crate::nested_dissection::bisection`), so with the unknowns in the
//! order (1, 2, S) the matrix is doubly bordered block diagonal (George 1973;
//! George and Liu, "Computer Solution of Large Sparse Positive Definite
//! Systems", 1981, ch. 8):
//!
//! ```text
//!     | A11  0   A1S |        | L11  0    0  |
//! A = |  0  A22  A2S |,   L = |  0  L22   0  |,   S = ASS - LS1 LS1^T - LS2 LS2^T = LSS LSS^T.
//!     | AS1 AS2  ASS |        | LS1 LS2  LSS |
//! ```
//!
//! Each half is factored on its own core as the principal submatrix
//! `Mh = [Ahh AhS; AShh ASS]` (symmetric positive definite whenever `A` is),
//! with the separator ordered last: its factor is `[Lhh 0; LSh Ch]` with
//! `Ch Ch^T = ASS - LSh LSh^T`. So `S = C1 C1^T + C2 C2^T - ASS`, a dense
//! matrix of the separator's size (a ring of about `sqrt n` vertices on a
//! mesh), factored by a dense Cholesky.
//!
//! Solving `A x = b` uses only the triangular solves of each half's factor:
//! the forward solve of `Mh` with `[bh; 0]` gives `yh = Lhh^-1 bh` and, in
//! the separator rows, `-Ch^-1 LSh yh`, from which `LSh yh` is one product
//! with `Ch`; then `S xS = bS - LS1 y1 - LS2 y2`, and the backward solve of
//! `Mh` with `[yh; Ch^T xS]` gives `xh = Lhh^-T (yh - LSh^T xS)`. Both halves
//! solve in parallel, both right-hand sides at once.
//!
//! Inside each half the order is nested dissection of the half's own graph
//! (`crate::nested_dissection`), whatever the shape. AMD, which the whole
//! matrix takes on round shapes, does not know that the separator comes
//! last: on the 1M bumpy blob's theta-phi system the halves' factors had
//! 105M entries with AMD of each half alone and 99M with AMD of each `Mh`
//! and the separator moved last, against 82M with nested dissection (76M
//! for AMD of the whole matrix).

use super::{factor_par, numeric_llt, scratch, symbolic_llt, Ordering, Supernodal};
use crate::error::SparseError;
use crate::nested_dissection::{bisection, nested_dissection, prefetch_rows_ahead};
use crate::CsrMatrix;
use faer::dyn_stack::MemStack;
use faer::linalg::matmul::triangular::{matmul, BlockStructure};
use faer::linalg::solvers::{Llt, Solve};
use faer::sparse::linalg::cholesky::supernodal::{SupernodalLltRef, SymbolicSupernodalCholesky};
use faer::sparse::linalg::cholesky::{SymbolicCholesky, SymbolicCholeskyRaw};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Accum, Conj, Mat, MatMut, MatRef, Par, Side};

/// The largest separator taken, against the number of unknowns `n`: the
/// dense corner has `ns^2` entries, held beside a factor of tens of entries
/// per unknown; `ns^2 <= 4 n` keeps it under a tenth of that (a mesh's
/// separators are about `sqrt n`, 1,000-2,000 vertices at a million).
const CORNER_PER_UNKNOWN: usize = 4;

/// `A = P^T L L^T P` by halves and a dense corner (module comment).
pub(crate) struct Bordered {
    halves: [Half; 2],
    /// The separator's rows of `A`, in the corner's order.
    separator: Vec<u32>,
    /// Dense Cholesky factor of the separator's Schur complement.
    corner: Llt<f64>,
}

/// One half's principal submatrix `Mh` factored, its own unknowns first.
struct Half {
    /// The row of `A` of each unknown of `Mh`: the half's own, then the separator's.
    rows: Vec<u32>,
    n_own: usize,
    symbolic: SymbolicCholesky<u32>,
    values: Vec<f64>,
}

/// Factors `a` (symmetric, the CSR arrays of a structurally symmetric
/// matrix) in two halves. `None` when the graph does not cut
/// well (disconnected, too short, or a separator too large for a dense
/// corner) or a half's factor needs more than 32-bit indices: the caller
/// factors the whole matrix then.
///
/// Errors: [`SparseError::NotPositiveDefinite`] on a non-positive pivot.
pub(crate) fn factor(a: &CsrMatrix) -> Result<Option<Bordered>, SparseError> {
    let n = a.n_rows();
    let Some(cut) = bisection(a.row_offsets(), a.col_indices()) else {
        return Ok(None);
    };
    let ns = cut.n_separator;
    if ns.saturating_mul(ns) > CORNER_PER_UNKNOWN * n {
        return Ok(None);
    }
    let separator = cut.vs[n - ns..].to_vec();
    let near = &cut.vs[..cut.n_near];
    let far = &cut.vs[cut.n_near..n - ns];
    let (h1, h2) =
        rayon::join(|| Half::factor(a, near, &separator), || Half::factor(a, far, &separator));
    let (Some(h1), Some(h2)) = (h1?, h2?) else {
        return Ok(None);
    };
    let corner = corner(a, [&h1, &h2], &separator)?;
    Ok(Some(Bordered { halves: [h1, h2], separator, corner }))
}

/// The dense Cholesky factor of the separator's Schur complement
/// `S = C1 C1^T + C2 C2^T - ASS` (module comment), from the halves' factors.
///
/// Errors: [`SparseError::NotPositiveDefinite`] on a non-positive pivot.
fn corner(a: &CsrMatrix, halves: [&Half; 2], separator: &[u32]) -> Result<Llt<f64>, SparseError> {
    let (n, ns) = (a.n_rows(), separator.len());
    // S = C1 C1^T + C2 C2^T - ASS, lower triangle only.
    let mut s = Mat::<f64>::zeros(ns, ns);
    for (h, beta) in [(halves[0], Accum::Replace), (halves[1], Accum::Add)] {
        let c = h.corner_dense();
        matmul(
            s.as_mut(),
            BlockStructure::TriangularLower,
            beta,
            c.as_ref(),
            BlockStructure::TriangularLower,
            c.transpose(),
            BlockStructure::TriangularUpper,
            1.0,
            factor_par(),
        );
    }
    // ASS, from the separator's rows of A.
    let mut local = vec![u32::MAX; n];
    for (t, &v) in separator.iter().enumerate() {
        local[v as usize] = t as u32;
    }
    for (t, &v) in separator.iter().enumerate() {
        let (cols, vals) = a.row(v as usize);
        for (&w, &x) in cols.iter().zip(vals) {
            let u = local[w as usize];
            if u != u32::MAX && u as usize >= t {
                s[(u as usize, t)] -= x;
            }
        }
    }
    s.llt(Side::Lower)
        .map_err(|_| SparseError::NotPositiveDefinite { method: "sparse Cholesky pivot" })
}

/// Which triangle of a half's matrix [`Triangle::of`] keeps.
#[derive(Clone, Copy, PartialEq)]
enum Part {
    /// Column `j` keeps rows `i <= j`; pattern only (what faer's symbolic analysis reads).
    Upper,
    /// Column `j` keeps rows `i >= j`, with values (what its numeric factorisation reads).
    Lower,
}

/// One triangle of a half's matrix `M` in compressed columns, 32-bit indices.
struct Triangle {
    col_ptr: Vec<u32>,
    row_idx: Vec<u32>,
    /// Empty for [`Part::Upper`].
    values: Vec<f64>,
}

impl Triangle {
    /// The `part` triangle of `M`, the `size x size` principal submatrix of
    /// `a` whose row `local[v]` is row `v` of `a` (`u32::MAX` outside it).
    /// `M` is symmetric, so its column `j` is its row `j`. `a`'s rows are
    /// read in their own order, once to count each column and once to fill
    /// it, and each column is then sorted: reading them in `M`'s (nested
    /// dissection) order instead jumps through `a` at random, 0.15-0.2 s per
    /// triangle and half at a million unknowns. The arrays have their exact
    /// size. `None` when `M`'s entries do not fit 32 bits.
    fn of(a: &CsrMatrix, local: &[u32], size: usize, part: Part) -> Option<Triangle> {
        let keep = |r: u32, u: u32| {
            u != u32::MAX
                && match part {
                    Part::Upper => u <= r,
                    Part::Lower => u >= r,
                }
        };
        let mut col_ptr = vec![0u32; size + 1];
        let mut nnz = 0usize;
        for (v, &r) in local.iter().enumerate() {
            if r != u32::MAX {
                let count = a.row(v).0.iter().filter(|&&w| keep(r, local[w as usize])).count();
                // At most a row's length, which is below `size`.
                col_ptr[r as usize + 1] = count as u32;
                nnz += count;
            }
        }
        u32::try_from(nnz).ok()?;
        for j in 0..size {
            col_ptr[j + 1] += col_ptr[j];
        }
        let with_values = part == Part::Lower;
        let mut row_idx = vec![0u32; nnz];
        let mut values = vec![0.0; if with_values { nnz } else { 0 }];
        let mut next = col_ptr[..size].to_vec();
        for (v, &r) in local.iter().enumerate() {
            if r == u32::MAX {
                continue;
            }
            let (cols, vals) = a.row(v);
            for (&w, &x) in cols.iter().zip(vals) {
                let u = local[w as usize];
                if keep(r, u) {
                    let k = next[r as usize] as usize;
                    row_idx[k] = u;
                    if with_values {
                        values[k] = x;
                    }
                    next[r as usize] += 1;
                }
            }
        }
        drop(next);
        let mut column: Vec<(u32, f64)> = Vec::new();
        for j in 0..size {
            let range = col_ptr[j] as usize..col_ptr[j + 1] as usize;
            column.clear();
            column.extend(
                range.clone().map(|k| (row_idx[k], if with_values { values[k] } else { 0.0 })),
            );
            column.sort_unstable_by_key(|&(u, _)| u);
            for (k, (u, x)) in range.zip(column.iter().copied()) {
                row_idx[k] = u;
                if with_values {
                    values[k] = x;
                }
            }
        }
        Some(Triangle { col_ptr, row_idx, values })
    }

    fn pattern(&self, size: usize) -> SymbolicSparseColMatRef<'_, u32> {
        // `new_checked` asserts what `of` builds: offsets from 0 to nnz,
        // sorted unique indices within range (a panic is caught by `guarded`).
        SymbolicSparseColMatRef::new_checked(size, size, &self.col_ptr, None, &self.row_idx)
    }
}

impl Half {
    /// Orders `own` by nested dissection of its own graph, then builds `M`
    /// on `own` then `separator` in that order (so faer factors it as it is,
    /// with no permuted copy) and factors it.
    fn factor(a: &CsrMatrix, own: &[u32], separator: &[u32]) -> Result<Option<Half>, SparseError> {
        let n_own = own.len();
        let mut local = vec![u32::MAX; a.n_rows()];
        for (r, &v) in own.iter().enumerate() {
            local[v as usize] = r as u32;
        }
        let order = {
            let mut offsets = Vec::with_capacity(n_own + 1);
            let mut indices = Vec::with_capacity(a.nnz() * n_own / a.n_rows().max(1));
            offsets.push(0usize);
            let (row_offsets, col_indices) = (a.row_offsets(), a.col_indices());
            for (i, &v) in own.iter().enumerate() {
                // `own` runs in the first cut's search order and the rows in
                // the mesh's (measured on the 1M capped disk: 0.03 s to
                // 0.02 s a half).
                prefetch_rows_ahead(row_offsets, col_indices, own, i);
                indices.extend(
                    a.row(v as usize)
                        .0
                        .iter()
                        .map(|&w| local[w as usize])
                        .filter(|&u| u != u32::MAX),
                );
                offsets.push(indices.len());
            }
            nested_dissection(&offsets, &indices)
        };
        let rows: Vec<u32> =
            order.iter().map(|&r| own[r as usize]).chain(separator.iter().copied()).collect();
        drop(order);
        local.fill(u32::MAX);
        for (r, &v) in rows.iter().enumerate() {
            local[v as usize] = r as u32;
        }
        // With no permutation faer's symbolic analysis reads the upper
        // triangle and its numeric factorisation the lower one. Each is built
        // only when it is read, with 32-bit offsets, so that the half's
        // matrix during the factorisation (the memory peak) is its lower
        // triangle alone: about half of the CSR matrix with both triangles
        // and 64-bit offsets that this replaced (about 40 MB less for both
        // halves of a million unknowns).
        let size = rows.len();
        let symbolic = {
            let Some(upper) = Triangle::of(a, &local, size, Part::Upper) else {
                return Ok(None);
            };
            let pattern = upper.pattern(size);
            match symbolic_llt(pattern, Ordering::AsGiven, Supernodal::Always)? {
                Some(symbolic) => symbolic,
                None => return Ok(None),
            }
        };
        if !matches!(symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_)) {
            // Forced above; a faer that ignored it would land here.
            return Ok(None);
        }
        let Some(lower) = Triangle::of(a, &local, size, Part::Lower) else {
            return Ok(None);
        };
        drop(local);
        let values =
            numeric_llt(&symbolic, SparseColMatRef::new(lower.pattern(size), &lower.values))?;
        Ok(Some(Half { rows, n_own, symbolic, values }))
    }

    /// The numeric factorisation of this half's `M` again, from the values
    /// of `a`, whose pattern is the one this half was analysed on (the
    /// caller's promise, see [`Bordered::refactor`]): the ordering and the
    /// symbolic analysis are kept.
    fn refactor(&mut self, a: &CsrMatrix) -> Result<(), SparseError> {
        let size = self.rows.len();
        let mut local = vec![u32::MAX; a.n_rows()];
        for (r, &v) in self.rows.iter().enumerate() {
            local[v as usize] = r as u32;
        }
        // The same pattern fitted 32 bits when the half was first factored.
        let lower = Triangle::of(a, &local, size, Part::Lower).ok_or_else(|| {
            SparseError::Factorization { detail: "a half's matrix no longer fits 32 bits".into() }
        })?;
        drop(local);
        // The old values go first: two factors side by side would be the peak.
        self.values = Vec::new();
        self.values =
            numeric_llt(&self.symbolic, SparseColMatRef::new(lower.pattern(size), &lower.values))?;
        Ok(())
    }

    fn supernodal(&self) -> &SymbolicSupernodalCholesky<u32> {
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => s,
            // `Half::factor` keeps supernodal factors only.
            SymbolicCholeskyRaw::Simplicial(_) => unreachable!("a half's factor is supernodal"),
        }
    }

    /// Calls `visit(i, j, value)` for every entry `C[i, j]` (`i >= j`) of the
    /// separator's corner `C` of this half's factor, read where faer keeps it
    /// (supernodes may start among the half's own columns).
    fn for_each_corner_entry(&self, mut visit: impl FnMut(usize, usize, f64)) {
        let symbolic = self.supernodal();
        let llt = SupernodalLltRef::new(symbolic, &self.values);
        let n_own = self.n_own;
        for s in 0..symbolic.n_supernodes() {
            let node = llt.supernode(s);
            let (start, val) = (node.start(), node.val());
            let ncols = val.ncols();
            for jj in n_own.saturating_sub(start)..ncols {
                let j = start + jj - n_own;
                for ii in jj..ncols {
                    visit(start + ii - n_own, j, val[(ii, jj)]);
                }
                for (idx, &i) in node.pattern().iter().enumerate() {
                    visit(i as usize - n_own, j, val[(ncols + idx, jj)]);
                }
            }
        }
    }

    /// The corner `C` as a dense lower-triangular matrix.
    fn corner_dense(&self) -> Mat<f64> {
        let ns = self.rows.len() - self.n_own;
        let mut c = Mat::zeros(ns, ns);
        self.for_each_corner_entry(|i, j, x| c[(i, j)] = x);
        c
    }

    /// `C z` (or `C^T z` when `transpose`), for every column of `z`.
    fn corner_mul(&self, z: MatRef<'_, f64>, transpose: bool) -> Mat<f64> {
        let mut out = Mat::zeros(z.nrows(), z.ncols());
        let k = z.ncols();
        self.for_each_corner_entry(|i, j, x| {
            let (to, from) = if transpose { (j, i) } else { (i, j) };
            for c in 0..k {
                out[(to, c)] += x * z[(from, c)];
            }
        });
        out
    }

    /// The forward solve of `M` with `[b_own; 0]` (`b(row of A, column)`, `k` columns), and
    /// `LS y = -C` times its separator part.
    fn forward(
        &self,
        k: usize,
        b: &(dyn Fn(usize, usize) -> f64 + Sync),
    ) -> Result<(Mat<f64>, Mat<f64>), SparseError> {
        let symbolic = self.supernodal();
        let n_own = self.n_own;
        let mut z = Mat::from_fn(self.rows.len(), k, |i, j| {
            if i < n_own {
                b(self.rows[i] as usize, j)
            } else {
                0.0
            }
        });
        let mut mem = scratch(symbolic.solve_in_place_scratch::<f64>(k, Par::Seq))?;
        SupernodalLltRef::new(symbolic, &self.values).l_solve_with_conj(
            Conj::No,
            z.as_mut(),
            Par::Seq,
            MemStack::new(&mut mem),
        );
        let mut ly = self.corner_mul(z.as_ref().subrows(n_own, self.rows.len() - n_own), false);
        for x in ly.col_iter_mut().flat_map(|c| c.iter_mut()) {
            *x = -*x;
        }
        Ok((z, ly))
    }

    /// The backward solve of `M` from the forward solution `z` with the
    /// separator's solution `xs`: this half's own unknowns come first, in `rows` order.
    fn backward(&self, mut z: Mat<f64>, xs: MatRef<'_, f64>) -> Result<Mat<f64>, SparseError> {
        let symbolic = self.supernodal();
        let n_own = self.n_own;
        let t = self.corner_mul(xs, true);
        z.as_mut().subrows_mut(n_own, t.nrows()).copy_from(&t);
        let mut mem = scratch(symbolic.solve_in_place_scratch::<f64>(z.ncols(), Par::Seq))?;
        SupernodalLltRef::new(symbolic, &self.values).l_transpose_solve_with_conj(
            Conj::No,
            z.as_mut(),
            Par::Seq,
            MemStack::new(&mut mem),
        );
        Ok(z)
    }
}

/// A solution by halves, before it is written back: each half's own
/// unknowns in its `rows` order, and the separator's.
struct Solved {
    own: [Mat<f64>; 2],
    xs: Mat<f64>,
}

impl Bordered {
    /// Each half's rows of `A` in its factor's order (its own unknowns,
    /// then the separator's), how many are its own, and its symbolic
    /// factor: for the ordering report (`super::orderings`).
    pub(super) fn halves(&self) -> [(&[u32], usize, &SymbolicCholesky<u32>); 2] {
        self.halves.each_ref().map(|h| (&h.rows[..], h.n_own, &h.symbolic))
    }

    /// Factors `a` again with the halves' orderings and symbolic analyses:
    /// `a` must have the pattern of the matrix this was made from (checked
    /// by [`super::Factorization::refactor`]).
    ///
    /// Errors: [`SparseError::NotPositiveDefinite`] on a non-positive pivot;
    /// the factor is then unusable and is dropped by the caller.
    pub(crate) fn refactor(&mut self, a: &CsrMatrix) -> Result<(), SparseError> {
        let [h1, h2] = &mut self.halves;
        let (r1, r2) = rayon::join(|| h1.refactor(a), || h2.refactor(a));
        r1.and(r2)?;
        let [h1, h2] = &self.halves;
        self.corner = corner(a, [h1, h2], &self.separator)?;
        Ok(())
    }

    /// The number of unknowns in the separator (the dense corner's size).
    pub(super) fn separator_len(&self) -> usize {
        self.separator.len()
    }

    /// Solves `A x = b` for the `k` columns of `b`, read as `b(row, column)`.
    fn solve(
        &self,
        k: usize,
        b: &(dyn Fn(usize, usize) -> f64 + Sync),
    ) -> Result<Solved, SparseError> {
        let [h1, h2] = &self.halves;
        let (f1, f2) = rayon::join(|| h1.forward(k, b), || h2.forward(k, b));
        let ((z1, ly1), (z2, ly2)) = (f1?, f2?);
        let mut xs = Mat::from_fn(self.separator.len(), k, |t, j| {
            b(self.separator[t] as usize, j) - ly1[(t, j)] - ly2[(t, j)]
        });
        self.corner.solve_in_place(xs.as_mut());
        let (o1, o2) =
            rayon::join(|| h1.backward(z1, xs.as_ref()), || h2.backward(z2, xs.as_ref()));
        Ok(Solved { own: [o1?, o2?], xs })
    }

    /// Calls `set(row, column, value)` for every entry of the solution.
    fn write(&self, solved: &Solved, mut set: impl FnMut(usize, usize, f64)) {
        for (h, own) in self.halves.iter().zip(&solved.own) {
            for (r, &v) in h.rows[..h.n_own].iter().enumerate() {
                for j in 0..own.ncols() {
                    set(v as usize, j, own[(r, j)]);
                }
            }
        }
        for (t, &v) in self.separator.iter().enumerate() {
            for j in 0..solved.xs.ncols() {
                set(v as usize, j, solved.xs[(t, j)]);
            }
        }
    }

    /// Solves `A x = b` in place for every column of `x`.
    pub(crate) fn solve_in_place(&self, mut x: MatMut<'_, f64>) -> Result<(), SparseError> {
        let b = x.as_ref();
        let solved = self.solve(b.ncols(), &|i, j| b[(i, j)])?;
        self.write(&solved, |i, j, v| x[(i, j)] = v);
        Ok(())
    }

    /// Solves `A x = b` in place for every column `b` of `columns` (each of
    /// `A`'s size), with no `n x k` copy of them: the halves' own work
    /// arrays are the only other copy (what [`Factor::solve_columns`] is for).
    ///
    /// [`Factor::solve_columns`]: super::Factor::solve_columns
    pub(crate) fn solve_columns(&self, columns: &mut [Vec<f64>]) -> Result<(), SparseError> {
        let solved = {
            let b: &[Vec<f64>] = columns;
            self.solve(b.len(), &|i, j| b[j][i])?
        };
        self.write(&solved, |i, j, v| columns[j][i] = v);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::direct::Factor;
    use crate::test_support::{grid_laplacian, rel_err};

    fn columns(n: usize) -> Mat<f64> {
        Mat::from_fn(n, 2, |i, j| if j == 0 { (i as f64 * 0.37).sin() } else { (i % 7) as f64 })
    }

    #[test]
    fn agrees_with_the_whole_factor() {
        // Square, long and tall grids.
        for (w, h) in [(60, 60), (400, 12), (25, 90)] {
            let a = grid_laplacian(w, h);
            let n = a.n_rows();
            let whole = Factor::cholesky(&a).unwrap();
            let halves = factor(&a).unwrap().expect("a grid cuts in two");
            let (mut x, mut y) = (columns(n), columns(n));
            halves.solve_in_place(x.as_mut()).unwrap();
            whole.solve_in_place(&mut y).unwrap();
            for j in 0..2 {
                let (xj, yj): (Vec<f64>, Vec<f64>) =
                    (x.col(j).iter().copied().collect(), y.col(j).iter().copied().collect());
                assert!(rel_err(&xj, &yj) < 1e-10, "{w} x {h}");
                // And it solves the system.
                let mut ax = vec![0.0; n];
                a.mul_vec(&xj, &mut ax).unwrap();
                let b: Vec<f64> = columns(n).col(j).iter().copied().collect();
                assert!(rel_err(&ax, &b) < 1e-10, "{w} x {h}");
            }
        }
    }

    #[test]
    fn refinement_ends_on_the_same_bits() {
        // What theta-phi relies on: double-double refinement with this factor
        // ends on the same solution as with the whole matrix's factor, bit
        // for bit, though the plain solves differ in their last bits.
        use crate::direct::Factorization;
        use crate::refine::refine_step;
        for (w, h) in [(80, 80), (500, 9)] {
            let a = grid_laplacian(w, h);
            let n = a.n_rows();
            let rhs: Vec<Vec<f64>> =
                (0..2).map(|j| columns(n).col(j).iter().copied().collect()).collect();
            let whole = Factorization {
                factor: Factor::cholesky(&a).unwrap(),
                n,
                pattern: None,
                reuses: 0,
            };
            let halves = Factorization {
                factor: Factor::Bordered(Box::new(factor(&a).unwrap().unwrap())),
                n,
                pattern: None,
                reuses: 0,
            };
            let refined = |f: &Factorization| {
                let mut x = f.solve(&a, &rhs).unwrap();
                for _ in 0..8 {
                    if refine_step(&a, f, &rhs, &mut x).unwrap() == 0 {
                        break;
                    }
                }
                x
            };
            assert_eq!(refined(&whole), refined(&halves), "{w} x {h}");
        }
    }

    #[test]
    fn declines_what_does_not_cut() {
        // Too small to cut, and two uncoupled grids (disconnected).
        assert!(factor(&grid_laplacian(10, 10)).unwrap().is_none());
        let g = grid_laplacian(30, 30);
        let (mut rows, mut cols, mut vals) = (vec![], vec![], vec![]);
        for shift in [0u32, 900] {
            for i in 0..900 {
                let (c, v) = g.row(i);
                for (&j, &x) in c.iter().zip(v) {
                    rows.push(i as u32 + shift);
                    cols.push(j + shift);
                    vals.push(x);
                }
            }
        }
        let a = CsrMatrix::from_triplets(1800, 1800, &rows, &cols, &vals).unwrap();
        assert!(factor(&a).unwrap().is_none());
    }

    #[test]
    fn an_indefinite_matrix_is_reported() {
        // A grid Laplacian shifted far enough to have negative eigenvalues.
        let g = grid_laplacian(40, 40);
        let n = g.n_rows();
        let (mut rows, mut cols, mut vals) = (vec![], vec![], vec![]);
        for i in 0..n {
            let (c, v) = g.row(i);
            for (&j, &x) in c.iter().zip(v) {
                rows.push(i as u32);
                cols.push(j);
                vals.push(if j as usize == i { x - 4.0 } else { x });
            }
        }
        let a = CsrMatrix::from_triplets(n, n, &rows, &cols, &vals).unwrap();
        assert!(matches!(factor(&a), Err(SparseError::NotPositiveDefinite { .. })));
    }
}
