//! Errors of the mesh crate. Every failure a caller can cause is a variant with
//! the data that says what is wrong and where; the Python bindings map each
//! variant to the exception hierarchy of DESIGN.md.

use crate::validate::MeshReport;
use std::fmt;

/// Where in a file a format error was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// 1-based line number of a text file.
    Line(u64),
    /// 0-based byte offset into a binary file.
    Byte(u64),
    /// The file as a whole (for instance an unknown extension).
    File,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(line) => write!(f, "line {line}"),
            Location::Byte(offset) => write!(f, "byte {offset}"),
            Location::File => write!(f, "file"),
        }
    }
}

/// A malformed file: names the file, the place and what was expected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{path}, {location}: {message}")]
pub struct FormatError {
    pub path: String,
    pub location: Location,
    pub message: String,
}

impl FormatError {
    pub fn new(path: &str, location: Location, message: impl Into<String>) -> Self {
        FormatError { path: path.to_string(), location, message: message.into() }
    }
}

/// A name outside a closed set of choices (a PLY encoding, a solver, a weight
/// type): what was given, and every name that would have been accepted, so
/// the bindings, a command line and the docs all say the same thing.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown {what} '{name}'; expected one of: {}", .expected.join(", "))]
pub struct UnknownName {
    /// What the name should have named, e.g. `"weights"`.
    pub what: &'static str,
    /// The name given.
    pub name: String,
    /// The accepted names, in their documented order.
    pub expected: Vec<&'static str>,
}

impl UnknownName {
    /// The position of `name` in `names`, or the error listing them. Exact,
    /// case-sensitive match: the names are identifiers, not prose.
    pub fn position(
        what: &'static str,
        name: &str,
        names: &[&'static str],
    ) -> Result<usize, UnknownName> {
        names.iter().position(|&n| n == name).ok_or_else(|| UnknownName {
            what,
            name: name.to_string(),
            expected: names.to_vec(),
        })
    }
}

/// What makes a mesh unusable for an operation that needs a certain topology.
#[derive(Debug, Clone, PartialEq)]
pub enum TopologyProblem {
    /// The operation needs a closed, connected, manifold genus-0 mesh.
    NotSphere,
    /// The operation needs a topological disk (one boundary loop, Euler
    /// characteristic 1); the mesh has `loops` boundary loops and Euler
    /// characteristic `euler`.
    NotDisk { loops: usize, euler: i64 },
    /// An edge is shared by more than two faces, or twice in the same direction.
    NonManifoldEdge { a: u32, b: u32, faces: usize },
    /// The faces around a vertex do not form a single fan.
    NonManifoldVertex { vertex: u32 },
    /// A vertex is used by no face, so it has no place on the surface.
    UnreferencedVertex { vertex: u32 },
    /// A face uses the same vertex twice.
    RepeatedIndex { face: u32 },
    /// No consistent orientation exists (a Moebius-like band); `face` is where the
    /// orientation propagation met itself with the wrong sign.
    NotOrientable { face: u32 },
    /// The faces are not consistently oriented, where the operation needs them to be.
    InconsistentOrientation { a: u32, b: u32 },
}

impl fmt::Display for TopologyProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TopologyProblem::NotSphere => {
                write!(f, "the mesh is not a closed, connected, manifold genus-0 surface")
            }
            TopologyProblem::NotDisk { loops, euler } => write!(
                f,
                "the mesh is not a topological disk: it has {loops} boundary loop{} and Euler characteristic {euler}, where a disk has one loop and Euler characteristic 1",
                if *loops == 1 { "" } else { "s" }
            ),
            TopologyProblem::NonManifoldEdge { a, b, faces } => write!(
                f,
                "edge ({a}, {b}) is non-manifold: it is used by {faces} faces or twice in one direction"
            ),
            TopologyProblem::NonManifoldVertex { vertex } => write!(
                f,
                "vertex {vertex} is non-manifold: the faces around it do not form one fan"
            ),
            TopologyProblem::UnreferencedVertex { vertex } => {
                write!(f, "vertex {vertex} is not used by any face")
            }
            TopologyProblem::RepeatedIndex { face } => {
                write!(f, "face {face} uses the same vertex more than once")
            }
            TopologyProblem::NotOrientable { face } => write!(
                f,
                "the surface is not orientable: orienting consistently from a seed face contradicts itself at face {face}"
            ),
            TopologyProblem::InconsistentOrientation { a, b } => write!(
                f,
                "the faces are not consistently oriented: edge ({a}, {b}) is used twice in the same direction (run orient first)"
            ),
        }
    }
}

/// A mesh whose topology does not allow the requested operation. Carries the full
/// validation report so that callers can see every problem at once.
#[derive(Debug, Clone, thiserror::Error)]
#[error("{problem}{}", summary(report))]
pub struct TopologyError {
    pub problem: TopologyProblem,
    pub report: Box<MeshReport>,
}

fn summary(report: &MeshReport) -> String {
    if report.problems.is_empty() {
        String::new()
    } else {
        format!(" ({})", report.problems.join("; "))
    }
}

/// Every error of the mesh crate.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("the mesh has no vertices")]
    NoVertices,
    #[error("the mesh has no faces")]
    NoFaces,
    #[error("the mesh has {n_vertices} vertices; spherify indexes vertices with 32 bits and handles at most {max}")]
    TooManyVertices { n_vertices: usize, max: usize },
    #[error("vertex {vertex} has a non-finite coordinate ({value})")]
    NonFiniteCoordinate { vertex: usize, value: f64 },
    #[error("face {face} refers to vertex {index}, but the mesh has {n_vertices} vertices (valid indices are 0 to {})", n_vertices.saturating_sub(1))]
    IndexOutOfRange { face: usize, index: i64, n_vertices: usize },
    #[error("{what} has length {got}, but the mesh has {expected} vertices")]
    AttributeLength { what: &'static str, got: usize, expected: usize },
    #[error("{path}: vertex {vertex} has the coordinate {value:e}, which {format}'s 32-bit floats cannot hold (it would become infinity or zero); save as .ply, .obj or .off, which keep float64, or rescale the mesh")]
    NotRepresentable { path: String, vertex: usize, value: f64, format: &'static str },
    #[error(transparent)]
    Format(#[from] FormatError),
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Topology(#[from] TopologyError),
}

impl MeshError {
    pub fn io(path: &std::path::Path, source: std::io::Error) -> Self {
        MeshError::Io { path: path.display().to_string(), source }
    }
}
