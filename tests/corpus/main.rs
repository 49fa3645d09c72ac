//! The corpus suites, as one test binary. Each module is what was one test file and reads its
//! inputs from the environment (`TEXATLAS_CORPUS_DIR`, `TEXATLAS_EVAL_DIR`,
//! `TEXATLAS_GLTF_VALIDATOR`; see each module); without them every test here prints why it
//! skipped and passes, so a fresh clone's `cargo test` passes. `.ci/run` runs each suite with
//! its variables, selected by a name filter:
//! `TEXATLAS_CORPUS_DIR=../shared/corpus cargo test --test corpus -- segment_corpus:: --nocapture`.
#[path = "../common/mod.rs"]
mod common;

mod corpus_roundtrip;
mod http_corpus;
mod measure_eval_agreement;
mod pack_corpus;
mod pages_eval;
mod segment_corpus;
mod unwrap_corpus;
