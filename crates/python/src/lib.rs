//! `spherify._core`: the PyO3 bindings. This crate translates between numpy and
//! the core crates and maps errors to the Python exception hierarchy; it holds no
//! algorithm (STYLE 1, 3).

use pyo3::prelude::*;

mod convert;
mod embed;
mod errors;
mod gotsman;
mod graph;
mod harmonics;
mod io;
mod mesh;
mod metrics;
mod options;
mod progress;
mod progressive;
mod radial;
mod relaxation;
mod restore;
mod sphere;
mod sphere_map;
mod theta_phi;
mod tutte;
mod validate;

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<mesh::CoreMesh>()?;
    m.add_class::<sphere_map::CoreSphereMap>()?;
    m.add_function(wrap_pyfunction!(io::load, m)?)?;
    m.add_function(wrap_pyfunction!(io::save, m)?)?;
    m.add_function(wrap_pyfunction!(validate::check, m)?)?;
    m.add_function(wrap_pyfunction!(validate::check_raw, m)?)?;
    m.add_function(wrap_pyfunction!(validate::orient, m)?)?;
    m.add_function(wrap_pyfunction!(sphere::check_sphere, m)?)?;
    m.add_function(wrap_pyfunction!(tutte::boundary_loop, m)?)?;
    m.add_function(wrap_pyfunction!(tutte::tutte, m)?)?;
    m.add_function(wrap_pyfunction!(graph::dijkstra, m)?)?;
    m.add_function(wrap_pyfunction!(graph::shortest_path, m)?)?;
    // Every spherical method goes through embed; each reads its options in
    // the file named after it.
    m.add_function(wrap_pyfunction!(embed::embed, m)?)?;
    m.add_function(wrap_pyfunction!(embed::methods, m)?)?;
    m.add_function(wrap_pyfunction!(embed::choices, m)?)?;
    m.add_function(wrap_pyfunction!(embed::improve, m)?)?;
    m.add_function(wrap_pyfunction!(embed::from_points, m)?)?;
    m.add_function(wrap_pyfunction!(harmonics::harmonics_fit, m)?)?;
    m.add_function(wrap_pyfunction!(harmonics::harmonics_evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::quality, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::face_quality, m)?)?;
    m.add_function(wrap_pyfunction!(restore::restore_map, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
