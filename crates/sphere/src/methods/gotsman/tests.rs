//! Tests of Gotsman's method (thesis 5.1), beside it.
use super::*;
use crate::certificate::validity::check_sphere;
use spherify_mesh::Mesh;
use spherify_sparse::{solve, SolveParams, SolverKind};

/// The method on a test mesh, validated here.
fn gotsman(mesh: &Mesh, params: &GotsmanParams) -> Result<SphereEmbedding, SphereError> {
    super::gotsman(&GenusZeroMesh::new(mesh.clone())?, params)
}

/// The uniform or chord weight matrix of a test mesh.
fn weight_matrix(mesh: &Mesh, weights: Weights) -> CsrMatrix {
    let mesh = GenusZeroMesh::new(mesh.clone()).unwrap();
    row_stochastic(&mesh, weights, Positivity::EveryWeight).unwrap()
}

/// The octahedron split `levels` times into four (edge midpoints), with
/// every vertex moved to radius `radius(direction)`: a star-shaped
/// genus-0 mesh, counter-clockwise from outside.
fn subdivided_octahedron(levels: usize, radius: impl Fn([f64; 3]) -> f64) -> Mesh {
    let base = spherify_mesh::solids::octasphere(levels);
    let p = base.positions().iter().map(|&d| d.map(|x| x * radius(d))).collect();
    Mesh::new(p, base.faces().to_vec()).unwrap()
}

fn bumpy(d: [f64; 3]) -> f64 {
    1.0 + 0.3 * (3.0 * d[0]).sin() * (2.0 * d[1]).cos() + 0.2 * d[2] * d[2]
}

/// max_i |u_i x v_i| / |u_i|: zero when every point is the projection of
/// its neighbours' weighted mean (eq. 5.5).
fn projection_error(mesh: &Mesh, points: &[[f64; 3]]) -> f64 {
    let w = weight_matrix(mesh, Weights::Uniform);
    let x: Vec<f64> = points.iter().flat_map(|p| [p[0], p[1], p[2], 0.0]).collect();
    let u = neighbour_means(&w, &x);
    (0..points.len())
        .map(|i| {
            let ui = xyz(&u[3 * i..]);
            norm3(cross(ui, points[i])) / dot3(ui, ui).sqrt()
        })
        .fold(0.0, f64::max)
}

fn norm3(a: [f64; 3]) -> f64 {
    spherify_mesh::vec3::norm(a)
}

#[test]
fn sphere_and_bumpy_meshes_converge_to_valid_embeddings() {
    for mesh in [subdivided_octahedron(3, |_| 1.0), subdivided_octahedron(4, bumpy)] {
        for weights in [Weights::Uniform, Weights::Chord { rho: 1.0 }, Weights::Chord { rho: -1.0 }]
        {
            let e = gotsman(&mesh, &GotsmanParams { weights, ..Default::default() }).unwrap();
            assert_eq!(e.status, Status::Converged, "{weights:?}: {}", e.message);
            assert!(e.iterations <= 40, "{}", e.message);
            assert!(e.points.iter().all(|p| (norm3(*p) - 1.0).abs() < 1e-14));
            assert!(check_sphere(mesh.faces(), &e.points).valid, "{weights:?}");
            if weights == Weights::Uniform {
                assert!(projection_error(&mesh, &e.points) < 1e-9);
            }
        }
    }
}

#[test]
fn same_input_same_bits() {
    let mesh = subdivided_octahedron(3, bumpy);
    let a = gotsman(&mesh, &GotsmanParams::default()).unwrap();
    let b = gotsman(&mesh, &GotsmanParams::default()).unwrap();
    assert_eq!(a.points, b.points);
}

#[test]
fn strict_reports_no_convergence_with_the_last_iterate() {
    let mesh = subdivided_octahedron(3, bumpy);
    let params = GotsmanParams { max_iter: 1, strict: true, ..Default::default() };
    match gotsman(&mesh, &params) {
        Err(SphereError::NoConvergence { last }) => {
            assert_eq!((last.iterations, last.status), (1, Status::MaxIterations));
            assert_eq!(last.points.len(), mesh.n_vertices());
        }
        other => panic!("{other:?}"),
    }
    let relaxed = gotsman(&mesh, &GotsmanParams { max_iter: 1, ..Default::default() }).unwrap();
    assert_eq!(relaxed.status, Status::MaxIterations);
}

#[test]
fn clustered_start_collapses_and_says_so() {
    let mesh = subdivided_octahedron(2, |_| 1.0);
    // Every point within ~3 degrees of the north pole, in a fixed pattern.
    let start: Vec<[f64; 3]> = (0..mesh.n_vertices())
        .map(|i| [0.05 * (i as f64).sin(), 0.05 * (1.7 * i as f64).cos(), 1.0])
        .collect();
    let params = GotsmanParams { initial: Initial::Points(start.clone()), ..Default::default() };
    let e = gotsman(&mesh, &params).unwrap();
    assert_eq!(e.status, Status::Collapsed, "{}", e.message);
    assert!(e.message.contains("trivial"));
    let strict =
        GotsmanParams { initial: Initial::Points(start), strict: true, ..Default::default() };
    assert!(matches!(gotsman(&mesh, &strict), Err(SphereError::NoConvergence { .. })));
}

#[test]
fn a_converged_start_needs_no_iteration() {
    let mesh = subdivided_octahedron(2, bumpy);
    let first = gotsman(&mesh, &GotsmanParams::default()).unwrap();
    let params = GotsmanParams {
        initial: Initial::Points(first.points.clone()),
        tol: 1e-9,
        ..Default::default()
    };
    let again = gotsman(&mesh, &params).unwrap();
    assert_eq!((again.iterations, again.status), (0, Status::Converged));
}

#[test]
fn bad_input_is_an_error() {
    let mesh = subdivided_octahedron(1, |_| 1.0);
    for weights in [Weights::Cotangent, Weights::MeanValue] {
        let p = GotsmanParams { weights, ..Default::default() };
        assert!(matches!(
            gotsman(&mesh, &p),
            Err(SphereError::InvalidParameter { name: "weights", .. })
        ));
    }
    let tol = GotsmanParams { tol: f64::NAN, ..Default::default() };
    assert!(matches!(gotsman(&mesh, &tol), Err(SphereError::InvalidParameter { name: "tol", .. })));
    let short =
        GotsmanParams { initial: Initial::Points(vec![[0.0, 0.0, 1.0]; 3]), ..Default::default() };
    assert!(matches!(
        gotsman(&mesh, &short),
        Err(SphereError::InvalidParameter { name: "initial", .. })
    ));
    let mut zero = vec![[0.0, 0.0, 1.0]; mesh.n_vertices()];
    zero[4] = [0.0; 3];
    let zero = GotsmanParams { initial: Initial::Points(zero), ..Default::default() };
    assert!(matches!(
        gotsman(&mesh, &zero),
        Err(SphereError::InvalidParameter { name: "initial", .. })
    ));
    // An open mesh (one face removed) is not a sphere.
    let (p, mut f) = mesh.into_parts();
    f.pop();
    let open = Mesh::new(p, f).unwrap();
    assert!(matches!(gotsman(&open, &GotsmanParams::default()), Err(SphereError::Topology(_))));
}

#[test]
fn jacobian_matches_finite_differences() {
    let mesh = subdivided_octahedron(1, bumpy);
    let w = weight_matrix(&mesh, Weights::Chord { rho: 1.0 });
    let x: Vec<f64> =
        (0..4 * mesh.n_vertices()).map(|k| ((k * 7 % 13) as f64 * 0.37).sin()).collect();
    let jac = jacobian(&w, &x).unwrap();
    let h = 1e-6;
    for col in 0..x.len() {
        let (mut plus, mut minus) = (x.clone(), x.clone());
        plus[col] += h;
        minus[col] -= h;
        let (fp, fm) = (residual(&w, &plus), residual(&w, &minus));
        for row in 0..x.len() {
            let fd = (fp[row] - fm[row]) / (2.0 * h);
            assert!(
                (fd - jac.get(row, col)).abs() < 1e-8,
                "({row}, {col}): {fd} vs {}",
                jac.get(row, col)
            );
        }
    }
}

#[test]
fn the_tangent_step_is_the_newton_step_of_the_full_jacobian() {
    let mesh = subdivided_octahedron(2, bumpy);
    let w = weight_matrix(&mesh, Weights::Chord { rho: 1.0 });
    // Points off the sphere and off any solution.
    let x: Vec<f64> = mesh
        .positions()
        .iter()
        .enumerate()
        .flat_map(|(i, p)| [p[0], p[1] + 0.1 * (i as f64).sin(), p[2], 0.9 + 0.01 * (i % 7) as f64])
        .collect();
    let f = residual(&w, &x);
    let minus_f: Vec<f64> = f.iter().map(|v| -v).collect();
    let (full, _) =
        solve(&jacobian(&w, &x).unwrap(), &[minus_f], SolverKind::Auto, &SolveParams::default())
            .unwrap();
    let reduced = newton_step(&w, &x, &f).unwrap().unwrap();
    let err = full[0].iter().zip(&reduced).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(err < 1e-10, "{err}");
}

#[test]
fn removing_the_rotation_leaves_a_rotation_free_step() {
    let mesh = subdivided_octahedron(1, |_| 1.0);
    let x: Vec<f64> = mesh.positions().iter().flat_map(|p| [p[0], p[1], p[2], 1.0]).collect();
    // A pure rotation about (1, 2, 3) plus an alpha change: only the latter stays.
    let omega = [1.0, 2.0, 3.0];
    let mut p: Vec<f64> = x
        .chunks(4)
        .flat_map(|v| {
            let r = cross(omega, xyz(v));
            [r[0], r[1], r[2], 0.5]
        })
        .collect();
    remove_rotation(&x, &mut p);
    for d in p.chunks(4) {
        assert!(norm3([d[0], d[1], d[2]]) < 1e-14 && d[3] == 0.5);
    }
}
