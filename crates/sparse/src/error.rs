//! Errors of the sparse crate. Every failure a caller can cause is a variant with
//! the data that says what is wrong; the Python bindings map them to
//! `spherify.MeshError` (bad shapes and indices) per DESIGN.md.

/// Every error of the sparse crate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SparseError {
    /// A triplet addresses an entry outside the matrix.
    #[error("entry {entry} is at row {row}, column {col}, outside the {n_rows} x {n_cols} matrix")]
    IndexOutOfRange { entry: usize, row: u32, col: u32, n_rows: usize, n_cols: usize },
    /// An array does not have the length the operation needs (`what` names it).
    #[error("{what} has length {got}, but {expected} is needed")]
    LengthMismatch { what: &'static str, got: usize, expected: usize },
}
