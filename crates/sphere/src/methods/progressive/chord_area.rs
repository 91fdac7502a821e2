//! The chord-area term of the stretch and balanced energies: Sander et al.'s
//! normalisation of L2 stretch, which the per-face densities of
//! [`crate::methods::progressive::distortion_energy`] leave out.
//!
//! Why: Sander, Snyder, Gortler and Hoppe (2001, section 4.1) make L2 stretch
//! scale-free by multiplying it by sqrt(total domain area / total surface
//! area). Measured on the chord triangles of a sphere map (as issue 22's
//! evaluator and Praun and Hoppe 2003 do), the domain area is the sum of the
//! chord triangles' areas C, which is not fixed: long triangles along great
//! circles have chords far inside the sphere, and C grows above 4 pi. The
//! densities measure each face's image by det[p0, p1, p2] / 2 (whose sum is
//! three times the enclosed volume, at most 4 pi), so lowering them alone let
//! C grow: on 20k-vertex `helix_tube` the balanced map had C = 26.8 against
//! SphereParam's 17.4, `tentacles` 17.4 against 13.6, `urchin` 19.3 against
//! 13.8, and squared L2 stretch is the densities' sum times C. Twenty sweeps of
//! the stretch energy from an isometric map of `tentacles` lowered the
//! density sum by 8% but raised C by 5%.
//!
//! The measured quantity is the product E C (E the density sum). Its
//! first-order change at the current (E0, C0) is C0 dE + E0 dC, so the sweeps
//! and global steps lower E + mu C with mu = [`CHORD_WEIGHT`] E0 / C0, taken
//! afresh once per sweep or global run, as the area scale k is. C is a sum of
//! face terms, so a vertex move still sees only its own faces.
//!
//! For one face with chord normal n = (p1 - p0) x (p2 - p0), the chord area is
//! |n| / 2; its gradient with respect to p0 is (p1 - p2) x n^ / 2 (cyclically
//! for p1 and p2), and its Hessian with respect to p0 is
//! [e]x^T (I - n^ n^T) [e]x / (2 |n|) with e = p1 - p2, positive semidefinite.

use spherify_mesh::vec3::{cross, dot, norm, scale, sub};

use crate::methods::progressive::distortion_energy::Energy;

/// The fraction of the first-order weight E0 / C0 that is used. The full
/// weight lowers stretch most on tubes, but at a cost in area that the
/// balanced energy's area term must then pay back: measured on 20k-vertex
/// `helix_tube` (balanced, area weight 0.15) L2 stretch 4.840 without the
/// term, 4.040 with the full weight (SphereParam 4.155); on octopus the full
/// weight took the area from 0.571 to 0.627 for a stretch of 2.536 against
/// 2.541, while 0.3 (with area weight 0.6) gave 2.507 and 0.545 (SphereParam
/// 2.640 and 0.554), and helix_tube 4.054 and 0.781 (SphereParam 0.784).
pub const CHORD_WEIGHT: f64 = 0.3;

/// Whether `energy` pays for chord area: the final levels of the stretch and
/// balanced energies, whose densities have no cost of growth.
pub fn applies(energy: Energy) -> bool {
    matches!(energy, Energy::Stretch | Energy::Balanced | Energy::BalancedWeighted(_))
}

/// mu = [`CHORD_WEIGHT`] E / C for the density sum `energy` and chord-area sum `chord`, or 0
/// when `applies` is false or either is not a positive finite number.
pub fn weight(applies: bool, energy: f64, chord: f64) -> f64 {
    let mu = CHORD_WEIGHT * energy / chord;
    if applies && energy > 0.0 && chord > 0.0 && mu.is_finite() {
        mu
    } else {
        0.0
    }
}

/// Area of the chord triangle `(p0, p1, p2)`.
pub fn chord_area(p0: [f64; 3], p1: [f64; 3], p2: [f64; 3]) -> f64 {
    0.5 * norm(cross(sub(p1, p0), sub(p2, p0)))
}

/// [`chord_area`], its gradient and its 3x3 Hessian with respect to `p0`
/// (zero for a degenerate chord triangle, which no positive face has).
pub fn chord_area_hessian(
    p0: [f64; 3],
    p1: [f64; 3],
    p2: [f64; 3],
) -> (f64, [f64; 3], [[f64; 3]; 3]) {
    let n = cross(sub(p1, p0), sub(p2, p0));
    let len = norm(n);
    if len == 0.0 || !len.is_finite() {
        return (0.0, [0.0; 3], [[0.0; 3]; 3]);
    }
    let u = scale(n, 1.0 / len);
    let e = sub(p1, p2);
    // Column j of [e]x is e x unit_j, so ([e]x^T [e]x)_ij = |e|^2 d_ij - e_i e_j
    // and (u^T [e]x)_j = (u x e)_j: H = (|e|^2 I - e e^T - w w^T) / (2 |n|)
    // with w = u x e, and the gradient (e x u) / 2 is -w / 2. (Written out
    // instead of through the three columns P [e]x and their nine products:
    // 7% of a balanced map's time went to this function.)
    let w = cross(u, e);
    let (ee, half) = (dot(e, e), 0.5 / len);
    let mut hess = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let diagonal = if i == j { ee } else { 0.0 };
            hess[i][j] = (diagonal - e[i] * e[j] - w[i] * w[j]) * half;
        }
    }
    (0.5 * len, scale(w, -0.5), hess)
}

/// [`chord_area`] and its gradients with respect to `p0`, `p1` and `p2`.
pub fn chord_area_gradients(p0: [f64; 3], p1: [f64; 3], p2: [f64; 3]) -> (f64, [[f64; 3]; 3]) {
    let n = cross(sub(p1, p0), sub(p2, p0));
    let len = norm(n);
    if len == 0.0 || !len.is_finite() {
        return (0.0, [[0.0; 3]; 3]);
    }
    let u = scale(n, 1.0 / len);
    let g = |a: [f64; 3], b: [f64; 3]| scale(cross(sub(a, b), u), 0.5);
    (0.5 * len, [g(p1, p2), g(p2, p0), g(p0, p1)])
}

#[cfg(test)]
mod tests {
    use super::*;

    const P: [[f64; 3]; 3] = [[0.9, 0.1, 0.2], [0.1, 0.95, 0.1], [0.15, 0.2, 0.95]];

    #[test]
    fn the_gradients_are_the_derivatives_of_the_area() {
        let (a, g) = chord_area_gradients(P[0], P[1], P[2]);
        assert!((a - chord_area(P[0], P[1], P[2])).abs() < 1e-15);
        for c in 0..3 {
            for i in 0..3 {
                let h = 1e-6;
                let (mut plus, mut minus) = (P, P);
                plus[c][i] += h;
                minus[c][i] -= h;
                let numeric = (chord_area(plus[0], plus[1], plus[2])
                    - chord_area(minus[0], minus[1], minus[2]))
                    / (2.0 * h);
                assert!((numeric - g[c][i]).abs() < 1e-8, "{c} {i}: {numeric} vs {}", g[c][i]);
            }
        }
        let (a0, g0, _) = chord_area_hessian(P[0], P[1], P[2]);
        assert_eq!(a0, a);
        assert!((0..3).all(|i| (g0[i] - g[0][i]).abs() < 1e-15));
    }

    #[test]
    fn the_hessian_is_the_derivative_of_the_gradient() {
        let (_, _, hess) = chord_area_hessian(P[0], P[1], P[2]);
        for j in 0..3 {
            let step = 1e-7;
            let (mut plus, mut minus) = (P[0], P[0]);
            plus[j] += step;
            minus[j] -= step;
            let gp = chord_area_hessian(plus, P[1], P[2]).1;
            let gm = chord_area_hessian(minus, P[1], P[2]).1;
            for i in 0..3 {
                let numeric = (gp[i] - gm[i]) / (2.0 * step);
                assert!((numeric - hess[i][j]).abs() < 1e-6, "{i}{j}: {numeric} vs {}", hess[i][j]);
            }
        }
    }

    #[test]
    fn the_weight_is_zero_where_it_does_not_apply() {
        assert_eq!(weight(false, 3.0, 2.0), 0.0);
        assert_eq!(weight(true, 3.0, 2.0), CHORD_WEIGHT * 1.5);
        assert_eq!(weight(true, 3.0, 0.0), 0.0);
        assert!(applies(Energy::Stretch) && applies(Energy::Balanced));
        assert!(!applies(Energy::Isometric) && !applies(Energy::CoarseBalanced));
    }
}
