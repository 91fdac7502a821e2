//! How far barycentric weights computed as ratios of determinants can be from
//! the exact ones (issue 13, item 7).
//!
//! Both inverse maps, the barycentric inverse of thesis 3.3 (`gc_map`) and
//! h1^-1 of 6.6.1 (`h_map`), compute a point's weights as d_i / (d_0 + d_1 +
//! d_2), where d_i is a determinant (a spherical volume or a planar area).
//! When the cell is nearly flat the sum is tiny, and a rounding error in the
//! d_i, or in the query point itself, moves the weights far: the sphere
//! point then does not hold enough digits to say where on the surface it came
//! from. [`ratio_weights`] turns a bound on each d_i's error into a bound on
//! the weights' error, so that `to_surface` can say how accurate each answer
//! is instead of being silently wrong.

/// Unit roundoff of f64, 2^-53.
pub const UNIT_ROUNDOFF: f64 = f64::EPSILON / 2.0;

/// The weights d_i / (d_0 + d_1 + d_2) and a bound on sum_i |w_i - w'_i| for
/// every w' = d' / sum d' with |d'_i - d_i| <= e_i. Infinite when the error
/// bounds do not keep the sum away from zero (the weights are then unknown).
///
/// Why: w_i - w'_i = (d_i (S' - S) + S (d_i - d'_i)) / (S S'), so |w_i - w'_i|
/// <= (e_i + |w_i| E) / (S - E) with S = sum d_i and E = sum e_i; summed over
/// i that is E (1 + sum |w_i|) / (S - E), plus the rounding of the divisions.
pub fn ratio_weights(d: [f64; 3], e: [f64; 3]) -> ([f64; 3], f64) {
    let s = d[0] + d[1] + d[2];
    let w = d.map(|x| x / s);
    // The sum itself is rounded too: 2 u |S| at most, and E covers the rest.
    let big_e = e[0] + e[1] + e[2] + 2.0 * UNIT_ROUNDOFF * (d[0].abs() + d[1].abs() + d[2].abs());
    let gap = s - big_e;
    if gap.is_nan() || gap <= 0.0 || !big_e.is_finite() {
        return (w, f64::INFINITY);
    }
    let spread = w[0].abs() + w[1].abs() + w[2].abs();
    let bound = big_e * (1.0 + spread) / gap + 4.0 * UNIT_ROUNDOFF * spread;
    (w, if bound.is_finite() { bound } else { f64::INFINITY })
}

/// Point location among the cells that may hold a point: the answer is a
/// cell that holds it exactly (decided by exact predicates), the best
/// conditioned one if several do (the point is on their common boundary);
/// its error bound is the worst over every cell that a point within the
/// query's rounding error could lie in, since its preimage may be there.
#[derive(Debug, Default)]
pub struct Candidates {
    best: Option<(u32, [f64; 3], f64)>,
    fallback: Option<(u32, [f64; 3], f64)>,
    worst_near: f64,
}

impl Candidates {
    /// One cell's answer: face, weights, distance bound, whether it holds the
    /// point exactly, whether it may hold a point within the rounding error,
    /// and its smallest own weight (for the fallback).
    pub fn offer(
        &mut self,
        face: u32,
        w: [f64; 3],
        distance: f64,
        contains: bool,
        near: bool,
        score: f64,
    ) {
        if near {
            self.worst_near = self.worst_near.max(distance);
        }
        if contains && self.best.as_ref().is_none_or(|b| distance < b.2) {
            self.best = Some((face, w, distance));
        }
        if score.is_finite() && self.fallback.as_ref().is_none_or(|b| score > b.2) {
            self.fallback = Some((face, w, score));
        }
    }

    /// Whether some cell holds the point exactly.
    pub fn found(&self) -> bool {
        self.best.is_some()
    }

    /// (face, weights, error bound). When no cell holds the point exactly
    /// the cells do not cover it (the map is not certified): the cell the
    /// point is least outside answers, with an infinite bound.
    pub fn answer(self) -> (u32, [f64; 3], f64) {
        match self.best {
            Some((f, w, _)) => (f, w, self.worst_near),
            None => {
                let (f, w, _) = self.fallback.unwrap_or((0, [1.0, 0.0, 0.0], 0.0));
                (f, w, f64::INFINITY)
            }
        }
    }
}

/// Rounding leaves weights a hair below zero on shared edges: clip and rescale.
/// Weights of a cell so flat that their common denominator rounds to zero are
/// infinite or NaN: the cell holds the point (exact predicates said so), but
/// where in it is unknown, which the caller's error bound (infinite) says; an
/// infinite weight then stands for its corner, a NaN for nothing.
pub fn clamp_weights(w: [f64; 3]) -> [f64; 3] {
    let finite = w.iter().all(|x| x.is_finite());
    let c = w.map(|x| {
        if finite {
            x.max(0.0)
        } else if x == f64::INFINITY {
            1.0
        } else {
            0.0
        }
    });
    let s = c[0] + c[1] + c[2];
    if s > 0.0 && s.is_finite() {
        c.map(|x| x / s)
    } else {
        [1.0 / 3.0; 3]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bound_holds_for_every_perturbation_within_the_errors() {
        let mut s = spherify_mesh::lcg::Lcg::new(11);
        for _ in 0..2000 {
            let d = [s.next_f64(), s.next_f64(), s.next_f64()].map(|x| x * 1e-6 + 1e-9);
            let e = [s.next_f64(), s.next_f64(), s.next_f64()].map(|x| x * 1e-9);
            let (w, bound) = ratio_weights(d, e);
            for _ in 0..20 {
                let dp: Vec<f64> =
                    (0..3).map(|i| d[i] + e[i] * (2.0 * s.next_f64() - 1.0)).collect();
                let sum: f64 = dp.iter().sum();
                let err: f64 = (0..3).map(|i| (dp[i] / sum - w[i]).abs()).sum();
                assert!(err <= bound, "{err} > {bound}");
            }
        }
    }

    #[test]
    fn a_sum_inside_its_error_gives_an_infinite_bound() {
        let (_, bound) = ratio_weights([1e-20, 1e-20, -1e-20], [1e-18; 3]);
        assert_eq!(bound, f64::INFINITY);
        let (w, bound) = ratio_weights([0.25, 0.25, 0.5], [0.0; 3]);
        assert_eq!(w, [0.25, 0.25, 0.5]);
        assert!(bound < 1e-15);
    }

    #[test]
    fn weights_of_a_collapsed_cell_are_still_weights() {
        assert_eq!(clamp_weights([f64::INFINITY, 0.0, 0.0]), [1.0, 0.0, 0.0]);
        assert_eq!(clamp_weights([f64::NAN, f64::NAN, f64::NAN]), [1.0 / 3.0; 3]);
        assert_eq!(clamp_weights([f64::INFINITY, f64::NEG_INFINITY, f64::NAN]), [1.0, 0.0, 0.0]);
        assert_eq!(clamp_weights([0.5, 0.5 + 1e-17, -1e-17]), [0.5 / 1.0, 0.5 / 1.0, 0.0]);
    }
}
