//! The two smallest closed genus-0 meshes, for examples and tests: the
//! tetrahedron (the only one with 4 vertices, thesis 2.2.7) and the octahedron.
//! Faces are counter-clockwise seen from outside.

use crate::mesh::Mesh;

/// Unit octahedron: vertices +-x, +-y, +-z (in that order).
pub const OCTAHEDRON_POSITIONS: [[f64; 3]; 6] = [
    [1.0, 0.0, 0.0],
    [-1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, -1.0, 0.0],
    [0.0, 0.0, 1.0],
    [0.0, 0.0, -1.0],
];

/// The octahedron's faces, counter-clockwise seen from outside.
pub const OCTAHEDRON_FACES: [[u32; 3]; 8] =
    [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];

/// The corner tetrahedron: the origin and the three unit points.
pub const TETRAHEDRON_POSITIONS: [[f64; 3]; 4] =
    [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The tetrahedron's faces, counter-clockwise seen from outside.
pub const TETRAHEDRON_FACES: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];

/// The unit octahedron as a mesh.
pub fn octahedron() -> Mesh {
    Mesh::new(OCTAHEDRON_POSITIONS.to_vec(), OCTAHEDRON_FACES.to_vec())
        .expect("the octahedron's constant arrays are valid")
}

/// The corner tetrahedron as a mesh.
pub fn tetrahedron() -> Mesh {
    Mesh::new(TETRAHEDRON_POSITIONS.to_vec(), TETRAHEDRON_FACES.to_vec())
        .expect("the tetrahedron's constant arrays are valid")
}

/// A mesh inscribed in the unit sphere with every triangle split in four
/// (at its edge midpoints) `levels` times, each new vertex pushed out onto the
/// sphere: the usual finer sphere meshes for tests and examples.
pub fn subdivided(mut positions: Vec<[f64; 3]>, mut faces: Vec<[u32; 3]>, levels: usize) -> Mesh {
    for _ in 0..levels {
        let mut midpoints = std::collections::HashMap::new();
        let mut split = |a: u32, b: u32, p: &mut Vec<[f64; 3]>| -> u32 {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (x, y) = (p[a as usize], p[b as usize]);
                let m = [x[0] + y[0], x[1] + y[1], x[2] + y[2]];
                let r = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
                p.push(m.map(|c| c / r));
                (p.len() - 1) as u32
            })
        };
        let mut finer = Vec::with_capacity(4 * faces.len());
        for &[a, b, c] in &faces {
            let (ab, bc, ca) = (
                split(a, b, &mut positions),
                split(b, c, &mut positions),
                split(c, a, &mut positions),
            );
            finer.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        faces = finer;
    }
    Mesh::new(positions, faces).expect("subdividing a valid sphere mesh keeps it valid")
}

/// The octahedron subdivided `levels` times onto the unit sphere: mirror
/// symmetric in the three coordinate planes, triangulation included.
pub fn octasphere(levels: usize) -> Mesh {
    subdivided(OCTAHEDRON_POSITIONS.to_vec(), OCTAHEDRON_FACES.to_vec(), levels)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::validate::check;

    #[test]
    fn both_are_valid_outward_spheres() {
        for mesh in [octahedron(), tetrahedron()] {
            let r = check(&mesh);
            assert!(r.is_sphere_topology && r.outward && r.problems.is_empty(), "{r:?}");
        }
    }
}
