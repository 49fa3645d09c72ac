//! The validated triangle mesh.
//!
//! Purpose: turn a triangle soup (positions + index triples) into a [`TriangleMesh`] with
//! welded vertices, half-edge connectivity and per-face data, reporting every defect.
//!
//! Units: positions are in the asset's model units (metres by glTF convention, `_m`).
mod input;

pub use input::MeshInput;
