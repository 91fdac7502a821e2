//! Mapping many points between the surface and the sphere: `to_sphere` (h)
//! and `to_surface` (h^-1) for any spherical map.
//!
//! * theta-phi maps use the thesis's own bijection h = h3 o h2 o h1 (6.6,
//!   [`crate::point_map::h_map`]), which holds whenever the rectangle embedding is
//!   certified (`tp_valid`), whether or not the folded points happen to form a
//!   valid GC-embedding;
//! * every other map uses the barycentric map of 3.3 ([`crate::point_map::gc_map`]),
//!   a bijection exactly when the embedding is a valid GC-embedding.
//!
//! `to_sphere` is a function in every case; `to_surface` is refused, with the
//! reason, when the map is not a certified bijection, since "the" preimage is
//! then not defined. Both validate their input row by row and run in parallel.

pub mod bvh;
pub mod from_points;
pub mod gc_map;
pub mod h_map;
pub mod restore;
pub mod weight_bound;

use std::sync::Arc;

use rayon::prelude::*;
use spherify_mesh::spatial_order::spatial_order;
use spherify_mesh::Mesh;

use crate::embed::{Details, Embedding};
use crate::memory_budget::{self, ResourceError};
use crate::point_map::bvh::NearCache;
use crate::point_map::gc_map::GcMap;
use crate::point_map::h_map::ThetaPhiMap;

/// Why a point query cannot be answered.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PointMapError {
    #[error("row {row}: face id {face} is out of range (the mesh has {n_faces} faces)")]
    FaceOutOfRange { row: usize, face: i64, n_faces: usize },
    #[error("row {row}: barycentric weights {weights:?} must be finite, >= 0 and sum to 1")]
    BadWeights { row: usize, weights: [f64; 3] },
    #[error("row {row}: {point:?} is not a unit vector (norm {norm})")]
    NotOnSphere { row: usize, point: [f64; 3], norm: f64 },
    #[error("face_ids has {faces} rows but bary has {weights}")]
    LengthMismatch { faces: usize, weights: usize },
    #[error("this map is not a bijection, so h^-1 is not defined: {0}")]
    NotBijective(String),
    /// The progress closure asked to stop (Ctrl-C in Python).
    #[error("stopped after {done} of {total} points")]
    Cancelled { done: usize, total: usize },
    /// The memory for the points could not be had (issue 26: an error, not an abort).
    #[error(transparent)]
    Resource(#[from] ResourceError),
}

/// Points per batch between two polls of the progress closure: a few
/// milliseconds of work, so that a request to stop is answered quickly, and
/// large enough that the pause between batches does not show.
const BATCH: usize = 1 << 16;

/// Runs `f` on consecutive batches of `0..n` (each in parallel), polling
/// `progress(0, 0)` before each one (see `crate::embed`'s progress contract).
fn batched<T: Send>(
    n: usize,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
    f: impl Fn(std::ops::Range<usize>) -> Result<Vec<T>, PointMapError>,
) -> Result<Vec<T>, PointMapError> {
    // Reserved fallibly: the output of millions of points is the one large
    // allocation here, and a refused one is a ResourceError, not an abort.
    let mut out = memory_budget::reserved(n, "the located points")?;
    for start in (0..n).step_by(BATCH) {
        if !progress(0, 0) {
            return Err(PointMapError::Cancelled { done: start, total: n });
        }
        out.extend(f(start..n.min(start + BATCH))?);
    }
    Ok(out)
}

/// Tolerances on user input: weights may be this far below 0 or their sum
/// this far from 1 (they are rescaled), and sphere points this far from unit
/// length (they are normalised).
const WEIGHT_TOLERANCE: f64 = 1e-6;
const NORM_TOLERANCE: f64 = 1e-6;

#[derive(Debug, Clone)]
enum Inner {
    ThetaPhi(ThetaPhiMap),
    Gc(GcMap),
}

/// h and h^-1 for one spherical map of one mesh.
#[derive(Debug, Clone)]
pub struct PointMap {
    mesh: Arc<Mesh>,
    inner: Inner,
    /// `Some(reason)` when h^-1 is not defined.
    not_bijective: Option<String>,
    /// The longest edge of every face of `mesh`: turns a bound on the
    /// weights' error into one on the surface point's.
    sizes: Vec<f64>,
    /// When the caller's faces were reoriented: `corners[f][k]` is the corner
    /// of `mesh`'s face f that is corner k of the caller's face f.
    corners: Option<Vec<[u8; 3]>>,
}

/// What [`PointMap::to_surface`] returns, one row per query point.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfacePoints {
    /// The face holding the preimage (in the caller's face order).
    pub faces: Vec<u32>,
    /// Its barycentric weights on the caller's corners of that face.
    pub bary: Vec<[f64; 3]>,
    /// The surface point.
    pub xyz: Vec<[f64; 3]>,
    /// A bound on the distance from `xyz` to the exact preimage of every
    /// sphere point within the rounding error of `to_sphere` of the query
    /// (so it also bounds the error of a round trip surface -> sphere ->
    /// surface); infinite when the query's digits cannot say where it came
    /// from (a nearly flat triangle, issue 13 item 7).
    pub error: Vec<f64>,
}

/// The longest edge of every face.
fn face_sizes(mesh: &Mesh) -> Vec<f64> {
    let x = mesh.positions();
    mesh.faces()
        .iter()
        .map(|f| {
            (0..3)
                .map(|k| {
                    let (a, b) = (x[f[k] as usize], x[f[(k + 1) % 3] as usize]);
                    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
                })
                .fold(0.0, f64::max)
        })
        .collect()
}

impl PointMap {
    /// The point map of `embedding`, a map of `mesh` (the oriented mesh it
    /// was computed for). Whether h^-1 is defined comes from the embedding's
    /// own certificate, never from the caller. O(F log F).
    pub fn new(mesh: Arc<Mesh>, embedding: &Embedding) -> PointMap {
        match &embedding.details {
            Details::ThetaPhi(tp) => {
                let poles = [tp.poles.north, tp.poles.south];
                PointMap::theta_phi(mesh, tp.cut.mesh.faces(), &tp.theta_phi, poles, tp.tp_valid)
            }
            _ => {
                let report = &embedding.certificate;
                let flipped = report.n_negative + report.n_zero;
                PointMap::gc(mesh, &embedding.result.points, report.valid, flipped)
            }
        }
    }

    /// The theta-phi map h (6.6). `cut_faces` are the cut mesh's faces in the
    /// input's face order, `theta_phi` its rectangle embedding; `tp_valid` is
    /// the certificate of the rectangle (without it h is not one-to-one).
    fn theta_phi(
        mesh: Arc<Mesh>,
        cut_faces: &[[u32; 3]],
        theta_phi: &[[f64; 2]],
        poles: [u32; 2],
        tp_valid: bool,
    ) -> Self {
        let map = ThetaPhiMap::new(cut_faces, theta_phi, poles[0], poles[1]);
        let not_bijective = if !tp_valid {
            Some(
                "the theta-phi rectangle embedding is not certified flip-free (tp_valid is False)"
                    .to_string(),
            )
        } else {
            map.problem().map(str::to_string)
        };
        let sizes = face_sizes(&mesh);
        PointMap { mesh, inner: Inner::ThetaPhi(map), not_bijective, sizes, corners: None }
    }

    /// The barycentric map of 3.3 for a GC-embedding; `valid` is its verdict
    /// under the exact tests of 3.4 and `flipped` the number of failing faces.
    fn gc(mesh: Arc<Mesh>, points: &[[f64; 3]], valid: bool, flipped: usize) -> Self {
        let not_bijective = (!valid).then(|| {
            format!("the points are not a valid GC-embedding ({flipped} faces fail the orientation test of thesis 3.4)")
        });
        let inner = Inner::Gc(GcMap::new(mesh.faces(), points));
        let sizes = face_sizes(&mesh);
        PointMap { mesh, inner, not_bijective, sizes, corners: None }
    }

    /// The same map speaking in the caller's corner order: `caller_faces` are
    /// the faces the caller gave before they were oriented (the same faces in
    /// the same order, each possibly with its corners reversed), so that
    /// weights given to `to_sphere` and returned by `to_surface` refer to the
    /// caller's corners (issue 13, item 9). Faces that are not the same set
    /// of corners as the oriented ones are left as they are. O(F).
    pub fn in_corner_order_of(mut self, caller_faces: &[[u32; 3]]) -> PointMap {
        let ours = self.mesh.faces();
        if caller_faces.len() != ours.len() || caller_faces == ours {
            return self;
        }
        let corners = caller_faces
            .iter()
            .zip(ours)
            .map(|(theirs, mine)| {
                let at = |v: u32| mine.iter().position(|&x| x == v);
                match (at(theirs[0]), at(theirs[1]), at(theirs[2])) {
                    (Some(a), Some(b), Some(c)) if a != b && b != c && a != c => {
                        [a as u8, b as u8, c as u8]
                    }
                    _ => [0, 1, 2],
                }
            })
            .collect();
        self.corners = Some(corners);
        self
    }

    /// Caller's weights -> weights on `mesh`'s corners of face f.
    fn to_ours(&self, f: usize, w: [f64; 3]) -> [f64; 3] {
        match &self.corners {
            Some(c) => {
                let mut out = [0.0; 3];
                for k in 0..3 {
                    out[c[f][k] as usize] = w[k];
                }
                out
            }
            None => w,
        }
    }

    /// Weights on `mesh`'s corners of face f -> the caller's.
    fn to_theirs(&self, f: usize, w: [f64; 3]) -> [f64; 3] {
        match &self.corners {
            Some(c) => std::array::from_fn(|k| w[c[f][k] as usize]),
            None => w,
        }
    }

    /// Why h^-1 is not defined, if it is not.
    pub fn not_bijective(&self) -> Option<&str> {
        self.not_bijective.as_deref()
    }

    /// h: the sphere point of every (face, barycentric weights) pair.
    pub fn to_sphere(
        &self,
        face_ids: &[i64],
        bary: &[[f64; 3]],
    ) -> Result<Vec<[f64; 3]>, PointMapError> {
        self.to_sphere_with(face_ids, bary, &|_, _| true)
    }

    /// [`PointMap::to_sphere`], stopping with [`PointMapError::Cancelled`]
    /// when `progress(0, 0)`, polled between batches of points, says so.
    pub fn to_sphere_with(
        &self,
        face_ids: &[i64],
        bary: &[[f64; 3]],
        progress: &(dyn Fn(usize, usize) -> bool + Sync),
    ) -> Result<Vec<[f64; 3]>, PointMapError> {
        if face_ids.len() != bary.len() {
            return Err(PointMapError::LengthMismatch {
                faces: face_ids.len(),
                weights: bary.len(),
            });
        }
        let n_faces = self.mesh.n_faces();
        batched(face_ids.len(), progress, |rows| {
            let start = rows.start;
            face_ids[rows.clone()]
                .par_iter()
                .zip(bary[rows].par_iter())
                .enumerate()
                .map(|(k, (&face, &w))| {
                    let row = start + k;
                    if face < 0 || face as usize >= n_faces {
                        return Err(PointMapError::FaceOutOfRange { row, face, n_faces });
                    }
                    let w = self.to_ours(face as usize, checked_weights(row, w)?);
                    Ok(match &self.inner {
                        Inner::ThetaPhi(m) => m.to_sphere(face as u32, w),
                        Inner::Gc(m) => m.to_sphere(face as u32, w),
                    })
                })
                .collect()
        })
    }

    /// h^-1: for every unit vector, the face, the barycentric weights on it,
    /// the surface point and a bound on its error ([`SurfacePoints`]).
    pub fn to_surface(&self, points: &[[f64; 3]]) -> Result<SurfacePoints, PointMapError> {
        self.to_surface_with(points, &|_, _| true)
    }

    /// [`PointMap::to_surface`], stopping with [`PointMapError::Cancelled`]
    /// when `progress(0, 0)`, polled between batches of points, says so.
    pub fn to_surface_with(
        &self,
        points: &[[f64; 3]],
        progress: &(dyn Fn(usize, usize) -> bool + Sync),
    ) -> Result<SurfacePoints, PointMapError> {
        if let Some(why) = &self.not_bijective {
            return Err(PointMapError::NotBijective(why.clone()));
        }
        let located: Vec<(u32, [f64; 3], f64)> = batched(points.len(), progress, |rows| {
            let start = rows.start;
            let batch = &points[rows];
            // Checked in row order first: the first row off the sphere is
            // the one named.
            for (k, &p) in batch.iter().enumerate() {
                let norm = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                if (norm - 1.0).abs().is_nan() || (norm - 1.0).abs() > NORM_TOLERANCE {
                    return Err(PointMapError::NotOnSphere { row: start + k, point: p, norm });
                }
            }
            // Located in the Morton order of the points (spatial_order: one
            // point's walk down the tree finds the nodes the one before read
            // still in the cache) and written back to their rows; each
            // point's answer is its own, so the order changes no bits.
            let order = spatial_order(batch);
            // Each worker keeps the candidate faces of the last few
            // millionths it located (GcMap::to_surface_near): the points
            // after the first of a cluster skip the tree walk, with the same
            // answers.
            let answers: Vec<(u32, [f64; 3], f64)> = order
                .par_iter()
                .map_init(NearCache::default, |cache, &row| {
                    let p = batch[row as usize];
                    match &self.inner {
                        Inner::ThetaPhi(m) => {
                            let norm = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                            m.to_surface(p.map(|x| x / norm), &self.sizes)
                        }
                        // Containment is a sign of det[p, b, c], which scaling
                        // p does not change: the point as given is located,
                        // not its rounded normalisation.
                        Inner::Gc(m) => m.to_surface_near(p, &self.sizes, Some(cache)),
                    }
                })
                .collect();
            let mut out = vec![(0u32, [0.0; 3], 0.0); batch.len()];
            for (&row, answer) in order.iter().zip(answers) {
                out[row as usize] = answer;
            }
            Ok(out)
        })?;
        let mut xyz = memory_budget::reserved(located.len(), "the surface points")?;
        xyz.par_extend(located.par_iter().map(|&(f, w, _)| {
            let face = self.mesh.faces()[f as usize];
            let mut x = [0.0; 3];
            for k in 0..3 {
                let p = self.mesh.positions()[face[k] as usize];
                for i in 0..3 {
                    x[i] += w[k] * p[i];
                }
            }
            x
        }));
        let n = located.len();
        let mut out = SurfacePoints {
            faces: memory_budget::reserved(n, "the located faces")?,
            bary: memory_budget::reserved(n, "the barycentric weights")?,
            xyz,
            error: memory_budget::reserved(n, "the error bounds")?,
        };
        for (f, w, error) in located {
            out.faces.push(f);
            out.bary.push(self.to_theirs(f as usize, w));
            out.error.push(error);
        }
        Ok(out)
    }
}

/// Checks one row of user weights and rescales it to sum exactly 1.
fn checked_weights(row: usize, w: [f64; 3]) -> Result<[f64; 3], PointMapError> {
    let sum = w[0] + w[1] + w[2];
    let ok = w.iter().all(|&x| x.is_finite() && x >= -WEIGHT_TOLERANCE)
        && (sum - 1.0).abs() <= WEIGHT_TOLERANCE;
    if !ok {
        return Err(PointMapError::BadWeights { row, weights: w });
    }
    let c = w.map(|x| x.max(0.0));
    let s = c[0] + c[1] + c[2];
    Ok(c.map(|x| x / s))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::embed::{embed, Method};
    use crate::genus_zero::GenusZeroMesh;
    use crate::methods::theta_phi::ThetaPhiParams;
    use spherify_mesh::lcg::Lcg;
    use spherify_mesh::solids::{octahedron, tetrahedron};

    fn theta_phi_map(mesh: &Mesh) -> PointMap {
        let mesh = GenusZeroMesh::new(mesh.clone()).unwrap();
        let method = Method::ThetaPhi(ThetaPhiParams::default());
        let e = embed(&mesh, &method, &|_, _| true).unwrap();
        assert!(e.bijective());
        PointMap::new(mesh.shared_mesh(), &e)
    }

    fn round_trip(map: &PointMap, mesh: &Mesh, seed: u64) {
        assert_eq!(map.not_bijective(), None);
        let mut s = Lcg::new(seed);
        // Surface -> sphere -> surface, on corners, edges and insides of every face.
        let mut ids = Vec::new();
        let mut bary = Vec::new();
        for f in 0..mesh.n_faces() as i64 {
            for w in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.5, 0.5, 0.0]] {
                ids.push(f);
                bary.push(w);
            }
            let (a, b) = (s.next_f64(), s.next_f64());
            let (a, b) = if a + b > 1.0 { (1.0 - a, 1.0 - b) } else { (a, b) };
            ids.push(f);
            bary.push([a, b, 1.0 - a - b]);
        }
        let sphere = map.to_sphere(&ids, &bary).unwrap();
        let back = map.to_surface(&sphere).unwrap();
        assert!(back.error.iter().all(|&e| e < 1e-12), "{:?}", back.error);
        let xyz = back.xyz;
        for (row, (&f, w)) in ids.iter().zip(&bary).enumerate() {
            let face = mesh.faces()[f as usize];
            let want: Vec<f64> = (0..3)
                .map(|i| (0..3).map(|k| w[k] * mesh.positions()[face[k] as usize][i]).sum())
                .collect();
            let err = (0..3).map(|i| (want[i] - xyz[row][i]).abs()).fold(0.0, f64::max);
            assert!(err < 1e-9, "row {row} face {f} {w:?}: {err}");
        }
        // Sphere -> surface -> sphere on random points and the poles.
        let mut points: Vec<[f64; 3]> = (0..500)
            .map(|_| {
                let z = 2.0 * s.next_f64() - 1.0;
                let t = 2.0 * std::f64::consts::PI * s.next_f64();
                let r = (1.0 - z * z).sqrt();
                [r * t.cos(), r * t.sin(), z]
            })
            .collect();
        points.extend([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.6, 0.0, 0.8]]);
        let located = map.to_surface(&points).unwrap();
        let ids: Vec<i64> = located.faces.iter().map(|&f| f as i64).collect();
        let back = map.to_sphere(&ids, &located.bary).unwrap();
        for (p, q) in points.iter().zip(&back) {
            let err = (0..3).map(|i| (p[i] - q[i]).abs()).fold(0.0, f64::max);
            assert!(err < 1e-9, "{p:?} -> {q:?}");
        }
    }

    #[test]
    fn theta_phi_round_trips_on_the_octahedron_and_the_tetrahedron() {
        for mesh in [octahedron(), tetrahedron()] {
            let map = theta_phi_map(&mesh);
            round_trip(&map, &mesh, 3);
        }
    }

    #[test]
    fn gc_round_trips_on_the_octahedron() {
        let mesh = octahedron();
        let map = PointMap::gc(Arc::new(mesh.clone()), mesh.positions(), true, 0);
        round_trip(&map, &mesh, 5);
    }

    #[test]
    fn a_reversed_callers_corners_are_kept() {
        let mesh = octahedron();
        let reversed: Vec<[u32; 3]> = mesh.faces().iter().map(|&[a, b, c]| [c, b, a]).collect();
        let plain = PointMap::gc(Arc::new(mesh.clone()), mesh.positions(), true, 0);
        let theirs = plain.clone().in_corner_order_of(&reversed);
        let w = [0.2, 0.3, 0.5];
        for f in 0..8i64 {
            let want = plain.to_sphere(&[f], &[w]).unwrap();
            assert_eq!(theirs.to_sphere(&[f], &[[w[2], w[1], w[0]]]).unwrap(), want);
            let back = theirs.to_surface(&want).unwrap();
            let b = back.bary[0];
            let x: Vec<f64> = (0..3)
                .map(|i| {
                    (0..3)
                        .map(|k| {
                            b[k] * mesh.positions()[reversed[back.faces[0] as usize][k] as usize][i]
                        })
                        .sum()
                })
                .collect();
            assert!((0..3).all(|i| (x[i] - back.xyz[0][i]).abs() < 1e-15), "{x:?} {:?}", back.xyz);
        }
    }

    #[test]
    fn bad_input_is_named_by_row() {
        let mesh = octahedron();
        let map = PointMap::gc(Arc::new(mesh.clone()), mesh.positions(), true, 0);
        let err = map.to_sphere(&[0, 8], &[[1.0, 0.0, 0.0]; 2]).unwrap_err();
        assert!(matches!(err, PointMapError::FaceOutOfRange { row: 1, face: 8, .. }));
        let err = map.to_sphere(&[0], &[[0.5, 0.6, 0.0]]).unwrap_err();
        assert!(matches!(err, PointMapError::BadWeights { row: 0, .. }));
        let err = map.to_surface(&[[0.0, 0.0, 1.0], [0.0, 0.0, 2.0]]).unwrap_err();
        assert!(matches!(err, PointMapError::NotOnSphere { row: 1, .. }));
        let invalid = PointMap::gc(Arc::new(mesh.clone()), mesh.positions(), false, 3);
        assert!(matches!(
            invalid.to_surface(&[[0.0, 0.0, 1.0]]),
            Err(PointMapError::NotBijective(_))
        ));
    }
}
