//! Compressed sparse row matrices: the storage of the linear systems of thesis
//! ch. 4 (Tutte's barycentric system 4.3-4.5) and of the spherical methods.
//!
//! Invariants of every [`CsrMatrix`], established by its constructors and relied
//! on by its methods: `row_offsets` has `n_rows + 1` non-decreasing entries from
//! 0 to `nnz`; within each row the column indices are strictly increasing (no
//! duplicates) and below `n_cols`. Explicit zeros given by the caller are kept.

use crate::error::SparseError;
use rayon::prelude::*;

/// Row count from which [`CsrMatrix::mul_vec`] splits the rows over rayon
/// threads; below it the thread hand-off costs more than it saves.
const PARALLEL_MIN_ROWS: usize = 20_000;
/// Rows per rayon task: large enough to amortise scheduling, small enough to
/// balance rows of unequal length.
const ROWS_PER_TASK: usize = 4096;

/// A sparse `n_rows x n_cols` matrix of f64 in compressed sparse row form.
#[derive(Debug, Clone, PartialEq)]
pub struct CsrMatrix {
    n_rows: usize,
    n_cols: usize,
    row_offsets: Vec<usize>,
    col_indices: Vec<u32>,
    values: Vec<f64>,
}

impl CsrMatrix {
    /// Builds a matrix from (row, column, value) triplets in any order; entries
    /// at the same position are summed in the order given (the way finite-element
    /// style assembly adds contributions). O(nnz + n_rows + n_cols): two stable
    /// counting sorts, by column then by row, leave each row's columns sorted.
    ///
    /// Errors: [`SparseError::LengthMismatch`] if the three slices differ in
    /// length, [`SparseError::IndexOutOfRange`] for the first triplet outside
    /// the matrix.
    pub fn from_triplets(
        n_rows: usize,
        n_cols: usize,
        rows: &[u32],
        cols: &[u32],
        values: &[f64],
    ) -> Result<CsrMatrix, SparseError> {
        let nnz = rows.len();
        for (what, got) in [("cols", cols.len()), ("values", values.len())] {
            if got != nnz {
                return Err(SparseError::LengthMismatch { what, got, expected: nnz });
            }
        }
        for (entry, (&row, &col)) in rows.iter().zip(cols).enumerate() {
            if row as usize >= n_rows || col as usize >= n_cols {
                return Err(SparseError::IndexOutOfRange { entry, row, col, n_rows, n_cols });
            }
        }
        // Pass 1: bucket by column (a CSC copy), keeping the input order inside
        // each column.
        let col_offsets = bucket_offsets(n_cols, cols);
        let mut fill = col_offsets.clone();
        let mut csc_rows = vec![0u32; nnz];
        let mut csc_values = vec![0.0f64; nnz];
        for k in 0..nnz {
            let slot = &mut fill[cols[k] as usize];
            csc_rows[*slot] = rows[k];
            csc_values[*slot] = values[k];
            *slot += 1;
        }
        // Pass 2: bucket by row, walking columns in increasing order, so each row
        // receives its columns sorted and duplicates arrive adjacent and in input
        // order.
        let row_offsets = bucket_offsets(n_rows, rows);
        let mut fill = row_offsets.clone();
        let mut col_indices = vec![0u32; nnz];
        let mut out_values = vec![0.0f64; nnz];
        for j in 0..n_cols {
            for k in col_offsets[j]..col_offsets[j + 1] {
                let slot = &mut fill[csc_rows[k] as usize];
                col_indices[*slot] = j as u32;
                out_values[*slot] = csc_values[k];
                *slot += 1;
            }
        }
        // Pass 3: sum duplicates, compacting in place.
        let mut offsets = vec![0usize; n_rows + 1];
        let mut write = 0;
        for i in 0..n_rows {
            let start = write;
            for k in row_offsets[i]..row_offsets[i + 1] {
                if write > start && col_indices[write - 1] == col_indices[k] {
                    out_values[write - 1] += out_values[k];
                } else {
                    col_indices[write] = col_indices[k];
                    out_values[write] = out_values[k];
                    write += 1;
                }
            }
            offsets[i + 1] = write;
        }
        col_indices.truncate(write);
        out_values.truncate(write);
        Ok(CsrMatrix { n_rows, n_cols, row_offsets: offsets, col_indices, values: out_values })
    }

    /// Builds a matrix row by row, the rows in parallel: `row(i, entries)`
    /// appends row `i`'s (column, value) pairs to `entries` (empty on each
    /// call) in any order, and returns a per-row value `T` collected in row
    /// order. Entries at the same position are summed in the order given, so
    /// the result equals [`CsrMatrix::from_triplets`] of the same triplets
    /// row by row, bit for bit. O(nnz log(row length)).
    ///
    /// Errors: [`SparseError::IndexOutOfRange`] for a column outside the matrix.
    pub fn from_rows<T, F>(
        n_rows: usize,
        n_cols: usize,
        row: F,
    ) -> Result<(CsrMatrix, Vec<T>), SparseError>
    where
        T: Send,
        F: Fn(usize, &mut Vec<(u32, f64)>) -> T + Sync,
    {
        struct Block<T> {
            lengths: Vec<usize>,
            cols: Vec<u32>,
            values: Vec<f64>,
            extra: Vec<T>,
        }
        let build = |rows: std::ops::Range<usize>| -> Result<Block<T>, SparseError> {
            let mut entries = Vec::new();
            let mut block = Block {
                lengths: Vec::with_capacity(rows.len()),
                cols: Vec::new(),
                values: Vec::new(),
                extra: Vec::with_capacity(rows.len()),
            };
            for i in rows {
                entries.clear();
                block.extra.push(row(i, &mut entries));
                // Stable: duplicates stay in the order given, then are summed.
                entries.sort_by_key(|&(j, _)| j);
                let start = block.cols.len();
                for (entry, &(j, v)) in entries.iter().enumerate() {
                    if j as usize >= n_cols {
                        return Err(SparseError::IndexOutOfRange {
                            entry,
                            row: i as u32,
                            col: j,
                            n_rows,
                            n_cols,
                        });
                    }
                    if block.cols.len() > start && block.cols[block.cols.len() - 1] == j {
                        *block.values.last_mut().expect("a previous entry") += v;
                    } else {
                        block.cols.push(j);
                        block.values.push(v);
                    }
                }
                block.lengths.push(block.cols.len() - start);
            }
            Ok(block)
        };
        let blocks: Vec<Block<T>> = (0..n_rows.div_ceil(ROWS_PER_TASK))
            .into_par_iter()
            .map(|b| build(b * ROWS_PER_TASK..((b + 1) * ROWS_PER_TASK).min(n_rows)))
            .collect::<Result<_, _>>()?;
        let nnz = blocks.iter().map(|b| b.cols.len()).sum();
        let mut row_offsets = Vec::with_capacity(n_rows + 1);
        row_offsets.push(0);
        let (mut col_indices, mut values) = (Vec::with_capacity(nnz), Vec::with_capacity(nnz));
        let mut extra = Vec::with_capacity(n_rows);
        for block in blocks {
            for length in block.lengths {
                row_offsets.push(row_offsets[row_offsets.len() - 1] + length);
            }
            col_indices.extend_from_slice(&block.cols);
            values.extend_from_slice(&block.values);
            extra.extend(block.extra);
        }
        Ok((CsrMatrix { n_rows, n_cols, row_offsets, col_indices, values }, extra))
    }

    /// The `n x n` identity matrix.
    pub fn identity(n: usize) -> CsrMatrix {
        CsrMatrix {
            n_rows: n,
            n_cols: n,
            row_offsets: (0..=n).collect(),
            col_indices: (0..n).map(|i| i as u32).collect(),
            values: vec![1.0; n],
        }
    }

    /// Number of rows.
    pub fn n_rows(&self) -> usize {
        self.n_rows
    }

    /// Number of columns.
    pub fn n_cols(&self) -> usize {
        self.n_cols
    }

    /// Number of stored entries (explicit zeros included, duplicates merged).
    pub fn nnz(&self) -> usize {
        self.values.len()
    }

    /// Column indices (increasing) and values of row `i`; empty slices if `i` is
    /// out of range.
    pub fn row(&self, i: usize) -> (&[u32], &[f64]) {
        if i >= self.n_rows {
            return (&[], &[]);
        }
        let range = self.row_offsets[i]..self.row_offsets[i + 1];
        (&self.col_indices[range.clone()], &self.values[range])
    }

    /// The `n_rows + 1` row start offsets into [`Self::col_indices`] and [`Self::values`].
    pub fn row_offsets(&self) -> &[usize] {
        &self.row_offsets
    }

    /// Column index of every stored entry, row by row.
    pub fn col_indices(&self) -> &[u32] {
        &self.col_indices
    }

    /// Value of every stored entry, row by row.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// `y = A x`. Each row is summed left to right over its stored entries, in
    /// the same order whether the rows run on one thread or (from 20,000 rows
    /// on) on rayon's pool, so the result is identical bit for bit either way.
    /// O(nnz).
    ///
    /// Errors: [`SparseError::LengthMismatch`] unless `x.len() == n_cols` and
    /// `y.len() == n_rows`; `y` is then left untouched.
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) -> Result<(), SparseError> {
        self.check_lengths(x, y)?;
        if self.n_rows >= PARALLEL_MIN_ROWS {
            self.mul_vec_parallel(x, y);
        } else {
            self.mul_vec_sequential(x, y);
        }
        Ok(())
    }

    fn check_lengths(&self, x: &[f64], y: &[f64]) -> Result<(), SparseError> {
        if x.len() != self.n_cols {
            return Err(SparseError::LengthMismatch {
                what: "x",
                got: x.len(),
                expected: self.n_cols,
            });
        }
        if y.len() != self.n_rows {
            return Err(SparseError::LengthMismatch {
                what: "y",
                got: y.len(),
                expected: self.n_rows,
            });
        }
        Ok(())
    }

    /// Row `i` times `x`; the one summation order used by both product paths.
    fn row_dot(&self, i: usize, x: &[f64]) -> f64 {
        let range = self.row_offsets[i]..self.row_offsets[i + 1];
        let mut sum = 0.0;
        for (&j, &v) in self.col_indices[range.clone()].iter().zip(&self.values[range]) {
            sum += v * x[j as usize];
        }
        sum
    }

    fn mul_vec_sequential(&self, x: &[f64], y: &mut [f64]) {
        for (i, yi) in y.iter_mut().enumerate() {
            *yi = self.row_dot(i, x);
        }
    }

    fn mul_vec_parallel(&self, x: &[f64], y: &mut [f64]) {
        y.par_chunks_mut(ROWS_PER_TASK).enumerate().for_each(|(chunk, ys)| {
            let first = chunk * ROWS_PER_TASK;
            for (k, yi) in ys.iter_mut().enumerate() {
                *yi = self.row_dot(first + k, x);
            }
        });
    }

    /// The transpose, with sorted columns. O(nnz + n_rows + n_cols).
    pub fn transpose(&self) -> CsrMatrix {
        let row_offsets = bucket_offsets(self.n_cols, &self.col_indices);
        let mut fill = row_offsets.clone();
        let mut col_indices = vec![0u32; self.nnz()];
        let mut values = vec![0.0f64; self.nnz()];
        // Walking rows in order makes every transposed row come out sorted.
        for i in 0..self.n_rows {
            for k in self.row_offsets[i]..self.row_offsets[i + 1] {
                let slot = &mut fill[self.col_indices[k] as usize];
                col_indices[*slot] = i as u32;
                values[*slot] = self.values[k];
                *slot += 1;
            }
        }
        CsrMatrix { n_rows: self.n_cols, n_cols: self.n_rows, row_offsets, col_indices, values }
    }

    /// The main diagonal, `min(n_rows, n_cols)` long; entries not stored are 0
    /// (for Jacobi scaling and Gauss-Seidel, thesis 4.5). O(nnz log d) worst case.
    pub fn diagonal(&self) -> Vec<f64> {
        (0..self.n_rows.min(self.n_cols)).map(|i| self.get(i, i)).collect()
    }

    /// `A <- diag(s) A`: multiplies row `i` by `s[i]`. O(nnz).
    ///
    /// Errors: [`SparseError::LengthMismatch`] unless `s.len() == n_rows`; the
    /// matrix is then left untouched.
    pub fn scale_rows(&mut self, s: &[f64]) -> Result<(), SparseError> {
        if s.len() != self.n_rows {
            return Err(SparseError::LengthMismatch {
                what: "s",
                got: s.len(),
                expected: self.n_rows,
            });
        }
        for (i, &si) in s.iter().enumerate() {
            for v in &mut self.values[self.row_offsets[i]..self.row_offsets[i + 1]] {
                *v *= si;
            }
        }
        Ok(())
    }

    /// Entry `(i, j)`: 0 where nothing is stored, including outside the matrix.
    /// Binary search in row `i`, O(log d).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (cols, values) = self.row(i);
        let Ok(j) = u32::try_from(j) else { return 0.0 };
        match cols.binary_search(&j) {
            Ok(k) => values[k],
            Err(_) => 0.0,
        }
    }

    /// Whether the matrix is square and `|a_ij - a_ji| <= tol` for every stored
    /// entry (an absolute tolerance; a missing mirror entry counts as 0, a NaN
    /// entry makes the answer false). The Tutte matrix of uniform or chord
    /// weights is symmetric, mean-value weights are not (thesis 4.4), which
    /// decides between CG and a general solver. O(nnz log d).
    pub fn is_symmetric(&self, tol: f64) -> bool {
        if self.n_rows != self.n_cols {
            return false;
        }
        (0..self.n_rows).all(|i| {
            let (cols, values) = self.row(i);
            cols.iter().zip(values).all(|(&j, &v)| (v - self.get(j as usize, i)).abs() <= tol)
        })
    }
}

/// CSR-style offsets of a counting sort of `keys` into `n` buckets: bucket `b`
/// is `offsets[b]..offsets[b + 1]`. Every key must be below `n`.
fn bucket_offsets(n: usize, keys: &[u32]) -> Vec<usize> {
    let mut offsets = vec![0usize; n + 1];
    for &key in keys {
        offsets[key as usize + 1] += 1;
    }
    for b in 0..n {
        offsets[b + 1] += offsets[b];
    }
    offsets
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::lcg::Lcg;

    type Triplets = (Vec<u32>, Vec<u32>, Vec<f64>);

    fn random_triplets(rng: &mut Lcg, n_rows: usize, n_cols: usize, nnz: usize) -> Triplets {
        let rows = (0..nnz).map(|_| rng.below(n_rows) as u32).collect();
        let cols = (0..nnz).map(|_| rng.below(n_cols) as u32).collect();
        let values = (0..nnz).map(|_| rng.between(-1.0, 1.0)).collect();
        (rows, cols, values)
    }

    fn dense(n_rows: usize, n_cols: usize, t: &Triplets) -> Vec<Vec<f64>> {
        let mut a = vec![vec![0.0; n_cols]; n_rows];
        for k in 0..t.0.len() {
            a[t.0[k] as usize][t.1[k] as usize] += t.2[k];
        }
        a
    }

    fn check_invariants(m: &CsrMatrix) {
        assert_eq!(m.row_offsets().len(), m.n_rows() + 1);
        assert_eq!(m.row_offsets()[m.n_rows()], m.nnz());
        for i in 0..m.n_rows() {
            let (cols, _) = m.row(i);
            assert!(cols.windows(2).all(|w| w[0] < w[1]));
            assert!(cols.iter().all(|&j| (j as usize) < m.n_cols()));
        }
    }

    #[test]
    fn from_rows_equals_from_triplets() {
        let mut rng = Lcg::new(7);
        for (n_rows, n_cols, nnz) in [(0, 0, 0), (5, 3, 40), (9000, 700, 60_000)] {
            let t = random_triplets(&mut rng, n_rows, n_cols, nnz);
            let expected = CsrMatrix::from_triplets(n_rows, n_cols, &t.0, &t.1, &t.2).unwrap();
            let mut by_row: Vec<Vec<(u32, f64)>> = vec![Vec::new(); n_rows];
            for k in 0..nnz {
                by_row[t.0[k] as usize].push((t.1[k], t.2[k]));
            }
            let (got, lengths) = CsrMatrix::from_rows(n_rows, n_cols, |i, entries| {
                entries.extend_from_slice(&by_row[i]);
                by_row[i].len()
            })
            .unwrap();
            assert_eq!(got, expected);
            assert_eq!(lengths, by_row.iter().map(Vec::len).collect::<Vec<_>>());
        }
        let bad = CsrMatrix::from_rows(2, 2, |i, entries| entries.push((i as u32 * 2, 1.0)));
        assert!(matches!(bad, Err(SparseError::IndexOutOfRange { row: 1, col: 2, .. })));
    }

    #[test]
    fn triplets_are_sorted_and_summed() {
        let rows = [2, 0, 2, 0, 1, 2, 0];
        let cols = [1, 3, 0, 0, 2, 1, 3];
        let vals = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 0.5];
        let m = CsrMatrix::from_triplets(3, 4, &rows, &cols, &vals).unwrap();
        check_invariants(&m);
        assert_eq!(m.row_offsets(), &[0, 2, 3, 5]);
        assert_eq!(m.col_indices(), &[0, 3, 2, 0, 1]);
        assert_eq!(m.values(), &[4.0, 2.5, 5.0, 3.0, 7.0]);
        assert_eq!(m.get(2, 1), 7.0);
        assert_eq!(m.get(1, 1), 0.0);
        assert_eq!(m.get(9, 0), 0.0);
        assert_eq!(m.get(0, usize::MAX), 0.0);
        assert_eq!(m.row(3), (&[][..], &[][..]));
    }

    #[test]
    fn bad_triplets_are_errors() {
        let e = CsrMatrix::from_triplets(2, 2, &[0, 1], &[0], &[1.0, 2.0]);
        assert_eq!(e, Err(SparseError::LengthMismatch { what: "cols", got: 1, expected: 2 }));
        let e = CsrMatrix::from_triplets(2, 2, &[0, 1], &[0, 2], &[1.0, 2.0]);
        let expected =
            SparseError::IndexOutOfRange { entry: 1, row: 1, col: 2, n_rows: 2, n_cols: 2 };
        assert_eq!(e, Err(expected));
        let empty = CsrMatrix::from_triplets(0, 0, &[], &[], &[]).unwrap();
        assert_eq!(empty.nnz(), 0);
        assert!(empty.mul_vec(&[], &mut []).is_ok());
    }

    #[test]
    fn mul_vec_matches_dense() {
        let mut rng = Lcg::new(7);
        for &(n_rows, n_cols, nnz) in &[(1, 1, 3), (5, 9, 20), (40, 30, 500), (200, 200, 300)] {
            let t = random_triplets(&mut rng, n_rows, n_cols, nnz);
            let m = CsrMatrix::from_triplets(n_rows, n_cols, &t.0, &t.1, &t.2).unwrap();
            check_invariants(&m);
            let a = dense(n_rows, n_cols, &t);
            let x: Vec<f64> = (0..n_cols).map(|_| rng.between(-1.0, 1.0)).collect();
            let mut y = vec![f64::NAN; n_rows];
            m.mul_vec(&x, &mut y).unwrap();
            for i in 0..n_rows {
                let expected: f64 = (0..n_cols).map(|j| a[i][j] * x[j]).sum();
                assert!((y[i] - expected).abs() <= 1e-12 * (1.0 + expected.abs()));
                for (j, &aij) in a[i].iter().enumerate() {
                    assert!((m.get(i, j) - aij).abs() <= 1e-15);
                }
            }
        }
    }

    #[test]
    fn mul_vec_rejects_wrong_lengths() {
        let m = CsrMatrix::identity(3);
        let mut y = vec![7.0; 3];
        let e = m.mul_vec(&[1.0; 2], &mut y);
        assert_eq!(e, Err(SparseError::LengthMismatch { what: "x", got: 2, expected: 3 }));
        let e = m.mul_vec(&[1.0; 3], &mut [0.0; 4]);
        assert_eq!(e, Err(SparseError::LengthMismatch { what: "y", got: 4, expected: 3 }));
        assert_eq!(y, vec![7.0; 3]);
        m.mul_vec(&[1.0, 2.0, 3.0], &mut y).unwrap();
        assert_eq!(y, vec![1.0, 2.0, 3.0]);
    }

    #[test]
    fn transpose_twice_is_identity() {
        let mut rng = Lcg::new(11);
        let t = random_triplets(&mut rng, 37, 53, 400);
        let m = CsrMatrix::from_triplets(37, 53, &t.0, &t.1, &t.2).unwrap();
        let mt = m.transpose();
        check_invariants(&mt);
        assert_eq!((mt.n_rows(), mt.n_cols(), mt.nnz()), (53, 37, m.nnz()));
        for i in 0..37 {
            for j in 0..53 {
                assert_eq!(m.get(i, j), mt.get(j, i));
            }
        }
        assert_eq!(mt.transpose(), m);
        // Built from swapped triplets, the transpose is the same matrix.
        assert_eq!(CsrMatrix::from_triplets(53, 37, &t.1, &t.0, &t.2).unwrap(), mt);
    }

    #[test]
    fn diagonal_and_scale_rows() {
        let m = CsrMatrix::from_triplets(3, 4, &[0, 0, 2, 2], &[0, 2, 2, 3], &[1.0, 5.0, 3.0, 4.0])
            .unwrap();
        assert_eq!(m.diagonal(), vec![1.0, 0.0, 3.0]);
        assert_eq!(m.transpose().diagonal(), vec![1.0, 0.0, 3.0]);
        assert_eq!(CsrMatrix::identity(4).diagonal(), vec![1.0; 4]);
        let mut s = m.clone();
        assert!(s.scale_rows(&[1.0, 2.0]).is_err());
        assert_eq!(s, m);
        s.scale_rows(&[2.0, 10.0, -1.0]).unwrap();
        assert_eq!(s.values(), &[2.0, 10.0, -3.0, -4.0]);
        assert_eq!(s.col_indices(), m.col_indices());
    }

    #[test]
    fn symmetry_detection() {
        let mut rng = Lcg::new(3);
        let t = random_triplets(&mut rng, 30, 30, 200);
        // A + A^T from triplets: symmetric up to rounding of the sums.
        let rows: Vec<u32> = t.0.iter().chain(&t.1).copied().collect();
        let cols: Vec<u32> = t.1.iter().chain(&t.0).copied().collect();
        let vals: Vec<f64> = t.2.iter().chain(&t.2).copied().collect();
        let mut sym = CsrMatrix::from_triplets(30, 30, &rows, &cols, &vals).unwrap();
        assert!(sym.is_symmetric(1e-14));
        assert!(!CsrMatrix::from_triplets(30, 30, &t.0, &t.1, &t.2).unwrap().is_symmetric(1e-9));
        // An entry without its mirror, then a small asymmetry within tolerance.
        let one_sided = CsrMatrix::from_triplets(2, 2, &[0], &[1], &[1e-3]).unwrap();
        assert!(!one_sided.is_symmetric(1e-4));
        assert!(one_sided.is_symmetric(1e-2));
        assert!(!CsrMatrix::from_triplets(2, 3, &[], &[], &[]).unwrap().is_symmetric(1.0));
        sym.scale_rows(&[f64::NAN; 30]).unwrap();
        assert!(!sym.is_symmetric(1.0));
    }

    #[test]
    fn parallel_and_sequential_agree_bit_for_bit() {
        let mut rng = Lcg::new(2024);
        let n = 50_000;
        let t = random_triplets(&mut rng, n, n, 12 * n);
        let m = CsrMatrix::from_triplets(n, n, &t.0, &t.1, &t.2).unwrap();
        let x: Vec<f64> = (0..n).map(|_| rng.between(-1.0, 1.0) * 1e3).collect();
        let (mut seq, mut par) = (vec![0.0; n], vec![0.0; n]);
        m.mul_vec_sequential(&x, &mut seq);
        m.mul_vec_parallel(&x, &mut par);
        assert!(seq.iter().zip(&par).all(|(a, b)| a.to_bits() == b.to_bits()));
        let mut auto = vec![0.0; n];
        m.mul_vec(&x, &mut auto).unwrap();
        assert!(seq.iter().zip(&auto).all(|(a, b)| a.to_bits() == b.to_bits()));
    }
}
