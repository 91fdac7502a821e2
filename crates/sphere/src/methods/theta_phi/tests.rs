//! Tests of the theta-phi pipeline (thesis ch. 6), beside it.
use super::*;
use crate::certificate::validity::check_sphere;
use crate::methods::theta_phi::rectangle::rectangle_system;
use std::f64::consts::PI;

/// A test run: the points, and the rest through `Deref`.
#[derive(Debug)]
struct Run {
    embedding: SphereEmbedding,
    details: ThetaPhi,
}

impl std::ops::Deref for Run {
    type Target = ThetaPhi;
    fn deref(&self) -> &ThetaPhi {
        &self.details
    }
}

/// The method on a test mesh, validated here.
fn theta_phi_with_progress(
    mesh: &Mesh,
    params: &ThetaPhiParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<Run, SphereError> {
    let mesh = GenusZeroMesh::new(mesh.clone())?;
    let (embedding, details) = super::theta_phi_with_progress(&mesh, params, progress)?;
    Ok(Run { embedding, details })
}

fn theta_phi(mesh: &Mesh, params: &ThetaPhiParams) -> Result<Run, SphereError> {
    theta_phi_with_progress(mesh, params, &|_, _| true)
}

fn uv_sphere(rings: usize, segments: usize) -> Mesh {
    let mut p = vec![[0.0, 0.0, 1.0]];
    for i in 1..rings {
        let t = PI * i as f64 / rings as f64;
        for j in 0..segments {
            let f = 2.0 * PI * j as f64 / segments as f64;
            p.push([
                t.sin() * f.cos() * (1.0 + 0.3 * (3.0 * f).sin()),
                t.sin() * f.sin(),
                t.cos() * 2.0,
            ]);
        }
    }
    p.push([0.0, 0.0, -2.0]);
    let south = (p.len() - 1) as u32;
    let at = |i: usize, j: usize| (1 + (i - 1) * segments + j % segments) as u32;
    let mut f = Vec::new();
    for j in 0..segments {
        f.push([0, at(1, j), at(1, j + 1)]);
        f.push([south, at(rings - 1, j + 1), at(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            f.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            f.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    Mesh::new(p, f).unwrap()
}

#[test]
fn sphere_like_mesh_is_certified_and_bijective() {
    let mesh = uv_sphere(12, 16);
    let last = mesh.n_vertices() as u32 - 1;
    for poles in [
        PoleChoice::FastGraph,
        PoleChoice::Graph,
        PoleChoice::Physical,
        PoleChoice::Explicit(3, last),
        PoleChoice::Symmetry(SymmetryParams::default()),
    ] {
        let params = ThetaPhiParams { poles, ..ThetaPhiParams::default() };
        let tp = theta_phi(&mesh, &params).unwrap();
        assert!(tp.tp_valid, "{poles:?}: {}", tp.embedding.message);
        let k = tp.cut_path.len() - 2;
        assert!(k >= 2);
        assert_eq!(tp.theta_phi.len(), mesh.n_vertices() + k);
        for p in &tp.embedding.points {
            assert!(((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 1.0).abs() < 1e-12);
        }
        // The fold of a flip-free rectangle covers the sphere once.
        let report = check_sphere(mesh.faces(), &tp.embedding.points);
        assert_eq!(report.covering_degree, 1, "{poles:?}");
    }
}

#[test]
fn symmetry_poles_cut_near_the_plane() {
    // Mirror-symmetric in x = 0 up to the direction of the quad diagonals.
    let mesh = uv_sphere(12, 16);
    let params = ThetaPhiParams {
        poles: PoleChoice::Symmetry(SymmetryParams::default()),
        ..ThetaPhiParams::default()
    };
    let tp = theta_phi(&mesh, &params).unwrap();
    let sym = tp.symmetry.as_ref().unwrap();
    assert_eq!(sym.fallback, None, "{sym:?}");
    let plane = sym.planes[sym.chosen.unwrap()];
    assert!(plane.normal[0] > 0.999, "{plane:?}");
    assert_eq!(tp.cut_path, sym.path);
    let d = |v: u32| {
        let x = mesh.positions()[v as usize];
        (0..3).map(|k| plane.normal[k] * (x[k] - sym.centre[k])).sum::<f64>()
    };
    assert!(tp.cut_path.iter().all(|&v| d(v).abs() <= sym.eps));
    assert!(tp.tp_valid, "{}", tp.embedding.message);
    // No plane convincing: the fast-graph poles, and the reason recorded.
    let strict = ThetaPhiParams {
        poles: PoleChoice::Symmetry(SymmetryParams { max_score: 0.0, ..SymmetryParams::default() }),
        ..ThetaPhiParams::default()
    };
    let tp = theta_phi(&mesh, &strict).unwrap();
    let fast = theta_phi(&mesh, &ThetaPhiParams::default()).unwrap();
    assert!(matches!(
        tp.symmetry.as_ref().unwrap().fallback,
        Some(crate::methods::theta_phi::symmetry::Fallback::NotSymmetric { .. })
    ));
    assert_eq!((tp.poles, &tp.cut_path), (fast.poles, &fast.cut_path));
}

#[test]
fn graph_poles_can_be_cancelled() {
    let mesh = uv_sphere(12, 16);
    let params = ThetaPhiParams { poles: PoleChoice::Graph, ..ThetaPhiParams::default() };
    let err = theta_phi_with_progress(&mesh, &params, &|done, _| done < 5).unwrap_err();
    assert!(matches!(err, SphereError::Cancelled { stage: "graph poles", .. }), "{err}");
}

#[test]
fn tetrahedron_works_with_a_lengthened_path() {
    let mesh = spherify_mesh::solids::tetrahedron();
    let tp = theta_phi(&mesh, &ThetaPhiParams::default()).unwrap();
    assert_eq!(tp.cut_path.len(), 4);
    assert!(tp.tp_valid, "{}", tp.embedding.message);
}

#[test]
fn explicit_poles_are_checked() {
    let mesh = uv_sphere(6, 8);
    let params = ThetaPhiParams { poles: PoleChoice::Explicit(3, 3), ..ThetaPhiParams::default() };
    assert!(matches!(theta_phi(&mesh, &params), Err(SphereError::InvalidParameter { .. })));
}

#[test]
fn pole_choices_round_trip_by_name_and_unknown_names_list_them() {
    for name in PoleChoice::NAMES {
        let choice = PoleChoice::from_name(name, SymmetryParams::default()).unwrap();
        assert_eq!(choice.name(), name);
    }
    assert_eq!(PoleChoice::Explicit(0, 1).name(), "explicit");
    let err = PoleChoice::from_name("north", SymmetryParams::default()).unwrap_err();
    assert!(err.to_string().contains("fast_graph, graph, physical, symmetry"), "{err}");
}

#[test]
fn rectangle_system_is_the_system_the_run_solved() {
    // The run's theta-phi coordinates of the free vertices satisfy the
    // rebuilt system to rounding, with every weight theta-phi accepts; a
    // system with another boundary or other weights would leave O(1) residuals.
    let mesh = uv_sphere(10, 14);
    for weights in [Weights::Uniform, Weights::Chord { rho: 1.0 }, Weights::MeanValue] {
        let params = ThetaPhiParams { weights, ..ThetaPhiParams::default() };
        let valid = GenusZeroMesh::new(mesh.clone()).unwrap();
        let (_, details) = super::theta_phi(&valid, &params).unwrap();
        assert_eq!(details.re_embedded, [false, false], "{weights:?}");
        let system = rectangle_system(&valid, &details, weights).unwrap();
        let boundary = details.cut.boundary.len();
        assert_eq!(system.free.len(), details.theta_phi.len() - boundary, "{weights:?}");
        for (c, rhs) in system.rhs.iter().enumerate() {
            let x: Vec<f64> =
                system.free.iter().map(|&v| details.theta_phi[v as usize][c]).collect();
            let r =
                spherify_sparse::refine::residual_double_double(&system.matrix, rhs, &x).unwrap();
            let scale = rhs.iter().fold(1.0f64, |m, b| m.max(b.abs()));
            let worst = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(worst < 1e-12 * scale, "{weights:?} column {c}: residual {worst:e}");
        }
    }
}
