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
