//! The report of one unwrap on the wire ↔ `proto/report.schema.json`.
//!
//! Built from plain domain data ([`Atlas`], its [`crate::atlas::AtlasReport`], the encoded
//! asset, the effective options and the measured timings) by [`ReportJson::new`]. The timings
//! come in as [`TimingsJsonS`]: the wire layer does not depend on the `unwrap` module, which
//! measures them (and builds this report), so the dependency runs `unwrap` → `api` only.
use serde::Serialize;

use crate::api::OptionsJson;
use crate::atlas::{Atlas, AtlasReport};
use crate::gltf_io::{Asset, EncodedAsset};
use crate::mesh::BuiltMesh;

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
    /// The one `TEXCOORD_k` that holds the atlas on every triangle primitive.
    pub uv_set: u32,
    /// `uv_set` once per triangle primitive, in (mesh, primitive) order (every entry is the
    /// same; kept for clients that read a set per primitive).
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
    /// The primitives of the output document holding this page's triangles (a primitive whose
    /// charts land on several pages is split into one primitive per page, same material).
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
    /// Validation splits for area distortion or stretch above the bound.
    pub splits_area_ratio: usize,
    /// Small charts merged back after splitting.
    pub merges: usize,
    /// Charts added by the pack stage's cuts: fit to page, the packing-aware cuts, because that
    /// raised the packing efficiency (meshes of at most 20k triangles and 256 charts that pack
    /// below 0.72); at a fixed density, the pieces of charts too large for a page.
    pub packing_cuts: usize,
    /// Charts kept above the stretch or area-ratio bound (could not be split further).
    pub bound_unresolved: usize,
    /// Charts flattened by the direct LSCM solve.
    pub charts_direct: usize,
    /// Charts flattened by HLSCM.
    pub charts_hierarchical: usize,
    /// Texel density used, texels per model unit.
    pub texels_per_unit: f64,
    /// Packings run to choose the density (1 at a fixed density).
    pub pack_trials: u32,
    /// Charts made only of degenerate faces (zero area or a repeated vertex): not packed, their
    /// corners sit on a coincident vertex of a packed chart (zero UV area).
    pub degenerate_charts: usize,
    /// The segmentation that ran: `features` (Lévy et al. 2002) or `stretch` (Iso-charts).
    pub segmentation: &'static str,
    /// Charts split by the stretch segmentation's spectral clustering (0 for `features`).
    pub spectral_splits: usize,
    /// Faces the border smoothing moved into the chart they stuck into (saw teeth where growing
    /// fronts met), at the end of segmentation; the smoothing of later splits is not counted.
    pub border_faces_smoothed: usize,
    /// The stretch optimisation that ran on the charts' maps: `global` (the global L2 descent),
    /// `linf_l2` (the global descent, then Sander et al. 2001's vertex passes) or `none`.
    pub stretch_optimization: &'static str,
    /// Charts whose map the stretch optimisation ran on.
    pub charts_stretch_optimized: usize,
    /// Vertex moves it kept, over all charts.
    pub stretch_vertex_moves: usize,
    /// The parameterization of the final maps: `lscm` (conformal) or `asp` (Degener et al.
    /// 2003, the LSCM maps relaxed for an angle/area trade-off).
    pub parameterization: &'static str,
    /// ASP's θ (area weight) when `parameterization` is `asp`, else `null`.
    pub asp_theta: Option<f64>,
    /// Charts whose ASP map was kept.
    pub charts_asp: usize,
    /// Charts that kept their LSCM map because the ASP map failed the validation bounds.
    pub charts_asp_kept_lscm: usize,
    /// The flip promise's last line of defence: 3-D-degenerate faces whose written UV corners
    /// were distinct and were collapsed to a segment (two equal corners).
    pub uv_collapsed_faces: usize,
    /// ... UV vertices moved by a few `f32` spacings to unflip a face with 3-D area, or to give a
    /// sliver back the UV height rounding took from it.
    pub uv_nudged_vertices: usize,
    /// ... faces split off their chart, then packed again: faces that no nudge repaired or that
    /// overlapped another face of their chart (each into a chart of its own), and the parts of a
    /// chart that the output's connectivity tore apart.
    pub uv_guard_splits: usize,
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
        timings_s: TimingsJsonS,
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
        // Where each page's triangles went in the output (a primitive spanning pages is split).
        for part in &encoded.parts {
            if let Some(p) = pages.get_mut(part.page as usize) {
                p.primitives.push(PrimitiveRefJson {
                    mesh: part.mesh_index,
                    primitive: part.primitive_index,
                    triangles: part.faces,
                });
            }
        }
        let s = &atlas.stats;
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
            uv_set: encoded.uv_set,
            uv_set_per_primitive: encoded.uv_set_per_primitive.clone(),
            pages,
            quality: QualityJson::from(&atlas.report),
            pipeline: PipelineJson {
                segmented_charts: s.segmented_charts,
                charts: atlas.chart_page.len(),
                splits_flipped: s.parameterize_splits[0],
                splits_overlap: s.parameterize_splits[1],
                splits_area_ratio: s.parameterize_splits[2],
                merges: s.parameterize_merges,
                packing_cuts: s.packing_cuts,
                bound_unresolved: s.bound_unresolved,
                charts_direct: s.charts_direct,
                charts_hierarchical: s.charts_hierarchical,
                texels_per_unit: s.texels_per_unit,
                pack_trials: s.pack_trials,
                degenerate_charts: s.degenerate_charts,
                segmentation: s.segmentation.name(),
                spectral_splits: s.spectral_splits,
                border_faces_smoothed: s.border_faces_smoothed,
                stretch_optimization: s.stretch_optimization.name(),
                charts_stretch_optimized: s.stretch.charts_optimized,
                stretch_vertex_moves: s.stretch.moves,
                parameterization: s.parameterization.name(),
                asp_theta: s.asp_theta,
                charts_asp: s.asp.charts_relaxed,
                charts_asp_kept_lscm: s.asp.charts_kept_lscm,
                uv_collapsed_faces: s.uv_collapsed_faces,
                uv_nudged_vertices: s.uv_nudged_vertices,
                uv_guard_splits: s.uv_guard_splits,
            },
            timings_s,
        }
    }
}

/// The measured quality: [`AtlasReport`] on the wire. Names follow the independent evaluator's
/// keys (`../shared/eval/atlas_eval.py`) where it has them; `null` means undefined or
/// non-finite, as there.
#[derive(Debug, Clone, Serialize)]
pub struct QualityJson {
    /// Faces measured, degenerate ones included.
    pub triangles: usize,
    /// Distinct (glTF mesh, position, page, UV) corners.
    pub unique_corners: usize,
    /// Σ 3-D area of non-degenerate faces, model units².
    pub area_3d_m2: f64,
    /// Σ |UV area| of non-degenerate faces, page units (a page is 1).
    pub uv_area: f64,
    /// UV-degenerate faces.
    pub degenerate: usize,
    /// 3-D-degenerate faces.
    pub degenerate_3d: usize,
    /// UV-degenerate faces with 3-D area (strictly infinite stretch).
    pub degenerate_uv_with_3d_area: usize,
    /// Charts, recomputed from the written UVs.
    pub charts: usize,
    /// Distinct cut 3-D edges.
    pub seam_edges: usize,
    /// Total 3-D length of the cut edges, model units.
    pub seam_length_3d_m: f64,
    /// Seam length / sqrt(3-D area).
    pub seam_edge_ratio: Option<f64>,
    /// All chart-boundary length (seams once per side, open borders) / sqrt(3-D area).
    pub boundary_edge_ratio: Option<f64>,
    /// 3-D length of the mesh's own open borders, model units.
    pub open_border_length_3d_m: f64,
    /// Sander stretch.
    pub stretch: StretchJson,
    /// Angle distortion (`null` without a measurable face).
    pub angle_distortion: Option<AngleDistortionJson>,
    /// Area distortion (`null` without a measurable face).
    pub area_distortion: Option<AreaDistortionJson>,
    /// Faces whose UV orientation differs from their chart's.
    pub flipped: usize,
    /// Mirrored charts (orientation opposite to the atlas majority; not flips).
    pub charts_minority_orientation: usize,
    /// Corners outside \[0,1\] (1e-6 tolerance).
    pub out_of_range_corners: usize,
    /// Faces with such a corner.
    pub out_of_range_triangles: usize,
    /// `[u_min, v_min, u_max, v_max]`, pages overlaid.
    pub uv_bbox: Option<[f64; 4]>,
    /// UV area / page area (all pages).
    pub packing_efficiency: f64,
    /// UV area / area of the used UV bounding box.
    pub packing_efficiency_bbox: Option<f64>,
    /// Σ padded chart area / page area (all pages), in texels: each chart's UV area plus its
    /// UV boundary length × padding/2 plus π (padding/2)² (the chart grown by half the
    /// padding); how close the packing came to what the padding allows. `≥ packing_efficiency`.
    pub packing_bound: f64,
    /// Covered texel centres / all page texels.
    pub texel_utilization: f64,
    /// Overlaps: exact and sampled.
    pub overlap: OverlapJson,
    /// Padding violations.
    pub padding: PaddingJson,
    /// Texel density across charts.
    pub texel_density: Option<TexelDensityJson>,
    /// Per chart: faces, page, areas, stretch, density.
    pub per_chart: Vec<ChartQualityJson>,
}

/// Sander stretch; see [`crate::atlas::measure::StretchReport`].
#[derive(Debug, Clone, Serialize)]
pub struct StretchJson {
    /// L2 stretch (≥ 1, 1 ideal), global normalisation.
    pub l2: Option<f64>,
    /// Symmetric L∞ stretch `max max(Γ, 1/γ)`.
    pub linf: Option<f64>,
    /// Sander's L∞ `max Γ`.
    pub linf_sander: Option<f64>,
    /// The normalisation k = Σ|UV area| / Σ 3-D area.
    pub uv_area_over_3d_area: Option<f64>,
    /// Some face has zero UV area but 3-D area.
    pub strict_infinite: bool,
    /// Faces used.
    pub triangles_used: usize,
}

/// Angle distortion; `_aw` = 3-D-area weighted.
#[derive(Debug, Clone, Serialize)]
#[allow(missing_docs)]
pub struct AngleDistortionJson {
    pub angle_deviation_deg_mean: Option<f64>,
    pub angle_deviation_deg_p95: Option<f64>,
    pub angle_deviation_deg_mean_aw: Option<f64>,
    pub angle_deviation_deg_p95_aw: Option<f64>,
    pub conformal_ratio_mean: Option<f64>,
    pub conformal_ratio_p95: Option<f64>,
    pub conformal_ratio_mean_aw: Option<f64>,
    pub conformal_ratio_p95_aw: Option<f64>,
}

/// Percentiles of the normalised area ratio (UV/3-D area over k); `_aw` = 3-D-area weighted.
#[derive(Debug, Clone, Serialize)]
#[allow(missing_docs)]
pub struct AreaDistortionJson {
    pub p5: Option<f64>,
    pub p50: Option<f64>,
    pub p95: Option<f64>,
    pub p5_aw: Option<f64>,
    pub p50_aw: Option<f64>,
    pub p95_aw: Option<f64>,
}

/// Overlaps.
#[derive(Debug, Clone, Serialize)]
pub struct OverlapJson {
    /// Face pairs whose open UV interiors intersect, decided with exact predicates.
    pub exact: ExactOverlapJson,
    /// The evaluator's texel-centre sampled figures.
    pub sampled: SampledOverlapJson,
}

/// Exact overlap pairs.
#[derive(Debug, Clone, Serialize)]
pub struct ExactOverlapJson {
    /// Overlapping face pairs (a lower bound when `truncated`).
    pub pairs: u64,
    /// Of which within one chart (fold-overs).
    pub pairs_same_chart: u64,
    /// Of which across charts.
    pub pairs_cross_chart: u64,
    /// Counting stopped at its cap.
    pub truncated: bool,
    /// Up to 16 overlapping face pairs (face indices in (mesh, primitive) order).
    pub examples: Vec<[u32; 2]>,
}

/// The evaluator's sampled overlap.
#[derive(Debug, Clone, Serialize)]
#[allow(missing_docs)]
pub struct SampledOverlapJson {
    pub covered_texels: u64,
    pub overlapping_texels: u64,
    pub fraction: f64,
    pub texels_cross_chart: u64,
    pub texels_same_chart: u64,
    pub pairs: u64,
    pub pairs_same_chart: u64,
    pub pairs_cross_chart: u64,
    pub pairs_truncated: bool,
}

/// Padding check.
#[derive(Debug, Clone, Serialize)]
pub struct PaddingJson {
    /// The padding checked, texels.
    pub padding_texels: u32,
    /// Covered texels with a texel of another chart within that Chebyshev distance.
    pub violation_texels: u64,
}

/// Texel density across charts (UV units per model unit per chart).
#[derive(Debug, Clone, Serialize)]
#[allow(missing_docs)]
pub struct TexelDensityJson {
    pub charts_measured: usize,
    pub min: f64,
    pub max: f64,
    pub max_over_min: Option<f64>,
    pub cv: Option<f64>,
    pub cv_aw: Option<f64>,
    /// Texels per model unit of the whole atlas.
    pub texels_per_unit: Option<f64>,
}

/// One chart's quality.
#[derive(Debug, Clone, Serialize)]
pub struct ChartQualityJson {
    /// Its lowest face (index in (mesh, primitive) order).
    pub first_face: u32,
    /// Its page.
    pub page: u32,
    /// Faces.
    pub faces: usize,
    /// 3-D area, model units².
    pub area_3d_m2: f64,
    /// UV area, page units.
    pub uv_area: f64,
    /// L2 stretch (global normalisation).
    pub l2: Option<f64>,
    /// Symmetric L∞ stretch.
    pub linf: Option<f64>,
    /// sqrt(UV area / 3-D area).
    pub texel_density: Option<f64>,
}

impl From<&AtlasReport> for QualityJson {
    fn from(r: &AtlasReport) -> Self {
        let s = &r.stretch;
        let ex = &r.overlap.exact;
        let sa = &r.overlap.sampled;
        QualityJson {
            triangles: r.triangles,
            unique_corners: r.unique_corners,
            area_3d_m2: r.area_3d_m2,
            uv_area: r.uv_area,
            degenerate: r.degenerate,
            degenerate_3d: r.degenerate_3d,
            degenerate_uv_with_3d_area: r.degenerate_uv_with_3d_area,
            charts: r.charts,
            seam_edges: r.seam_edges,
            seam_length_3d_m: r.seam_length_3d_m,
            seam_edge_ratio: r.seam_edge_ratio,
            boundary_edge_ratio: r.boundary_edge_ratio,
            open_border_length_3d_m: r.open_border_length_3d_m,
            stretch: StretchJson {
                l2: s.l2,
                linf: s.linf,
                linf_sander: s.linf_sander,
                uv_area_over_3d_area: s.uv_area_over_3d_area,
                strict_infinite: s.strict_infinite,
                triangles_used: s.triangles_used,
            },
            angle_distortion: r.angle_distortion.as_ref().map(|a| AngleDistortionJson {
                angle_deviation_deg_mean: a.angle_deviation_deg_mean,
                angle_deviation_deg_p95: a.angle_deviation_deg_p95,
                angle_deviation_deg_mean_aw: a.angle_deviation_deg_mean_aw,
                angle_deviation_deg_p95_aw: a.angle_deviation_deg_p95_aw,
                conformal_ratio_mean: a.conformal_ratio_mean,
                conformal_ratio_p95: a.conformal_ratio_p95,
                conformal_ratio_mean_aw: a.conformal_ratio_mean_aw,
                conformal_ratio_p95_aw: a.conformal_ratio_p95_aw,
            }),
            area_distortion: r.area_distortion.as_ref().map(|a| AreaDistortionJson {
                p5: a.p5,
                p50: a.p50,
                p95: a.p95,
                p5_aw: a.p5_aw,
                p50_aw: a.p50_aw,
                p95_aw: a.p95_aw,
            }),
            flipped: r.flipped,
            charts_minority_orientation: r.charts_minority_orientation,
            out_of_range_corners: r.out_of_range_corners,
            out_of_range_triangles: r.out_of_range_triangles,
            uv_bbox: r.uv_bbox,
            packing_efficiency: r.packing_efficiency,
            packing_efficiency_bbox: r.packing_efficiency_bbox,
            packing_bound: r.packing_bound,
            texel_utilization: r.texel_utilization,
            overlap: OverlapJson {
                exact: ExactOverlapJson {
                    pairs: ex.pairs,
                    pairs_same_chart: ex.pairs_same_chart,
                    pairs_cross_chart: ex.pairs_cross_chart,
                    truncated: ex.truncated,
                    examples: ex.examples.iter().map(|p| p.map(|f| f.0)).collect(),
                },
                sampled: SampledOverlapJson {
                    covered_texels: sa.covered_texels,
                    overlapping_texels: sa.overlapping_texels,
                    fraction: sa.fraction,
                    texels_cross_chart: sa.texels_cross_chart,
                    texels_same_chart: sa.texels_same_chart,
                    pairs: sa.pairs,
                    pairs_same_chart: sa.pairs_same_chart,
                    pairs_cross_chart: sa.pairs_cross_chart,
                    pairs_truncated: sa.pairs_truncated,
                },
            },
            padding: PaddingJson {
                padding_texels: r.padding.padding_texels,
                violation_texels: r.padding.violation_texels,
            },
            texel_density: r.texel_density.as_ref().map(|d| TexelDensityJson {
                charts_measured: d.charts_measured,
                min: d.min,
                max: d.max,
                max_over_min: d.max_over_min,
                cv: d.cv,
                cv_aw: d.cv_aw,
                texels_per_unit: d.texels_per_unit,
            }),
            per_chart: r
                .per_chart
                .iter()
                .map(|c| ChartQualityJson {
                    first_face: c.first_face.0,
                    page: c.page,
                    faces: c.faces,
                    area_3d_m2: c.area_3d_m2,
                    uv_area: c.uv_area,
                    l2: c.l2,
                    linf: c.linf,
                    texel_density: c.texel_density,
                })
                .collect(),
        }
    }
}
