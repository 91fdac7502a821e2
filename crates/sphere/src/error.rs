//! How a spherical method fails: one error enum for the crate (STYLE 6).

use spherify_mesh::TopologyError;
use spherify_sparse::SparseError;

use crate::embedding::SphereEmbedding;
use crate::memory_budget::ResourceError;

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
    /// The progressive method found no point for a re-inserted vertex at
    /// which its faces are positive in double precision, even after moving
    /// its neighbourhood.
    #[error("vertex {vertex} (with {neighbours} neighbours at its level) could not be re-inserted: its ring's kernel is too thin for double precision even after moving its neighbourhood")]
    Insertion { vertex: usize, neighbours: usize },
    /// A map that was to be improved is not a valid GC-embedding.
    #[error("the map to improve is not a valid GC-embedding ({flipped} faces not positive, covering degree {degree}): improve only starts from a valid map")]
    InvalidStart { flipped: usize, degree: i64 },
    /// Points given for a map ([`crate::point_map::from_points`]) do not match the mesh.
    #[error("points has {points} rows, but the mesh has {vertices} vertices")]
    PointCount { points: usize, vertices: usize },
    /// A given point with no direction: not finite, or the zero vector.
    #[error("points row {row}: {point:?} has no direction (not finite, or zero)")]
    BadPoint { row: usize, point: [f64; 3] },
    /// Coordinates no method can map in double precision: a degenerate mesh,
    /// or one too large or too small ([`crate::certificate::geometry_range`]).
    #[error("{message}")]
    Geometry { message: String },
    /// Landmarks that no map can take as given: ids out of range or repeated,
    /// targets with no direction, two landmarks at one point
    /// ([`crate::methods::progressive::landmarks::Landmarks::new`]).
    #[error("landmarks {}: {reason}", list_ids(ids))]
    BadLandmarks { ids: Vec<usize>, reason: String },
    /// Landmarks that could not all be pinned to their targets: a set no
    /// valid map realises (two neighbours at opposite points, a face of three
    /// landmarks upside down), or a drag that stalled after its bounded work.
    #[error("landmarks {} cannot all be pinned to their targets: {reason}", list_ids(ids))]
    LandmarkConflict { ids: Vec<usize>, reason: String },
    /// The call does not fit in the memory the process can have
    /// ([`crate::memory_budget`]): refused before it started, or an
    /// allocation of one of its large buffers failed.
    #[error(transparent)]
    Resource(#[from] ResourceError),
    /// A progress callback asked a long stage to stop.
    #[error("{stage} stopped by the progress callback after {done} of {total} steps")]
    Cancelled { stage: &'static str, done: usize, total: usize },
}

/// Vertex ids for a message: the first 20 and how many more.
fn list_ids(ids: &[usize]) -> String {
    let shown: Vec<String> = ids.iter().take(20).map(|i| i.to_string()).collect();
    match ids.len() {
        n if n > 20 => format!("{} (and {} more)", shown.join(", "), n - 20),
        _ => shown.join(", "),
    }
}
