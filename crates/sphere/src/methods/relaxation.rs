//! The method of iterative relaxation (thesis 5.2, eq. 5.13-5.15).
//!
//! Start from the vertices pushed radially onto the sphere from a centre point
//! (eq. 5.13, the centroid of eq. 5.14 unless the caller names a centre or gives
//! points), then replace every vertex by the projection onto the sphere of a
//! convex combination of its neighbours, `v_i <- u_i / |u_i|` with
//! `U = W V` (eq. 5.15), until the exact validity test of thesis 3.4 passes.
//!
//! The update is Jacobi-style, as eq. 5.15 writes it (`U^(r) = W V^(r)`: every
//! vertex moves from the previous iterate) and as the thesis's MATLAB does
//! (`U = W*V`). That makes one iteration a sparse matrix product whose rows are
//! independent, so it runs in parallel and gives the same bits on any number of
//! threads; a Gauss-Seidel sweep would be sequential and its result would depend
//! on the vertex order.
//!
//! Relaxation is power iteration in disguise: the constant vector is W's
//! dominant eigenvector, so the drawing tends to contract towards one point, the
//! trivial solution of eq. 5.10 (thesis 5.2, 7.3). We stop as soon as that
//! contraction is certain to be final. If every point lies in an open hemisphere
//! `n . v > 0`, a convex combination of them does too, and so does its
//! projection; the points can then never leave it. A valid drawing covers the
//! whole sphere (all faces positive and covering degree 1 make the map onto),
//! and minor-arc triangles inside an open hemisphere cannot, so from that moment
//! no valid embedding can be reached. The test is cheap: `n` is the mean
//! direction of the points and the measure is the angular radius of the cap about
//! `n` that holds them all (below 90 degrees: collapsed).
//!
//! The driver (initial points, checks, stopping rules, timing, and the
//! collapse certificate above) is in [`crate::methods::relaxation_loop`], shared with
//! Alexa's method in [`crate::methods::alexa`], which differs only in its update.

use std::time::Instant;

use spherify_sparse::weights::Weights;

use crate::embedding::{normalize, SphereEmbedding};
use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;
use crate::methods::initial::{initial_points, Initial};
use crate::methods::relaxation_loop::{iterate, CapLimit, Controls};
use crate::methods::weight_matrix::{row_stochastic, Positivity};

/// Parameters of [`relaxation`].
#[derive(Debug, Clone)]
pub struct RelaxationParams {
    /// The weights w_ij of eq. 5.3-5.4, from the mesh's own geometry; each row is
    /// normalised to sum to 1. Uniform (Tutte) and chord-length weights are the
    /// thesis's; mean-value weights are positive too; cotangent weights can be
    /// negative, and then the collapse test (which needs convex combinations) is
    /// switched off.
    pub weights: Weights,
    /// Most iterations of eq. 5.15 (0: only test the initial points).
    pub max_iter: usize,
    /// Run the validity test every this many iterations (the thesis's R), and
    /// always at the start and after the last iteration.
    pub check_every: usize,
    /// Also test validity when the largest move of a point in one iteration
    /// falls below `tol` (the iteration has settled).
    pub tol: f64,
    /// Return [`SphereError::NoConvergence`] instead of an embedding whose
    /// status is not `Converged`.
    pub strict: bool,
    pub initial: Initial,
}

impl Default for RelaxationParams {
    fn default() -> Self {
        RelaxationParams {
            weights: Weights::Uniform,
            max_iter: 10_000,
            check_every: 10,
            tol: 1e-12,
            strict: false,
            initial: Initial::Centroid,
        }
    }
}

/// Iterative relaxation (thesis 5.2) on a closed genus-0 mesh whose faces are
/// counter-clockwise seen from outside.
///
/// Ends `Converged` when the exact validity test passes (at a scheduled check, or
/// when the iteration has settled), `Collapsed` when every point lies in an open
/// hemisphere (see the module notes), `MaxIterations` otherwise. Cost per
/// iteration O(E), in parallel; a validity test O(F).
pub fn relaxation(
    mesh: &GenusZeroMesh,
    params: &RelaxationParams,
) -> Result<SphereEmbedding, SphereError> {
    relaxation_with_progress(mesh, params, &|_, _| true)
}

/// [`relaxation`], reporting `progress(iterations, max_iter)` once per
/// iteration: `false` stops it with [`SphereError::Cancelled`] (Ctrl-C in
/// Python).
pub fn relaxation_with_progress(
    mesh: &GenusZeroMesh,
    params: &RelaxationParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<SphereEmbedding, SphereError> {
    let start = Instant::now();
    if let Weights::Chord { rho } = params.weights {
        if !rho.is_finite() {
            return Err(SphereError::InvalidParameter {
                name: "rho",
                value: rho.to_string(),
                expected: "a finite exponent",
            });
        }
    }
    let controls = Controls::new(params.max_iter, params.check_every, params.tol, params.strict)?;
    let w = row_stochastic(mesh, params.weights, Positivity::RowSums)?;
    let points = initial_points(mesh, &params.initial)?;
    // Convex combinations keep points in a hemisphere only when no weight is negative.
    let cap =
        if w.values().iter().all(|&x| x >= 0.0) { CapLimit::Hemisphere } else { CapLimit::None };
    let setup = start.elapsed().as_secs_f64();
    iterate(
        mesh.faces(),
        points,
        &controls,
        cap,
        setup,
        "relaxation",
        progress,
        |old: &[[f64; 3]], i: usize| {
            let mut u = [0.0; 3];
            let (cols, vals) = w.row(i);
            for (&j, &wij) in cols.iter().zip(vals) {
                let p = old[j as usize];
                u = [u[0] + wij * p[0], u[1] + wij * p[1], u[2] + wij * p[2]];
            }
            // u = 0 (neighbours cancelling exactly) has no direction: stay put.
            normalize(u).unwrap_or(old[i])
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::certificate::validity::check_sphere;
    use crate::embedding::Status;
    use crate::methods::relaxation_loop::{enclosing_cap, point_sum};
    use crate::methods::test_support::{assert_converged_and_valid, initial_points};
    use spherify_mesh::solids::{
        bent_tube, bumpy, capsule, icosphere, octahedron, octasphere, perturbed_octahedron,
        scrambled,
    };
    use spherify_mesh::{validate, Mesh};

    /// The method on a test mesh, validated here.
    fn relaxation(mesh: &Mesh, params: &RelaxationParams) -> Result<SphereEmbedding, SphereError> {
        super::relaxation(&GenusZeroMesh::new(mesh.clone())?, params)
    }

    fn assert_valid(mesh: &Mesh, e: &SphereEmbedding) {
        assert_converged_and_valid(mesh, e);
        assert_eq!(e.seconds.iter().map(|s| s.0).collect::<Vec<_>>(), vec!["setup", "iterate"]);
    }

    #[test]
    fn topology_and_the_test_mesh_builders_are_sound() {
        for mesh in [
            icosphere(2),
            octasphere(2),
            perturbed_octahedron().0,
            bumpy(2),
            capsule(8, 20, 30.0),
            bent_tube(),
            octahedron(),
        ] {
            let report = validate::check(&mesh);
            assert!(report.is_sphere_topology && report.outward, "{:?}", report.problems);
        }
    }

    #[test]
    fn perturbed_octahedron_becomes_valid() {
        let (mesh, start) = perturbed_octahedron();
        assert!(!check_sphere(mesh.faces(), &start).valid);
        for weights in [Weights::Uniform, Weights::Chord { rho: 1.0 }] {
            let params = RelaxationParams {
                weights,
                initial: Initial::Points(start.clone()),
                check_every: 1,
                ..Default::default()
            };
            let e = relaxation(&mesh, &params).unwrap();
            assert_valid(&mesh, &e);
            assert!(e.iterations >= 1);
        }
    }

    #[test]
    fn plain_octahedron_is_degenerate_and_reported_honestly() {
        // At the regular octahedron every vertex's four neighbours sum to zero,
        // so eq. 5.15 has no direction to project; a perturbed start falls into
        // a hemisphere at once. Whatever happens, the status must not lie.
        let mesh = octahedron();
        let mut start = mesh.positions().to_vec();
        start[4] = [0.3, 0.2, -0.9];
        let e = relaxation(
            &mesh,
            &RelaxationParams { initial: Initial::Points(start), ..Default::default() },
        )
        .unwrap();
        assert_eq!(e.converged(), check_sphere(mesh.faces(), &e.points).valid, "{}", e.message);
    }

    #[test]
    fn icosphere_from_scrambled_points_becomes_valid() {
        let mesh = icosphere(3);
        let start = scrambled(&mesh, 0.15);
        assert!(!check_sphere(mesh.faces(), &start).valid);
        for weights in [Weights::Uniform, Weights::Chord { rho: 1.0 }, Weights::MeanValue] {
            let params = RelaxationParams {
                weights,
                initial: Initial::Points(start.clone()),
                ..Default::default()
            };
            let e = relaxation(&mesh, &params).unwrap();
            assert_valid(&mesh, &e);
            assert!(e.iterations > 0 && e.iterations <= params.max_iter);
        }
    }

    #[test]
    fn bumpy_sphere_becomes_valid() {
        let mesh = bumpy(3);
        // Seen from a centre near a bump the surface folds over.
        let params =
            RelaxationParams { initial: Initial::Center([0.0, 0.0, 1.4]), ..Default::default() };
        let start = initial_points(&mesh, &params.initial).unwrap();
        assert!(!check_sphere(mesh.faces(), &start).valid);
        let e = relaxation(&mesh, &params).unwrap();
        assert_valid(&mesh, &e);
        assert!(e.iterations > 0);
    }

    #[test]
    fn already_valid_start_costs_no_iteration() {
        let mesh = icosphere(2);
        let e = relaxation(&mesh, &RelaxationParams::default()).unwrap();
        assert_valid(&mesh, &e);
        assert_eq!(e.iterations, 0);
    }

    #[test]
    fn straight_capsule_unfolds() {
        // Seen from its centroid the capsule's far rings fold over; relaxation
        // smooths them out.
        let mesh = capsule(8, 60, 60.0);
        assert!(
            !check_sphere(mesh.faces(), &initial_points(&mesh, &Initial::Centroid).unwrap()).valid
        );
        assert_valid(&mesh, &relaxation(&mesh, &RelaxationParams::default()).unwrap());
    }

    #[test]
    fn bent_tube_collapses_and_strict_says_so() {
        let mesh = bent_tube();
        let params = RelaxationParams { max_iter: 50_000, ..Default::default() };
        let e = relaxation(&mesh, &params).unwrap();
        assert_eq!(e.status, Status::Collapsed, "{}", e.message);
        assert!(e.iterations > 100 && e.iterations < params.max_iter);
        assert!(!e.converged() && e.message.contains("degrees"));
        assert!(!check_sphere(mesh.faces(), &e.points).valid);
        // Stopped long before the points coincide: they still span a wide cap.
        let (cos, resultant) = enclosing_cap(&e.points, point_sum(&e.points)).unwrap();
        assert!(cos > 0.0 && cos < 0.5 && resultant < 0.9, "cap cos {cos}, resultant {resultant}");
        match relaxation(&mesh, &RelaxationParams { strict: true, ..params }) {
            Err(SphereError::NoConvergence { last }) => {
                assert_eq!(last.status, Status::Collapsed);
                assert_eq!(last.iterations, e.iterations);
                assert_eq!(last.points, e.points, "deterministic");
            }
            other => panic!("expected NoConvergence, got {other:?}"),
        }
    }

    #[test]
    fn max_iter_is_respected_and_strict_raises() {
        let mesh = icosphere(3);
        // Scrambled beyond recognition: a few iterations cannot untangle it.
        let start = scrambled(&mesh, 3.0);
        let params =
            RelaxationParams { initial: Initial::Points(start), max_iter: 3, ..Default::default() };
        let e = relaxation(&mesh, &params).unwrap();
        assert_eq!((e.status, e.iterations), (Status::MaxIterations, 3), "{}", e.message);
        let err = relaxation(&mesh, &RelaxationParams { strict: true, ..params }).unwrap_err();
        assert!(matches!(err, SphereError::NoConvergence { ref last } if last.iterations == 3));
        assert!(err.to_string().starts_with("max_iterations after 3 iterations"), "{err}");
    }

    #[test]
    fn start_outside_a_convex_mesh_is_collapsed_at_once() {
        let mesh = icosphere(2);
        let e = relaxation(
            &mesh,
            &RelaxationParams { initial: Initial::Center([3.0, 0.0, 0.0]), ..Default::default() },
        )
        .unwrap();
        assert_eq!((e.status, e.iterations), (Status::Collapsed, 0));
        assert!(e.message.contains("initial points"), "{}", e.message);
    }

    #[test]
    fn bad_parameters_are_errors() {
        let mesh = icosphere(1);
        let bad = |p: RelaxationParams| {
            matches!(relaxation(&mesh, &p), Err(SphereError::InvalidParameter { .. }))
        };
        assert!(bad(RelaxationParams { check_every: 0, ..Default::default() }));
        assert!(bad(RelaxationParams { tol: f64::NAN, ..Default::default() }));
        assert!(bad(RelaxationParams {
            weights: Weights::Chord { rho: f64::INFINITY },
            ..Default::default()
        }));
        assert!(bad(RelaxationParams {
            initial: Initial::Points(vec![[1.0, 0.0, 0.0]]),
            ..Default::default()
        }));
        assert!(bad(RelaxationParams {
            initial: Initial::Center([f64::NAN, 0.0, 0.0]),
            ..Default::default()
        }));
        assert!(bad(RelaxationParams {
            initial: Initial::Center(mesh.positions()[5]),
            ..Default::default()
        }));
        let mut zero = mesh.positions().to_vec();
        zero[2] = [0.0; 3];
        assert!(bad(RelaxationParams { initial: Initial::Points(zero), ..Default::default() }));
        // An open mesh is not a sphere.
        let open = Mesh::new(mesh.positions().to_vec(), mesh.faces()[1..].to_vec()).unwrap();
        assert!(matches!(
            relaxation(&open, &RelaxationParams::default()),
            Err(SphereError::Topology(_))
        ));
    }
}
