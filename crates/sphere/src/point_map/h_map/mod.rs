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
//! the cells with a box tree ([`crate::point_map::bvh`]).

mod fan_psi;
mod locate;
mod pole_cell;

use crate::methods::theta_phi::fold::fold;
use crate::point_map::bvh::{Aabb, Bvh};

use fan_psi::assign_psi;
use pole_cell::{convex, piece_weights, split_straight_angles, FlatPiece, PoleCell};

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

/// The stretched pole cells (thesis 6.6.2) of every face with a pole corner,
/// a face with both poles giving one cell per pole (split at the point of n-s
/// at the height of its third corner), and a face and corner at each pole.
fn pole_cells(
    faces: &[[u32; 3]],
    uv: &[[f64; 2]],
    poles: [u32; 2],
) -> (Vec<PoleCell>, [(u32, usize); 2]) {
    let [north, south] = poles;
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
    (cells, pole_corners)
}

/// The pieces of the rectangle point location can return (the faces without
/// pole corners, the pole cells, the flat pieces), their boxes, and each
/// face's pieces as `part_regions[part_start[f]..part_start[f + 1]]`.
fn regions(
    faces: &[[u32; 3]],
    [north, south]: [u32; 2],
    uv: &[[f64; 2]],
    cells: &[PoleCell],
    flats: &[FlatPiece],
) -> (Vec<Region>, Vec<Aabb<2>>, Vec<u32>, Vec<u32>) {
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
    (regions, boxes, part_start, part_regions)
}

impl ThetaPhiMap {
    /// Builds h from the cut mesh's faces (in the input's face order), the
    /// rectangle embedding `uv` (thesis 6.4) and the poles. Never fails: when
    /// the stretched pole cells cannot be made one-to-one, [`Self::problem`]
    /// says why and `to_surface` must not be trusted.
    pub fn new(faces: &[[u32; 3]], uv: &[[f64; 2]], north: u32, south: u32) -> Self {
        let poles = [north, south];
        let (mut cells, pole_corners) = pole_cells(faces, uv, poles);
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

        let (regions, boxes, part_start, part_regions) = regions(faces, poles, uv, &cells, &flats);
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
}
