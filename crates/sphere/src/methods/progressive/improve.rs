//! Thesis 9.3.2's local iteration from any valid map: the flip-free moves of
//! [`crate::methods::progressive::flip_free`] lower a distortion energy starting from a theta-phi,
//! Alexa or Gotsman map, which smooths away the visible seam of theta-phi's
//! cut. Every move keeps every face positive under the exact test, so the
//! result is never less valid than the start.

use std::time::Instant;

use crate::certificate::validity::check_sphere;
use crate::embedding::{SphereEmbedding, Status};
use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;
use crate::methods::progressive::distortion_energy::Energy;
use crate::methods::progressive::flip_free::check_tolerance;
use crate::methods::progressive::{require_valid_start, whole_mesh_problem};

#[derive(Debug, Clone, PartialEq)]
pub struct ImproveParams {
    pub energy: Energy,
    pub max_iter: usize,
    pub tolerance: f64,
}

impl Default for ImproveParams {
    fn default() -> Self {
        ImproveParams { energy: Energy::Isometric, max_iter: 30, tolerance: 1e-3 }
    }
}

/// Lowers `params.energy` from `points` (one per vertex), which must be a
/// valid GC-embedding of `mesh`. `progress(done, total)` hears after every
/// sweep; returning `false` stops with [`SphereError::Cancelled`].
///
/// # Errors
/// [`SphereError::InvalidStart`] when `points` is not a valid map;
/// [`SphereError::InvalidParameter`] for a bad tolerance; cancellation.
pub fn improve(
    mesh: &GenusZeroMesh,
    points: &[[f64; 3]],
    params: &ImproveParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<SphereEmbedding, SphereError> {
    check_tolerance(params.tolerance)?;
    if points.len() != mesh.n_vertices() {
        return Err(SphereError::InvalidParameter {
            name: "points",
            value: format!("{} rows", points.len()),
            expected: "one point per vertex of the mesh",
        });
    }
    require_valid_start(&check_sphere(mesh.faces(), points))?;
    let started = Instant::now();
    let rings = crate::methods::progressive::rings_of(mesh)?;
    let problem = whole_mesh_problem(params.energy, mesh);
    let mut points = points.to_vec();
    let total = params.max_iter.max(1);
    let end = problem
        .optimise(&rings, &mut points, params.max_iter, params.tolerance, &|sweep| {
            !(progress(0, 0) && progress(sweep, total))
        })
        .map_err(|_| SphereError::Cancelled { stage: "improve", done: 0, total })?;
    progress(total, total);
    let status = if end.converged { Status::Converged } else { Status::MaxIterations };
    let message = format!(
        "{} sweeps of flip-free moves lowered the {} energy to {:.4} per unit area (last relative change {:.1e})",
        end.sweeps,
        params.energy.name(),
        end.energy,
        end.last_change
    );
    Ok(SphereEmbedding {
        points,
        iterations: end.sweeps,
        status,
        message,
        seconds: vec![("improve", started.elapsed().as_secs_f64())],
    })
}
