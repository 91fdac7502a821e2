//! What a valid map is used for (thesis ch. 8): spherical harmonics of a
//! surface, and how much a map distorts it.

pub mod harmonics;
pub mod metrics;
