//! The theta-phi method (thesis ch. 6): a spherical parameterisation that is a
//! bijection for every closed genus-0 mesh.
//!
//! 1. Poles n and s ([`poles`], thesis 6.2) and a shortest path between them
//!    (6.2.4, [`cut_path`]), or poles and a path near a symmetry plane
//!    ([`symmetry`], 6.2.5); the path is made chordless and at least 4
//!    vertices long (the thesis assumes k >= 2; we lengthen shorter paths so
//!    the tetrahedron works too).
//! 2. The mesh is cut open along the path into a disk (6.3, `spherify_mesh::cut`).
//! 3. The disk is Tutte-embedded in the theta-phi rectangle [0, pi] x [0, 2 pi]
//!    with the boundary of eq. 6.31 (6.4, [`rectangle`]), and every triangle is
//!    checked with an exact orientation predicate. Where double precision
//!    flipped or collapsed a triangle, the solution is refined with residuals
//!    in double-double (`spherify_sparse::refine`) and checked again.
//! 4. The phi values around each pole must increase strictly (6.5.1); where they
//!    do not, the disk is re-embedded with the pole's neighbours pinned as in
//!    eq. 6.36-6.38 ([`pole_fans`]).
//! 5. The fold m(theta, phi) = (sin t cos p, sin t sin p, cos t) (eq. 6.35,
//!    [`mod@fold`]) puts every vertex on the sphere.
//!
//! `tp_valid` certifies step 3 in floating point: the rectangle embedding has
//! no flipped or zero-area triangle under exact predicates. That is the
//! thesis's guarantee (6.4) made concrete; when double precision cannot hold
//! the embedding it says so. Whether the pole fans are monotone (step 4) is
//! reported separately in `fans_monotone`.

pub mod cut_path;
mod cut_rotations;
pub mod fold;
pub mod pole_fans;
pub mod poles;
pub mod rectangle;
pub mod symmetric_eigen;
pub mod symmetry;

use std::time::Instant;

use spherify_mesh::cut::{cut_open_with, CutError, CutMesh};
use spherify_mesh::dijkstra::EdgeWeights;
use spherify_mesh::graph::Adjacency;
use spherify_mesh::{validate, Mesh, TopologyError, TopologyProblem, UnknownName};
use spherify_sparse::tutte::{inverted_faces, InvertedFaces};
use spherify_sparse::weights::Weights;

use crate::embedding::{SphereEmbedding, Status};
use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;
use crate::methods::theta_phi::cut_path::{cut_path, finish_path};
use crate::methods::theta_phi::cut_rotations::CutRotations;
use crate::methods::theta_phi::fold::fold;
use crate::methods::theta_phi::pole_fans::{
    fan_of_ring, pin_fan, rectangle_boundary, strictly_increasing_phi,
};
use crate::methods::theta_phi::poles::Poles;
use crate::methods::theta_phi::rectangle::{
    disk_half_edges, rectangle_margin, RectangleSolver, Rows,
};
use crate::methods::theta_phi::symmetry::{Symmetry, SymmetryParams};

/// How to choose the poles (thesis 6.2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PoleChoice {
    /// Two Dijkstra sweeps (6.2.3); the default.
    FastGraph,
    /// Exact graph diameter (6.2.2), O(N^2 log N).
    Graph,
    /// Farthest pair in space (6.2.1), exact.
    Physical,
    /// Poles and cut path near a symmetry plane (6.2.5); falls back to
    /// `FastGraph` when no plane is convincing (see [`symmetry`]).
    Symmetry(SymmetryParams),
    /// The caller's pair.
    Explicit(u32, u32),
}

impl PoleChoice {
    /// The choices made by name, as the bindings, the CLI and the docs spell them.
    pub const NAMES: [&'static str; 4] = ["fast_graph", "graph", "physical", "symmetry"];

    /// The choice named `name`; `symmetry` holds the parameters of "symmetry".
    pub fn from_name(name: &str, symmetry: SymmetryParams) -> Result<PoleChoice, UnknownName> {
        Ok(match UnknownName::position("poles", name, &Self::NAMES)? {
            0 => PoleChoice::FastGraph,
            1 => PoleChoice::Graph,
            2 => PoleChoice::Physical,
            _ => PoleChoice::Symmetry(symmetry),
        })
    }

    /// The name of the choice ("explicit" for a caller's pair).
    pub fn name(&self) -> &'static str {
        match self {
            PoleChoice::FastGraph => "fast_graph",
            PoleChoice::Graph => "graph",
            PoleChoice::Physical => "physical",
            PoleChoice::Symmetry(_) => "symmetry",
            PoleChoice::Explicit(..) => "explicit",
        }
    }
}

/// Parameters of [`theta_phi`].
#[derive(Debug, Clone)]
pub struct ThetaPhiParams {
    pub poles: PoleChoice,
    pub weights: Weights,
    /// Most double-double refinement steps per embedding.
    pub max_refinements: usize,
}

impl Default for ThetaPhiParams {
    fn default() -> Self {
        ThetaPhiParams {
            poles: PoleChoice::FastGraph,
            weights: Weights::Uniform,
            max_refinements: 8,
        }
    }
}

/// What the theta-phi method computed besides the points on the sphere.
#[derive(Debug, Clone)]
pub struct ThetaPhi {
    pub poles: Poles,
    pub cut_path: Vec<u32>,
    pub cut: CutMesh,
    /// (theta, phi) of every vertex of the cut mesh (6.31-6.32).
    pub theta_phi: Vec<[f64; 2]>,
    /// The rectangle embedding is flip-free: no clockwise and no zero-area
    /// triangle under exact predicates (the thesis's guarantee, 6.4).
    pub tp_valid: bool,
    /// Triangles of the cut mesh that are clockwise or collapsed in the rectangle.
    pub inverted: InvertedFaces,
    /// Refinement steps taken (over all embeddings).
    pub refinements: usize,
    /// Whether the north / south pole fan had to be re-embedded (6.36-6.38).
    pub re_embedded: [bool; 2],
    /// Whether the north / south pole fans are strictly monotone in the end.
    pub fans_monotone: [bool; 2],
    /// Smallest triangle area in the rectangle divided by the rectangle's area (2 pi^2).
    pub min_area_ratio: f64,
    /// What the symmetry method found, for `PoleChoice::Symmetry`; its
    /// `fallback` says whether (and why) the fast-graph poles were used instead.
    pub symmetry: Option<Symmetry>,
}

fn topology(mesh: &Mesh, problem: TopologyProblem) -> SphereError {
    SphereError::Topology(TopologyError { problem, report: Box::new(validate::check(mesh)) })
}

impl ThetaPhiParams {
    /// The weights the rectangle accepts: Tutte's theorem (4.3) needs positive
    /// weights; cotangent weights can be negative, and then the rectangle may fold.
    pub const WEIGHTS: [&'static str; 3] = ["uniform", "chord", "mean_value"];
}

fn check_weights(weights: Weights) -> Result<(), SphereError> {
    match weights {
        _ if !ThetaPhiParams::WEIGHTS.contains(&weights.name()) => {
            Err(SphereError::InvalidParameter {
                name: "weights",
                value: weights.name().into(),
                expected:
                    "uniform, chord or mean_value: Tutte's theorem (4.3) needs positive weights",
            })
        }
        Weights::Chord { rho } if !rho.is_finite() => Err(SphereError::InvalidParameter {
            name: "rho",
            value: rho.to_string(),
            expected: "a finite exponent",
        }),
        _ => Ok(()),
    }
}

fn from_cut(mesh: &Mesh, err: CutError) -> SphereError {
    match err {
        CutError::Topology(t) => SphereError::Topology(t),
        other => {
            let _ = mesh;
            SphereError::InvalidParameter {
                name: "cut path",
                value: other.to_string(),
                expected: "a simple path along mesh edges",
            }
        }
    }
}

/// Maps a closed genus-0 mesh onto the sphere with the theta-phi method: one
/// point per vertex, and what the method computed on the way.
pub fn theta_phi(
    mesh: &GenusZeroMesh,
    params: &ThetaPhiParams,
) -> Result<(SphereEmbedding, ThetaPhi), SphereError> {
    theta_phi_with_progress(mesh, params, &|_, _| true)
}

/// [`theta_phi`] reporting the progress of `PoleChoice::Graph`, the one slow
/// stage (O(N^2 log N)), as `progress(done, total)` sources, from worker
/// threads. Returning `false` stops the search: the call then fails with
/// [`SphereError::Cancelled`]. Every stage also polls `progress(0, 0)`
/// (between stages and refinement steps; one factorisation is not
/// interrupted).
pub fn theta_phi_with_progress(
    mesh: &GenusZeroMesh,
    params: &ThetaPhiParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<(SphereEmbedding, ThetaPhi), SphereError> {
    check_weights(params.weights)?;
    let mut solver = RectangleSolver::new(params.weights, params.max_refinements);
    let (he, mesh) = (mesh.half_edges(), mesh.mesh());
    let graph = he.adjacency();
    let lengths = EdgeWeights::Length(mesh.positions());
    let ChosenPoles { poles: chosen, path: pole_path, symmetry: found_symmetry } =
        choose_poles(mesh, &graph, lengths, params.poles, progress)?;
    solver.watch.lap("poles");
    go_on(progress, "poles")?;

    let path = match pole_path {
        Some(path) => finish_path(&graph, path, lengths),
        None => cut_path(&graph, chosen.north, chosen.south, lengths),
    }
    .ok_or_else(|| topology(mesh, TopologyProblem::NotSphere))?;
    let mut cut = cut_open_with(mesh, he, &path).map_err(|e| from_cut(mesh, e))?;
    // The factorisation below is the memory peak; what only chose the poles
    // and the path need not be alive then.
    drop(graph);
    solver.watch.lap("cut");

    // Uniform weights (the default) need only the rotations of the cut
    // disk, read from the sphere's half-edges; the other weights are computed
    // on the disk's own half-edges (its face corners and boundary).
    let cut_he = disk_half_edges(params.weights, &cut.mesh)?;
    cut.mesh.forget_edge_table();
    let rotations = CutRotations::new(he, mesh.faces(), &cut);
    let k = path.len() - 2;
    let n_vertices = mesh.n_vertices();
    let fans = fans_of(&rotations, &chosen, mesh)?;

    let mut fixed = rectangle_boundary(&cut.boundary, k, n_vertices);
    solver.watch.lap("system");
    go_on(progress, "cut")?;
    let mut uv = solver.solve(Rows::of(cut_he, &rotations), &cut.mesh, &fixed, progress)?;
    let re_embedded = pin_pole_fans(
        &mut solver,
        &mut uv,
        &mut fixed,
        PoleFans { fans: &fans, k, weights: params.weights, cut: &cut.mesh, rotations: &rotations },
        progress,
    )?;
    let fans_monotone = fans.each_ref().map(|fan| strictly_increasing_phi(&uv, fan));
    let inverted = inverted_faces(cut.mesh.faces(), &uv);
    let tp_valid = inverted.is_empty();
    let min_area_ratio = rectangle_margin(cut.mesh.faces(), &uv);
    solver.watch.lap("check");
    go_on(progress, "check")?;

    let points = folded(&uv[..n_vertices], &chosen);
    solver.watch.lap("fold");
    let refinements = solver.refinements;

    let details = ThetaPhi {
        poles: chosen,
        cut_path: path,
        cut,
        theta_phi: uv,
        tp_valid,
        inverted,
        refinements,
        re_embedded,
        fans_monotone,
        min_area_ratio,
        symmetry: found_symmetry,
    };
    let embedding = SphereEmbedding {
        points,
        iterations: refinements,
        status: Status::Direct,
        message: message(&details),
        seconds: solver.watch.seconds,
    };
    Ok((embedding, details))
}

/// What [`choose_poles`] found.
struct ChosenPoles {
    poles: Poles,
    /// A shortest path between the poles when the pole search found one.
    path: Option<Vec<u32>>,
    /// What the symmetry method found, for `PoleChoice::Symmetry`.
    symmetry: Option<Symmetry>,
}

/// The poles (thesis 6.2) chosen as `choice` says, the shortest path between
/// them when the search found one, and what the symmetry method found.
fn choose_poles(
    mesh: &Mesh,
    graph: &Adjacency,
    lengths: EdgeWeights<'_>,
    choice: PoleChoice,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<ChosenPoles, SphereError> {
    let mut found_symmetry = None;
    // A shortest path between the poles when the pole search found one.
    let mut pole_path = None;
    let fast_graph = |pole_path: &mut Option<Vec<u32>>| {
        poles::fast_graph_with_path(graph, 0, lengths).map(|(poles, path)| {
            *pole_path = Some(path);
            poles
        })
    };
    let chosen = match choice {
        PoleChoice::FastGraph => fast_graph(&mut pole_path),
        PoleChoice::Graph => poles::graph(graph, lengths, progress).map_err(|c| {
            SphereError::Cancelled { stage: "graph poles", done: c.done, total: c.total }
        })?,
        PoleChoice::Symmetry(sym_params) => {
            let sym = symmetry::symmetry(mesh.positions(), mesh.faces(), graph, &sym_params)?;
            let chosen = match (sym.fallback, sym.poles) {
                (None, Some(p)) => {
                    pole_path = Some(sym.path.clone());
                    Some(p)
                }
                _ => fast_graph(&mut pole_path),
            };
            found_symmetry = Some(sym);
            chosen
        }
        PoleChoice::Physical => poles::physical(mesh.positions()),
        PoleChoice::Explicit(n, s) => {
            if n == s || n as usize >= mesh.n_vertices() || s as usize >= mesh.n_vertices() {
                return Err(SphereError::InvalidParameter {
                    name: "poles",
                    value: format!("({n}, {s})"),
                    expected: "two different vertex ids of the mesh",
                });
            }
            Some(Poles { north: n, south: s, distance: f64::NAN })
        }
    }
    .ok_or_else(|| topology(mesh, TopologyProblem::NotSphere))?;
    Ok(ChosenPoles { poles: chosen, path: pole_path, symmetry: found_symmetry })
}

/// The north and south pole fans (6.5.1), from the rings of the poles in the
/// cut disk.
fn fans_of(
    rotations: &CutRotations<'_>,
    poles: &Poles,
    mesh: &Mesh,
) -> Result<[Vec<u32>; 2], SphereError> {
    let ring = |pole| {
        rotations.boundary_ring(pole).ok_or_else(|| topology(mesh, TopologyProblem::NotSphere))
    };
    Ok([fan_of_ring(ring(poles.north)?, false), fan_of_ring(ring(poles.south)?, true)])
}

/// What re-embedding a pole fan needs besides the solver and the boundary.
struct PoleFans<'a> {
    /// The north and south fans (6.5.1).
    fans: &'a [Vec<u32>; 2],
    /// Inner vertices of the cut path.
    k: usize,
    weights: Weights,
    cut: &'a Mesh,
    rotations: &'a CutRotations<'a>,
}

/// Pole fans (6.5.1): re-embeds `uv` with a fan pinned (6.38) where phi is
/// not strictly increasing, and says which fans were. Eq. 6.38 needs the
/// fan's inner vertices to be free; when the poles are adjacent to other path
/// vertices (tiny meshes such as the tetrahedron, where every vertex is on the
/// boundary) there is nothing to pin, and the fan is reported as it is.
fn pin_pole_fans(
    solver: &mut RectangleSolver,
    uv: &mut Vec<[f64; 2]>,
    fixed: &mut [Option<[f64; 2]>],
    pole_fans: PoleFans<'_>,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<[bool; 2], SphereError> {
    let PoleFans { fans, k, weights, cut, rotations } = pole_fans;
    let mut re_embedded = [false; 2];
    // Pinning one fan moves the other pole's neighbours, which can turn that
    // fan back: look again after each re-embedding (at most once per pole).
    loop {
        let mut pinned = false;
        for (side, fan) in fans.iter().enumerate() {
            let inner = &fan[1..fan.len().saturating_sub(1).max(1)];
            if !re_embedded[side]
                && !strictly_increasing_phi(uv, fan)
                && inner.iter().all(|&v| fixed[v as usize].is_none())
            {
                pin_fan(fixed, fan, k, side == 1);
                re_embedded[side] = true;
                pinned = true;
            }
        }
        if !pinned {
            return Ok(re_embedded);
        }
        *uv = solver.solve(
            Rows::of(disk_half_edges(weights, cut)?, rotations),
            cut,
            fixed,
            progress,
        )?;
    }
}

/// The fold (6.35) of the original vertices' `uv` (they keep their labels in
/// the cut mesh), with the poles exactly at the poles.
fn folded(uv: &[[f64; 2]], poles: &Poles) -> Vec<[f64; 3]> {
    let mut points: Vec<[f64; 3]> = uv.iter().copied().map(fold).collect();
    points[poles.north as usize] = [0.0, 0.0, 1.0];
    points[poles.south as usize] = [0.0, 0.0, -1.0];
    points
}

/// The run's account in words: certified, or why double precision could not
/// hold the embedding.
fn message(details: &ThetaPhi) -> String {
    let ThetaPhi { refinements, min_area_ratio, inverted, fans_monotone, .. } = details;
    let refinements = match refinements {
        1 => "1 refinement step".to_string(),
        n => format!("{n} refinement steps"),
    };
    if details.tp_valid {
        format!(
            "theta-phi embedding certified flip-free in double precision ({refinements}, thinnest triangle {min_area_ratio:.3e} of the rectangle)"
        )
    } else {
        format!(
            "double precision cannot hold this embedding: {} flipped and {} collapsed triangles in the theta-phi rectangle after {refinements}; pole fans monotone: north {}, south {}",
            inverted.flipped.len(),
            inverted.degenerate.len(),
            fans_monotone[0],
            fans_monotone[1]
        )
    }
}

/// Wall-clock seconds per stage in first-seen order. A stage met again (the
/// pole re-embedding solves a second system) adds to its first entry, so the
/// stages always sum to the whole call.
struct Stopwatch {
    clock: Instant,
    seconds: Vec<(&'static str, f64)>,
}

impl Stopwatch {
    fn new() -> Stopwatch {
        Stopwatch { clock: Instant::now(), seconds: Vec::new() }
    }

    /// Charges the time since the last lap to `stage`.
    fn lap(&mut self, stage: &'static str) {
        let elapsed = self.clock.elapsed().as_secs_f64();
        self.clock = Instant::now();
        match self.seconds.iter_mut().find(|(name, _)| *name == stage) {
            Some((_, total)) => *total += elapsed,
            None => self.seconds.push((stage, elapsed)),
        }
    }
}

/// Polls `progress(0, 0)` between stages (see [`crate::embed::embed`]):
/// `false` stops the method with [`SphereError::Cancelled`] at `stage`.
fn go_on(
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
    stage: &'static str,
) -> Result<(), SphereError> {
    if progress(0, 0) {
        Ok(())
    } else {
        Err(SphereError::Cancelled { stage, done: 0, total: 0 })
    }
}

#[cfg(test)]
mod tests;
