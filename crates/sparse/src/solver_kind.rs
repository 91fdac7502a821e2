//! The solvers [`solve`](crate::solve()) can run, and their names: one list
//! for the bindings, a command line and the docs.

use spherify_mesh::UnknownName;
use std::fmt;
use std::str::FromStr;

/// Which solver [`solve`](crate::solve()) runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolverKind {
    /// Let [`solve`](crate::solve()) choose: always `Direct` today, for the
    /// reasons in docs/benchmarks.md. Never reported back in [`SolveInfo::solver`](crate::SolveInfo::solver).
    Auto,
    /// Sparse Cholesky for a symmetric matrix, sparse LU otherwise
    /// (`crate::direct`). Uses `tol` only to decide whether to refine the
    /// solution iteratively with the same factor; ignores `max_iter` and `x0`.
    Direct,
    /// Conjugate gradients with the Jacobi (diagonal) preconditioner. Needs a
    /// symmetric positive definite matrix.
    CgJacobi,
    /// Conjugate gradients with the zero-fill incomplete Cholesky
    /// preconditioner. Needs a symmetric positive definite matrix.
    CgIc0,
    /// Gauss-Seidel sweeps (thesis 4.5). Needs a positive diagonal; converges
    /// for the Tutte matrices (Prop. 4.10 and `crate::gauss_seidel`).
    GaussSeidel,
}

impl SolverKind {
    /// Every solver, in the order of [`SolverKind::NAMES`].
    pub const ALL: [SolverKind; 5] = [
        SolverKind::Auto,
        SolverKind::Direct,
        SolverKind::CgIc0,
        SolverKind::CgJacobi,
        SolverKind::GaussSeidel,
    ];

    /// The name of each solver in [`SolverKind::ALL`], as [`SolverKind::as_str`] gives it.
    pub const NAMES: [&'static str; 5] = ["auto", "direct", "cg_ic0", "cg_jacobi", "gauss_seidel"];

    /// Other names that parse: `"cg"` is the preconditioned CG that is worth
    /// trying, and `"cholesky"` what Direct does on the symmetric systems.
    pub const ALIASES: [(&'static str, SolverKind); 2] =
        [("cg", SolverKind::CgIc0), ("cholesky", SolverKind::Direct)];

    /// The name of this solver (never an alias).
    pub const fn as_str(self) -> &'static str {
        match self {
            SolverKind::Auto => "auto",
            SolverKind::Direct => "direct",
            SolverKind::CgIc0 => "cg_ic0",
            SolverKind::CgJacobi => "cg_jacobi",
            SolverKind::GaussSeidel => "gauss_seidel",
        }
    }
}

impl FromStr for SolverKind {
    type Err = UnknownName;

    /// One of [`SolverKind::NAMES`] or [`SolverKind::ALIASES`], exactly; the
    /// error lists the names, then the aliases.
    fn from_str(name: &str) -> Result<Self, UnknownName> {
        if let Some(&(_, kind)) = Self::ALIASES.iter().find(|(alias, _)| *alias == name) {
            return Ok(kind);
        }
        let accepted: Vec<&'static str> =
            Self::NAMES.into_iter().chain(Self::ALIASES.map(|(alias, _)| alias)).collect();
        UnknownName::position("solver", name, &accepted).map(|k| Self::ALL[k])
    }
}

impl fmt::Display for SolverKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for (kind, name) in SolverKind::ALL.into_iter().zip(SolverKind::NAMES) {
            assert_eq!(kind.as_str(), name);
            assert_eq!(kind.to_string(), name);
            assert_eq!(name.parse::<SolverKind>(), Ok(kind));
        }
        assert_eq!("cg".parse::<SolverKind>(), Ok(SolverKind::CgIc0));
        assert_eq!("cholesky".parse::<SolverKind>(), Ok(SolverKind::Direct));
        let err = "lu".parse::<SolverKind>().unwrap_err();
        assert_eq!(
            err.to_string(),
            "unknown solver 'lu'; expected one of: \
             auto, direct, cg_ic0, cg_jacobi, gauss_seidel, cg, cholesky"
        );
    }
}
