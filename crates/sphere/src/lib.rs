//! spherify-sphere: maps of closed genus-0 meshes onto the unit sphere.
//!
//! * [`predicates`]: exact orientation signs (2D orientation, the 3x3 determinant
//!   of thesis eq. 3.9, collinearity), re-exported from `spherify-mesh`, where they
//!   live because mesh validation and the 2D Tutte check in `spherify-sparse` need
//!   them too.
//!
//! * [`validity`]: the orientation and area tests of thesis 3.4 that decide
//!   whether points on the sphere form a GC-embedding.
//!
//! Still to come here (see DESIGN.md): the spherical methods of thesis ch. 3
//! (radial projection, relaxation, Alexa, Gotsman), ch. 5 and ch. 6 (the
//! theta-phi method: poles, cut path, the two Tutte-like systems of 6.27), the
//! validity tests of 3.4 built on [`predicates`], quality measures (angle,
//! conformal, area and stretch distortion), and point maps between surface and
//! sphere (3.3, 6.6).

pub mod alexa;
pub mod bvh;
pub mod cut_path;
pub mod dogleg;
pub mod embed;
pub mod embedding;
pub mod error;
pub mod gc_map;
pub mod genus_zero;
pub mod gotsman;
pub mod h_map;
pub mod initial;
pub mod jacobi;
pub mod kernel;
pub mod lp;
pub mod metrics;
pub mod point_map;
pub mod pole_fans;
pub mod poles;
pub mod radial;
pub mod relaxation;
pub mod symmetry;
pub mod theta_phi;
pub mod validity;
pub mod weight_matrix;

pub use embed::{embed, Details, Embedding, Method, MethodName, UnknownMethod};
pub use embedding::{SphereEmbedding, Status};
pub use error::SphereError;
pub use genus_zero::GenusZeroMesh;
pub use spherify_mesh::predicates;
pub use spherify_mesh::predicates::Sign;
pub use validity::{check_sphere, SphereReport};
