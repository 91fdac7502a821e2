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
//! The driver here (initial points, checks, stopping rules, timing) is shared
//! with Alexa's method in [`crate::alexa`], which differs only in its update.

use spherify_mesh::vec3::add;
use std::time::Instant;

use rayon::prelude::*;
use spherify_sparse::weights::Weights;

use crate::embedding::{normalize, SphereEmbedding, Status};
use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;
use crate::initial::{initial_points, Initial};
use crate::validity::check_sphere;
use crate::weight_matrix::{row_stochastic, Positivity};

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

/// The controls both relaxation methods share, checked.
pub(crate) struct Controls {
    pub max_iter: usize,
    pub check_every: usize,
    pub tol: f64,
    pub strict: bool,
}

impl Controls {
    pub fn new(
        max_iter: usize,
        check_every: usize,
        tol: f64,
        strict: bool,
    ) -> Result<Controls, SphereError> {
        if check_every == 0 {
            return Err(SphereError::InvalidParameter {
                name: "check_every",
                value: "0".into(),
                expected: "at least 1",
            });
        }
        if !(tol >= 0.0 && tol.is_finite()) {
            return Err(SphereError::InvalidParameter {
                name: "tol",
                value: tol.to_string(),
                expected: "a finite number >= 0",
            });
        }
        Ok(Controls { max_iter, check_every, tol, strict })
    }
}

/// How far the points may spread and still be certain never to become valid.
#[derive(Debug, Clone, Copy)]
pub(crate) enum CapLimit {
    /// No certificate: updates that are not convex combinations can leave any cap.
    None,
    /// Any open hemisphere (updates are convex combinations).
    Hemisphere,
    /// A cap of angular radius at most `asin(s)`, `s < 1`: within it the update is
    /// a convex combination (Alexa's method with a large constant step).
    SinRadius(f64),
}

/// Margin on the hemisphere test, far above the rounding of one update (~1e-16)
/// so that rounding cannot undo the certificate.
const HEMISPHERE_MARGIN: f64 = 1e-9;

/// Points per parallel task. Fixed, so that per-chunk sums are added in the same
/// order on any number of threads (a work-stealing float reduction is not).
const CHUNK: usize = 1024;

/// Sum of the points, chunk by chunk, deterministically.
fn point_sum(points: &[[f64; 3]]) -> [f64; 3] {
    let partial: Vec<[f64; 3]> =
        points.par_chunks(CHUNK).map(|c| c.iter().fold([0.0; 3], |s, &p| add(s, p))).collect();
    partial.into_iter().fold([0.0; 3], add)
}

/// One Jacobi sweep, `next[i] = update(points, i)` for every vertex in parallel.
/// Returns the largest move of a point and the sum of the new points (for the
/// collapse test), computed in the same pass.
fn sweep<F>(points: &[[f64; 3]], next: &mut [[f64; 3]], update: &F) -> (f64, [f64; 3])
where
    F: Fn(&[[f64; 3]], usize) -> [f64; 3] + Sync,
{
    let partial: Vec<(f64, [f64; 3])> = next
        .par_chunks_mut(CHUNK)
        .enumerate()
        .map(|(c, out)| {
            let (mut moved, mut sum) = (0.0f64, [0.0; 3]);
            for (k, slot) in out.iter_mut().enumerate() {
                let i = c * CHUNK + k;
                let (p, old) = (update(points, i), points[i]);
                let d =
                    ((p[0] - old[0]).powi(2) + (p[1] - old[1]).powi(2) + (p[2] - old[2]).powi(2))
                        .sqrt();
                moved = moved.max(d);
                sum = add(sum, p);
                *slot = p;
            }
            (moved, sum)
        })
        .collect();
    partial.into_iter().fold((0.0, [0.0; 3]), |(m, s), (dm, ds)| (m.max(dm), add(s, ds)))
}

/// The cap about the mean direction that holds every point: `(cos of its
/// angular radius, |mean of the points|)`, or `None` when the mean is zero.
/// `sum` is the sum of the points.
fn enclosing_cap(points: &[[f64; 3]], sum: [f64; 3]) -> Option<(f64, f64)> {
    let n = normalize(sum)?;
    let resultant =
        (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt() / points.len() as f64;
    // min is exact, so the parallel reduction is deterministic.
    let cos = points
        .par_iter()
        .with_min_len(1 << 14)
        .map(|p| n[0] * p[0] + n[1] * p[1] + n[2] * p[2])
        .reduce(|| f64::INFINITY, f64::min);
    Some((cos, resultant))
}

fn collapsed(cap: CapLimit, cos: f64) -> bool {
    match cap {
        CapLimit::None => false,
        CapLimit::Hemisphere => cos > HEMISPHERE_MARGIN,
        CapLimit::SinRadius(s) => cos > (1.0 - s * s).max(0.0).sqrt() + HEMISPHERE_MARGIN,
    }
}

/// The loop both methods share: `update(points, i)` is the new position of
/// vertex `i` from the previous iterate (a Jacobi step). Tests for collapse
/// after every iteration (O(N), fused with the sweep), for validity every
/// `check_every` iterations, when the moves fall below `tol`, and at the end.
pub(crate) fn iterate<F>(
    faces: &[[u32; 3]],
    mut points: Vec<[f64; 3]>,
    controls: &Controls,
    cap: CapLimit,
    setup_seconds: f64,
    method: &str,
    update: F,
) -> Result<SphereEmbedding, SphereError>
where
    F: Fn(&[[f64; 3]], usize) -> [f64; 3] + Sync,
{
    let start = Instant::now();
    let mut next = points.clone();
    let mut sum = point_sum(&points);
    let mut r = 0usize;
    let mut settled_checked = false;
    let (status, message) = loop {
        if let Some((cos, resultant)) = enclosing_cap(&points, sum) {
            if collapsed(cap, cos) {
                let radius = cos.clamp(-1.0, 1.0).acos().to_degrees();
                let (when, advice) = if r == 0 {
                    (
                        "the initial points already lie".to_string(),
                        "; choose a centre inside the mesh, or other initial points",
                    )
                } else {
                    (format!("after {r} iterations all points lie"), "")
                };
                break (
                    Status::Collapsed,
                    format!(
                        "{method}: {when} within {radius:.3} degrees of one direction (mean resultant length \
                         {resultant:.4}), in an open hemisphere that the update never leaves and that holds no \
                         valid embedding: the drawing is collapsing towards one point (thesis 5.2){advice}"
                    ),
                );
            }
        }
        let scheduled = r % controls.check_every == 0 || r == controls.max_iter;
        if scheduled {
            let report = check_sphere(faces, &points);
            if report.valid {
                break (
                    Status::Converged,
                    format!("{method}: the exact validity test of thesis 3.4 passed after {r} iterations"),
                );
            }
            if r == controls.max_iter {
                let flipped = report.flipped_faces.len();
                break (
                    Status::MaxIterations,
                    format!(
                        "{method}: no valid embedding after {r} iterations (max_iter): {flipped} of {} faces fail \
                         the orientation test, covering degree {}",
                        faces.len(),
                        report.covering_degree
                    ),
                );
            }
        }
        let (moved, new_sum) = sweep(&points, &mut next, &update);
        std::mem::swap(&mut points, &mut next);
        sum = new_sum;
        r += 1;
        // A settled iteration is tested once (until it moves again); if it is
        // not valid it may still drift, so the schedule goes on.
        if moved < controls.tol {
            if !settled_checked && r % controls.check_every != 0 && r != controls.max_iter {
                settled_checked = true;
                if check_sphere(faces, &points).valid {
                    break (
                        Status::Converged,
                        format!(
                            "{method}: the iteration settled (largest move {moved:.3e} < tol) and the exact \
                             validity test of thesis 3.4 passed after {r} iterations"
                        ),
                    );
                }
            }
        } else {
            settled_checked = false;
        }
    };
    let embedding = SphereEmbedding {
        points,
        iterations: r,
        status,
        message,
        seconds: vec![("setup", setup_seconds), ("iterate", start.elapsed().as_secs_f64())],
    };
    if controls.strict && status != Status::Converged {
        return Err(SphereError::NoConvergence { last: Box::new(embedding) });
    }
    Ok(embedding)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use spherify_mesh::{validate, Mesh};

    /// The method on a test mesh, validated here.
    fn relaxation(mesh: &Mesh, params: &RelaxationParams) -> Result<SphereEmbedding, SphereError> {
        super::relaxation(&GenusZeroMesh::new(mesh.clone())?, params)
    }

    fn initial_points(mesh: &Mesh, initial: &Initial) -> Result<Vec<[f64; 3]>, SphereError> {
        crate::initial::initial_points(&GenusZeroMesh::new(mesh.clone())?, initial)
    }

    /// Unit icosahedron, faces counter-clockwise from outside.
    fn icosahedron() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let t = (1.0 + 5f64.sqrt()) / 2.0;
        let p = [
            [-1.0, t, 0.0],
            [1.0, t, 0.0],
            [-1.0, -t, 0.0],
            [1.0, -t, 0.0],
            [0.0, -1.0, t],
            [0.0, 1.0, t],
            [0.0, -1.0, -t],
            [0.0, 1.0, -t],
            [t, 0.0, -1.0],
            [t, 0.0, 1.0],
            [-t, 0.0, -1.0],
            [-t, 0.0, 1.0],
        ];
        let f = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        (p.iter().map(|&q| normalize(q).unwrap()).collect(), f)
    }

    /// Unit octahedron, faces counter-clockwise from outside.
    fn octahedron_arrays() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let (p, f) = (
            spherify_mesh::solids::OCTAHEDRON_POSITIONS.to_vec(),
            spherify_mesh::solids::OCTAHEDRON_FACES.to_vec(),
        );
        (p, f)
    }

    fn subdivide((p, f): (Vec<[f64; 3]>, Vec<[u32; 3]>), levels: usize) -> Mesh {
        spherify_mesh::solids::subdivided(p, f, levels)
    }

    pub fn icosphere(levels: usize) -> Mesh {
        subdivide(icosahedron(), levels)
    }

    /// The octahedron, split `levels` times.
    pub fn octasphere(levels: usize) -> Mesh {
        subdivide(octahedron_arrays(), levels)
    }

    /// Moves every vertex of a unit-sphere mesh along its ray: `radius(p)`.
    pub fn reshape(mesh: &Mesh, radius: impl Fn([f64; 3]) -> [f64; 3]) -> Mesh {
        let p = mesh.positions().iter().map(|&q| radius(q)).collect();
        Mesh::new(p, mesh.faces().to_vec()).unwrap()
    }

    /// A sphere with bumps and dents (star-shaped about the origin, but folded
    /// when seen from the off-centre centroid of a lopsided blob).
    pub fn bumpy(levels: usize) -> Mesh {
        reshape(&icosphere(levels), |q| {
            let bumps = [([0.0, 0.0, 1.0], 0.9), ([0.8, 0.6, 0.0], 0.7), ([-0.6, 0.0, -0.8], -0.4)];
            let mut r = 1.0;
            for (c, a) in bumps {
                let d: f64 = q.iter().zip(c).map(|(x, y)| x * y).sum();
                r += a * (12.0 * (d - 1.0)).exp();
            }
            [q[0] * r, q[1] * r, q[2] * r]
        })
    }

    /// Pseudo-random, deterministic noise in [-1, 1].
    pub fn noise(i: usize, k: usize) -> f64 {
        let mut x = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ (k as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
        x ^= x >> 31;
        x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x ^= x >> 29;
        (x >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }

    /// The vertices of `mesh` with noise of size `amount` added: an initial
    /// drawing with foldovers.
    pub fn scrambled(mesh: &Mesh, amount: f64) -> Vec<[f64; 3]> {
        mesh.positions()
            .iter()
            .enumerate()
            .map(|(i, p)| {
                [
                    p[0] + amount * noise(i, 0),
                    p[1] + amount * noise(i, 1),
                    p[2] + amount * noise(i, 2),
                ]
            })
            .collect()
    }

    /// A closed tube of `rings` rings of `around` vertices about the curve
    /// `centre(t)`, t in [0, 1], radius `radius`, each end closed by an apex
    /// vertex. Rings lie in the plane spanned by `normal(t)` and the binormal
    /// `tangent x normal`; odd rings are turned half a step.
    pub fn tube(
        around: usize,
        rings: usize,
        radius: f64,
        centre: impl Fn(f64) -> [f64; 3],
        tangent: impl Fn(f64) -> [f64; 3],
        normal: impl Fn(f64) -> [f64; 3],
    ) -> Mesh {
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
        };
        let at =
            |c: [f64; 3], d: [f64; 3], s: f64| [c[0] + s * d[0], c[1] + s * d[1], c[2] + s * d[2]];
        let mut p =
            vec![at(centre(0.0), tangent(0.0), -radius), at(centre(1.0), tangent(1.0), radius)];
        for r in 0..rings {
            let t = r as f64 / (rings - 1) as f64;
            let (c, n) = (centre(t), normal(t));
            let b = cross(tangent(t), n);
            for k in 0..around {
                let a = std::f64::consts::TAU * (k as f64 + 0.5 * (r % 2) as f64) / around as f64;
                p.push(at(at(c, n, radius * a.cos()), b, radius * a.sin()));
            }
        }
        let id = |r: usize, k: usize| (2 + r * around + k % around) as u32;
        let mut f = Vec::new();
        for k in 0..around {
            f.push([0, id(0, k + 1), id(0, k)]);
            f.push([1, id(rings - 1, k), id(rings - 1, k + 1)]);
        }
        for r in 0..rings - 1 {
            for k in 0..around {
                // Odd rings are turned half a step: stagger the diagonals.
                if r % 2 == 0 {
                    f.push([id(r, k), id(r, k + 1), id(r + 1, k)]);
                    f.push([id(r + 1, k), id(r, k + 1), id(r + 1, k + 1)]);
                } else {
                    f.push([id(r, k), id(r + 1, k + 1), id(r + 1, k)]);
                    f.push([id(r, k), id(r, k + 1), id(r + 1, k + 1)]);
                }
            }
        }
        Mesh::new(p, f).unwrap()
    }

    /// A straight capsule along z, radius 1, `length` long.
    pub fn capsule(around: usize, rings: usize, length: f64) -> Mesh {
        tube(
            around,
            rings,
            1.0,
            |t| [0.0, 0.0, length * (t - 0.5)],
            |_| [0.0, 0.0, 1.0],
            |_| [1.0, 0.0, 0.0],
        )
    }

    /// A thin tube bent along `turns` turns of a helix of radius 1 and `pitch`
    /// rise per turn about the z axis: its centroid lies outside it.
    pub fn helix(around: usize, rings: usize, radius: f64, turns: f64, pitch: f64) -> Mesh {
        let w = std::f64::consts::TAU * turns;
        let h = pitch * turns;
        let len = (w * w + h * h).sqrt();
        tube(
            around,
            rings,
            radius,
            move |t| [(w * t).cos(), (w * t).sin(), h * (t - 0.5)],
            move |t| [-w * (w * t).sin() / len, w * (w * t).cos() / len, h / len],
            move |t| [(w * t).cos(), (w * t).sin(), 0.0],
        )
    }

    fn assert_valid(mesh: &Mesh, e: &SphereEmbedding) {
        assert_eq!(e.status, Status::Converged, "{}", e.message);
        assert!(check_sphere(mesh.faces(), &e.points).valid, "{}", e.message);
        for p in &e.points {
            assert!(((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 1.0).abs() < 1e-12);
        }
        assert_eq!(e.seconds.iter().map(|s| s.0).collect::<Vec<_>>(), vec!["setup", "iterate"]);
    }

    pub fn octahedron() -> Mesh {
        let (p, f) = octahedron_arrays();
        Mesh::new(p, f).unwrap()
    }

    /// A perturbed, subdivided octahedron and a folded start on it.
    pub fn perturbed_octahedron() -> (Mesh, Vec<[f64; 3]>) {
        let base = octasphere(2);
        let mesh = Mesh::new(scrambled(&base, 0.05), base.faces().to_vec()).unwrap();
        // The top vertex pulled down across its ring: its fan folds over.
        let mut start = mesh.positions().to_vec();
        start[4] = [0.2, 0.1, 0.6];
        (mesh, start)
    }

    /// A thin tube bent along 216 degrees of a circle (a "C"): relaxation from
    /// the centroid, which lies outside the tube, collapses on it.
    pub fn bent_tube() -> Mesh {
        helix(8, 100, 0.2, 0.6, 0.0)
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
