//! Real spherical harmonics of a surface through its sphere map (thesis 8.3):
//! the surface's x, y and z as functions on the unit sphere, transformed up
//! to a degree `lmax`, and the surface rebuilt from the coefficients.
//!
//! The transform samples the surface on a quadrature grid of the sphere
//! through h^-1 ([`PointMap::to_surface`]): Gauss-Legendre nodes in
//! cos(theta) ([`mod@gauss_legendre`]), uniform in phi. For a function of
//! degree at most `lmax` the grid gives the coefficients exactly (the
//! Gauss-Legendre rule integrates the products of two columns of
//! [`crate::applications::harmonics::legendre`] exactly, the uniform rule the products of two
//! trigonometric terms). A sum over phi per ring and degree (O(L^3) in all)
//! then one Legendre column per ring and order (O(L^3)): no dense matrix of
//! harmonics at the vertices.
//!
//! Coefficients are stored one row per harmonic, row `l^2 + l + m` for
//! `m = -l..=l`, three columns (x, y, z). The harmonic of row `(l, m)` is
//! `P(l, 0)` for m = 0, `sqrt 2 P(l, m) cos(m phi)` for m > 0 and
//! `sqrt 2 P(l, |m|) sin(|m| phi)` for m < 0, orthonormal on the unit sphere,
//! theta from the north pole (0, 0, 1), phi from the x axis towards y (6.27).

pub mod gauss_legendre;
pub mod legendre;

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use rayon::prelude::*;

use crate::applications::harmonics::gauss_legendre::gauss_legendre;
use crate::applications::harmonics::legendre::Legendre;
use crate::memory_budget::{self, Application, ResourceError};
use crate::point_map::{PointMap, PointMapError};

/// Largest degree accepted: the grid at this degree already holds 8 million
/// points (about 200 MB for the samples alone), per oversampling step squared.
pub const MAX_DEGREE: usize = 2000;
/// Largest oversampling factor of the grid.
pub const MAX_OVERSAMPLE: usize = 8;
/// Largest grid accepted, in points.
const MAX_GRID: usize = 1 << 24;
/// Sphere points may be this far from unit length (they are normalised).
const NORM_TOLERANCE: f64 = 1e-6;

/// Why a transform or an evaluation cannot be done.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HarmonicsError {
    #[error("{name} = {value}: {expected}")]
    InvalidParameter { name: &'static str, value: usize, expected: String },
    #[error("coefficients have {rows} rows, which is not (lmax + 1)^2 for any lmax")]
    NotSquare { rows: usize },
    #[error("row {row}: {point:?} is not a unit vector (norm {norm})")]
    NotOnSphere { row: usize, point: [f64; 3], norm: f64 },
    #[error(transparent)]
    Map(#[from] PointMapError),
    /// The grid or the points do not fit in memory (issue 26): refused before
    /// the work starts, or an allocation the system refused.
    #[error(transparent)]
    Resource(#[from] ResourceError),
    /// `progress(0, 0)` asked to stop (Ctrl-C from Python).
    #[error("stopped on request")]
    Cancelled,
}

/// Polls `progress(0, 0)` from parallel work: once it says stop, every
/// later poll says so too without asking again.
struct Poll<'a> {
    progress: &'a (dyn Fn(usize, usize) -> bool + Sync),
    stopped: AtomicBool,
}

impl<'a> Poll<'a> {
    fn new(progress: &'a (dyn Fn(usize, usize) -> bool + Sync)) -> Self {
        Poll { progress, stopped: AtomicBool::new(false) }
    }

    /// Whether to go on; polled before each piece of a few milliseconds.
    fn go_on(&self) -> bool {
        if self.stopped.load(Ordering::Relaxed) {
            return false;
        }
        let go_on = (self.progress)(0, 0);
        if !go_on {
            self.stopped.store(true, Ordering::Relaxed);
        }
        go_on
    }

    /// Reports `(done, total)`; a `false` answer stops the work as a poll's.
    fn report(&self, done: usize, total: usize) -> bool {
        if self.stopped.load(Ordering::Relaxed) {
            return false;
        }
        let go_on = (self.progress)(done, total);
        if !go_on {
            self.stopped.store(true, Ordering::Relaxed);
        }
        go_on
    }

    fn result<T>(&self, value: T) -> Result<T, HarmonicsError> {
        if self.stopped.load(Ordering::Relaxed) {
            Err(HarmonicsError::Cancelled)
        } else {
            Ok(value)
        }
    }
}

/// The sampling grid of a transform up to degree `lmax`.
#[derive(Debug, Clone)]
pub struct Grid {
    pub lmax: usize,
    /// cos(theta) of each ring, from north to south, and its weight.
    pub x: Vec<f64>,
    pub weights: Vec<f64>,
    /// Points per ring.
    pub n_phi: usize,
}

impl Grid {
    /// `oversample * (lmax + 1)` rings of `2 oversample (lmax + 1)` points.
    ///
    /// # Errors
    /// [`HarmonicsError::InvalidParameter`] for `lmax` above [`MAX_DEGREE`],
    /// `oversample` outside 1..=[`MAX_OVERSAMPLE`] or a grid of more than
    /// 2^24 points.
    pub fn new(lmax: usize, oversample: usize) -> Result<Grid, HarmonicsError> {
        if lmax > MAX_DEGREE {
            return Err(HarmonicsError::InvalidParameter {
                name: "lmax",
                value: lmax,
                expected: format!("must be at most {MAX_DEGREE}"),
            });
        }
        if !(1..=MAX_OVERSAMPLE).contains(&oversample) {
            return Err(HarmonicsError::InvalidParameter {
                name: "oversample",
                value: oversample,
                expected: format!("must be in 1..={MAX_OVERSAMPLE}"),
            });
        }
        let n_theta = oversample * (lmax + 1);
        let n_phi = 2 * oversample * (lmax + 1);
        if n_theta * n_phi > MAX_GRID {
            return Err(HarmonicsError::InvalidParameter {
                name: "oversample",
                value: oversample,
                expected: format!(
                    "the grid of {n_theta} x {n_phi} points is larger than {MAX_GRID}"
                ),
            });
        }
        let (x, weights) = gauss_legendre(n_theta);
        Ok(Grid { lmax, x, weights, n_phi })
    }

    /// The grid's unit vectors, ring by ring (north first), each ring from
    /// phi = 0 in steps of 2 pi / n_phi.
    pub fn points(&self) -> Vec<[f64; 3]> {
        let (cos_phi, sin_phi) = self.trig_table();
        let mut points = Vec::with_capacity(self.x.len() * self.n_phi);
        for &x in &self.x {
            let s = sin_of(x);
            points.extend(cos_phi.iter().zip(&sin_phi).map(|(&c, &n)| [s * c, s * n, x]));
        }
        points
    }

    fn trig_table(&self) -> (Vec<f64>, Vec<f64>) {
        let step = 2.0 * std::f64::consts::PI / self.n_phi as f64;
        (0..self.n_phi).map(|k| (k as f64 * step).sin_cos()).map(|(s, c)| (c, s)).unzip()
    }

    /// The coefficients of the function with `values` at [`Grid::points`]
    /// (in that order), three channels. O(L^3), in parallel, deterministic.
    pub fn analyse(&self, values: &[[f64; 3]]) -> Vec<[f64; 3]> {
        match self.analyse_with(values, &|_, _| true) {
            Ok(coefficients) => coefficients,
            Err(_) => unreachable!("a progress closure that never stops"),
        }
    }

    /// [`Grid::analyse`], polling `progress(0, 0)` before each ring's and
    /// each order's sums (milliseconds each at lmax 2000) and stopping with
    /// [`HarmonicsError::Cancelled`] when it says so.
    pub fn analyse_with(
        &self,
        values: &[[f64; 3]],
        progress: &(dyn Fn(usize, usize) -> bool + Sync),
    ) -> Result<Vec<[f64; 3]>, HarmonicsError> {
        self.analyse_counted(values, progress, 0, 0)
    }

    /// [`Grid::analyse_with`] that also reports its work to `progress`: each
    /// ring summed and each order done is one unit, counted from `before`
    /// out of `total` (nothing is reported when `total` is 0).
    fn analyse_counted(
        &self,
        values: &[[f64; 3]],
        progress: &(dyn Fn(usize, usize) -> bool + Sync),
        before: usize,
        total: usize,
    ) -> Result<Vec<[f64; 3]>, HarmonicsError> {
        let poll = Poll::new(progress);
        let done = AtomicUsize::new(before);
        let count = || {
            let now = done.fetch_add(1, Ordering::Relaxed) + 1;
            if total > 0 {
                poll.report(now, total);
            }
        };
        let (lmax, n_phi) = (self.lmax, self.n_phi);
        let (cos_phi, sin_phi) = self.trig_table();
        // Per ring and order: sum_k f(phi_k) cos(m phi_k) and sin(m phi_k);
        // cos(m phi_k) is the table's entry (m k) mod n_phi, exact and cheap.
        let rings: Vec<Vec<([f64; 3], [f64; 3])>> = values
            .par_chunks(n_phi)
            .map(|ring| {
                if !poll.go_on() {
                    return Vec::new();
                }
                (0..=lmax)
                    .map(|m| {
                        let (mut c, mut s) = ([0.0; 3], [0.0; 3]);
                        for (k, f) in ring.iter().enumerate() {
                            let r = (m * k) % n_phi;
                            for i in 0..3 {
                                c[i] += f[i] * cos_phi[r];
                                s[i] += f[i] * sin_phi[r];
                            }
                        }
                        (c, s)
                    })
                    .collect::<Vec<_>>()
            })
            .inspect(|_| count())
            .collect();
        let rings = poll.result(rings)?;
        let legendre = Legendre::new(lmax);
        let starts: Vec<_> = self.x.par_iter().map(|&x| legendre.sectorals(sin_of(x))).collect();
        let dphi = 2.0 * std::f64::consts::PI / n_phi as f64;
        // One order at a time (in parallel), each summing over the rings in
        // order: the same input gives the same coefficients, bit for bit.
        // Per order m, the cos and the sin sums for l = m..=lmax.
        type Sums = (Vec<[f64; 3]>, Vec<[f64; 3]>);
        let orders: Vec<Sums> = (0..=lmax)
            .into_par_iter()
            .map(|m| {
                let (mut cos_part, mut sin_part) =
                    (vec![[0.0; 3]; lmax + 1 - m], vec![[0.0; 3]; lmax + 1 - m]);
                if !poll.go_on() {
                    return (cos_part, sin_part);
                }
                for (j, &x) in self.x.iter().enumerate() {
                    let w = self.weights[j];
                    let (c, s) = (rings[j][m].0.map(|v| w * v), rings[j][m].1.map(|v| w * v));
                    legendre.walk(m, x, starts[j][m], |i, p| {
                        for d in 0..3 {
                            cos_part[i][d] += p * c[d];
                            sin_part[i][d] += p * s[d];
                        }
                    });
                }
                (cos_part, sin_part)
            })
            .inspect(|_| count())
            .collect();
        let orders = poll.result(orders)?;
        let mut coefficients = vec![[0.0; 3]; (lmax + 1) * (lmax + 1)];
        let root2 = std::f64::consts::SQRT_2;
        for (m, (cos_part, sin_part)) in orders.iter().enumerate() {
            for l in m..=lmax {
                let (c, s) = (cos_part[l - m], sin_part[l - m]);
                if m == 0 {
                    coefficients[l * l + l] = c.map(|v| v * dphi);
                } else {
                    coefficients[l * l + l + m] = c.map(|v| v * dphi * root2);
                    coefficients[l * l + l - m] = s.map(|v| v * dphi * root2);
                }
            }
        }
        Ok(coefficients)
    }
}

/// sin(theta) from cos(theta), accurate near the poles.
fn sin_of(x: f64) -> f64 {
    ((1.0 - x) * (1.0 + x)).max(0.0).sqrt()
}

/// What [`fit`] did.
#[derive(Debug, Clone)]
pub struct FitInfo {
    pub n_theta: usize,
    pub n_phi: usize,
    pub seconds: Vec<(&'static str, f64)>,
}

/// The harmonic coefficients of the surface of `map` up to degree `lmax`,
/// from `oversample * (lmax + 1) x 2 oversample (lmax + 1)` samples through
/// h^-1. O(S log F + L^3) for S samples and F faces.
///
/// # Errors
/// Bad `lmax` / `oversample`, or a map that is not a certified bijection
/// ([`PointMapError::NotBijective`]).
pub fn fit(
    map: &PointMap,
    lmax: usize,
    oversample: usize,
) -> Result<(Vec<[f64; 3]>, FitInfo), HarmonicsError> {
    fit_with(map, lmax, oversample, &|_, _| true)
}

/// [`fit`], polling `progress(0, 0)` while it samples and transforms and
/// stopping with [`HarmonicsError::Cancelled`] (or the point map's
/// `Cancelled`) when it says so. It also reports `(done, total)`: the rings
/// sampled (in pieces of about a twentieth of the grid), then the rings
/// summed and the orders transformed, `2 n_theta + lmax + 1` units in all.
pub fn fit_with(
    map: &PointMap,
    lmax: usize,
    oversample: usize,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<(Vec<[f64; 3]>, FitInfo), HarmonicsError> {
    if let Some(why) = map.not_bijective() {
        return Err(PointMapError::NotBijective(why.to_string()).into());
    }
    let started = std::time::Instant::now();
    let grid = Grid::new(lmax, oversample)?;
    // Checked once the degree is known to be in range (a degree out of range
    // is a parameter error, not a memory one), before the grid is made.
    let samples = grid.x.len() * grid.n_phi;
    let need = memory_budget::application_need(Application::HarmonicsFit, 0, 0, samples);
    memory_budget::check(&need)?;
    let points = grid.points();
    let n_theta = grid.x.len();
    let total = 2 * n_theta + lmax + 1;
    // Point location is point by point: pieces give the same samples.
    let rings_per_piece = n_theta.div_ceil(20);
    let mut xyz = memory_budget::reserved(points.len(), "the harmonic fit's samples")?;
    for (k, piece) in points.chunks(rings_per_piece * grid.n_phi).enumerate() {
        xyz.extend(map.to_surface_with(piece, progress)?.xyz);
        if !progress(((k + 1) * rings_per_piece).min(n_theta), total) {
            return Err(HarmonicsError::Cancelled);
        }
    }
    let sampled = started.elapsed().as_secs_f64();
    let coefficients = grid.analyse_counted(&xyz, progress, n_theta, total)?;
    let seconds =
        vec![("sample", sampled), ("transform", started.elapsed().as_secs_f64() - sampled)];
    Ok((coefficients, FitInfo { n_theta: grid.x.len(), n_phi: grid.n_phi, seconds }))
}

/// `lmax` of a coefficient table with `rows` rows.
pub fn degree_of(rows: usize) -> Result<usize, HarmonicsError> {
    let l = (rows as f64).sqrt().round() as usize;
    if rows == 0 || l * l != rows {
        return Err(HarmonicsError::NotSquare { rows });
    }
    Ok(l - 1)
}

/// The function with `coefficients` (rows as in the module doc) at each of
/// `points` (unit vectors, within 1e-6; normalised). O(L^2) per point, in
/// parallel; deterministic.
///
/// # Errors
/// A coefficient table that is not square, a point that is not a unit vector.
pub fn evaluate(
    coefficients: &[[f64; 3]],
    points: &[[f64; 3]],
) -> Result<Vec<[f64; 3]>, HarmonicsError> {
    evaluate_with(coefficients, points, &|_, _| true)
}

/// [`evaluate`], polling `progress(0, 0)` before each group of points and
/// stopping with [`HarmonicsError::Cancelled`] when it says so.
pub fn evaluate_with(
    coefficients: &[[f64; 3]],
    points: &[[f64; 3]],
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<Vec<[f64; 3]>, HarmonicsError> {
    let poll = Poll::new(progress);
    let lmax = degree_of(coefficients.len())?;
    if lmax > MAX_DEGREE {
        return Err(HarmonicsError::InvalidParameter {
            name: "lmax",
            value: lmax,
            expected: format!("must be at most {MAX_DEGREE}"),
        });
    }
    // Before the points are copied: the values and the unit points are the
    // call's memory, per point.
    let need = memory_budget::application_need(Application::HarmonicsEvaluate, 0, 0, points.len());
    memory_budget::check(&need)?;
    // Column order: for each m, the cos (m >= 0) and sin (m > 0) rows for
    // l = m..=lmax, next to each other as the recurrence visits them.
    let mut cos_rows = Vec::with_capacity(coefficients.len());
    let mut sin_rows = Vec::with_capacity(coefficients.len());
    for m in 0..=lmax {
        for l in m..=lmax {
            cos_rows.push(coefficients[l * l + l + m]);
            sin_rows.push(if m == 0 { [0.0; 3] } else { coefficients[l * l + l - m] });
        }
    }
    let legendre = Legendre::new(lmax);
    let unit: Vec<[f64; 3]> = points
        .par_iter()
        .enumerate()
        .map(|(row, &p)| {
            let norm = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            if (norm - 1.0).abs().is_nan() || (norm - 1.0).abs() > NORM_TOLERANCE {
                return Err(HarmonicsError::NotOnSphere { row, point: p, norm });
            }
            Ok(p.map(|v| v / norm))
        })
        .collect::<Result<_, _>>()?;
    let rows = ColumnRows { cos: &cos_rows, sin: &sin_rows };
    let values = unit
        .par_chunks(LANES)
        .flat_map_iter(|chunk| {
            // A few milliseconds per group at lmax 2000 (O(L^2) per point).
            if poll.go_on() {
                evaluate_lanes(&legendre, &rows, chunk)
            } else {
                Vec::new()
            }
        })
        .collect();
    poll.result(values)
}

/// Points evaluated together: their recurrences are independent, so running
/// them in lockstep hides the latency of each one's chain of multiplications
/// (about 3x faster than one point at a time). The arithmetic per point is
/// the same either way, so the result does not depend on the grouping.
const LANES: usize = 4;

/// The coefficients in column order (see [`evaluate`]).
struct ColumnRows<'a> {
    cos: &'a [[f64; 3]],
    sin: &'a [[f64; 3]],
}

/// Up to [`LANES`] unit vectors; returns one value per input point.
fn evaluate_lanes(legendre: &Legendre, rows: &ColumnRows<'_>, chunk: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let lmax = legendre.lmax();
    let root2 = std::f64::consts::SQRT_2;
    // Pad with the first point; the padding's values are dropped.
    let lane = |k: usize| chunk[k.min(chunk.len() - 1)];
    let x: [f64; LANES] = std::array::from_fn(|k| lane(k)[2]);
    let s: [f64; LANES] = std::array::from_fn(|k| {
        let p = lane(k);
        (p[0] * p[0] + p[1] * p[1]).sqrt()
    });
    let phi: [f64; LANES] = std::array::from_fn(|k| lane(k)[1].atan2(lane(k)[0]));
    let mut f = [[0.0; 3]; LANES];
    let mut start = [legendre.first_sectoral(); LANES];
    let mut column = vec![0.0; lmax + 1];
    let mut offset = 0;
    for m in 0..=lmax {
        if m > 0 {
            for k in 0..LANES {
                start[k] = legendre.next_sectoral(start[k], m, s[k]);
            }
        }
        let n = lmax + 1 - m;
        let (cr, sr) = (&rows.cos[offset..offset + n], &rows.sin[offset..offset + n]);
        offset += n;
        // Sums per coordinate d and lane k, lanes innermost so that the
        // lockstep loops vectorise.
        let mut c = [[0.0; LANES]; 3];
        let mut sn = [[0.0; LANES]; 3];
        if start.iter().all(|p| p.exponent == 0) {
            // The plain recurrence of `Legendre::walk`, LANES at a time.
            let (a, b) = legendre.recurrence(m);
            let mut prev = [0.0; LANES];
            let mut cur: [f64; LANES] = std::array::from_fn(|k| start[k].mantissa);
            for i in 0..n {
                if i > 0 {
                    for k in 0..LANES {
                        let next = a[i] * (x[k] * cur[k] - b[i] * prev[k]);
                        prev[k] = cur[k];
                        cur[k] = next;
                    }
                }
                let (rc, rs) = (cr[i], sr[i]);
                for d in 0..3 {
                    for k in 0..LANES {
                        c[d][k] += cur[k] * rc[d];
                        sn[d][k] += cur[k] * rs[d];
                    }
                }
            }
        } else {
            for k in 0..LANES {
                legendre.column(m, x[k], start[k], &mut column[..n]);
                for (i, &v) in column[..n].iter().enumerate() {
                    for d in 0..3 {
                        c[d][k] += v * cr[i][d];
                        sn[d][k] += v * sr[i][d];
                    }
                }
            }
        }
        for k in 0..LANES {
            if m == 0 {
                for d in 0..3 {
                    f[k][d] += c[d][k];
                }
            } else {
                let (sin_m, cos_m) = (m as f64 * phi[k]).sin_cos();
                for d in 0..3 {
                    f[k][d] += root2 * (c[d][k] * cos_m + sn[d][k] * sin_m);
                }
            }
        }
    }
    f[..chunk.len()].to_vec()
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::lcg::Lcg;

    fn random_coefficients(lmax: usize, seed: u64) -> Vec<[f64; 3]> {
        let mut r = Lcg::new(seed);
        (0..(lmax + 1) * (lmax + 1))
            .map(|_| [r.next_f64() - 0.5, r.next_f64() - 0.5, r.next_f64() - 0.5])
            .collect()
    }

    #[test]
    fn analysis_inverts_synthesis_for_band_limited_functions() {
        for (lmax, oversample) in [(0, 1), (1, 1), (6, 1), (25, 1), (25, 3)] {
            let coefficients = random_coefficients(lmax, 7 + lmax as u64);
            let grid = Grid::new(lmax, oversample).unwrap();
            let values = evaluate(&coefficients, &grid.points()).unwrap();
            let back = grid.analyse(&values);
            for (row, (a, b)) in coefficients.iter().zip(&back).enumerate() {
                for d in 0..3 {
                    assert!((a[d] - b[d]).abs() < 1e-12, "lmax {lmax}, row {row}: {a:?} {b:?}");
                }
            }
        }
    }

    #[test]
    fn a_stop_request_cancels_analysis_and_evaluation() {
        let lmax = 40;
        let coefficients = random_coefficients(lmax, 3);
        let grid = Grid::new(lmax, 1).unwrap();
        let points = grid.points();
        // Stop at the fifth poll: the work polls many times more than that.
        let polls = std::sync::atomic::AtomicUsize::new(0);
        let stop_soon = |_: usize, _: usize| polls.fetch_add(1, Ordering::Relaxed) < 5;
        let stopped = evaluate_with(&coefficients, &points, &stop_soon);
        assert_eq!(stopped, Err(HarmonicsError::Cancelled));
        let values = evaluate(&coefficients, &points).unwrap();
        polls.store(0, Ordering::Relaxed);
        assert_eq!(grid.analyse_with(&values, &stop_soon), Err(HarmonicsError::Cancelled));
        // Going on gives the same bits as the call without polls.
        assert_eq!(evaluate_with(&coefficients, &points, &|_, _| true).unwrap(), values);
        assert_eq!(grid.analyse_with(&values, &|_, _| true).unwrap(), grid.analyse(&values));
    }

    #[test]
    fn degree_one_harmonics_are_the_coordinates() {
        // x = sqrt(4 pi / 3) Y(1, 1), y = sqrt(4 pi / 3) Y(1, -1), z = sqrt(4 pi / 3) Y(1, 0).
        let k = (4.0 * std::f64::consts::PI / 3.0).sqrt();
        let mut coefficients = vec![[0.0; 3]; 4];
        coefficients[3] = [k, 0.0, 0.0];
        coefficients[1] = [0.0, k, 0.0];
        coefficients[2] = [0.0, 0.0, k];
        let mut r = Lcg::new(3);
        let points: Vec<[f64; 3]> = (0..200)
            .map(|_| {
                let p = [r.next_f64() - 0.5, r.next_f64() - 0.5, r.next_f64() - 0.5];
                let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                p.map(|v| v / n)
            })
            .chain([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
            .collect();
        let f = evaluate(&coefficients, &points).unwrap();
        for (p, v) in points.iter().zip(&f) {
            for d in 0..3 {
                assert!((p[d] - v[d]).abs() < 1e-14, "{p:?} -> {v:?}");
            }
        }
    }

    #[test]
    fn a_point_gets_the_same_bits_alone_or_in_any_group() {
        let coefficients = random_coefficients(40, 5);
        let mut r = Lcg::new(9);
        let points: Vec<[f64; 3]> = (0..11)
            .map(|_| {
                let p = [r.next_f64() - 0.5, r.next_f64() - 0.5, r.next_f64() - 0.5];
                let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                p.map(|v| v / n)
            })
            .chain([[0.0, 0.0, 1.0], [1e-200, 0.0, -1.0]])
            .collect();
        let together = evaluate(&coefficients, &points).unwrap();
        for (k, p) in points.iter().enumerate() {
            assert_eq!(evaluate(&coefficients, &points[k..k + 1]).unwrap()[0], together[k]);
            assert_eq!(evaluate(&coefficients, &[points[0], *p]).unwrap()[1], together[k]);
        }
    }

    #[test]
    fn bad_input_is_refused() {
        assert_eq!(degree_of(5), Err(HarmonicsError::NotSquare { rows: 5 }));
        assert_eq!(degree_of(0), Err(HarmonicsError::NotSquare { rows: 0 }));
        assert_eq!(degree_of(16), Ok(3));
        let err = evaluate(&[[1.0; 3]], &[[0.0, 0.0, 2.0]]).unwrap_err();
        assert!(matches!(err, HarmonicsError::NotOnSphere { row: 0, .. }));
        assert!(evaluate(&[[1.0; 3]], &[[f64::NAN, 0.0, 1.0]]).is_err());
        assert!(Grid::new(MAX_DEGREE + 1, 1).is_err());
        assert!(Grid::new(10, 0).is_err());
        assert!(Grid::new(2000, 2).is_err());
    }
}
