//! h^-1 of the theta-phi map (thesis 6.6.4): point location in the rectangle
//! decided with exact predicates, and how accurate each answer is (issue 13,
//! item 7).
//!
//! A certified rectangle (`tp_valid`) is tiled by its cells: triangles without
//! a pole corner, the convex stretched pole cells of h2 and the flat pieces
//! cut off them. The closed cell holding the unfolded point is found with
//! exact orientation tests (`orient2d`), so thin cells cannot hand the point
//! to a neighbour. The weights inside a cell are ratios of areas (or, in a
//! pole cell, the bilinear inverse of eq. 6.53-6.56), and their error is
//! bounded from the rounding of the point itself ([`ThetaPhiMap::to_surface`]
//! cannot know more than its digits hold) and of the arithmetic.

use std::f64::consts::PI;

use spherify_mesh::predicates::{orient2d, Sign};

use super::pole_cell::{cross2, sub2};
use super::{Region, ThetaPhiMap};
use crate::methods::theta_phi::fold::unfold;
use crate::point_map::weight_bound::{clamp_weights, ratio_weights, Candidates, UNIT_ROUNDOFF};

/// One region's answer for one point.
struct RegionWeights {
    face: u32,
    /// The face's barycentric weights.
    w: [f64; 3],
    /// Bound on sum |w - w'| over the exact weights w' of every point within
    /// the rounding error of the query (infinite: unknown).
    bound: f64,
    /// The closed region holds the point exactly.
    contains: bool,
    /// Some point within the rounding error of the query lies in the region.
    near: bool,
    /// The smallest of the region's own weights (negative outside): used
    /// only when no region holds the point (an uncertified map).
    score: f64,
}

/// The area of (x, y, p) with the bounds point location needs: its float
/// value, the error of that value, and how far a move of p by `delta` (in
/// theta, phi) can change it. `cross2(x - p, y - p)` has gradient
/// (x1 - y1, y0 - x0) in p.
fn area(x: [f64; 2], y: [f64; 2], p: [f64; 2], delta: [f64; 2]) -> (f64, f64, f64) {
    let (xp, yp) = (sub2(x, p), sub2(y, p));
    let value = cross2(xp, yp);
    let eval = 8.0 * UNIT_ROUNDOFF * (xp[0].abs() * yp[1].abs() + xp[1].abs() * yp[0].abs());
    let moved = (x[1] - y[1]).abs() * delta[0] + (y[0] - x[0]).abs() * delta[1];
    (value, eval, moved)
}

/// Weights of `p` in the triangle (a, b, c) of the rectangle, counter-clockwise
/// in a certified embedding: (weights, bound, contains, near).
fn triangle(t: [[f64; 2]; 3], p: [f64; 2], delta: [f64; 2]) -> ([f64; 3], f64, bool, bool) {
    let [a, b, c] = t;
    let edges = [(b, c), (c, a), (a, b)];
    let parts = edges.map(|(x, y)| area(x, y, p, delta));
    let d = parts.map(|x| x.0);
    let e = parts.map(|x| x.1 + x.2);
    // Near the poles phi's rounding error is huge while the point is well
    // placed in theta: the triangle's own theta range (and phi range, when
    // phi's error is small) must reach the point too.
    let reaches = |axis: usize| {
        let lo = a[axis].min(b[axis]).min(c[axis]);
        let hi = a[axis].max(b[axis]).max(c[axis]);
        p[axis] + delta[axis] >= lo && p[axis] - delta[axis] <= hi
    };
    let near = reaches(0) && reaches(1) && (0..3).all(|i| d[i] + e[i] >= 0.0);
    let contains = near
        && (0..3).all(|i| {
            let (value, eval, _) = parts[i];
            if value > eval {
                true
            } else if value < -eval {
                false
            } else {
                orient2d(edges[i].0, edges[i].1, p) != Sign::Negative
            }
        });
    let (w, bound) = ratio_weights(d, e);
    (w, bound, contains, near)
}

impl ThetaPhiMap {
    /// h^-1 (6.6.4): the face and barycentric weights of the surface point
    /// mapped to the unit vector `p`, and a bound on the distance of that
    /// surface point from the exact preimage of every sphere point within the
    /// rounding error of [`ThetaPhiMap::to_sphere`] of `p` (`sizes[f]`: the
    /// longest edge of surface face f); infinite when unknown.
    pub fn to_surface(&self, p: [f64; 3], sizes: &[f64]) -> (u32, [f64; 3], f64) {
        let u = unfold(p);
        for side in 0..2 {
            let pole_line = if side == 0 { u[0] <= 0.0 } else { u[0] >= PI };
            if pole_line {
                // Exactly a pole: its own vertex, exactly.
                let (f, c) = self.pole_corners[side];
                let mut w = [0.0; 3];
                w[c] = 1.0;
                return (f, w, 0.0);
            }
        }
        self.locate(u, sizes)
    }

    /// h1^-1 h2^-1: the face, weights and error bound (as in
    /// [`ThetaPhiMap::to_surface`]) of the rectangle point `u`.
    pub fn locate(&self, u: [f64; 2], sizes: &[f64]) -> (u32, [f64; 3], f64) {
        let u = [u[0].clamp(0.0, PI), u[1].clamp(0.0, 2.0 * PI)];
        // to_sphere's combination of rectangle corners (coordinates up to
        // 2 pi) and fold, then normalising and unfolding the sphere point, are
        // each a few u; phi's error grows as 1 / sin(theta) towards the poles.
        let delta = [
            16.0 * UNIT_ROUNDOFF * (PI + 1.0),
            16.0 * UNIT_ROUNDOFF * (2.0 * PI + 1.0 / u[0].sin().max(f64::MIN_POSITIVE)),
        ];
        let mut found = Candidates::default();
        let consider = |r: u32, found: &mut Candidates| {
            let rw = self.region_weights(r, u, delta);
            let distance = rw.bound * sizes[rw.face as usize];
            found.offer(rw.face, rw.w, distance, rw.contains, rw.near, rw.score);
        };
        // The slack covers delta wherever a bound is finite.
        self.locator.for_each_containing(&u, 1e-9, |x| consider(x, &mut found));
        if !found.found() {
            // The cells tile the rectangle, so some box holds u; this is a
            // safety net, not a path taken in practice.
            for r in 0..self.regions.len() as u32 {
                consider(r, &mut found);
            }
        }
        let (f, w, bound) = found.answer();
        (f, clamp_weights(w), bound)
    }

    /// The face and weights of `u` in region `r` (see [`RegionWeights`]).
    fn region_weights(&self, r: u32, u: [f64; 2], delta: [f64; 2]) -> RegionWeights {
        match self.regions[r as usize] {
            Region::Triangle(f) => {
                let t = self.faces[f as usize].map(|v| self.uv[v as usize]);
                let (w, bound, contains, near) = triangle(t, u, delta);
                RegionWeights { face: f, w, bound, contains, near, score: w[0].min(w[1]).min(w[2]) }
            }
            Region::Flat(k) => {
                let flat = &self.flats[k as usize];
                let (t, bound, contains, near) = triangle(flat.positions, u, delta);
                // w = sum t_k corner_k with corners of weights >= 0 summing to 1,
                // so sum |dw| <= sum |dt|.
                let mut w = [0.0; 3];
                for (corner, &tk) in flat.corners.iter().zip(&t) {
                    for i in 0..3 {
                        w[i] += tk * corner[i];
                    }
                }
                let score = t[0].min(t[1]).min(t[2]);
                RegionWeights { face: flat.face, w, bound, contains, near, score }
            }
            Region::Pole(c) => self.pole_cell_weights(c, u, delta),
        }
    }

    /// A stretched pole cell: exact containment in its convex quadrilateral
    /// (T_A, A, B, T_B), the bilinear inverse, and a bound on the weights
    /// from the inverse's Jacobian.
    fn pole_cell_weights(&self, c: u32, u: [f64; 2], delta: [f64; 2]) -> RegionWeights {
        let cell = &self.cells[c as usize];
        let q = cell.corners();
        let mut contains = true;
        let mut near = true;
        for i in 0..4 {
            let (x, y) = (q[i], q[(i + 1) % 4]);
            // orient2d(x, y, u) = cross2(x - u, y - u).
            let (value, eval, moved) = area(x, y, u, delta);
            if value + eval + moved < 0.0 {
                near = false;
            }
            let inside = if value > eval {
                true
            } else if value < -eval {
                false
            } else {
                orient2d(x, y, u) != Sign::Negative
            };
            contains &= inside;
        }
        contains &= near;
        let (lambda, mu) = cell.inverse(u);
        let s = [1.0 - mu, lambda * mu, (1.0 - lambda) * mu];
        let mut w = [0.0; 3];
        w[cell.pole_corner] = s[0];
        for ((wk, ak), bk) in w.iter_mut().zip(cell.a).zip(cell.b) {
            *wk += s[1] * ak + s[2] * bk;
        }
        // u = T_B + lambda e + mu f + lambda mu g: a change r of u moves
        // (lambda, mu) by J^-1 r to first order, J = [e + mu g, f + lambda g].
        let tb = cell.top(cell.psi_b);
        let e = sub2(cell.top(cell.psi_a), tb);
        let f = sub2(cell.ub, tb);
        let g = sub2(sub2(cell.ua, cell.ub), e);
        let jl = [e[0] + mu * g[0], e[1] + mu * g[1]];
        let jm = [f[0] + lambda * g[0], f[1] + lambda * g[1]];
        let det = cross2(jl, jm);
        let at = cell.forward(s);
        let size = 2.0 * PI;
        let r = [
            (at[0] - u[0]).abs() + delta[0] + 16.0 * UNIT_ROUNDOFF * size,
            (at[1] - u[1]).abs() + delta[1] + 16.0 * UNIT_ROUNDOFF * size,
        ];
        let d_lambda = (r[0] * jm[1].abs() + r[1] * jm[0].abs()) / det.abs();
        let d_mu = (r[1] * jl[0].abs() + r[0] * jl[1].abs()) / det.abs();
        let first_order = d_mu * (1.0 + lambda.abs() + (1.0 - lambda).abs())
            + 2.0 * (mu.abs() * d_lambda + d_lambda * d_mu);
        // The first-order bound, doubled for the curvature of the bilinear map,
        // is trusted only while the move it allows is small. Near the pole
        // phi (and so lambda) is barely known, but every cell of the fan
        // shrinks to the pole there: a point with mu' <= mu + d_mu is within
        // mu' of its face's size from the pole vertex, whatever lambda is, so
        // sum |dw| <= 2 mu + d_mu bounds the surface distance as well.
        let near_pole = 2.0 * mu.abs() + d_mu;
        let bound = if first_order.is_finite() && d_lambda + d_mu < 1e-3 {
            (2.0 * first_order).min(near_pole)
        } else if near_pole.is_finite() && d_mu < 1e-3 {
            near_pole
        } else {
            f64::INFINITY
        };
        let score = s[0].min(s[1]).min(s[2]);
        RegionWeights { face: cell.face, w, bound, contains, near, score }
    }
}
