//! The atlas pipeline: pure, synchronous and deterministic.
//!
//! Stages, each a function of the previous stage's output and its own options:
//! - [`segment`]: `segment_charts` cuts a [`crate::mesh::TriangleMesh`] into charts that are each
//!   a topological disk (Lévy et al. 2002 §3.1–3.2), and `validate_charts` flattens them and
//!   splits those with flips, UV boundary crossings or too much area distortion (§3.3).
//! - [`parameterize`]: flattens one chart (LSCM, Lévy et al. 2002 §2; hierarchical LSCM, Ray &
//!   Lévy 2003).
//!
//! Invariant: no IO, no serde, no wall-clock time, no logging; same input, same output bits
//! whatever the thread count (`tests/architecture.rs` checks the `use` lines).
pub mod measure;
pub mod pack;
pub mod parameterize;
pub mod segment;
