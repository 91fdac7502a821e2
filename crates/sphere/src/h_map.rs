//! The map h of the theta-phi method between the surface and the sphere, and
//! its inverse (thesis 6.6).
//!
//! h = h3 o h2 o h1:
//! * h1 (6.6.1): a point of face f, given by barycentric weights, goes to the
//!   same weights of f's triangle in the theta-phi rectangle (the cut mesh keeps
//!   the face order, so face f of the input is face f of the cut mesh).
//! * h2 (6.6.2): triangles with a pole corner P are stretched so that P becomes
//!   the whole line theta = theta_P: triangle (P, A, B) becomes the quadrilateral
//!   (T_A, A, B, T_B) with T_X = (theta_P, psi_X), through the point
//!   u' = mu v + (1 - mu) t of eq. 6.49-6.50, where v = lambda A + (1 - lambda) B,
//!   t = (theta_P, lambda psi_A + (1 - lambda) psi_B), mu = 1 - w_P and
//!   lambda = w_A / (1 - w_P). Every other triangle stays where it is.
//! * h3 (6.6.3): the fold m(theta, phi) of eq. 6.35.
//!
//! The thesis takes psi_X = phi_X, which gives trapezia with vertical sides and
//! needs the phi values around each pole to increase strictly (6.5.1). Two
//! cases it leaves open are closed here:
//! * a pole whose neighbours include other path vertices (every vertex of the
//!   tetrahedron and the octahedron is on or next to the cut), or a fan that
//!   6.36-6.38 could not re-embed: phi cannot increase strictly there. psi is
//!   then chosen per fan so that every quadrilateral is convex ([`fan_psi`]),
//!   which makes its bilinear parameterisation one-to-one, and the result is
//!   checked with exact orientation tests; cells with a straight angle are
//!   split ([`split_straight_angles`]).
//! * a face with both poles as corners (adjacent poles: the tetrahedron, or a
//!   caller's explicit pair): the edge n-s lies on phi = pi, and the face
//!   (n, x, s) is split at c = the point of n-s at theta_x into a north cell
//!   (n, x, c) and a south cell (s, c, x), each stretched as above.
//!
//! The inverse h2^-1 solves the bilinear quadrilateral for (lambda, mu): in
//! closed form for the thesis's trapezia (eq. 6.53-6.56; note that the
//! denominator of eq. 6.55 should read mu (theta_1 - theta_2) + theta_2 -
//! theta_3), and as a quadratic in lambda otherwise. Points are located among
//! the cells with a box tree ([`crate::bvh`]).

use std::collections::{HashMap, HashSet};
use std::f64::consts::PI;

use spherify_mesh::predicates::{orient2d, Sign};
use spherify_mesh::vec3::det3;

use crate::bvh::{Aabb, Bvh};

/// One stretched pole triangle (P, A, B) of h2. A and B are given as
/// barycentric weights on the face's corners, since c of a two-pole face is
/// not a vertex.
#[derive(Debug, Clone)]
struct PoleCell {
    face: u32,
    pole_corner: usize,
    pole_theta: f64,
    a: [f64; 3],
    b: [f64; 3],
    ua: [f64; 2],
    ub: [f64; 2],
    psi_a: f64,
    psi_b: f64,
    /// psi equals phi at A and B: the thesis's trapezium, inverted in closed form.
    vertical: bool,
}

/// A triangle cut off a pole cell whose quadrilateral would have a straight
/// angle (see [`split_straight_angles`]); h2 is linear on it. Corners are
/// barycentric weights on the face's corners, positions are in the rectangle.
#[derive(Debug, Clone)]
struct FlatPiece {
    face: u32,
    corners: [[f64; 3]; 3],
    positions: [[f64; 2]; 3],
}

/// A piece of the rectangle that point location can return.
#[derive(Debug, Clone, Copy)]
enum Region {
    /// A face without pole corners: h2 is the identity on it.
    Triangle(u32),
    /// A stretched pole cell.
    Pole(u32),
    /// A flat piece of a split pole cell.
    Flat(u32),
}

/// The theta-phi map h and its inverse.
#[derive(Debug, Clone)]
pub struct ThetaPhiMap {
    faces: Vec<[u32; 3]>,
    uv: Vec<[f64; 2]>,
    poles: [u32; 2],
    /// The regions of face f are `part_regions[part_start[f]..part_start[f + 1]]`;
    /// none for a face without pole corners (h2 is the identity there).
    part_start: Vec<u32>,
    part_regions: Vec<u32>,
    cells: Vec<PoleCell>,
    flats: Vec<FlatPiece>,
    regions: Vec<Region>,
    locator: Bvh<2>,
    /// A face and corner at the north and south pole.
    pole_corners: [(u32, usize); 2],
    /// Why h2 is not one-to-one, when it is not.
    problem: Option<String>,
}

fn lerp2(a: [f64; 2], b: [f64; 2], t: f64) -> [f64; 2] {
    [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
}

fn cross2(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

fn sub2(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

/// The fold m of eq. 6.35.
pub fn fold(u: [f64; 2]) -> [f64; 3] {
    let (st, ct) = u[0].sin_cos();
    let (sp, cp) = u[1].sin_cos();
    [st * cp, st * sp, ct]
}

/// m^-1 of eq. 6.57, with atan2 for both angles (accurate near the poles,
/// where arccos(z) loses half the digits); phi in [0, 2 pi).
pub fn unfold(p: [f64; 3]) -> [f64; 2] {
    let r = p[0].hypot(p[1]);
    let theta = r.atan2(p[2]);
    let mut phi = p[1].atan2(p[0]);
    if phi < 0.0 {
        phi += 2.0 * PI;
        if phi >= 2.0 * PI {
            phi = 0.0;
        }
    }
    [theta, phi]
}

/// Barycentric weights of `p` in triangle (a, b, c), each computed from the
/// sub-triangle opposite its corner, so a point near a corner keeps its digits.
pub(crate) fn triangle_weights(p: [f64; 2], a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> [f64; 3] {
    let area = cross2(sub2(b, a), sub2(c, a));
    let wa = cross2(sub2(b, p), sub2(c, p)) / area;
    let wb = cross2(sub2(c, p), sub2(a, p)) / area;
    let wc = cross2(sub2(a, p), sub2(b, p)) / area;
    let sum = wa + wb + wc;
    [wa / sum, wb / sum, wc / sum]
}

/// Solves w = s_0 x + s_1 y + s_2 z for (s_0, s_1, s_2) (Cramer's rule): the
/// weights of a face point in a piece whose corners x, y, z are themselves
/// given by weights on the face's corners.
fn piece_weights([x, y, z]: [[f64; 3]; 3], w: [f64; 3]) -> [f64; 3] {
    let d = det3(x, y, z);
    [det3(w, y, z) / d, det3(x, w, z) / d, det3(x, y, w) / d]
}

fn corner_vector(corner: usize) -> [f64; 3] {
    let mut e = [0.0; 3];
    e[corner] = 1.0;
    e
}

fn combine(x: [f64; 3], y: [f64; 3], t: f64) -> [f64; 3] {
    [x[0] + t * (y[0] - x[0]), x[1] + t * (y[1] - x[1]), x[2] + t * (y[2] - x[2])]
}

impl PoleCell {
    /// (s_P, s_A, s_B) of the face point with weights `w`.
    fn weights(&self, w: [f64; 3]) -> [f64; 3] {
        piece_weights([corner_vector(self.pole_corner), self.a, self.b], w)
    }

    fn top(&self, psi: f64) -> [f64; 2] {
        [self.pole_theta, psi]
    }

    /// The corners (T_A, A, B, T_B), counter-clockwise in a valid embedding.
    fn corners(&self) -> [[f64; 2]; 4] {
        [self.top(self.psi_a), self.ua, self.ub, self.top(self.psi_b)]
    }

    /// h2 on the cell, from weights (s_P, s_A, s_B) with s_P < 1 (eq. 6.49-6.50).
    fn forward(&self, s: [f64; 3]) -> [f64; 2] {
        let mu = s[1] + s[2];
        let lambda = s[1] / mu;
        let v = lerp2(self.ub, self.ua, lambda);
        let t = self.top(self.psi_b + lambda * (self.psi_a - self.psi_b));
        lerp2(t, v, mu)
    }

    /// h2^-1 on the cell: (lambda, mu) with u = forward(lambda mu, ...).
    fn inverse(&self, u: [f64; 2]) -> (f64, f64) {
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

/// Key of a fan point: a vertex id, or the split point c of a two-pole face.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum FanPoint {
    Vertex(u32),
    Split(u32),
}

impl ThetaPhiMap {
    /// Builds h from the cut mesh's faces (in the input's face order), the
    /// rectangle embedding `uv` (thesis 6.4) and the poles. Never fails: when
    /// the stretched pole cells cannot be made one-to-one, [`Self::problem`]
    /// says why and `to_surface` must not be trusted.
    pub fn new(faces: &[[u32; 3]], uv: &[[f64; 2]], north: u32, south: u32) -> Self {
        let poles = [north, south];
        let mut cells: Vec<PoleCell> = Vec::new();
        let mut pole_corners = [(u32::MAX, 0usize); 2];
        for (f, face) in faces.iter().enumerate() {
            let corner_of = |v: u32| face.iter().position(|&x| x == v);
            let corners = [corner_of(north), corner_of(south)];
            for side in 0..2 {
                if let Some(c) = corners[side] {
                    if pole_corners[side].0 == u32::MAX {
                        pole_corners[side] = (f as u32, c);
                    }
                }
            }
            for side in 0..2 {
                let Some(pc) = corners[side] else { continue };
                let (ca, cb) = ((pc + 1) % 3, (pc + 2) % 3);
                let point = |corner: usize| -> [f64; 3] {
                    let mut w = [0.0; 3];
                    match corners[1 - side] {
                        Some(other) if other == corner => {
                            // The split point c on n-s at the height of x (the third corner).
                            let x = 3 - pc - other;
                            let (ut, up, uo) = (
                                uv[face[x] as usize][0],
                                uv[face[pc] as usize][0],
                                uv[face[other] as usize][0],
                            );
                            let tau = (ut - up) / (uo - up);
                            w[pc] = 1.0 - tau;
                            w[other] = tau;
                        }
                        _ => w[corner] = 1.0,
                    }
                    w
                };
                let (a, b) = (point(ca), point(cb));
                let at = |w: [f64; 3]| {
                    let mut p = [0.0; 2];
                    for k in 0..3 {
                        let q = uv[face[k] as usize];
                        p[0] += w[k] * q[0];
                        p[1] += w[k] * q[1];
                    }
                    p
                };
                let (ua, ub) = (at(a), at(b));
                cells.push(PoleCell {
                    face: f as u32,
                    pole_corner: pc,
                    pole_theta: uv[poles[side] as usize][0],
                    a,
                    b,
                    ua,
                    ub,
                    psi_a: ua[1],
                    psi_b: ub[1],
                    vertical: true,
                });
            }
        }
        let mut problem = None;
        for side in 0..2 {
            if let Err(why) = assign_psi(&mut cells, faces, poles, side) {
                problem.get_or_insert(why);
            }
        }
        let flats = split_straight_angles(&mut cells);
        if let Some(bad) = cells.iter().find(|c| !convex(c)) {
            problem.get_or_insert(format!(
                "the stretched pole triangle of face {} is not convex, so h2 is not one-to-one there",
                bad.face
            ));
        }

        let mut regions = Vec::with_capacity(faces.len() + cells.len() + flats.len());
        let mut boxes = Vec::with_capacity(regions.capacity());
        let mut parts: Vec<(u32, u32)> = Vec::with_capacity(cells.len() + flats.len());
        for (f, face) in faces.iter().enumerate() {
            if !face.contains(&north) && !face.contains(&south) {
                regions.push(Region::Triangle(f as u32));
                boxes.push(Aabb::around(&face.map(|v| uv[v as usize])));
            }
        }
        for (i, cell) in cells.iter().enumerate() {
            parts.push((cell.face, regions.len() as u32));
            regions.push(Region::Pole(i as u32));
            boxes.push(Aabb::around(&cell.corners()));
        }
        for (i, flat) in flats.iter().enumerate() {
            parts.push((flat.face, regions.len() as u32));
            regions.push(Region::Flat(i as u32));
            boxes.push(Aabb::around(&flat.positions));
        }
        parts.sort_unstable();
        let mut part_start = vec![0u32; faces.len() + 1];
        for &(f, _) in &parts {
            part_start[f as usize + 1] += 1;
        }
        for f in 0..faces.len() {
            part_start[f + 1] += part_start[f];
        }
        let part_regions = parts.into_iter().map(|(_, r)| r).collect();
        let locator = Bvh::new(&boxes);
        ThetaPhiMap {
            faces: faces.to_vec(),
            uv: uv.to_vec(),
            poles,
            part_start,
            part_regions,
            cells,
            flats,
            regions,
            locator,
            pole_corners,
            problem,
        }
    }

    /// Why h2 is not one-to-one on this embedding, if it is not.
    pub fn problem(&self) -> Option<&str> {
        self.problem.as_deref()
    }

    /// h1 then h2 (6.6.1-6.6.2): the point of the full rectangle for weights
    /// `w` on face `f`; `None` for a pole itself (a whole line of the rectangle).
    pub fn to_rectangle(&self, f: u32, w: [f64; 3]) -> Option<[f64; 2]> {
        let parts = &self.part_regions
            [self.part_start[f as usize] as usize..self.part_start[f as usize + 1] as usize];
        if parts.is_empty() {
            let face = self.faces[f as usize];
            let mut p = [0.0; 2];
            for k in 0..3 {
                let q = self.uv[face[k] as usize];
                p[0] += w[k] * q[0];
                p[1] += w[k] * q[1];
            }
            return Some(p);
        }
        // The piece in which the point's weights are least negative holds it.
        let mut best: Option<(Region, [f64; 3], f64)> = None;
        for &r in parts {
            let region = self.regions[r as usize];
            let s = match region {
                Region::Pole(c) => self.cells[c as usize].weights(w),
                Region::Flat(k) => piece_weights(self.flats[k as usize].corners, w),
                Region::Triangle(_) => continue,
            };
            let score = s[0].min(s[1]).min(s[2]);
            if best.as_ref().is_none_or(|b| score > b.2) {
                best = Some((region, s, score));
            }
        }
        match best? {
            (Region::Pole(c), s, _) => (s[0] < 1.0).then(|| self.cells[c as usize].forward(s)),
            (Region::Flat(k), s, _) => {
                let p = self.flats[k as usize].positions;
                Some([
                    s[0] * p[0][0] + s[1] * p[1][0] + s[2] * p[2][0],
                    s[0] * p[0][1] + s[1] * p[1][1] + s[2] * p[2][1],
                ])
            }
            (Region::Triangle(_), _, _) => None,
        }
    }

    /// h (6.6.4): the point on the sphere for weights `w` on face `f`.
    pub fn to_sphere(&self, f: u32, w: [f64; 3]) -> [f64; 3] {
        match self.to_rectangle(f, w) {
            Some(u) => fold(u),
            None => {
                let face = self.faces[f as usize];
                let corner = (0..3).max_by(|&i, &j| w[i].total_cmp(&w[j])).unwrap_or(0);
                if face[corner] == self.poles[0] {
                    [0.0, 0.0, 1.0]
                } else {
                    [0.0, 0.0, -1.0]
                }
            }
        }
    }

    /// h^-1 (6.6.4): the face and barycentric weights of the surface point
    /// mapped to the unit vector `p`.
    pub fn to_surface(&self, p: [f64; 3]) -> (u32, [f64; 3]) {
        let u = unfold(p);
        for side in 0..2 {
            let pole_line = if side == 0 { u[0] <= 0.0 } else { u[0] >= PI };
            if pole_line {
                let (f, c) = self.pole_corners[side];
                let mut w = [0.0; 3];
                w[c] = 1.0;
                return (f, w);
            }
        }
        self.locate(u)
    }

    /// h1^-1 h2^-1: the face and weights of the rectangle point `u`.
    pub fn locate(&self, u: [f64; 2]) -> (u32, [f64; 3]) {
        let u = [u[0].clamp(0.0, PI), u[1].clamp(0.0, 2.0 * PI)];
        let consider = |r: u32, best: &mut Option<(u32, [f64; 3], f64)>| {
            let (f, w, score) = self.region_weights(r, u);
            if score.is_finite() && best.as_ref().is_none_or(|b| score > b.2) {
                *best = Some((f, w, score));
            }
        };
        let mut best = None;
        self.locator.for_each_containing(&u, 1e-12, |r| consider(r, &mut best));
        if best.is_none() {
            // The cells tile the rectangle, so some box holds u; this is a
            // safety net for non-finite weights, not a path taken in practice.
            for r in 0..self.regions.len() as u32 {
                consider(r, &mut best);
            }
        }
        let (f, w, _) = best.unwrap_or((0, [1.0, 0.0, 0.0], 0.0));
        (f, clamp_weights(w))
    }

    /// The face and barycentric weights of `u` in region `r`, and how far
    /// inside the region `u` lies: the smallest of the region's own weights
    /// (negative outside). For a pole cell these are (s_P, s_A, s_B), not the
    /// face's weights, since a two-pole face has two cells.
    fn region_weights(&self, r: u32, u: [f64; 2]) -> (u32, [f64; 3], f64) {
        match self.regions[r as usize] {
            Region::Triangle(f) => {
                let [a, b, c] = self.faces[f as usize].map(|v| self.uv[v as usize]);
                let w = triangle_weights(u, a, b, c);
                (f, w, w[0].min(w[1]).min(w[2]))
            }
            Region::Pole(c) => {
                let cell = &self.cells[c as usize];
                let (lambda, mu) = cell.inverse(u);
                let s = [1.0 - mu, lambda * mu, (1.0 - lambda) * mu];
                let mut w = [0.0; 3];
                w[cell.pole_corner] = s[0];
                for k in 0..3 {
                    w[k] += s[1] * cell.a[k] + s[2] * cell.b[k];
                }
                (cell.face, w, s[0].min(s[1]).min(s[2]))
            }
            Region::Flat(k) => {
                let flat = &self.flats[k as usize];
                let [a, b, c] = flat.positions;
                let t = triangle_weights(u, a, b, c);
                let mut w = [0.0; 3];
                for (corner, &tk) in flat.corners.iter().zip(&t) {
                    for i in 0..3 {
                        w[i] += tk * corner[i];
                    }
                }
                (flat.face, w, t[0].min(t[1]).min(t[2]))
            }
        }
    }
}

/// Rounding leaves weights a hair below zero on shared edges: clip and rescale.
pub(crate) fn clamp_weights(w: [f64; 3]) -> [f64; 3] {
    let c = w.map(|x| x.max(0.0));
    let s = c[0] + c[1] + c[2];
    if s > 0.0 {
        c.map(|x| x / s)
    } else {
        [1.0 / 3.0; 3]
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
fn split_straight_angles(cells: &mut [PoleCell]) -> Vec<FlatPiece> {
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
fn convex(cell: &PoleCell) -> bool {
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

/// Chooses psi along the fan of pole `side` (6.5.1): phi where phi increases
/// strictly from p_1 to N + k, interpolated between such anchors elsewhere.
fn assign_psi(
    cells: &mut [PoleCell],
    faces: &[[u32; 3]],
    poles: [u32; 2],
    side: usize,
) -> Result<(), String> {
    let pole = poles[side];
    let key = |cell: &PoleCell, w: &[f64; 3]| -> FanPoint {
        let face = faces[cell.face as usize];
        match (0..3).find(|&k| w[k] == 1.0) {
            Some(k) => FanPoint::Vertex(face[k]),
            None => FanPoint::Split(cell.face),
        }
    };
    // The fan as links A -> B, one per cell of this pole.
    let mut next: HashMap<FanPoint, usize> = HashMap::new();
    let mut is_target: HashSet<FanPoint> = HashSet::new();
    let mine: Vec<usize> = (0..cells.len())
        .filter(|&i| faces[cells[i].face as usize][cells[i].pole_corner] == pole)
        .collect();
    for &i in &mine {
        let (a, b) = (key(&cells[i], &cells[i].a), key(&cells[i], &cells[i].b));
        if next.insert(a, i).is_some() {
            return Err(format!("the fan of pole {pole} is not a simple path"));
        }
        is_target.insert(b);
    }
    let mut visited = 0;
    let starts: Vec<usize> = mine
        .iter()
        .copied()
        .filter(|&i| !is_target.contains(&key(&cells[i], &cells[i].a)))
        .collect();
    for start in starts {
        // Walk one piece: points q_0 .. q_m and the cells between them.
        let mut chain = vec![start];
        let mut at = key(&cells[start], &cells[start].b);
        while let Some(&i) = next.get(&at) {
            if chain.len() > mine.len() {
                return Err(format!("the fan of pole {pole} has a cycle"));
            }
            chain.push(i);
            at = key(&cells[i], &cells[i].b);
        }
        visited += chain.len();
        let pieces: Vec<&PoleCell> = chain.iter().map(|&i| &cells[i]).collect();
        // The stretch needs the fan's neighbours to run monotonically in phi.
        // Equal steps are allowed only along the rectangle's sides (phi = 0 or
        // 2 pi: a pole next to further path vertices, as in the tetrahedron
        // and the octahedron). Where the fan turns back, or stalls inside the
        // rectangle, the region between the pole line and the fan is not a
        // strip, and no choice of psi is known to tile it.
        let mut phi = vec![pieces[0].ua[1]];
        phi.extend(pieces.iter().map(|c| c.ub[1]));
        let rising = phi.last() > phi.first();
        let on_side = |p: f64| p == 0.0 || p == 2.0 * PI;
        let ok = phi.windows(2).all(|w| {
            let step = if rising { w[1] - w[0] } else { w[0] - w[1] };
            step > 0.0 || (step == 0.0 && on_side(w[0]))
        });
        if !ok {
            return Err(format!(
                "the neighbours of pole {pole} do not run monotonically in phi (the pole is next to the other pole's neighbours or to further cut-path vertices, as on tiny meshes or with a caller's poles), so the stretch h2 of thesis 6.6.2 is not defined; choose other poles"
            ));
        }
        let psi = fan_psi(&pieces).ok_or_else(|| {
            format!("no pole line positions make the fan of pole {pole} one-to-one")
        })?;
        for (j, &i) in chain.iter().enumerate() {
            let cell = &mut cells[i];
            cell.psi_a = psi[j];
            cell.psi_b = psi[j + 1];
            cell.vertical = cell.psi_a == cell.ua[1] && cell.psi_b == cell.ub[1];
        }
    }
    if visited != mine.len() {
        return Err(format!("the fan of pole {pole} has a cycle"));
    }
    Ok(())
}

/// psi for the points q_0 .. q_m of one piece of a pole fan, cell j lying
/// between q_j and q_{j+1}. The ends keep their phi (0 or 2 pi on the
/// rectangle's sides, pi at a split point). The quadrilateral (T_A, A, B, T_B)
/// of a cell is convex when both T_A and T_B lie on the pole's side of the line
/// A B, which bounds each psi to an interval; psi must also run strictly from
/// one end to the other. Where the fan is monotone, psi = phi satisfies all of
/// this (the thesis's vertical trapezia) and is kept; elsewhere psi keeps phi
/// where the bounds allow and otherwise spreads the points evenly over the
/// room left. `None` when the bounds leave no room.
fn fan_psi(chain: &[&PoleCell]) -> Option<Vec<f64>> {
    let m = chain.len();
    let mut phi = vec![chain[0].ua[1]];
    phi.extend(chain.iter().map(|c| c.ub[1]));
    // Work in x = dir * psi, increasing from q_0 to q_m.
    let dir = match phi[m].partial_cmp(&phi[0]) {
        Some(std::cmp::Ordering::Greater) => 1.0,
        Some(std::cmp::Ordering::Less) => -1.0,
        _ => return None,
    };
    let x: Vec<f64> = phi.iter().map(|p| dir * p).collect();
    let mut lo = vec![f64::NEG_INFINITY; m + 1];
    let mut hi = vec![f64::INFINITY; m + 1];
    for (j, cell) in chain.iter().enumerate() {
        // orient2d(A, B, (theta_P, t)) = alpha t + beta must be > 0.
        let (a, b) = (cell.ua, cell.ub);
        let alpha = b[0] - a[0];
        let beta = -alpha * a[1] - (b[1] - a[1]) * (cell.pole_theta - a[0]);
        let slope = alpha * dir;
        for end in [j, j + 1] {
            if slope > 0.0 {
                lo[end] = lo[end].max(-beta / slope);
            } else if slope < 0.0 {
                hi[end] = hi[end].min(-beta / slope);
            } else if !(beta > 0.0) {
                return None;
            }
        }
    }
    // upper[j]: the largest x_j may approach so that the rest still fits.
    let mut upper = vec![x[m]; m + 1];
    for j in (1..m).rev() {
        upper[j] = hi[j].min(upper[j + 1]);
    }
    let mut psi = x.clone();
    for j in 1..m {
        let low = lo[j].max(psi[j - 1]);
        let high = upper[j];
        if !(low < high) {
            return None;
        }
        if !(x[j] > low && x[j] < high) {
            psi[j] = low + (high - low) / ((m - j) as f64 + 1.0);
        }
    }
    Some(psi.into_iter().map(|p| dir * p).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fold_and_unfold_are_inverse_away_from_the_poles() {
        for &(t, p) in &[(0.3, 0.0), (1.0, 1.0), (3.0, 6.2), (1e-9, 3.0), (PI - 1e-9, 0.5)] {
            let u = unfold(fold([t, p]));
            assert!((u[0] - t).abs() < 1e-15 && (u[1] - p).abs() < 1e-12, "{u:?} vs {t} {p}");
        }
        assert_eq!(unfold([0.0, 0.0, 1.0])[0], 0.0);
        assert_eq!(unfold([0.0, 0.0, -1.0])[0], PI);
    }

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
