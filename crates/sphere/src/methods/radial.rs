//! Radial projection (thesis 3.5, eq. 3.17) from a point, from the vertex mean
//! (eq. 3.18), or from the deepest point of the mesh's kernel.
//!
//! Every vertex moves along its ray from a centre `m` onto the unit sphere,
//! `v_i = (x_i - m) / |x_i - m|`. For face `abc` the orientation test of eq. 3.9
//! on the projected points has the sign of `det[a - m; b - m; c - m]`, which is
//! six times the signed volume of the tetrahedron `m a b c`: positive exactly
//! when `m` lies strictly on the inner side of the face's plane. So the map is
//! flip-free exactly when `m` lies in the *kernel*
//! `K = { p : n_f . (a_f - p) > 0 for every face f }` (outward normals `n_f`,
//! any vertex `a_f` of `f`), and for an embedded surface it then covers the
//! sphere once: a valid GC-embedding. The kernel is non-empty exactly when the
//! mesh is star-shaped (a self-intersecting mesh may wind around `m` more than
//! once; the exact area test of 3.4 catches that).
//!
//! The thesis takes `m` as the vertex mean and notes that this can miss the
//! kernel of a star-shaped mesh, leaving the choice of `m` open (9.3.1).
//! [`Center::Kernel`] closes it with the deepest point of the kernel, the
//! optimum of a small linear program ([`mod@crate::methods::radial::kernel`], solved by
//! [`crate::methods::radial::lp`]); an empty kernel is an error that says the mesh is not
//! star-shaped.
//!
//! The LP only chooses the centre. Whether the floating-point points it yields
//! are valid is decided afterwards, exactly, by [`crate::certificate::validity::check_sphere`]
//! (the caller's `SphereMap.valid`); nothing here claims validity. With the
//! centre strictly inside the kernel every projected face is positively
//! oriented in exact arithmetic; only the rounding of the normalisation can
//! still flip a face whose projected determinant is within about 1e-16 of its
//! size. No retry from other points is made: the LP's point is already the
//! deepest one, and the tests (kernels down to 1e-4 of the mesh size) found no
//! such flips; should one happen, `SphereMap.valid` reports it.

pub mod kernel;
pub mod lp;

use std::time::Instant;

use rayon::prelude::*;

use crate::embedding::{normalize, SphereEmbedding, Status};
use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;
use crate::methods::initial::vertex_mean;
use crate::methods::radial::kernel::{format_point, kernel, KernelPoint};

/// Which point [`radial`] projects from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Center {
    /// A point given by the caller (it should lie in the kernel; no check).
    Point([f64; 3]),
    /// The mean of the vertex positions (thesis eq. 3.18), as in the thesis.
    Centroid,
    /// The deepest point of the kernel, found by a linear program; an error
    /// when the mesh is not star-shaped.
    Kernel,
}

impl Default for Center {
    /// The kernel's deepest point: the one centre that is certain to see every
    /// face when the mesh is star-shaped.
    fn default() -> Self {
        Center::Kernel
    }
}

/// Projects every vertex radially from the chosen centre onto the unit sphere
/// (thesis eq. 3.17). O(F) for [`Center::Kernel`] (the LP), O(n) otherwise.
///
/// Faces must be counter-clockwise seen from outside (the caller orients the
/// mesh). Stages timed: `"center"`, `"project"`.
///
/// # Errors
/// [`SphereError::NotStarShaped`] for [`Center::Kernel`] on a mesh without a
/// kernel; [`SphereError::InvalidParameter`] for a non-finite point or a
/// centre that coincides with a vertex (which then has no direction).
pub fn radial(mesh: &GenusZeroMesh, center: Center) -> Result<SphereEmbedding, SphereError> {
    radial_map(mesh, center).map(|r| r.embedding)
}

/// What [`radial_map`] returns: the embedding and the centre it used.
#[derive(Debug, Clone)]
pub struct Radial {
    pub embedding: SphereEmbedding,
    /// The point `m` of eq. 3.17.
    pub center: [f64; 3],
    /// The LP's account, for [`Center::Kernel`].
    pub kernel: Option<KernelPoint>,
}

/// [`radial`], also returning the centre (and the kernel LP's account).
///
/// # Errors
/// As [`radial`].
pub fn radial_map(mesh: &GenusZeroMesh, center: Center) -> Result<Radial, SphereError> {
    let mesh = mesh.mesh();
    let started = Instant::now();
    let mut kernel_account = None;
    let (m, from) = match center {
        Center::Point(p) => {
            if !p.iter().all(|x| x.is_finite()) {
                return Err(SphereError::InvalidParameter {
                    name: "center",
                    value: format_point(p),
                    expected: "a point with finite coordinates",
                });
            }
            (p, format!("the given point {}", format_point(p)))
        }
        Center::Centroid => {
            let m = vertex_mean(mesh.positions());
            (m, format!("the vertex mean {} (eq. 3.18)", format_point(m)))
        }
        Center::Kernel => {
            let k = kernel(mesh)?;
            let mut from = format!(
                "the deepest kernel point {} at depth {:.3e} ({} LP pivots)",
                format_point(k.point),
                k.depth,
                k.pivots
            );
            if k.skipped_faces > 0 {
                from += &format!(
                    "; {} zero-area faces cannot be oriented from any point",
                    k.skipped_faces
                );
            }
            let point = k.point;
            kernel_account = Some(k);
            (point, from)
        }
    };
    let center_seconds = started.elapsed().as_secs_f64();

    let started = Instant::now();
    let projected: Vec<Option<[f64; 3]>> = mesh
        .positions()
        .par_iter()
        .map(|&x| normalize([x[0] - m[0], x[1] - m[1], x[2] - m[2]]))
        .collect();
    let mut points = Vec::with_capacity(projected.len());
    for (v, p) in projected.into_iter().enumerate() {
        match p {
            Some(p) => points.push(p),
            None => {
                return Err(SphereError::InvalidParameter {
                    name: "center",
                    value: format!("{} (vertex {v} lies there)", format_point(m)),
                    expected: "a centre that is not a vertex of the mesh",
                })
            }
        }
    }
    let embedding = SphereEmbedding {
        points,
        iterations: 0,
        status: Status::Direct,
        message: format!("radial projection (eq. 3.17) from {from}"),
        seconds: vec![("center", center_seconds), ("project", started.elapsed().as_secs_f64())],
    };
    Ok(Radial { embedding, center: m, kernel: kernel_account })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::certificate::validity::check_sphere;
    use crate::methods::radial::kernel::tests::{bent_positions, spike};
    use crate::methods::radial::kernel::{backfacing, deepest_point};
    use spherify_mesh::solids::lat_long_sphere;
    use spherify_mesh::vec3::{cross, dot};
    use spherify_mesh::Mesh;

    /// The method on a test mesh, validated here.
    fn radial(mesh: &Mesh, center: Center) -> Result<SphereEmbedding, SphereError> {
        super::radial(&GenusZeroMesh::new(mesh.clone())?, center)
    }

    /// A closed mesh with faces turned outward (by the sign of the volume).
    fn mesh(positions: Vec<[f64; 3]>, mut faces: Vec<[u32; 3]>) -> Mesh {
        let volume: f64 = faces
            .iter()
            .map(|&[a, b, c]| {
                let (a, b, c) =
                    (positions[a as usize], positions[b as usize], positions[c as usize]);
                dot(a, cross(b, c))
            })
            .sum();
        if volume < 0.0 {
            faces.iter_mut().for_each(|f| f.swap(1, 2));
        }
        Mesh::new(positions, faces).unwrap()
    }

    fn cube(center: [f64; 3], half: f64) -> Mesh {
        let mut p = Vec::new();
        for i in 0..8 {
            p.push([0, 1, 2].map(|k| center[k] + if i >> k & 1 == 1 { half } else { -half }));
        }
        let f = vec![
            [0, 2, 3],
            [0, 3, 1],
            [4, 5, 7],
            [4, 7, 6],
            [0, 1, 5],
            [0, 5, 4],
            [2, 6, 7],
            [2, 7, 3],
            [0, 4, 6],
            [0, 6, 2],
            [1, 3, 7],
            [1, 7, 5],
        ];
        mesh(p, f)
    }

    fn octahedron(shift: [f64; 3]) -> Mesh {
        let (p, f) = (
            spherify_mesh::solids::OCTAHEDRON_POSITIONS,
            spherify_mesh::solids::OCTAHEDRON_FACES.to_vec(),
        );
        mesh(p.iter().map(|q| [0, 1, 2].map(|k| q[k] + shift[k])).collect(), f)
    }

    /// Star-shaped from the origin, but a long +x spike that is dense in
    /// vertices (near the pole of the latitude-longitude grid) drags the
    /// vertex mean far along +x, where the flanks of the four side spikes
    /// hide faces from it.
    fn spiky() -> Mesh {
        lat_long_sphere(60, 80, |u| {
            let side: f64 = [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]
                .iter()
                .map(|&axis| spike(u, axis, 4.0, 0.3))
                .sum();
            1.0 + spike(u, [1.0, 0.0, 0.0], 30.0, 0.35) + side
        })
    }

    /// A stretched sphere bent into a 286 degree arc: a fat "C", star-shaped
    /// from no point.
    fn bent() -> Mesh {
        let tube = lat_long_sphere(30, 24, |_| 1.0);
        mesh(bent_positions(tube.positions()), tube.faces().to_vec())
    }

    fn valid(m: &Mesh, e: &SphereEmbedding) -> bool {
        check_sphere(m.faces(), &e.points).valid
    }

    #[test]
    fn cube_and_octahedron_centre_is_found_and_maps_validly() {
        let m = cube([5.0, -3.0, 2.0], 0.5);
        let k = kernel(&m).unwrap();
        assert!((k.depth - 0.5).abs() < 1e-12, "{k:?}");
        assert!(k.optimal && k.skipped_faces == 0);
        for (got, want) in k.point.iter().zip([5.0, -3.0, 2.0]) {
            assert!((got - want).abs() < 1e-12, "{k:?}");
        }
        let e = radial(&m, Center::Kernel).unwrap();
        assert!(valid(&m, &e));
        assert_eq!((e.status, e.iterations), (Status::Direct, 0));
        assert!(
            e.message.contains("kernel") && e.seconds.iter().map(|s| s.0).eq(["center", "project"])
        );
        for p in &e.points {
            assert!((dot(*p, *p).sqrt() - 1.0).abs() < 1e-15);
        }

        let m = octahedron([100.0, 0.0, -7.0]);
        let k = kernel(&m).unwrap();
        assert!((k.depth - 1.0 / 3f64.sqrt()).abs() < 1e-12, "{k:?}");
        for center in [Center::Kernel, Center::Centroid, Center::Point([100.1, 0.2, -7.1])] {
            assert!(valid(&m, &radial(&m, center).unwrap()), "{center:?}");
        }
    }

    #[test]
    fn star_shaped_mesh_where_the_centroid_fails_maps_from_the_kernel() {
        let m = spiky();
        let centroid = radial(&m, Center::Centroid).unwrap();
        let report = check_sphere(m.faces(), &centroid.points);
        assert!(!report.valid && report.n_negative > 0, "the vertex mean should miss the kernel");
        assert!(backfacing(&m, vertex_mean(m.positions())) > 0);
        let k = kernel(&m).unwrap();
        assert!(k.depth > 0.0 && backfacing(&m, k.point) == 0, "{k:?}");
        let e = radial(&m, Center::Kernel).unwrap();
        assert!(valid(&m, &e), "{}", e.message);
        // Translating and scaling the mesh moves the kernel point along.
        let moved: Vec<[f64; 3]> = m
            .positions()
            .iter()
            .map(|p| [3.0 * p[0] + 1e3, 3.0 * p[1] - 40.0, 3.0 * p[2]])
            .collect();
        let moved = Mesh::new(moved, m.faces().to_vec()).unwrap();
        let km = kernel(&moved).unwrap();
        assert!((km.depth - 3.0 * k.depth).abs() < 1e-9 * k.depth.max(1.0));
        assert!(valid(&moved, &radial(&moved, Center::Kernel).unwrap()));
    }

    #[test]
    fn non_star_shaped_mesh_is_an_error_that_says_so() {
        let m = bent();
        let err = radial(&m, Center::Kernel).unwrap_err();
        assert!(matches!(err, SphereError::NotStarShaped { .. }));
        let text = err.to_string();
        assert!(
            text.contains("not star-shaped") && text.contains("face away from the vertex mean"),
            "{text}"
        );
        assert!(deepest_point(&m).unwrap().depth < 0.0);
        // The centroid still gives points; they are just not a valid map.
        let e = radial(&m, Center::Centroid).unwrap();
        assert!(!valid(&m, &e));
    }

    #[test]
    fn a_point_outside_gives_an_invalid_map_but_no_error() {
        let m = octahedron([0.0; 3]);
        let e = radial(&m, Center::Point([5.0, 0.5, 0.25])).unwrap();
        let r = check_sphere(m.faces(), &e.points);
        assert!(!r.valid && r.n_negative > 0);
        let err = radial(&m, Center::Point([0.0, 1.0, 0.0])).unwrap_err();
        assert!(matches!(err, SphereError::InvalidParameter { name: "center", .. }), "{err}");
        let err = radial(&m, Center::Point([f64::NAN, 0.0, 0.0])).unwrap_err();
        assert!(matches!(err, SphereError::InvalidParameter { name: "center", .. }), "{err}");
    }

    #[test]
    fn coplanar_faces_give_a_degenerate_lp_that_still_ends() {
        // Every vertex pushed out onto the cube [-1, 1]^3: thousands of
        // faces share the six face planes, so most pivots are degenerate.
        let m = lat_long_sphere(40, 48, |u| 1.0 / u.iter().fold(0.0, |a: f64, x| a.max(x.abs())));
        let k = kernel(&m).unwrap();
        assert!(k.optimal && k.depth > 0.5, "{k:?}");
        assert!(valid(&m, &radial(&m, Center::Kernel).unwrap()));
    }
}
