//! spherify-sparse: sparse linear algebra for spherical parameterisation.
//!
//! * [`csr`]: compressed sparse row matrices ([`CsrMatrix`]) built from triplets,
//!   with matrix-vector products, transpose, diagonal and row scaling.
//! * [`solve()`]: one entry point for `A x = b` with several right-hand sides,
//!   choosing among a sparse direct solver (Cholesky / LU from `faer`),
//!   conjugate gradients with Jacobi or IC(0) preconditioning, and the
//!   Gauss-Seidel iteration of thesis 4.5 ([`SolverKind`], [`SolveParams`],
//!   [`SolveInfo`]).
//!
//! * [`tutte`]: the generalised 2D Tutte embedding of a disk with a convex
//!   boundary (thesis 4.3), checked triangle by triangle with an exact predicate,
//!   with the weights of [`weights`] (thesis 4.4: uniform, chord length, and
//!   beyond the thesis mean-value and cotangent).

pub mod csr;
pub mod error;
pub mod refine;
pub mod tutte;
pub mod weights;

mod cg;
mod direct;
mod gauss_seidel;
mod nested_dissection;
mod preconditioner;
mod solve;
mod solver_kind;
#[cfg(test)]
mod test_support;
mod vector;

pub use csr::CsrMatrix;
pub use direct::orderings::{ordering_report, OrderingStats};
pub use direct::{release_free_memory, Factorization};
pub use error::SparseError;
pub use solve::{solve, SolveInfo, SolveParams};
pub use solver_kind::SolverKind;
