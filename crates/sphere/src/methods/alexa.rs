//! Alexa's method (thesis 5.3, eq. 5.17-5.19; Alexa 2000).
//!
//! Relaxation with weights that change every step: each vertex moves against the
//! length-weighted sum of its edge vectors,
//!
//! ```text
//! q_i = c_i / deg(i) * sum_{j in N(i)} (v_i - v_j) |v_i - v_j|       (5.18)
//! v_i <- (v_i - q_i) / |v_i - q_i|                                  (5.17)
//! ```
//!
//! the gradient step of the spring energy sum |v_i - v_j|^2 (5.16) with each
//! edge weighted by its own length, so long edges shrink first and the drawing
//! spreads more evenly than under plain relaxation. Alexa's step scale is
//! `c_i = 1 / max_j |v_i - v_j|` (5.19), which keeps short edges from stalling
//! the iteration; a constant `c` (Alexa's robust but slow `c = 1`) is offered too.
//!
//! Written out, `v_i - q_i = (1 - s_i) v_i + sum_j a_ij v_j` with
//! `a_ij = c_i |v_i - v_j| / deg(i)` and `s_i = sum_j a_ij`: a convex combination
//! of the vertex and its neighbours whenever `s_i <= 1`, which (5.19) always
//! gives. The collapse certificate of [`crate::methods::relaxation`] (every point in an
//! open hemisphere, which convex combinations never leave and which holds no
//! valid embedding) therefore applies. With a constant `c > 1/2` an update can
//! overshoot; there it applies only to caps of angular radius `theta` with
//! `2 c sin(theta) <= 1`, because no edge inside such a cap is longer than
//! `2 sin(theta)`.
//!
//! The update is Jacobi-style, like the thesis's MATLAB (`oldV`): every vertex
//! moves from the previous iterate, in parallel and deterministically.

use std::time::Instant;

use crate::embedding::{normalize, SphereEmbedding};
use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;
use crate::methods::initial::{initial_points, Initial};
use crate::methods::relaxation_loop::{iterate, CapLimit, Controls};

/// The step scale c_i of eq. 5.18.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AlexaStep {
    /// `c_i = 1 / max_{j in N(i)} |v_i - v_j|` (eq. 5.19), the thesis's choice.
    InverseLongestEdge,
    /// The same `c` for every vertex and step; `c = 1` is Alexa's "robust, but
    /// not very efficient" choice. Must be finite and positive.
    Constant(f64),
}

/// Parameters of [`alexa`].
#[derive(Debug, Clone)]
pub struct AlexaParams {
    pub step: AlexaStep,
    /// Most iterations of eq. 5.17 (0: only test the initial points).
    pub max_iter: usize,
    /// Run the validity test every this many iterations (the thesis's R), and
    /// always at the start and after the last iteration.
    pub check_every: usize,
    /// Also test validity when the largest move of a point in one iteration
    /// falls below `tol`.
    pub tol: f64,
    /// Return [`SphereError::NoConvergence`] instead of an embedding whose
    /// status is not `Converged`.
    pub strict: bool,
    pub initial: Initial,
}

impl Default for AlexaParams {
    fn default() -> Self {
        AlexaParams {
            step: AlexaStep::InverseLongestEdge,
            max_iter: 10_000,
            check_every: 10,
            tol: 1e-12,
            strict: false,
            initial: Initial::Centroid,
        }
    }
}

/// Alexa's method (thesis 5.3) on a closed genus-0 mesh whose faces are
/// counter-clockwise seen from outside. Stops like [`crate::methods::relaxation::relaxation`]:
/// `Converged` when the exact validity test passes, `Collapsed` when the points
/// are certain never to spread over the sphere again, `MaxIterations` otherwise.
/// O(E) per iteration, in parallel; O(F) per validity test.
pub fn alexa(mesh: &GenusZeroMesh, params: &AlexaParams) -> Result<SphereEmbedding, SphereError> {
    alexa_with_progress(mesh, params, &|_, _| true)
}

/// [`alexa`], reporting `progress(iterations, max_iter)` once per iteration: `false` stops it
/// with [`SphereError::Cancelled`] (Ctrl-C in Python).
pub fn alexa_with_progress(
    mesh: &GenusZeroMesh,
    params: &AlexaParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<SphereEmbedding, SphereError> {
    let start = Instant::now();
    let cap = match params.step {
        AlexaStep::InverseLongestEdge => CapLimit::Hemisphere,
        AlexaStep::Constant(c) if c > 0.0 && c.is_finite() => {
            if c <= 0.5 {
                CapLimit::Hemisphere
            } else {
                CapLimit::SinRadius(0.5 / c)
            }
        }
        AlexaStep::Constant(c) => {
            return Err(SphereError::InvalidParameter {
                name: "c",
                value: c.to_string(),
                expected: "a finite step scale > 0",
            })
        }
    };
    let controls = Controls::new(params.max_iter, params.check_every, params.tol, params.strict)?;
    let graph = mesh.half_edges().adjacency();
    let points = initial_points(mesh, &params.initial)?;
    let setup = start.elapsed().as_secs_f64();
    let step = params.step;
    iterate(
        mesh.faces(),
        points,
        &controls,
        cap,
        setup,
        "alexa",
        progress,
        |old: &[[f64; 3]], i: usize| {
            let vi = old[i];
            let neighbours = graph.neighbors(i as u32);
            let mut q = [0.0; 3];
            let mut longest = 0.0f64;
            for &j in neighbours {
                let vj = old[j as usize];
                let e = [vi[0] - vj[0], vi[1] - vj[1], vi[2] - vj[2]];
                let len = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
                q = [q[0] + e[0] * len, q[1] + e[1] * len, q[2] + e[2] * len];
                longest = longest.max(len);
            }
            let c = match step {
                // All neighbours on top of v_i: q = 0 and nothing moves.
                AlexaStep::InverseLongestEdge if longest > 0.0 => 1.0 / longest,
                AlexaStep::InverseLongestEdge => 0.0,
                AlexaStep::Constant(c) => c,
            };
            let scale = c / neighbours.len().max(1) as f64;
            normalize([vi[0] - scale * q[0], vi[1] - scale * q[1], vi[2] - scale * q[2]])
                .unwrap_or(vi)
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::certificate::validity::check_sphere;
    use crate::embedding::Status;
    use crate::methods::test_support::{assert_converged_and_valid, initial_points};
    use spherify_mesh::solids::{
        bent_tube, bumpy, capsule, icosphere, octahedron, perturbed_octahedron, scrambled,
    };
    use spherify_mesh::Mesh;

    /// The method on a test mesh, validated here.
    fn alexa(mesh: &Mesh, params: &AlexaParams) -> Result<SphereEmbedding, SphereError> {
        super::alexa(&GenusZeroMesh::new(mesh.clone())?, params)
    }

    #[test]
    fn perturbed_octahedron_becomes_valid() {
        let (mesh, start) = perturbed_octahedron();
        assert!(!check_sphere(mesh.faces(), &start).valid);
        let e = alexa(
            &mesh,
            &AlexaParams { initial: Initial::Points(start), check_every: 1, ..Default::default() },
        )
        .unwrap();
        assert_converged_and_valid(&mesh, &e);
        assert!(e.iterations >= 1);
    }

    #[test]
    fn plain_octahedron_is_reported_honestly() {
        // At the regular octahedron v_i - q_i = 0 for every vertex (eq. 5.17 has
        // no direction); whatever happens from a perturbed start, no lies.
        let mesh = octahedron();
        let mut start = mesh.positions().to_vec();
        start[4] = [0.3, 0.2, -0.9];
        let e =
            alexa(&mesh, &AlexaParams { initial: Initial::Points(start), ..Default::default() })
                .unwrap();
        assert_eq!(e.converged(), check_sphere(mesh.faces(), &e.points).valid, "{}", e.message);
    }

    #[test]
    fn icosphere_from_scrambled_points_becomes_valid_with_either_step() {
        let mesh = icosphere(3);
        let start = scrambled(&mesh, 0.15);
        assert!(!check_sphere(mesh.faces(), &start).valid);
        for step in [AlexaStep::InverseLongestEdge, AlexaStep::Constant(1.0)] {
            let params =
                AlexaParams { step, initial: Initial::Points(start.clone()), ..Default::default() };
            let e = alexa(&mesh, &params).unwrap();
            assert_converged_and_valid(&mesh, &e);
            assert!(e.iterations > 0 && e.iterations <= params.max_iter);
        }
    }

    #[test]
    fn bumpy_sphere_becomes_valid() {
        let mesh = bumpy(3);
        let initial = Initial::Center([0.0, 0.0, 1.4]);
        assert!(!check_sphere(mesh.faces(), &initial_points(&mesh, &initial).unwrap()).valid);
        let e = alexa(&mesh, &AlexaParams { initial, ..Default::default() }).unwrap();
        assert_converged_and_valid(&mesh, &e);
        assert!(e.iterations > 0);
    }

    #[test]
    fn straight_capsule_unfolds() {
        let mesh = capsule(8, 60, 60.0);
        assert_converged_and_valid(&mesh, &alexa(&mesh, &AlexaParams::default()).unwrap());
    }

    #[test]
    fn bent_tube_collapses() {
        let mesh = bent_tube();
        let e = alexa(&mesh, &AlexaParams { max_iter: 50_000, ..Default::default() }).unwrap();
        assert_eq!(e.status, Status::Collapsed, "{}", e.message);
        assert!(e.iterations > 100 && !check_sphere(mesh.faces(), &e.points).valid);
    }

    #[test]
    fn start_in_a_hemisphere_is_collapsed_at_once_and_strict_raises() {
        let mesh = icosphere(2);
        let params =
            AlexaParams { initial: Initial::Center([0.0, 3.0, 0.0]), ..Default::default() };
        let e = alexa(&mesh, &params).unwrap();
        assert_eq!((e.status, e.iterations), (Status::Collapsed, 0), "{}", e.message);
        let err = alexa(&mesh, &AlexaParams { strict: true, ..params }).unwrap_err();
        assert!(
            matches!(err, SphereError::NoConvergence { ref last } if last.status == Status::Collapsed)
        );
    }

    #[test]
    fn max_iter_is_respected_and_strict_raises() {
        let mesh = icosphere(3);
        let params = AlexaParams {
            initial: Initial::Points(scrambled(&mesh, 3.0)),
            max_iter: 2,
            ..Default::default()
        };
        let e = alexa(&mesh, &params).unwrap();
        assert_eq!((e.status, e.iterations), (Status::MaxIterations, 2), "{}", e.message);
        let err = alexa(&mesh, &AlexaParams { strict: true, ..params }).unwrap_err();
        assert!(matches!(err, SphereError::NoConvergence { ref last } if last.iterations == 2));
    }

    #[test]
    fn bad_parameters_are_errors() {
        let mesh = icosphere(1);
        for step in
            [AlexaStep::Constant(0.0), AlexaStep::Constant(-1.0), AlexaStep::Constant(f64::NAN)]
        {
            let err = alexa(&mesh, &AlexaParams { step, ..Default::default() }).unwrap_err();
            assert!(matches!(err, SphereError::InvalidParameter { name: "c", .. }), "{err}");
        }
        let err = alexa(&mesh, &AlexaParams { check_every: 0, ..Default::default() }).unwrap_err();
        assert!(matches!(err, SphereError::InvalidParameter { name: "check_every", .. }));
    }
}
