//! The criterion benches of spherify's crates live in `benches/` beside this
//! file, one per algorithm (`cargo bench -p spherify-benches --bench NAME`).
//! This crate has no code of its own: it exists so that criterion is a
//! dependency of the benches alone and not of every test build.
