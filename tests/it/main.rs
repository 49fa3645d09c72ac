//! The integration tests that need nothing outside the checkout, as one test binary (one link
//! of faer, axum and rusqlite instead of one per file). Each module is what was one test file;
//! select one with a name filter: `cargo test --test it -- http_service::`.
//!
//! The corpus suites (`../shared`, environment variables) are the `corpus` binary
//! (`tests/corpus/main.rs`); the architecture rules, which only read files, are
//! `tests/architecture.rs`. Helpers shared by both binaries are `tests/common/`.
//!
//! proptest keeps the seeds of past failures of module `x` in `tests/proptest-regressions/x.txt`
//! (its default next to a crate root `main.rs`) and replays them first.
#[path = "../common/mod.rs"]
mod common;

mod cli_inspect;
mod cli_unwrap;
mod gltf_hostile;
mod gltf_pages;
mod gltf_roundtrip;
mod http_crash;
mod http_service;
mod mesh_api;
mod pack_box;
mod param_oracles;
mod pipeline;
mod pipeline_flips;

// Figures printed (not asserted) next to the stage guarantees they assert; run one alone for
// its figures, in release, e.g. `cargo test --release --test it -- pack_bench:: --nocapture`.
mod mesh_build_bench;
mod pack_bench;
