//! Sparse direct solvers: Cholesky `L L^T` for symmetric positive definite
//! matrices and LU with partial pivoting for the rest, both from the `faer`
//! crate (supernodal, with a fill-reducing ordering: nested dissection
//! (`crate::nested_dissection`) or AMD for Cholesky, COLAMD for LU). Large
//! Cholesky factors are made in two halves in parallel ([`bordered`]).
//!
//! This module (with its children [`bordered`] and [`orderings`]) is the
//! only one that names `faer`: its API changes between minor versions, and
//! STYLE.md ("Avoid") wants such a dependency behind one small module so an
//! upgrade touches one file.
//!
//! The thesis (4.5) prefers Gauss-Seidel to a direct method because the
//! Tutte matrix has no band structure; a modern fill-reducing ordering makes
//! that moot on planar meshes: nested-dissection-like orderings of a planar
//! graph give `O(n log n)` fill (Lipton, Rose and Tarjan 1979), and AMD gets
//! close on meshes. docs/benchmarks.md has the measurements.
//!
//! [`Factorization`], the public face of a factor kept for many solves (the
//! iterative refinement of `crate::refine`), lives here too.

mod bordered;
pub(crate) mod orderings;

use crate::error::SparseError;
use crate::nested_dissection::{nested_dissection, pseudo_diameter};
use crate::solve::{find_asymmetry, validate, SolveParams};
use crate::vector::{residual_into, residual_scale};
use crate::CsrMatrix;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltError as DenseLltError;
use faer::perm::PermRef;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymmetricOrdering,
};
use faer::sparse::linalg::lu::{factorize_symbolic_lu, LuRef, NumericLu, SymbolicLu};
use faer::sparse::linalg::{LuError, SupernodalThreshold};
use faer::sparse::FaerError;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Index, Mat, Par, Side};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// Iterative-refinement steps tried after the first solve when the residual
/// misses the tolerance (an ill-conditioned LU); each costs one solve with the
/// existing factor and one mat-vec, never a new factorisation.
const MAX_REFINEMENT_STEPS: usize = 2;

/// Parallelism of the numeric factorisations: rayon's pool, so the one thread
/// switch of DESIGN.md governs it too.
fn factor_par() -> Par {
    Par::rayon(0)
}

/// Parallelism of the triangular solves: none. faer's supernodal solve hands
/// `par` to a dense kernel per supernode, and a Tutte factor has hundreds of
/// thousands of tiny supernodes: measured on the 1000 x 1000 grid with two
/// right-hand sides, 8.4 s with rayon against 0.4 s sequential (2 cores).
const SOLVE_PAR: Par = Par::Seq;

/// A factorised matrix, ready to solve any number of right-hand sides.
pub(crate) enum Factor {
    /// `A = P^T L L^T P` (fill-reducing ordering `P`, see [`analyse`]), of `A` itself, with 32-bit
    /// indices: the CSR column indices serve as they are, and the factor's
    /// own index arrays take half the memory (the factorisation is the
    /// memory peak of a Tutte map).
    Cholesky32 { symbolic: SymbolicCholesky<u32>, values: Vec<f64> },
    /// The same with 64-bit indices, for factors too large for 32 bits.
    Cholesky { symbolic: SymbolicCholesky<usize>, values: Vec<f64> },
    /// The same in two halves factored in parallel and a dense corner
    /// ([`bordered`]), for large matrices.
    Bordered(Box<bordered::Bordered>),
    /// LU of `A^T`; see [`Factor::lu`] for why the transpose.
    LuOfTranspose { symbolic: SymbolicLu<usize>, numeric: NumericLu<usize, f64> },
}

/// The CSR arrays of `A` read as compressed *columns*: that is `A^T` in
/// faer's CSC form, with no copy of the values. faer wants one index type for
/// offsets and indices, so the u32 column indices are widened.
struct TransposeView {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
}

impl TransposeView {
    fn new(a: &CsrMatrix) -> TransposeView {
        TransposeView {
            col_ptr: a.row_offsets().to_vec(),
            row_idx: a.col_indices().iter().map(|&j| j as usize).collect(),
        }
    }

    fn matrix<'a>(&'a self, a: &'a CsrMatrix) -> SparseColMatRef<'a, usize, f64> {
        // `new_checked` asserts the CSC invariants, which are exactly the
        // CsrMatrix invariants (offsets from 0 to nnz, sorted unique indices
        // within range), so it cannot fire on a CsrMatrix.
        let n = a.n_rows();
        let symbolic =
            SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
        SparseColMatRef::new(symbolic, a.values())
    }
}

/// Runs a faer call, turning a panic inside it into a typed error: faer
/// asserts internally, and a panic must never reach Python (DESIGN.md).
fn guarded<T>(what: &str, f: impl FnOnce() -> Result<T, SparseError>) -> Result<T, SparseError> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(result) => result,
        Err(_) => {
            Err(SparseError::Factorization { detail: format!("{what} panicked inside faer") })
        }
    }
}

fn failed(what: &str, e: impl std::fmt::Debug) -> SparseError {
    SparseError::Factorization { detail: format!("{what}: {e:?}") }
}

/// Scratch memory for faer, or a typed error when it cannot be had.
fn scratch(req: StackReq) -> Result<MemBuffer, SparseError> {
    MemBuffer::try_new(req).map_err(|_| SparseError::OutOfMemory {
        what: "the direct solver's scratch",
        bytes: req.size_bytes() as u64,
    })
}

/// A Cholesky factor: faer's symbolic structure and the values of `L`.
type Llt<I> = (SymbolicCholesky<I>, Vec<f64>);

/// Graphs at most this large are ordered both ways (nested dissection and
/// AMD) and factored with the ordering that predicts the smaller factor:
/// both orderings together cost less than a tenth of a second there.
const COMPARE_ORDERINGS_UP_TO: usize = 200_000;

/// Larger graphs take nested dissection when their pseudo-diameter is at
/// least this many times `sqrt(n)`, AMD otherwise (see [`analyse`]).
const LONG_GRAPH: f64 = 1.5;

/// The fill-reducing ordering of a symbolic factor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Ordering<'a> {
    /// faer's approximate minimum degree.
    Amd,
    /// `perm[k]` = the row eliminated `k`-th.
    Custom(&'a [u32]),
    /// The matrix's own order (no permuted copy of it is made).
    AsGiven,
}

/// Whether a symbolic factor may be simplicial (faer's choice, by its
/// predicted flops) or must be supernodal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Supernodal {
    FaerChooses,
    Always,
}

/// The symbolic factor of `m` (its lower triangle) under `ordering`;
/// `None` back when the factor has more entries than `I` can count.
pub(crate) fn symbolic_llt<I: Index>(
    m: SymbolicSparseColMatRef<'_, I>,
    ordering: Ordering<'_>,
    supernodal: Supernodal,
) -> Result<Option<SymbolicCholesky<I>>, SparseError> {
    let perm = match ordering {
        Ordering::Amd | Ordering::AsGiven => None,
        Ordering::Custom(perm) => Some(perm),
    };
    let arrays = perm.map(|perm| {
        let forward: Vec<I> = perm.iter().map(|&v| I::truncate(v as usize)).collect();
        let mut inverse = vec![I::truncate(0); perm.len()];
        for (k, &v) in perm.iter().enumerate() {
            inverse[v as usize] = I::truncate(k);
        }
        (forward, inverse)
    });
    let ordering = match &arrays {
        // `new_checked` asserts a permutation, which nested dissection returns.
        Some((forward, inverse)) => {
            SymmetricOrdering::Custom(PermRef::new_checked(forward, inverse, m.nrows()))
        }
        None if ordering == Ordering::AsGiven => SymmetricOrdering::Identity,
        None => SymmetricOrdering::Amd,
    };
    let mut params = CholeskySymbolicParams::default();
    if supernodal == Supernodal::Always {
        params.supernodal_flop_ratio_threshold = SupernodalThreshold::FORCE_SUPERNODAL;
    }
    match factorize_symbolic_cholesky(m, Side::Lower, ordering, params) {
        Ok(symbolic) => Ok(Some(symbolic)),
        Err(FaerError::IndexOverflow) => Ok(None),
        Err(e) => Err(failed("sparse Cholesky analysis", e)),
    }
}

/// Fill-reducing ordering and symbolic analysis of `m` (whose pattern has
/// the CSR arrays `offsets`, `indices`): nested dissection
/// ([`crate::nested_dissection`]) or AMD, whichever fits the graph.
///
/// Measured on the theta-phi systems of the 1M-vertex shapes
/// (docs/benchmarks.md, issue 14 third session), nested dissection stores
/// 15% fewer values of L than AMD on the helix tube, 9% fewer on the
/// tentacles, 7% on the ellipsoid and 1% on the bumpy blob; its factor is at least as fast to compute (its tree
/// is balanced, so both cores work), but its ordering costs up to twice
/// AMD's on round shapes. It pays on long graphs, whose diameter is large
/// against `sqrt(n)` (helix 4.9, tentacles 2.2, blob and ellipsoid 0.95).
/// Small graphs are ordered both ways and keep the smaller predicted factor.
fn analyse<I: Index>(
    m: SymbolicSparseColMatRef<'_, I>,
    offsets: &[usize],
    indices: &[u32],
) -> Result<Option<SymbolicCholesky<I>>, SparseError> {
    let n = m.nrows();
    let nested = || {
        let perm = nested_dissection(offsets, indices);
        symbolic_llt(m, Ordering::Custom(&perm), Supernodal::FaerChooses)
    };
    if n <= COMPARE_ORDERINGS_UP_TO {
        let (nested, amd) = (nested()?, symbolic_llt(m, Ordering::Amd, Supernodal::FaerChooses)?);
        return Ok(match (nested, amd) {
            (Some(nd), Some(amd)) => Some(if amd.len_val() < nd.len_val() { amd } else { nd }),
            (nd, amd) => nd.or(amd),
        });
    }
    if is_long(offsets, indices) {
        nested()
    } else {
        symbolic_llt(m, Ordering::Amd, Supernodal::FaerChooses)
    }
}

/// Whether the graph is long for its size: pseudo-diameter at least
/// [`LONG_GRAPH`] times `sqrt(n)` (see [`analyse`]).
fn is_long(offsets: &[usize], indices: &[u32]) -> bool {
    let n = offsets.len().saturating_sub(1);
    pseudo_diameter(offsets, indices) as f64 >= LONG_GRAPH * (n as f64).sqrt()
}

/// Symbolic analysis ([`analyse`]) and numeric `L L^T` of the lower
/// triangle of `m`, with indices of type `I`; `None` when the factor has
/// more entries than `I` can count. `offsets` and `indices` are `m`'s
/// pattern as CSR arrays (the same graph: `m` is symmetric).
fn llt<I: Index>(
    m: SparseColMatRef<'_, I, f64>,
    offsets: &[usize],
    indices: &[u32],
) -> Result<Option<Llt<I>>, SparseError> {
    // The CSC view is A^T = A (A is symmetric); its lower triangle is A's
    // upper one, equal to A's lower one within the tolerance.
    let symbolic = match analyse(m.symbolic(), offsets, indices)? {
        Some(symbolic) => symbolic,
        None => return Ok(None),
    };
    let values = numeric_llt(&symbolic, m)?;
    Ok(Some((symbolic, values)))
}

/// Factors of at least this many values (32 MB, glibc's largest mmap
/// threshold) are preceded by [`release_free_memory`]; smaller ones, such as
/// the many small systems of the progressive method's Newton steps, are not
/// worth the call.
const TRIM_FROM_VALUES: usize = 1 << 22;

/// Hands the allocator's free pages back to the system, so that the factor
/// about to be allocated does not sit beside them: it is the memory peak.
///
/// glibc serves allocations below its mmap threshold, which rises up to 32 MB
/// as large blocks are freed, from its arenas, and keeps what is freed there
/// resident. Before a numeric factorisation the arenas hold what the stages
/// before it freed (the pole search's graph, the cut mesh's half-edges, the
/// weights, the ordering's work arrays): measured at the peak of theta-phi on
/// the 1M helix tube and bumpy blob, 230 MB of free but resident arena memory,
/// a fifth of the peak. `malloc_trim` returns every free page (not only the
/// arena's top); it took 7-33 ms there. Elsewhere it is not needed or
/// not available, and nothing is done. Also called by the progressive method
/// of `spherify-sphere` before its largest buffer.
pub fn release_free_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        extern "C" {
            fn malloc_trim(pad: usize) -> std::ffi::c_int;
        }
        // SAFETY: malloc_trim takes no pointer, only reads and returns the
        // allocator's own free lists, and is thread-safe (glibc locks each
        // arena in turn); Rust's global allocator on linux-gnu is this malloc.
        unsafe {
            malloc_trim(0);
        }
    }
}

/// The numeric `L L^T` of the lower triangle of `m` under `symbolic`.
fn numeric_llt<I: Index>(
    symbolic: &SymbolicCholesky<I>,
    m: SparseColMatRef<'_, I, f64>,
) -> Result<Vec<f64>, SparseError> {
    if symbolic.len_val() >= TRIM_FROM_VALUES {
        release_free_memory();
    }
    let mut values = Vec::new();
    values.try_reserve_exact(symbolic.len_val()).map_err(|_| SparseError::OutOfMemory {
        what: "the Cholesky factor",
        bytes: (symbolic.len_val() as u64).saturating_mul(8),
    })?;
    values.resize(symbolic.len_val(), 0.0);
    let par = factor_par();
    let mut mem = scratch(symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()))?;
    let result = symbolic.factorize_numeric_llt(
        &mut values,
        m,
        Side::Lower,
        Default::default(),
        par,
        MemStack::new(&mut mem),
        Default::default(),
    );
    // The only numeric failure faer reports is a non-positive pivot.
    if let Err(DenseLltError::NonPositivePivot { .. }) = result {
        return Err(SparseError::NotPositiveDefinite { method: "sparse Cholesky pivot" });
    }
    Ok(values)
}

/// Approximate minimum degree ordering (faer's AMD) of the `n`-vertex graph
/// with CSR arrays `offsets`, `indices` (sorted rows, no duplicates): false
/// when faer cannot (it then leaves `perm` as it is).
pub(crate) fn amd_order(
    perm: &mut [u32],
    inverse: &mut [u32],
    n: usize,
    offsets: &[u32],
    indices: &[u32],
) -> bool {
    let Ok(mut mem) = MemBuffer::try_new(amd::order_scratch::<u32>(n, indices.len())) else {
        return false;
    };
    // `new_checked` asserts what the caller promises; a panic is caught all the same.
    catch_unwind(AssertUnwindSafe(|| {
        let graph = SymbolicSparseColMatRef::new_checked(n, n, offsets, None, indices);
        amd::order(perm, inverse, graph, amd::Control::default(), MemStack::new(&mut mem)).is_ok()
    }))
    .unwrap_or(false)
}

/// Solves `L L^T x = b` in place for every column of `x`. Two or more
/// columns are split in two halves solved on two rayon tasks: the supernodes
/// of a mesh factor are too small for faer's parallel kernels (see
/// [`SOLVE_PAR`]), but two independent sweeps over the factor keep two cores
/// busy: on the 1M helix tube and bumpy blob the theta-phi solve stage went
/// from 0.43-0.78 s to 0.25 s, and the refinement step (one more solve) from
/// 0.53-0.64 s to 0.27-0.31 s (2 cores, load 3-5). The split depends only on
/// the number of columns, so the result is deterministic.
fn llt_solve<I: Index>(
    symbolic: &SymbolicCholesky<I>,
    values: &[f64],
    x: &mut Mat<f64>,
) -> Result<(), SparseError> {
    let solve_columns = |x: faer::MatMut<'_, f64>| -> Result<(), SparseError> {
        let mut mem = scratch(symbolic.solve_in_place_scratch::<f64>(x.ncols(), SOLVE_PAR))?;
        LltRef::new(symbolic, values).solve_in_place_with_conj(
            Conj::No,
            x,
            SOLVE_PAR,
            MemStack::new(&mut mem),
        );
        Ok(())
    };
    let k = x.ncols();
    if k < 2 {
        return solve_columns(x.as_mut());
    }
    let (left, right) = x.as_mut().split_at_col_mut(k / 2);
    let (a, b) = rayon::join(|| solve_columns(left), || solve_columns(right));
    a.and(b)
}

impl Factor {
    /// Cholesky when `a` is `symmetric` and turns out positive definite, LU
    /// otherwise: LU still solves a symmetric indefinite matrix. What
    /// `SolverKind::Auto` and [`Factorization`] use.
    pub(crate) fn cholesky_or_lu(a: &CsrMatrix, symmetric: bool) -> Result<Factor, SparseError> {
        if symmetric {
            match Factor::cholesky(a) {
                Ok(factor) => return Ok(factor),
                Err(SparseError::NotPositiveDefinite { .. }) => {}
                Err(e) => return Err(e),
            }
        }
        Factor::lu(a)
    }

    /// Sparse Cholesky of a symmetric matrix (square, finite, symmetric within
    /// tolerance: checked by the dispatcher). Only one triangle is read.
    ///
    /// Errors: [`SparseError::NotPositiveDefinite`] on a non-positive pivot.
    pub(crate) fn cholesky(a: &CsrMatrix) -> Result<Factor, SparseError> {
        guarded("sparse Cholesky", || {
            // Large matrices are factored in two halves on two cores
            // ([`bordered`]); faer alone keeps one core busy on a mesh factor.
            if a.n_rows() > COMPARE_ORDERINGS_UP_TO {
                if let Some(halves) = bordered::factor(a)? {
                    return Ok(Factor::Bordered(Box::new(halves)));
                }
            }
            // 32-bit indices when A and L fit (faer reports an L that does
            // not as `IndexOverflow`), 64-bit otherwise.
            if let Ok(col_ptr) =
                a.row_offsets().iter().map(|&o| u32::try_from(o)).collect::<Result<Vec<_>, _>>()
            {
                let n = a.n_rows();
                // The CSR arrays read as CSC are A^T; the checks are the
                // CsrMatrix invariants, so `new_checked` cannot fire.
                let symbolic =
                    SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, a.col_indices());
                let m = SparseColMatRef::new(symbolic, a.values());
                if let Some((symbolic, values)) = llt(m, a.row_offsets(), a.col_indices())? {
                    return Ok(Factor::Cholesky32 { symbolic, values });
                }
            }
            Factor::cholesky_wide(a)
        })
    }

    /// [`Factor::cholesky`] with 64-bit indices.
    fn cholesky_wide(a: &CsrMatrix) -> Result<Factor, SparseError> {
        guarded("sparse Cholesky", || {
            let view = TransposeView::new(a);
            match llt(view.matrix(a), a.row_offsets(), a.col_indices())? {
                Some((symbolic, values)) => Ok(Factor::Cholesky { symbolic, values }),
                None => Err(failed("sparse Cholesky analysis", FaerError::IndexOverflow)),
            }
        })
    }

    /// Sparse LU with partial pivoting. We factor `A^T`, which is what the
    /// CSR arrays are in column form (no transposed copy), and solve with the
    /// transposed factor. For the Tutte matrices this is also the better
    /// choice: `A` is row-diagonally dominant (thesis 4.3), so `A^T` is
    /// column-diagonally dominant, where partial pivoting never needs to swap
    /// rows and the diagonal pivots are as stable as they come.
    ///
    /// Errors: [`SparseError::Singular`] for a structurally singular matrix.
    pub(crate) fn lu(a: &CsrMatrix) -> Result<Factor, SparseError> {
        guarded("sparse LU", || {
            let view = TransposeView::new(a);
            let m = view.matrix(a);
            let symbolic = factorize_symbolic_lu(m.symbolic(), Default::default())
                .map_err(|e| failed("sparse LU analysis", e))?;
            let mut numeric = NumericLu::new();
            let par = factor_par();
            let mut mem =
                scratch(symbolic.factorize_numeric_lu_scratch::<f64>(par, Default::default()))?;
            let result = symbolic.factorize_numeric_lu(
                &mut numeric,
                m,
                par,
                MemStack::new(&mut mem),
                Default::default(),
            );
            match result {
                Ok(_) => {}
                Err(LuError::SymbolicSingular { index }) => {
                    return Err(SparseError::Singular {
                        detail: format!("structurally singular, no pivot for step {index}"),
                    })
                }
                Err(LuError::Generic(e)) => return Err(failed("sparse LU", e)),
            }
            Ok(Factor::LuOfTranspose { symbolic, numeric })
        })
    }

    /// The numeric factorisation again, of `a`, under this factor's ordering
    /// and symbolic analysis; `a` has the pattern of the matrix it was made
    /// from (checked by [`Factorization::refactor`]). `false` back, with
    /// nothing done, for an LU factor, whose pivots depend on the values.
    ///
    /// Errors: [`SparseError::NotPositiveDefinite`] on a non-positive pivot;
    /// the factor is then unusable.
    fn refactor(&mut self, a: &CsrMatrix) -> Result<bool, SparseError> {
        guarded("sparse Cholesky", || {
            match self {
                Factor::Cholesky32 { symbolic, values } => {
                    let col_ptr: Vec<u32> = a.row_offsets().iter().map(|&o| o as u32).collect();
                    let n = a.n_rows();
                    // As in [`Factor::cholesky`]: the CSR arrays read as CSC.
                    let pattern =
                        SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, a.col_indices());
                    *values = Vec::new();
                    *values = numeric_llt(symbolic, SparseColMatRef::new(pattern, a.values()))?;
                }
                Factor::Cholesky { symbolic, values } => {
                    let view = TransposeView::new(a);
                    *values = Vec::new();
                    *values = numeric_llt(symbolic, view.matrix(a))?;
                }
                Factor::Bordered(halves) => halves.refactor(a)?,
                Factor::LuOfTranspose { .. } => return Ok(false),
            }
            Ok(true)
        })
    }

    /// Solves in place for all columns of `x` at once (one pass over the
    /// factor serves every right-hand side).
    fn solve_in_place(&self, x: &mut Mat<f64>) -> Result<(), SparseError> {
        let k = x.ncols();
        match self {
            Factor::Cholesky32 { symbolic, values } => llt_solve(symbolic, values, x)?,
            Factor::Cholesky { symbolic, values } => llt_solve(symbolic, values, x)?,
            Factor::Bordered(halves) => halves.solve_in_place(x.as_mut())?,
            Factor::LuOfTranspose { symbolic, numeric } => {
                let mut mem =
                    scratch(symbolic.solve_transpose_in_place_scratch::<f64>(k, SOLVE_PAR))?;
                LuRef::new_unchecked(symbolic, numeric).solve_transpose_in_place_with_conj(
                    Conj::No,
                    x.as_mut(),
                    SOLVE_PAR,
                    MemStack::new(&mut mem),
                );
            }
        }
        Ok(())
    }

    /// Replaces every column `b` of `columns` (each of `A`'s size) by
    /// `A^-1 b`, one solve with the factor and nothing more: no residual (the
    /// callers, iterative refinement, take their own in double-double).
    /// The bordered factor reads and writes the columns where they are; the
    /// others solve an `n x k` copy, as [`Factor::solve`] does.
    ///
    /// Errors: [`SparseError::Singular`] if a solution is not finite.
    fn solve_columns(&self, columns: &mut [Vec<f64>]) -> Result<(), SparseError> {
        guarded("sparse triangular solve", || {
            match self {
                Factor::Bordered(halves) => halves.solve_columns(columns)?,
                _ => {
                    let n = columns.first().map_or(0, Vec::len);
                    let mut x = Mat::from_fn(n, columns.len(), |i, j| columns[j][i]);
                    self.solve_in_place(&mut x)?;
                    for (j, column) in columns.iter_mut().enumerate() {
                        column.iter_mut().zip(x.col(j).iter()).for_each(|(c, &v)| *c = v);
                    }
                }
            }
            if columns.iter().flatten().any(|v| !v.is_finite()) {
                return Err(SparseError::Singular {
                    detail: "numerically singular, the solution is not finite".into(),
                });
            }
            Ok(())
        })
    }

    /// `A x = b` for every `b` in `rhs` (lengths validated by the dispatcher),
    /// then up to [`MAX_REFINEMENT_STEPS`] steps of iterative refinement
    /// `x += A^{-1} (b - A x)` for as long as some relative residual is above
    /// `tol`. Returns the solutions and their relative residuals.
    ///
    /// Errors: [`SparseError::Singular`] if a solution is not finite (a zero
    /// pivot in LU; Cholesky reports its zero pivots when factoring).
    pub(crate) fn solve(
        &self,
        a: &CsrMatrix,
        rhs: &[Vec<f64>],
        tol: f64,
    ) -> Result<(Vec<Vec<f64>>, Vec<f64>), SparseError> {
        guarded("sparse triangular solve", || {
            let n = a.n_rows();
            let k = rhs.len();
            let mut x = Mat::from_fn(n, k, |i, j| rhs[j][i]);
            self.solve_in_place(&mut x)?;
            let mut sol: Vec<Vec<f64>> =
                (0..k).map(|j| x.col(j).iter().copied().collect()).collect();
            let scales: Vec<f64> = rhs.iter().map(|b| residual_scale(b)).collect();
            let mut r = vec![vec![0.0; n]; k];
            let mut residuals = vec![0.0; k];
            for step in 0..=MAX_REFINEMENT_STEPS {
                for j in 0..k {
                    if sol[j].iter().any(|v| !v.is_finite()) {
                        return Err(SparseError::Singular {
                            detail: "numerically singular, the solution is not finite".into(),
                        });
                    }
                    residuals[j] = residual_into(a, &rhs[j], &sol[j], &mut r[j], scales[j]);
                }
                if step == MAX_REFINEMENT_STEPS || residuals.iter().all(|&res| res <= tol) {
                    break;
                }
                let mut d = Mat::from_fn(n, k, |i, j| r[j][i]);
                self.solve_in_place(&mut d)?;
                for (j, s) in sol.iter_mut().enumerate() {
                    for (si, di) in s.iter_mut().zip(d.col(j).iter()) {
                        *si += di;
                    }
                }
            }
            Ok((sol, residuals))
        })
    }
}

/// A matrix factorised once for many solves: sparse Cholesky when it is
/// symmetric (and positive definite), LU otherwise. Used by iterative
/// refinement ([`crate::refine`]), which solves again and again with one factor.
pub struct Factorization {
    factor: Factor,
    n: usize,
    /// The pattern of the matrix factorised (row offsets, column indices),
    /// kept by [`Factorization::reusable`] for [`Factorization::refactor`].
    pattern: Option<(Vec<usize>, Vec<u32>)>,
    /// How many times [`Factorization::refactor`] reused the analysis.
    reuses: usize,
}

impl Factorization {
    /// Factorises `a` (square and finite; checked).
    pub fn new(a: &CsrMatrix) -> Result<Factorization, SparseError> {
        validate(a, &[], &SolveParams::default())?;
        let factor = Factor::cholesky_or_lu(a, find_asymmetry(a).is_none())?;
        Ok(Factorization { factor, n: a.n_rows(), pattern: None, reuses: 0 })
    }

    /// [`Factorization::new`], keeping a copy of `a`'s pattern (12 bytes per
    /// nonzero at most) so that [`Factorization::refactor`] can reuse the
    /// ordering and analysis for a matrix of exactly that pattern.
    ///
    /// Errors: those of [`Factorization::new`].
    pub fn reusable(a: &CsrMatrix) -> Result<Factorization, SparseError> {
        let mut f = Factorization::new(a)?;
        f.pattern = Some((a.row_offsets().to_vec(), a.col_indices().to_vec()));
        Ok(f)
    }

    /// How many times [`Factorization::refactor`] has reused this factor's
    /// ordering and symbolic analysis.
    pub fn reuses(&self) -> usize {
        self.reuses
    }

    /// Factorises `a`, a matrix with new values, reusing this factor's
    /// fill-reducing ordering and symbolic analysis when this factor was made
    /// by [`Factorization::reusable`] (or `refactor`) from a matrix of exactly
    /// `a`'s pattern and `a` is symmetric. Gives what
    /// [`Factorization::new`] of `a` gives, bit for bit: the ordering and
    /// analysis depend on the pattern alone. Otherwise (another pattern, an
    /// LU factor, a pivot that is not positive) it is `new(a)`.
    ///
    /// Why: a Gauss-Newton iteration (the progressive method's authalic
    /// steps) solves one system per step on a fixed mesh, and the ordering
    /// and analysis were about a third of each step's time.
    ///
    /// Errors: those of [`Factorization::new`].
    pub fn refactor(mut self, a: &CsrMatrix) -> Result<Factorization, SparseError> {
        validate(a, &[], &SolveParams::default())?;
        // The whole pattern is compared, not a hash of it: a factor reused
        // for another pattern would be a wrong answer, not a slow one.
        let same = a.n_rows() == self.n
            && self.pattern.as_ref().is_some_and(|(offsets, columns)| {
                offsets.as_slice() == a.row_offsets() && columns.as_slice() == a.col_indices()
            })
            && find_asymmetry(a).is_none();
        if same {
            match self.factor.refactor(a) {
                Ok(true) => {
                    self.reuses += 1;
                    return Ok(self);
                }
                Ok(false) | Err(SparseError::NotPositiveDefinite { .. }) => {}
                Err(e) => return Err(e),
            }
        }
        drop(self);
        Factorization::reusable(a)
    }

    /// Solves `A x = b` for every `b`, with no refinement and no residual;
    /// `a` is the matrix that was factorised (its size is checked).
    pub fn solve(&self, a: &CsrMatrix, rhs: &[Vec<f64>]) -> Result<Vec<Vec<f64>>, SparseError> {
        let mut x = rhs.to_vec();
        self.solve_in_place(a, &mut x)?;
        Ok(x)
    }

    /// [`Factorization::solve`] in place: each column of `columns` is a
    /// right-hand side and becomes its solution. Iterative refinement solves
    /// for its corrections this way, in the residuals' own storage: at a
    /// million unknowns that is two fewer copies of the two columns (32 MB)
    /// beside the factor, whose solves are the memory peak of theta-phi once
    /// it is factored.
    pub fn solve_in_place(
        &self,
        a: &CsrMatrix,
        columns: &mut [Vec<f64>],
    ) -> Result<(), SparseError> {
        if a.n_rows() != self.n {
            return Err(SparseError::LengthMismatch {
                what: "matrix rows",
                got: a.n_rows(),
                expected: self.n,
            });
        }
        for b in columns.iter() {
            if b.len() != self.n {
                return Err(SparseError::LengthMismatch {
                    what: "right-hand side",
                    got: b.len(),
                    expected: self.n,
                });
            }
        }
        self.factor.solve_columns(columns)
    }
}

#[cfg(test)]
mod tests;
