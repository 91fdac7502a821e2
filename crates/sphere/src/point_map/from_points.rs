//! A map made elsewhere: per-vertex sphere positions from another tool (a
//! FreeSurfer `?h.sphere`, a saved map, a user's own method) become an
//! [`Embedding`] certified exactly like the output of every method of
//! [`crate::embed`], so that h and h^-1 (3.3) and everything built on them
//! work the same.
//!
//! The points are projected onto the unit sphere (each divided by its norm)
//! before they are certified: a map given on a sphere of another radius
//! (FreeSurfer's is 100 mm) is the same map, and the orientation signs of 3.4
//! do not change under positive scaling. What is certified is exactly what is
//! kept, the projected points. A point without a direction (not finite, or
//! zero) is refused, with its row.

use std::time::Instant;

use crate::embed::{Details, Embedding, MethodName};
use crate::embedding::{SphereEmbedding, Status};
use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;

/// The map of `mesh` given by `points` (one per vertex, in the mesh's vertex
/// order, at any positive distance from the origin), certified by the exact
/// tests of 3.4. O(N + F), in parallel for the certificate.
///
/// # Errors
/// [`SphereError::PointCount`] when there is not one point per vertex;
/// [`SphereError::BadPoint`] for the first point without a direction.
pub fn from_points(mesh: &GenusZeroMesh, points: &[[f64; 3]]) -> Result<Embedding, SphereError> {
    if points.len() != mesh.n_vertices() {
        return Err(SphereError::PointCount { points: points.len(), vertices: mesh.n_vertices() });
    }
    let started = Instant::now();
    let mut unit = Vec::with_capacity(points.len());
    let mut largest_error = 0.0_f64;
    for (row, &p) in points.iter().enumerate() {
        let (u, norm) = direction(p).ok_or(SphereError::BadPoint { row, point: p })?;
        largest_error = largest_error.max((norm - 1.0).abs());
        unit.push(u);
    }
    let message = if largest_error == 0.0 {
        "points given by the caller, already of unit length".to_string()
    } else {
        format!(
            "points given by the caller, projected onto the unit sphere \
             (largest | |p| - 1 | before: {largest_error:.3e})"
        )
    };
    let result = SphereEmbedding {
        points: unit,
        iterations: 0,
        status: Status::Direct,
        message,
        seconds: vec![("normalise", started.elapsed().as_secs_f64())],
    };
    Ok(Embedding::certified(mesh, MethodName::Points, result, Details::None))
}

/// `p / |p|` and `|p|`, or `None` when `p` has no direction. The norm is taken
/// of `p` scaled by its largest component, so that neither very large nor very
/// small (but nonzero) points overflow or underflow on the way.
fn direction(p: [f64; 3]) -> Option<([f64; 3], f64)> {
    if !p.iter().all(|x| x.is_finite()) {
        return None;
    }
    let big = p.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    if big == 0.0 {
        return None;
    }
    let s = p.map(|x| x / big);
    let n = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
    Some((s.map(|x| x / n), n * big))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::certificate::validity::check_sphere;
    use spherify_mesh::solids::octasphere;

    fn sphere() -> GenusZeroMesh {
        GenusZeroMesh::new(octasphere(2)).unwrap()
    }

    #[test]
    fn a_round_meshs_own_vertices_are_a_valid_map_and_any_radius_is_the_same_map() {
        let mesh = sphere();
        let own = mesh.positions().to_vec();
        let e = from_points(&mesh, &own).unwrap();
        assert_eq!(e.method, MethodName::Points);
        assert!(e.certificate.valid && e.bijective(), "{:?}", e.certificate);
        assert_eq!(e.certificate, check_sphere(mesh.faces(), &e.result.points));
        let big: Vec<[f64; 3]> = own.iter().map(|p| p.map(|x| 100.0 * x)).collect();
        let scaled = from_points(&mesh, &big).unwrap();
        for (a, b) in scaled.result.points.iter().zip(&e.result.points) {
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() < 1e-15);
            }
        }
        assert!(scaled.result.message.contains("projected"), "{}", scaled.result.message);
        let norms =
            scaled.result.points.iter().map(|p| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt());
        assert!(norms.into_iter().all(|n| (n - 1.0).abs() < 1e-15));
    }

    #[test]
    fn a_vertex_moved_across_its_neighbours_is_not_valid() {
        let mesh = sphere();
        let mut points = mesh.positions().to_vec();
        // Through the centre to the other side of the sphere.
        points[0] = points[0].map(|x| -x);
        let e = from_points(&mesh, &points).unwrap();
        assert!(!e.certificate.valid && !e.bijective());
        assert!(e.certificate.n_negative > 0);
    }

    #[test]
    fn wrong_counts_and_points_without_direction_are_refused_with_the_row() {
        let mesh = sphere();
        let mut points = mesh.positions().to_vec();
        points.pop();
        let err = from_points(&mesh, &points).unwrap_err();
        assert!(
            matches!(err, SphereError::PointCount { vertices, .. } if vertices == mesh.n_vertices())
        );
        for bad in [[0.0; 3], [f64::NAN, 0.0, 1.0], [f64::INFINITY, 0.0, 0.0]] {
            let mut points = mesh.positions().to_vec();
            points[3] = bad;
            let err = from_points(&mesh, &points).unwrap_err();
            assert!(matches!(err, SphereError::BadPoint { row: 3, .. }), "{err}");
        }
        // Tiny and huge points keep their direction.
        assert_eq!(direction([1e-300, 0.0, 0.0]), Some(([1.0, 0.0, 0.0], 1e-300)));
        assert_eq!(direction([0.0, -1e300, 0.0]), Some(([0.0, -1.0, 0.0], 1e300)));
    }
}
