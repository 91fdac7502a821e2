//! Options and results of the theta-phi method (thesis ch. 6).

use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use spherify_sphere::methods::theta_phi::symmetry::{Symmetry, SymmetryParams};
use spherify_sphere::methods::theta_phi::{PoleChoice, ThetaPhi, ThetaPhiParams};
use spherify_sphere::Method;

use crate::convert::{to_i64_rows, to_numpy};
use crate::errors::mesh_error;
use crate::options::Options;

/// What `poles` may be, in words, from the core's list of names.
fn poles_expected() -> String {
    let names: Vec<String> = PoleChoice::NAMES.iter().map(|n| format!("'{n}'")).collect();
    format!("poles must be {} or a (north, south) pair of vertex ids", names.join(", "))
}

fn pole_choice(poles: &Bound<'_, PyAny>, symmetry: SymmetryParams) -> PyResult<PoleChoice> {
    if let Ok(name) = poles.extract::<String>() {
        return PoleChoice::from_name(&name, symmetry)
            .map_err(|_| mesh_error(format!("{}, got {name:?}", poles_expected())));
    }
    // A bool is an int to Python; as a vertex id it is a mistake.
    let pair = poles.extract::<(Bound<'_, PyAny>, Bound<'_, PyAny>)>().ok().filter(|(n, s)| {
        !n.is_instance_of::<pyo3::types::PyBool>() && !s.is_instance_of::<pyo3::types::PyBool>()
    });
    let ids = pair.and_then(|(n, s)| Some((n.extract::<i64>().ok()?, s.extract::<i64>().ok()?)));
    match ids.ok_or(()) {
        Ok((n, s)) if n >= 0 && s >= 0 && n <= u32::MAX as i64 && s <= u32::MAX as i64 => {
            Ok(PoleChoice::Explicit(n as u32, s as u32))
        }
        _ => {
            let got = poles.repr().map(|r| r.to_string()).unwrap_or_default();
            Err(mesh_error(format!("{}, got {got}", poles_expected())))
        }
    }
}

/// `info["symmetry"]`: the planes, the chosen one, the band and the fallback.
fn symmetry_to_py<'py>(py: Python<'py>, sym: &Symmetry) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("centre", sym.centre.to_vec())?;
    let planes: Vec<[f64; 3]> = sym.planes.iter().map(|p| p.normal).collect();
    d.set_item("normals", to_numpy(py, &planes))?;
    let column = |f: fn(&spherify_sphere::methods::theta_phi::symmetry::Plane) -> f64| -> Vec<f64> {
        sym.planes.iter().map(f).collect()
    };
    d.set_item("variances", column(|p| p.variance))?;
    d.set_item("signed_sums", column(|p| p.signed_sum))?;
    d.set_item("balances", column(|p| p.balance))?;
    d.set_item("skews", column(|p| p.skew))?;
    d.set_item("scores", column(|p| p.score))?;
    d.set_item("chosen", sym.chosen)?;
    let chosen = sym.chosen.and_then(|k| sym.planes.get(k));
    d.set_item("normal", chosen.map(|p| p.normal.to_vec()))?;
    d.set_item("score", chosen.map(|p| p.score))?;
    d.set_item("eps", sym.eps)?;
    d.set_item("band", sym.band)?;
    d.set_item("component", sym.component)?;
    d.set_item("symmetry_poles", sym.poles.map(|p| (p.north, p.south)))?;
    d.set_item("spread", sym.spread)?;
    d.set_item("fallback", sym.fallback.map(|f| f.to_string()))?;
    Ok(d)
}

/// Theta-phi's options, as the core's table lists them: `poles` (a name or a
/// (north, south) pair), `weights` with `rho`, `max_refinements`, and
/// `symmetry_eps` and `symmetry_max_score` (only with `poles="symmetry"`,
/// which the table's requirement enforces before this runs).
pub fn method(options: &Options<'_>) -> PyResult<Method> {
    let defaults = ThetaPhiParams::default();
    let eps = options.optional_number("symmetry_eps")?;
    let max_score = options.optional_number("symmetry_max_score")?;
    let symmetry = SymmetryParams {
        eps,
        max_score: max_score.unwrap_or(SymmetryParams::default().max_score),
        ..SymmetryParams::default()
    };
    let poles = match options.take("poles")? {
        Some(p) => pole_choice(&p, symmetry)?,
        None => PoleChoice::FastGraph,
    };
    Ok(Method::ThetaPhi(ThetaPhiParams {
        poles,
        weights: options.weights(defaults.weights)?,
        max_refinements: options.count("max_refinements", defaults.max_refinements)?,
    }))
}

fn ids(v: &[u32]) -> Vec<i64> {
    v.iter().map(|&x| i64::from(x)).collect()
}

/// The facts `ThetaPhiMap.details` holds: refinement, pole fans, the
/// rectangle's thinnest and inverted triangles, the cut's boundary, and what
/// the symmetry method found. Small: the per-vertex arrays come one at a time
/// through [`array`], when asked for.
pub fn details<'py>(py: Python<'py>, tp: &ThetaPhi, d: &Bound<'py, PyDict>) -> PyResult<()> {
    d.set_item("cut_boundary", ids(&tp.cut.boundary).into_pyarray(py))?;
    d.set_item("tp_flipped_faces", ids(&tp.inverted.flipped).into_pyarray(py))?;
    d.set_item("tp_degenerate_faces", ids(&tp.inverted.degenerate).into_pyarray(py))?;
    d.set_item("refinements", tp.refinements)?;
    d.set_item("re_embedded", tp.re_embedded.to_vec())?;
    d.set_item("fans_monotone", tp.fans_monotone.to_vec())?;
    d.set_item("min_area_ratio", tp.min_area_ratio)?;
    if let Some(sym) = &tp.symmetry {
        d.set_item("symmetry", symmetry_to_py(py, sym)?)?;
    }
    Ok(())
}

/// The per-vertex and per-face arrays of a theta-phi map, by name (`None`
/// for an unknown name): `cut_path`, `theta_phi`, `cut_vertices`,
/// `cut_faces`, `cut_original`. A new array on every call.
pub fn array<'py>(py: Python<'py>, tp: &ThetaPhi, name: &str) -> Option<Bound<'py, PyAny>> {
    Some(match name {
        "cut_path" => ids(&tp.cut_path).into_pyarray(py).into_any(),
        "theta_phi" => to_numpy(py, &tp.theta_phi).into_any(),
        "cut_vertices" => to_numpy(py, tp.cut.mesh.positions()).into_any(),
        "cut_faces" => to_numpy(py, &to_i64_rows(tp.cut.mesh.faces())).into_any(),
        "cut_original" => ids(&tp.cut.original).into_pyarray(py).into_any(),
        _ => return None,
    })
}
