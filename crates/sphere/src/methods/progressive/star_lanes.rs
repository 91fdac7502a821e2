//! The sums over a vertex's faces that every flip-free move evaluates
//! ([`crate::methods::progressive::flip_free`]): the energy with its gradient
//! and Hessian at the vertex, and the energy at a trial point, with the
//! chord-area term ([`crate::methods::progressive::chord_area`]) where the
//! energy pays for it. The faces are taken four at a time, laid out by lane
//! (structure of arrays), so that each arithmetic operation on four faces
//! compiles to one vector instruction; the thirteen or more divisions per
//! face of the Hessian (and the chord term's square root and two more) and
//! the three of the energy are most of a move's time when done one face at a
//! time (issue 27: the move is about 46% of the default map's CPU time;
//! issue 22: the balanced energy's moves dominate its sweeps).
//!
//! The densities with lanes: every energy. The isometric energy (the
//! default); the stretch family, stretch and balanced with their
//! coarse-level and weighted forms (f = a / (2 d^2), plus w (d + 1/d) for
//! the balanced area term, plus x a for the coarse levels' expansion cost);
//! the conformal energy (a / d, plus (F / d - 1)^2 below the area floor F,
//! that branch taken by lane with a mask) and the authalic energy
//! (d + 1/d + w a / d).
//!
//! **The same bits as one face at a time**: each lane performs exactly the
//! operations, in the same order, of
//! [`crate::methods::progressive::distortion_energy::face_energy_hessian`],
//! [`crate::methods::progressive::distortion_energy::face_energy`] (with
//! `Energy::density` and `Energy::curvature`),
//! [`crate::methods::progressive::chord_area::chord_area_hessian`] and
//! [`crate::methods::progressive::chord_area::chord_area`], and of their
//! combination in `flip_free::star_hessian` / `star_energy` (IEEE 754 rounds
//! a vector lane as it rounds a scalar, and Rust contracts no `a * b + c`
//! into a fused multiply-add); the faces' terms are then added in ring order
//! as before. Where the processor has AVX2 the lanes run as one 256-bit
//! vector (code compiled for it, chosen at run time); elsewhere the faces go
//! one at a time, as before. A star with any face whose energy is not finite
//! gives `None`, as the scalar sum (infinite) made the move give up.

use spherify_mesh::predicates::{det3_sign, Sign};
use spherify_mesh::vec3::{det3, norm, sub};

use spherify_mesh::vec3::{add, scale};

use crate::methods::progressive::chord_area::{chord_area, chord_area_gradients};
use crate::methods::progressive::distortion_energy::{
    face_energy, face_energy_gradients, Energy, Reference, COARSE_STRETCH_EXPANSION,
};
use crate::methods::progressive::flip_free::{star_energy, star_hessian};

/// Faces per group.
const LANES: usize = 4;

type Lane = [f64; LANES];

/// The energy, gradient and Hessian sums of a star.
type Sums = (f64, [f64; 3], [[f64; 3]; 3]);

/// Whether the lanes can run here (x86-64 with AVX2; the answer is cached
/// by the standard library). Elsewhere [`hessian`] and [`energy`] add the
/// faces one at a time, with the same bits.
#[inline]
pub fn available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// A density the lanes evaluate, with its weights (see [`Energy::density`]).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Density {
    /// a (1 + 1 / d^2).
    Isometric,
    /// a / (2 d^2), plus `area` times (d + 1/d) (the balanced energies),
    /// plus `expansion` times a (the coarse levels' cost of growth).
    Stretch { area: Option<f64>, expansion: Option<f64> },
    /// a / d, plus (F / d - 1)^2 where d < F = `CONFORMAL_AREA_FLOOR`.
    Conformal,
    /// d + 1/d + w a / d, w = `AUTHALIC_ANGLE_WEIGHT`.
    Authalic,
}

/// The lanes' form of `energy`'s density (every energy has one; `None` is
/// kept for a density without lanes).
fn density(energy: Energy) -> Option<Density> {
    let stretch = |area, expansion| Some(Density::Stretch { area, expansion });
    match energy {
        Energy::Isometric => Some(Density::Isometric),
        Energy::Stretch => stretch(None, None),
        Energy::CoarseStretch => stretch(None, Some(COARSE_STRETCH_EXPANSION)),
        Energy::Balanced | Energy::BalancedWeighted(_) => stretch(Some(energy.area_weight()), None),
        Energy::CoarseBalanced => {
            stretch(Some(energy.area_weight()), Some(COARSE_STRETCH_EXPANSION))
        }
        Energy::Conformal => Some(Density::Conformal),
        Energy::Authalic => Some(Density::Authalic),
    }
}

/// Whether [`hessian`] and [`energy`] run `energy`'s faces in lanes here.
#[inline]
pub fn handles(energy: Energy) -> bool {
    density(energy).is_some() && available()
}

/// `energy`'s density over the faces `(p, corners[j], corners[j + 1])` with
/// references `refs[j]`, plus `chord` times their chord areas, its gradient
/// and its Hessian at `p`: the sums of `flip_free::star_hessian` (bit for
/// bit), or `None` if a face's energy is not finite (where that sum is
/// infinite).
pub fn hessian(
    energy: Energy,
    k: f64,
    chord: f64,
    p: [f64; 3],
    refs: &[Reference],
    corners: &[[f64; 3]],
) -> Option<Sums> {
    #[cfg(target_arch = "x86_64")]
    if let (Some(density), true) = (density(energy), available()) {
        // SAFETY: the processor has AVX2 (asked just above).
        return unsafe { lanes::hessian(density, k, chord, p, refs, corners) };
    }
    scalar_hessian(energy, k, chord, p, refs, corners)
}

/// The same energy of the same faces at `p`: `flip_free::star_energy`, bit
/// for bit.
pub fn energy(
    energy: Energy,
    k: f64,
    chord: f64,
    p: [f64; 3],
    refs: &[Reference],
    corners: &[[f64; 3]],
) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if let (Some(density), true) = (density(energy), available()) {
        // SAFETY: the processor has AVX2 (asked just above).
        return unsafe { lanes::energy(density, k, chord, p, refs, corners) };
    }
    star_energy(energy, k, chord, p, refs, corners)
}

/// One face's energy plus `mu` times its chord area, that sum's gradients
/// at its three corners, and the density's f_a (what
/// [`crate::methods::progressive::lbfgs`] takes from each face).
pub type FaceGradients = (f64, [[f64; 3]; 3], f64);

/// [`face_gradients_one`] for each face `faces[f]` (corner indices into
/// `points`) with reference `refs[f]`, written to `out[f]` (as long as
/// `faces`).
pub fn face_gradients(
    energy: Energy,
    k: f64,
    mu: f64,
    points: &[[f64; 3]],
    (faces, refs): (&[[u32; 3]], &[Reference]),
    out: &mut [FaceGradients],
) {
    #[cfg(target_arch = "x86_64")]
    if let (Some(density), true) = (density(energy), available()) {
        // SAFETY: the processor has AVX2 (asked just above).
        return unsafe { lanes::face_gradients(density, k, mu, points, faces, refs, out) };
    }
    for ((&f, r), x) in faces.iter().zip(refs).zip(out) {
        *x = face_gradients_one(energy, r, k, mu, f.map(|v| points[v as usize]));
    }
}

/// One face's [`FaceGradients`], one face at a time: `face_energy_gradients`
/// with `mu` times `chord_area_gradients` added where the energy is finite.
pub fn face_gradients_one(
    energy: Energy,
    r: &Reference,
    k: f64,
    mu: f64,
    [pa, pb, pc]: [[f64; 3]; 3],
) -> FaceGradients {
    let (mut e, mut g, f_a) = face_energy_gradients(energy, r, k, pa, pb, pc);
    if mu != 0.0 && e.is_finite() {
        let (area, cg) = chord_area_gradients(pa, pb, pc);
        e += mu * area;
        for (gi, ci) in g.iter_mut().zip(cg) {
            *gi = add(*gi, scale(ci, mu));
        }
    }
    (e, g, f_a)
}

/// The sum in face order (from -0.0, as `Iterator::sum`) of each face's
/// energy plus `mu` times its chord area: [`face_energy_one`] added up.
pub fn faces_energy(
    energy: Energy,
    k: f64,
    mu: f64,
    points: &[[f64; 3]],
    faces: &[[u32; 3]],
    refs: &[Reference],
) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if let (Some(density), true) = (density(energy), available()) {
        // SAFETY: the processor has AVX2 (asked just above).
        return unsafe { lanes::faces_energy(density, k, mu, points, faces, refs) };
    }
    faces
        .iter()
        .zip(refs)
        .map(|(&f, r)| face_energy_one(energy, r, k, mu, f.map(|v| points[v as usize])))
        .sum()
}

/// One face's energy plus `mu` times its chord area, one face at a time.
pub fn face_energy_one(
    energy: Energy,
    r: &Reference,
    k: f64,
    mu: f64,
    [pa, pb, pc]: [[f64; 3]; 3],
) -> f64 {
    let e = face_energy(energy, r, k, pa, pb, pc);
    if mu == 0.0 {
        e
    } else {
        e + mu * chord_area(pa, pb, pc)
    }
}

/// The largest `t` for which every face `(p + t step, a, b)` of the fan
/// of `corners` around `p` keeps det > 0 to first order: the least of
/// -det[p, a, b] / det[step, a, b] over the faces where the latter is
/// negative (infinite where none is).
pub fn safe_step(p: [f64; 3], step: [f64; 3], corners: &[[f64; 3]]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if available() {
        // SAFETY: the processor has AVX2 (asked just above).
        return unsafe { lanes::safe_step(p, step, corners) };
    }
    let m = corners.len();
    let mut t_safe = f64::INFINITY;
    for j in 0..m {
        let (a, b) = (corners[j], corners[(j + 1) % m]);
        let rate = det3(step, a, b);
        if rate < 0.0 {
            t_safe = t_safe.min(-det3(p, a, b) / rate);
        }
    }
    t_safe
}

/// The distance from `p` to its nearest corner.
pub fn reach(p: [f64; 3], corners: &[[f64; 3]]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if available() {
        // SAFETY: the processor has AVX2 (asked just above).
        return unsafe { lanes::reach(p, corners) };
    }
    corners.iter().map(|&r| norm(sub(r, p))).fold(f64::INFINITY, f64::min)
}

/// Whether every face `(q, corners[j], corners[j + 1])` is positively
/// oriented, exactly: Shewchuk's first filter of `orient3d` (as the
/// `robust` crate computes it, with the origin as fourth point) four faces
/// at a time, and the exact [`det3_sign`] for a face it cannot decide.
pub fn positive_fan(q: [f64; 3], corners: &[[f64; 3]]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if available() {
        // SAFETY: the processor has AVX2 (asked just above).
        return unsafe { lanes::positive_fan(q, corners) };
    }
    let m = corners.len();
    (0..m).all(|j| det3_sign(q, corners[j], corners[(j + 1) % m]) == Sign::Positive)
}

/// [`hessian`] one face at a time, as the moves of the other energies add
/// them.
fn scalar_hessian(
    energy: Energy,
    k: f64,
    chord: f64,
    p: [f64; 3],
    refs: &[Reference],
    corners: &[[f64; 3]],
) -> Option<Sums> {
    let total = star_hessian(energy, k, chord, p, refs, corners);
    total.0.is_finite().then_some(total)
}

#[cfg(target_arch = "x86_64")]
mod lanes {
    //! Four faces per 256-bit vector. Every expression below is the scalar
    //! one of `distortion_energy` (`FaceTerms::new`, `face_energy_hessian`,
    //! `Energy::density` and `Energy::curvature`), of `chord_area` and of
    //! `flip_free::star_hessian` / `star_energy`, with its operations in the
    //! same order.

    use std::arch::x86_64::*;
    use std::ops::{Add, Div, Mul, Sub};

    use spherify_mesh::predicates::{det3_sign, Sign};

    use super::{Density, Lane, Sums, LANES};
    use crate::methods::progressive::distortion_energy::{
        Reference, AUTHALIC_ANGLE_WEIGHT, CONFORMAL_AREA_FLOOR,
    };

    #[derive(Clone, Copy)]
    struct F4(__m256d);

    // The operators are inlined into the `avx2` functions below, where the
    // intrinsics are available; they are never called elsewhere.
    impl F4 {
        #[inline(always)]
        fn splat(x: f64) -> F4 {
            F4(unsafe { _mm256_set1_pd(x) })
        }
        #[inline(always)]
        fn load(a: &Lane) -> F4 {
            F4(unsafe { _mm256_loadu_pd(a.as_ptr()) })
        }
        #[inline(always)]
        fn abs(self) -> F4 {
            F4(unsafe { _mm256_andnot_pd(_mm256_set1_pd(-0.0), self.0) })
        }
        /// `-x`: the sign bit flipped, as the scalar negation.
        #[inline(always)]
        fn neg(self) -> F4 {
            F4(unsafe { _mm256_xor_pd(_mm256_set1_pd(-0.0), self.0) })
        }
        /// Each lane where `keep` holds, and +0.0 elsewhere.
        #[inline(always)]
        fn and(self, keep: F4) -> F4 {
            F4(unsafe { _mm256_and_pd(self.0, keep.0) })
        }
        /// `self` where `mask` is set, `other` elsewhere.
        #[inline(always)]
        fn select(self, mask: F4, other: F4) -> F4 {
            F4(unsafe { _mm256_blendv_pd(other.0, self.0, mask.0) })
        }
        /// All bits set where the lane is finite.
        #[inline(always)]
        fn finite_mask(self) -> F4 {
            F4::splat(f64::INFINITY).gt(self.abs())
        }
        /// All bits set where `self > o` (ordered: false for a NaN).
        #[inline(always)]
        fn gt(self, o: F4) -> F4 {
            F4(unsafe { _mm256_cmp_pd::<_CMP_GT_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn sqrt(self) -> F4 {
            F4(unsafe { _mm256_sqrt_pd(self.0) })
        }
        #[inline(always)]
        fn lanes(self) -> Lane {
            let mut a = [0.0; LANES];
            unsafe { _mm256_storeu_pd(a.as_mut_ptr(), self.0) };
            a
        }
    }
    impl Add for F4 {
        type Output = F4;
        #[inline(always)]
        fn add(self, o: F4) -> F4 {
            F4(unsafe { _mm256_add_pd(self.0, o.0) })
        }
    }
    impl Sub for F4 {
        type Output = F4;
        #[inline(always)]
        fn sub(self, o: F4) -> F4 {
            F4(unsafe { _mm256_sub_pd(self.0, o.0) })
        }
    }
    impl Mul for F4 {
        type Output = F4;
        #[inline(always)]
        fn mul(self, o: F4) -> F4 {
            F4(unsafe { _mm256_mul_pd(self.0, o.0) })
        }
    }
    impl Div for F4 {
        type Output = F4;
        #[inline(always)]
        fn div(self, o: F4) -> F4 {
            F4(unsafe { _mm256_div_pd(self.0, o.0) })
        }
    }

    /// Up to four faces `(p, a, b)` of one star, by lane: their two other
    /// corners and references. A short last group repeats its last face in
    /// the unused lanes, whose results are never read.
    struct Group {
        a: [F4; 3],
        b: [F4; 3],
        g00: F4,
        g01: F4,
        g11: F4,
        area: F4,
        len: usize,
    }

    #[inline(always)]
    fn group(refs: &[Reference], corners: &[[f64; 3]], first: usize) -> Group {
        let m = corners.len();
        let len = (m - first).min(LANES);
        let (mut a, mut b) = ([[0.0; LANES]; 3], [[0.0; LANES]; 3]);
        let mut gram = [[0.0; LANES]; 4];
        for l in 0..LANES {
            let j = first + l.min(len - 1);
            let (pa, pb) = (corners[j], corners[if j + 1 == m { 0 } else { j + 1 }]);
            for c in 0..3 {
                a[c][l] = pa[c];
                b[c][l] = pb[c];
            }
            let r = &refs[j];
            gram[0][l] = r.gram[0];
            gram[1][l] = r.gram[1];
            gram[2][l] = r.gram[2];
            gram[3][l] = r.area;
        }
        Group {
            a: [F4::load(&a[0]), F4::load(&a[1]), F4::load(&a[2])],
            b: [F4::load(&b[0]), F4::load(&b[1]), F4::load(&b[2])],
            g00: F4::load(&gram[0]),
            g01: F4::load(&gram[1]),
            g11: F4::load(&gram[2]),
            area: F4::load(&gram[3]),
            len,
        }
    }

    /// The two corners other than the centre of the faces `first ..
    /// first + 4` of a fan (fewer at the end; the last repeated).
    #[inline(always)]
    fn fan_group(corners: &[[f64; 3]], first: usize) -> ([F4; 3], [F4; 3], usize) {
        let m = corners.len();
        let len = (m - first).min(LANES);
        let (mut a, mut b) = ([[0.0; LANES]; 3], [[0.0; LANES]; 3]);
        for l in 0..LANES {
            let j = first + l.min(len - 1);
            let (pa, pb) = (corners[j], corners[if j + 1 == m { 0 } else { j + 1 }]);
            for c in 0..3 {
                a[c][l] = pa[c];
                b[c][l] = pb[c];
            }
        }
        let load = |x: &[Lane; 3]| [F4::load(&x[0]), F4::load(&x[1]), F4::load(&x[2])];
        (load(&a), load(&b), len)
    }

    /// `cross(a, b)` by lane, as `vec3::cross`.
    #[inline(always)]
    fn cross(a: [F4; 3], b: [F4; 3]) -> [F4; 3] {
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    }

    #[inline(always)]
    fn splat3(p: [f64; 3]) -> [F4; 3] {
        [F4::splat(p[0]), F4::splat(p[1]), F4::splat(p[2])]
    }

    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn safe_step(p: [f64; 3], step: [f64; 3], corners: &[[f64; 3]]) -> f64 {
        let (pv, sv) = (splat3(p), splat3(step));
        let mut t_safe = f64::INFINITY;
        for first in (0..corners.len()).step_by(LANES) {
            let (a, b, len) = fan_group(corners, first);
            let ab = cross(a, b);
            // det3(step, a, b) and det3(p, a, b): a dot product with a x b.
            let (rate, det) = (dot(sv, ab).lanes(), dot(pv, ab).lanes());
            for l in 0..len {
                if rate[l] < 0.0 {
                    t_safe = t_safe.min(-det[l] / rate[l]);
                }
            }
        }
        t_safe
    }

    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn reach(p: [f64; 3], corners: &[[f64; 3]]) -> f64 {
        let pv = splat3(p);
        let mut least = f64::INFINITY;
        // The corners as the first corners of the fan's faces.
        for first in (0..corners.len()).step_by(LANES) {
            let (a, _, len) = fan_group(corners, first);
            let e = [a[0] - pv[0], a[1] - pv[1], a[2] - pv[2]];
            let r = dot(e, e).sqrt().lanes();
            for x in &r[..len] {
                least = least.min(*x);
            }
        }
        least
    }

    /// `robust::orient3d`'s first error bound, (7 + 56 eps) eps.
    const O3DERRBOUND_A: f64 = (7.0 + 56.0 * f64::EPSILON / 2.0) * (f64::EPSILON / 2.0);

    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn positive_fan(q: [f64; 3], corners: &[[f64; 3]]) -> bool {
        let qv = splat3(q);
        let bound = F4::splat(O3DERRBOUND_A);
        for first in (0..corners.len()).step_by(LANES) {
            let (b, c, len) = fan_group(corners, first);
            // orient3d(q, b, c, origin) as the robust crate evaluates it:
            // (a, b, c) - origin is exact.
            let [adx, ady, adz] = qv;
            let [bdx, bdy, bdz] = b;
            let [cdx, cdy, cdz] = c;
            let (bdxcdy, cdxbdy) = (bdx * cdy, cdx * bdy);
            let (cdxady, adxcdy) = (cdx * ady, adx * cdy);
            let (adxbdy, bdxady) = (adx * bdy, bdx * ady);
            let det = (adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy)) + cdz * (adxbdy - bdxady);
            let permanent = ((bdxcdy.abs() + cdxbdy.abs()) * adz.abs()
                + (cdxady.abs() + adxcdy.abs()) * bdz.abs())
                + (adxbdy.abs() + bdxady.abs()) * cdz.abs();
            let (det, errbound) = (det.lanes(), (bound * permanent).lanes());
            for l in 0..len {
                if det[l] > errbound[l] {
                    continue;
                }
                if -det[l] > errbound[l] {
                    return false;
                }
                let m = corners.len();
                let j = first + l;
                if det3_sign(q, corners[j], corners[(j + 1) % m]) != Sign::Positive {
                    return false;
                }
            }
        }
        true
    }

    /// `FaceTerms::new` by lane, with `a x b` (d's determinant's cross product).
    struct Terms {
        q1: [F4; 3],
        q2: [F4; 3],
        kdet: F4,
        a: F4,
        area_s: F4,
        d: F4,
        ab: [F4; 3],
    }

    #[inline(always)]
    fn dot(u: [F4; 3], v: [F4; 3]) -> F4 {
        u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
    }

    #[inline(always)]
    fn terms(k: f64, p: [f64; 3], g: &Group) -> Terms {
        terms_at(k, splat3(p), g)
    }

    /// [`terms`] with the first corner by lane (faces of a face list).
    #[inline(always)]
    fn terms_at(k: f64, pv: [F4; 3], g: &Group) -> Terms {
        let q1 = [g.a[0] - pv[0], g.a[1] - pv[1], g.a[2] - pv[2]];
        let q2 = [g.b[0] - pv[0], g.b[1] - pv[1], g.b[2] - pv[2]];
        let k = F4::splat(k);
        let kdet = k * (g.g00 * g.g11 - g.g01 * g.g01);
        let two = F4::splat(2.0);
        let a = (dot(q1, q1) * g.g11 - two * dot(q1, q2) * g.g01 + dot(q2, q2) * g.g00) / kdet;
        let area_s = k * g.area;
        let (a3, b3) = (g.a, g.b);
        let ab = [
            a3[1] * b3[2] - a3[2] * b3[1],
            a3[2] * b3[0] - a3[0] * b3[2],
            a3[0] * b3[1] - a3[1] * b3[0],
        ];
        let d = F4::splat(0.5) * dot(pv, ab) / area_s;
        Terms { q1, q2, kdet, a, area_s, d, ab }
    }

    /// Whether `Energy::density` is finite at every lane in use: it is
    /// infinite where d <= 0 or a or d is not finite, or where f overflows.
    #[inline(always)]
    fn finite(a: F4, d: F4, f: F4, len: usize) -> bool {
        let (a, d, f) = (a.lanes(), d.lanes(), f.lanes());
        let mut all = true;
        for l in 0..len {
            all &= admissible(a[l], d[l]) && f[l].is_finite();
        }
        all
    }

    /// Whether `Energy::density` takes its formula at (a, d), not infinity.
    #[inline(always)]
    fn admissible(a: f64, d: f64) -> bool {
        d > 0.0 && d.is_finite() && a.is_finite()
    }

    /// A density by lane: f, f_a, f_d (`Energy::density`) and f_ad, f_dd
    /// (`Energy::curvature`), each in the scalar code's order.
    trait LaneDensity: Copy {
        fn first(self, a: F4, d: F4) -> (F4, F4, F4);
        fn second(self, a: F4, d: F4) -> (F4, F4);
        /// f alone (the trial energy).
        fn value(self, a: F4, d: F4) -> F4;
    }

    #[derive(Clone, Copy)]
    struct Isometric;

    impl LaneDensity for Isometric {
        #[inline(always)]
        fn first(self, a: F4, d: F4) -> (F4, F4, F4) {
            let one = F4::splat(1.0);
            let inv2 = one / (d * d);
            (a * (one + inv2), one + inv2, F4::splat(-2.0) * a * inv2 / d)
        }
        #[inline(always)]
        fn second(self, a: F4, d: F4) -> (F4, F4) {
            let d3 = d * d * d;
            (F4::splat(-2.0) / d3, F4::splat(6.0) * a / (d3 * d))
        }
        #[inline(always)]
        fn value(self, a: F4, d: F4) -> F4 {
            let one = F4::splat(1.0);
            a * (one + one / (d * d))
        }
    }

    /// a / (2 d^2), plus w (d + 1/d) if `AREA`, plus x a if `EXPANSION`
    /// (stretch, balanced and their coarse-level forms), `two_w` = 2 w.
    #[derive(Clone, Copy)]
    struct Stretch<const AREA: bool, const EXPANSION: bool> {
        w: F4,
        two_w: F4,
        x: F4,
    }

    impl<const AREA: bool, const EXPANSION: bool> Stretch<AREA, EXPANSION> {
        #[inline(always)]
        fn f(self, a: F4, d: F4, inv2: F4) -> F4 {
            let mut f = F4::splat(0.5) * a * inv2;
            if AREA {
                f = f + self.w * (d + F4::splat(1.0) / d);
            }
            if EXPANSION {
                f = f + self.x * a;
            }
            f
        }
    }

    impl<const AREA: bool, const EXPANSION: bool> LaneDensity for Stretch<AREA, EXPANSION> {
        #[inline(always)]
        fn first(self, a: F4, d: F4) -> (F4, F4, F4) {
            let inv2 = F4::splat(1.0) / (d * d);
            let mut f_a = F4::splat(0.5) * inv2;
            if EXPANSION {
                f_a = f_a + self.x;
            }
            let mut f_d = a.neg() * inv2 / d;
            if AREA {
                f_d = f_d + self.w * (F4::splat(1.0) - inv2);
            }
            (self.f(a, d, inv2), f_a, f_d)
        }
        #[inline(always)]
        fn second(self, a: F4, d: F4) -> (F4, F4) {
            let d3 = d * d * d;
            let mut f_dd = F4::splat(3.0) * a / (d3 * d);
            if AREA {
                f_dd = f_dd + self.two_w / d3;
            }
            (F4::splat(-1.0) / d3, f_dd)
        }
        #[inline(always)]
        fn value(self, a: F4, d: F4) -> F4 {
            self.f(a, d, F4::splat(1.0) / (d * d))
        }
    }

    /// a / d, plus (F / d - 1)^2 where d < F (`Energy::Conformal`): the
    /// floor's branch computed in every lane and kept where d < F (a lane
    /// with d not below F, or NaN, keeps the plain value, as the scalar
    /// `if`).
    #[derive(Clone, Copy)]
    struct Conformal;

    impl Conformal {
        /// F, and the lanes where d < F.
        #[inline(always)]
        fn below(d: F4) -> (F4, F4) {
            let floor = F4::splat(CONFORMAL_AREA_FLOOR);
            (floor, floor.gt(d))
        }
    }

    impl LaneDensity for Conformal {
        #[inline(always)]
        fn first(self, a: F4, d: F4) -> (F4, F4, F4) {
            let (f, f_a, f_d) = (a / d, F4::splat(1.0) / d, a.neg() / (d * d));
            let (floor, below) = Conformal::below(d);
            let excess = floor / d - F4::splat(1.0);
            let f = (f + excess * excess).select(below, f);
            let f_d = (f_d - F4::splat(2.0) * excess * floor / (d * d)).select(below, f_d);
            (f, f_a, f_d)
        }
        #[inline(always)]
        fn second(self, a: F4, d: F4) -> (F4, F4) {
            let (d2, d3) = (d * d, d * d * d);
            let f_dd = F4::splat(2.0) * a / d3;
            let (floor, below) = Conformal::below(d);
            let two_ff = F4::splat(2.0 * CONFORMAL_AREA_FLOOR * CONFORMAL_AREA_FLOOR);
            let four_f = F4::splat(4.0 * CONFORMAL_AREA_FLOOR);
            let extra = two_ff / (d3 * d) + four_f * (floor / d - F4::splat(1.0)) / d3;
            (F4::splat(-1.0) / d2, (f_dd + extra).select(below, f_dd))
        }
        #[inline(always)]
        fn value(self, a: F4, d: F4) -> F4 {
            let f = a / d;
            let (floor, below) = Conformal::below(d);
            let excess = floor / d - F4::splat(1.0);
            (f + excess * excess).select(below, f)
        }
    }

    /// d + 1/d + w a / d (`Energy::Authalic`), `w` = the angle weight,
    /// `two_w` = 2 w.
    #[derive(Clone, Copy)]
    struct Authalic {
        w: F4,
        minus_w: F4,
        two_w: F4,
    }

    impl LaneDensity for Authalic {
        #[inline(always)]
        fn first(self, a: F4, d: F4) -> (F4, F4, F4) {
            let one = F4::splat(1.0);
            let f = d + one / d + self.w * a / d;
            let f_d = one - one / (d * d) - self.w * a / (d * d);
            (f, self.w / d, f_d)
        }
        #[inline(always)]
        fn second(self, a: F4, d: F4) -> (F4, F4) {
            let (d2, d3) = (d * d, d * d * d);
            (self.minus_w / d2, F4::splat(2.0) / d3 + self.two_w * a / d3)
        }
        #[inline(always)]
        fn value(self, a: F4, d: F4) -> F4 {
            d + F4::splat(1.0) / d + self.w * a / d
        }
    }

    /// Calls `$run` with `$density` as its [`LaneDensity`] type.
    macro_rules! with_density {
        ($density:expr, $run:ident($($arg:expr),*)) => {
            match $density {
                Density::Isometric => $run(Isometric, $($arg),*),
                Density::Conformal => $run(Conformal, $($arg),*),
                Density::Authalic => {
                    let w = AUTHALIC_ANGLE_WEIGHT;
                    let (minus_w, two_w) = (F4::splat(-w), F4::splat(2.0 * w));
                    $run(Authalic { w: F4::splat(w), minus_w, two_w }, $($arg),*)
                }
                Density::Stretch { area, expansion } => {
                    let w = area.unwrap_or(0.0);
                    let x = expansion.unwrap_or(0.0);
                    let s = |w: f64| (F4::splat(w), F4::splat(2.0 * w), F4::splat(x));
                    let (w, two_w, x) = s(w);
                    match (area.is_some(), expansion.is_some()) {
                        (false, false) => $run(Stretch::<false, false> { w, two_w, x }, $($arg),*),
                        (false, true) => $run(Stretch::<false, true> { w, two_w, x }, $($arg),*),
                        (true, false) => $run(Stretch::<true, false> { w, two_w, x }, $($arg),*),
                        (true, true) => $run(Stretch::<true, true> { w, two_w, x }, $($arg),*),
                    }
                }
            }
        };
    }

    /// The chord triangle's normal n = q1 x q2 by lane: |n|, the lanes
    /// where the triangle is not degenerate (|n| nonzero and finite), and
    /// the unit normal n / |n| (the start of [`chord_terms`] and of
    /// `face_gradients_with`'s chord step).
    #[inline(always)]
    fn chord_normal(q1: [F4; 3], q2: [F4; 3]) -> (F4, F4, [F4; 3]) {
        let n = cross(q1, q2);
        let len = dot(n, n).sqrt();
        // len != 0 and finite: len is a square root, so 0 < len < inf.
        let keep = len.gt(F4::splat(0.0)).and(F4::splat(f64::INFINITY).gt(len));
        let inv = F4::splat(1.0) / len;
        (len, keep, [n[0] * inv, n[1] * inv, n[2] * inv])
    }

    /// `chord_area_hessian(p, a, b)` by lane, with q1 = a - p, q2 = b - p:
    /// the chord area, its gradient and its Hessian at p, zero where the
    /// chord triangle is degenerate (|n| zero or not finite).
    #[inline(always)]
    fn chord_terms(
        q1: [F4; 3],
        q2: [F4; 3],
        a: [F4; 3],
        b: [F4; 3],
    ) -> (F4, [F4; 3], [[F4; 3]; 3]) {
        let (len, keep, u) = chord_normal(q1, q2);
        let e = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        let w = cross(u, e);
        let (ee, half) = (dot(e, e), F4::splat(0.5) / len);
        let (zero, minus_half) = (F4::splat(0.0), F4::splat(-0.5));
        let mut hess = [[zero; 3]; 3];
        for i in 0..3 {
            for j in i..3 {
                let diagonal = if i == j { ee } else { zero };
                // Symmetric: e_i e_j and w_i w_j are products of two factors.
                hess[i][j] = ((diagonal - e[i] * e[j] - w[i] * w[j]) * half).and(keep);
                hess[j][i] = hess[i][j];
            }
        }
        let grad = [
            (w[0] * minus_half).and(keep),
            (w[1] * minus_half).and(keep),
            (w[2] * minus_half).and(keep),
        ];
        ((F4::splat(0.5) * len).and(keep), grad, hess)
    }

    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn hessian(
        density: Density,
        k: f64,
        chord: f64,
        p: [f64; 3],
        refs: &[Reference],
        corners: &[[f64; 3]],
    ) -> Option<Sums> {
        with_density!(density, hessian_with(k, chord, p, refs, corners))
    }

    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn energy(
        density: Density,
        k: f64,
        chord: f64,
        p: [f64; 3],
        refs: &[Reference],
        corners: &[[f64; 3]],
    ) -> f64 {
        with_density!(density, energy_with(k, chord, p, refs, corners))
    }

    #[target_feature(enable = "avx2")]
    unsafe fn hessian_with<D: LaneDensity>(
        density: D,
        k: f64,
        chord: f64,
        p: [f64; 3],
        refs: &[Reference],
        corners: &[[f64; 3]],
    ) -> Option<Sums> {
        let mut total = (0.0, [0.0; 3], [[0.0; 3]; 3]);
        let (two, half, c) = (F4::splat(2.0), F4::splat(0.5), F4::splat(chord));
        for first in (0..corners.len()).step_by(LANES) {
            let g = group(refs, corners, first);
            let Terms { q1, q2, kdet, a, area_s, d, ab } = terms(k, p, &g);
            // Energy::density and Energy::curvature.
            let (f, f_a, f_d) = density.first(a, d);
            if !finite(a, d, f, g.len) {
                return None;
            }
            let (f_ad, f_dd) = density.second(a, d);
            // face_energy_hessian.
            let m2 = F4::splat(-2.0);
            // Plain loops: closures and `std::array::from_fn` were not
            // all inlined into this function's AVX2 code.
            let (mut da, mut dd) = ([F4::splat(0.0); 3], [F4::splat(0.0); 3]);
            let mut grad = [F4::splat(0.0); 3];
            for i in 0..3 {
                da[i] = (m2 * q1[i] * g.g11 + two * (q1[i] + q2[i]) * g.g01 - two * q2[i] * g.g00)
                    / kdet;
                dd[i] = half * ab[i] / area_s;
                grad[i] = area_s * (f_a * da[i] + f_d * dd[i]);
            }
            let a_curv = two * (g.g11 + g.g00 - two * g.g01) / kdet;
            let diagonal = f_a * a_curv;
            let mut hess = [[F4::splat(0.0); 3]; 3];
            for i in 0..3 {
                for j in 0..3 {
                    let mut h = f_ad * (da[i] * dd[j] + dd[i] * da[j]) + f_dd * dd[i] * dd[j];
                    if i == j {
                        h = h + diagonal;
                    }
                    hess[i][j] = area_s * h;
                }
            }
            let mut e = area_s * f;
            // star_hessian's chord-area term where the face's energy is
            // finite: e + chord ca, g + cg chord, h + ch chord.
            if chord != 0.0 {
                let (ca, cg, ch) = chord_terms(q1, q2, g.a, g.b);
                let fin = e.finite_mask();
                for i in 0..3 {
                    grad[i] = (grad[i] + cg[i] * c).select(fin, grad[i]);
                    for j in 0..3 {
                        hess[i][j] = (hess[i][j] + ch[i][j] * c).select(fin, hess[i][j]);
                    }
                }
                e = (e + c * ca).select(fin, e);
            }
            let e = e.lanes();
            let grad = [grad[0].lanes(), grad[1].lanes(), grad[2].lanes()];
            let mut h = [[[0.0; LANES]; 3]; 3];
            for i in 0..3 {
                for j in 0..3 {
                    h[i][j] = hess[i][j].lanes();
                }
            }
            // Face by face in ring order, as the scalar sum.
            for l in 0..g.len {
                total.0 += e[l];
                for (x, g) in total.1.iter_mut().zip(&grad) {
                    *x += g[l];
                }
                for (row, h_row) in total.2.iter_mut().zip(&h) {
                    for (x, h) in row.iter_mut().zip(h_row) {
                        *x += h[l];
                    }
                }
            }
        }
        Some(total)
    }

    #[target_feature(enable = "avx2")]
    unsafe fn energy_with<D: LaneDensity>(
        density: D,
        k: f64,
        chord: f64,
        p: [f64; 3],
        refs: &[Reference],
        corners: &[[f64; 3]],
    ) -> f64 {
        // In ring order, as `Iterator::sum` added the faces (from -0.0;
        // every face's energy is positive, so the start changes no bit).
        let mut total = -0.0;
        for first in (0..corners.len()).step_by(LANES) {
            let g = group(refs, corners, first);
            group_energy(density, k, chord, splat3(p), &g, &mut total);
        }
        total
    }

    /// The energies of a group's faces with first corners `pv` (splatted
    /// for a star, by lane for a face list), each plus `chord` times its
    /// chord area when `chord` is nonzero, added to `total` face by face in
    /// order (`face_energy_one`'s arithmetic, the scalar sum's order): the
    /// one tail of [`energy_with`] and [`faces_energy_with`].
    #[inline(always)]
    fn group_energy<D: LaneDensity>(
        density: D,
        k: f64,
        chord: f64,
        pv: [F4; 3],
        g: &Group,
        total: &mut f64,
    ) {
        let t = terms_at(k, pv, g);
        let f = density.value(t.a, t.d).lanes();
        let (a, d, area_s) = (t.a.lanes(), t.d.lanes(), t.area_s.lanes());
        // chord * chord_area(p, a, b), chord_area = 0.5 |q1 x q2|.
        let chord_term = if chord != 0.0 {
            let n = cross(t.q1, t.q2);
            (F4::splat(chord) * (F4::splat(0.5) * dot(n, n).sqrt())).lanes()
        } else {
            [0.0; LANES]
        };
        for l in 0..g.len {
            let e = area_s[l] * if admissible(a[l], d[l]) { f[l] } else { f64::INFINITY };
            *total += if chord == 0.0 { e } else { e + chord_term[l] };
        }
    }

    /// Up to four faces of a face list by lane: the first corners, and the
    /// other two with the references as a [`Group`] (a short last group
    /// repeats its last face).
    #[inline(always)]
    fn list_group(
        points: &[[f64; 3]],
        faces: &[[u32; 3]],
        refs: &[Reference],
        first: usize,
    ) -> ([F4; 3], Group) {
        let len = (faces.len() - first).min(LANES);
        let mut c = [[[0.0; LANES]; 3]; 3];
        let mut gram = [[0.0; LANES]; 4];
        for l in 0..LANES {
            let f = first + l.min(len - 1);
            for (corner, &v) in faces[f].iter().enumerate() {
                let x = points[v as usize];
                for i in 0..3 {
                    c[corner][i][l] = x[i];
                }
            }
            let r = &refs[f];
            gram[0][l] = r.gram[0];
            gram[1][l] = r.gram[1];
            gram[2][l] = r.gram[2];
            gram[3][l] = r.area;
        }
        let load = |x: &[Lane; 3]| [F4::load(&x[0]), F4::load(&x[1]), F4::load(&x[2])];
        let group = Group {
            a: load(&c[1]),
            b: load(&c[2]),
            g00: F4::load(&gram[0]),
            g01: F4::load(&gram[1]),
            g11: F4::load(&gram[2]),
            area: F4::load(&gram[3]),
            len,
        };
        (load(&c[0]), group)
    }

    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn face_gradients(
        density: Density,
        k: f64,
        mu: f64,
        points: &[[f64; 3]],
        faces: &[[u32; 3]],
        refs: &[Reference],
        out: &mut [super::FaceGradients],
    ) {
        with_density!(density, face_gradients_with(k, mu, points, faces, refs, out))
    }

    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn faces_energy(
        density: Density,
        k: f64,
        mu: f64,
        points: &[[f64; 3]],
        faces: &[[u32; 3]],
        refs: &[Reference],
    ) -> f64 {
        with_density!(density, faces_energy_with(k, mu, points, faces, refs))
    }

    /// `face_gradients_one` by lane: `face_energy_gradients` and
    /// `chord_area_gradients` in the scalar code's order.
    #[target_feature(enable = "avx2")]
    unsafe fn face_gradients_with<D: LaneDensity>(
        density: D,
        k: f64,
        mu: f64,
        points: &[[f64; 3]],
        faces: &[[u32; 3]],
        refs: &[Reference],
        out: &mut [super::FaceGradients],
    ) {
        let (two, half, m) = (F4::splat(2.0), F4::splat(0.5), F4::splat(mu));
        for first in (0..faces.len()).step_by(LANES) {
            let (p0, g) = list_group(points, faces, refs, first);
            let Terms { q1, q2, kdet, a, area_s, d, ab } = terms_at(k, p0, &g);
            let (f, f_a, f_d) = density.first(a, d);
            let (p1, p2) = (g.a, g.b);
            let mut da = [[F4::splat(0.0); 3]; 3];
            for i in 0..3 {
                da[1][i] = two * (q1[i] * g.g11 - q2[i] * g.g01) / kdet;
                da[2][i] = two * (q2[i] * g.g00 - q1[i] * g.g01) / kdet;
                da[0][i] = (da[1][i] + da[2][i]).neg();
            }
            let dd = [ab, cross(p2, p0), cross(p0, p1)];
            let h = half / area_s;
            let mut grads = [[F4::splat(0.0); 3]; 3];
            for c in 0..3 {
                for i in 0..3 {
                    grads[c][i] = area_s * (f_a * da[c][i] + f_d * h * dd[c][i]);
                }
            }
            let mut e = area_s * f;
            if mu != 0.0 {
                // chord_area_gradients: n = q1 x q2, u = n / |n|, the
                // gradient at each corner (next - previous) x u / 2; zero
                // for a degenerate chord triangle.
                let (len, keep, u) = chord_normal(q1, q2);
                let ends = [(p1, p2), (p2, p0), (p0, p1)];
                // Only where the face's energy is finite, as the scalar code.
                let fin = e.finite_mask();
                for (c, (x, y)) in ends.into_iter().enumerate() {
                    let cg = cross([x[0] - y[0], x[1] - y[1], x[2] - y[2]], u);
                    for i in 0..3 {
                        let with = grads[c][i] + (cg[i] * half).and(keep) * m;
                        grads[c][i] = with.select(fin, grads[c][i]);
                    }
                }
                e = (e + m * (half * len).and(keep)).select(fin, e);
            }
            let (e, f_a, lanes_a, lanes_d, lanes_f) =
                (e.lanes(), f_a.lanes(), a.lanes(), d.lanes(), f.lanes());
            let mut gl = [[[0.0; LANES]; 3]; 3];
            for c in 0..3 {
                for i in 0..3 {
                    gl[c][i] = grads[c][i].lanes();
                }
            }
            for l in 0..g.len {
                let (a, d, f) = (lanes_a[l], lanes_d[l], lanes_f[l]);
                // Energy::density's admissibility and face_energy_gradients'
                // test of f.
                out[first + l] = if admissible(a, d) && f.is_finite() {
                    let grad = |c: usize| [gl[c][0][l], gl[c][1][l], gl[c][2][l]];
                    (e[l], [grad(0), grad(1), grad(2)], f_a[l])
                } else {
                    (f64::INFINITY, [[0.0; 3]; 3], 0.0)
                };
            }
        }
    }

    /// `faces_energy` by lane, added in face order.
    #[target_feature(enable = "avx2")]
    unsafe fn faces_energy_with<D: LaneDensity>(
        density: D,
        k: f64,
        mu: f64,
        points: &[[f64; 3]],
        faces: &[[u32; 3]],
        refs: &[Reference],
    ) -> f64 {
        let mut total = -0.0;
        for first in (0..faces.len()).step_by(LANES) {
            let (p0, g) = list_group(points, faces, refs, first);
            group_energy(density, k, mu, p0, &g, &mut total);
        }
        total
    }
}

#[cfg(test)]
mod tests {
    use super::energy as energy_of;
    use super::*;
    use crate::methods::progressive::distortion_energy::CONFORMAL_AREA_FLOOR;
    use spherify_mesh::lcg::Lcg;

    fn unit(v: [f64; 3]) -> [f64; 3] {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|x| x / n)
    }

    /// A vertex, its faces' references and its ring's points.
    type TestStar = ([f64; 3], Vec<Reference>, Vec<[f64; 3]>);

    /// Random stars of 3 to 13 faces around a point near the north pole
    /// (some with a face turned over), their references from a random
    /// surface (some below the area floor).
    fn stars() -> Vec<TestStar> {
        let mut rng = Lcg::new(27);
        let mut out = Vec::new();
        for m in 3..=13 {
            for _ in 0..60 {
                let mut corners = Vec::new();
                for j in 0..m {
                    let angle =
                        std::f64::consts::TAU * (j as f64 + 0.4 * rng.next_f64()) / m as f64;
                    let r = 0.05 + 0.1 * rng.next_f64();
                    corners.push(unit([r * angle.cos(), r * angle.sin(), 1.0]));
                }
                let p = unit([0.2 * rng.next_f64() - 0.1, 0.2 * rng.next_f64() - 0.1, 1.0]);
                let s0 = [rng.next_f64(), rng.next_f64(), rng.next_f64()];
                let refs: Vec<Reference> = (0..m)
                    .map(|_| {
                        let s1 = [rng.next_f64(), rng.next_f64(), rng.next_f64()];
                        let s2 = [rng.next_f64(), rng.next_f64(), rng.next_f64()];
                        Reference::new(s0, s1, s2, 0.02)
                    })
                    .collect();
                // Some with a corner on the centre itself: a chord triangle
                // of zero normal (the chord terms' zero case), whose
                // det[p, p, b] rounds to either sign or to zero.
                if rng.next_f64() < 0.1 {
                    let mut corners = corners.clone();
                    corners[m / 2] = p;
                    out.push((p, refs.clone(), corners));
                }
                out.push((p, refs, corners));
            }
        }
        out
    }

    fn bits(s: &Sums) -> Vec<u64> {
        let mut v = vec![s.0.to_bits()];
        v.extend(s.1.map(f64::to_bits));
        v.extend(s.2.iter().flat_map(|row| row.map(f64::to_bits)));
        v
    }

    /// Every energy, those with lanes and those without.
    const ENERGIES: [Energy; 10] = [
        Energy::Isometric,
        Energy::Stretch,
        Energy::CoarseStretch,
        Energy::Balanced,
        Energy::BalancedWeighted(20),
        Energy::BalancedWeighted(1300),
        Energy::BalancedWeighted(457),
        Energy::CoarseBalanced,
        Energy::Conformal,
        Energy::Authalic,
    ];

    #[test]
    fn the_lanes_give_the_bits_of_one_face_at_a_time() {
        let (mut finite, mut infinite) = (0, 0);
        for (p, refs, corners) in stars() {
            for energy in ENERGIES {
                for k in [0.7, 1.3e-3, 40.0] {
                    for chord in [0.0, 0.37, 12.5] {
                        // One face at a time, as the moves add them without the lanes.
                        let sums = star_hessian(energy, k, chord, p, &refs, &corners);
                        let plain = star_energy(energy, k, chord, p, &refs, &corners);
                        let ways = [
                            hessian(energy, k, chord, p, &refs, &corners),
                            scalar_hessian(energy, k, chord, p, &refs, &corners),
                        ];
                        for got in ways {
                            match got {
                                Some(got) => {
                                    assert_eq!(bits(&got), bits(&sums), "{energy:?} {chord}");
                                    finite += 1;
                                }
                                None => {
                                    assert!(!sums.0.is_finite());
                                    infinite += 1;
                                }
                            }
                        }
                        let got = energy_of(energy, k, chord, p, &refs, &corners);
                        assert_eq!(got.to_bits(), plain.to_bits(), "{energy:?} {chord}");
                    }
                }
            }
        }
        assert!(finite > 50_000 && infinite > 5_000, "{finite} {infinite}");
        // The conformal energy's area-floor branch (0 < d < F) is taken.
        let mut floored = 0;
        for (p, refs, corners) in stars() {
            let m = corners.len();
            for k in [0.7, 1.3e-3, 40.0] {
                for (j, r) in refs.iter().enumerate() {
                    let d = 0.5 * det3(p, corners[j], corners[(j + 1) % m]) / (k * r.area);
                    floored += usize::from(d > 0.0 && d < CONFORMAL_AREA_FLOOR);
                }
            }
        }
        assert!(floored > 100, "{floored}");
        assert_eq!(handles(Energy::Balanced), available());
        assert_eq!(handles(Energy::Conformal), available());
        assert_eq!(handles(Energy::Authalic), available());
    }

    #[test]
    fn the_face_lists_in_lanes_give_the_bits_of_one_face_at_a_time() {
        let (mut finite, mut infinite, mut flat) = (0, 0, 0);
        for (p, refs, corners) in stars() {
            // The star's faces as a face list, with the centre first, last
            // or between (each corner of a face is someone's first).
            let m = corners.len();
            let mut points = vec![p];
            points.extend(&corners);
            let faces: Vec<[u32; 3]> = (0..m)
                .map(|j| {
                    let f = [0, 1 + j as u32, 1 + ((j + 1) % m) as u32];
                    [f, [f[1], f[2], f[0]], [f[2], f[0], f[1]]][j % 3]
                })
                .collect();
            for energy in ENERGIES {
                for k in [0.7, 1.3e-3, 40.0] {
                    for mu in [0.0, 0.37, 12.5] {
                        let mut got = vec![(0.0, [[0.0; 3]; 3], 0.0); m];
                        face_gradients(energy, k, mu, &points, (&faces, &refs), &mut got);
                        let mut plain = Vec::new();
                        for ((f, r), x) in faces.iter().zip(&refs).zip(&got) {
                            let corners = f.map(|v| points[v as usize]);
                            let want = face_gradients_one(energy, r, k, mu, corners);
                            let b = |(e, g, f_a): &FaceGradients| {
                                let mut v = vec![e.to_bits(), f_a.to_bits()];
                                v.extend(g.iter().flat_map(|c| c.map(f64::to_bits)));
                                v
                            };
                            assert_eq!(b(x), b(&want), "{energy:?} {mu}");
                            match want.0.is_finite() {
                                true => finite += 1,
                                false => infinite += 1,
                            }
                            let [pa, pb, pc] = corners;
                            flat +=
                                usize::from(want.0.is_finite() && chord_area(pa, pb, pc) == 0.0);
                            plain.push(face_energy_one(energy, r, k, mu, corners));
                        }
                        let sum: f64 = plain.iter().sum();
                        let lanes = faces_energy(energy, k, mu, &points, &faces, &refs);
                        assert_eq!(lanes.to_bits(), sum.to_bits(), "{energy:?} {mu}");
                    }
                }
            }
        }
        assert!(finite > 100_000 && infinite > 5_000, "{finite} {infinite}");
        // Finite energies of faces whose chord triangle has a zero normal.
        assert!(flat > 100, "{flat}");
    }

    #[test]
    fn the_fan_tests_in_lanes_give_the_answers_of_one_face_at_a_time() {
        let mut rng = Lcg::new(2027);
        let (mut positive, mut not, mut exact) = (0, 0, 0);
        for (p, _, corners) in stars() {
            let m = corners.len();
            let step = [0.1 * rng.next_f64() - 0.05, 0.1 * rng.next_f64() - 0.05, 0.0];
            let mut t_safe = f64::INFINITY;
            for j in 0..m {
                let (a, b) = (corners[j], corners[(j + 1) % m]);
                let rate = det3(step, a, b);
                if rate < 0.0 {
                    t_safe = t_safe.min(-det3(p, a, b) / rate);
                }
            }
            assert_eq!(safe_step(p, step, &corners).to_bits(), t_safe.to_bits());
            let near = corners.iter().map(|&r| norm(sub(r, p))).fold(f64::INFINITY, f64::min);
            assert_eq!(reach(p, &corners).to_bits(), near.to_bits());
            // Centres inside, outside, and exactly on a face's plane
            // (a point on the great circle through two corners, where only
            // the exact test can tell).
            let (a, b) = (corners[0], corners[1]);
            let on_edge = [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
            for q in [p, unit([0.3, 0.1, 1.0]), on_edge, a] {
                let want = (0..m)
                    .all(|j| det3_sign(q, corners[j], corners[(j + 1) % m]) == Sign::Positive);
                assert_eq!(positive_fan(q, &corners), want);
                match want {
                    true => positive += 1,
                    false => not += 1,
                }
                exact += usize::from(det3_sign(q, a, b) == Sign::Zero);
            }
        }
        assert!(positive > 100 && not > 100 && exact > 100, "{positive} {not} {exact}");
    }

    #[test]
    fn a_turned_face_makes_the_star_infinite() {
        let corners = [[0.1, 0.0, 1.0], [0.0, 0.1, 1.0], [-0.1, 0.0, 1.0], [0.0, -0.1, 1.0]]
            .map(unit)
            .to_vec();
        let refs = vec![Reference::new([0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], 1e-12); 4];
        let inside = unit([0.0, 0.0, 1.0]);
        let outside = unit([0.3, 0.0, 1.0]);
        for e in ENERGIES {
            for chord in [0.0, 0.5] {
                assert!(hessian(e, 1.0, chord, inside, &refs, &corners).is_some());
                assert!(hessian(e, 1.0, chord, outside, &refs, &corners).is_none());
                assert_eq!(energy_of(e, 1.0, chord, outside, &refs, &corners), f64::INFINITY);
            }
        }
    }
}
