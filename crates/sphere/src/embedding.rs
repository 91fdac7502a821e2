//! What every spherical method returns.
//!
//! Each method lives in its own module (`radial.rs`, `relaxation.rs`,
//! `alexa.rs`, `gotsman.rs`, `theta_phi.rs`) and returns a
//! [`SphereEmbedding`]: one point on the unit sphere per vertex plus an honest
//! account of how the method ended. Whether the points form a valid
//! GC-embedding is decided separately and exactly by
//! [`crate::certificate::validity::check_sphere`]; methods never claim validity themselves.

/// How an iterative method ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// Reached its stopping criterion (for the relaxation methods: a valid
    /// embedding found by the periodic validity check, or a converged iteration).
    Converged,
    /// Used up `max_iter` iterations.
    MaxIterations,
    /// The points contracted towards one point (thesis 5.2, 7.3): the trivial
    /// solution of the spherical Tutte equations.
    Collapsed,
    /// A direct method: nothing to converge.
    Direct,
}

impl Status {
    pub fn name(self) -> &'static str {
        match self {
            Status::Converged => "converged",
            Status::MaxIterations => "max_iterations",
            Status::Collapsed => "collapsed",
            Status::Direct => "direct",
        }
    }
}

/// Points on the sphere and how they were found.
#[derive(Debug, Clone)]
pub struct SphereEmbedding {
    /// One unit vector per vertex.
    pub points: Vec<[f64; 3]>,
    pub iterations: usize,
    pub status: Status,
    /// A sentence that says why the method stopped, for people.
    pub message: String,
    /// Seconds per stage, in order.
    pub seconds: Vec<(&'static str, f64)>,
}

impl SphereEmbedding {
    pub fn converged(&self) -> bool {
        matches!(self.status, Status::Converged | Status::Direct)
    }
}

/// Projects `x` onto the unit sphere; `None` for the zero vector or non-finite input.
pub fn normalize(x: [f64; 3]) -> Option<[f64; 3]> {
    let n = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
    (n > 0.0 && n.is_finite()).then(|| [x[0] / n, x[1] / n, x[2] / n])
}
