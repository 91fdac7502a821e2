//! Powell's dogleg step for a trust region on `|F|_2` (Nocedal and Wright,
//! *Numerical Optimization*, 2nd ed., Alg. 4.1 and 11.5; thesis 5.1.3, where
//! MATLAB's `fsolve` used it): the path from the Cauchy point (steepest
//! descent of `|F|^2`) to the Newton point, cut at the trust radius, and the
//! radius update. Nothing here knows eq. 5.10; [`crate::methods::gotsman`] supplies the
//! sparse Jacobian, the residual and the Newton step.

use spherify_sparse::{CsrMatrix, SparseError};

/// The two ends of the dogleg path and their images under `J`.
pub(crate) struct Dogleg {
    /// Cauchy point `-(|g|^2 / |J g|^2) g`, `g = J^T F`, and `J` times it.
    cauchy: Option<(Vec<f64>, Vec<f64>)>,
    /// Newton point `-J^-1 F` (rotation removed) and `J` times it.
    newton: Option<(Vec<f64>, Vec<f64>)>,
}

impl Dogleg {
    pub(crate) fn new(
        jac: &CsrMatrix,
        f: &[f64],
        newton: Option<Vec<f64>>,
    ) -> Result<Dogleg, SparseError> {
        let n = f.len();
        let mut g = vec![0.0; n];
        jac.transpose().mul_vec(f, &mut g)?;
        let mut jg = vec![0.0; n];
        jac.mul_vec(&g, &mut jg)?;
        let (gg, jgjg) = (dot(&g, &g), dot(&jg, &jg));
        let cauchy = (gg > 0.0 && jgjg > 0.0 && (gg / jgjg).is_finite()).then(|| {
            let s = -gg / jgjg;
            (g.iter().map(|v| s * v).collect(), jg.iter().map(|v| s * v).collect())
        });
        let newton = match newton {
            Some(p) => {
                let mut jp = vec![0.0; n];
                jac.mul_vec(&p, &mut jp)?;
                Some((p, jp))
            }
            None => None,
        };
        Ok(Dogleg { cauchy, newton })
    }

    /// The dogleg step for trust radius `radius` and `J` times it; `None` when
    /// there is no direction to move in.
    pub(crate) fn step(&self, radius: f64) -> Option<(Vec<f64>, Vec<f64>)> {
        let scaled = |(p, jp): &(Vec<f64>, Vec<f64>), s: f64| -> (Vec<f64>, Vec<f64>) {
            (p.iter().map(|v| s * v).collect(), jp.iter().map(|v| s * v).collect())
        };
        match (&self.cauchy, &self.newton) {
            (_, Some(nt)) if dot(&nt.0, &nt.0).sqrt() <= radius => Some(nt.clone()),
            (Some(c), newton) => {
                let c_norm = dot(&c.0, &c.0).sqrt();
                match newton {
                    Some(nt) if c_norm < radius => {
                        // p = c + tau (n - c) with |p| = radius, tau in [0, 1].
                        let d: Vec<f64> = nt.0.iter().zip(&c.0).map(|(a, b)| a - b).collect();
                        let (a, b, cc) =
                            (dot(&d, &d), 2.0 * dot(&c.0, &d), c_norm * c_norm - radius * radius);
                        let tau = (-b + (b * b - 4.0 * a * cc).max(0.0).sqrt()) / (2.0 * a);
                        let tau = if tau.is_finite() { tau.clamp(0.0, 1.0) } else { 0.0 };
                        let p = c.0.iter().zip(&d).map(|(ci, di)| ci + tau * di).collect();
                        let jp =
                            c.1.iter().zip(&nt.1).map(|(jc, jn)| jc + tau * (jn - jc)).collect();
                        Some((p, jp))
                    }
                    _ => Some(scaled(c, (radius / c_norm).min(1.0))),
                }
            }
            // No Cauchy point (the gradient vanished) but a Newton step longer
            // than the radius: shorten it.
            (None, Some(nt)) => Some(scaled(nt, radius / dot(&nt.0, &nt.0).sqrt())),
            (None, None) => None,
        }
    }
}

/// The next trust radius after a step of length `p_norm` whose actual
/// reduction of `|F|^2` was `ratio` times the predicted one: a quarter of the
/// step when the model was poor, twice the radius when it was good and the
/// step reached the boundary.
pub(crate) fn resized_radius(radius: f64, ratio: f64, p_norm: f64) -> f64 {
    if ratio < 0.25 {
        0.25 * p_norm
    } else if ratio > 0.75 && p_norm >= 0.99 * radius {
        radius * 2.0
    } else {
        radius
    }
}

/// The inner product of two vectors of any (equal) length.
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
