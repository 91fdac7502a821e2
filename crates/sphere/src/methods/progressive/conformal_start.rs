//! A global conformal start for the progressive method's conformal energy:
//! a discrete conformal map of the whole mesh onto the sphere from two sparse
//! solves, used only when the exact test certifies it.
//!
//! Local flip-free sweeps remove smooth, global angle distortion slowly (on
//! the 134k-vertex igea, 283 sweeps from the progressive hierarchy reach 0.48
//! degrees of mean angle distortion where a conformal map has 0.3). A
//! conformal map has no such distortion to remove:
//!
//! 1. Put a pole into the most regular face `(a, b, c)`: the discrete
//!    conformal map of the sphere minus a point onto the plane is the
//!    solution of one sparse system with the cotangent Laplacian (Pinkall and
//!    Polthier 1993) whose right-hand side sits on `a`, `b`, `c` only
//!    (Angenent, Haker, Tannenbaum and Kikinis 1999, "On the
//!    Laplace-Beltrami operator and brain surface flattening"; Haker et al.
//!    2000, "Conformal surface parameterization for texture mapping").
//!    The face goes to infinity, the rest onto the plane.
//! 2. Scale the plane so that half the vertices lie in the unit circle.
//! 3. Solve the half around the pole again in w = 1 / z, with the other half
//!    fixed: there the pole's discretisation error was largest, and in w the
//!    face is an ordinary one (the repair of the pole's region that Choi,
//!    Lam and Lui 2015, "FLASH: fast landmark aligned spherical harmonic
//!    parameterization", make with a Beltrami solve; with a zero Beltrami
//!    coefficient it is this harmonic solve).
//! 4. Inverse stereographic projection onto the sphere, then Möbius centring
//!    ([`crate::methods::progressive::mobius_centring`]), which picks among the conformal maps
//!    that differ by a Möbius transformation the one whose surface area is
//!    balanced around the sphere. Without it nearly all of the mesh sits in
//!    a small cap, far below the conformal energy's area floor.
//!
//! What is left is the O(h) angle error of a map that is linear on each
//! triangle in the plane and then projected (h the edge length); the flip-free
//! sweeps that follow remove that error locally.
//!
//! Cotangent weights are negative across obtuse pairs of angles, and the
//! projection bends straight edges, so nothing here guarantees a valid
//! GC-embedding: the result is returned only when [`check_sphere`] certifies
//! it, and the caller falls back to the hierarchy otherwise.

use rayon::prelude::*;
use spherify_mesh::vec3::{cross, dot, norm, scale, sub, triangle_area};
use spherify_sparse::tutte::{embed_with_fixed, FixedSystem, TutteError};
use spherify_sparse::{solve, SolveParams, SolverKind};

use crate::certificate::validity::{check_sphere, SphereReport};
use crate::genus_zero::GenusZeroMesh;
use crate::methods::progressive::mobius_centring::{centre, Centred};

/// A certified conformal start.
#[derive(Debug, Clone)]
pub struct ConformalStart {
    /// One unit vector per vertex.
    pub points: Vec<[f64; 3]>,
    /// The face that holds the pole (goes to infinity in the plane).
    pub removed_face: usize,
    pub centred: Centred,
    /// The certificate of `points`.
    pub report: SphereReport,
}

/// Why there is no conformal start.
#[derive(Debug, Clone)]
pub enum NoStart {
    /// The planar system could not be solved (for instance, the cotangent
    /// Laplacian was not positive definite in floating point).
    Solve(TutteError),
    /// The map was found but the exact test refuses it.
    NotValid(Box<SphereReport>),
    /// `stop()` asked to stop between two steps.
    Stopped,
}

/// The conformal start of `mesh`; `area_floor` is the area below which a
/// surface triangle counts as that large (as in the energies), so that
/// degenerate input triangles give finite weights. `stop()` is asked after
/// each solve (a factorisation itself cannot be interrupted).
///
/// # Errors
/// [`NoStart`] when a solve fails, the map is not a valid GC-embedding, or
/// `stop()` said so.
///
/// Slightly over 80 lines because the comments of steps 1 and 3 say why the
/// pole and its repair are made this way.
pub fn conformal_start(
    mesh: &GenusZeroMesh,
    area_floor: f64,
    stop: &(dyn Fn() -> bool + Sync),
) -> Result<ConformalStart, NoStart> {
    let positions = mesh.positions();
    let faces = mesh.faces();
    let he = mesh.half_edges();
    let removed = most_regular_face(positions, faces);
    let [a, b, c] = faces[removed];

    // Step 1: K z = b, with K the cotangent stiffness matrix of the closed
    // mesh and b_j = dphi_j/du - i dphi_j/dv in the removed face (phi_j the
    // hat function of corner j, (u, v) an orthonormal frame of the face
    // with u x v along its outward normal). This is the weak form of
    // Delta z = (d/du - i d/dv) delta_p (Angenent et al. 1999, eq. 3): z
    // behaves like 1 / (2 pi w) near a point p of the face, so the face goes
    // to infinity and the rest of the mesh onto the plane, orientation kept.
    // Unlike fixing the face's corners at a triangle (FLASH's first step),
    // this leaves no corner singularity whose error pollutes the whole map
    // (measured on soccerball: mean angle distortion 2.6 degrees with the
    // corners fixed). K is singular (constants); the sources sum to zero, so
    // grounding one vertex outside the face makes it definite.
    let weights = cotangent_weights(positions, he, area_floor);
    let uv = planar_map(mesh, &weights, [a, b, c], area_floor)?;
    if stop() {
        return Err(NoStart::Stopped);
    }

    // Step 2. Scale the plane (a Möbius transformation too) so that half the
    // vertices lie inside the unit circle around the area-weighted centre:
    // the projection then spreads the mesh over the sphere instead of
    // packing it into a cap a few digits wide, centring starts close, and
    // step 3 has half the mesh to solve.
    let mass = vertex_areas(positions, faces, area_floor);
    let z = scaled(&uv, &mass);

    // Step 3. The discrete pole spreads an error of about h / r around the
    // removed face (h the edge length, r the distance): measured on
    // soccerball, 16 degrees of angle distortion next to it, 0.35 on the far
    // side. So keep the far half (|z| <= 1) and solve the near half again,
    // in w = 1 / z, where the face is an ordinary interior face: the harmonic
    // map with the far half fixed is conformal there (the same repair of the
    // pole's region as FLASH's second step, with the Beltrami coefficient
    // zero). 1 / z is holomorphic, so orientation is kept.
    let far: Vec<bool> = z.iter().map(|p| p[0].hypot(p[1]) <= 1.0).collect();
    let w_fixed: Vec<Option<[f64; 2]>> = z
        .iter()
        .zip(&far)
        .map(|(p, &far)| {
            far.then(|| {
                let r2 = p[0] * p[0] + p[1] * p[1];
                [p[0] / r2, -p[1] / r2]
            })
        })
        .collect();
    let (w, _) =
        embed_with_fixed(he, &weights, &w_fixed, SolverKind::Direct, &SolveParams::default())
            .map_err(NoStart::Solve)?;
    if stop() {
        return Err(NoStart::Stopped);
    }
    let mut points: Vec<[f64; 3]> = (0..z.len())
        .into_par_iter()
        .map(|v| {
            if far[v] {
                inverse_stereographic(z[v][0], z[v][1])
            } else {
                // The point over z = 1 / w, computed from w (see
                // [`inverse_stereographic_at_south`]).
                inverse_stereographic_at_south(w[v][0], w[v][1])
            }
        })
        .collect();

    // Step 4.
    let centred = centre(&mut points, &mass);
    let report = check_sphere(faces, &points);
    if !report.valid {
        return Err(NoStart::NotValid(Box::new(report)));
    }
    Ok(ConformalStart { points, removed_face: removed, centred, report })
}

/// Step 1 of [`conformal_start`]: the map of the mesh onto the plane that
/// sends the face `[a, b, c]` to infinity, by solving K z = b with `weights`
/// the cotangent stiffness matrix (the comment at the call says why).
fn planar_map(
    mesh: &GenusZeroMesh,
    weights: &[f64],
    [a, b, c]: [u32; 3],
    area_floor: f64,
) -> Result<Vec<[f64; 2]>, NoStart> {
    let ground = (0..mesh.n_vertices() as u32).find(|v| ![a, b, c].contains(v)).unwrap_or(0);
    let mut fixed: Vec<Option<[f64; 2]>> = vec![None; mesh.n_vertices()];
    fixed[ground as usize] = Some([0.0, 0.0]);
    let mut system =
        FixedSystem::assemble(mesh.half_edges(), weights, &fixed).map_err(NoStart::Solve)?;
    let sources = pole_sources([a, b, c].map(|v| mesh.positions()[v as usize]), area_floor);
    for (&v, source) in [a, b, c].iter().zip(sources) {
        // The free vertices are numbered in increasing order.
        if let Ok(row) = system.free.binary_search(&v) {
            system.rhs[0][row] += source[0];
            system.rhs[1][row] += source[1];
        }
    }
    let (solution, _) =
        solve(&system.matrix, &system.rhs, SolverKind::Direct, &SolveParams::default())
            .map_err(|e| NoStart::Solve(e.into()))?;
    let mut uv = system.fixed_positions(&fixed);
    system.scatter(&mut uv, &solution);
    Ok(uv)
}

/// Step 2 of [`conformal_start`]: `uv` moved and scaled (a Möbius
/// transformation too) so that half the vertices lie inside the unit circle
/// around the centre weighted by `mass`.
fn scaled(uv: &[[f64; 2]], mass: &[f64]) -> Vec<[f64; 2]> {
    let total: f64 = mass.iter().sum();
    let mut centre_uv = [0.0; 2];
    for (p, &m) in uv.iter().zip(mass) {
        centre_uv[0] += m * p[0] / total;
        centre_uv[1] += m * p[1] / total;
    }
    let mut radii: Vec<f64> =
        uv.iter().map(|p| (p[0] - centre_uv[0]).hypot(p[1] - centre_uv[1])).collect();
    let middle = radii.len() / 2;
    let median = *radii.select_nth_unstable_by(middle, f64::total_cmp).1;
    let unit = if median > 0.0 && median.is_finite() { 1.0 / median } else { 1.0 };
    uv.par_iter().map(|p| [(p[0] - centre_uv[0]) * unit, (p[1] - centre_uv[1]) * unit]).collect()
}

/// The point of the unit sphere over z = 1 / w (see
/// [`inverse_stereographic`]): w = 0 goes to the south pole, and
/// counter-clockwise in the w plane stays counter-clockwise seen from outside.
pub fn inverse_stereographic_at_south(u: f64, v: f64) -> [f64; 3] {
    let r2 = u * u + v * v;
    let s = 1.0 / (1.0 + r2);
    [2.0 * u * s, -2.0 * v * s, (r2 - 1.0) * s]
}

/// The sources b_j = (grad phi_j . e_u, -grad phi_j . e_v) at the corners of
/// the face `p` (see step 1): grad phi_j is the opposite edge turned a
/// quarter about the unit normal n, over twice the area; e_u is the first
/// edge's direction and e_v = n x e_u. They sum to zero.
fn pole_sources(p: [[f64; 3]; 3], area_floor: f64) -> [[f64; 2]; 3] {
    let normal = cross(sub(p[1], p[0]), sub(p[2], p[0]));
    let twice_area = norm(normal).max(2.0 * area_floor);
    let n = scale(normal, 1.0 / norm(normal).max(f64::MIN_POSITIVE));
    let e_u = scale(sub(p[1], p[0]), 1.0 / norm(sub(p[1], p[0])).max(f64::MIN_POSITIVE));
    let e_v = cross(n, e_u);
    [0, 1, 2].map(|j| {
        // The edge opposite corner j, from corner j+1 to corner j+2, turned
        // a quarter towards corner j: n x edge.
        let edge = sub(p[(j + 2) % 3], p[(j + 1) % 3]);
        let grad = scale(cross(n, edge), 1.0 / twice_area);
        [dot(grad, e_u), -dot(grad, e_v)]
    })
}

/// The point of the unit sphere over `(x, y)`, seen from the south pole: the
/// origin goes to the north pole, and counter-clockwise in the plane stays
/// counter-clockwise seen from outside.
pub fn inverse_stereographic(x: f64, y: f64) -> [f64; 3] {
    let r2 = x * x + y * y;
    let s = 1.0 / (1.0 + r2);
    [2.0 * x * s, 2.0 * y * s, (1.0 - r2) * s]
}

/// The face whose edge lengths are closest to equal (the sum of
/// |length / mean - 1| is smallest; the first such face): it goes onto an
/// equilateral triangle with the least distortion (Choi, Lam and Lui 2015).
fn most_regular_face(positions: &[[f64; 3]], faces: &[[u32; 3]]) -> usize {
    let irregularity = |f: &[u32; 3]| {
        let p = f.map(|v| positions[v as usize]);
        let l = [norm(sub(p[1], p[0])), norm(sub(p[2], p[1])), norm(sub(p[0], p[2]))];
        let mean = (l[0] + l[1] + l[2]) / 3.0;
        let s: f64 = l.iter().map(|x| (x / mean - 1.0).abs()).sum();
        if s.is_finite() {
            s
        } else {
            f64::INFINITY
        }
    };
    faces
        .par_iter()
        .enumerate()
        .map(|(i, f)| (irregularity(f), i))
        .min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)))
        .map_or(0, |(_, i)| i)
}

/// The cotangent weight (cot alpha + cot beta) / 2 of every half-edge of the
/// closed mesh, alpha and beta the angles opposite the edge. Each face's
/// cotangents share one denominator, twice its area but at least twice
/// `area_floor`: a face's cotangent form is then its Dirichlet energy times a
/// positive factor, so the whole Laplacian stays positive semi-definite even
/// with degenerate input triangles. The two halves of an edge get the same
/// bits, so the matrix is exactly symmetric.
fn cotangent_weights(
    positions: &[[f64; 3]],
    he: &spherify_mesh::HalfEdgeMesh,
    area_floor: f64,
) -> Vec<f64> {
    let p = |v: u32| positions[v as usize];
    // cot of the angle opposite each half-edge, inside its own face.
    let opposite: Vec<f64> = (0..he.n_half_edges() as u32)
        .into_par_iter()
        .map(|h| {
            let (i, j) = (he.tail(h), he.head(h));
            let k = he.head(he.next(h));
            let (u, v) = (sub(p(i), p(k)), sub(p(j), p(k)));
            let twice_area = norm(cross(u, v)).max(2.0 * area_floor);
            dot(u, v) / twice_area
        })
        .collect();
    (0..he.n_half_edges() as u32)
        .into_par_iter()
        .map(|h| 0.5 * (opposite[h as usize] + opposite[he.twin(h) as usize]))
        .collect()
}

/// A third of the (floored) area of the faces around each vertex.
fn vertex_areas(positions: &[[f64; 3]], faces: &[[u32; 3]], area_floor: f64) -> Vec<f64> {
    let mut mass = vec![0.0; positions.len()];
    for f in faces {
        let [x, y, z] = f.map(|v| positions[v as usize]);
        let area = triangle_area(x, y, z).max(area_floor);
        for &v in f {
            mass[v as usize] += area / 3.0;
        }
    }
    mass
}

#[cfg(test)]
mod tests;
