//! How a spherical method fails: one error enum for the crate (STYLE 6).

use spherify_mesh::TopologyError;
use spherify_sparse::SparseError;

use crate::embedding::SphereEmbedding;

/// Why a spherical method could not produce points at all.
#[derive(Debug, Clone, thiserror::Error)]
pub enum SphereError {
    #[error(transparent)]
    Topology(#[from] TopologyError),
    /// Radial projection from the kernel: the mesh is not star-shaped.
    #[error("the mesh is not star-shaped: no point sees every face from inside (the kernel is empty{detail})")]
    NotStarShaped { detail: String },
    /// A parameter outside its range.
    #[error("{name} = {value}: {expected}")]
    InvalidParameter { name: &'static str, value: String, expected: &'static str },
    /// The caller asked for `strict` and the method did not converge; `last`
    /// holds where it stopped.
    #[error("{} after {} iterations: {}", last.status.name(), last.iterations, last.message)]
    NoConvergence { last: Box<SphereEmbedding> },
    #[error(transparent)]
    Solve(#[from] SparseError),
    /// Points given for a map ([`crate::from_points`]) do not match the mesh.
    #[error("points has {points} rows, but the mesh has {vertices} vertices")]
    PointCount { points: usize, vertices: usize },
    /// A given point with no direction: not finite, or the zero vector.
    #[error("points row {row}: {point:?} has no direction (not finite, or zero)")]
    BadPoint { row: usize, point: [f64; 3] },
    /// A progress callback asked a long stage to stop.
    #[error("{stage} stopped by the progress callback after {done} of {total} steps")]
    Cancelled { stage: &'static str, done: usize, total: usize },
}
