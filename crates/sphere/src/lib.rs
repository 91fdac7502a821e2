//! spherify-sphere: maps of closed genus-0 meshes onto the unit sphere.
//!
//! Entry and results:
//! * [`genus_zero`]: [`GenusZeroMesh`], the validated mesh every method takes (STYLE 5).
//! * [`embed`]: one entry point, [`embed()`], for every method and its parameters.
//! * [`method_options`]: the keyword options of every method, their kinds, defaults and
//!   choices: the one table the bindings, the API, the batch and the CLI read.
//! * [`embedding`]: [`SphereEmbedding`], the points and account every method returns.
//! * [`from_points`]: a map made elsewhere, given as points, certified like the rest.
//! * [`error`]: [`SphereError`], how a method fails.
//!
//! The methods:
//! * [`radial`]: radial projection from a point, the vertex mean or the kernel (3.5, eq. 3.17-3.18).
//! * [`kernel`]: the kernel of a star-shaped mesh and its deepest point (3.5, 9.3.1).
//! * [`lp`]: the small active-set simplex method the kernel LP runs on.
//! * [`relaxation`]: iterative relaxation (5.2, eq. 5.13-5.15).
//! * [`alexa`]: Alexa's method (5.3, eq. 5.17-5.19).
//! * [`gotsman`]: Gotsman, Gu and Sheffer's system solved by Newton's method (5.1, eq. 5.10).
//! * [`dogleg`]: the dogleg trust region of that Newton iteration.
//! * [`progressive`]: progressive meshes with exact insertion and flip-free optimisation (9.3.3).
//! * [`conformal_start`]: a certified global conformal map, the conformal energy's start.
//! * [`mobius_centring`]: the Möbius transformation that balances a map's area.
//! * [`distortion_energy`]: the isometric, conformal, authalic and stretch energies it lowers.
//! * [`authalic_newton`]: global Gauss-Newton steps towards equal areas for the authalic energy.
//! * [`flip_free`]: vertex moves that keep every face positive (9.3.2).
//! * [`improve`]: those moves started from any valid map (9.3.2).
//! * [`theta_phi`]: the theta-phi method, a bijection for every genus-0 mesh (ch. 6).
//! * [`poles`]: pole selection for theta-phi (6.2.1-6.2.3).
//! * [`symmetry`]: poles and cut path near a symmetry plane (6.2.5).
//! * [`symmetric_eigen`]: 3x3 symmetric eigen-decomposition for the symmetry plane (eq. 6.15).
//! * [`cut_path`]: the chordless, lengthened north-south cut path (6.2.4).
//! * [`pole_fans`]: the rectangle boundary and the pole fans (6.4, 6.5.1, eq. 6.31, 6.36-6.38).
//! * [`initial`]: starting points of the iterative methods and the vertex mean (eq. 3.18, 5.11-5.14).
//! * [`weight_matrix`]: the row-stochastic weights of the spherical Tutte methods (eq. 5.3-5.4, 5.9).
//!
//! Checking and using a map:
//! * [`validity`]: the exact orientation and area tests of a GC-embedding (3.4).
//! * [`predicates`]: exact orientation signs, re-exported from `spherify-mesh`.
//! * [`metrics`]: angle, conformal, area and stretch distortion.
//! * [`gc_map`]: the surface-sphere map of a valid GC-embedding (3.3, Prop. 3.3).
//! * [`h_map`]: the theta-phi map h and its inverse (6.6).
//! * [`point_map`]: many points at once between surface and sphere (3.3, 6.6).
//! * [`restore`]: a stored map rebuilt, its certificates computed again.
//! * [`bvh`]: the box tree that locates points for them.
//!
//! Applications (ch. 8):
//! * [`harmonics`]: the real spherical-harmonic transform of a surface through its map (8.3).
//! * [`legendre`]: the normalised associated Legendre functions it runs on.
//! * [`gauss_legendre`]: its quadrature nodes in cos(theta).

pub mod alexa;
pub mod authalic_newton;
pub mod bvh;
pub mod conformal_start;
pub mod cut_path;
mod cut_rotations;
pub mod distortion_energy;
pub mod dogleg;
pub mod embed;
pub mod embedding;
pub mod error;
pub mod flip_free;
pub mod from_points;
pub mod gauss_legendre;
pub mod gc_map;
pub mod genus_zero;
pub mod geometry_range;
pub mod gotsman;
pub mod h_map;
pub mod harmonics;
pub mod improve;
pub mod initial;
pub mod kernel;
pub mod legendre;
pub mod lp;
pub mod method_options;
pub mod metrics;
pub mod mobius_centring;
pub mod point_map;
pub mod pole_fans;
pub mod poles;
pub mod progressive;
pub mod radial;
pub mod relaxation;
pub mod relaxation_loop;
pub mod restore;
pub mod symmetric_eigen;
pub mod symmetry;
pub mod theta_phi;
pub mod validity;
pub mod weight_bound;
pub mod weight_matrix;

/// README.md's Rust snippet, compiled as a doc test so that it stays true.
#[cfg(doctest)]
#[doc = include_str!("../../../README.md")]
pub struct ReadmeSnippets;

pub use embed::{embed, improve_embedding, Details, Embedding, Method, MethodName, UnknownMethod};
pub use embedding::{SphereEmbedding, Status};
pub use error::SphereError;
pub use genus_zero::GenusZeroMesh;
pub use spherify_mesh::predicates;
pub use spherify_mesh::predicates::Sign;
pub use validity::{check_sphere, SphereReport};
