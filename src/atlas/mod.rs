//! The atlas pipeline: pure, synchronous and deterministic.
pub mod parameterize;
pub mod segment;
