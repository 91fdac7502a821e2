//! The pole cells of h2 (thesis 6.6.2, eq. 6.44-6.56): a triangle (P, A, B)
//! with a pole corner P stretched into the quadrilateral (T_A, A, B, T_B), its
//! bilinear inverse, the flat triangles cut off cells with a straight angle,
//! and the exact convexity test that makes a cell one-to-one.

use spherify_mesh::predicates::{orient2d, Sign};
use spherify_mesh::vec3::det3;

/// One stretched pole triangle (P, A, B) of h2. A and B are given as
/// barycentric weights on the face's corners, since c of a two-pole face is
/// not a vertex.
#[derive(Debug, Clone)]
pub(super) struct PoleCell {
    pub(super) face: u32,
    pub(super) pole_corner: usize,
    pub(super) pole_theta: f64,
    pub(super) a: [f64; 3],
    pub(super) b: [f64; 3],
    pub(super) ua: [f64; 2],
    pub(super) ub: [f64; 2],
    pub(super) psi_a: f64,
    pub(super) psi_b: f64,
    /// psi equals phi at A and B: the thesis's trapezium, inverted in closed form.
    pub(super) vertical: bool,
}

/// A triangle cut off a pole cell whose quadrilateral would have a straight
/// angle (see [`split_straight_angles`]); h2 is linear on it. Corners are
/// barycentric weights on the face's corners, positions are in the rectangle.
#[derive(Debug, Clone)]
pub(super) struct FlatPiece {
    pub(super) face: u32,
    pub(super) corners: [[f64; 3]; 3],
    pub(super) positions: [[f64; 2]; 3],
}

pub(super) fn lerp2(a: [f64; 2], b: [f64; 2], t: f64) -> [f64; 2] {
    [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
}

pub(super) fn cross2(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

pub(super) fn sub2(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

/// Solves w = s_0 x + s_1 y + s_2 z for (s_0, s_1, s_2) (Cramer's rule): the
/// weights of a face point in a piece whose corners x, y, z are themselves
/// given by weights on the face's corners.
pub(super) fn piece_weights([x, y, z]: [[f64; 3]; 3], w: [f64; 3]) -> [f64; 3] {
    let d = det3(x, y, z);
    [det3(w, y, z) / d, det3(x, w, z) / d, det3(x, y, w) / d]
}

pub(super) fn corner_vector(corner: usize) -> [f64; 3] {
    let mut e = [0.0; 3];
    e[corner] = 1.0;
    e
}

pub(super) fn combine(x: [f64; 3], y: [f64; 3], t: f64) -> [f64; 3] {
    [x[0] + t * (y[0] - x[0]), x[1] + t * (y[1] - x[1]), x[2] + t * (y[2] - x[2])]
}

impl PoleCell {
    /// (s_P, s_A, s_B) of the face point with weights `w`.
    pub(super) fn weights(&self, w: [f64; 3]) -> [f64; 3] {
        piece_weights([corner_vector(self.pole_corner), self.a, self.b], w)
    }

    pub(super) fn top(&self, psi: f64) -> [f64; 2] {
        [self.pole_theta, psi]
    }

    /// The corners (T_A, A, B, T_B), counter-clockwise in a valid embedding.
    pub(super) fn corners(&self) -> [[f64; 2]; 4] {
        [self.top(self.psi_a), self.ua, self.ub, self.top(self.psi_b)]
    }

    /// h2 on the cell, from weights (s_P, s_A, s_B) with s_P < 1 (eq. 6.49-6.50).
    pub(super) fn forward(&self, s: [f64; 3]) -> [f64; 2] {
        let mu = s[1] + s[2];
        let lambda = s[1] / mu;
        let v = lerp2(self.ub, self.ua, lambda);
        let t = self.top(self.psi_b + lambda * (self.psi_a - self.psi_b));
        lerp2(t, v, mu)
    }

    /// h2^-1 on the cell: (lambda, mu) with u = forward(lambda mu, ...).
    pub(super) fn inverse(&self, u: [f64; 2]) -> (f64, f64) {
        if self.vertical {
            // Eq. 6.53-6.56: phi picks the vertical line, theta the height on it.
            let lambda = (u[1] - self.psi_b) / (self.psi_a - self.psi_b);
            let v = lerp2(self.ub, self.ua, lambda);
            let mu = (u[0] - self.pole_theta) / (v[0] - self.pole_theta);
            return (lambda, mu);
        }
        // u = T_B + lambda e + mu f + lambda mu g, solved for lambda by
        // eliminating mu: cross(q - lambda e, f + lambda g) = 0.
        let tb = self.top(self.psi_b);
        let ta = self.top(self.psi_a);
        let e = sub2(ta, tb);
        let f = sub2(self.ub, tb);
        let g = sub2(sub2(self.ua, self.ub), e);
        let q = sub2(u, tb);
        let qa = -cross2(e, g);
        let qb = cross2(q, g) - cross2(e, f);
        let qc = cross2(q, f);
        let scale = qa.abs().max(qb.abs()).max(qc.abs()).max(f64::MIN_POSITIVE);
        let mut candidates = Vec::with_capacity(2);
        if qa.abs() <= 1e-14 * scale {
            candidates.push(-qc / qb);
        } else {
            let disc = (qb * qb - 4.0 * qa * qc).max(0.0);
            let r = -0.5 * (qb + qb.signum() * disc.sqrt());
            candidates.push(r / qa);
            if r != 0.0 {
                candidates.push(qc / r);
            }
        }
        let mu_of = |lambda: f64| {
            let d = [f[0] + lambda * g[0], f[1] + lambda * g[1]];
            let r = [q[0] - lambda * e[0], q[1] - lambda * e[1]];
            (r[0] * d[0] + r[1] * d[1]) / (d[0] * d[0] + d[1] * d[1])
        };
        // The bilinear map of the whole plane is two-to-one, and eliminating mu
        // can add a root that solves neither equation: among the candidates
        // that reproduce u, keep the one in (or nearest) the unit square.
        let residual = |l: f64, m: f64| {
            let r = [
                tb[0] + l * e[0] + m * f[0] + l * m * g[0] - u[0],
                tb[1] + l * e[1] + m * f[1] + l * m * g[1] - u[1],
            ];
            r[0].abs().max(r[1].abs())
        };
        let outside = |l: f64, m: f64| (-l).max(l - 1.0).max(-m).max(m - 1.0).max(0.0);
        let size = 1.0 + u[0].abs().max(u[1].abs());
        let mut best = (f64::NAN, f64::NAN, (true, f64::INFINITY));
        for lambda in candidates.into_iter().filter(|l| l.is_finite()) {
            let mu = mu_of(lambda);
            let res = residual(lambda, mu);
            // Rank: a solving candidate before a non-solving one, then by
            // distance from the square (solving) or by residual (not solving).
            let key = if res <= 1e-9 * size { (false, outside(lambda, mu)) } else { (true, res) };
            if key < best.2 {
                best = (lambda, mu, key);
            }
        }
        let (mut lambda, mut mu) = (best.0, best.1);
        // Two Newton steps on the bilinear equations polish the root.
        for _ in 0..2 {
            let r = [
                tb[0] + lambda * e[0] + mu * f[0] + lambda * mu * g[0] - u[0],
                tb[1] + lambda * e[1] + mu * f[1] + lambda * mu * g[1] - u[1],
            ];
            let jl = [e[0] + mu * g[0], e[1] + mu * g[1]];
            let jm = [f[0] + lambda * g[0], f[1] + lambda * g[1]];
            let det = cross2(jl, jm);
            if det == 0.0 || !det.is_finite() {
                break;
            }
            lambda -= cross2(r, jm) / det;
            mu -= cross2(jl, r) / det;
        }
        (lambda, mu)
    }
}

/// Where a fan runs along the rectangle's side (a pole next to other path
/// vertices, as in the octahedron and the tetrahedron), T_A, A and B (or A, B
/// and T_B) are collinear, and no smooth map can open the triangle's corner at
/// A into that straight angle without a singular derivative: the bilinear
/// inverse would lose half the digits there. Such a cell (P, A, B) is split by
/// the segment from A to the midpoint D of P-B into a pole cell (P, A, D) and a
/// flat triangle (A, B, D) mapped linearly onto (A, B, D'), D' being the
/// midpoint of the spoke T_B-B (and likewise at B). Every edge keeps its
/// linear parameterisation, so h stays continuous across the seam.
pub(super) fn split_straight_angles(cells: &mut [PoleCell]) -> Vec<FlatPiece> {
    let mut flats = Vec::new();
    for cell in cells.iter_mut() {
        let q = cell.corners();
        let p = corner_vector(cell.pole_corner);
        if orient2d(q[0], q[1], q[2]) == Sign::Zero {
            let d = combine(p, cell.b, 0.5);
            let d_at = lerp2(q[3], cell.ub, 0.5);
            flats.push(FlatPiece {
                face: cell.face,
                corners: [cell.a, cell.b, d],
                positions: [cell.ua, cell.ub, d_at],
            });
            cell.b = d;
            cell.ub = d_at;
            cell.vertical = false;
        } else if orient2d(q[1], q[2], q[3]) == Sign::Zero {
            let d = combine(p, cell.a, 0.5);
            let d_at = lerp2(q[0], cell.ua, 0.5);
            flats.push(FlatPiece {
                face: cell.face,
                corners: [cell.a, cell.b, d],
                positions: [cell.ua, cell.ub, d_at],
            });
            cell.a = d;
            cell.ua = d_at;
            cell.vertical = false;
        }
    }
    flats
}

/// Whether the cell's quadrilateral (T_A, A, B, T_B) is convex and
/// counter-clockwise, by exact orientation tests: then its bilinear map is
/// one-to-one (its Jacobian is affine and positive at three corners or more).
pub(super) fn convex(cell: &PoleCell) -> bool {
    let q = cell.corners();
    let mut positive = 0;
    for i in 0..4 {
        match orient2d(q[i], q[(i + 1) % 4], q[(i + 2) % 4]) {
            Sign::Positive => positive += 1,
            Sign::Zero => {}
            Sign::Negative => return false,
        }
    }
    positive >= 3
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trapezium() -> PoleCell {
        PoleCell {
            face: 0,
            pole_corner: 0,
            pole_theta: 0.0,
            a: [0.0, 1.0, 0.0],
            b: [0.0, 0.0, 1.0],
            ua: [0.5, 1.0],
            ub: [0.8, 2.0],
            psi_a: 1.0,
            psi_b: 2.0,
            vertical: true,
        }
    }

    #[test]
    fn trapezium_inverse_undoes_forward() {
        let mut cell = trapezium();
        for vertical in [true, false] {
            cell.vertical = vertical;
            for &(l, m) in &[(0.5, 0.5), (0.0, 1.0), (1.0, 0.1), (0.25, 1e-9)] {
                let u = cell.forward([1.0 - m, l * m, (1.0 - l) * m]);
                let (l2, m2) = cell.inverse(u);
                assert!((l - l2).abs() < 1e-9 && (m - m2).abs() < 1e-12, "{l} {m} -> {l2} {m2}");
            }
        }
    }

    #[test]
    fn general_quadrilateral_inverse_undoes_forward() {
        let mut cell = trapezium();
        cell.psi_a = 0.7;
        cell.psi_b = 2.4;
        cell.vertical = false;
        assert!(convex(&cell));
        for &(l, m) in &[(0.5, 0.5), (0.9, 0.9), (0.1, 0.3), (0.0, 1e-12), (1.0, 1.0)] {
            let u = cell.forward([1.0 - m, l * m, (1.0 - l) * m]);
            let (l2, m2) = cell.inverse(u);
            assert!((l - l2).abs() < 1e-12 && (m - m2).abs() < 1e-12, "{l} {m} -> {l2} {m2}");
        }
    }

    #[test]
    fn a_quadrilateral_folded_over_is_not_convex() {
        let mut cell = trapezium();
        cell.psi_a = 2.5;
        cell.psi_b = 1.0;
        assert!(!convex(&cell));
    }
}
