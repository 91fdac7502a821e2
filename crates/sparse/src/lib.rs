//! spherify-sparse: sparse linear algebra for spherical parameterisation.
//!
//! * [`csr`]: compressed sparse row matrices ([`CsrMatrix`]) built from triplets,
//!   with matrix-vector products, transpose, diagonal and row scaling.
//!
//! Still to come here (see DESIGN.md): Gauss-Seidel (thesis 4.5), preconditioned
//! conjugate gradients, a fast default solver, and the 2D Tutte embedding of a
//! disk with a convex boundary (ch. 4) with its weights (4.4).

pub mod csr;
pub mod error;

pub use csr::CsrMatrix;
pub use error::SparseError;
