//! The conformal energy's other start: where the global conformal map of
//! [`crate::methods::progressive::conformal_start`] is certified and no face lies inside the
//! energy's barrier, the flip-free sweeps start from it instead of from the
//! hierarchy.
//!
//! The rule, and why: below [`CONFORMAL_AREA_FLOOR`] the conformal energy is
//! plain MIPS, which a discrete conformal map nearly minimises already, and
//! whose smooth, global part local sweeps remove only slowly (igea, 134k
//! vertices: 0.25 degrees of mean angle distortion from the start after one
//! sweep, in 3 s; 0.74 from the hierarchy in 11 s). A face inside the barrier
//! means a limb the conformal map squeezes; there the hierarchy, which gives
//! limbs their share of the sphere from the coarse levels on, is the better
//! start (human_man: the conformal start leaves faces with no area in double
//! precision, which 100 sweeps do not repair).
//!
//! A second start competes with it: the radial projection from the vertex
//! mean (thesis eq. 3.17-3.18), when it is certified and outside the
//! barrier too. The sweeps start from whichever of the two has the lower
//! conformal energy. On a nearly round mesh the projection is nearly
//! conformal already and the discrete conformal map's small smooth error is
//! what the sweeps are slowest to remove (issue 22, mean angle distortion
//! after the sweeps: the soccer ball 0.227 degrees from the conformal map,
//! 0.035 from the projection, SphereParam about 0.1; a 20k icosphere 0.154
//! and 0.0001). Elsewhere the projection squeezes what sticks out, or is not
//! valid at all, and loses (20k ellipsoid: conformal energy 2.038 per unit
//! area against 2.0006).

use std::time::Instant;

use rayon::prelude::*;
use spherify_mesh::vec3::det3;

use super::{area_floor, rings_of, ProgressiveParams};
use crate::certificate::validity::check_sphere;
use crate::embedding::{SphereEmbedding, Status};
use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;
use crate::methods::progressive::conformal_start::{conformal_start, NoStart};
use crate::methods::progressive::distortion_energy::CONFORMAL_AREA_FLOOR;
use crate::methods::progressive::flip_free::{Problem, Stars};
use crate::methods::radial::{radial_map, Center};

/// Why the hierarchy runs after all, and the seconds spent finding that out.
pub struct NotUsed {
    pub reason: String,
    pub seconds: f64,
}

/// The progressive conformal map from the global conformal start, or why
/// that start is not used. `progress` as in [`super::progressive`].
///
/// # Errors
/// [`SphereError::Cancelled`].
pub fn from_conformal_start(
    mesh: &GenusZeroMesh,
    params: &ProgressiveParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<Result<SphereEmbedding, NotUsed>, SphereError> {
    let n = mesh.n_vertices();
    let total = 3 * n;
    let started = Instant::now();
    let floor = area_floor(mesh);
    let cancelled = |done: usize| SphereError::Cancelled { stage: "conformal start", done, total };
    let start = match conformal_start(mesh, floor, &|| !progress(0, 0)) {
        Ok(start) => start,
        Err(why) => {
            let reason = match why {
                NoStart::Stopped => return Err(cancelled(0)),
                NoStart::Solve(e) => format!("its planar solve failed ({e})"),
                NoStart::NotValid(r) => format!(
                    "it is not a valid GC-embedding ({} faces not positive)",
                    r.flipped_faces.len()
                ),
            };
            return Ok(Err(NotUsed { reason, seconds: started.elapsed().as_secs_f64() }));
        }
    };
    if !(progress(0, 0) && progress(n, total)) {
        return Err(cancelled(n));
    }
    let rings = rings_of(mesh)?;
    let problem = Problem {
        energy: params.energy,
        surface: mesh.positions(),
        area_floor: floor,
        represented: None,
        pull: None,
    };
    let stars = problem.stars(&rings);
    let smallest = smallest_area_ratio(&problem, &stars, &start.points);
    if smallest.is_nan() || smallest < CONFORMAL_AREA_FLOOR {
        let reason = format!(
            "it squeezes a face to {smallest:.1e} of its share of the area, inside the barrier \
             below {CONFORMAL_AREA_FLOOR:.0e}"
        );
        return Ok(Err(NotUsed { reason, seconds: started.elapsed().as_secs_f64() }));
    }
    let rival = radial_rival(mesh, &problem, &stars, &start.points);
    let seconds_start = started.elapsed().as_secs_f64();
    if !progress(0, 0) {
        return Err(cancelled(n));
    }

    let started = Instant::now();
    let (mut points, from) = match rival {
        Some(Rival { points, energy, conformal_energy }) => (
            points,
            format!(
                "started from the radial projection from the vertex mean (eq. 3.17-3.18), whose \
                 conformal energy {energy:.6} per unit area was below the global conformal map's \
                 {conformal_energy:.6}"
            ),
        ),
        None => (
            start.points,
            format!(
                "started from the global conformal map (a pole at face {}, Möbius-centred in {} \
                 steps)",
                start.removed_face, start.centred.steps
            ),
        ),
    };
    let max_iter = params.max_iter.max(1);
    let stop = |sweep: usize| !(progress(0, 0) && progress(2 * n + n * sweep / max_iter, total));
    let end = problem
        .optimise(&rings, &mut points, params.max_iter, params.tolerance, &stop)
        .map_err(|_| SphereError::Cancelled { stage: "optimisation", done: 2 * n, total })?;
    progress(total, total);
    let status = if end.converged { Status::Converged } else { Status::MaxIterations };
    let message = format!(
        "{from}; {} final sweeps of the {} energy, {:.4} per unit area (last relative change \
         {:.1e})",
        end.sweeps,
        params.energy.name(),
        end.energy,
        end.last_change
    );
    Ok(Ok(SphereEmbedding {
        points,
        iterations: end.sweeps,
        status,
        message,
        seconds: vec![
            ("conformal start", seconds_start),
            ("optimisation", started.elapsed().as_secs_f64()),
        ],
    }))
}

/// The radial projection from the vertex mean when it beats the global
/// conformal map as a start, with both conformal energies per unit area.
struct Rival {
    points: Vec<[f64; 3]>,
    energy: f64,
    conformal_energy: f64,
}

/// The radial projection from the vertex mean, when it is a certified map
/// (exact orientation and area tests) with no face inside the barrier and
/// a lower conformal energy than `start` (the global conformal map's
/// points, whose energy is measured only then); otherwise `None`.
fn radial_rival(
    mesh: &GenusZeroMesh,
    problem: &Problem<'_>,
    stars: &Stars,
    start: &[[f64; 3]],
) -> Option<Rival> {
    // A vertex at the mean has no direction: then there is no rival.
    let points = radial_map(mesh, Center::Centroid).ok()?.embedding.points;
    if !check_sphere(mesh.faces(), &points).valid {
        return None;
    }
    let smallest = smallest_area_ratio(problem, stars, &points);
    if smallest.is_nan() || smallest < CONFORMAL_AREA_FLOOR {
        return None;
    }
    let energy = problem.per_area(stars, &points);
    let conformal_energy = problem.per_area(stars, start);
    (energy < conformal_energy).then_some(Rival { points, energy, conformal_energy })
}

/// The smallest d (image area over scaled surface area, as in the energies)
/// over the faces, each seen from its smallest corner.
fn smallest_area_ratio(problem: &Problem<'_>, stars: &Stars, points: &[[f64; 3]]) -> f64 {
    let k = problem.area_scale(stars, points);
    (0..stars.len() as u32)
        .into_par_iter()
        .map(|i| {
            let (ring, refs) = (stars.ring(i), stars.refs(i));
            let m = ring.len();
            (0..m)
                .filter(|&j| i < ring[j] && i < ring[(j + 1) % m])
                .map(|j| {
                    let [p, a, b] = [i, ring[j], ring[(j + 1) % m]].map(|v| points[v as usize]);
                    0.5 * det3(p, a, b) / (k * refs[j].area)
                })
                .fold(f64::INFINITY, f64::min)
        })
        .reduce(|| f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::super::progressive;
    use super::*;
    use crate::applications::metrics::quality;
    use crate::certificate::validity::check_sphere;
    use crate::methods::progressive::distortion_energy::Energy;
    use spherify_mesh::solids::{bumpy, capsule, icosphere};

    fn conformal(mesh: &GenusZeroMesh) -> SphereEmbedding {
        progressive(mesh, &ProgressiveParams::for_energy(Energy::Conformal), &|_, _| true).unwrap()
    }

    /// The conformal map of `mesh` on one and on two threads is `map`, bit
    /// for bit.
    fn assert_same_on_one_and_two_threads(mesh: &GenusZeroMesh, map: &SphereEmbedding) {
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            assert_eq!(pool.install(|| conformal(mesh).points), map.points, "{threads} threads");
        }
    }

    #[test]
    fn a_smooth_shape_starts_from_the_global_conformal_map() {
        let mesh = GenusZeroMesh::new(bumpy(3)).unwrap();
        let map = conformal(&mesh);
        assert!(
            map.message.starts_with("started from the global conformal map"),
            "{}",
            map.message
        );
        let report = check_sphere(mesh.faces(), &map.points);
        assert!(report.valid && report.min_area_ratio > 1e-3, "{report:?}");
        // The sweeps only lower the energy from the start, and with it the
        // angle distortion.
        let start = conformal_start(&mesh, area_floor(&mesh), &|| false).unwrap();
        let before = quality(mesh.mesh(), &start.points).unwrap().angle_mean_deg;
        let after = quality(mesh.mesh(), &map.points).unwrap().angle_mean_deg;
        assert!(after <= before && after < 3.0, "{before} -> {after}");
        // The same bits on every thread count, start included.
        assert_same_on_one_and_two_threads(&mesh, &map);
    }

    #[test]
    fn a_round_mesh_starts_from_the_radial_projection_where_it_is_lower() {
        // An icosphere's vertices lie on a sphere about its vertex mean:
        // the projection is the identity, exactly conformal, and the
        // global conformal map (a planar solve) is a little off it.
        let mesh = GenusZeroMesh::new(icosphere(4)).unwrap();
        let map = conformal(&mesh);
        assert!(map.message.starts_with("started from the radial projection"), "{}", map.message);
        let report = check_sphere(mesh.faces(), &map.points);
        assert!(report.valid && report.min_area_ratio > 1e-3, "{report:?}");
        let angle = quality(mesh.mesh(), &map.points).unwrap().angle_mean_deg;
        let start = conformal_start(&mesh, area_floor(&mesh), &|| false).unwrap();
        let from_start = quality(mesh.mesh(), &start.points).unwrap().angle_mean_deg;
        // 0.004 degrees after the sweeps (rounding-level moves), 0.43 from
        // the global conformal map alone.
        assert!(angle < 0.01 && angle < 0.1 * from_start, "{angle} against {from_start}");
        // The same bits on every thread count.
        assert_same_on_one_and_two_threads(&mesh, &map);
    }

    #[test]
    fn a_long_limb_falls_back_to_the_hierarchy_and_says_why() {
        // The conformal map of a 30:1 capsule squeezes its middle by about
        // 1e-13 in area: refused by the exact test or inside the barrier.
        let mesh = GenusZeroMesh::new(capsule(10, 200, 30.0)).unwrap();
        let map = conformal(&mesh);
        assert!(map.message.contains("the global conformal start was not used"), "{}", map.message);
        assert!(map.seconds.iter().any(|(stage, _)| *stage == "conformal start"));
        assert!(map.seconds.iter().any(|(stage, _)| *stage == "hierarchy"));
        let report = check_sphere(mesh.faces(), &map.points);
        assert!(report.valid && report.min_area_ratio > 1e-12, "{report:?}");
    }

    #[test]
    fn the_start_can_be_cancelled() {
        let mesh = GenusZeroMesh::new(bumpy(3)).unwrap();
        let params = ProgressiveParams::for_energy(Energy::Conformal);
        let err = progressive(&mesh, &params, &|done, _| done == 0).unwrap_err();
        assert!(matches!(err, SphereError::Cancelled { stage: "conformal start", .. }), "{err}");
    }
}
