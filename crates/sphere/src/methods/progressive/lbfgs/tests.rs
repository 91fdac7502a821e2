//! Tests of the global L-BFGS steps, beside them.

use super::*;
use crate::genus_zero::GenusZeroMesh;
use crate::methods::progressive::{area_floor, progressive, rings_of, ProgressiveParams};
use spherify_mesh::solids::{bumpy, capsule, helix};
use spherify_mesh::vec3::norm;

/// A certified map of `mesh` with few final sweeps, the stretch or balanced
/// problem on it, and its rings.
fn start(mesh: spherify_mesh::Mesh, energy: Energy) -> (GenusZeroMesh, Vec<[f64; 3]>) {
    let mesh = GenusZeroMesh::new(mesh).unwrap();
    let params = ProgressiveParams { energy, max_iter: 1, tolerance: 1e-2 };
    let points = progressive(&mesh, &params, &|_, _| true).unwrap().points;
    (mesh, points)
}

#[test]
fn global_steps_lower_the_energy_and_keep_a_certified_map() {
    for energy in [Energy::Stretch, Energy::Balanced] {
        for shape in [capsule(8, 60, 16.0), helix(8, 120, 0.15, 2.0, 0.8), bumpy(2)] {
            let (mesh, mut points) = start(shape, energy);
            let problem = Problem {
                energy,
                surface: mesh.positions(),
                area_floor: area_floor(&mesh),
                represented: None,
                pull: None,
            };
            let rings = rings_of(&mesh).unwrap();
            let params = LbfgsParams { max_iter: 50, tolerance: 1e-9 };
            let run = lbfgs(&problem, &rings, &mut points, &params, &|| false).unwrap();
            assert!(!run.fell_back, "{energy:?}: {run:?}");
            assert!(run.end < run.start, "{energy:?}: {run:?}");
            assert!(run.iterations > 0);
            assert!(check_sphere(mesh.faces(), &points).valid);
            assert!(points.iter().all(|p| (norm(*p) - 1.0).abs() < 1e-12));
        }
    }
}

#[test]
fn the_same_bits_on_one_and_on_two_threads() {
    let (mesh, points) = start(helix(8, 120, 0.15, 2.0, 0.8), Energy::Balanced);
    let problem = Problem {
        energy: Energy::Balanced,
        surface: mesh.positions(),
        area_floor: area_floor(&mesh),
        represented: None,
        pull: None,
    };
    let rings = rings_of(&mesh).unwrap();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut p = points.clone();
            let params = LbfgsParams { max_iter: 30, tolerance: 0.0 };
            lbfgs(&problem, &rings, &mut p, &params, &|| false).unwrap();
            p
        })
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn a_stop_request_is_heard() {
    let (mesh, mut points) = start(bumpy(2), Energy::Stretch);
    let problem = Problem {
        energy: Energy::Stretch,
        surface: mesh.positions(),
        area_floor: area_floor(&mesh),
        represented: None,
        pull: None,
    };
    let params = LbfgsParams { max_iter: 50, tolerance: 0.0 };
    let stopped = lbfgs(&problem, &rings_of(&mesh).unwrap(), &mut points, &params, &|| true);
    assert_eq!(stopped, Err(Stopped));
}
