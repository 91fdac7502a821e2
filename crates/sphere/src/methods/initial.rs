//! Where the iterative methods start (thesis eq. 5.11, 5.13-5.14), and the
//! vertex mean they and radial projection (eq. 3.18) share.

use crate::embedding::normalize;
use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;

/// The start of relaxation, Alexa and Gotsman.
#[derive(Debug, Clone, PartialEq)]
pub enum Initial {
    /// `v_i = (x_i - m) / |x_i - m|` with `m` the mean of the vertices (eq.
    /// 5.11, 5.14). A vertex exactly at the mean takes the direction of its
    /// neighbours (any start will do for it; the iteration moves it).
    Centroid,
    /// The same from a caller-chosen centre `m`: the thesis needs this where
    /// the centroid lies outside the mesh (its HELIX model, 7.3). The centre
    /// may not be a vertex, which would then have no direction.
    Center([f64; 3]),
    /// One point per vertex, normalised onto the sphere (to resume a run, or to
    /// start from another method's result).
    Points(Vec<[f64; 3]>),
}

/// The mean of the positions (thesis eq. 3.18), summed in order so that the
/// result does not depend on the number of threads.
pub fn vertex_mean(positions: &[[f64; 3]]) -> [f64; 3] {
    let sum = positions.iter().fold([0.0; 3], |s, p| [s[0] + p[0], s[1] + p[1], s[2] + p[2]]);
    let n = positions.len().max(1) as f64;
    sum.map(|s| s / n)
}

/// One unit vector per vertex, as `initial` says.
///
/// # Errors
/// [`SphereError::InvalidParameter`] for the wrong number of points, a zero or
/// non-finite point, a non-finite centre, or a centre on a vertex.
pub fn initial_points(
    mesh: &GenusZeroMesh,
    initial: &Initial,
) -> Result<Vec<[f64; 3]>, SphereError> {
    let positions = mesh.positions();
    let center = match initial {
        Initial::Points(points) => return given_points(points, positions.len()),
        Initial::Center(c) => {
            if !c.iter().all(|x| x.is_finite()) {
                return Err(SphereError::InvalidParameter {
                    name: "center",
                    value: format!("{c:?}"),
                    expected: "a finite point",
                });
            }
            *c
        }
        Initial::Centroid => vertex_mean(positions),
    };
    let from_center =
        |p: &[f64; 3]| normalize([p[0] - center[0], p[1] - center[1], p[2] - center[2]]);
    let mut points = Vec::with_capacity(positions.len());
    for (i, p) in positions.iter().enumerate() {
        match (from_center(p), initial) {
            (Some(v), _) => points.push(v),
            (None, Initial::Centroid) => {
                let he = mesh.half_edges();
                let around = he
                    .rotation(i as u32)
                    .filter_map(|h| from_center(&positions[he.head(h) as usize]))
                    .fold([0.0; 3], |s, q| [s[0] + q[0], s[1] + q[1], s[2] + q[2]]);
                points.push(normalize(around).unwrap_or([0.0, 0.0, 1.0]));
            }
            (None, _) => {
                return Err(SphereError::InvalidParameter {
                    name: "center",
                    value: format!("{center:?}, which is vertex {i}"),
                    expected: "a point that is not a vertex (it gives that vertex no direction)",
                })
            }
        }
    }
    Ok(points)
}

fn given_points(points: &[[f64; 3]], n: usize) -> Result<Vec<[f64; 3]>, SphereError> {
    if points.len() != n {
        return Err(SphereError::InvalidParameter {
            name: "initial",
            value: format!("{} points", points.len()),
            expected: "one point per vertex",
        });
    }
    points
        .iter()
        .enumerate()
        .map(|(i, &p)| {
            normalize(p).ok_or_else(|| SphereError::InvalidParameter {
                name: "initial",
                value: format!("point {i} = {p:?}"),
                expected: "finite, non-zero points",
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::solids::{OCTAHEDRON_FACES, OCTAHEDRON_POSITIONS};
    use spherify_mesh::Mesh;

    /// The octahedron scaled by `scale`, with vertex 0 moved to `p0`.
    fn octahedron_with(scale: f64, p0: [f64; 3]) -> GenusZeroMesh {
        let mut positions: Vec<[f64; 3]> =
            OCTAHEDRON_POSITIONS.iter().map(|p| p.map(|x| x * scale)).collect();
        positions[0] = p0;
        GenusZeroMesh::new(Mesh::new(positions, OCTAHEDRON_FACES.to_vec()).unwrap()).unwrap()
    }

    #[test]
    fn the_centroid_start_projects_from_the_vertex_mean() {
        let mesh = octahedron_with(1.0, OCTAHEDRON_POSITIONS[0]);
        let points = initial_points(&mesh, &Initial::Centroid).unwrap();
        for (p, q) in points.iter().zip(OCTAHEDRON_POSITIONS.iter()) {
            assert!((0..3).all(|k| (p[k] - q[k]).abs() < 1e-15));
        }
    }

    #[test]
    fn a_vertex_at_the_centroid_borrows_its_neighbours_direction() {
        // Scaled by 5 with vertex 0 at (-1, 0, 0): the mean is (-1 - 5) / 6 = -1,
        // exactly vertex 0.
        let mesh = octahedron_with(5.0, [-1.0, 0.0, 0.0]);
        assert_eq!(vertex_mean(mesh.positions()), [-1.0, 0.0, 0.0]);
        let points = initial_points(&mesh, &Initial::Centroid).unwrap();
        let norm = |p: [f64; 3]| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        assert!(points.iter().all(|&p| (norm(p) - 1.0).abs() < 1e-15));
    }

    #[test]
    fn a_centre_on_a_vertex_and_a_wrong_point_count_are_refused() {
        let mesh = octahedron_with(1.0, OCTAHEDRON_POSITIONS[0]);
        let on_vertex = Initial::Center(OCTAHEDRON_POSITIONS[2]);
        assert!(matches!(
            initial_points(&mesh, &on_vertex),
            Err(SphereError::InvalidParameter { name: "center", .. })
        ));
        let too_few = Initial::Points(vec![[1.0, 0.0, 0.0]; 5]);
        assert!(initial_points(&mesh, &too_few).is_err());
        let zero = Initial::Points(vec![[0.0; 3]; 6]);
        assert!(initial_points(&mesh, &zero).is_err());
    }
}
