//! Test support shared by the `it` and `corpus` test binaries (`tests/it/main.rs`,
//! `tests/corpus/main.rs`), each helper written once:
//!
//! - [`gltf`]: a glTF/GLB builder and an independent reader (no `texatlas::gltf_io` code);
//! - [`http`]: the real server on `127.0.0.1:0` with a scripted fake processor, and response
//!   checks against `proto/openapi.json`;
//! - [`proto`]: validators for the documents in `proto/`, offline;
//! - [`tools`]: the independent checkers of the corpus suites (evaluator, glTF-Validator);
//! - [`cli`]: the real `texatlas` binary as a user runs it;
//! - here: the files of `tests/fixtures` and the per-face-cell test UVs.
// Each binary uses a part of these helpers, so the rest is dead code in it.
#![allow(dead_code)]

pub mod cli;
pub mod gltf;
pub mod http;
pub mod proto;
pub mod tools;

use std::path::{Path, PathBuf};

/// `tests/fixtures/<name>`.
pub fn fixture_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// The bytes of `tests/fixtures/<name>`.
pub fn fixture(name: &str) -> Vec<u8> {
    let path = fixture_path(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Per-corner UVs of a well-formed atlas: each face in its own small square cell, corners placed
/// by corner slot, so no two faces share a UV, every edge is a seam (the most charts possible)
/// and nothing overlaps.
pub fn per_face_cell_uvs(faces: usize) -> Vec<[[f32; 2]; 3]> {
    let side = (faces as f64).sqrt().ceil().max(1.0) as usize;
    let cell = 1.0 / side as f32;
    (0..faces)
        .map(|f| {
            let (x, y) = ((f % side) as f32 * cell, (f / side) as f32 * cell);
            [[x, y], [x + 0.9 * cell, y], [x, y + 0.9 * cell]]
        })
        .collect()
}
