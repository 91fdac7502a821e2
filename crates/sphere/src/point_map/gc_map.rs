//! The map between the surface and the sphere given by a valid GC-embedding
//! (thesis 3.3, Prop. 3.3), and its inverse.
//!
//! A point with barycentric weights w on face (a, b, c) goes to the central
//! projection of the same weights of the sphere triangle's corners:
//! h(x) = (w_a v_a + w_b v_b + w_c v_c) / |...|. Back, a unit vector p lies in
//! the spherical triangle (v_a, v_b, v_c) when det(p, v_b, v_c), det(v_a, p, v_c)
//! and det(v_a, v_b, p) are all >= 0, and those three determinants, scaled to
//! sum 1, are the weights whose projection is p (the ray through p meets the
//! flat triangle at the point with these weights). Both directions are only a
//! bijection when the embedding is valid (3.4); callers check that first.

use spherify_mesh::predicates::{det3_sign, Sign};
use spherify_mesh::vec3::{cross, det3, dot, norm, scale};

use crate::point_map::bvh::{Aabb, Bvh, NearCache};
use crate::point_map::weight_bound::{clamp_weights, ratio_weights, Candidates, UNIT_ROUNDOFF};

/// The slack of point location's box tests (far more than the boxes'
/// outward rounding).
const BOX_SLACK: f64 = 1e-10;
/// How far around a point [`GcMap::to_surface_near`] gathers the candidate
/// faces for the points after it: a Gauss-Newton probe is a step of 1e-6
/// (spherify._align) from its residual's point, so a step's seven (or
/// thirteen) points of one vertex lie within about 2e-6 of each other.
const NEAR_REACH: f64 = 4e-6;

/// The GC map of one embedding.
#[derive(Debug, Clone)]
pub struct GcMap {
    faces: Vec<[u32; 3]>,
    points: Vec<[f64; 3]>,
    /// det[a, b, c] of every face (positive in a valid embedding).
    dets: Vec<f64>,
    /// |v| of every point (1 up to rounding for a map's points).
    lengths: Vec<f64>,
    locator: Bvh<3>,
}

/// A box holding the spherical triangle (v_a, v_b, v_c): its points are
/// q / |q| for q in the flat triangle, and d <= |q| <= 1 where d is the flat
/// triangle's distance from the centre, so they lie between the flat triangle
/// and its copy scaled by 1 / d. Triangles reaching a hemisphere or more get
/// the whole cube.
fn spherical_box(t: [[f64; 3]; 3]) -> Aabb<3> {
    let normal = cross(
        [t[1][0] - t[0][0], t[1][1] - t[0][1], t[1][2] - t[0][2]],
        [t[2][0] - t[0][0], t[2][1] - t[0][1], t[2][2] - t[0][2]],
    );
    let length = norm(normal);
    let d = if length > 0.0 { dot(normal, t[0]) / length } else { 0.0 };
    if d.is_nan() || d <= 1e-3 {
        return Aabb { min: [-1.0; 3], max: [1.0; 3] };
    }
    let grown = t.map(|p| scale(p, 1.0 / d));
    let corners = [t[0], t[1], t[2], grown[0], grown[1], grown[2]];
    let mut b = Aabb::around(&corners);
    for i in 0..3 {
        b.min[i] = b.min[i].max(-1.0);
        b.max[i] = b.max[i].min(1.0);
    }
    b
}

impl GcMap {
    /// Builds the map and its point-location tree.
    pub fn new(faces: &[[u32; 3]], points: &[[f64; 3]]) -> Self {
        let boxes: Vec<Aabb<3>> =
            faces.iter().map(|f| spherical_box(f.map(|v| points[v as usize]))).collect();
        let dets = faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|v| points[v as usize]);
                det3(a, b, c)
            })
            .collect();
        let lengths = points.iter().map(|&p| norm(p)).collect();
        GcMap {
            faces: faces.to_vec(),
            points: points.to_vec(),
            dets,
            lengths,
            locator: Bvh::new(&boxes),
        }
    }

    /// h (3.3): the unit vector for weights `w` on face `f`.
    pub fn to_sphere(&self, f: u32, w: [f64; 3]) -> [f64; 3] {
        let face = self.faces[f as usize];
        let mut q = [0.0; 3];
        for k in 0..3 {
            let p = self.points[face[k] as usize];
            for i in 0..3 {
                q[i] += w[k] * p[i];
            }
        }
        let n = norm(q);
        if n > 0.0 {
            scale(q, 1.0 / n)
        } else {
            // Only antipodal corners can cancel, which a valid embedding has not.
            [f64::NAN; 3]
        }
    }

    /// The weights of `p` (a unit vector) in face `f`, with what point
    /// location needs: whether the closed spherical triangle holds `p`
    /// exactly, whether some point within the rounding error of
    /// [`GcMap::to_sphere`] of `p` lies in it, and a bound on sum |w - w'|
    /// over the exact weights w' of every such point ([`ratio_weights`]).
    fn face_weights(&self, f: u32, p: [f64; 3]) -> FaceWeights {
        let face = self.faces[f as usize];
        let [a, b, c] = face.map(|v| self.points[v as usize]);
        let crosses = [cross(b, c), cross(c, a), cross(a, b)];
        let d = crosses.map(|n| dot(p, n));
        // to_sphere projects a point q of the flat triangle with an error of a
        // few u relative to |q|, and |q| = det[a, b, c] / (p . n) with n the sum
        // of the crosses, which is d's sum: so p stands for every unit vector
        // within delta of it, and a move by delta moves d_i by delta |cross_i|.
        // Points of the cone have p . n >= det[a, b, c] and p . n <= |n| <= 3, so
        // |q| >= det / 3 there: that bounds delta when the sum says nothing (p
        // on the far side).
        let sum = d[0] + d[1] + d[2];
        let det = self.dets[f as usize];
        let q = if sum > 0.0 && sum < 3.0 { det / sum } else { det / 3.0 };
        let delta = 16.0 * UNIT_ROUNDOFF * (1.0 + 1.0 / q.max(f64::MIN_POSITIVE));
        // Most candidates of the box tree are plainly outside: reject them on
        // a cheap bound first (the permanent is at most the product of the
        // rows' 1-norms, <= 3^1.5 times the product of their lengths, and
        // |b x c| <= |b| |c|), before the exact bounds below.
        let [la, lb, lc] = face.map(|v| self.lengths[v as usize]);
        let lp = norm(p);
        let pairs = [lb * lc, lc * la, la * lb];
        if (0..3).any(|i| d[i] + (8.0 * UNIT_ROUNDOFF * 5.2 * lp + delta) * pairs[i] < 0.0) {
            return FaceWeights {
                w: d.map(|x| x / sum),
                bound: f64::INFINITY,
                contains: false,
                near: false,
            };
        }
        let rows = [[p, b, c], [a, p, c], [a, b, p]];
        // det3 as dot(p, cross) is within 8 u of its permanent (a forward
        // error bound of the six-product sum, with room to spare).
        let eval_error = rows.map(|r| 8.0 * UNIT_ROUNDOFF * permanent(r));
        let e: [f64; 3] = std::array::from_fn(|i| eval_error[i] + delta * norm(crosses[i]));
        let near = (0..3).all(|i| d[i] + e[i] >= 0.0);
        let contains = near
            && (0..3).all(|i| {
                if d[i] > eval_error[i] {
                    true
                } else if d[i] < -eval_error[i] {
                    false
                } else {
                    let [x, y, z] = rows[i];
                    det3_sign(x, y, z) != Sign::Negative
                }
            });
        let (w, bound) = ratio_weights(d, e);
        FaceWeights { w, bound, contains, near }
    }

    /// h^-1 (3.3): the face and weights of the surface point mapped to the unit
    /// vector `p`, and a bound on the distance of that surface point from the
    /// exact preimage of every sphere point within the rounding error of
    /// [`GcMap::to_sphere`] of `p` (`sizes[f]`: the longest edge of surface
    /// face f). Infinite when the digits of `p` cannot say where it came from.
    ///
    /// Containment is decided with exact predicates (the signs of det[p, b, c],
    /// det[a, p, c], det[a, b, p]): in a valid GC-embedding the closed
    /// spherical triangles cover the sphere, so some face holds `p` exactly,
    /// however thin the triangles are; among those the best conditioned one
    /// answers. The bound is the worst over every face that a point within
    /// the rounding error could lie in, since the preimage may be there.
    pub fn to_surface(&self, p: [f64; 3], sizes: &[f64]) -> (u32, [f64; 3], f64) {
        self.to_surface_near(p, sizes, None)
    }

    /// [`GcMap::to_surface`], the candidate faces taken from `cache` where
    /// `p` lies in the region it last gathered ([`Bvh::for_each_box_containing_near`]:
    /// the same faces in the same order, so the same answer to the bit).
    pub fn to_surface_near(
        &self,
        p: [f64; 3],
        sizes: &[f64],
        cache: Option<&mut NearCache<3>>,
    ) -> (u32, [f64; 3], f64) {
        let mut found = Candidates::default();
        let consider = |f: u32, found: &mut Candidates| {
            let fw = self.face_weights(f, p);
            let score = fw.w[0].min(fw.w[1]).min(fw.w[2]);
            found.offer(f, fw.w, fw.bound * sizes[f as usize], fw.contains, fw.near, score);
        };
        // The boxes are rounded outward by far less than this slack. A face
        // whose own box (so grown) misses p neither holds p nor any point
        // within the rounding error of it: its offer would only be a
        // fallback, which is not used when some face holds p (and when none
        // does, every face is offered below). So only the faces whose box
        // holds p are weighed, in the order of the tree's leaves as before.
        match cache {
            Some(cache) => {
                self.locator.for_each_box_containing_near(&p, BOX_SLACK, NEAR_REACH, cache, |x| {
                    consider(x, &mut found)
                })
            }
            None => {
                self.locator.for_each_box_containing(&p, BOX_SLACK, |x| consider(x, &mut found))
            }
        }
        if !found.found() {
            // The boxes cover the sphere, so this is a safety net only.
            for f in 0..self.faces.len() as u32 {
                consider(f, &mut found);
            }
        }
        let (f, w, bound) = found.answer();
        (f, clamp_weights(w), bound)
    }
}

/// What [`GcMap::face_weights`] finds.
struct FaceWeights {
    w: [f64; 3],
    bound: f64,
    contains: bool,
    near: bool,
}

/// The sum of the absolute values of the six products of det[x; y; z].
fn permanent([x, y, z]: [[f64; 3]; 3]) -> f64 {
    let ab = |v: [f64; 3]| v.map(f64::abs);
    let (x, y, z) = (ab(x), ab(y), ab(z));
    x[0] * (y[1] * z[2] + y[2] * z[1])
        + x[1] * (y[0] * z[2] + y[2] * z[0])
        + x[2] * (y[0] * z[1] + y[1] * z[0])
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::lcg::Lcg;
    use spherify_mesh::solids::{icosphere, octahedron};

    #[test]
    fn near_location_gives_the_same_bits() {
        // Clusters of sphere points a few millionths apart (Gauss-Newton's
        // probes), some on vertices and edges: the cached candidates give
        // the walk's answers to the bit.
        let mesh = icosphere(3);
        let points: Vec<[f64; 3]> =
            mesh.positions().iter().map(|&p| scale(p, 1.0 / norm(p))).collect();
        let map = GcMap::new(mesh.faces(), &points);
        let sizes = vec![0.1; mesh.n_faces()];
        let mut cache = NearCache::default();
        let mut s = Lcg::new(5);
        for k in 0..300 {
            let base = if k % 3 == 0 {
                points[k % points.len()]
            } else {
                let f = (s.next_f64() * mesh.n_faces() as f64) as u32;
                let w = if k % 3 == 1 { [0.5, 0.5, 0.0] } else { [s.next_f64(), 0.3, 0.2] };
                let t = w[0] + w[1] + w[2];
                map.to_sphere(f, w.map(|x| x / t))
            };
            for j in 0..7 {
                let d = if j == 0 { 0.0 } else { 2e-6 };
                let q: [f64; 3] = std::array::from_fn(|i| base[i] + d * (s.next_f64() - 0.5));
                let q = scale(q, 1.0 / norm(q));
                let walk = map.to_surface(q, &sizes);
                let near = map.to_surface_near(q, &sizes, Some(&mut cache));
                assert_eq!(walk.0, near.0);
                assert_eq!(walk.1.map(f64::to_bits), near.1.map(f64::to_bits));
                assert_eq!(walk.2.to_bits(), near.2.to_bits());
            }
        }
    }

    #[test]
    fn octahedron_round_trips() {
        let mesh = octahedron();
        let map = GcMap::new(mesh.faces(), mesh.positions());
        let sizes = [1.0; 8];
        for f in 0..8u32 {
            for w in [[0.2, 0.3, 0.5], [1.0, 0.0, 0.0], [0.0, 0.5, 0.5], [1.0 / 3.0; 3]] {
                let p = map.to_sphere(f, w);
                let (g, w2, bound) = map.to_surface(p, &sizes);
                assert!(bound < 1e-13, "{bound}");
                let back = map.to_sphere(g, w2);
                let err = (0..3).map(|i| (back[i] - p[i]).abs()).fold(0.0, f64::max);
                assert!(err < 1e-14, "face {f} {w:?}: {err}");
                if w.iter().all(|&x| x > 0.0) {
                    assert_eq!(g, f);
                    assert!((0..3).all(|i| (w2[i] - w[i]).abs() < 1e-12));
                }
            }
        }
    }
}
