//! Meshes whose coordinates no method can work with in double precision
//! (issue 13, item 18): refused up front with a message that says why,
//! instead of failing later with a symptom ("the cut path visits vertex 0
//! twice", "not star-shaped", a centre of infinities).
//!
//! * All vertices at one point, or every face of exactly zero area: the mesh
//!   is degenerate; no map of it can be one-to-one in any useful sense.
//! * A bounding box beyond [`LARGEST`] or below [`SMALLEST`]: the methods form
//!   products of up to four lengths (squared areas inside norms, cotangent
//!   weights, volumes and the determinants of thesis 3.4), which overflow or
//!   underflow f64 there.
//!   A mesh of any real-world size is far inside the range; the caller can
//!   rescale (every method is scale-invariant, so the map is the same).

use spherify_mesh::predicates::collinear3;

use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;

/// Largest bounding-box size or coordinate accepted: its fourth power is
/// 1e240, leaving room for the constants of the methods.
pub const LARGEST: f64 = 1e60;
/// Smallest bounding-box size accepted: its fourth power is 1e-240, normal.
pub const SMALLEST: f64 = 1e-60;

/// Refuses a mesh whose geometry no method can map (see the module docs).
pub fn check_geometry(mesh: &GenusZeroMesh) -> Result<(), SphereError> {
    let x = mesh.positions();
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut largest = 0.0f64;
    for p in x {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
            largest = largest.max(p[i].abs());
        }
    }
    let size = (0..3).map(|i| hi[i] - lo[i]).fold(0.0, f64::max);
    let refuse = |message: String| Err(SphereError::Geometry { message });
    if size == 0.0 {
        return refuse(format!(
            "the mesh is degenerate: all {} vertices are at one point",
            x.len()
        ));
    }
    if largest.is_nan() || size.is_nan() || largest > LARGEST || size > LARGEST {
        return refuse(format!(
            "the coordinates are too large for double precision (up to {largest:.3e}, a \
             bounding box of {size:.3e}): areas and volumes overflow beyond {LARGEST:e}; \
             scale the mesh down (every method is scale-invariant)"
        ));
    }
    if size < SMALLEST {
        return refuse(format!(
            "the mesh is too small for double precision (a bounding box of {size:.3e}): \
             areas and volumes underflow below {SMALLEST:e}; scale the mesh up (every \
             method is scale-invariant)"
        ));
    }
    let flat = mesh.faces().iter().all(|f| {
        let [a, b, c] = f.map(|v| x[v as usize]);
        collinear3(a, b, c)
    });
    if flat {
        return refuse(format!(
            "the mesh is degenerate: all {} faces have zero area (each has its corners on one line)",
            mesh.n_faces()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::solids::octahedron;
    use spherify_mesh::Mesh;

    fn scaled(s: f64) -> GenusZeroMesh {
        let o = octahedron();
        let p = o.positions().iter().map(|q| q.map(|x| x * s)).collect();
        GenusZeroMesh::new(Mesh::new(p, o.faces().to_vec()).unwrap()).unwrap()
    }

    fn message(s: f64) -> String {
        match check_geometry(&scaled(s)) {
            Err(e) => e.to_string(),
            Ok(()) => String::new(),
        }
    }

    #[test]
    fn ordinary_scales_pass_and_extreme_ones_say_why() {
        for s in [1e-55, 1e-6, 1.0, 1e6, 1e55] {
            assert_eq!(message(s), "", "{s}");
        }
        assert!(message(1e308).contains("too large"), "{}", message(1e308));
        assert!(message(1e-310).contains("too small"), "{}", message(1e-310));
        assert!(message(0.0).contains("all 6 vertices are at one point"), "{}", message(0.0));
    }
}
