//! spherify-mesh: triangle meshes for spherical parameterisation.
//!
//! * [`Mesh`]: validated position and face arrays (finite, indices in range).
//! * [`validate`]: the full topological report of thesis Prop. 2.8 and more.
//! * [`halfedge::HalfEdgeMesh`]: connectivity of an oriented manifold mesh.
//! * [`orient`]: consistent, outward orientation (thesis Alg. 2.9, seedless).
//! * [`io`]: OBJ, OFF, PLY and STL read and write.
//! * [`cut`]: cutting a closed mesh open along a path into a disk (thesis 6.3).
//! * [`dijkstra`]: single-source shortest paths on the vertex graph (thesis App. A).
//! * [`predicates`]: exact orientation signs on which every validity decision rests.
//! * [`surface_heights`], [`feature_nearest`], [`cell_grid`]: registration's descriptor pairs
//!   (the height of the surface over its neighbourhood, the nearest candidate in position and
//!   height, the uniform grid both search; issue 23).
//! * [`lcg`]: the deterministic generator of the tests of every crate.

pub mod cell_grid;
pub mod closest_point;
pub mod cut;
pub mod dijkstra;
pub mod edge_table;
pub mod error;
pub mod feature_nearest;
pub mod graph;
pub mod halfedge;
pub mod huge_pages;
pub mod io;
pub mod lcg;
pub mod mesh;
pub mod orient;
pub mod predicates;
pub mod solids;
pub mod spatial_order;
pub mod surface_heights;
pub mod validate;
pub mod vec3;
mod volume;
pub mod weld;

pub use error::{FormatError, Location, MeshError, TopologyError, TopologyProblem, UnknownName};
pub use graph::Adjacency;
pub use halfedge::HalfEdgeMesh;
pub use mesh::Mesh;
pub use validate::MeshReport;
