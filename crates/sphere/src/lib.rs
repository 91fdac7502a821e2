//! spherify-sphere: maps of closed genus-0 meshes onto the unit sphere.
//!
//! The folders follow the roles: the methods make a map, the certificate says
//! whether it is one, the point maps use it, the applications build on it.
//! Dependencies run one way: `applications` use `point_map`, which uses the
//! methods' results (through `embed`) and the theta-phi fold and rectangle;
//! `methods` use `certificate` and the shared types (`genus_zero`,
//! `embedding`, `error`); `certificate` uses nothing above it. Only tests
//! reach the other way (the methods' tests measure with `applications`).
//!
//! Entry and results:
//! * [`genus_zero`]: [`GenusZeroMesh`], the validated mesh every method takes (STYLE 5).
//! * [`mod@embed`]: one entry point, [`embed()`], for every method and its parameters.
//! * [`method_options`]: the keyword options of every method, their kinds, defaults and
//!   choices: the one table the bindings, the API, the batch and the CLI read.
//! * [`embedding`]: [`SphereEmbedding`], the points and account every method returns.
//! * [`error`]: [`SphereError`], how a method fails.
//! * [`memory_budget`]: the memory policy: each call's estimate checked against what the
//!   process can still get before it starts, and fallible allocation of the large buffers.
//!
//! [`methods`], one file or folder per family:
//! * [`methods::radial`]: radial projection from a point, the vertex mean or the kernel (3.5, eq. 3.17-3.18).
//!   * [`methods::radial::kernel`]: the kernel of a star-shaped mesh and its deepest point (3.5, 9.3.1).
//!   * [`methods::radial::lp`]: the small active-set simplex method the kernel LP runs on.
//! * [`methods::relaxation`]: iterative relaxation (5.2, eq. 5.13-5.15).
//! * [`methods::alexa`]: Alexa's method (5.3, eq. 5.17-5.19).
//! * [`methods::relaxation_loop`]: the sweep loop and collapse certificate those two share.
//! * [`methods::initial`]: starting points of the iterative methods and the vertex mean (eq. 3.18, 5.11-5.14).
//! * [`methods::weight_matrix`]: the row-stochastic weights of the spherical Tutte methods (eq. 5.3-5.4, 5.9).
//! * [`methods::gotsman`]: Gotsman, Gu and Sheffer's system solved by Newton's method (5.1, eq. 5.10).
//!   * `methods::gotsman::newton_system`: the equations of eq. 5.10 and their Newton step.
//!   * [`methods::gotsman::dogleg`]: the dogleg trust region of that Newton iteration.
//! * [`methods::theta_phi`]: the theta-phi method, a bijection for every genus-0 mesh (ch. 6).
//!   * [`methods::theta_phi::poles`]: pole selection (6.2.1-6.2.3), with `poles::farthest_pair`,
//!     the exact farthest pair of eq. 6.1-6.2.
//!   * [`methods::theta_phi::symmetry`]: poles and cut path near a symmetry plane (6.2.5).
//!   * [`methods::theta_phi::symmetric_eigen`]: 3x3 symmetric eigen-decomposition for that plane (eq. 6.15).
//!   * [`methods::theta_phi::cut_path`]: the chordless, lengthened north-south cut path (6.2.4).
//!   * `methods::theta_phi::cut_rotations`: the cut disk's connectivity read from the sphere's half-edges (6.3).
//!   * [`methods::theta_phi::rectangle`]: the cut disk's Tutte embedding in the rectangle, refined and measured (6.4).
//!   * [`methods::theta_phi::pole_fans`]: the rectangle boundary and the pole fans (6.4, 6.5.1, eq. 6.31, 6.36-6.38).
//!   * [`methods::theta_phi::fold`]: the fold m onto the sphere and its inverse (eq. 6.35, 6.57).
//! * [`methods::progressive`]: progressive meshes with exact insertion and flip-free optimisation (9.3.3).
//!   * `hierarchy`, `ring_mesh`, `placement`, `conformal`: the collapses, the mesh they edit,
//!     where a vertex is re-inserted, and the conformal energy's certified start.
//!   * [`methods::progressive::flip_free`]: vertex moves that keep every face positive (9.3.2).
//!   * [`methods::progressive::improve`]: those moves started from any valid map (9.3.2).
//!   * [`methods::progressive::distortion_energy`]: the isometric (default), balanced, conformal, authalic and stretch energies.
//!   * [`methods::progressive::authalic_newton`]: global Gauss-Newton steps towards equal areas.
//!   * [`methods::progressive::conformal_start`]: a certified global conformal map, the conformal energy's start.
//!   * [`methods::progressive::mobius_centring`]: the Möbius transformation that balances a map's area.
//!
//! [`certificate`], whether a map is one:
//! * [`certificate::validity`]: the exact orientation and area tests of a GC-embedding (3.4).
//! * [`certificate::geometry_range`]: coordinates no method can work with, refused up front.
//! * [`predicates`]: exact orientation signs, re-exported from `spherify-mesh`.
//!
//! [`point_map`], using a map: many points at once between surface and sphere (3.3, 6.6):
//! * [`point_map::gc_map`]: the surface-sphere map of a valid GC-embedding (3.3, Prop. 3.3).
//! * [`point_map::h_map`]: the theta-phi map h and its inverse (6.6).
//! * [`point_map::bvh`]: the box tree that locates points for them.
//! * [`point_map::weight_bound`]: how far barycentric weights can be from the exact ones.
//! * [`point_map::from_points`]: a map made elsewhere, given as points, certified like the rest.
//! * [`point_map::restore`]: a stored map rebuilt, its certificates computed again.
//!
//! [`applications`] (ch. 8):
//! * [`applications::harmonics`]: the real spherical-harmonic transform of a surface through its map (8.3).
//!   * [`applications::harmonics::legendre`]: the normalised associated Legendre functions it runs on.
//!   * [`applications::harmonics::gauss_legendre`]: its quadrature nodes in cos(theta).
//! * [`applications::metrics`]: angle, conformal, area and stretch distortion.

pub mod applications;
pub mod certificate;
pub mod embed;
pub mod embedding;
pub mod error;
pub mod genus_zero;
pub mod memory_budget;
pub mod method_options;
pub mod methods;
pub mod point_map;

/// README.md's Rust snippet, compiled as a doc test so that it stays true.
#[cfg(doctest)]
#[doc = include_str!("../../../README.md")]
pub struct ReadmeSnippets;

pub use certificate::validity::{check_sphere, SphereReport};
pub use embed::{
    embed, improve_embedding, move_towards_embedding, pin_embedding, pin_or_refine_embedding,
    pull_towards_embedding, Details, Embedding, Method, MethodName, UnknownMethod,
};
pub use embedding::{SphereEmbedding, Status};
pub use error::SphereError;
pub use genus_zero::GenusZeroMesh;
pub use spherify_mesh::predicates;
pub use spherify_mesh::predicates::Sign;
