//! The spherical methods, one file or folder per family, and the few helpers
//! more than one family shares.

pub mod alexa;
pub mod gotsman;
pub mod initial;
pub mod progressive;
pub mod radial;
pub mod relaxation;
pub mod relaxation_loop;
#[cfg(test)]
pub(crate) mod test_support;
pub mod theta_phi;
pub mod weight_matrix;
