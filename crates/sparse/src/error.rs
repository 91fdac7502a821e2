//! Errors of the sparse crate. Every failure a caller can cause is a variant with
//! the data that says what is wrong; the Python bindings map them to
//! `spherify.MeshError` (bad shapes and indices) per DESIGN.md, and
//! [`SparseError::NoConvergence`] to `spherify.ConvergenceError`, which carries
//! the last iterate.

/// Every error of the sparse crate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SparseError {
    /// A triplet addresses an entry outside the matrix.
    #[error("entry {entry} is at row {row}, column {col}, outside the {n_rows} x {n_cols} matrix")]
    IndexOutOfRange { entry: usize, row: u32, col: u32, n_rows: usize, n_cols: usize },
    /// An array does not have the length the operation needs (`what` names it).
    #[error("{what} has length {got}, but {expected} is needed")]
    LengthMismatch { what: &'static str, got: usize, expected: usize },
    /// A linear system needs a square matrix.
    #[error("the matrix is {n_rows} x {n_cols}, but a square matrix is needed")]
    NotSquare { n_rows: usize, n_cols: usize },
    /// A NaN or infinity in the input. `what` names the array and `index` the
    /// position in it: the stored-entry index for `"matrix"`; `k * n + i` for
    /// element `i` of right-hand side `k` in `"rhs"` or `"x0"` (the flat index
    /// of a `(k, n)` array).
    #[error("{what} holds a non-finite value (NaN or infinity) at index {index}")]
    NonFinite { what: &'static str, index: usize },
    /// A solver parameter outside its range (`name` says which).
    #[error("parameter {name} = {value} is out of range: {expected}")]
    InvalidParameter { name: &'static str, value: f64, expected: &'static str },
    /// A solver that needs a symmetric matrix (conjugate gradients, Cholesky)
    /// was given one where `a[row][col]` and `a[col][row]` differ beyond the
    /// relative tolerance.
    #[error("the matrix is not symmetric: a[{row}][{col}] = {value}, a[{col}][{row}] = {mirror}")]
    NotSymmetric { row: usize, col: usize, value: f64, mirror: f64 },
    /// A diagonal entry that must be positive (Gauss-Seidel, Jacobi, the
    /// conjugate-gradient solvers) is zero, negative or missing.
    #[error("diagonal entry {row} is {value}, but the solver needs a positive diagonal")]
    NonPositiveDiagonal { row: usize, value: f64 },
    /// The matrix turned out not to be positive definite (`method` says where
    /// this showed: a Cholesky pivot, a conjugate-gradient curvature `p^T A p`,
    /// an incomplete Cholesky that no diagonal shift could rescue).
    #[error("the matrix is not positive definite ({method})")]
    NotPositiveDefinite { method: &'static str },
    /// The LU factorisation found the matrix singular (structurally, or its
    /// solution came out non-finite).
    #[error("the matrix is singular ({detail})")]
    Singular { detail: String },
    /// The direct solver failed for a reason other than the matrix or memory.
    #[error("the direct solver failed: {detail}")]
    Factorization { detail: String },
    /// An allocation the solver needs (the Cholesky factor's values, faer's
    /// scratch) was refused by the system: `bytes` were asked for `what`.
    /// The bindings raise it as `spherify.ResourceError`.
    #[error("could not allocate {bytes} bytes for {what}: the system refused the memory")]
    OutOfMemory { what: &'static str, bytes: u64 },
    /// An iterative solver used up its iterations. `iterations` and `residual`
    /// (the relative residual `|b - A x| / |b|`) are the worst over the
    /// right-hand sides; `last` holds the last iterate of each right-hand side,
    /// so a caller can keep or restart from it.
    #[error("no convergence after {iterations} iterations: relative residual {residual:e}")]
    NoConvergence { iterations: usize, residual: f64, last: Vec<Vec<f64>> },
}
