//! Normalised associated Legendre functions for real spherical harmonics
//! (thesis 8.3 names the spherical-harmonic transform; the recurrences are the
//! standard three-term ones of the fully normalised functions, as in Holmes
//! and Featherstone, J. Geodesy 76 (2002) 279-299).
//!
//! `P(l, m)(x)` here is normalised so that `P(l, m)(cos t) e^{i m phi}` is
//! orthonormal on the unit sphere: the integral of `P(l, m)^2` over
//! `[-1, 1]` is `1 / (2 pi)`. Real harmonics are then
//! `P(l, 0)`, `sqrt 2 P(l, m) cos(m phi)` and `sqrt 2 P(l, m) sin(m phi)`.
//! No Condon-Shortley phase.
//!
//! Each column (fixed `m`) starts at the sectoral value
//! `P(m, m) = sqrt((2m + 1) / 2m) sin t P(m-1, m-1)`, `P(0, 0) = 1 / sqrt(4 pi)`,
//! and runs up in `l` with
//! `P(l, m) = a(l, m) (x P(l-1, m) - b(l, m) P(l-2, m))`,
//! `a = sqrt((4 l^2 - 1) / (l^2 - m^2))`, `b = sqrt(((l-1)^2 - m^2) / (4 (l-1)^2 - 1))`.
//! Both are stable; the one hazard is that `P(m, m) ~ sin^m t` underflows
//! near the poles for large `m` before the column grows back into range. So
//! the sectoral values carry an exponent of 2 beside the mantissa (the scaling
//! of Holmes and Featherstone, by exact powers of two here), and a column
//! drops the exponent once its values have grown: every value that is
//! representable in double precision comes out right, at any degree.

/// Mantissas are kept in [2^-600, 2^600] while a power of two is pending.
const SHIFT: i32 = 600;

/// `2^k` for `k` in the normal range, exactly.
fn pow2(k: i32) -> f64 {
    debug_assert!((-1022..=1023).contains(&k));
    f64::from_bits(((1023 + k) as u64) << 52)
}

/// `p 2^e` for `e <= 0`, a multiple of [`SHIFT`].
fn unscale(p: f64, e: i32) -> f64 {
    let mut v = p;
    let mut k = e;
    while k < 0 && v != 0.0 {
        v *= pow2(-SHIFT);
        k += SHIFT;
    }
    v
}

/// The recurrence coefficients up to degree `lmax`, computed once.
#[derive(Debug, Clone)]
pub struct Legendre {
    lmax: usize,
    /// `sqrt((2m + 1) / 2m)` for m >= 1 (index m).
    sectoral: Vec<f64>,
    /// Start of column `m` in `a` and `b` (entries for l = m..=lmax).
    offsets: Vec<usize>,
    a: Vec<f64>,
    b: Vec<f64>,
}

/// A sectoral value `P(m, m)` as mantissa and power of two.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sectoral {
    pub mantissa: f64,
    pub exponent: i32,
}

impl Legendre {
    pub fn new(lmax: usize) -> Legendre {
        let sectoral = (0..=lmax)
            .map(|m| if m == 0 { 1.0 } else { ((2 * m + 1) as f64 / (2 * m) as f64).sqrt() })
            .collect();
        let mut offsets = Vec::with_capacity(lmax + 1);
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for m in 0..=lmax {
            offsets.push(a.len());
            for l in m..=lmax {
                let (lf, mf) = (l as f64, m as f64);
                if l == m {
                    a.push(0.0);
                    b.push(0.0);
                } else {
                    a.push(((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf)).sqrt());
                    let k = lf - 1.0;
                    b.push(((k * k - mf * mf) / (4.0 * k * k - 1.0)).max(0.0).sqrt());
                }
            }
        }
        Legendre { lmax, sectoral, offsets, a, b }
    }

    pub fn lmax(&self) -> usize {
        self.lmax
    }

    /// `P(m, m)(cos t)` for m = 0..=lmax, given `s = sin t >= 0`.
    pub fn sectorals(&self, s: f64) -> Vec<Sectoral> {
        let mut out = Vec::with_capacity(self.lmax + 1);
        let mut p = self.first_sectoral();
        out.push(p);
        for m in 1..=self.lmax {
            p = self.next_sectoral(p, m, s);
            out.push(p);
        }
        out
    }

    /// `P(0, 0) = 1 / sqrt(4 pi)`.
    pub fn first_sectoral(&self) -> Sectoral {
        Sectoral { mantissa: 1.0 / (4.0 * std::f64::consts::PI).sqrt(), exponent: 0 }
    }

    /// `P(m, m)` from `P(m-1, m-1)`, for m >= 1 and `s = sin t`.
    pub fn next_sectoral(&self, p: Sectoral, m: usize, s: f64) -> Sectoral {
        let mut mantissa = p.mantissa * self.sectoral[m] * s;
        let mut exponent = p.exponent;
        if mantissa != 0.0 && mantissa.abs() < pow2(-SHIFT) {
            mantissa *= pow2(SHIFT);
            exponent -= SHIFT;
        }
        Sectoral { mantissa, exponent }
    }

    /// The recurrence coefficients `(a, b)` of column `m`, for l = m..=lmax
    /// (index l - m; entry 0 unused): for callers that run several columns
    /// in lockstep.
    pub fn recurrence(&self, m: usize) -> (&[f64], &[f64]) {
        let n = self.lmax + 1 - m;
        let o = self.offsets[m];
        (&self.a[o..o + n], &self.b[o..o + n])
    }

    /// Column `m` at `x = cos t` from its sectoral value: `out[l - m] = P(l, m)(x)`
    /// for l = m..=lmax. `out` must hold `lmax + 1 - m` values.
    pub fn column(&self, m: usize, x: f64, start: Sectoral, out: &mut [f64]) {
        self.walk(m, x, start, |i, p| out[i] = p);
    }

    /// Calls `visit(l - m, P(l, m)(x))` for l = m..=lmax in order: column `m`
    /// at `x = cos t` from its sectoral value, without storing it (the
    /// transforms fold each value into their sums as it comes).
    #[inline(always)]
    pub fn walk(&self, m: usize, x: f64, start: Sectoral, mut visit: impl FnMut(usize, f64)) {
        let n = self.lmax + 1 - m;
        let a = &self.a[self.offsets[m]..self.offsets[m] + n];
        let b = &self.b[self.offsets[m]..self.offsets[m] + n];
        let (mut prev, mut cur, mut e) = (0.0, start.mantissa, start.exponent);
        visit(0, unscale(cur, e));
        let mut i = 1;
        // While a power of two is pending: rescale once the column has grown.
        while i < n && e < 0 {
            let next = a[i] * (x * cur - b[i] * prev);
            prev = cur;
            cur = next;
            if cur.abs() > pow2(SHIFT) {
                prev *= pow2(-SHIFT);
                cur *= pow2(-SHIFT);
                e += SHIFT;
            }
            visit(i, unscale(cur, e));
            i += 1;
        }
        // The plain recurrence: the common case, and every column away from the poles.
        while i < n {
            let next = a[i] * (x * cur - b[i] * prev);
            prev = cur;
            cur = next;
            visit(i, cur);
            i += 1;
        }
    }

    /// Calls `visit(m, column)` for m = 0..=lmax in order, where
    /// `column[l - m] = P(l, m)(x)`, at `x = cos t`, `s = sin t >= 0`.
    /// `buffer` must hold `lmax + 1` values. O(lmax^2).
    pub fn for_each_column(
        &self,
        x: f64,
        s: f64,
        buffer: &mut [f64],
        mut visit: impl FnMut(usize, &[f64]),
    ) {
        let mut p = self.first_sectoral();
        for m in 0..=self.lmax {
            if m > 0 {
                p = self.next_sectoral(p, m, s);
            }
            let column = &mut buffer[..=self.lmax - m];
            self.column(m, x, p, column);
            visit(m, column);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::applications::harmonics::gauss_legendre::gauss_legendre;
    use std::f64::consts::PI;

    fn table(lmax: usize, t: f64) -> Vec<Vec<f64>> {
        let leg = Legendre::new(lmax);
        let mut buffer = vec![0.0; lmax + 1];
        let mut out = Vec::new();
        leg.for_each_column(t.cos(), t.sin(), &mut buffer, |_, c| out.push(c.to_vec()));
        out
    }

    #[test]
    fn low_degrees_match_their_closed_forms() {
        let t: f64 = 0.7;
        let (x, s) = (t.cos(), t.sin());
        let p = table(3, t);
        let n = |k: f64| (k / (4.0 * PI)).sqrt();
        let want = [
            (0, 0, n(1.0)),
            (1, 0, n(3.0) * x),
            (1, 1, n(3.0 / 2.0) * s),
            (2, 0, n(5.0) * (3.0 * x * x - 1.0) / 2.0),
            (2, 1, n(5.0 / 6.0) * 3.0 * x * s),
            (2, 2, n(5.0 / 24.0) * 3.0 * s * s),
            (3, 3, n(7.0 / 720.0) * 15.0 * s * s * s),
        ];
        for (l, m, v) in want {
            assert!((p[m][l - m] - v).abs() < 1e-15, "P({l},{m}) = {} not {v}", p[m][l - m]);
        }
    }

    #[test]
    fn columns_are_orthonormal_under_gauss_legendre_quadrature() {
        let lmax = 60;
        let (x, w) = gauss_legendre(lmax + 1);
        let cols: Vec<Vec<Vec<f64>>> = x.iter().map(|&xi| table(lmax, xi.acos())).collect();
        for m in [0, 1, 7, 30, 59, 60] {
            for l1 in m..=lmax {
                for l2 in [m, l1, lmax] {
                    let dot: f64 =
                        (0..x.len()).map(|j| w[j] * cols[j][m][l1 - m] * cols[j][m][l2 - m]).sum();
                    let want = if l1 == l2 { 1.0 / (2.0 * PI) } else { 0.0 };
                    assert!((dot - want).abs() < 1e-13, "m {m}, l {l1} {l2}: {dot}");
                }
            }
        }
    }

    #[test]
    fn high_degrees_near_the_pole_are_finite_and_keep_the_addition_theorem() {
        // sum over m of (2 - [m = 0]) P(l, m)^2 = (2l + 1) / (4 pi) for every t
        // (the addition theorem at equal points): a check on every column at
        // once, here at degree 2000 where sin^m t underflows without scaling.
        // Measured: relative error 1.8e-11 at l = 1999, t = 1e-3.
        let lmax = 2000;
        // At sin t = 0.36, P(700, 700) ~ 0.36^700 ~ 1e-310 is below the normal
        // range while P(2000, 700) is of order 0.1: without the scaling the
        // sum at l = 2000 would lose those columns.
        for t in [1e-3, 0.05, 0.3, 0.36f64.asin(), 0.3f64.asin(), PI / 2.0, 3.0] {
            let p = table(lmax, t);
            for l in [0, 1, 10, 500, 1999, 2000] {
                let sum: f64 =
                    (0..=l).map(|m| if m == 0 { 1.0 } else { 2.0 } * p[m][l - m].powi(2)).sum();
                let want = (2 * l + 1) as f64 / (4.0 * PI);
                // Rounding accumulates along the column, about linearly in l.
                let tolerance = 1e-13 * (l as f64).max(1.0);
                assert!(((sum - want) / want).abs() < tolerance, "t {t}, l {l}: {sum} vs {want}");
            }
            assert!(p.iter().flatten().all(|v| v.is_finite()));
        }
        // A value far below the normal range at the start of its column
        // (P(600, 600) at t = 1e-3 is about 1e-1800) is 0, not garbage.
        assert_eq!(table(600, 1e-3)[600][0], 0.0);
    }

    #[test]
    fn the_poles_have_only_the_zonal_column() {
        let p = table(20, 0.0);
        for (m, col) in p.iter().enumerate() {
            for (i, &v) in col.iter().enumerate() {
                let l = m + i;
                let want = if m == 0 { ((2 * l + 1) as f64 / (4.0 * PI)).sqrt() } else { 0.0 };
                assert!((v - want).abs() < 1e-13, "P({l},{m}) = {v}");
            }
        }
    }
}
