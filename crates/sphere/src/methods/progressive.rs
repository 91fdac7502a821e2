//! The progressive method (thesis 9.3.3, after Praun and Hoppe 2003): a
//! sphere map that keeps every triangle's area in proportion, so that long
//! limbs and spikes never need more digits than a double has, and that is
//! bijective as stored because every step is decided by exact predicates.
//!
//! 1. [`hierarchy`]: collapse the mesh to a tetrahedron in rounds of
//!    independent half-edge collapses, flat regions first.
//! 2. Map the tetrahedron onto a regular tetrahedron on the sphere.
//! 3. Undo the rounds, last first; each re-inserted vertex goes to the
//!    Chebyshev centre of its ring's kernel ([`placement`]), and every new
//!    face is tested exactly. When the kernel is too thin for doubles the
//!    neighbourhood is moved (flip-free) and the vertex tried again; if that
//!    fails the method stops with an error naming the vertex. Then each new
//!    vertex takes one flip-free move towards lower energy.
//! 4. Whenever the mesh has grown by [`LEVEL_GROWTH`], and at the end, lower
//!    the distortion [`Energy`] with flip-free moves ([`crate::methods::progressive::flip_free`]).
//!    For the stretch and balanced energies, global L-BFGS steps over every
//!    vertex follow the sweeps of the coarse levels up to 30k vertices and the
//!    final sweeps ([`mod@crate::methods::progressive::lbfgs`]): the sweeps stall on
//!    tubes and nearly round meshes (the final ones are left out on large
//!    limbed balanced maps, where they bought nothing measurable).
//!    For the authalic energy, global steps towards equal areas follow
//!    ([`mod@crate::methods::progressive::authalic_newton`]): the local moves alone stall on limbs.
//!
//! For the conformal energy, a certified global conformal map (or the radial
//! projection from the vertex mean, where that is certified too and lower in
//! conformal energy) replaces steps 1-3 where no face of it lies inside the
//! energy's barrier ([`conformal`]); otherwise the method runs as above.
//!
//! Every state the method passes through is a valid GC-embedding of the
//! current mesh: the tetrahedron is one, an insertion into the kernel keeps
//! one (the new faces tile the old fan), and a move keeps one (all faces stay
//! positive along the straight path, so the covering degree cannot jump).

pub mod authalic_newton;
pub mod chord_area;
mod conformal;
pub mod conformal_start;
pub mod distortion_energy;
pub mod flip_free;
mod hierarchy;
pub mod improve;
pub mod landmarks;
pub mod lbfgs;
mod level_mesh;
pub mod mobius_centring;
pub mod move_towards;
mod placement;
mod ring_mesh;
mod star_lanes;
pub mod target_pull;

use std::sync::Arc;
use std::time::Instant;

use rayon::prelude::*;
use spherify_mesh::predicates::{det3_sign, Sign};
use spherify_mesh::vec3::triangle_area;

use crate::certificate::validity::{check_sphere, SphereReport};
use crate::embedding::{normalize, SphereEmbedding, Status};
use crate::error::SphereError;
use crate::genus_zero::{GenusZeroMesh, Neighbourhoods};
use crate::memory_budget::filled;
use crate::methods::progressive::authalic_newton::{
    authalic_newton, authalic_newton_rings, AuthalicSteps,
};
use crate::methods::progressive::distortion_energy::{balanced_area_weight, Energy};
use crate::methods::progressive::flip_free::{
    check_tolerance, colour_flat, flat_rings, positive_star, Optimised, Problem,
};
use crate::methods::progressive::lbfgs::{lbfgs, LbfgsParams, LbfgsRun};
use conformal::NotUsed;
use hierarchy::Hierarchy;
use level_mesh::LevelMesh;
use ring_mesh::{Collapse, RingMesh};

/// Optimise the current level when it has grown by this factor since the last time.
pub const LEVEL_GROWTH: f64 = 2.0;
/// Vertex moves spent on a level: coarse levels, where limbs win or lose
/// their share of the sphere, get many sweeps (measured on 20k-vertex
/// `tentacles`: L2 stretch 24.6 with two sweeps per level, 3.4 with this).
const LEVEL_MOVES: usize = 100_000;
/// Fewest and most sweeps over a level.
const LEVEL_SWEEPS: usize = 2;
const MAX_LEVEL_SWEEPS: usize = 100;
/// Global authalic steps ([`crate::methods::progressive::authalic_newton`]) on each level of at
/// least [`AUTHALIC_LEVEL_MIN`] vertices, so that limbs get their area while
/// the mesh is coarse and a step is cheap (measured with 15 final steps,
/// mean |log area ratio| on chord triangles without and with these: human_man
/// 0.058 and 0.036, scorpion 0.347 and 0.154; mean angle distortion 43.7 and
/// 40.0, 51.3 and 52.2 degrees).
const AUTHALIC_LEVEL_STEPS: usize = 10;
const AUTHALIC_LEVEL_MIN: usize = 64;
/// Most global authalic steps at the end: [`AUTHALIC_FINAL_WORK`] face-steps,
/// within these bounds (small meshes converge slowly, and their steps are cheap).
const AUTHALIC_FINAL_STEPS: (usize, usize) = (15, 100);
const AUTHALIC_FINAL_WORK: usize = 100_000;
/// Most global L-BFGS steps ([`lbfgs`]) after the final sweeps of the
/// stretch and balanced energies, and the relative fall of the energy in a
/// step below which they stop. Measured on horse (balanced, weight 0.1):
/// 100 steps took L2 stretch from 1.602 to 1.564 (SphereParam 1.587); 50
/// steps after 5 sweeps instead of 20 only to 1.590.
const GLOBAL_STEPS: usize = 100;
const GLOBAL_TOLERANCE: f64 = 1e-7;
/// The final global steps: all [`GLOBAL_STEPS`] up to [`GLOBAL_FULL_SIZE`]
/// vertices, then fewer as the square of the size grows, at least
/// [`GLOBAL_MIN_STEPS`] (13 at 134k, 10 at 200k). On large meshes a step
/// costs about a sweep and buys little once the coarse levels had theirs
/// (issue 22, measured on 200k-vertex `helix_tube`, balanced: 100 steps took
/// L2 stretch from 3.7128 to 3.7023 in 22 of the map's 45 s); nearly round
/// meshes stop after 5-10 steps by the tolerance anyway. Horse (48k) needs
/// its hundred: with 41 its angle distortion was 30.30 degrees, above 1.1
/// times SphereParam's 27.41; with 100, 29.25.
const GLOBAL_FULL_SIZE: usize = 50_000;
const GLOBAL_MIN_STEPS: usize = 10;
/// Above [`GLOBAL_FULL_SIZE`] vertices, a balanced map whose stretch density
/// S (see [`balanced_area_weight`]) is above this, a limbed shape, takes no
/// final global steps: there the ten steps bought nothing its twenty sweeps
/// had not (issue 22, measured at 200k vertices with and without them, L2
/// stretch / area: `helix_tube` 3.6399 / 0.7580 and 3.6421 / 0.7581,
/// `tentacles` 2.7848 / 0.7430 and 2.7893 / 0.7431) for a quarter to a
/// third of the map's time. Nearly round meshes (S about 1.0-1.1) keep them:
/// without them 200k `bumpy_blob`'s angle distortion was 3.26 degrees
/// instead of 2.82 (SphereParam 2.8).
const GLOBAL_SKIP_STRETCH: f64 = 4.0;
/// On the same large limbed balanced maps, a vertex wakes itself and its
/// neighbours for the next final sweep only by moving more than this
/// fraction of its shortest edge (elsewhere [`flip_free::NOTICEABLE`],
/// 1e-3, which kept nearly every vertex moving in every sweep), and the
/// final sweeps are [`LIMBED_EXTRA_SWEEPS`] more: the later sweeps then move
/// only where the map still changes (issue 22, 200k `helix_tube`, L2 stretch
/// / area / CPU s in one process: 16 sweeps as before 3.647 / 0.7698 /
/// 8.31; wake 0.05 and 16 sweeps 3.648 / 0.7700 / 7.55; 0.1 and 18 sweeps
/// 3.638 / 0.7669 / 7.53).
const LIMBED_WAKE: f64 = 0.1;
const LIMBED_EXTRA_SWEEPS: usize = 2;
/// Global steps on each coarse level of the stretch and balanced energies
/// with this many vertices, after its sweeps: there limbs win or lose their
/// share of the sphere (measured with the weight 0.1, L2 stretch without and
/// with them: knight 1.7925 / 1.7855, hand 1.4397 / 1.4270, octopus 2.5668
/// / 2.5393). Levels above 30k vertices are left to the final steps, for time.
/// A hundred steps rather than thirty, now that a level's steps cost its own
/// size (see [`optimise_level`]): on 200k-vertex `helix_tube` (balanced, 20
/// final sweeps, no final global steps) L2 stretch 3.713 with 30 and 3.635
/// with 100, area 0.783 and 0.776; 20k `tentacles` 3.022 and 2.974.
const LEVEL_GLOBAL_STEPS: LbfgsParams = LbfgsParams { max_iter: 100, tolerance: 1e-6 };
const LEVEL_GLOBAL_SIZES: (usize, usize) = (64, 30_000);
/// Levels of at least this many vertices hand the allocator's free pages
/// back before they are copied ([`optimise_level`]); below, the call
/// (milliseconds) is not worth it.
const TRIM_FROM_LEVEL: usize = 1 << 18;
/// Rounds of moving a failed vertex's neighbourhood before giving up on it.
const INSERTION_RETRIES: usize = 4;

#[derive(Debug, Clone, PartialEq)]
pub struct ProgressiveParams {
    pub energy: Energy,
    /// Most sweeps of the final optimisation.
    pub max_iter: usize,
    /// The final optimisation stops when a sweep lowers the energy by less
    /// than this fraction.
    pub tolerance: f64,
}

impl Default for ProgressiveParams {
    fn default() -> Self {
        ProgressiveParams::for_energy(Energy::Isometric)
    }
}

impl ProgressiveParams {
    /// The defaults for `energy`. Isometric: five final sweeps to a relative
    /// change of 1e-3; with each new vertex already moved once, more sweeps
    /// barely change it (measured on 200k-vertex `tentacles`: 41.7 against
    /// 43.3 degrees of mean angle distortion, L2 stretch 3.68 against 3.60
    /// with ten). Authalic: ten, as area keeps improving a little longer.
    /// The stretch and conformal energies keep improving in small steps, and
    /// people choose them for the last bit of sampling quality or angle: fifty
    /// and a hundred sweeps to 1e-5 (measured on the corpus: octopus 2.646 ->
    /// 2.599, spot 1.185 -> 1.177 in L2 stretch; spot 5.7 -> 3.8 and hand
    /// 14.3 -> 11.8 degrees of mean angle distortion). Balanced (the best
    /// quality; not the default, as it takes 2.5-3.5 times the isometric
    /// energy's time at 200k vertices, issue 22 allows 1.5): sixteen to
    /// 1e-4 (two more on large limbed meshes, see `LIMBED_WAKE`), as final
    /// sweeps are what bring its stretch
    /// to SphereParam's (measured on ten corpus meshes, five sweeps to 1e-3
    /// against twenty: stretch worse than SphereParam's on 10 and 6,
    /// area on 8 and 5; sword 2.732 and 2.696, octopus 2.816 and 2.613).
    /// Sixteen rather than twenty since its moves are over-relaxed
    /// ([`flip_free`]'s `OVER_RELAXATION`): 200k `helix_tube` L2 stretch /
    /// area 3.662 / 0.7746 with fourteen, 3.640 / 0.7580 with twenty
    /// unrelaxed (SphereParam 3.701 / 0.7755).
    pub fn for_energy(energy: Energy) -> ProgressiveParams {
        match energy {
            Energy::Stretch | Energy::CoarseStretch => {
                ProgressiveParams { energy, max_iter: 50, tolerance: 1e-5 }
            }
            Energy::Balanced | Energy::BalancedWeighted(_) | Energy::CoarseBalanced => {
                ProgressiveParams { energy, max_iter: 16, tolerance: 1e-4 }
            }
            Energy::Conformal => ProgressiveParams { energy, max_iter: 100, tolerance: 1e-5 },
            Energy::Authalic => ProgressiveParams { energy, max_iter: 10, tolerance: 1e-3 },
            Energy::Isometric => ProgressiveParams { energy, max_iter: 5, tolerance: 1e-3 },
        }
    }
}

/// Maps `mesh` onto the sphere with the progressive method.
///
/// `progress(done, total)` hears after every round of the hierarchy, every
/// round of insertion and every sweep; returning `false` stops the method
/// with [`SphereError::Cancelled`].
///
/// # Errors
/// [`SphereError::InvalidParameter`] for a negative or non-finite tolerance;
/// [`SphereError::Insertion`] when a vertex finds no place in double precision;
/// [`SphereError::Cancelled`].
pub fn progressive(
    mesh: &GenusZeroMesh,
    params: &ProgressiveParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<SphereEmbedding, SphereError> {
    check_tolerance(params.tolerance)?;
    let mut not_used = None;
    if params.energy == Energy::Conformal {
        match conformal::from_conformal_start(mesh, params, progress)? {
            Ok(map) => return Ok(map),
            Err(why) => not_used = Some(why),
        }
    }
    let n = mesh.n_vertices();
    let total = 3 * n;
    let positions = mesh.positions();
    let cancelled =
        |stage: &'static str, done: usize| SphereError::Cancelled { stage, done, total };
    let mut seconds = Vec::new();
    if let Some(why) = &not_used {
        seconds.push(("conformal start", why.seconds));
    }

    let started = Instant::now();
    let mut rings = RingMesh::for_collapses(n, mesh.faces())?;
    // progress(0, 0) only asks whether to go on; the other calls report.
    let go_on = || progress(0, 0);
    let mut hierarchy = hierarchy::decimate(&mut rings, positions, &mut |removed| {
        go_on() && progress(removed, total)
    })
    .ok_or_else(|| cancelled("hierarchy", n - rings.n_alive))?;
    seconds.push(("hierarchy", started.elapsed().as_secs_f64()));

    let started = Instant::now();
    let mut points = filled(n, [0.0; 3], "the progressive method's points")?;
    place_tetrahedron(&rings, &mut points);
    let problem = whole_mesh_problem(params.energy, mesh);
    insert_levels(
        &mut hierarchy,
        &problem,
        params,
        mesh.faces(),
        &mut rings,
        &mut points,
        progress,
    )?;
    seconds.push(("insertion", started.elapsed().as_secs_f64()));
    // The balanced energy's final area weight, from the stretch of the map
    // as inserted (see balanced_area_weight).
    let (problem, stretch_density) = if params.energy == Energy::Balanced {
        let stretch = Problem { energy: Energy::Stretch, ..problem };
        let s = stretch.per_area(&stretch.stars(&rings.rings), &points);
        (Problem { energy: Energy::BalancedWeighted(balanced_area_weight(s)), ..problem }, s)
    } else {
        (problem, 1.0)
    };

    let started = Instant::now();
    // The hierarchy has been undone: only its size is told from here on.
    let undone = (hierarchy.collapses.len(), hierarchy.rounds.len());
    drop(hierarchy);
    let max_iter = params.max_iter.max(1);
    let stop = |sweep: usize| !(go_on() && progress(2 * n + n * sweep / max_iter, total));
    let global_params = global_steps(params.energy, n, stretch_density);
    let (start, flat) = flat_rings(&rings.rings);
    // The final sweeps' colouring (serial) reads only the flat rings: it
    // runs beside the rings' release and the trim (serial too; issue 27,
    // 0.08 s at 1M vertices), where it ran beside the first energy sums.
    let (classes, rings) = rayon::join(
        || colour_flat(&start, &flat),
        || {
            // Only the global steps read the rings again; without them they
            // are let go before the references, the method's largest
            // buffer, are made.
            let rings = global_params.map(|_| rings);
            // The freed rings and hierarchy (a million small blocks at 1M
            // vertices) stay resident in the allocator's arenas unless handed
            // back: measured on the 1M helix tube, about 110 bytes per vertex
            // of the peak that the references below set.
            spherify_sparse::release_free_memory();
            rings
        },
    );
    let stars = problem.stars_of(start, flat);
    let (wake, sweeps) = final_sweeps(params, n, stretch_density);
    let end = problem
        .optimise_coloured(
            &stars,
            classes,
            &mut points,
            (sweeps, params.tolerance),
            None,
            wake,
            &stop,
        )
        .map_err(|_| cancelled("optimisation", 2 * n))?;
    drop(stars);
    seconds.push(("optimisation", started.elapsed().as_secs_f64()));
    let mut global: Option<LbfgsRun> = None;
    if let (Some(steps), Some(rings)) = (global_params, &rings) {
        let started = Instant::now();
        let run = lbfgs(&problem, &rings.rings, &mut points, &steps, &|| !go_on())
            .map_err(|_| cancelled("optimisation", 2 * n))?;
        global = Some(run);
        seconds.push(("global steps", started.elapsed().as_secs_f64()));
    }
    let mut authalic: Option<AuthalicSteps> = None;
    if params.energy == Energy::Authalic {
        let started = Instant::now();
        let steps = (AUTHALIC_FINAL_WORK / mesh.n_faces().max(1))
            .clamp(AUTHALIC_FINAL_STEPS.0, AUTHALIC_FINAL_STEPS.1);
        let floor = problem.area_floor;
        let run = authalic_newton(mesh.faces(), positions, floor, &mut points, steps, &|| !go_on())
            .map_err(|_| cancelled("optimisation", 2 * n))?;
        authalic = Some(run);
        seconds.push(("authalic steps", started.elapsed().as_secs_f64()));
    }
    progress(total, total);

    let status = if end.converged { Status::Converged } else { Status::MaxIterations };
    let message = message(undone, problem.energy, &end, global, authalic, not_used);
    Ok(SphereEmbedding { points, iterations: end.sweeps, status, message, seconds })
}

/// Steps 3 and 4 up to the finest level: undoes the rounds of `hierarchy`,
/// last first ([`insert_round`]), moves each new vertex once, and lowers the
/// energy whenever the mesh has grown by [`LEVEL_GROWTH`] ([`optimise_level`]).
/// The collapses undone give their rings to `rings`: only the rounds not yet
/// undone keep theirs (what [`Hierarchy::represented_area`] reads).
fn insert_levels(
    hierarchy: &mut Hierarchy,
    problem: &Problem<'_>,
    params: &ProgressiveParams,
    faces: &[[u32; 3]],
    rings: &mut RingMesh,
    points: &mut [[f64; 3]],
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<(), SphereError> {
    let n = points.len();
    let total = 3 * n;
    let go_on = || progress(0, 0);
    let mut optimised_at = 4usize;
    // The last level's area floor, represented areas and area scale, for
    // the moves of new vertices.
    let mut level: Option<Level> = None;
    let mut inserted = 0usize;
    // The alive vertices in ascending order as of the last level, those
    // inserted since, and each level's local numbers ([`LevelMesh`]).
    let mut alive: Vec<u32> = (0..n as u32).filter(|&v| rings.is_alive(v)).collect();
    let mut fresh: Vec<u32> = Vec::new();
    let mut local = filled(n, 0u32, "the progressive method's level numbers")?;
    for round in hierarchy.rounds.clone().into_iter().rev() {
        let collapses = &mut hierarchy.collapses[round.clone()];
        let order = by_vertex(collapses);
        let level_problem = level.as_ref().map(|level| (level.problem(problem), level.scale));
        insert_round(
            collapses,
            &order,
            problem,
            level_problem.as_ref().map(|(p, k)| (p, *k)),
            rings,
            points,
        )?;
        // In ascending order within the round (`order`): the levels' sort
        // below then merges a few runs instead of sorting at random.
        fresh.extend(order.iter().map(|&j| collapses[j as usize].u));
        inserted += collapses.len();
        let done = n + inserted;
        if !(go_on() && progress(done, total)) {
            return Err(SphereError::Cancelled { stage: "insertion", done, total });
        }
        if rings.n_alive as f64 >= LEVEL_GROWTH * optimised_at as f64 && rings.n_alive < n {
            optimised_at = rings.n_alive;
            let level_done = || SphereError::Cancelled { stage: "insertion", done, total };
            let represented = if matches!(params.energy, Energy::Stretch | Energy::Balanced) {
                Some(hierarchy.represented_area(round.start, &rings.rings, problem.surface, faces))
            } else {
                None
            };
            // Ascending runs, one per round: the stable sort merges them
            // (issue 27: the unstable sort of 354k new vertices on 1M-vertex
            // `tentacles` was a serial 20 ms), and the same with `alive`.
            fresh.sort();
            alive.append(&mut fresh);
            alive.sort();
            level = Some(optimise_level(
                problem,
                params,
                rings,
                (&alive, &mut local),
                represented,
                points,
                &go_on,
                level_done,
            )?);
        }
    }
    Ok(())
}

/// What a coarse level's optimisation leaves for the moves of the vertices
/// inserted after it: its problem's area floor and represented areas, and
/// its area scale.
struct Level {
    area_floor: f64,
    represented: Option<Vec<f64>>,
    scale: f64,
}

impl Level {
    fn problem<'p>(&'p self, problem: &Problem<'p>) -> Problem<'p> {
        Problem {
            energy: problem.energy.on_coarse_levels(),
            surface: problem.surface,
            area_floor: self.area_floor,
            represented: self.represented.as_deref(),
            pull: None,
        }
    }
}

/// Undoes one round of collapses, last collapse first, each vertex at the
/// centre of its ring's kernel, or, when that kernel is too thin, after its
/// neighbourhood has moved ([`retry_placement`]); then, when `moves` gives a
/// coarse level's problem and area scale, moves each new vertex once
/// ([`new_vertex_moves`]). The collapses' rings move into `rings` (see
/// [`RingMesh::undo_taking`]).
///
/// When every vertex of the round found its place (nearly always), the
/// round's edits of its neighbours' lists, a serial loop over vertices all
/// over the mesh, run beside the parallel moves of the new vertices instead
/// of before them: a move reads only its vertex's ring (the collapse's, which
/// the edits do not change) and the points, which the edits do not touch.
/// Same results as one after the other.
fn insert_round(
    collapses: &mut [Collapse],
    order: &[u32],
    problem: &Problem<'_>,
    moves: Option<(&Problem<'_>, f64)>,
    rings: &mut RingMesh,
    points: &mut [[f64; 3]],
) -> Result<(), SphereError> {
    let shared: &[[f64; 3]] = points;
    let in_order: &[Collapse] = collapses;
    let found: Vec<Option<[f64; 3]>> = order
        .par_iter()
        .enumerate()
        .with_min_len(64)
        .map_init(placement::Scratch::default, |scratch, (x, &j)| {
            prefetch_round_ahead(in_order, order, x, shared, None);
            placement::place_with(&in_order[j as usize].ring, shared, scratch)
        })
        .collect();
    if found.iter().all(Option::is_some) {
        for (&j, q) in order.iter().zip(found) {
            if let Some(q) = q {
                points[collapses[j as usize].u as usize] = q;
            }
        }
        let shared: &[[f64; 3]] = points;
        let in_place: &[Collapse] = collapses;
        let (moved, ()) = rayon::join(
            || {
                moves.map(|(level, k)| {
                    new_vertex_moves(
                        order,
                        |x, j| {
                            prefetch_round_ahead(in_place, order, x, shared, Some(level));
                            (in_place[j as usize].u, in_place[j as usize].ring.as_slice())
                        },
                        level,
                        k,
                        shared,
                    )
                })
            },
            || {
                for j in (0..in_place.len()).rev() {
                    prefetch_undo_ahead(rings, in_place, j);
                    rings.undo_around(&in_place[j]);
                }
            },
        );
        for &j in order {
            let c = &mut collapses[j as usize];
            rings.rings[c.u as usize] = std::mem::take(&mut c.ring);
        }
        if let Some(moved) = moved {
            apply_moves(collapses, order, moved, points);
        }
        return Ok(());
    }
    let mut placed = vec![None; collapses.len()];
    for (&j, q) in order.iter().zip(found) {
        placed[j as usize] = q;
    }
    // Undo the round last collapse first. A retry moves vertices, which
    // may spoil the places found for the rest of the round: after one,
    // each place is tested again before it is used.
    let mut moved = false;
    // The area scale for retries, measured once per round when needed.
    let mut retry_scale: Option<f64> = None;
    for (j, q) in placed.into_iter().enumerate().rev() {
        prefetch_undo_ahead(rings, collapses, j);
        let c = &mut collapses[j];
        let q = match q {
            Some(q) if !moved || positive_star(q, &c.ring, points) => Some(q),
            _ if moved => placement::place(&c.ring, points),
            _ => None,
        };
        let q = match q {
            Some(q) => q,
            None => {
                moved = true;
                let k = *retry_scale.get_or_insert_with(|| {
                    problem.area_scale(&problem.stars(&rings.rings), points)
                });
                retry_placement(problem, k, rings, points, c).ok_or(SphereError::Insertion {
                    vertex: c.u as usize,
                    neighbours: c.ring.len(),
                })?
            }
        };
        insert(rings, points, c, q);
    }
    if let Some((level, k)) = moves {
        let taken: &RingMesh = rings;
        let moved = new_vertex_moves(
            order,
            |_, j| {
                (collapses[j as usize].u, taken.rings[collapses[j as usize].u as usize].as_slice())
            },
            level,
            k,
            points,
        );
        apply_moves(collapses, order, moved, points);
    }
    Ok(())
}

/// Asks for the memory of the collapses a few places before `j` in the undo
/// loop, which goes last first ([`RingMesh::prefetch_undo`]).
fn prefetch_undo_ahead(rings: &RingMesh, collapses: &[Collapse], j: usize) {
    for (stage, ahead) in
        [ring_mesh::AHEAD, ring_mesh::AHEAD / 2, ring_mesh::AHEAD / 4].into_iter().enumerate()
    {
        if let Some(i) = j.checked_sub(ahead) {
            rings.prefetch_undo(&collapses[i], stage as u8);
        }
    }
}

/// Each new vertex moves once from its kernel's centre towards lower energy
/// (measured on 200k-vertex `bumpy_blob`: 4 final sweeps instead of 9, 3.6
/// degrees of angle distortion instead of 4.3): the new points, in `order`.
/// No two share a face, so they move in parallel. `ring_of(j)` is the
/// removed vertex of collapse `j` and its ring, the one it was collapsed
/// with (no neighbour of it was re-inserted in the same round).
fn new_vertex_moves<'r>(
    order: &[u32],
    ring_of: impl Fn(usize, u32) -> (u32, &'r [u32]) + Sync,
    level: &Problem<'_>,
    k: f64,
    points: &[[f64; 3]],
) -> Vec<Option<[f64; 3]>> {
    order
        .par_iter()
        .enumerate()
        .with_min_len(64)
        .map_init(
            || (Vec::new(), Vec::new()),
            |(refs, corners), (x, &j)| {
                let (u, ring) = ring_of(x, j);
                level.move_vertex_with(k, u, ring, points, refs, corners)
            },
        )
        .collect()
}

/// Places ahead in a round's `order` whose memory the placements and the
/// moves of new vertices ask for early: the collapse [`ROUND_AHEAD`] places
/// on, its ring (a block of memory anywhere) half as far, and the ring's
/// points (and, for a move, `level`'s surface positions and represented
/// areas) a quarter as far, each stage reading what the one before fetched.
/// Only a hint: it changes no result.
fn prefetch_round_ahead(
    collapses: &[Collapse],
    order: &[u32],
    x: usize,
    points: &[[f64; 3]],
    level: Option<&Problem<'_>>,
) {
    if let Some(&j) = order.get(x + ROUND_AHEAD) {
        ring_mesh::prefetch(&collapses[j as usize]);
    }
    if let Some(&j) = order.get(x + ROUND_AHEAD / 2) {
        ring_mesh::prefetch(collapses[j as usize].ring.as_ptr());
    }
    if let Some(&j) = order.get(x + ROUND_AHEAD / 4) {
        for &r in &collapses[j as usize].ring {
            ring_mesh::prefetch(&points[r as usize]);
            if let Some(level) = level {
                ring_mesh::prefetch(&level.surface[r as usize]);
                if let Some(rho) = level.represented {
                    ring_mesh::prefetch(&rho[r as usize]);
                }
            }
        }
    }
}

/// How far ahead in a round's order [`prefetch_round_ahead`] asks for memory
/// (1M-vertex `tentacles`, one thread, process CPU time: the placements 0.70
/// s without, 0.51 s with; the moves of new vertices beside the ring edits
/// 0.76 and 0.56 s).
const ROUND_AHEAD: usize = 16;

/// Writes the moves of [`new_vertex_moves`] (in `order`) into `points`.
fn apply_moves(
    collapses: &[Collapse],
    order: &[u32],
    moved: Vec<Option<[f64; 3]>>,
    points: &mut [[f64; 3]],
) {
    for (&j, q) in order.iter().zip(moved) {
        if let Some(q) = q {
            points[collapses[j as usize].u as usize] = q;
        }
    }
}

/// The positions in `collapses` in the order of their removed vertices.
/// A round's collapses are listed by score, all over the mesh; its
/// placements and moves, each independent of the others, run in this order
/// instead, so that neighbouring vertices' points (close in the mesh's
/// order) are read together from memory.
fn by_vertex(collapses: &[Collapse]) -> Vec<u32> {
    let mut order: Vec<u32> = (0..collapses.len() as u32).collect();
    order.par_sort_unstable_by_key(|&j| collapses[j as usize].u);
    order
}

/// Step 4 on a coarse level: flip-free sweeps of the coarse-level energy
/// against the finest surface's areas (`represented`, see
/// [`Hierarchy::represented_area`]), then, for the authalic energy, global
/// steps towards equal areas. The sweeps run on the level copied out
/// ([`LevelMesh`]) from its vertices `alive` (ascending), with `local` as
/// the scratch for their numbers. Returns what the moves of the next new
/// vertices need; `cancelled` is the error when `go_on` says stop.
#[allow(clippy::too_many_arguments)]
fn optimise_level(
    problem: &Problem<'_>,
    params: &ProgressiveParams,
    rings: &RingMesh,
    (alive, local): (&[u32], &mut [u32]),
    represented: Option<Vec<f64>>,
    points: &mut [[f64; 3]],
    go_on: &(dyn Fn() -> bool + Sync),
    cancelled: impl Fn() -> SphereError,
) -> Result<Level, SphereError> {
    if alive.len() >= TRIM_FROM_LEVEL {
        // What the insertion freed (the rings' grown blocks) stays resident
        // unless handed back; the level's copy and references below are the
        // method's peak when the level is most of the mesh (measured on the
        // 1M ellipsoid, a level of over 90% of its vertices).
        spherify_sparse::release_free_memory();
    }
    let mut sub = LevelMesh::gather(
        alive,
        local,
        &rings.rings,
        problem.surface,
        represented.as_deref(),
        points,
    )?;
    let whole_level = Problem { surface: &sub.surface, ..*problem };
    let area_floor = whole_level.at_level_of(sub.n_vertices(), &|j| sub.ring(j)).area_floor;
    let local_problem = Problem {
        energy: problem.energy.on_coarse_levels(),
        surface: &sub.surface,
        area_floor,
        represented: sub.represented.as_deref(),
        pull: None,
    };
    // The level's global steps run on the level copied out too: on the whole
    // mesh's rings each step walked every slot of the finest mesh (measured
    // on 200k-vertex `helix_tube`, balanced: 1.5-2.9 s per level for 30
    // steps from 93 vertices up, 14 of the insertion's 18 s).
    let global = matches!(params.energy, Energy::Stretch | Energy::Balanced)
        && (LEVEL_GLOBAL_SIZES.0..=LEVEL_GLOBAL_SIZES.1).contains(&rings.n_alive);
    let level_rings: Option<Vec<Vec<u32>>> =
        global.then(|| (0..sub.n_vertices()).map(|j| sub.ring(j).to_vec()).collect());
    // The stars take over the level's rings.
    let stars =
        local_problem.stars_of(std::mem::take(&mut sub.start), std::mem::take(&mut sub.ring));
    let sweeps = (LEVEL_MOVES / rings.n_alive).clamp(LEVEL_SWEEPS, MAX_LEVEL_SWEEPS);
    // Only the level's area scale is read of the sweeps' end (by the moves
    // of the next new vertices).
    let scale = local_problem
        .optimise_stars_for_scale(&stars, &mut sub.points, sweeps, params.tolerance, &|_| !go_on())
        .map_err(|_| cancelled())?;
    drop(stars);
    if let Some(level_rings) = &level_rings {
        lbfgs(&local_problem, level_rings, &mut sub.points, &LEVEL_GLOBAL_STEPS, &|| !go_on())
            .map_err(|_| cancelled())?;
    }
    sub.scatter(alive, points);
    drop(sub);
    let level = Level { area_floor, represented, scale };
    if params.energy == Energy::Authalic && rings.n_alive >= AUTHALIC_LEVEL_MIN {
        authalic_newton_rings(
            &rings.rings,
            problem.surface,
            area_floor,
            points,
            AUTHALIC_LEVEL_STEPS,
            &|| !go_on(),
        )
        .map_err(|_| cancelled())?;
    }
    Ok(level)
}

/// The global L-BFGS steps ([`lbfgs`]) after the final sweeps: for the
/// stretch and balanced energies, whose sweeps stall far from the minimum on
/// tubes and on nearly round meshes (issue 22); not for a large limbed
/// balanced map (`stretch_density` above [`GLOBAL_SKIP_STRETCH`]).
fn global_steps(energy: Energy, n: usize, stretch_density: f64) -> Option<LbfgsParams> {
    if limbed_balanced(energy, n, stretch_density) {
        return None;
    }
    let shrink = (GLOBAL_FULL_SIZE as f64 / n.max(1) as f64).min(1.0);
    let max_iter =
        ((GLOBAL_STEPS as f64 * shrink * shrink) as usize).clamp(GLOBAL_MIN_STEPS, GLOBAL_STEPS);
    match energy {
        Energy::Stretch | Energy::Balanced => {
            Some(LbfgsParams { max_iter, tolerance: GLOBAL_TOLERANCE })
        }
        _ => None,
    }
}

/// The final sweeps' waking threshold (see [`Problem::optimise_waking`])
/// and most sweeps: [`LIMBED_WAKE`] and [`LIMBED_EXTRA_SWEEPS`] more than
/// `params.max_iter` where the final global steps are left out (a large
/// limbed balanced map), [`flip_free::NOTICEABLE`] and `params.max_iter`
/// elsewhere.
fn final_sweeps(params: &ProgressiveParams, n: usize, stretch_density: f64) -> (f64, usize) {
    if limbed_balanced(params.energy, n, stretch_density) {
        (LIMBED_WAKE, params.max_iter + LIMBED_EXTRA_SWEEPS)
    } else {
        (flip_free::NOTICEABLE, params.max_iter)
    }
}

/// A balanced map above [`GLOBAL_FULL_SIZE`] vertices whose stretch density
/// is above [`GLOBAL_SKIP_STRETCH`]: a large limbed shape.
fn limbed_balanced(energy: Energy, n: usize, stretch_density: f64) -> bool {
    energy == Energy::Balanced && n > GLOBAL_FULL_SIZE && stretch_density > GLOBAL_SKIP_STRETCH
}

/// The run's account in words: the hierarchy, the final sweeps, the global
/// authalic steps, and why the conformal start was not used.
fn message(
    (collapses, rounds): (usize, usize),
    energy: Energy,
    end: &Optimised,
    global: Option<LbfgsRun>,
    authalic: Option<AuthalicSteps>,
    not_used: Option<NotUsed>,
) -> String {
    let mut message = format!(
        "{} collapses in {} rounds undone; {} final sweeps of the {} energy, {:.4} per unit area \
         (last relative change {:.1e})",
        collapses,
        rounds,
        end.sweeps,
        energy.name(),
        end.energy,
        end.last_change
    );
    if let Energy::BalancedWeighted(_) = energy {
        message.push_str(&format!(" with area weight {:.3}", energy.area_weight()));
    }
    if let Some(run) = global {
        message.push_str(&format!(
            "; {} global L-BFGS steps took it (with its chord-area term) from {:.4} to {:.4}{} \
             ({} line-search trials, \
             {:.2} s factoring, {:.2} s solving)",
            run.iterations,
            run.start,
            run.end,
            if run.fell_back { " (not certified: the sweeps' map kept)" } else { "" },
            run.trials,
            run.factor_seconds,
            run.solve_seconds
        ));
    }
    if let Some(run) = authalic {
        message.push_str(&format!(
            "; {} global authalic steps took the mean |log area ratio| from {:.3} to {:.3}",
            run.steps, run.start, run.end
        ));
        if let Some(why) = run.solve_failed {
            message.push_str(&format!(" (stopped: {why})"));
        }
    }
    if let Some(why) = not_used {
        message.push_str(&format!("; the global conformal start was not used: {}", why.reason));
    }
    message
}

/// The energy of `energy` on the whole of `mesh` (no coarse level): what
/// the method's insertion, `improve`, the landmarks and `move_towards` all
/// optimise.
pub(crate) fn whole_mesh_problem(energy: Energy, mesh: &GenusZeroMesh) -> Problem<'_> {
    Problem {
        energy,
        surface: mesh.positions(),
        area_floor: area_floor(mesh),
        represented: None,
        pull: None,
    }
}

/// `Ok` when `report` certifies a GC-embedding: improving, pinning or moving
/// a map takes flip-free steps, which keep a valid map valid but cannot make
/// an invalid one valid.
///
/// # Errors
/// [`SphereError::InvalidStart`] with the flipped faces and covering degree.
pub(crate) fn require_valid_start(report: &SphereReport) -> Result<(), SphereError> {
    if report.valid {
        return Ok(());
    }
    Err(SphereError::InvalidStart {
        flipped: report.flipped_faces.len(),
        degree: report.covering_degree,
    })
}

/// [`require_valid_start`] of `points` on `mesh`, from `certificate` where
/// their exact test was already made (a map's own certificate), else by
/// testing them.
pub(crate) fn require_valid_points(
    mesh: &GenusZeroMesh,
    points: &[[f64; 3]],
    certificate: Option<&SphereReport>,
) -> Result<(), SphereError> {
    match certificate {
        Some(report) => require_valid_start(report),
        None => require_valid_start(&check_sphere(mesh.faces(), points)),
    }
}

/// Per vertex, whether it is among the `fixed` ids (held still by the moves).
///
/// # Errors
/// [`SphereError::InvalidParameter`] naming an id that is not a vertex.
pub(crate) fn held_vertices(fixed: &[i64], n: usize) -> Result<Vec<bool>, SphereError> {
    let mut held = vec![false; n];
    for &i in fixed {
        if i < 0 || i as u64 >= n as u64 {
            return Err(SphereError::InvalidParameter {
                name: "fixed",
                value: format!("id {i}"),
                expected: "vertex ids of the mesh",
            });
        }
        held[i as usize] = true;
    }
    Ok(held)
}

/// Surface triangles below a millionth of the mean area count as that large.
pub(crate) fn area_floor(mesh: &GenusZeroMesh) -> f64 {
    area_floor_of(mesh, mesh.positions())
}

/// [`area_floor`] of the mesh's triangles at the points `p` (one per vertex).
pub(crate) fn area_floor_of(mesh: &GenusZeroMesh, p: &[[f64; 3]]) -> f64 {
    let total: f64 = mesh
        .faces()
        .iter()
        .map(|&[a, b, c]| triangle_area(p[a as usize], p[b as usize], p[c as usize]))
        .sum();
    let floor = 1e-6 * total / mesh.n_faces().max(1) as f64;
    if floor > 0.0 && floor.is_finite() {
        floor
    } else {
        f64::MIN_POSITIVE
    }
}

/// The neighbour lists of `mesh`, counter-clockwise seen from outside.
///
/// # Errors
/// [`ResourceError::Allocation`](crate::memory_budget::ResourceError) when the
/// system refuses their memory.
pub(crate) fn rings_of(mesh: &GenusZeroMesh) -> Result<Vec<Vec<u32>>, SphereError> {
    Ok(RingMesh::from_faces(mesh.n_vertices(), mesh.faces())?.rings)
}

/// The rings of `mesh` and their colour classes, made on the first call and
/// kept with the mesh ([`Neighbourhoods`]).
///
/// # Errors
/// As [`rings_of`].
pub(crate) fn neighbourhoods_of(mesh: &GenusZeroMesh) -> Result<Arc<Neighbourhoods>, SphereError> {
    if let Some(made) = mesh.neighbourhoods_cell().get() {
        return Ok(Arc::clone(made));
    }
    let rings = rings_of(mesh)?;
    let classes = flip_free::colour_classes(&rings);
    let made = Arc::new(Neighbourhoods { rings, classes });
    Ok(Arc::clone(mesh.neighbourhoods_cell().get_or_init(|| made)))
}

fn insert(rings: &mut RingMesh, points: &mut [[f64; 3]], c: &mut Collapse, q: [f64; 3]) {
    rings.undo_taking(c);
    points[c.u as usize] = q;
}

/// The four remaining vertices onto a regular tetrahedron, oriented so that
/// its four faces are positive.
fn place_tetrahedron(rings: &RingMesh, points: &mut [[f64; 3]]) {
    let base: Vec<u32> = (0..rings.rings.len() as u32).filter(|&v| rings.is_alive(v)).collect();
    let corners = [[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]]
        .map(|p| normalize(p).expect("non-zero"));
    for (&v, p) in base.iter().zip(corners) {
        points[v as usize] = p;
    }
    let a = base[0];
    let ring = &rings.rings[a as usize];
    let positive =
        det3_sign(points[a as usize], points[ring[0] as usize], points[ring[1] as usize]);
    if positive != Sign::Positive {
        points.swap(base[2] as usize, base[3] as usize);
    }
}

/// Moves the neighbourhood of a vertex whose kernel was too thin, flip-free
/// and lowering the energy, and tries to place it again, widening the
/// neighbourhood each time.
fn retry_placement(
    problem: &Problem<'_>,
    k: f64,
    rings: &RingMesh,
    points: &mut [[f64; 3]],
    c: &Collapse,
) -> Option<[f64; 3]> {
    let mut region: Vec<u32> = c.ring.clone();
    for _ in 0..INSERTION_RETRIES {
        for _ in 0..4 {
            for &i in &region {
                if let Some(q) = problem.move_vertex(k, i, &rings.rings[i as usize], points) {
                    points[i as usize] = q;
                }
            }
        }
        if let Some(q) = placement::place(&c.ring, points) {
            return Some(q);
        }
        let mut wider = region.clone();
        for &i in &region {
            wider.extend(rings.rings[i as usize].iter().copied());
        }
        wider.sort_unstable();
        wider.dedup();
        region = wider;
    }
    None
}

#[cfg(test)]
mod tests;
