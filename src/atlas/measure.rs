//! Measuring an atlas: the quality report (issue 5).
//!
//! INTERFACE SKELETON — the implementation lands with issue 5. Definitions follow
//! `../shared/eval/atlas_eval.py` (its module docstring) so that the report agrees with the
//! independent evaluator.
use crate::mesh::TriangleMesh;

/// What [`measure_atlas`] measures: the final per-corner UVs of every face of `mesh`.
#[derive(Debug, Clone, Copy)]
pub struct MeasureInput<'a> {
    /// The mesh (positions, connectivity, weld groups = glTF meshes).
    pub mesh: &'a TriangleMesh,
    /// UVs of the 3 corners of each face, in face order, normalized page coordinates, exactly the
    /// `f32` values written to the file.
    pub corner_uvs: &'a [[[f32; 2]; 3]],
    /// Page of each face.
    pub face_page: &'a [u32],
    /// Number of pages.
    pub num_pages: u32,
    /// Page width in texels.
    pub width_texels: u32,
    /// Page height in texels.
    pub height_texels: u32,
    /// Padding wanted between charts, texels (0 disables the padding check).
    pub padding_texels: u32,
}

/// The quality report (plain data; the JSON form is in `crate::api`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AtlasReport {}

/// Measures the atlas. Pure and deterministic.
pub fn measure_atlas(input: &MeasureInput<'_>) -> AtlasReport {
    let _ = input;
    unimplemented!("issue 5: measure")
}
