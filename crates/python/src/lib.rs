//! `spherify._core`: the PyO3 bindings. This crate translates between numpy and
//! the core crates and maps errors to the Python exception hierarchy; it holds no
//! algorithm (STYLE 1, 3).

use pyo3::prelude::*;

mod closest_point;
mod convert;
mod embed;
mod errors;
mod files;
mod gotsman;
mod graph;
mod harmonics;
mod io;
mod landmarks;
mod memory;
mod mesh;
mod metrics;
mod options;
mod pool;
mod progress;
mod progressive;
mod radial;
mod relaxation;
mod restore;
mod sphere;
mod sphere_map;
mod surface_heights;
mod theta_phi;
mod tutte;
mod validate;

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // Load numpy's C API now, while no signal can be pending in a core call:
    // rust-numpy loads it on first use and panics if that import fails, and a
    // pending KeyboardInterrupt makes it fail (issue 13, item 1). Failing here
    // raises the KeyboardInterrupt from the import of spherify instead.
    m.py().import("numpy")?;
    let _ = numpy::PyArray1::<f64>::zeros(m.py(), [0], false);
    m.add_class::<mesh::CoreMesh>()?;
    m.add_class::<sphere_map::CoreSphereMap>()?;
    m.add_class::<closest_point::CoreClosestPoints>()?;
    m.add_class::<surface_heights::CoreSampledSurface>()?;
    m.add_class::<surface_heights::CoreFeatureNearest>()?;
    m.add_function(wrap_pyfunction!(io::load, m)?)?;
    m.add_function(wrap_pyfunction!(io::save, m)?)?;
    m.add_function(wrap_pyfunction!(io::write_atomic, m)?)?;
    m.add_function(wrap_pyfunction!(io::encode, m)?)?;
    m.add_function(wrap_pyfunction!(io::save_textured_obj, m)?)?;
    m.add_class::<files::AtomicWrite>()?;
    m.add_function(wrap_pyfunction!(files::temporary_path, m)?)?;
    m.add_function(wrap_pyfunction!(files::is_temporary, m)?)?;
    m.add_function(wrap_pyfunction!(files::is_stale_temporary, m)?)?;
    m.add_function(wrap_pyfunction!(files::remove_stale_temporaries, m)?)?;
    m.add_function(wrap_pyfunction!(files::special_kind, m)?)?;
    m.add_function(wrap_pyfunction!(files::require_regular_file, m)?)?;
    m.add_function(wrap_pyfunction!(validate::check, m)?)?;
    m.add_function(wrap_pyfunction!(validate::check_raw, m)?)?;
    m.add_function(wrap_pyfunction!(validate::orient, m)?)?;
    m.add_function(wrap_pyfunction!(validate::weld, m)?)?;
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
    m.add_function(wrap_pyfunction!(embed::method_options, m)?)?;
    m.add_function(wrap_pyfunction!(embed::improve, m)?)?;
    m.add_function(wrap_pyfunction!(embed::from_points, m)?)?;
    m.add_function(wrap_pyfunction!(landmarks::move_towards, m)?)?;
    m.add_function(wrap_pyfunction!(landmarks::pull_towards, m)?)?;
    m.add_function(wrap_pyfunction!(harmonics::harmonics_fit, m)?)?;
    m.add_function(wrap_pyfunction!(harmonics::harmonics_evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::quality, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::face_quality, m)?)?;
    m.add_function(wrap_pyfunction!(restore::restore_map, m)?)?;
    m.add_function(wrap_pyfunction!(memory::embed_need, m)?)?;
    m.add_function(wrap_pyfunction!(memory::check_memory, m)?)?;
    m.add_function(wrap_pyfunction!(memory::check_application, m)?)?;
    m.add_function(wrap_pyfunction!(pool::set_num_threads, m)?)?;
    m.add_function(wrap_pyfunction!(pool::get_num_threads, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

/// Large blocks offered transparent huge pages (see the module notes).
#[global_allocator]
static ALLOCATOR: spherify_mesh::huge_pages::HugePageAllocator =
    spherify_mesh::huge_pages::HugePageAllocator;
