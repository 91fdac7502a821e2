//! `spherify._core`: the PyO3 bindings. This crate translates between numpy and
//! the core crates and maps errors to the Python exception hierarchy; it holds no
//! algorithm (STYLE 1, 3).

use pyo3::prelude::*;

mod convert;
mod embed;
mod errors;
mod gotsman;
mod graph;
mod io;
mod mesh;
mod metrics;
mod point_map;
mod progress;
mod radial;
mod relaxation;
mod sphere;
mod theta_phi;
mod tutte;
mod validate;

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<mesh::CoreMesh>()?;
    m.add_class::<point_map::CorePointMap>()?;
    m.add_function(wrap_pyfunction!(point_map::point_map_theta_phi, m)?)?;
    m.add_function(wrap_pyfunction!(point_map::point_map_gc, m)?)?;
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
    // Spherical methods (one file each) register below.
    m.add_function(wrap_pyfunction!(gotsman::embed_gotsman, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::quality, m)?)?;
    m.add_function(wrap_pyfunction!(relaxation::embed_relaxation, m)?)?;
    m.add_function(wrap_pyfunction!(relaxation::embed_alexa, m)?)?;
    m.add_function(wrap_pyfunction!(radial::embed_radial, m)?)?;
    m.add_function(wrap_pyfunction!(theta_phi::embed_theta_phi, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
