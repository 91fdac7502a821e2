//! What the tests of relaxation (thesis 5.2) and Alexa's method (5.3) share:
//! both start from the same initial points and promise the same result (a
//! converged, certified map of unit vectors).

use spherify_mesh::Mesh;

use crate::certificate::validity::check_sphere;
use crate::embedding::{SphereEmbedding, Status};
use crate::genus_zero::GenusZeroMesh;
use crate::methods::initial::Initial;
use crate::SphereError;

/// The initial points of `initial` on a test mesh, validated here.
pub fn initial_points(mesh: &Mesh, initial: &Initial) -> Result<Vec<[f64; 3]>, SphereError> {
    crate::methods::initial::initial_points(&GenusZeroMesh::new(mesh.clone())?, initial)
}

/// `e` converged to a certified map whose points are unit vectors.
pub fn assert_converged_and_valid(mesh: &Mesh, e: &SphereEmbedding) {
    assert_eq!(e.status, Status::Converged, "{}", e.message);
    assert!(check_sphere(mesh.faces(), &e.points).valid, "{}", e.message);
    for p in &e.points {
        assert!(((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 1.0).abs() < 1e-12);
    }
}
