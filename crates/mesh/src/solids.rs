//! Closed genus-0 meshes for examples and tests: the tetrahedron (the only one
//! with 4 vertices, thesis 2.2.7), the octahedron and icosahedron, their
//! subdivisions, and the bumpy spheres and tubes of the spherical methods' tests.
//! Faces are counter-clockwise seen from outside.

use crate::mesh::Mesh;
use crate::vec3::cross;

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

// The shapes below are the meshes of the relaxation, Alexa and Gotsman tests
// (thesis ch. 5): spheres with bumps, noise for folded starts, and tubes whose
// centroid lies outside them (thesis 9.3.1).

/// The unit icosahedron's positions and faces, counter-clockwise from outside.
pub fn icosahedron() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let p = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let f = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    // Every corner has the same length: divide by it as embedding::normalize does.
    let p = p.iter().map(|&q| {
        let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
        [q[0] / n, q[1] / n, q[2] / n]
    });
    (p.collect(), f)
}

/// The icosahedron subdivided `levels` times onto the unit sphere.
pub fn icosphere(levels: usize) -> Mesh {
    let (p, f) = icosahedron();
    subdivided(p, f, levels)
}

/// Moves every vertex of a unit-sphere mesh along its ray: `radius(p)`.
pub fn reshape(mesh: &Mesh, radius: impl Fn([f64; 3]) -> [f64; 3]) -> Mesh {
    let p = mesh.positions().iter().map(|&q| radius(q)).collect();
    Mesh::new(p, mesh.faces().to_vec()).expect("radius must give finite positions")
}

/// A sphere with bumps and dents (star-shaped about the origin, but folded
/// when seen from the off-centre centroid of a lopsided blob).
pub fn bumpy(levels: usize) -> Mesh {
    reshape(&icosphere(levels), |q| {
        let bumps = [([0.0, 0.0, 1.0], 0.9), ([0.8, 0.6, 0.0], 0.7), ([-0.6, 0.0, -0.8], -0.4)];
        let mut r = 1.0;
        for (c, a) in bumps {
            let d: f64 = q.iter().zip(c).map(|(x, y)| x * y).sum();
            r += a * (12.0 * (d - 1.0)).exp();
        }
        [q[0] * r, q[1] * r, q[2] * r]
    })
}

/// Pseudo-random, deterministic noise in [-1, 1] for vertex `i`, coordinate `k`
/// (a splitmix-style hash; no state, so any vertex can be redrawn alone).
pub fn noise(i: usize, k: usize) -> f64 {
    let mut x = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (k as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    x ^= x >> 31;
    x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x ^= x >> 29;
    (x >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// The vertices of `mesh` with noise of size `amount` added: an initial
/// drawing with foldovers.
pub fn scrambled(mesh: &Mesh, amount: f64) -> Vec<[f64; 3]> {
    mesh.positions()
        .iter()
        .enumerate()
        .map(|(i, p)| {
            [p[0] + amount * noise(i, 0), p[1] + amount * noise(i, 1), p[2] + amount * noise(i, 2)]
        })
        .collect()
}

/// A closed tube of `rings` rings of `around` vertices about the curve
/// `centre(t)`, t in [0, 1], radius `radius`, each end closed by an apex
/// vertex. Rings lie in the plane spanned by `normal(t)` and the binormal
/// `tangent x normal`; odd rings are turned half a step.
pub fn tube(
    around: usize,
    rings: usize,
    radius: f64,
    centre: impl Fn(f64) -> [f64; 3],
    tangent: impl Fn(f64) -> [f64; 3],
    normal: impl Fn(f64) -> [f64; 3],
) -> Mesh {
    let at = |c: [f64; 3], d: [f64; 3], s: f64| [c[0] + s * d[0], c[1] + s * d[1], c[2] + s * d[2]];
    let mut p = vec![at(centre(0.0), tangent(0.0), -radius), at(centre(1.0), tangent(1.0), radius)];
    for r in 0..rings {
        let t = r as f64 / (rings - 1) as f64;
        let (c, n) = (centre(t), normal(t));
        let b = cross(tangent(t), n);
        for k in 0..around {
            let a = std::f64::consts::TAU * (k as f64 + 0.5 * (r % 2) as f64) / around as f64;
            p.push(at(at(c, n, radius * a.cos()), b, radius * a.sin()));
        }
    }
    let id = |r: usize, k: usize| (2 + r * around + k % around) as u32;
    let mut f = Vec::new();
    for k in 0..around {
        f.push([0, id(0, k + 1), id(0, k)]);
        f.push([1, id(rings - 1, k), id(rings - 1, k + 1)]);
    }
    for r in 0..rings - 1 {
        for k in 0..around {
            // Odd rings are turned half a step: stagger the diagonals.
            if r % 2 == 0 {
                f.push([id(r, k), id(r, k + 1), id(r + 1, k)]);
                f.push([id(r + 1, k), id(r, k + 1), id(r + 1, k + 1)]);
            } else {
                f.push([id(r, k), id(r + 1, k + 1), id(r + 1, k)]);
                f.push([id(r, k), id(r, k + 1), id(r + 1, k + 1)]);
            }
        }
    }
    Mesh::new(p, f).expect("a tube about a finite curve is a valid mesh")
}

/// A straight capsule along z, radius 1, `length` long.
pub fn capsule(around: usize, rings: usize, length: f64) -> Mesh {
    tube(
        around,
        rings,
        1.0,
        |t| [0.0, 0.0, length * (t - 0.5)],
        |_| [0.0, 0.0, 1.0],
        |_| [1.0, 0.0, 0.0],
    )
}

/// A thin tube bent along `turns` turns of a helix of radius 1 and `pitch`
/// rise per turn about the z axis: its centroid lies outside it.
pub fn helix(around: usize, rings: usize, radius: f64, turns: f64, pitch: f64) -> Mesh {
    let w = std::f64::consts::TAU * turns;
    let h = pitch * turns;
    let len = (w * w + h * h).sqrt();
    tube(
        around,
        rings,
        radius,
        move |t| [(w * t).cos(), (w * t).sin(), h * (t - 0.5)],
        move |t| [-w * (w * t).sin() / len, w * (w * t).cos() / len, h / len],
        move |t| [(w * t).cos(), (w * t).sin(), 0.0],
    )
}

/// A perturbed, subdivided octahedron and a folded start on it.
pub fn perturbed_octahedron() -> (Mesh, Vec<[f64; 3]>) {
    let base = octasphere(2);
    let mesh = Mesh::new(scrambled(&base, 0.05), base.faces().to_vec())
        .expect("noise of size 0.05 keeps positions finite");
    // The top vertex pulled down across its ring: its fan folds over.
    let mut start = mesh.positions().to_vec();
    start[4] = [0.2, 0.1, 0.6];
    (mesh, start)
}

/// A thin tube bent along 216 degrees of a circle (a "C"): relaxation from
/// the centroid, which lies outside the tube, collapses on it.
pub fn bent_tube() -> Mesh {
    helix(8, 100, 0.2, 0.6, 0.0)
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
