//! A map rebuilt from what was stored of it (a `.spheremap.npz`, a pickle), with
//! every certificate computed again here: a file is data, not proof.
//!
//! * The GC certificate (`valid`, thesis 3.4) is the exact test of
//!   [`crate::certificate::validity::check_sphere`] on the stored points,
//!   through the one certification of every fresh map and of
//!   [`crate::point_map::from_points`] (`Embedding::certified`).
//!   `from_points` itself is not called: it projects the points (changing
//!   their last bits) and names the method "points", where a restored map
//!   must come back as it was, bit for bit, under its own method.
//! * For a theta-phi map (thesis ch. 6) the cut is made again from the stored
//!   path ([`cut_open_with`], 6.3), so the cut mesh is the core's own; the
//!   stored rectangle must put the cut's boundary exactly where eq. 6.31 puts
//!   it; and `tp_valid` is the exact orientation test of every rectangle
//!   triangle, as in [`crate::methods::theta_phi`]. A PL map of a disk that is
//!   positive on every triangle and takes the boundary once around a convex
//!   polygon is one-to-one (the argument behind Tutte's theorem, thesis 4.3),
//!   which is what `tp_valid` claims. The pole fans' monotonicity (6.5.1) and
//!   the thinnest triangle are measured again too.
//! * The stored points of a theta-phi map must be the fold (eq. 6.35) of its
//!   rectangle, within [`FOLD_TOLERANCE`] (not bit for bit: `sin` and `cos`
//!   may differ in the last bit between machines). The points themselves are
//!   kept as stored, so a round trip gives back the same bits.
//!
//! What cannot be checked (iterations, status, message, refinement steps,
//! whether a pole fan was re-embedded) is carried over as information.

use spherify_mesh::cut::{cut_open_with, CutError};
use spherify_mesh::{HalfEdgeMesh, TopologyError};
use spherify_sparse::tutte::inverted_faces;

use crate::embed::{Details, Embedding, MethodName};
use crate::embedding::{SphereEmbedding, Status};
use crate::genus_zero::GenusZeroMesh;
use crate::methods::theta_phi::fold::fold;
use crate::methods::theta_phi::pole_fans::{pole_fan, rectangle_boundary, strictly_increasing_phi};
use crate::methods::theta_phi::poles::Poles;
use crate::methods::theta_phi::rectangle::rectangle_margin;
use crate::methods::theta_phi::ThetaPhi;
/// How far stored theta-phi points may be from the fold of their rectangle.
pub const FOLD_TOLERANCE: f64 = 1e-9;

/// What is stored of a theta-phi map besides the points.
#[derive(Debug, Clone)]
pub struct StoredThetaPhi {
    /// North and south pole.
    pub poles: [u32; 2],
    /// The cut path, north to south.
    pub cut_path: Vec<u32>,
    /// (theta, phi) of every vertex of the cut mesh.
    pub theta_phi: Vec<[f64; 2]>,
    /// Information: refinement steps taken when the map was made.
    pub refinements: usize,
    /// Information: whether each pole fan was re-embedded when it was made.
    pub re_embedded: [bool; 2],
}

/// What is stored of a map.
#[derive(Debug, Clone)]
pub struct StoredMap {
    pub method: MethodName,
    /// One point per vertex of the mesh.
    pub points: Vec<[f64; 3]>,
    pub iterations: usize,
    pub status: Status,
    pub message: String,
    /// Present exactly for `MethodName::ThetaPhi`.
    pub theta_phi: Option<StoredThetaPhi>,
}

/// Why stored parts do not make a map of the mesh.
#[derive(Debug, thiserror::Error)]
pub enum RestoreError {
    #[error("{found} points stored for a mesh of {expected} vertices")]
    PointCount { found: usize, expected: usize },
    #[error("a {method} map {}", if *.has_theta_phi { "cannot carry theta-phi parts" } else { "needs its theta-phi parts (poles, cut path, rectangle)" })]
    ThetaPhiParts { method: MethodName, has_theta_phi: bool },
    #[error("the cut path runs from {first} to {last}, not from the north pole {north} to the south pole {south}")]
    PathEnds { first: u32, last: u32, north: u32, south: u32 },
    #[error("the cut path: {0}")]
    Cut(#[from] CutError),
    #[error("the cut mesh: {0}")]
    CutMesh(#[from] TopologyError),
    #[error("{found} rectangle positions stored for a cut mesh of {expected} vertices")]
    RectangleCount { found: usize, expected: usize },
    #[error("rectangle vertex {vertex} is not finite")]
    NotFinite { vertex: usize },
    #[error("boundary vertex {vertex} of the cut mesh is at {found:?}, not at {expected:?} where eq. 6.31 puts it")]
    Boundary { vertex: u32, found: [f64; 2], expected: [f64; 2] },
    #[error("point {vertex} is {distance:.3e} away from the fold of its rectangle position (tolerance {FOLD_TOLERANCE:e})")]
    NotTheFold { vertex: usize, distance: f64 },
}

/// The status named `name` (as [`Status::name`] spells it).
pub fn status_from_name(name: &str) -> Option<Status> {
    [Status::Converged, Status::MaxIterations, Status::Collapsed, Status::Direct]
        .into_iter()
        .find(|s| s.name() == name)
}

/// Rebuilds the map `stored` of `mesh`, certifying it again. O(F) for the
/// GC test; a theta-phi map adds the cut, O(F log d), and the rectangle test.
///
/// # Errors
/// [`RestoreError`] when the parts do not fit the mesh or each other; the
/// certificate itself never fails, it is computed.
pub fn restore(mesh: &GenusZeroMesh, stored: StoredMap) -> Result<Embedding, RestoreError> {
    let n = mesh.mesh().n_vertices();
    if stored.points.len() != n {
        return Err(RestoreError::PointCount { found: stored.points.len(), expected: n });
    }
    let is_theta_phi = stored.method == MethodName::ThetaPhi;
    if is_theta_phi != stored.theta_phi.is_some() {
        return Err(RestoreError::ThetaPhiParts {
            method: stored.method,
            has_theta_phi: stored.theta_phi.is_some(),
        });
    }
    let details = match stored.theta_phi {
        Some(tp) => Details::ThetaPhi(Box::new(theta_phi(mesh, tp, &stored.points)?)),
        None => Details::None,
    };
    let result = SphereEmbedding {
        points: stored.points,
        iterations: stored.iterations,
        status: stored.status,
        message: stored.message,
        seconds: Vec::new(),
    };
    // The certification every fresh map and `from_points` go through.
    Ok(Embedding::certified(mesh, stored.method, result, details))
}

/// The theta-phi parts of a stored map, with the cut made and the rectangle
/// checked again.
fn theta_phi(
    mesh: &GenusZeroMesh,
    stored: StoredThetaPhi,
    points: &[[f64; 3]],
) -> Result<ThetaPhi, RestoreError> {
    let [north, south] = stored.poles;
    let path = stored.cut_path;
    let (first, last) = (path.first().copied(), path.last().copied());
    if first != Some(north) || last != Some(south) {
        return Err(RestoreError::PathEnds {
            first: first.unwrap_or(u32::MAX),
            last: last.unwrap_or(u32::MAX),
            north,
            south,
        });
    }
    let cut = cut_open_with(mesh.mesh(), mesh.half_edges(), &path)?;
    let uv = stored.theta_phi;
    let n_cut = cut.mesh.n_vertices();
    if uv.len() != n_cut {
        return Err(RestoreError::RectangleCount { found: uv.len(), expected: n_cut });
    }
    if let Some(vertex) = uv.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
        return Err(RestoreError::NotFinite { vertex });
    }
    let n = mesh.mesh().n_vertices();
    let k = path.len() - 2;
    // The boundary is where eq. 6.31 puts it, bit for bit: those positions
    // are fixed by the method, not solved for.
    for (vertex, want) in rectangle_boundary(&cut.boundary, k, n).into_iter().enumerate() {
        if let Some(expected) = want {
            let found = uv[vertex];
            if found[0].to_bits() != expected[0].to_bits()
                || found[1].to_bits() != expected[1].to_bits()
            {
                return Err(RestoreError::Boundary { vertex: vertex as u32, found, expected });
            }
        }
    }
    for (vertex, (&p, &u)) in points.iter().zip(&uv).enumerate() {
        let want = match vertex as u32 {
            v if v == north => [0.0, 0.0, 1.0],
            v if v == south => [0.0, 0.0, -1.0],
            _ => fold(u),
        };
        // f64::max would drop a NaN, so a non-finite point is refused first.
        let distance = if p.iter().all(|x| x.is_finite()) {
            (0..3).map(|i| (p[i] - want[i]).abs()).fold(0.0, f64::max)
        } else {
            f64::INFINITY
        };
        if distance > FOLD_TOLERANCE {
            return Err(RestoreError::NotTheFold { vertex, distance });
        }
    }
    let cut_he = HalfEdgeMesh::new(&cut.mesh)?;
    let fans = [pole_fan(&cut_he, north, false), pole_fan(&cut_he, south, true)];
    let fans_monotone = fans.each_ref().map(|fan| strictly_increasing_phi(&uv, fan));
    let inverted = inverted_faces(cut.mesh.faces(), &uv);
    let min_area_ratio = rectangle_margin(cut.mesh.faces(), &uv);
    Ok(ThetaPhi {
        poles: Poles { north, south, distance: f64::NAN },
        cut_path: path,
        cut,
        theta_phi: uv,
        tp_valid: inverted.is_empty(),
        inverted,
        refinements: stored.refinements,
        re_embedded: stored.re_embedded,
        fans_monotone,
        min_area_ratio,
        symmetry: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::embed::embed;
    use crate::point_map::from_points::from_points;
    use spherify_mesh::solids;

    fn made(method: MethodName) -> (GenusZeroMesh, Embedding) {
        let mesh = GenusZeroMesh::new(solids::icosphere(2)).unwrap();
        let map = match method.with_defaults() {
            Some(m) => embed(&mesh, &m, &|_, _| true).unwrap(),
            None => from_points(&mesh, mesh.mesh().positions()).unwrap(),
        };
        (mesh, map)
    }

    fn stored(map: &Embedding) -> StoredMap {
        StoredMap {
            method: map.method,
            points: map.result.points.clone(),
            iterations: map.result.iterations,
            status: map.result.status,
            message: map.result.message.clone(),
            theta_phi: match &map.details {
                Details::ThetaPhi(tp) => Some(StoredThetaPhi {
                    poles: [tp.poles.north, tp.poles.south],
                    cut_path: tp.cut_path.clone(),
                    theta_phi: tp.theta_phi.clone(),
                    refinements: tp.refinements,
                    re_embedded: tp.re_embedded,
                }),
                _ => None,
            },
        }
    }

    fn tp(map: &Embedding) -> &ThetaPhi {
        match &map.details {
            Details::ThetaPhi(tp) => tp,
            _ => panic!("not a theta-phi map"),
        }
    }

    #[test]
    fn every_method_restores_to_the_same_certificate() {
        for method in MethodName::ALL.into_iter().chain([MethodName::Points]) {
            let (mesh, map) = made(method);
            let back = restore(&mesh, stored(&map)).unwrap();
            assert_eq!(back.certificate.valid, map.certificate.valid, "{method}");
            assert_eq!(back.certificate.n_positive, map.certificate.n_positive);
            assert_eq!(back.result.points, map.result.points);
            assert_eq!(back.bijective(), map.bijective());
        }
    }

    #[test]
    fn theta_phi_parts_are_recomputed() {
        let (mesh, map) = made(MethodName::ThetaPhi);
        let back = restore(&mesh, stored(&map)).unwrap();
        let (a, b) = (tp(&map), tp(&back));
        assert!(b.tp_valid && a.tp_valid);
        assert_eq!(a.cut.mesh.faces(), b.cut.mesh.faces());
        assert_eq!(a.cut.boundary, b.cut.boundary);
        assert_eq!(a.fans_monotone, b.fans_monotone);
        assert_eq!(a.min_area_ratio, b.min_area_ratio);
    }

    #[test]
    fn a_flipped_rectangle_triangle_is_not_certified() {
        let (mesh, map) = made(MethodName::ThetaPhi);
        let mut s = stored(&map);
        let parts = s.theta_phi.as_mut().unwrap();
        // Swap two interior rectangle positions: their triangles turn over. The
        // points are swapped along, so they stay the fold.
        let cut = &tp(&map).cut;
        let interior: Vec<usize> = (0..mesh.mesh().n_vertices())
            .filter(|&v| !cut.boundary.contains(&(v as u32)))
            .take(2)
            .collect();
        parts.theta_phi.swap(interior[0], interior[1]);
        s.points.swap(interior[0], interior[1]);
        let back = restore(&mesh, s).unwrap();
        assert!(!tp(&back).tp_valid);
        assert!(!back.bijective());
    }

    #[test]
    fn inconsistent_parts_are_refused() {
        let (mesh, map) = made(MethodName::ThetaPhi);
        let good = stored(&map);
        let boundary_vertex = tp(&map).cut.boundary[1] as usize;
        let mut moved = good.clone();
        moved.theta_phi.as_mut().unwrap().theta_phi[boundary_vertex][1] = 1e-300;
        assert!(matches!(restore(&mesh, moved), Err(RestoreError::Boundary { .. })));
        let mut edited = good.clone();
        edited.points[5][0] += 1e-6;
        assert!(matches!(restore(&mesh, edited), Err(RestoreError::NotTheFold { vertex: 5, .. })));
        let mut nan = good.clone();
        nan.points[7][1] = f64::NAN;
        assert!(matches!(restore(&mesh, nan), Err(RestoreError::NotTheFold { vertex: 7, .. })));
        let mut short = good.clone();
        short.points.pop();
        assert!(matches!(restore(&mesh, short), Err(RestoreError::PointCount { .. })));
        let mut reversed = good.clone();
        reversed.theta_phi.as_mut().unwrap().cut_path.reverse();
        assert!(matches!(restore(&mesh, reversed), Err(RestoreError::PathEnds { .. })));
        let mut other = good;
        other.method = MethodName::Radial;
        assert!(matches!(restore(&mesh, other), Err(RestoreError::ThetaPhiParts { .. })));
    }

    #[test]
    fn an_edited_gc_map_gets_the_certificate_of_its_points() {
        let (mesh, map) = made(MethodName::Radial);
        assert!(map.certificate.valid);
        let mut s = stored(&map);
        s.points.swap(0, 1);
        let back = restore(&mesh, s).unwrap();
        assert!(!back.certificate.valid);
    }

    #[test]
    fn status_names_round_trip() {
        for s in [Status::Converged, Status::MaxIterations, Status::Collapsed, Status::Direct] {
            assert_eq!(status_from_name(s.name()), Some(s));
        }
        assert_eq!(status_from_name("certified"), None);
    }
}
