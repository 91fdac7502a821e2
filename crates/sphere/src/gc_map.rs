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

use spherify_mesh::vec3::{cross, det3, dot, norm, scale};

use crate::bvh::{Aabb, Bvh};

/// The GC map of one embedding.
#[derive(Debug, Clone)]
pub struct GcMap {
    faces: Vec<[u32; 3]>,
    points: Vec<[f64; 3]>,
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
        GcMap { faces: faces.to_vec(), points: points.to_vec(), locator: Bvh::new(&boxes) }
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

    /// The weights of `p` in face `f` and how far inside the face it lies
    /// (the smallest weight; negative outside, NaN on the far side of the sphere).
    fn face_weights(&self, f: u32, p: [f64; 3]) -> ([f64; 3], f64) {
        let [a, b, c] = self.faces[f as usize].map(|v| self.points[v as usize]);
        let w = [det3(p, b, c), det3(a, p, c), det3(a, b, p)];
        let sum = w[0] + w[1] + w[2];
        if sum.is_nan() || sum <= 0.0 {
            return (w, f64::NAN);
        }
        let w = w.map(|x| x / sum);
        (w, w[0].min(w[1]).min(w[2]))
    }

    /// h^-1 (3.3): the face and weights of the surface point mapped to the unit
    /// vector `p`.
    pub fn to_surface(&self, p: [f64; 3]) -> (u32, [f64; 3]) {
        let consider = |f: u32, best: &mut Option<(u32, [f64; 3], f64)>| {
            let (w, score) = self.face_weights(f, p);
            if score.is_finite() && best.as_ref().is_none_or(|b| score > b.2) {
                *best = Some((f, w, score));
            }
        };
        let mut best = None;
        self.locator.for_each_containing(&p, 1e-12, |f| consider(f, &mut best));
        if best.is_none() {
            // The boxes cover the sphere, so this is a safety net only.
            for f in 0..self.faces.len() as u32 {
                consider(f, &mut best);
            }
        }
        let (f, w, _) = best.unwrap_or((0, [1.0, 0.0, 0.0], 0.0));
        (f, crate::h_map::clamp_weights(w))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::solids::octahedron;

    #[test]
    fn octahedron_round_trips() {
        let mesh = octahedron();
        let map = GcMap::new(mesh.faces(), mesh.positions());
        for f in 0..8u32 {
            for w in [[0.2, 0.3, 0.5], [1.0, 0.0, 0.0], [0.0, 0.5, 0.5], [1.0 / 3.0; 3]] {
                let p = map.to_sphere(f, w);
                let (g, w2) = map.to_surface(p);
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
