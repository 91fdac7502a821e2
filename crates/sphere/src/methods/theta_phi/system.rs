//! The theta-phi rectangle's linear system rebuilt from a finished run, for
//! reports on the factorisation (`crates/sphere/examples/orderings.rs`,
//! docs/benchmarks.md): the same matrix [`super::theta_phi`] factors first.

use spherify_mesh::HalfEdgeMesh;
use spherify_sparse::tutte::FixedSystem;
use spherify_sparse::weights::Weights;

use super::{disk_system, ThetaPhi};
use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;
use crate::methods::theta_phi::pole_fans::rectangle_boundary;

/// The Tutte system of the cut mesh of `details` (a run of
/// [`super::theta_phi`] on `mesh` with these `weights`) with the rectangle
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
