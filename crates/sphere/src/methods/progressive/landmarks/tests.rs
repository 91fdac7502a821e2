//! Tests of landmark pinning and of the soft moves towards targets, beside them.

use super::*;
use crate::methods::progressive::move_towards::{move_towards, TowardsParams};
use crate::methods::progressive::{progressive, ProgressiveParams};
use spherify_mesh::solids::{bumpy, capsule, icosphere};
use spherify_mesh::Mesh;

fn mapped(mesh: Mesh) -> (GenusZeroMesh, Vec<[f64; 3]>) {
    let mesh = GenusZeroMesh::new(mesh).unwrap();
    let e = progressive(&mesh, &ProgressiveParams::default(), &|_, _| true).unwrap();
    (mesh, e.points)
}

/// `p` turned by `degrees` about an axis orthogonal to it, chosen by `seed`.
fn turned(p: [f64; 3], degrees: f64, seed: usize) -> [f64; 3] {
    let (e1, e2) = tangent_basis(p);
    let a = seed as f64 * 2.399963; // the golden angle: directions spread out
    let dir = add(scale(e1, a.cos()), scale(e2, a.sin()));
    let t = degrees.to_radians();
    normalize(add(scale(p, t.cos()), scale(dir, t.sin()))).unwrap()
}

/// Each landmark's point turned by `degrees`, each its own way (seed = its
/// index in `ids`).
fn turned_targets(points: &[[f64; 3]], ids: &[i64], degrees: f64) -> Vec<[f64; 3]> {
    ids.iter().enumerate().map(|(j, &i)| turned(points[i as usize], degrees, j)).collect()
}

/// A vertex of the icosphere and its whole ring pinned where they are, the
/// vertex itself sent to the far side of its ring: no map of the mesh as
/// given has it there.
fn across_its_pinned_ring(mesh: &GenusZeroMesh, points: &[[f64; 3]]) -> (Vec<i64>, Vec<[f64; 3]>) {
    let rings = rings_of(mesh).unwrap();
    let v = 0usize;
    let mut ids: Vec<i64> = rings[v].iter().map(|&r| r as i64).collect();
    let mut targets: Vec<[f64; 3]> = rings[v].iter().map(|&r| points[r as usize]).collect();
    ids.push(v as i64);
    targets.push(scale(points[v], -1.0));
    (ids, targets)
}

/// Vertices spread over the map: farthest-point sampling from vertex 0.
fn spread(points: &[[f64; 3]], k: usize) -> Vec<i64> {
    let mut chosen = vec![0usize];
    let mut near: Vec<f64> = points.iter().map(|&p| angle(p, points[0])).collect();
    while chosen.len() < k {
        let next = (0..points.len()).max_by(|&a, &b| near[a].total_cmp(&near[b])).unwrap();
        chosen.push(next);
        for (d, &p) in near.iter_mut().zip(points) {
            *d = d.min(angle(p, points[next]));
        }
    }
    chosen.into_iter().map(|i| i as i64).collect()
}

fn pin(
    mesh: &GenusZeroMesh,
    points: &[[f64; 3]],
    ids: &[i64],
    targets: &[[f64; 3]],
) -> Result<Vec<[f64; 3]>, SphereError> {
    let landmarks = Landmarks::new(mesh.n_vertices(), ids, targets)?;
    let (e, _) = pin_landmarks(mesh, points, &landmarks, &PinParams::default(), &|_, _| true)?;
    Ok(e.points)
}

fn assert_pinned(mesh: &GenusZeroMesh, points: &[[f64; 3]], ids: &[i64], targets: &[[f64; 3]]) {
    let report = check_sphere(mesh.faces(), points);
    assert!(report.valid, "{report:?}");
    assert!(report.min_area_ratio > 1e-12, "{}", report.min_area_ratio);
    for (&i, &t) in ids.iter().zip(targets) {
        assert_eq!(points[i as usize], normalize(t).unwrap(), "landmark {i}");
    }
}

#[test]
fn landmarks_45_degrees_away_land_exactly_on_a_valid_map() {
    for (name, shape) in [("icosphere", icosphere(3)), ("bumpy", bumpy(2))] {
        let (mesh, points) = mapped(shape);
        for k in [1, 3, 8] {
            let ids = spread(&points, k);
            let targets: Vec<[f64; 3]> = turned_targets(&points, &ids, 45.0);
            let pinned = pin(&mesh, &points, &ids, &targets)
                .unwrap_or_else(|e| panic!("{name}, {k} landmarks: {e}"));
            assert_pinned(&mesh, &pinned, &ids, &targets);
        }
    }
}

#[test]
fn a_long_capsule_takes_its_ends_to_new_places() {
    let (mesh, points) = mapped(capsule(8, 60, 8.0));
    let ids = spread(&points, 4);
    let targets: Vec<[f64; 3]> = turned_targets(&points, &ids, 30.0);
    let pinned = pin(&mesh, &points, &ids, &targets).unwrap();
    assert_pinned(&mesh, &pinned, &ids, &targets);
}

#[test]
fn pinning_gives_the_same_bits_on_one_and_two_threads() {
    let (mesh, points) = mapped(bumpy(3));
    let ids = spread(&points, 8);
    let targets: Vec<[f64; 3]> = turned_targets(&points, &ids, 45.0);
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| pin(&mesh, &points, &ids, &targets).unwrap())
    };
    assert_eq!(on(1), on(2));
}

#[test]
fn neighbours_at_opposite_points_and_an_upside_down_face_are_conflicts() {
    let (mesh, points) = mapped(icosphere(1));
    let [a, b, c] = mesh.faces()[0];
    let t = points[a as usize];
    let err = pin(&mesh, &points, &[a as i64, b as i64], &[t, scale(t, -1.0)]).unwrap_err();
    match err {
        SphereError::LandmarkConflict { ids, .. } => {
            let mut want = vec![a as usize, b as usize];
            want.sort_unstable();
            assert_eq!(ids, want);
        }
        other => panic!("{other}"),
    }
    // The face's corners at their own places, two of them swapped.
    let (pa, pb, pc) = (points[a as usize], points[b as usize], points[c as usize]);
    let err = pin(&mesh, &points, &[a as i64, b as i64, c as i64], &[pb, pa, pc]).unwrap_err();
    assert!(
        matches!(err, SphereError::LandmarkConflict { ref ids, .. } if ids.len() == 3),
        "{err}"
    );
    assert!(err.to_string().contains("upside down"), "{err}");
}

#[test]
fn a_crossing_that_no_map_realises_stops_with_the_landmarks_named() {
    // A vertex of the icosphere and its whole ring pinned where they are,
    // and the vertex itself asked to leave its ring for the far side: no
    // valid map has it there, and the drag must say so in bounded work.
    let (mesh, points) = mapped(icosphere(2));
    let (ids, targets) = across_its_pinned_ring(&mesh, &points);
    let sent = *ids.last().unwrap() as usize; // the vertex, after its ring
    let err = pin(&mesh, &points, &ids, &targets).unwrap_err();
    match err {
        SphereError::LandmarkConflict { ids, reason } => {
            assert!(ids.contains(&sent), "{ids:?}: {reason}");
        }
        other => panic!("{other}"),
    }
}

#[test]
fn bad_sets_are_refused_before_any_move() {
    let n = 10;
    let t = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let bad = |ids: &[i64], targets: &[[f64; 3]]| match Landmarks::new(n, ids, targets) {
        Err(SphereError::BadLandmarks { ids, reason }) => (ids, reason),
        other => panic!("{other:?}"),
    };
    assert_eq!(bad(&[1, 10], &t).0, vec![10]);
    assert_eq!(bad(&[-1, 2], &t).0, vec![0]);
    assert_eq!(bad(&[3, 3], &t).0, vec![3]);
    assert_eq!(bad(&[3, 4], &[[0.0; 3], [1.0, 0.0, 0.0]]).0, vec![3]);
    assert_eq!(bad(&[3, 4], &[[f64::NAN, 0.0, 0.0], [1.0, 0.0, 0.0]]).0, vec![3]);
    let (ids, reason) = bad(&[5, 4], &[[2.0, 0.0, 0.0], [1.0, 0.0, 0.0]]);
    assert_eq!(ids, vec![4, 5]);
    assert!(reason.contains("same direction"), "{reason}");
    assert!(bad(&[1], &t).1.contains("1 ids but 2"));
}

#[test]
fn pinning_stops_when_the_callback_says_so() {
    let (mesh, points) = mapped(icosphere(2));
    let ids = spread(&points, 3);
    let targets: Vec<[f64; 3]> = turned_targets(&points, &ids, 45.0);
    let landmarks = Landmarks::new(mesh.n_vertices(), &ids, &targets).unwrap();
    let err = pin_landmarks(&mesh, &points, &landmarks, &PinParams::default(), &|_, _| false)
        .unwrap_err();
    assert!(matches!(err, SphereError::Cancelled { stage: "landmarks", .. }), "{err}");
}

#[test]
fn holding_nothing_is_optimise_move_for_move() {
    let (mesh, points) = mapped(bumpy(2));
    let rings = rings_of(&mesh).unwrap();
    let problem = whole_mesh_problem(Energy::Isometric, &mesh);
    let (mut a, mut b) = (points.clone(), points.clone());
    problem.optimise(&rings, &mut a, 5, 0.0, &|_| false).unwrap();
    problem.optimise_holding(&rings, &mut b, 5, 0.0, None, &|_| false).unwrap();
    assert_eq!(a, b);
    let held: Vec<bool> = (0..points.len()).map(|i| i % 3 == 0).collect();
    let mut c = points.clone();
    problem.optimise_holding(&rings, &mut c, 5, 0.0, Some(&held), &|_| false).unwrap();
    for i in (0..points.len()).step_by(3) {
        assert_eq!(c[i], points[i]);
    }
}

#[test]
fn move_towards_keeps_the_map_valid_and_the_fixed_vertices_still() {
    let (mesh, points) = mapped(bumpy(2));
    let n = points.len();
    let targets: Vec<[f64; 3]> = (0..n).map(|i| turned(points[i], 20.0, 7)).collect();
    let weights: Vec<f64> = (0..n).map(|i| if i % 5 == 0 { 0.0 } else { 1.0 }).collect();
    let fixed: Vec<i64> = (0..n as i64).filter(|i| i % 7 == 0).collect();
    let e = move_towards(
        &mesh,
        &points,
        &targets,
        &weights,
        &fixed,
        &TowardsParams::default(),
        &|_, _| true,
    )
    .unwrap();
    assert!(check_sphere(mesh.faces(), &e.points).valid);
    for &i in &fixed {
        assert_eq!(e.points[i as usize], points[i as usize]);
    }
    // Without energy sweeps, the weighted vertices got closer and the others stayed.
    let params = TowardsParams { energy_sweeps: 0, ..Default::default() };
    let e =
        move_towards(&mesh, &points, &targets, &weights, &fixed, &params, &|_, _| true).unwrap();
    let before: f64 =
        (0..n).filter(|i| weights[*i] > 0.0).map(|i| angle(points[i], targets[i])).sum();
    let after: f64 =
        (0..n).filter(|i| weights[*i] > 0.0).map(|i| angle(e.points[i], targets[i])).sum();
    assert!(after < 0.5 * before, "{before} -> {after}");
    for i in (0..n).filter(|i| weights[*i] == 0.0) {
        assert_eq!(e.points[i], points[i]);
    }
}

#[test]
fn repeated_soft_moves_never_shrink_the_smallest_face() {
    // Every vertex pulled 10 degrees in its own direction, twenty times over
    // (as a registration's warp calls it): the smallest face may not shrink
    // below where it started or the floor, whichever is lower.
    let (mesh, mut points) = mapped(bumpy(2));
    let start = check_sphere(mesh.faces(), &points).min_area_ratio;
    let params = TowardsParams { energy_sweeps: 0, ..Default::default() };
    let n = points.len();
    let weights = vec![1.0; n];
    for round in 0..20 {
        let targets: Vec<[f64; 3]> = (0..n).map(|i| turned(points[i], 10.0, i + round)).collect();
        points = move_towards(&mesh, &points, &targets, &weights, &[], &params, &|_, _| true)
            .unwrap()
            .points;
    }
    let report = check_sphere(mesh.faces(), &points);
    assert!(report.valid);
    assert!(report.min_area_ratio >= 0.5 * start.min(1e-2), "{start} -> {}", report.min_area_ratio);
}

// The path layout (path_layout.rs).

/// Lays `ids` out at `targets` and checks what the module promises: a
/// certified map of the refined mesh, landmarks exactly at their targets,
/// the input's vertices first and every vertex on the input surface.
fn assert_laid_out(
    mesh: &GenusZeroMesh,
    points: &[[f64; 3]],
    ids: &[i64],
    targets: &[[f64; 3]],
) -> Refined {
    let landmarks = Landmarks::new(mesh.n_vertices(), ids, targets).unwrap();
    let (e, refined) =
        lay_out(mesh, points, &landmarks, &PinParams::default(), &|_, _| true).unwrap();
    let report = check_sphere(refined.mesh.faces(), &e.points);
    assert!(report.valid, "{report:?}");
    assert!(report.min_area_ratio > 1e-12, "{}", report.min_area_ratio);
    for (&i, &t) in ids.iter().zip(targets) {
        assert_eq!(e.points[i as usize], normalize(t).unwrap(), "landmark {i}");
    }
    let n = mesh.n_vertices();
    assert_eq!(&refined.mesh.positions()[..n], mesh.positions());
    let (faces, weights) = refined.layout.barycentric(mesh.faces(), None);
    for (v, (&f, &w)) in faces.iter().zip(&weights).enumerate() {
        let face = mesh.faces()[f as usize];
        let p =
            (0..3).fold([0.0; 3], |s, j| add(s, scale(mesh.positions()[face[j] as usize], w[j])));
        let q = refined.mesh.positions()[v];
        assert!(norm(sub(p, q)) < 1e-12, "vertex {v}: {p:?} != {q:?}");
        assert!(w.iter().all(|&x| x >= 0.0) && (w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }
    refined
}

#[test]
fn a_scrambled_set_the_drag_cannot_pin_is_laid_out_exactly() {
    // 32 landmarks each turned 45 degrees its own way: their order around
    // each other is scrambled, so no flip-free drag passes them.
    let (mesh, points) = mapped(bumpy(2));
    let ids = spread(&points, 32);
    let targets: Vec<[f64; 3]> = turned_targets(&points, &ids, 45.0);
    assert!(matches!(
        pin(&mesh, &points, &ids, &targets),
        Err(SphereError::LandmarkConflict { .. })
    ));
    let landmarks = Landmarks::new(mesh.n_vertices(), &ids, &targets).unwrap();
    let out_of_order = path_layout::out_of_order_count(&points, &landmarks);
    assert!(out_of_order > DRAG_FIRST_OUT_OF_ORDER, "{out_of_order} out of order");
    let unmoved: Vec<[f64; 3]> = ids.iter().map(|&i| points[i as usize]).collect();
    let still = Landmarks::new(mesh.n_vertices(), &ids, &unmoved).unwrap();
    assert_eq!(path_layout::out_of_order_count(&points, &still), 0);
    let refined = assert_laid_out(&mesh, &points, &ids, &targets);
    assert!(refined.mesh.n_vertices() > mesh.n_vertices(), "paths split edges");
    assert_eq!(refined.layout.patches, 2 * 32 - 4);
    // A caller's bound on the refined mesh: met exactly, it lays out the
    // same; one vertex short, the set is refused and the bound named.
    let rows = refined.mesh.n_vertices();
    let bounded = |max| PinParams { max_vertices: Some(max), ..PinParams::default() };
    let (e, again) = lay_out(&mesh, &points, &landmarks, &bounded(rows), &|_, _| true).unwrap();
    assert_eq!(again.mesh.n_vertices(), rows);
    assert!(check_sphere(again.mesh.faces(), &e.points).valid);
    match lay_out(&mesh, &points, &landmarks, &bounded(rows - 1), &|_, _| true) {
        Err(SphereError::LandmarkConflict { reason, .. }) => {
            assert!(reason.contains("max_vertices"), "{reason}")
        }
        other => panic!("expected a conflict, got {other:?}"),
    }
}

#[test]
fn three_landmarks_get_auxiliary_ones_that_are_not_held() {
    let (mesh, points) = mapped(icosphere(3));
    let ids = spread(&points, 3);
    let targets: Vec<[f64; 3]> = turned_targets(&points, &ids, 40.0);
    let refined = assert_laid_out(&mesh, &points, &ids, &targets);
    assert!(!refined.layout.auxiliary.is_empty());
    assert!(refined.layout.auxiliary.iter().all(|a| !ids.contains(&(*a as i64))));
}

#[test]
fn a_vertex_sent_across_its_pinned_ring_is_laid_out_by_splitting() {
    // The set the drag refuses above (a_crossing_that_no_map_realises...):
    // on the mesh as given no map has it, after edge splits one does.
    let (mesh, points) = mapped(icosphere(2));
    let (ids, targets) = across_its_pinned_ring(&mesh, &points);
    assert_laid_out(&mesh, &points, &ids, &targets);
}

#[test]
fn the_hull_of_cocircular_targets_is_one_triangulation() {
    // A cube's corners: each face is four co-circular points, fanned once.
    let s = 1.0 / 3f64.sqrt();
    let corners: Vec<[f64; 3]> = (0..8)
        .map(|c| {
            let b = |k: usize| if c >> k & 1 == 1 { s } else { -s };
            [b(0), b(1), b(2)]
        })
        .collect();
    let tris = path_layout::hull(&corners).unwrap();
    assert_eq!(tris.len(), 12);
    for &[a, b, c] in &tris {
        let n = cross(sub(corners[b], corners[a]), sub(corners[c], corners[a]));
        assert!(dot(n, corners[a]) > 0.0, "outward");
    }
}

#[test]
fn the_layout_gives_the_same_bits_on_one_and_two_threads() {
    let (mesh, points) = mapped(bumpy(2));
    let ids = spread(&points, 16);
    let targets: Vec<[f64; 3]> = turned_targets(&points, &ids, 45.0);
    let landmarks = Landmarks::new(mesh.n_vertices(), &ids, &targets).unwrap();
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            lay_out(&mesh, &points, &landmarks, &PinParams::default(), &|_, _| true)
                .unwrap()
                .0
                .points
        })
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn the_cosine_test_agrees_with_the_angle() {
    // Wherever surely_within_arc says yes, the angle is within MAX_ARC, on
    // pairs spread over every angle and crowded near MAX_ARC itself.
    let mut s = spherify_mesh::lcg::Lcg::new(17);
    let mut yes = 0;
    for k in 0..200_000 {
        let p = normalize([s.next_f64() - 0.5, s.next_f64() - 0.5, s.next_f64() - 0.5]);
        let Some(p) = p else { continue };
        let (e1, e2) = tangent_basis(p);
        let theta = if k % 2 == 0 {
            std::f64::consts::PI * s.next_f64()
        } else {
            MAX_ARC + 4e-6 * (s.next_f64() - 0.5)
        };
        let phi = std::f64::consts::TAU * s.next_f64();
        let dir = add(scale(e1, phi.cos()), scale(e2, phi.sin()));
        let q = add(scale(p, theta.cos()), scale(dir, theta.sin()));
        // Lengths a little off 1, as a map's points may be.
        let q = scale(q, 1.0 + 1e-12 * (s.next_f64() - 0.5));
        if surely_within_arc(p, q) {
            yes += 1;
            assert!(angle(p, q) <= MAX_ARC, "{p:?} {q:?}");
        }
    }
    assert!(yes > 50_000);
}
