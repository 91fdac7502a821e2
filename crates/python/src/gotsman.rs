//! Options of Gotsman, Gu and Sheffer's spherical Tutte embedding (thesis
//! 5.1, eq. 5.10), solved by sparse Newton with a dogleg trust region.

use pyo3::prelude::*;
use spherify_sphere::methods::gotsman::GotsmanParams;
use spherify_sphere::Method;

use crate::options::Options;
use crate::relaxation::initial;

/// `weights` ("uniform" or "chord" with `rho`: the system needs symmetric
/// positive weights, which the core checks), `max_iter` (50), `tol` (1e-10:
/// every equation of 5.10 to this), `strict` (raise ConvergenceError unless
/// converged), and the start: `center` or `initial` points (default the
/// centroid projection, eq. 5.11).
pub fn method(options: &Options<'_>) -> PyResult<Method> {
    let defaults = GotsmanParams::default();
    Ok(Method::Gotsman(GotsmanParams {
        weights: options.weights(defaults.weights)?,
        max_iter: options.count("max_iter", defaults.max_iter)?,
        tol: options.number("tol", defaults.tol)?,
        strict: options.flag("strict", defaults.strict)?,
        initial: initial(options)?,
    }))
}
