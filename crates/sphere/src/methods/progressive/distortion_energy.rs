//! Distortion energies of a map from a surface triangle to the chord triangle
//! of its image on the sphere (thesis 9.3: the objective of a progressive map
//! must keep areas in proportion, which no harmonic or conformal energy does).
//!
//! Every energy is a density f(a, d) of the two invariants of the 2x2 Jacobian
//! J of the affine map from the surface triangle (scaled by `k` in area, so
//! that the mesh and its image have equal total area) to the chord triangle:
//! a = |J|_F^2 = s1^2 + s2^2 and d = det J = s1 s2, with s1, s2 the singular
//! values. A face contributes (area of the scaled surface triangle) * f.
//! Both invariants come from Gram matrices alone: with G the Gram matrix of
//! two surface edges from one corner and H that of the matching chord edges,
//! a = tr(H G^-1), and d is the ratio of the areas.
//!
//! The image's area is taken as det[p0, p1, p2] / 2: the chord triangle's
//! area times the distance of its plane from the centre. For small triangles
//! the two agree; unlike the chord area, it vanishes exactly when the
//! spherical triangle does, also for a long sliver along a great circle,
//! whose chord triangle stays large. So every barrier below guards the exact
//! orientation test itself.

use spherify_mesh::vec3::{cross, det3, dot, norm, sub};

/// Which distortion a map minimises.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Energy {
    /// Symmetric Dirichlet, |J|^2 + |J^-1|^2 (Smith and Schaefer 2015): both
    /// angles and areas, infinite when a triangle collapses.
    Isometric,
    /// MIPS, |J|^2 / det J (Hormann and Greiner 2000), plus a barrier below
    /// an area ratio of [`CONFORMAL_AREA_FLOOR`]: an exactly conformal map of
    /// a limbed shape shrinks limbs below what a double can hold.
    Conformal,
    /// det J + 1 / det J, plus [`AUTHALIC_ANGLE_WEIGHT`] times MIPS.
    Authalic,
    /// Sander et al.'s L2 stretch of the map from the sphere back to the
    /// surface, (s1^-2 + s2^-2) / 2 (Praun and Hoppe 2003 minimise it).
    Stretch,
    /// The default: stretch plus [`BALANCED_AREA_WEIGHT`] times (det J +
    /// 1 / det J), the L2 stretch of the map back to the surface with a cost
    /// of growth as well as of shrinkage, so that each face also keeps its
    /// share of the sphere (issue 22: stretch alone leaves the area
    /// distortion above SphereParam's on most meshes, the isometric energy
    /// both stretch and area). The progressive method lowers it with this
    /// fixed weight only through `improve`; its own final level uses
    /// [`Energy::BalancedWeighted`].
    Balanced,
    /// Stretch plus [`COARSE_STRETCH_EXPANSION`] times |J|^2: what the coarse
    /// levels of a progressive stretch map lower (see [`Energy::on_coarse_levels`]).
    /// Not offered to users.
    CoarseStretch,
    /// Balanced with its area weight chosen from the map (in thousandths,
    /// see [`balanced_area_weight`]): what the final sweeps and global steps
    /// of a balanced map lower. Not offered to users.
    BalancedWeighted(u16),
    /// Balanced with [`BALANCED_COARSE_AREA_WEIGHT`] for its area term plus
    /// [`COARSE_STRETCH_EXPANSION`] times |J|^2: what the coarse levels of a
    /// balanced map lower (see [`Energy::on_coarse_levels`]). Not offered to users.
    CoarseBalanced,
}

/// Area ratio below which the conformal energy's barrier starts. Limbs need
/// room to shrink for angles to be kept (measured on the corpus, 1e-5
/// against 1e-3: mean angle distortion 17.1 against 20.7 degrees on
/// human_man, 20.5 against 26.1 on scorpion), and the smallest triangle stays
/// at least 4e-8 of the mean there, eight orders above the double floor.
pub const CONFORMAL_AREA_FLOOR: f64 = 1e-5;
/// Weight of the angle term of the authalic energy.
pub const AUTHALIC_ANGLE_WEIGHT: f64 = 0.1;
/// Weight of the area term of [`Energy::Balanced`]. Measured against
/// SphereParam on ten corpus meshes (20 final sweeps): 0.25 costs 0.5-3% of
/// L2 stretch against the stretch energy; 0.1 and 0.05 cost 0-1%, with 0.1
/// a little lower in area (human_man 0.774 and 0.790, octopus 0.571 and
/// 0.579) and 0.05 a little lower in stretch (sword 2.641 and 2.696). With
/// the global L-BFGS steps ([`crate::methods::progressive::lbfgs`]) the
/// energy gets much nearer its minimum, and 0.15 did better than 0.1 on the
/// four meshes tried (spherical area octopus 0.572 / 0.571, knight 0.488 /
/// 0.483, sword 0.633 / 0.620, scorpion 0.730 / 0.720; L2 stretch within
/// 0.1%).
pub const BALANCED_AREA_WEIGHT: f64 = 0.15;
/// Weight of the area term on the coarse levels of a balanced map
/// ([`Energy::CoarseBalanced`]): there limbs win or lose their share of the
/// sphere, which the finest levels cannot give back. Measured against
/// SphereParam on eight meshes (tentacles, helix_tube and urchin at 20k,
/// knight, hand, human_man, octopus, sword), mean |log area ratio| on
/// spherical triangles with 0.1 / 1.0 (and the expansion cost): tentacles
/// 1.045 / 0.861, helix_tube 1.177 / 0.854, hand 0.420 / 0.374, human_man
/// 0.774 / 0.666, sword 0.896 / 0.647; L2 stretch tentacles 3.489 / 3.245,
/// helix_tube 6.504 / 4.766, sword 2.696 / 2.598, hand 1.468 / 1.451.
/// 2.0 (with five times the level sweeps) lowered areas further but
/// raised stretch on six of the eight.
pub const BALANCED_COARSE_AREA_WEIGHT: f64 = 1.0;
/// The area weight of a balanced map's final level grows with its stretch:
/// [`BALANCED_WEIGHT_SLOPE`] times (S - 1), S the stretch density per unit
/// area at the start of the final sweeps, within [`BALANCED_WEIGHT_RANGE`].
/// Measured against SphereParam (with the chord-area term, weight 0.3 of
/// [`crate::methods::progressive::chord_area`]): nearly round meshes (S - 1
/// about 0.07-0.09) keep their stretch at SphereParam's only with a weight
/// near 0.02 (bumpy: 0.02 gives L2 stretch 1.0413 and area 0.122 against
/// 1.0414 and 0.123; 0.15 gives 1.0414 rounded up to above it); limbed ones
/// need far more to get areas at or below SphereParam's: 20k-vertex
/// `tentacles` (S about 9) area 0.825 with 0.6 and 0.788 with 1.0 against
/// 0.803; octopus (S about 6.5) 0.574 with 0.3, 0.545 with 0.6 against 0.554;
/// while spot (S about 1.4) lost stretch with 1.0 (1.187 against 1.180) and
/// hand its angle (27.5 against 24.9 x 1.1).
pub const BALANCED_WEIGHT_SLOPE: f64 = 0.3;
/// The lower end: 20k-vertex `bumpy_blob` (S - 1 below 0.03) kept its area
/// above SphereParam's with 0.01 (0.0288 against 0.0287), not with 0.02
/// (0.0286). The upper end: 200k-vertex `helix_tube` had area 0.7758
/// against SphereParam's 0.7755 with 1.0, 0.7580 with 1.3 (L2 stretch 3.632
/// and 3.640 against 3.701); 2.0 cost it its stretch.
pub const BALANCED_WEIGHT_RANGE: (f64, f64) = (0.02, 1.3);

/// The area weight of [`Energy::BalancedWeighted`] for the stretch density
/// `s` per unit area, in thousandths.
pub fn balanced_area_weight(s: f64) -> u16 {
    let (lo, hi) = BALANCED_WEIGHT_RANGE;
    let w = if s.is_finite() { (BALANCED_WEIGHT_SLOPE * (s - 1.0)).clamp(lo, hi) } else { hi };
    (1000.0 * w).round() as u16
}

/// Weight of the expansion cost |J|^2 in [`Energy::CoarseStretch`].
pub const COARSE_STRETCH_EXPANSION: f64 = 0.1;

impl Energy {
    pub const NAMES: [&'static str; 5] =
        ["isometric", "conformal", "authalic", "stretch", "balanced"];

    pub fn name(self) -> &'static str {
        match self {
            Energy::Isometric => "isometric",
            Energy::Conformal => "conformal",
            Energy::Authalic => "authalic",
            Energy::Stretch => "stretch",
            Energy::Balanced => "balanced",
            Energy::BalancedWeighted(_) => "balanced (weighted)",
            Energy::CoarseStretch => "coarse stretch",
            Energy::CoarseBalanced => "coarse balanced",
        }
    }

    /// The energy to lower on the coarse levels of a progressive map. Stretch
    /// alone costs nothing where a triangle grows, so on coarse levels a few
    /// regions swell, and local moves at the finer levels cannot shrink them
    /// again: measured on scorpion, 1% of the faces (0.6% of the surface)
    /// ended up covering 45% of the sphere. A small cost of growth prevents
    /// that, and the final sweeps lower stretch alone (L2 stretch with 0.1:
    /// scorpion 2.961 -> 2.479, armadillo 1.594 -> 1.521, horse 1.604 ->
    /// 1.584, sword 2.604 -> 2.524, octopus 2.586 -> 2.577; 0.02 helped
    /// less, 0.2 and the isometric energy made horse worse).
    pub fn on_coarse_levels(self) -> Energy {
        match self {
            Energy::Stretch => Energy::CoarseStretch,
            Energy::Balanced | Energy::BalancedWeighted(_) => Energy::CoarseBalanced,
            other => other,
        }
    }

    pub fn from_name(name: &str) -> Option<Energy> {
        [Energy::Isometric, Energy::Conformal, Energy::Authalic, Energy::Stretch, Energy::Balanced]
            .into_iter()
            .find(|e| e.name() == name)
    }

    /// f(a, d) and its partial derivatives; infinite for d <= 0.
    #[inline]
    pub fn density(self, a: f64, d: f64) -> (f64, f64, f64) {
        if d <= 0.0 || !d.is_finite() || !a.is_finite() {
            return (f64::INFINITY, 0.0, 0.0);
        }
        match self {
            Energy::Isometric => {
                let inv2 = 1.0 / (d * d);
                (a * (1.0 + inv2), 1.0 + inv2, -2.0 * a * inv2 / d)
            }
            Energy::Conformal => {
                let (mut f, f_a, mut f_d) = (a / d, 1.0 / d, -a / (d * d));
                if d < CONFORMAL_AREA_FLOOR {
                    let excess = CONFORMAL_AREA_FLOOR / d - 1.0;
                    f += excess * excess;
                    f_d -= 2.0 * excess * CONFORMAL_AREA_FLOOR / (d * d);
                }
                (f, f_a, f_d)
            }
            Energy::Authalic => {
                let w = AUTHALIC_ANGLE_WEIGHT;
                (d + 1.0 / d + w * a / d, w / d, 1.0 - 1.0 / (d * d) - w * a / (d * d))
            }
            Energy::Stretch => {
                let inv2 = 1.0 / (d * d);
                (0.5 * a * inv2, 0.5 * inv2, -a * inv2 / d)
            }
            Energy::Balanced | Energy::BalancedWeighted(_) => {
                let (w, inv2) = (self.area_weight(), 1.0 / (d * d));
                (0.5 * a * inv2 + w * (d + 1.0 / d), 0.5 * inv2, -a * inv2 / d + w * (1.0 - inv2))
            }
            Energy::CoarseBalanced => {
                let (w, x) = (BALANCED_COARSE_AREA_WEIGHT, COARSE_STRETCH_EXPANSION);
                let inv2 = 1.0 / (d * d);
                let f = 0.5 * a * inv2 + w * (d + 1.0 / d) + x * a;
                (f, 0.5 * inv2 + x, -a * inv2 / d + w * (1.0 - inv2))
            }
            Energy::CoarseStretch => {
                let (w, inv2) = (COARSE_STRETCH_EXPANSION, 1.0 / (d * d));
                (0.5 * a * inv2 + w * a, 0.5 * inv2 + w, -a * inv2 / d)
            }
        }
    }
}

impl Energy {
    /// The weight of the balanced energies' area term (0 for the others).
    pub fn area_weight(self) -> f64 {
        match self {
            Energy::Balanced => BALANCED_AREA_WEIGHT,
            Energy::BalancedWeighted(per_mille) => f64::from(per_mille) / 1000.0,
            Energy::CoarseBalanced => BALANCED_COARSE_AREA_WEIGHT,
            _ => 0.0,
        }
    }

    /// The second partial derivatives (f_aa, f_ad, f_dd) of [`Energy::density`].
    /// Every density is linear in a, so f_aa = 0.
    pub fn curvature(self, a: f64, d: f64) -> (f64, f64, f64) {
        if d <= 0.0 || !d.is_finite() || !a.is_finite() {
            return (0.0, 0.0, 0.0);
        }
        let (d2, d3) = (d * d, d * d * d);
        match self {
            Energy::Isometric => (0.0, -2.0 / d3, 6.0 * a / (d3 * d)),
            Energy::Conformal => {
                let mut f_dd = 2.0 * a / d3;
                if d < CONFORMAL_AREA_FLOOR {
                    let floor = CONFORMAL_AREA_FLOOR;
                    f_dd += 2.0 * floor * floor / (d3 * d) + 4.0 * floor * (floor / d - 1.0) / d3;
                }
                (0.0, -1.0 / d2, f_dd)
            }
            Energy::Authalic => {
                let w = AUTHALIC_ANGLE_WEIGHT;
                (0.0, -w / d2, 2.0 / d3 + 2.0 * w * a / d3)
            }
            Energy::Stretch | Energy::CoarseStretch => (0.0, -1.0 / d3, 3.0 * a / (d3 * d)),
            Energy::Balanced | Energy::BalancedWeighted(_) => {
                (0.0, -1.0 / d3, 3.0 * a / (d3 * d) + 2.0 * self.area_weight() / d3)
            }
            Energy::CoarseBalanced => {
                (0.0, -1.0 / d3, 3.0 * a / (d3 * d) + 2.0 * BALANCED_COARSE_AREA_WEIGHT / d3)
            }
        }
    }
}

/// A surface triangle seen from one corner: the Gram matrix of its two edges
/// from that corner, `[g00, g01, g11]`, and its area.
#[derive(Debug, Clone, Copy)]
pub struct Reference {
    pub gram: [f64; 3],
    pub area: f64,
}

impl Reference {
    /// The triangle `(s0, s1, s2)` seen from `s0`. A triangle smaller than
    /// `area_floor` (degenerate input) is replaced by an equilateral one of
    /// that area, so that G stays invertible.
    pub fn new(s0: [f64; 3], s1: [f64; 3], s2: [f64; 3], area_floor: f64) -> Reference {
        let (e1, e2) = (sub(s1, s0), sub(s2, s0));
        let area = 0.5 * norm(cross(e1, e2));
        if area >= area_floor && area.is_finite() {
            return Reference { gram: [dot(e1, e1), dot(e1, e2), dot(e2, e2)], area };
        }
        // Equilateral with side L: area = sqrt(3)/4 L^2, G = L^2 [[1, 1/2], [1/2, 1]].
        let l2 = area_floor * 4.0 / 3f64.sqrt();
        Reference { gram: [l2, 0.5 * l2, l2], area: area_floor }
    }

    /// The same triangle scaled by `factor` in area (its shape kept).
    pub fn scaled(self, factor: f64) -> Reference {
        let [g00, g01, g11] = self.gram;
        Reference { gram: [g00 * factor, g01 * factor, g11 * factor], area: self.area * factor }
    }
}

/// What every face term is built from (with G = `r.gram`): the edges
/// q1 = p1 - p0 and q2 = p2 - p0, k det G, the Dirichlet term
/// a = |J|_F^2 = (|q1|^2 g11 - 2 q1.q2 g01 + |q2|^2 g00) / (k det G), the
/// face's surface area scaled by k and d = det J (the image's area,
/// det[p0, p1, p2] / 2, over that scaled area).
struct FaceTerms {
    q1: [f64; 3],
    q2: [f64; 3],
    kdet: f64,
    a: f64,
    area_s: f64,
    d: f64,
}

impl FaceTerms {
    fn new(r: &Reference, k: f64, p0: [f64; 3], p1: [f64; 3], p2: [f64; 3]) -> FaceTerms {
        let (q1, q2) = (sub(p1, p0), sub(p2, p0));
        let [g00, g01, g11] = r.gram;
        let kdet = k * (g00 * g11 - g01 * g01);
        let a = (dot(q1, q1) * g11 - 2.0 * dot(q1, q2) * g01 + dot(q2, q2) * g00) / kdet;
        let area_s = k * r.area;
        let d = 0.5 * det3(p0, p1, p2) / area_s;
        FaceTerms { q1, q2, kdet, a, area_s, d }
    }
}

/// Energy of one face whose image corners are `p0, p1, p2` (the surface seen
/// from the corner of `p0`), with the surface scaled by `k` in area.
pub fn face_energy(
    energy: Energy,
    r: &Reference,
    k: f64,
    p0: [f64; 3],
    p1: [f64; 3],
    p2: [f64; 3],
) -> f64 {
    let t = FaceTerms::new(r, k, p0, p1, p2);
    t.area_s * energy.density(t.a, t.d).0
}

/// [`face_energy`], its gradient and its 3x3 Hessian with respect to `p0`: a is
/// quadratic in p0 (its Hessian is a multiple of the identity) and d linear,
/// so the Hessian is exact and costs little more than the gradient.
pub fn face_energy_hessian(
    energy: Energy,
    r: &Reference,
    k: f64,
    p0: [f64; 3],
    p1: [f64; 3],
    p2: [f64; 3],
) -> (f64, [f64; 3], [[f64; 3]; 3]) {
    let FaceTerms { q1, q2, kdet, a, area_s, d } = FaceTerms::new(r, k, p0, p1, p2);
    let [g00, g01, g11] = r.gram;
    let (f, f_a, f_d) = energy.density(a, d);
    if !f.is_finite() {
        return (f64::INFINITY, [0.0; 3], [[0.0; 3]; 3]);
    }
    let (_, f_ad, f_dd) = energy.curvature(a, d);
    let d_area = cross(p1, p2);
    let mut da = [0.0; 3];
    let mut dd = [0.0; 3];
    for i in 0..3 {
        da[i] = (-2.0 * q1[i] * g11 + 2.0 * (q1[i] + q2[i]) * g01 - 2.0 * q2[i] * g00) / kdet;
        dd[i] = 0.5 * d_area[i] / area_s;
    }
    let grad = [0, 1, 2].map(|i| area_s * (f_a * da[i] + f_d * dd[i]));
    let a_curv = 2.0 * (g11 + g00 - 2.0 * g01) / kdet;
    let mut hess = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let mut h = f_ad * (da[i] * dd[j] + dd[i] * da[j]) + f_dd * dd[i] * dd[j];
            if i == j {
                h += f_a * a_curv;
            }
            hess[i][j] = area_s * h;
        }
    }
    (area_s * f, grad, hess)
}

/// [`face_energy`] and its gradients with respect to all three corners
/// (`p0`, `p1`, `p2`, in that order), and the density's derivative f_a, the
/// weight of the face's Dirichlet term a (which the preconditioner of
/// [`crate::methods::progressive::lbfgs`] is built from). With q1 = p1 - p0,
/// q2 = p2 - p0: da/dp1 = 2 (g11 q1 - g01 q2) / (k det G), da/dp2 =
/// 2 (g00 q2 - g01 q1) / (k det G), da/dp0 = -(da/dp1 + da/dp2); d is linear
/// in each corner, dd/dp0 = (p1 x p2) / (2 A), and so on cyclically.
/// Infinite energy (and zero gradients) where the face is not positive.
pub fn face_energy_gradients(
    energy: Energy,
    r: &Reference,
    k: f64,
    p0: [f64; 3],
    p1: [f64; 3],
    p2: [f64; 3],
) -> (f64, [[f64; 3]; 3], f64) {
    let FaceTerms { q1, q2, kdet, a, area_s, d } = FaceTerms::new(r, k, p0, p1, p2);
    let [g00, g01, g11] = r.gram;
    let (f, f_a, f_d) = energy.density(a, d);
    if !f.is_finite() {
        return (f64::INFINITY, [[0.0; 3]; 3], 0.0);
    }
    let da1 = [0, 1, 2].map(|i| 2.0 * (q1[i] * g11 - q2[i] * g01) / kdet);
    let da2 = [0, 1, 2].map(|i| 2.0 * (q2[i] * g00 - q1[i] * g01) / kdet);
    let da0 = [0, 1, 2].map(|i| -(da1[i] + da2[i]));
    let dd = [cross(p1, p2), cross(p2, p0), cross(p0, p1)];
    let half = 0.5 / area_s;
    let grads = [da0, da1, da2]
        .iter()
        .zip(dd)
        .map(|(da, dd)| [0, 1, 2].map(|i| area_s * (f_a * da[i] + f_d * half * dd[i])))
        .collect::<Vec<_>>();
    (area_s * f, [grads[0], grads[1], grads[2]], f_a)
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: [Energy; 8] = [
        Energy::Isometric,
        Energy::Conformal,
        Energy::Authalic,
        Energy::Stretch,
        Energy::Balanced,
        Energy::BalancedWeighted(700),
        Energy::CoarseStretch,
        Energy::CoarseBalanced,
    ];

    #[test]
    fn an_isometry_has_the_smallest_density_and_collapse_costs_without_bound() {
        // Isometry: a = 2, d = 1. Stretch alone prefers larger triangles;
        // the sphere's fixed total area rules those out.
        for e in ALL {
            let (f0, _, _) = e.density(2.0, 1.0);
            for (a, d) in [(2.5, 1.0), (4.0, 1.0), (2.2, 0.9), (3.0, 1.4), (8.0, 0.3)] {
                if matches!(
                    e,
                    Energy::Stretch
                        | Energy::Balanced
                        | Energy::BalancedWeighted(_)
                        | Energy::CoarseStretch
                        | Energy::CoarseBalanced
                ) && d > 1.0
                {
                    continue;
                }
                assert!(e.density(a, d).0 > f0 - 1e-12, "{e:?} at ({a}, {d})");
            }
            // a >= 2 d always; shrinking a triangle to a point keeps a = 2 d.
            assert!(e.density(2e-9, 1e-9).0 > 1e6 * f0, "{e:?} has no barrier");
            assert_eq!(e.density(1.0, 0.0).0, f64::INFINITY);
        }
    }

    #[test]
    fn the_gradient_is_the_derivative_of_the_energy() {
        let r = Reference::new([0.0, 0.0, 0.0], [1.0, 0.1, 0.0], [0.3, 0.8, 0.2], 1e-12);
        let (p0, p1, p2) = ([0.9, 0.1, 0.2], [0.1, 0.95, 0.1], [0.15, 0.2, 0.95]);
        for e in ALL {
            let (f, g, _) = face_energy_hessian(e, &r, 0.7, p0, p1, p2);
            assert!((f - face_energy(e, &r, 0.7, p0, p1, p2)).abs() < 1e-12 * f.abs());
            for i in 0..3 {
                let h = 1e-6;
                let (mut plus, mut minus) = (p0, p0);
                plus[i] += h;
                minus[i] -= h;
                let numeric = (face_energy(e, &r, 0.7, plus, p1, p2)
                    - face_energy(e, &r, 0.7, minus, p1, p2))
                    / (2.0 * h);
                assert!(
                    (numeric - g[i]).abs() < 1e-5 * (1.0 + g[i].abs()),
                    "{e:?} {i}: {numeric} vs {}",
                    g[i]
                );
            }
        }
    }

    #[test]
    fn the_gradients_of_all_corners_are_the_derivatives_of_the_energy() {
        let r = Reference::new([0.0, 0.0, 0.0], [1.0, 0.1, 0.0], [0.3, 0.8, 0.2], 1e-12);
        let p = [[0.9, 0.1, 0.2], [0.1, 0.95, 0.1], [0.15, 0.2, 0.95]];
        for e in ALL {
            let (f, g, _) = face_energy_gradients(e, &r, 0.7, p[0], p[1], p[2]);
            assert!((f - face_energy(e, &r, 0.7, p[0], p[1], p[2])).abs() < 1e-12 * f.abs());
            for c in 0..3 {
                for i in 0..3 {
                    let h = 1e-6;
                    let (mut plus, mut minus) = (p, p);
                    plus[c][i] += h;
                    minus[c][i] -= h;
                    let numeric = (face_energy(e, &r, 0.7, plus[0], plus[1], plus[2])
                        - face_energy(e, &r, 0.7, minus[0], minus[1], minus[2]))
                        / (2.0 * h);
                    assert!(
                        (numeric - g[c][i]).abs() < 1e-5 * (1.0 + g[c][i].abs()),
                        "{e:?} corner {c} {i}: {numeric} vs {}",
                        g[c][i]
                    );
                }
            }
        }
    }

    #[test]
    fn the_hessian_is_the_derivative_of_the_gradient() {
        let r = Reference::new([0.0, 0.0, 0.0], [1.0, 0.1, 0.0], [0.3, 0.8, 0.2], 1e-12);
        let (p0, p1, p2) = ([0.9, 0.1, 0.2], [0.1, 0.95, 0.1], [0.15, 0.2, 0.95]);
        // Also inside the conformal barrier (d below the floor).
        let (q1, q2) = ([0.903, 0.1, 0.2], [0.9, 0.103, 0.2]);
        let r_small = face_energy_hessian(Energy::Conformal, &r, 0.7, p0, q1, q2);
        let d = 0.5 * det3(p0, q1, q2) / (0.7 * r.area);
        assert!(d > 0.0 && d < CONFORMAL_AREA_FLOOR, "{d} {r_small:?}");
        for e in ALL {
            for (a, b) in [(p1, p2), (q1, q2)] {
                let (f, _, h) = face_energy_hessian(e, &r, 0.7, p0, a, b);
                assert_eq!(f, face_energy(e, &r, 0.7, p0, a, b));
                for j in 0..3 {
                    let step = 1e-7;
                    let (mut plus, mut minus) = (p0, p0);
                    plus[j] += step;
                    minus[j] -= step;
                    let gp = face_energy_hessian(e, &r, 0.7, plus, a, b).1;
                    let gm = face_energy_hessian(e, &r, 0.7, minus, a, b).1;
                    for i in 0..3 {
                        let numeric = (gp[i] - gm[i]) / (2.0 * step);
                        let scale = 1.0 + h[i][j].abs();
                        assert!(
                            (numeric - h[i][j]).abs() < 1e-4 * scale,
                            "{e:?} {i}{j}: {numeric} vs {}",
                            h[i][j]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn names_round_trip() {
        for e in ALL.into_iter().filter(|&e| {
            !matches!(
                e,
                Energy::CoarseStretch | Energy::CoarseBalanced | Energy::BalancedWeighted(_)
            )
        }) {
            assert_eq!(Energy::from_name(e.name()), Some(e));
        }
        assert_eq!(Energy::from_name(Energy::CoarseStretch.name()), None);
        assert_eq!(Energy::from_name(Energy::CoarseBalanced.name()), None);
        assert_eq!(Energy::from_name(Energy::BalancedWeighted(150).name()), None);
        assert_eq!(Energy::NAMES.map(|n| Energy::from_name(n).unwrap().name()), Energy::NAMES);
        assert_eq!(Energy::from_name("harmonic"), None);
    }
}
