//! What makes a map trustworthy: the exact validity test of a GC-embedding,
//! and the input geometry refused before any method runs.

pub mod geometry_range;
pub mod validity;
