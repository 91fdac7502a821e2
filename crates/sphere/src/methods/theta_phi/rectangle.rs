//! The rectangle embedding of the theta-phi method (thesis 6.4): the cut
//! disk Tutte-embedded in [0, pi] x [0, 2 pi] with the boundary of eq. 6.31,
//! solved once, refined in double-double while triangles are inverted, and
//! measured ([`rectangle_margin`]). [`rectangle_system`] rebuilds the same
//! system from a finished run, for reports on the factorisation
//! (`crates/sphere/examples/orderings.rs`, docs/benchmarks.md).

use std::f64::consts::PI;

use spherify_mesh::{HalfEdgeMesh, Mesh};
use spherify_sparse::refine::refine_step;
use spherify_sparse::tutte::{inverted_faces, FixedSystem, TutteError};
use spherify_sparse::weights::{half_edge_weights, Weights};
use spherify_sparse::Factorization;

use super::{go_on, Stopwatch, ThetaPhi};
use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;
use crate::methods::theta_phi::cut_rotations::CutRotations;
use crate::methods::theta_phi::pole_fans::rectangle_boundary;

/// The cut disk's own half-edges where `weights` need them (its face
/// corners and boundary); uniform weights read the rows from the sphere's
/// ([`Rows::Sphere`]) and get `None`.
pub(super) fn disk_half_edges(
    weights: Weights,
    cut: &Mesh,
) -> Result<Option<HalfEdgeMesh>, SphereError> {
    Ok(match weights {
        Weights::Uniform => None,
        _ => Some(HalfEdgeMesh::new(cut)?),
    })
}

/// The rectangle system assembled on the cut disk's own half-edges `he`
/// with `weights`: any weights, and what [`Rows::Sphere`] gives bit for bit
/// for uniform ones.
fn disk_system(
    cut: &Mesh,
    he: &HalfEdgeMesh,
    weights: Weights,
    fixed: &[Option<[f64; 2]>],
) -> Result<FixedSystem, SphereError> {
    let weights =
        half_edge_weights(cut.positions(), he, weights).map_err(|e| from_tutte(e.into()))?;
    FixedSystem::assemble(he, &weights, fixed).map_err(from_tutte)
}

/// Where the rows of the rectangle system come from: the cut disk's own
/// half-edges (any weights), or, for uniform weights, the rotations read from
/// the sphere's half-edges (the same rows in the same order: [`CutRotations`]).
pub(super) enum Rows<'a> {
    Disk(HalfEdgeMesh),
    Sphere(&'a CutRotations<'a>),
}

impl<'a> Rows<'a> {
    /// The disk's own half-edges when [`disk_half_edges`] made them, else the
    /// sphere's `rotations`.
    pub(super) fn of(cut_he: Option<HalfEdgeMesh>, rotations: &'a CutRotations<'a>) -> Rows<'a> {
        match cut_he {
            Some(he) => Rows::Disk(he),
            None => Rows::Sphere(rotations),
        }
    }
}

/// What both rectangle solves (the first, and the one with pinned pole fans)
/// share: the weights, the refinement budget, and the running counts.
pub(super) struct RectangleSolver {
    weights: Weights,
    max_refinements: usize,
    /// Refinement steps taken, over all solves.
    pub(super) refinements: usize,
    pub(super) watch: Stopwatch,
}

impl RectangleSolver {
    pub(super) fn new(weights: Weights, max_refinements: usize) -> RectangleSolver {
        RectangleSolver { weights, max_refinements, refinements: 0, watch: Stopwatch::new() }
    }

    /// Solves the Tutte system of `cut` (whose rows come from `rows`) with
    /// `fixed` boundary, then refines in double-double while triangles are
    /// inverted and refinement still changes the solution.
    ///
    /// `rows` is taken by value so that the disk's half-edges and the weights
    /// are freed once the system is assembled: the factor then has their
    /// memory (at a million vertices they are ~130 MB next to a ~600 MB factor).
    pub(super) fn solve(
        &mut self,
        rows: Rows<'_>,
        cut: &Mesh,
        fixed: &[Option<[f64; 2]>],
        progress: &(dyn Fn(usize, usize) -> bool + Sync),
    ) -> Result<Vec<[f64; 2]>, SphereError> {
        let system = match rows {
            Rows::Sphere(rotations) => {
                FixedSystem::assemble_rows(fixed, |i, out| rotations.uniform_edges(i, out))
                    .map_err(from_tutte)?
            }
            Rows::Disk(he) => disk_system(cut, &he, self.weights, fixed)?,
        };
        let faces = cut.faces();
        if system.free.is_empty() {
            return Ok(system.fixed_positions(fixed));
        }
        self.watch.lap("system");
        go_on(progress, "rectangle system")?;
        let factor = Factorization::new(&system.matrix)?;
        self.watch.lap("factor");
        go_on(progress, "factorisation")?;
        let mut uv = system.fixed_positions(fixed);
        let mut x = factor.solve(&system.matrix, &system.rhs)?;
        system.scatter(&mut uv, &x);
        self.watch.lap("solve");
        // One refinement step always: the plain solve leaves cond(A) * eps behind.
        for step in 0..self.max_refinements {
            if step > 0 {
                let done = inverted_faces(faces, &uv).is_empty();
                self.watch.lap("check");
                if done {
                    break;
                }
            }
            go_on(progress, "refinement")?;
            let changed = refine_step(&system.matrix, &factor, &system.rhs, &mut x)?;
            self.refinements += 1;
            system.scatter(&mut uv, &x);
            self.watch.lap("refine");
            // A step that changed no entry reached a fixed point: every
            // further step would give these same bits. Where double precision
            // cannot hold the embedding (long tubes, spikes) this ends after
            // 2-3 steps instead of the whole budget.
            if changed == 0 {
                break;
            }
        }
        Ok(uv)
    }
}

/// The Tutte system of the cut mesh of `details` (a run of
/// [`super::theta_phi()`] on `mesh` with these `weights`) with the rectangle
/// boundary of eq. 6.31: its `matrix` is the free block theta-phi factors.
/// When the run re-embedded a pole fan (`details.re_embedded`) it also
/// factored a second system with the fan pinned, which this is not.
pub fn rectangle_system(
    mesh: &GenusZeroMesh,
    details: &ThetaPhi,
    weights: Weights,
) -> Result<FixedSystem, SphereError> {
    let cut = &details.cut;
    let he = HalfEdgeMesh::new(&cut.mesh)?;
    let k = details.cut_path.len() - 2;
    let fixed = rectangle_boundary(&cut.boundary, k, mesh.mesh().n_vertices());
    disk_system(&cut.mesh, &he, weights, &fixed)
}

fn from_tutte(err: TutteError) -> SphereError {
    match err {
        TutteError::Topology(t) => SphereError::Topology(t),
        TutteError::Solve(s) => SphereError::Solve(s),
        other => SphereError::InvalidParameter {
            name: "theta-phi embedding",
            value: other.to_string(),
            expected: "a solvable Tutte system",
        },
    }
}

/// The smallest signed triangle area of the theta-phi rectangle divided by
/// the rectangle's area, 2 pi^2: [`ThetaPhi::min_area_ratio`].
pub fn rectangle_margin(faces: &[[u32; 3]], uv: &[[f64; 2]]) -> f64 {
    faces
        .iter()
        .map(|&[a, b, c]| {
            let (a, b, c) = (uv[a as usize], uv[b as usize], uv[c as usize]);
            0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
        })
        .fold(f64::INFINITY, f64::min)
        / (2.0 * PI * PI)
}
