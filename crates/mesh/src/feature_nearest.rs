//! The nearest candidate in position and feature: registration's descriptor
//! pairs (issue 23; `spherify._descriptors.DescriptorPairs`).
//!
//! For a point x with features d(x), the candidate c_j (with features d_j)
//! minimising
//!
//! ```text
//! |x - c_j|^2 + |d(x) - d_j|^2
//! ```
//!
//! (the features already weighted and scaled by the caller), beside the
//! candidate nearest in position alone: the feature-augmented closest point
//! of Johnson and Kang 1999 ("Registration and integration of textured 3D
//! data") and Sharp, Lee and Wehe 2002 ("ICP registration using invariant
//! features"). Only candidates within `reach` of x in space are looked at
//! (a [`CellGrid`] of side `reach`), so an answer is certain where its value
//! is at most `reach^2`: every candidate farther in space is farther in both
//! measures. Ties go to the first candidate in the grid's order, and each
//! query is answered alone, so the answers do not depend on the threads.

use rayon::prelude::*;

use crate::cell_grid::CellGrid;
use crate::vec3::{dot, sub};

/// Queries per parallel chunk.
const CHUNK: usize = 256;

/// One query's answer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeatureMatch {
    /// The candidate nearest in position and feature (`None`: no candidate
    /// within reach).
    pub best: Option<u32>,
    /// The candidate nearest in position alone.
    pub plain: Option<u32>,
    /// Whether both are certain (both values at most reach^2).
    pub certain: bool,
}

/// Candidates with features, ready for [`FeatureNearest::nearest`].
#[derive(Debug, Clone)]
pub struct FeatureNearest {
    points: Vec<[f64; 3]>,
    /// Row-major, `width` features a candidate.
    features: Vec<f64>,
    width: usize,
    reach: f64,
    grid: CellGrid,
}

impl FeatureNearest {
    /// `points` (finite) with `features` (`points.len()` rows of `width`,
    /// row-major) and the search's `reach` (positive).
    pub fn new(
        points: Vec<[f64; 3]>,
        features: Vec<f64>,
        width: usize,
        reach: f64,
    ) -> FeatureNearest {
        assert_eq!(features.len(), points.len() * width, "one row of features per point");
        let grid = CellGrid::new(&points, reach);
        FeatureNearest { points, features, width, reach, grid }
    }

    /// The number of features of a candidate.
    pub fn width(&self) -> usize {
        self.width
    }

    /// The answer for each query `x[i]` with features
    /// `features[i * width..(i + 1) * width]`; on rayon's threads.
    pub fn nearest(&self, x: &[[f64; 3]], features: &[f64]) -> Vec<FeatureMatch> {
        assert_eq!(features.len(), x.len() * self.width, "one row of features per query");
        let w = self.width.max(1);
        x.par_chunks(CHUNK)
            .zip(features.par_chunks(CHUNK * w))
            .flat_map_iter(|(xs, fs)| {
                xs.iter()
                    .enumerate()
                    .map(|(i, &q)| self.one(q, &fs[i * self.width..(i + 1) * self.width]))
                    .collect::<Vec<_>>()
            })
            .collect()
    }

    fn one(&self, q: [f64; 3], d: &[f64]) -> FeatureMatch {
        let reach2 = self.reach * self.reach;
        let (mut best, mut best_value) = (None, f64::INFINITY);
        let (mut plain, mut plain_value) = (None, f64::INFINITY);
        self.grid.for_each_near(q, |p| {
            let c = self.points[p];
            let gap = sub(q, c);
            let near = dot(gap, gap);
            // Within reach (a NaN is not).
            if near.is_nan() || near > reach2 {
                return;
            }
            let mut both = near;
            for (k, &dk) in d.iter().enumerate() {
                let g = dk - self.features[p * self.width + k];
                both += g * g;
            }
            if both < best_value {
                best_value = both;
                best = Some(p as u32);
            }
            if near < plain_value {
                plain_value = near;
                plain = Some(p as u32);
            }
        });
        FeatureMatch { best, plain, certain: best_value <= reach2 && plain_value <= reach2 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lcg::Lcg;

    #[test]
    fn the_answers_are_the_brute_force_minima() {
        let mut rng = Lcg::new(11);
        let n = 800;
        let points: Vec<[f64; 3]> =
            (0..n).map(|_| [rng.next_f64(), rng.next_f64(), rng.next_f64() * 0.3]).collect();
        let features: Vec<f64> = (0..2 * n).map(|_| rng.next_f64() * 0.1).collect();
        let reach = 0.12;
        let near = FeatureNearest::new(points.clone(), features.clone(), 2, reach);
        let queries: Vec<[f64; 3]> = (0..300)
            .map(|_| [rng.next_f64() * 1.2 - 0.1, rng.next_f64(), rng.next_f64() * 0.4])
            .collect();
        let qf: Vec<f64> = (0..600).map(|_| rng.next_f64() * 0.1).collect();
        let got = near.nearest(&queries, &qf);
        let mut certain = 0;
        for (i, q) in queries.iter().enumerate() {
            let d2 = |p: usize| (0..3).map(|c| (q[c] - points[p][c]).powi(2)).sum::<f64>();
            let both = |p: usize| {
                d2(p) + (0..2).map(|k| (qf[2 * i + k] - features[2 * p + k]).powi(2)).sum::<f64>()
            };
            let argmin = |f: &dyn Fn(usize) -> f64| {
                (0..n).min_by(|&a, &b| f(a).partial_cmp(&f(b)).unwrap()).unwrap()
            };
            let (b, p) = (argmin(&both), argmin(&d2));
            let sure = both(b) <= reach * reach && d2(p) <= reach * reach;
            assert_eq!(got[i].certain, sure, "query {i}");
            if sure {
                certain += 1;
                assert_eq!(got[i].best, Some(b as u32));
                assert_eq!(got[i].plain, Some(p as u32));
            }
        }
        assert!(certain > 100);
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        assert_eq!(one.install(|| near.nearest(&queries, &qf)), got);
    }
}
