//! Options of the progressive method (thesis 9.3.3) and of `improve` (9.3.2):
//! both lower one of the core's distortion energies with flip-free moves.

use pyo3::prelude::*;
use spherify_sphere::methods::progressive::distortion_energy::Energy;
use spherify_sphere::methods::progressive::improve::ImproveParams;
use spherify_sphere::methods::progressive::ProgressiveParams;
use spherify_sphere::Method;

use crate::errors::mesh_error;
use crate::options::Options;

/// `energy`: one of the core's [`Energy::NAMES`].
pub fn energy(options: &Options<'_>, default: Energy) -> PyResult<Energy> {
    let name = options.string("energy", default.name())?;
    Energy::from_name(&name).ok_or_else(|| {
        mesh_error(format!("energy = {name:?}: expected one of {}", Energy::NAMES.join(", ")))
    })
}

/// `energy` ("isometric"), `max_iter` (final sweeps; 5 for "isometric", 16 for "balanced", 10
/// for "authalic", 50 for "stretch", 100 for "conformal"), `tol` (stop when a sweep lowers the
/// energy by less than this fraction; 1e-3, 1e-4 for "balanced", or 1e-5 for "stretch" and
/// "conformal").
pub fn method(options: &Options<'_>) -> PyResult<Method> {
    let energy = energy(options, ProgressiveParams::default().energy)?;
    let defaults = ProgressiveParams::for_energy(energy);
    Ok(Method::Progressive(ProgressiveParams {
        energy,
        max_iter: options.count("max_iter", defaults.max_iter)?,
        tolerance: options.number("tol", defaults.tolerance)?,
    }))
}

/// The same three options for `improve`.
pub fn improve_params(options: &Options<'_>) -> PyResult<ImproveParams> {
    let defaults = ImproveParams::default();
    Ok(ImproveParams {
        energy: energy(options, defaults.energy)?,
        max_iter: options.count("max_iter", defaults.max_iter)?,
        tolerance: options.number("tol", defaults.tolerance)?,
    })
}
