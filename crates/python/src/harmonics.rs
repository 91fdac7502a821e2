//! `harmonics_fit` and `harmonics_evaluate`: the spherical-harmonic transform
//! of `spherify_sphere::applications::harmonics` (thesis 8.3) for `spherify.harmonics`.

use numpy::{PyArray2, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use spherify_sphere::applications::harmonics::{evaluate_with, fit_with};

use crate::convert::{rows, to_numpy};
use crate::errors::harmonics_error;
use crate::sphere_map::CoreSphereMap;

/// harmonics_fit(map, lmax, oversample=1, progress=None) -> (coefficients ((lmax+1)^2, 3)
/// float64, info dict).
///
/// MapError when the map is not a certified bijection; MeshError for bad
/// parameters. The GIL is released for the sampling and the transform, and
/// Ctrl-C stops both.
#[pyfunction]
#[pyo3(signature = (map, lmax, oversample=1, progress=None))]
pub fn harmonics_fit<'py>(
    py: Python<'py>,
    map: &CoreSphereMap,
    lmax: usize,
    oversample: usize,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyDict>)> {
    let point_map = map.point_map(py)?;
    // Through progress::run so that Ctrl-C stops a transform of high degree,
    // and `progress` (a callable or None) hears of the rings and orders done.
    let (coefficients, info) =
        crate::progress::run(py, progress, |go_on| fit_with(point_map, lmax, oversample, go_on))?
            .map_err(harmonics_error)?;
    let d = PyDict::new(py);
    d.set_item("n_theta", info.n_theta)?;
    d.set_item("n_phi", info.n_phi)?;
    d.set_item("seconds", info.seconds)?;
    Ok((to_numpy(py, &coefficients), d))
}

/// harmonics_evaluate(coefficients (K, 3) float64, points (k, 3) float64) -> (k, 3) float64.
#[pyfunction]
pub fn harmonics_evaluate<'py>(
    py: Python<'py>,
    coefficients: PyReadonlyArrayDyn<'_, f64>,
    points: PyReadonlyArrayDyn<'_, f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let coefficients = rows::<f64, 3>(&coefficients, "coefficients")?;
    let points = rows::<f64, 3>(&points, "points")?;
    let values =
        crate::progress::run(py, None, |go_on| evaluate_with(&coefficients, &points, go_on))?
            .map_err(harmonics_error)?;
    Ok(to_numpy(py, &values))
}
