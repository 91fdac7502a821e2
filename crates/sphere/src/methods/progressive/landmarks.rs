//! Landmark-exact maps (issue 23, item 1): from a valid GC-embedding, move
//! chosen vertices onto given directions exactly, through valid maps only,
//! then lower the distortion energy with those vertices held.
//!
//! 1. A smooth flow of the sphere ([`sphere_flow`]) carries every vertex
//!    along with the landmarks in small increments, each certified with the
//!    exact test of thesis 3.4 before it is kept; this does most of the
//!    distance where the landmarks' displacements agree locally.
//! 2. The drag: each landmark moves along the great circle towards its
//!    target, in chord steps as long as its star stays positive. Along the
//!    chord `p + s d` every det[p + s d, a, b] is linear in `s`, so the
//!    largest safe step has a closed form, and a step whose end passes the
//!    exact orientation test keeps every face positive on the whole way
//!    (thesis 9.3.2; the covering degree cannot jump). The last step stores
//!    the normalised target itself, so the landmark is exact.
//! 3. When a landmark is blocked (its ring's kernel ends before the target),
//!    the energy is lowered with every landmark held, first on a growing
//!    neighbourhood of it, then on the whole mesh, and the drag goes on.
//!    The work is bounded: a drag that stops gaining is reported as a
//!    [`SphereError::LandmarkConflict`] naming the landmarks not placed.
//! 4. Energy sweeps with the landmarks held ([`Problem::optimise_holding`]).
//!
//! Sets no map can realise are refused before any move: two neighbours at
//! opposite points (their edge would be no minor arc), a face of three
//! landmarks whose targets are not positively oriented.

pub mod path_layout;
mod sphere_flow;

use std::time::Instant;

use spherify_mesh::predicates::{det3_sign, Sign};
use spherify_mesh::vec3::{add, cross, dot, norm, scale, sub};

use crate::certificate::validity::check_sphere;
use crate::embedding::{normalize, SphereEmbedding, Status};
use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;
use crate::methods::progressive::distortion_energy::Energy;
use crate::methods::progressive::flip_free::{check_tolerance, tangent_basis, Optimised, Problem};
use crate::methods::progressive::star_lanes::positive_fan;
use crate::methods::progressive::{require_valid_start, rings_of, whole_mesh_problem};
use path_layout::{path_layout, PathLayout};
use spherify_mesh::Mesh;

/// Vertex ids and the unit directions they are pinned to, checked.
#[derive(Debug, Clone, PartialEq)]
pub struct Landmarks {
    pub ids: Vec<u32>,
    /// Normalised: what the landmark's stored point is at the end.
    pub targets: Vec<[f64; 3]>,
}

impl Landmarks {
    /// Checks `ids` against a mesh of `n_vertices` and normalises `targets`.
    ///
    /// # Errors
    /// [`SphereError::BadLandmarks`] naming the ids: lengths differ, an id out
    /// of range or repeated, a target not finite or zero, two targets at the
    /// same direction.
    pub fn new(
        n_vertices: usize,
        ids: &[i64],
        targets: &[[f64; 3]],
    ) -> Result<Landmarks, SphereError> {
        let bad = |ids: Vec<usize>, reason: String| SphereError::BadLandmarks { ids, reason };
        if ids.len() != targets.len() {
            return Err(bad(
                vec![],
                format!("{} ids but {} target points", ids.len(), targets.len()),
            ));
        }
        let out: Vec<usize> = ids
            .iter()
            .filter(|&&i| i < 0 || i as u64 >= n_vertices as u64)
            .map(|&i| i.max(0) as usize)
            .collect();
        if let Some(&i) = ids.iter().find(|&&i| i < 0 || i as u64 >= n_vertices as u64) {
            return Err(bad(
                out,
                format!("id {i} is not a vertex of the mesh (it has {n_vertices} vertices)"),
            ));
        }
        let ids: Vec<u32> = ids.iter().map(|&i| i as u32).collect();
        let mut sorted = ids.clone();
        sorted.sort_unstable();
        let repeated: Vec<usize> =
            sorted.windows(2).filter(|w| w[0] == w[1]).map(|w| w[0] as usize).collect();
        if !repeated.is_empty() {
            return Err(bad(repeated, "each vertex can be pinned once: repeated ids".into()));
        }
        let mut unit = Vec::with_capacity(targets.len());
        for (&i, &t) in ids.iter().zip(targets) {
            match normalize(t) {
                Some(u) => unit.push(u),
                None => {
                    return Err(bad(
                        vec![i as usize],
                        format!("target {t:?} has no direction (not finite, or zero)"),
                    ))
                }
            }
        }
        let mut order: Vec<usize> = (0..unit.len()).collect();
        order.sort_by(|&a, &b| unit[a].partial_cmp(&unit[b]).expect("finite"));
        if let Some(w) = order.windows(2).find(|w| unit[w[0]] == unit[w[1]]) {
            let (a, b) = (ids[w[0]] as usize, ids[w[1]] as usize);
            return Err(bad(
                vec![a.min(b), a.max(b)],
                format!(
                    "two landmarks at the same direction {:?}: a map is one-to-one",
                    unit[w[0]]
                ),
            ));
        }
        Ok(Landmarks { ids, targets: unit })
    }

    pub fn len(&self) -> usize {
        self.ids.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// One flag per vertex: landmark or not.
    pub fn mask(&self, n_vertices: usize) -> Vec<bool> {
        let mut held = vec![false; n_vertices];
        for &i in &self.ids {
            held[i as usize] = true;
        }
        held
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct PinParams {
    /// The energy lowered between drags and at the end.
    pub energy: Energy,
    /// Most energy sweeps with the landmarks held, at the end.
    pub max_iter: usize,
    pub tolerance: f64,
    /// Lay out at once, without trying the drag, when more than
    /// [`DRAG_FIRST_OUT_OF_ORDER`] landmarks are out of order at the start
    /// ([`path_layout::out_of_order_count`]).
    pub layout_when_scrambled: bool,
    /// Most vertices the layout may refine the mesh to; `None`: the layout's
    /// own bound ([`path_layout::path_layout`]). A caller that would rather
    /// do without a map than work on one much finer than its mesh (the
    /// warp's scaffold) asks for less.
    pub max_vertices: Option<usize>,
}

impl Default for PinParams {
    fn default() -> Self {
        PinParams {
            energy: Energy::Isometric,
            max_iter: 30,
            tolerance: 1e-3,
            layout_when_scrambled: true,
            max_vertices: None,
        }
    }
}

/// How the pinning went, for the message.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PinInfo {
    /// Increments of the flow that were certified and kept.
    pub flow_increments: usize,
    /// The largest angle from a landmark to its target after the flow.
    pub after_flow: f64,
    /// Rounds of drags, local and global relaxations.
    pub rounds: usize,
    pub local_relaxations: usize,
    pub global_relaxations: usize,
    /// Final energy sweeps.
    pub sweeps: usize,
}

/// The longest arc a chord step aims at: a chord of less than a quarter
/// circle stays far from the origin, so its normalisation is well defined.
const MAX_ARC: f64 = std::f64::consts::FRAC_PI_3;
/// Fraction of the largest flip-free chord step a drag takes: the rest keeps
/// the ring's kernel open for the next step.
const DRAG_FRACTION: f64 = 0.8;
/// Halvings of a drag step before the landmark counts as stuck.
const DRAG_HALVINGS: usize = 30;
/// Drag steps of one landmark in one round.
const STEPS_PER_ROUND: usize = 8;
/// Relaxation radii (in rings) around a blocked landmark: doubled on each
/// block in a row, from 1 to this.
const MAX_RADIUS: usize = 16;
/// Passes of flip-free moves over a neighbourhood.
const LOCAL_PASSES: usize = 3;
/// Rounds without a gain of [`GAIN`] in the total angle left before the
/// drag gives up (five global relaxations among them), and the sweeps of a
/// global relaxation.
const STALL_ROUNDS: usize = 10;
const GAIN: f64 = 1e-3;
const GLOBAL_SWEEPS: usize = 3;
/// Energy sweeps after each increment of the flow.
const FLOW_SWEEPS: usize = 2;
/// Most rounds in all: the drag's work is bounded.
const MAX_ROUNDS: usize = 1000;

/// A cosine above cos([`MAX_ARC`]) = 1/2 by a margin far beyond rounding.
const WITHIN_ARC_COS: f64 = 0.5 + 1e-6;

/// Whether the angle between `p` and `q` is surely at most [`MAX_ARC`], and
/// so [`angle`] (whose rounding is far below the margin of
/// [`WITHIN_ARC_COS`]) at most `MAX_ARC` too: their cosine, p . q over
/// |p| |q|, is at least `WITHIN_ARC_COS`. False says nothing.
fn surely_within_arc(p: [f64; 3], q: [f64; 3]) -> bool {
    let d = dot(p, q);
    d > 0.0 && d * d >= WITHIN_ARC_COS * WITHIN_ARC_COS * dot(p, p) * dot(q, q)
}

/// The angle between two unit vectors, accurate near 0 and pi.
pub(crate) fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    norm(cross(a, b)).atan2(dot(a, b))
}

/// The point a fraction `t` of the way from `p` to `q` along their great circle.
pub(crate) fn slerp(p: [f64; 3], q: [f64; 3], t: f64) -> [f64; 3] {
    let theta = angle(p, q);
    let along = sub(q, scale(p, dot(p, q)));
    let u = normalize(along).unwrap_or_else(|| tangent_basis(p).0);
    let a = t * theta;
    normalize(add(scale(p, a.cos()), scale(u, a.sin()))).unwrap_or(p)
}

/// One drag of a vertex at `p` with ring `ring` towards `goal` (a unit
/// vector): the new point, the goal itself when the whole way is free, or
/// `None` when no step passes.
///
/// The chord `p + s (w - p)` to a waypoint `w` at most [`MAX_ARC`] along the
/// great circle: each face's det is linear in `s`, which gives the largest
/// flip-free `s`; the end of the step is tested exactly.
pub(crate) fn drag(
    p: [f64; 3],
    goal: [f64; 3],
    ring: &[u32],
    points: &[[f64; 3]],
) -> Option<[f64; 3]> {
    drag_above(p, goal, ring, points, 0.0)
}

/// [`drag`] keeping every face's det above `floor`, and a face already below
/// `floor` from shrinking at all: soft moves towards targets that need not be
/// reached must not crush triangles against each other on the way. (Letting
/// such a face halve per step, as before, let the sixteen rounds of a
/// registration warp crush the thin faces of an octopus's map to det 0 in
/// floating point: halving compounds over calls.)
pub(crate) fn drag_above(
    p: [f64; 3],
    goal: [f64; 3],
    ring: &[u32],
    points: &[[f64; 3]],
    floor: f64,
) -> Option<[f64; 3]> {
    let mut star = Star::default();
    star.gather(ring, points);
    drag_star(p, goal, &star, floor)
}

/// A vertex's ring laid out for its drags while the ring stands still: the
/// corners in ring order and, for each face `(p, a, b)` of the fan, the
/// cross product `a x b`, so that det[x, a, b] = x . (a x b) costs one dot
/// product for every point `x` a drag tries ([`spherify_mesh::vec3::det3`]
/// forms it so: the same bits). The warp's rounds drag every vertex up to
/// four times a pass with its ring fixed (issue 23, register's speed,
/// session 13).
#[derive(Debug, Default)]
pub(crate) struct Star {
    corners: Vec<[f64; 3]>,
    crosses: Vec<[f64; 3]>,
}

impl Star {
    /// The star of the vertex with ring `ring` in `points` (the buffers are
    /// reused).
    pub(crate) fn gather(&mut self, ring: &[u32], points: &[[f64; 3]]) {
        self.corners.clear();
        self.corners.extend(ring.iter().map(|&v| points[v as usize]));
        let m = self.corners.len();
        self.crosses.clear();
        let corners = &self.corners;
        self.crosses.extend((0..m).map(|j| cross(corners[j], corners[(j + 1) % m])));
    }
}

/// [`drag_above`] on a gathered [`Star`]: the same points to the bit (each
/// det is `x . (a x b)` as [`spherify_mesh::vec3::det3`] forms it, and the
/// exact orientation test is [`positive_fan`]'s, whose answer is
/// [`crate::methods::progressive::flip_free::positive_star`]'s).
pub(crate) fn drag_star(p: [f64; 3], goal: [f64; 3], star: &Star, floor: f64) -> Option<[f64; 3]> {
    if p == goal {
        return Some(goal);
    }
    // The angle (an atan2, a tenth of the registration's rounds of moves)
    // only where the cosine does not already say it is within MAX_ARC.
    let waypoint = if surely_within_arc(p, goal) {
        goal
    } else {
        let theta = angle(p, goal);
        if theta <= MAX_ARC {
            goal
        } else {
            slerp(p, goal, MAX_ARC / theta)
        }
    };
    let d = sub(waypoint, p);
    let mut s_safe = f64::INFINITY;
    for &ab in &star.crosses {
        let rate = dot(d, ab);
        if rate < 0.0 {
            let det = dot(p, ab);
            s_safe = s_safe.min((det - floor.min(det)) / -rate);
        }
    }
    if waypoint == goal && s_safe > 1.0 && positive_fan(goal, &star.corners) {
        return Some(goal);
    }
    let mut s = (DRAG_FRACTION * s_safe).min(1.0);
    for _ in 0..DRAG_HALVINGS {
        let x = add(p, scale(d, s));
        if x == p {
            // The step rounds away (s is 0 where a face at the floor
            // blocks the way): every later halving rounds away too (each
            // coordinate's sum rounds to p's for a term no larger), so
            // each would make this same test. Made once, not up to thirty
            // times (the same answer; issue 23, speed, session 13).
            return normalize(x).filter(|&q| q != p && positive_fan(q, &star.corners));
        }
        if let Some(q) = normalize(x) {
            if q != p && positive_fan(q, &star.corners) {
                return Some(q);
            }
        }
        s *= 0.5;
    }
    None
}

/// Sets no map realises, found from the mesh alone: neighbours at opposite
/// points, faces of three landmarks not positively oriented.
fn conflicts(mesh: &GenusZeroMesh, landmarks: &Landmarks) -> Result<(), SphereError> {
    let n = mesh.n_vertices();
    let mut target: Vec<Option<[f64; 3]>> = vec![None; n];
    for (&i, &t) in landmarks.ids.iter().zip(&landmarks.targets) {
        target[i as usize] = Some(t);
    }
    for &[a, b, c] in mesh.faces() {
        let [ta, tb, tc] = [a, b, c].map(|v| target[v as usize]);
        for (u, tu, w, tw) in [(a, ta, b, tb), (b, tb, c, tc), (c, tc, a, ta)] {
            if let (Some(x), Some(y)) = (tu, tw) {
                // Normalisation is odd, so opposite directions are exact negatives.
                if x == scale(y, -1.0) {
                    return Err(SphereError::LandmarkConflict {
                        ids: vec![u.min(w) as usize, u.max(w) as usize],
                        reason: format!(
                            "neighbours {u} and {w} are asked to sit at opposite points; their \
                             edge would be half a great circle"
                        ),
                    });
                }
            }
        }
        if let (Some(x), Some(y), Some(z)) = (ta, tb, tc) {
            if det3_sign(x, y, z) != Sign::Positive {
                let mut ids = vec![a as usize, b as usize, c as usize];
                ids.sort_unstable();
                return Err(SphereError::LandmarkConflict {
                    ids,
                    reason: format!(
                        "the face ({a}, {b}, {c}) of three landmarks would be upside down or flat \
                         at their targets"
                    ),
                });
            }
        }
    }
    Ok(())
}

/// The vertices within `radius` rings of `v`, breadth first (a fixed order).
fn neighbourhood(rings: &[Vec<u32>], v: u32, radius: usize, seen: &mut [bool]) -> Vec<u32> {
    let mut region = vec![v];
    seen[v as usize] = true;
    let mut start = 0;
    for _ in 0..radius {
        let end = region.len();
        for k in start..end {
            for &r in &rings[region[k] as usize] {
                if !seen[r as usize] {
                    seen[r as usize] = true;
                    region.push(r);
                }
            }
        }
        start = end;
    }
    for &r in &region {
        seen[r as usize] = false;
    }
    region
}

/// Moves the landmarks of `points` (a valid map of `mesh`) onto their
/// targets exactly, through valid maps only, then lowers `params.energy`
/// with the landmarks held. `progress(0, 0)` is polled; `false` stops with
/// [`SphereError::Cancelled`].
///
/// # Errors
/// [`SphereError::InvalidStart`] for a start that is not a valid map;
/// [`SphereError::LandmarkConflict`] for a set no map realises or a drag
/// that stalls; bad parameters; cancellation.
pub fn pin_landmarks(
    mesh: &GenusZeroMesh,
    points: &[[f64; 3]],
    landmarks: &Landmarks,
    params: &PinParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<(SphereEmbedding, PinInfo), SphereError> {
    check_tolerance(params.tolerance)?;
    let n = mesh.n_vertices();
    if points.len() != n {
        return Err(SphereError::PointCount { points: points.len(), vertices: n });
    }
    if landmarks.ids.iter().any(|&i| i as usize >= n) {
        return Err(SphereError::BadLandmarks {
            ids: landmarks.ids.iter().filter(|&&i| i as usize >= n).map(|&i| i as usize).collect(),
            reason: format!("not vertices of the mesh (it has {n} vertices)"),
        });
    }
    require_valid_start(&check_sphere(mesh.faces(), points))?;
    conflicts(mesh, landmarks)?;
    let started = Instant::now();
    let total = 3 * landmarks.len().max(1);
    let cancelled = |done: usize| SphereError::Cancelled { stage: "landmarks", done, total };
    let go_on = || progress(0, 0);
    let mut points = points.to_vec();
    let mut info = PinInfo {
        flow_increments: 0,
        after_flow: 0.0,
        rounds: 0,
        local_relaxations: 0,
        global_relaxations: 0,
        sweeps: 0,
    };

    let rings = rings_of(mesh)?;
    let held = landmarks.mask(n);
    let problem = whole_mesh_problem(params.energy, mesh);
    let mut relax = |points: &mut [[f64; 3]]| {
        problem
            .optimise_holding(&rings, points, FLOW_SWEEPS, 0.0, Some(&held), &|_| !go_on())
            .map(|_| ())
    };
    info.flow_increments =
        sphere_flow::flow(mesh.faces(), &mut points, landmarks, &mut relax, &|| !go_on())
            .map_err(|_| cancelled(0))?;
    let left = |points: &[[f64; 3]]| -> Vec<f64> {
        landmarks
            .ids
            .iter()
            .zip(&landmarks.targets)
            .map(|(&i, &t)| angle(points[i as usize], t))
            .collect()
    };
    info.after_flow = left(&points).into_iter().fold(0.0, f64::max);
    progress(landmarks.len(), total);

    drag_all(&problem, &rings, &held, landmarks, &mut points, &mut info, &go_on)?;
    progress(2 * landmarks.len(), total);

    let end = problem
        .optimise_holding(
            &rings,
            &mut points,
            params.max_iter,
            params.tolerance,
            Some(&held),
            &|_| !go_on(),
        )
        .map_err(|_| cancelled(2 * landmarks.len()))?;
    info.sweeps = end.sweeps;
    progress(total, total);
    let message = format!(
        "{} landmarks pinned: a flow of {} certified increments left at most {:.3} degrees, \
         {} rounds of drags ({} local and {} global relaxations) placed them exactly, then {} \
         sweeps of the {} energy with them held, {:.4} per unit area",
        landmarks.len(),
        info.flow_increments,
        info.after_flow.to_degrees(),
        info.rounds,
        info.local_relaxations,
        info.global_relaxations,
        end.sweeps,
        params.energy.name(),
        end.energy
    );
    Ok((held_map(points, &end, message, started), info))
}

/// The map the landmark paths end with: the points after their final
/// sweeps with the landmarks held, timed as one "landmarks" stage.
fn held_map(
    points: Vec<[f64; 3]>,
    end: &Optimised,
    message: String,
    started: Instant,
) -> SphereEmbedding {
    let status = if end.converged { Status::Converged } else { Status::MaxIterations };
    SphereEmbedding {
        points,
        iterations: end.sweeps,
        status,
        message,
        seconds: vec![("landmarks", started.elapsed().as_secs_f64())],
    }
}

/// A landmark map on a refined mesh: the input's edges split by
/// [`path_layout`], the refined mesh (its first vertices are the input's),
/// and where each of its vertices lies on the input surface.
#[derive(Debug, Clone)]
pub struct Refined {
    pub mesh: GenusZeroMesh,
    pub layout: PathLayout,
}

/// [`pin_landmarks`], and where its drag stalls, the constructive layout of
/// [`path_layout`] on a refined mesh, then energy sweeps with the landmarks
/// held. A face of three landmarks upside down at their targets, which no
/// map of the mesh as given realises, goes to the layout directly: its
/// first splits take every edge between two landmarks apart (issue 23:
/// "either split edges and return the refined mesh ... or raise").
/// Neighbours at opposite points are still refused.
///
/// # Errors
/// Bad parameters, an invalid start, cancellation; a layout that failed
/// (see [`path_layout`]).
pub fn pin_or_lay_out(
    mesh: &GenusZeroMesh,
    points: &[[f64; 3]],
    landmarks: &Landmarks,
    params: &PinParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<(SphereEmbedding, Option<Refined>), SphereError> {
    let started = Instant::now();
    let why = match conflicts(mesh, landmarks) {
        // Neighbours at exactly opposite points stay refused: the set is
        // most likely a mistake, and T would need an edge through the centre.
        Err(conflict @ SphereError::LandmarkConflict { .. }) if opposite(&conflict) => {
            return Err(conflict)
        }
        Err(conflict) => format!("no map of the mesh as given realises them: {conflict}"),
        Ok(())
            if params.layout_when_scrambled
                && path_layout::out_of_order_count(points, landmarks) > DRAG_FIRST_OUT_OF_ORDER =>
        {
            "their cyclic order at the start differs from their targets' throughout".into()
        }
        Ok(()) => match pin_landmarks(mesh, points, landmarks, params, progress) {
            Ok((pinned, _)) => {
                // A drag can crush a face to nothing between landmarks pinned
                // close together (measured: 64 swirled landmarks on the
                // 112-vertex blub left a face at 0 of the mean); the layout
                // refines there instead.
                let floor = check_sphere(mesh.faces(), &pinned.points).min_area_ratio;
                if floor >= MIN_AREA_RATIO {
                    return Ok((pinned, None));
                }
                format!("the drag left a face at {floor:.1e} of the mean area")
            }
            Err(SphereError::LandmarkConflict { reason, .. }) => {
                format!("the drag stalled: {reason}")
            }
            Err(other) => return Err(other),
        },
    };
    let (mut embedding, refined) = lay_out(mesh, points, landmarks, params, progress)?;
    embedding.message = format!("{why}; {}", embedding.message);
    // The stage's time includes the drag that stalled.
    embedding.seconds = vec![("landmarks", started.elapsed().as_secs_f64())];
    Ok((embedding, Some(refined)))
}

/// Most landmarks out of order at the start for which the drag is still
/// tried before the layout. The drag's map is on the mesh as given and
/// better: registering corpus pairs with 8 landmark pairs (2-8 of them out
/// of order), the warp's mean / p95 error was 1.0% / 3.4% on human_man and
/// 1.1% / 2.9% on sword after a drag, 2.0% / 13.9% and 3.9% / 11.8% after
/// the layout. With 32 landmarks moved 45 degrees each its own way the drag
/// took 5-15 times the layout's time, or stalled after 40 times (horse).
pub const DRAG_FIRST_OUT_OF_ORDER: usize = 8;

/// The smallest face over the mean a pinned map must keep (issue 23).
const MIN_AREA_RATIO: f64 = 1e-12;

/// Whether a conflict of [`conflicts`] is two neighbours at opposite points.
fn opposite(conflict: &SphereError) -> bool {
    matches!(conflict, SphereError::LandmarkConflict { ids, .. } if ids.len() == 2)
}

/// The constructive layout alone ([`path_layout`]), certified, then
/// `params.max_iter` energy sweeps with the caller's landmarks held (the
/// auxiliary ones move freely).
///
/// # Errors
/// As [`path_layout`]; [`SphereError::InvalidStart`] if the layout's stored
/// doubles do not pass the exact test (rounding in a patch's solve).
pub fn lay_out(
    mesh: &GenusZeroMesh,
    points: &[[f64; 3]],
    landmarks: &Landmarks,
    params: &PinParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<(SphereEmbedding, Refined), SphereError> {
    check_tolerance(params.tolerance)?;
    let started = Instant::now();
    let go_on = || progress(0, 0);
    let cancelled = |done| SphereError::Cancelled { stage: "landmark layout", done, total: 2 };
    let rings = rings_of(mesh)?;
    let layout =
        path_layout(&rings, mesh.positions(), points, landmarks, params.max_vertices, &go_on)?;
    progress(1, 2);
    let positions = layout.positions(mesh.positions());
    let refined_mesh =
        Mesh::new(positions, layout.faces.clone()).map_err(|e| SphereError::LandmarkConflict {
            ids: vec![],
            reason: format!("the path layout's refined mesh is not valid: {e}"),
        })?;
    let refined = GenusZeroMesh::new(refined_mesh)?;
    if refined.reoriented_faces() != 0 || refined.faces() != layout.faces.as_slice() {
        return Err(SphereError::LandmarkConflict {
            ids: vec![],
            reason: "the path layout's refined mesh came back reoriented".into(),
        });
    }
    let mut points = layout.points.clone();
    require_valid_start(&check_sphere(refined.faces(), &points))?;
    let n = refined.n_vertices();
    let held = landmarks.mask(n);
    let rings = rings_of(&refined)?;
    let problem = whole_mesh_problem(params.energy, &refined);
    let end = problem
        .optimise_holding(
            &rings,
            &mut points,
            params.max_iter,
            params.tolerance,
            Some(&held),
            &|_| !go_on(),
        )
        .map_err(|_| cancelled(1))?;
    progress(2, 2);
    let message = format!(
        "{} landmarks laid out by paths ({} auxiliary, {} patches, {} vertices added by edge \
         splits), then {} sweeps of the {} energy with them held, {:.4} per unit area",
        landmarks.len(),
        layout.auxiliary.len(),
        layout.patches,
        n - mesh.n_vertices(),
        end.sweeps,
        params.energy.name(),
        end.energy
    );
    Ok((held_map(points, &end, message, started), Refined { mesh: refined, layout }))
}

/// Step 2 and 3 of the module documentation: rounds of drags, with local
/// and then global relaxations where they block, until every landmark sits
/// on its target, or the bounded work is spent.
fn drag_all(
    problem: &Problem<'_>,
    rings: &[Vec<u32>],
    held: &[bool],
    landmarks: &Landmarks,
    points: &mut [[f64; 3]],
    info: &mut PinInfo,
    go_on: &(dyn Fn() -> bool + Sync),
) -> Result<(), SphereError> {
    let total = 3 * landmarks.len().max(1);
    let cancelled = || SphereError::Cancelled { stage: "landmarks", done: landmarks.len(), total };
    let mut k_scale: Option<f64> = None;
    let mut radius = vec![0usize; landmarks.len()];
    let mut seen = vec![false; points.len()];
    let mut best = f64::INFINITY;
    let mut stalled = 0usize;
    for round in 0..MAX_ROUNDS {
        if !go_on() {
            return Err(cancelled());
        }
        info.rounds = round + 1;
        let mut blocked = Vec::new();
        for (j, (&v, &t)) in landmarks.ids.iter().zip(&landmarks.targets).enumerate() {
            let ring = &rings[v as usize];
            let mut moved = false;
            for _ in 0..STEPS_PER_ROUND {
                if points[v as usize] == t {
                    break;
                }
                match drag(points[v as usize], t, ring, points) {
                    Some(q) => {
                        points[v as usize] = q;
                        moved = true;
                    }
                    None => break,
                }
            }
            if points[v as usize] != t {
                // Relax wider each round the landmark stays short of its target
                // without moving; a landmark that moves starts small again.
                radius[j] = if moved { 1 } else { (2 * radius[j]).clamp(1, MAX_RADIUS) };
                blocked.push(j);
            }
        }
        if blocked.is_empty() {
            return Ok(());
        }
        let remaining: f64 = blocked
            .iter()
            .map(|&j| angle(points[landmarks.ids[j] as usize], landmarks.targets[j]))
            .sum();
        if remaining < best * (1.0 - GAIN) {
            best = remaining;
            stalled = 0;
        } else {
            stalled += 1;
        }
        if stalled >= STALL_ROUNDS {
            return Err(stall(landmarks, &blocked, points, round + 1));
        }
        let k = *k_scale.get_or_insert_with(|| problem.area_scale(&problem.stars(rings), points));
        for &j in &blocked {
            let v = landmarks.ids[j];
            carry(rings, held, v, landmarks.targets[j], points, &mut seen);
            let region = neighbourhood(rings, v, radius[j], &mut seen);
            info.local_relaxations += 1;
            for _ in 0..LOCAL_PASSES {
                for &i in region.iter().filter(|&&i| !held[i as usize]) {
                    if let Some(q) = problem.move_vertex(k, i, &rings[i as usize], points) {
                        points[i as usize] = q;
                    }
                }
            }
        }
        // A blocked landmark is most often held by triangles piled up farther
        // away than its neighbourhood: every other round relaxes everything.
        if round % 2 == 1 {
            info.global_relaxations += 1;
            let end = problem
                .optimise_holding(rings, points, GLOBAL_SWEEPS, 0.0, Some(held), &|_| !go_on())
                .map_err(|_| cancelled())?;
            k_scale = Some(end.scale);
        }
    }
    let blocked: Vec<usize> = (0..landmarks.len())
        .filter(|&j| points[landmarks.ids[j] as usize] != landmarks.targets[j])
        .collect();
    Err(stall(landmarks, &blocked, points, MAX_ROUNDS))
}

/// Rings carried along with a blocked landmark, and the width of the
/// carry's falloff in its mean edge lengths.
const CARRY_RADIUS: usize = 6;
const CARRY_WIDTH: f64 = 3.0;

/// Carries the patch around a blocked landmark `v` a step towards `target`:
/// each free vertex of the patch aims at its point turned about the
/// landmark's axis of motion by the step times a Gaussian falloff of its
/// distance to the landmark, and is dragged there flip-free, the vertices
/// farthest ahead first so that they make room for those behind. The
/// energy relaxation alone balances the ring around the landmark where it
/// stands, and a drag blocked by a ring that does not follow stays blocked
/// (measured: 8 landmarks on a 162-vertex `bumpy` stalled 11 degrees short).
fn carry(
    rings: &[Vec<u32>],
    held: &[bool],
    v: u32,
    target: [f64; 3],
    points: &mut [[f64; 3]],
    seen: &mut [bool],
) {
    let p = points[v as usize];
    let Some(axis) = normalize(cross(p, target)) else {
        return;
    };
    let ring = &rings[v as usize];
    let edge =
        ring.iter().map(|&r| angle(p, points[r as usize])).sum::<f64>() / ring.len().max(1) as f64;
    let step = angle(p, target).min(edge);
    let width = CARRY_WIDTH * edge;
    if !(step > 0.0 && width > 0.0) {
        return;
    }
    let ahead = cross(axis, p);
    let mut region: Vec<u32> = neighbourhood(rings, v, CARRY_RADIUS, seen)
        .into_iter()
        .filter(|&u| !held[u as usize])
        .collect();
    // Farthest ahead first; ties by id, so the order is fixed.
    region.sort_by(|&a, &b| {
        let (da, db) = (dot(points[a as usize], ahead), dot(points[b as usize], ahead));
        db.total_cmp(&da).then(a.cmp(&b))
    });
    for u in region {
        let x = points[u as usize];
        let d = angle(x, p) / width;
        let turn = step * (-d * d).exp();
        let goal = rotate(x, axis, turn);
        if let Some(q) = drag(x, goal, &rings[u as usize], points) {
            points[u as usize] = q;
        }
    }
}

/// `x` turned by `angle` about the unit `axis` (Rodrigues' formula).
fn rotate(x: [f64; 3], axis: [f64; 3], angle: f64) -> [f64; 3] {
    let (s, c) = angle.sin_cos();
    let turned =
        add(add(scale(x, c), scale(cross(axis, x), s)), scale(axis, dot(axis, x) * (1.0 - c)));
    normalize(turned).unwrap_or(x)
}

/// The error of a drag that stopped gaining: the landmarks still away from
/// their targets, and how far.
fn stall(
    landmarks: &Landmarks,
    blocked: &[usize],
    points: &[[f64; 3]],
    rounds: usize,
) -> SphereError {
    let mut ids: Vec<usize> = blocked.iter().map(|&j| landmarks.ids[j] as usize).collect();
    ids.sort_unstable();
    let far = blocked
        .iter()
        .map(|&j| angle(points[landmarks.ids[j] as usize], landmarks.targets[j]))
        .fold(0.0, f64::max);
    SphereError::LandmarkConflict {
        ids,
        reason: format!(
            "the flip-free drag stopped gaining after {rounds} rounds, up to {:.3e} degrees short; \
             their targets likely cross each other or other landmarks' order",
            far.to_degrees()
        ),
    }
}

#[cfg(test)]
mod tests;
