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

/// A latitude-longitude sphere with `n_lat` bands and `n_lon` meridians and its
/// poles on the x axis (vertex 0 at +x, the last at -x), each coordinate of a
/// unit direction `u` scaled by `radius(u)` (called once per coordinate, in
/// vertex order, so a random radius gives a random star-shaped polyhedron).
/// For a positive radius that is the same for the three coordinates, the mesh
/// is star-shaped from the origin: the unit sphere is convex round it and
/// radial scaling keeps every face's orientation seen from there.
/// Needs `n_lat >= 2` and `n_lon >= 3`.
pub fn lat_long_sphere(
    n_lat: usize,
    n_lon: usize,
    mut radius: impl FnMut([f64; 3]) -> f64,
) -> Mesh {
    let mut p = vec![[1.0, 0.0, 0.0]];
    for i in 1..n_lat {
        let theta = std::f64::consts::PI * i as f64 / n_lat as f64;
        for j in 0..n_lon {
            let phi = 2.0 * std::f64::consts::PI * j as f64 / n_lon as f64;
            p.push([theta.cos(), theta.sin() * phi.cos(), theta.sin() * phi.sin()]);
        }
    }
    p.push([-1.0, 0.0, 0.0]);
    let south = (p.len() - 1) as u32;
    let ring = |i: usize, j: usize| (1 + (i - 1) * n_lon + j % n_lon) as u32;
    let mut f = Vec::new();
    for j in 0..n_lon {
        f.push([0, ring(1, j), ring(1, j + 1)]);
        f.push([south, ring(n_lat - 1, j + 1), ring(n_lat - 1, j)]);
        for i in 1..n_lat - 1 {
            f.push([ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)]);
            f.push([ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)]);
        }
    }
    let p = p.into_iter().map(|u| u.map(|x| x * radius(u))).collect();
    Mesh::new(p, f).expect("a latitude-longitude grid with finite radii is a valid mesh")
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
