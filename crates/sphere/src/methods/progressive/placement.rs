//! Where a re-inserted vertex goes (thesis 9.3.3): the point of its ring's
//! kernel farthest from the kernel's edges.
//!
//! The new vertex `u` with ring `r_0 .. r_k` (`r_0` the vertex it was
//! collapsed into) owns the faces `(u, r_j, r_j+1)`, which are positive
//! exactly when `n_j . u > 0` with `n_j = r_j x r_j+1`: the kernel is a convex
//! cone. In the gnomonic chart of a centre `c` (points `c + y1 e1 + y2 e2` of
//! the tangent plane, where great circles are straight lines) it is a convex
//! polygon; we clip a box by the kernel's half-planes (Sutherland-Hodgman),
//! then find the polygon's Chebyshev centre, the centre of its largest
//! inscribed disc, among the points fixed by three of its edges. Every
//! candidate is tested with the exact predicate after normalisation, on the
//! doubles that will be stored.

use spherify_mesh::vec3::{add, cross, det3, dot, scale};

use crate::embedding::normalize;
use crate::methods::progressive::flip_free::{positive_star, tangent_basis};

/// Half-width of the chart window: about 76 degrees from the centre.
const WINDOW: f64 = 4.0;
/// Kernel polygons with more edges than this use their vertex mean instead of
/// the O(m^3) Chebyshev search.
const MAX_CHEBYSHEV_EDGES: usize = 24;

/// A half-plane `alpha + beta . y >= 0` with `|beta| = 1`.
#[derive(Debug, Clone, Copy)]
struct HalfPlane {
    alpha: f64,
    beta: [f64; 2],
}

impl HalfPlane {
    fn at(&self, y: [f64; 2]) -> f64 {
        self.alpha + self.beta[0] * y[0] + self.beta[1] * y[1]
    }
}

/// The buffers of [`place_with`], kept between calls: a placement made a
/// dozen small allocations (one per clipping half-plane among them), about
/// as long as its arithmetic at a million placements per map.
#[derive(Debug, Default)]
pub struct Scratch {
    normals: Vec<[f64; 3]>,
    planes: Vec<HalfPlane>,
    polygon: Vec<([f64; 2], usize)>,
    clipped: Vec<([f64; 2], usize)>,
    lines: Vec<HalfPlane>,
}

/// A point for a vertex with ring `ring` (positions `points`) at which every
/// new face is positive under the exact test, or `None` when none of the
/// candidates passes (a kernel too thin for doubles).
pub fn place(ring: &[u32], points: &[[f64; 3]]) -> Option<[f64; 3]> {
    place_with(ring, points, &mut Scratch::default())
}

/// [`place`] with its buffers in `scratch` (the same point).
pub fn place_with(ring: &[u32], points: &[[f64; 3]], scratch: &mut Scratch) -> Option<[f64; 3]> {
    let Scratch { normals, planes, polygon, clipped, lines } = scratch;
    normals.clear();
    normals.extend(
        (0..ring.len())
            .map(|j| cross(points[ring[j] as usize], points[ring[(j + 1) % ring.len()] as usize])),
    );
    let mean = ring.iter().fold([0.0; 3], |s, &r| add(s, points[r as usize]));
    let centre = match normalize(mean) {
        Some(c) if normals.iter().all(|n| dot(*n, c) > 0.0) => c,
        // The ring's mean is outside the kernel: chart around the vertex
        // the new one was collapsed into, which is on the kernel's boundary.
        _ => points[ring[0] as usize],
    };
    let (e1, e2) = tangent_basis(centre);
    planes.clear();
    for n in normals.iter() {
        let beta = [dot(*n, e1), dot(*n, e2)];
        let len = beta[0].hypot(beta[1]);
        let alpha = dot(*n, centre);
        if len > 0.0 && len.is_finite() {
            planes.push(HalfPlane { alpha: alpha / len, beta: [beta[0] / len, beta[1] / len] });
        } else if alpha.is_nan() || alpha <= 0.0 {
            return None;
        }
    }
    for beta in [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]] {
        planes.push(HalfPlane { alpha: WINDOW, beta });
    }
    kernel_polygon(planes, polygon, clipped);
    if polygon.len() < 3 {
        return None;
    }
    let to_sphere = |y: [f64; 2]| normalize(add(centre, add(scale(e1, y[0]), scale(e2, y[1]))));
    let chebyshev = if polygon.len() <= MAX_CHEBYSHEV_EDGES {
        chebyshev_centre(polygon, planes, lines)
    } else {
        None
    };
    let m = polygon.len() as f64;
    let mean = polygon.iter().fold([0.0; 2], |s, v| [s[0] + v.0[0] / m, s[1] + v.0[1] / m]);
    [chebyshev, Some(mean)]
        .into_iter()
        .flatten()
        .filter_map(to_sphere)
        .find(|&q| positive_star(q, ring, points))
}

/// The window clipped by every half-plane, into `poly`: vertices in order,
/// each with the index of the half-plane whose line carries the edge leaving
/// it (`out` is the buffer of each clip).
fn kernel_polygon(
    planes: &[HalfPlane],
    poly: &mut Vec<([f64; 2], usize)>,
    out: &mut Vec<([f64; 2], usize)>,
) {
    let n = planes.len();
    // The window itself, counter-clockwise; its four planes are the last
    // four: y0 >= -W, y0 <= W, y1 >= -W, y1 <= W.
    poly.clear();
    poly.extend([
        ([WINDOW, -WINDOW], n - 3),
        ([WINDOW, WINDOW], n - 1),
        ([-WINDOW, WINDOW], n - 4),
        ([-WINDOW, -WINDOW], n - 2),
    ]);
    for (index, plane) in planes.iter().enumerate().take(n - 4) {
        out.clear();
        for j in 0..poly.len() {
            let (a, label) = poly[j];
            let b = poly[(j + 1) % poly.len()].0;
            let (fa, fb) = (plane.at(a), plane.at(b));
            if fa >= 0.0 {
                out.push((a, label));
            }
            if (fa >= 0.0) != (fb >= 0.0) {
                let t = fa / (fa - fb);
                let x = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
                // Entering the half-plane: the edge from x continues along
                // the old edge; leaving: the edge from x runs along this line.
                out.push((x, if fa >= 0.0 { index } else { label }));
            }
        }
        std::mem::swap(poly, out);
        if poly.len() < 3 {
            return;
        }
    }
}

/// The point of the polygon farthest from its edges, among the points equally
/// far from three edge lines.
fn chebyshev_centre(
    polygon: &[([f64; 2], usize)],
    planes: &[HalfPlane],
    lines: &mut Vec<HalfPlane>,
) -> Option<[f64; 2]> {
    lines.clear();
    lines.extend(polygon.iter().map(|&(_, i)| planes[i]));
    let m = lines.len();
    let mut best: Option<([f64; 2], f64)> = None;
    for i in 0..m {
        for j in i + 1..m {
            for l in j + 1..m {
                // alpha + beta . y = s for the three lines: unknowns (y0, y1, s).
                let rows = [lines[i], lines[j], lines[l]];
                let a = rows.map(|p| [p.beta[0], p.beta[1], -1.0]);
                let b = rows.map(|p| -p.alpha);
                // The radius first: most triples give no larger disc than
                // the best so far, and their centres are not needed.
                let Some(s) = solve3_radius(a, b) else { continue };
                if s <= 0.0 || best.is_some_and(|(_, bs)| s <= bs) {
                    continue;
                }
                let Some([y0, y1]) = solve3_centre(a, b) else { continue };
                let tolerance = 1e-12 * (1.0 + s);
                if lines.iter().all(|p| p.at([y0, y1]) >= s - tolerance) {
                    best = Some(([y0, y1], s));
                }
            }
        }
    }
    best.map(|(y, _)| y)
}

/// The last unknown of `a x = b` (Cramer's rule, as
/// [`spherify_mesh::vec3::solve3`] computes it, bit for bit), or `None` when
/// `a` is nearly singular or it is not finite.
fn solve3_radius(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<f64> {
    let det = det3(a[0], a[1], a[2]);
    if det.abs() < 1e-14 || !det.is_finite() {
        return None;
    }
    let s = cramer(a, b, 2, det);
    s.is_finite().then_some(s)
}

/// The first two unknowns of the same system, once its last is known to
/// be wanted (`a` already found regular), or `None` when one is not finite.
/// Each unknown of Cramer's rule is computed on its own, so the three are
/// those of `solve3`.
fn solve3_centre(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 2]> {
    let det = det3(a[0], a[1], a[2]);
    let y = [cramer(a, b, 0, det), cramer(a, b, 1, det)];
    y.iter().all(|v| v.is_finite()).then_some(y)
}

/// `x_k` of `a x = b` by Cramer's rule, `det` being `a`'s determinant: the
/// expression of [`spherify_mesh::vec3::solve3`].
fn cramer(a: [[f64; 3]; 3], b: [f64; 3], k: usize, det: f64) -> f64 {
    let mut ak = a;
    (0..3).for_each(|r| ak[r][k] = b[r]);
    det3(ak[0], ak[1], ak[2]) / det
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::vec3::norm;

    fn ring_points(n: usize, radius: f64, centre_offset: [f64; 2]) -> Vec<[f64; 3]> {
        (0..n)
            .map(|j| {
                let a = std::f64::consts::TAU * j as f64 / n as f64;
                normalize([
                    centre_offset[0] + radius * a.cos(),
                    centre_offset[1] + radius * a.sin(),
                    1.0,
                ])
                .unwrap()
            })
            .collect()
    }

    #[test]
    fn a_regular_ring_gets_its_centre() {
        let points = ring_points(6, 0.1, [0.0, 0.0]);
        let ring: Vec<u32> = (0..6).collect();
        let q = place(&ring, &points).unwrap();
        assert!(norm(sub3(q, [0.0, 0.0, 1.0])) < 1e-9, "{q:?}");
    }

    fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }

    #[test]
    fn a_non_convex_ring_gets_a_point_of_its_kernel() {
        // An arrow-shaped ring: the centroid of the vertices is outside the
        // kernel near the notch, the Chebyshev centre is inside.
        let flat = [[0.0, -1.0], [1.0, -1.0], [1.0, 1.0], [0.0, 1.0], [0.9, 0.0]];
        let points: Vec<[f64; 3]> =
            flat.iter().map(|p| normalize([0.05 * p[0], 0.05 * p[1], 1.0]).unwrap()).collect();
        let ring: Vec<u32> = (0..5).collect();
        let q = place(&ring, &points).unwrap();
        assert!(positive_star(q, &ring, &points));
        // Deep inside: farther than 1/5 of the half-height from the notch lines.
        assert!(q[0] / q[2] > 0.9 * 0.05, "{q:?}");
    }

    /// The Chebyshev search as it was before the radius was solved first:
    /// all three unknowns by `solve3`, then the tests.
    fn chebyshev_all_unknowns(lines: &[HalfPlane]) -> Option<[f64; 2]> {
        let m = lines.len();
        let mut best: Option<([f64; 2], f64)> = None;
        for i in 0..m {
            for j in i + 1..m {
                for l in j + 1..m {
                    let rows = [lines[i], lines[j], lines[l]];
                    let a = rows.map(|p| [p.beta[0], p.beta[1], -1.0]);
                    let b = rows.map(|p| -p.alpha);
                    let det = det3(a[0], a[1], a[2]);
                    if det.abs() < 1e-14 || !det.is_finite() {
                        continue;
                    }
                    let [y0, y1, s] = spherify_mesh::vec3::solve3(a, b);
                    if ![y0, y1, s].iter().all(|v| v.is_finite()) {
                        continue;
                    }
                    if s <= 0.0 || best.is_some_and(|(_, bs)| s <= bs) {
                        continue;
                    }
                    let tolerance = 1e-12 * (1.0 + s);
                    if lines.iter().all(|p| p.at([y0, y1]) >= s - tolerance) {
                        best = Some(([y0, y1], s));
                    }
                }
            }
        }
        best.map(|(y, _)| y)
    }

    #[test]
    fn the_radius_first_gives_the_same_centre_bit_for_bit() {
        let mut rng = spherify_mesh::lcg::Lcg::new(9);
        let mut lines = Vec::new();
        for case in 0..3000 {
            let m = 3 + case % 10;
            let planes: Vec<HalfPlane> = (0..m)
                .map(|j| {
                    // Nearly regular polygons, some lines repeated or
                    // parallel (singular triples), some far apart.
                    let angle = if case % 7 == 0 && j > 0 {
                        std::f64::consts::TAU * (j / 2) as f64 / m as f64
                    } else {
                        std::f64::consts::TAU * (j as f64 + 0.5 * rng.next_f64()) / m as f64
                    };
                    let alpha = if case % 5 == 0 { 1.0 } else { 0.1 + rng.next_f64() };
                    HalfPlane { alpha, beta: [-angle.cos(), -angle.sin()] }
                })
                .collect();
            let polygon: Vec<([f64; 2], usize)> = (0..m).map(|i| ([0.0, 0.0], i)).collect();
            let new = chebyshev_centre(&polygon, &planes, &mut lines);
            let old = chebyshev_all_unknowns(&planes);
            assert_eq!(new.map(|y| y.map(f64::to_bits)), old.map(|y| y.map(f64::to_bits)));
        }
    }

    #[test]
    fn an_empty_kernel_gives_none() {
        // A clockwise ring: no point sees it counter-clockwise.
        let mut points = ring_points(5, 0.1, [0.0, 0.0]);
        points.reverse();
        let ring: Vec<u32> = (0..5).collect();
        assert_eq!(place(&ring, &points), None);
    }
}
