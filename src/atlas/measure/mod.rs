//! Measuring an atlas: the quality report (issue 5).
//!
//! # Purpose
//! [`measure_atlas`] turns the *final* data of an atlas — each face's 3-D corner positions, the
//! `f32` corner UVs exactly as written to the file, the glTF mesh of each face and its page —
//! into an [`AtlasReport`]: stretch, angle and area distortion, charts and seams, flips,
//! overlaps (exact and sampled), packing, padding, range and texel density.
//!
//! The report measures the output the way the independent evaluator
//! (`../shared/eval/atlas_eval.py`, its module docstring) does, with the same definitions, so
//! that the two agree; it never trusts pipeline-internal chart ids. In particular a *chart* is
//! recomputed from the output: a connected component of triangles, two triangles being connected
//! when they share an edge whose two corners are equal in glTF mesh
//! ([`TriangleMesh::vertex_weld_group`]), 3-D position and UV (exact equality, `-0.0 == 0.0`).
//! Where we extend the evaluator (pages, `W × H` pages, exact overlaps, per-chart stretch) the
//! extension reduces to the evaluator's definition for one square page `R = W = H`, which is how
//! the agreement test (`tests/measure_eval_agreement.rs`) compares them.
//!
//! # Definitions (T a triangle, q1..q3 its positions, (s_i, t_i) its UVs)
//! - `A3 = |(q2-q1) × (q3-q1)| / 2`, `A2 = ((s2-s1)(t3-t1) - (s3-s1)(t2-t1)) / 2` (signed).
//! - UV-degenerate: `|A2| <= 1e-12 · (longest UV edge)²` (or NaN); 3-D degenerate: the same rule
//!   on `A3`. A triangle is *used* for stretch, angle, area and density when neither.
//! - Stretch (Sander et al. 2001, "Texture mapping progressive meshes" §3): `Ss = ∂q/∂s`,
//!   `St = ∂q/∂t`, `a = Ss·Ss`, `b = Ss·St`, `c = St·St`, all scaled by the *global*
//!   `k = Σ|A2| / ΣA3` over used triangles (the whole atlas is rescaled so that UV area = 3-D
//!   area; per-chart values use the same `k`, so a chart at a different texel density has
//!   L2 ≠ 1). Γ, γ = max and min singular values. `l2 = sqrt(Σ (a+c)/2·A3 / Σ A3)`,
//!   `linf = max max(Γ, 1/γ)` (the symmetric form of Iso-charts, Zhou et al. 2004 §4),
//!   `linf_sander = max Γ`.
//! - Angle distortion: `|angle(Ss, St) - 90°|` and the conformal ratio Γ/γ; area distortion
//!   `(|A2|/A3)/k`. Unweighted percentiles use numpy's linear interpolation, 3-D-area-weighted
//!   (`_aw`) ones the inverted weighted CDF.
//! - Orientation: a chart's orientation is the sign of its total signed UV area (ties positive);
//!   `flipped` counts non-UV-degenerate triangles of the other sign.
//! - Raster metrics sample texel centres on each `W × H` page with UVs snapped to `1/256` texel
//!   fixed point and exact `i64` edge functions with a top-left tie rule (see `raster.rs`).
//! - Exact overlaps: pairs of triangles on the same page whose open UV interiors intersect,
//!   decided with Shewchuk's exact orientation predicate (see `overlap.rs`).
//!
//! # Invariants
//! Pure and deterministic: the same input gives the same report bits whatever the thread count
//! (every parallel reduction is over integers or is done in a fixed order). No IO, no logging.
//!
//! # Units
//! 3-D lengths in model units (`_m`), areas `_m2`; UV lengths and areas in normalized page units
//! (a page is the unit square); raster quantities in texels (`_texels`); angles in the report in
//! degrees (`_deg`, as the evaluator); stretch and ratios are dimensionless (1 ideal).
//!
//! # Cost
//! Linear in faces plus linear in page texels: one pass per face for geometry and stretch,
//! bucket sorts (no comparison sort over all corners) for connectivity, one rasterisation pass
//! per page (plus a second only when texels are covered twice), a separable `O(W·H·padding)`
//! padding scan, and a uniform grid for exact overlaps (about 3 candidate pairs per face on
//! a well-packed atlas). Measured with `cargo test --release --test measure_eval_agreement
//! measure_speed` (process CPU time, all threads; the shared 2-core machine ran at load ~10, so
//! wall time was about 3× this): bunny (69k faces) at 1024²: 60 ms; a 1M-face grid: 0.8 s at
//! 1024², 1.15 s at 4096²; the 1M-face `beast_sub2_1M` with one chart per face: 1.2 s; the same
//! with a closed surface folded flat (8.2M true overlap pairs, each needing all 18 predicates):
//! 5.6 s. Memory about 100 bytes per face plus 5 bytes per page texel, plus 8 bytes per exact
//! overlap pair found (none on a correct atlas; at most [`EXACT_OVERLAP_PAIRS_MAX`]).
//! The exact-overlap search runs concurrently with everything else (it needs no chart ids;
//! its pairs are classified by chart at the end). Instructions per measure of bunny under callgrind
//! (one thread), before → after the branch-free padding scan, the radix percentile sorts and
//! the counting-sorted half-edges (same report bits): raster 321M → 191M, stretch 124M → 88M,
//! exact overlaps 125M → 132M (the pairs are now stored).
//!
//! # Code map
//! - `geometry.rs`: per-face areas, degeneracy, edge lengths.
//! - `charts.rs`: corner keys, charts, seams, boundaries.
//! - `stretch.rs`: stretch, angle and area distortion, texel density.
//! - `numpy.rs`: the evaluator's numerics (pairwise sums, einsum order, percentiles).
//! - `raster.rs`: centre-sampled coverage, sampled overlap, padding violations.
//! - `overlap.rs`: exact overlap pairs on a uniform grid.
use crate::mesh::{FaceId, TriangleMesh};

mod charts;
mod geometry;
mod numpy;
mod overlap;
mod raster;
mod stretch;
#[cfg(test)]
mod tests;

/// The evaluator's default cap on enumerated candidate pairs of the *sampled* overlap
/// (`--max-pairs`); past it [`SampledOverlap::pairs_truncated`] is set.
pub const SAMPLED_PAIR_CANDIDATES_MAX: u64 = 20_000_000;

/// Cap on counted *exact* overlap pairs: past it counting stops (at a deterministic point) and
/// [`ExactOverlap::truncated`] is set. A correct atlas has 0; this only bounds the time spent
/// on a badly broken one.
pub const EXACT_OVERLAP_PAIRS_MAX: u64 = 10_000_000;

/// How many overlapping face pairs [`ExactOverlap::examples`] lists.
pub const EXACT_OVERLAP_EXAMPLES: usize = 16;

/// What [`measure_atlas`] measures: the final per-corner UVs of every face of `mesh`.
///
/// Preconditions (a violation is a caller bug and panics): `corner_uvs.len() ==
/// face_page.len() == mesh.num_faces()`, every page `< num_pages`, `num_pages >= 1`,
/// `width_texels >= 1`, `height_texels >= 1`.
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
    /// Padding wanted between charts, texels (0 disables the padding check, as the
    /// evaluator's `--padding 0`).
    pub padding_texels: u32,
}

/// The quality report (plain data; the JSON form is in `crate::api`). Field names mirror the
/// evaluator's keys where it has them, with units added (`_m`, `_m2`); a value the evaluator
/// writes as `null` (undefined or non-finite) is `None` here.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AtlasReport {
    /// Faces measured, degenerate ones included (evaluator `triangles`).
    pub triangles: usize,
    /// Distinct (glTF mesh, position, page, UV) corners (evaluator `unique_corners`).
    pub unique_corners: usize,
    /// Σ A3 over non-3-D-degenerate faces (evaluator `area_3d`).
    pub area_3d_m2: f64,
    /// Σ |A2| over non-UV-degenerate faces, all pages (evaluator `uv_area`).
    pub uv_area: f64,
    /// UV-degenerate faces (evaluator `degenerate`).
    pub degenerate: usize,
    /// 3-D-degenerate faces (evaluator `degenerate_3d`).
    pub degenerate_3d: usize,
    /// UV-degenerate faces with 3-D area: strictly infinite stretch
    /// (evaluator `degenerate_uv_with_3d_area`).
    pub degenerate_uv_with_3d_area: usize,
    /// Sander stretch over the used faces (evaluator `stretch`).
    pub stretch: StretchReport,
    /// Angle distortion; `None` when no face is used (evaluator `angle_distortion`).
    pub angle_distortion: Option<AngleDistortion>,
    /// Area distortion; `None` when no face is used (evaluator `area_distortion`).
    pub area_distortion: Option<AreaDistortion>,
    /// Number of charts, recomputed from the output (evaluator `charts`).
    pub charts: usize,
    /// Distinct cut 3-D edges (evaluator `seam_edges`).
    pub seam_edges: usize,
    /// Total 3-D length of the cut edges, each once (evaluator `seam_length_3d`).
    pub seam_length_3d_m: f64,
    /// `seam_length_3d_m / sqrt(area_3d_m2)`; `None` without 3-D area.
    pub seam_edge_ratio: Option<f64>,
    /// 3-D length of all chart-boundary half-edges (seams once per side, open borders
    /// included) / `sqrt(area_3d_m2)`; `None` without 3-D area.
    pub boundary_edge_ratio: Option<f64>,
    /// 3-D length of the mesh's own open borders (evaluator `open_border_length_3d`).
    pub open_border_length_3d_m: f64,
    /// Non-UV-degenerate faces whose orientation differs from their chart's.
    pub flipped: usize,
    /// Charts whose orientation differs from the area-weighted majority of the atlas
    /// (mirrored charts, not counted as flipped).
    pub charts_minority_orientation: usize,
    /// Corners with u or v outside `[-1e-6, 1 + 1e-6]` or NaN (evaluator `out_of_range_corners`).
    pub out_of_range_corners: usize,
    /// Faces with at least one such corner.
    pub out_of_range_triangles: usize,
    /// `[u_min, v_min, u_max, v_max]` over the corners of faces whose UVs are all finite, all
    /// pages overlaid; `None` when there is none.
    pub uv_bbox: Option<[f64; 4]>,
    /// `uv_area / num_pages`: the share of the page area covered (overlaps count twice).
    pub packing_efficiency: f64,
    /// `uv_area / (num_pages · area of uv_bbox)`; `None` when that area is 0 or undefined.
    pub packing_efficiency_bbox: Option<f64>,
    /// Texel centres covered by at least one face / (`num_pages · W · H`).
    pub texel_utilization: f64,
    /// Overlaps, exact and sampled.
    pub overlap: OverlapReport,
    /// Padding violations (evaluator `padding`).
    pub padding: PaddingReport,
    /// Texel density across charts; `None` when no face is used.
    pub texel_density: Option<TexelDensityReport>,
    /// One entry per chart, numbered by lowest face.
    pub per_chart: Vec<ChartReport>,
    /// One entry per page.
    pub pages: Vec<PageReport>,
}

/// Sander stretch (evaluator `stretch`). `None` values: no used face, or non-finite (e.g. a
/// face with γ = 0 makes `linf` infinite).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StretchReport {
    /// L2 stretch, ≥ 1, 1 ideal.
    pub l2: Option<f64>,
    /// Symmetric L∞ stretch `max max(Γ, 1/γ)`, ≥ 1.
    pub linf: Option<f64>,
    /// Sander's original L∞ `max Γ`.
    pub linf_sander: Option<f64>,
    /// The normalisation `k = Σ|A2| / ΣA3` over used faces, UV units² per m²
    /// (evaluator `uv_area_over_3d_area`).
    pub uv_area_over_3d_area: Option<f64>,
    /// Some face is UV-degenerate with 3-D area (strictly infinite stretch); the values above
    /// are then over the remaining faces.
    pub strict_infinite: bool,
    /// Faces used (non-degenerate in UV and 3-D).
    pub triangles_used: usize,
    /// Faces left out for being UV-degenerate only.
    pub excluded_uv_degenerate: usize,
    /// Faces left out for being 3-D-degenerate.
    pub excluded_3d_degenerate: usize,
}

/// Angle distortion over used faces (evaluator `angle_distortion`); `_aw` = 3-D-area weighted.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AngleDistortion {
    /// Mean of `|angle(Ss, St) - 90°|`, degrees.
    pub angle_deviation_deg_mean: Option<f64>,
    /// 95th percentile (linear interpolation), degrees.
    pub angle_deviation_deg_p95: Option<f64>,
    /// Area-weighted mean, degrees.
    pub angle_deviation_deg_mean_aw: Option<f64>,
    /// Area-weighted 95th percentile (inverted CDF), degrees.
    pub angle_deviation_deg_p95_aw: Option<f64>,
    /// Mean of Γ/γ over faces where it is finite.
    pub conformal_ratio_mean: Option<f64>,
    /// 95th percentile of Γ/γ.
    pub conformal_ratio_p95: Option<f64>,
    /// Area-weighted mean of Γ/γ where finite.
    pub conformal_ratio_mean_aw: Option<f64>,
    /// Area-weighted 95th percentile of Γ/γ.
    pub conformal_ratio_p95_aw: Option<f64>,
}

/// Percentiles of the normalised area ratio `(|A2|/A3)/k` (evaluator `area_distortion`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AreaDistortion {
    /// 5th percentile, linear interpolation.
    pub p5: Option<f64>,
    /// Median, linear interpolation.
    pub p50: Option<f64>,
    /// 95th percentile, linear interpolation.
    pub p95: Option<f64>,
    /// 5th percentile, 3-D-area weighted (inverted CDF).
    pub p5_aw: Option<f64>,
    /// Median, 3-D-area weighted.
    pub p50_aw: Option<f64>,
    /// 95th percentile, 3-D-area weighted.
    pub p95_aw: Option<f64>,
}

/// Overlaps: the exact count and the evaluator's sampled figures.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OverlapReport {
    /// Pairs of faces whose open UV interiors intersect (exact predicates).
    pub exact: ExactOverlap,
    /// Texel-centre sampled overlap (evaluator `overlap`).
    pub sampled: SampledOverlap,
}

/// Exact overlap: unordered pairs of faces on the same page whose open UV triangles intersect.
/// Faces sharing an edge or a vertex do not overlap unless one folds over the other; faces of
/// zero UV area (exactly) have no interior and never overlap.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ExactOverlap {
    /// Overlapping pairs (a lower bound when `truncated`).
    pub pairs: u64,
    /// Of which both faces are in the same chart (fold-overs).
    pub pairs_same_chart: u64,
    /// Of which the faces are in different charts.
    pub pairs_cross_chart: u64,
    /// Counting stopped at [`EXACT_OVERLAP_PAIRS_MAX`].
    pub truncated: bool,
    /// Up to [`EXACT_OVERLAP_EXAMPLES`] overlapping pairs (lower face first), for debugging.
    pub examples: Vec<[FaceId; 2]>,
}

/// The evaluator's centre-sampled overlap, summed over pages (evaluator `overlap`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SampledOverlap {
    /// Texel centres covered by at least one face.
    pub covered_texels: u64,
    /// Texel centres covered by at least two faces.
    pub overlapping_texels: u64,
    /// `overlapping_texels / covered_texels` (0 when nothing is covered).
    pub fraction: f64,
    /// Overlapping texels whose faces come from several charts.
    pub texels_cross_chart: u64,
    /// Overlapping texels whose faces all come from one chart (fold-overs).
    pub texels_same_chart: u64,
    /// Distinct face pairs covering a common texel centre.
    pub pairs: u64,
    /// Of which in the same chart.
    pub pairs_same_chart: u64,
    /// Of which in different charts.
    pub pairs_cross_chart: u64,
    /// More than [`SAMPLED_PAIR_CANDIDATES_MAX`] candidates: the pair counts are lower bounds.
    pub pairs_truncated: bool,
    /// Faces touching the page whose coordinates are too large for the fixed-point raster.
    pub raster_skipped_triangles: u64,
}

/// Padding check (evaluator `padding`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PaddingReport {
    /// The padding checked, texels (0: not checked).
    pub padding_texels: u32,
    /// Covered texels with a texel of another chart within Chebyshev distance ≤ padding on the
    /// same page (texels covered by several charts count under overlap only).
    pub violation_texels: u64,
}

/// Texel density across charts: per chart `d = sqrt(Σ|A2| / ΣA3)` over its used faces, in
/// UV units per model unit (evaluator `texel_density`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TexelDensityReport {
    /// Charts with used 3-D area.
    pub charts_measured: usize,
    /// Smallest `d`.
    pub min: f64,
    /// Largest `d`.
    pub max: f64,
    /// `max / min`; `None` when `min` is 0.
    pub max_over_min: Option<f64>,
    /// Standard deviation / mean over charts, unweighted.
    pub cv: Option<f64>,
    /// The same, 3-D-area weighted.
    pub cv_aw: Option<f64>,
    /// `sqrt(k · W · H)`: texels per model unit of the whole atlas (`sqrt(k)·R` for `R = W = H`).
    pub texels_per_unit: Option<f64>,
}

/// One chart (charts are numbered by their lowest face).
#[derive(Debug, Clone, PartialEq)]
pub struct ChartReport {
    /// Its lowest face.
    pub first_face: FaceId,
    /// Its page (a chart never spans pages: the page is part of the corner key).
    pub page: u32,
    /// Number of faces, degenerate ones included.
    pub faces: usize,
    /// Σ A3 of its used faces.
    pub area_3d_m2: f64,
    /// Σ |A2| of its used faces.
    pub uv_area: f64,
    /// Total signed UV area of its non-UV-degenerate faces: the sign is its orientation.
    pub signed_uv_area: f64,
    /// L2 stretch over its used faces with the global `k`; `None` without used faces.
    pub l2: Option<f64>,
    /// Symmetric L∞ over its used faces with the global `k`; `None` without used faces or when
    /// infinite.
    pub linf: Option<f64>,
    /// `sqrt(uv_area / area_3d_m2)`; `None` without used area.
    pub texel_density: Option<f64>,
}

/// One page.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PageReport {
    /// Faces on it.
    pub faces: usize,
    /// Charts on it.
    pub charts: usize,
    /// Σ |A2| of its non-UV-degenerate faces, page units.
    pub uv_area: f64,
    /// Texel centres covered.
    pub covered_texels: u64,
}

/// `Some(x)` when finite: the evaluator writes non-finite numbers as `null`.
fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// Measures the atlas. Pure and deterministic. Panics on the precondition violations listed on
/// [`MeasureInput`]. Cost: see the module doc.
pub fn measure_atlas(input: &MeasureInput<'_>) -> AtlasReport {
    let mesh = input.mesh;
    let nf = mesh.num_faces();
    assert_eq!(input.corner_uvs.len(), nf, "one corner_uvs entry per face");
    assert_eq!(input.face_page.len(), nf, "one face_page entry per face");
    assert!(input.num_pages >= 1, "num_pages >= 1");
    assert!(
        input.width_texels >= 1 && input.height_texels >= 1,
        "pages are at least 1 × 1 texel"
    );
    assert!(
        input.face_page.iter().all(|&p| p < input.num_pages),
        "every face_page < num_pages"
    );

    // The exact-overlap search needs no chart ids (its pairs are classified at the end), so it
    // runs concurrently with everything else.
    let ((mut report, chart_of_face), exact_pairs) = rayon::join(
        || measure_without_exact_overlaps(input),
        || overlap::exact_overlap_pairs(input.corner_uvs, input.face_page, input.num_pages),
    );
    report.overlap.exact = exact_pairs.classify(&chart_of_face);
    report
}

/// Everything [`measure_atlas`] measures but the exact overlaps, and the chart of each face.
fn measure_without_exact_overlaps(input: &MeasureInput<'_>) -> (AtlasReport, Vec<u32>) {
    let mesh = input.mesh;
    let nf = mesh.num_faces();
    let geo = geometry::face_geometry(mesh, input.corner_uvs);
    let con = charts::connectivity(mesh, input.corner_uvs, input.face_page, &geo.edge_len_m);
    let mut report = AtlasReport {
        triangles: nf,
        unique_corners: con.unique_corners,
        charts: con.num_charts,
        seam_edges: con.seam_edges,
        seam_length_3d_m: con.seam_length_3d_m,
        open_border_length_3d_m: con.open_border_length_3d_m,
        ..AtlasReport::default()
    };

    // Counts, areas, orientation.
    let mut area_3d = Vec::with_capacity(nf);
    let mut uv_area = Vec::with_capacity(nf);
    // Plain sequential sums in face order, as the evaluator's `bincount`: a chart whose front
    // and back cancel (a closed surface projected flat) has a signed area near 0, and its sign
    // must come out the same.
    let mut chart_signed = vec![0.0f64; con.num_charts];
    for f in 0..nf {
        let (deg2, deg3) = (geo.uv_degenerate[f], geo.degenerate_3d[f]);
        report.degenerate += usize::from(deg2);
        report.degenerate_3d += usize::from(deg3);
        report.degenerate_uv_with_3d_area += usize::from(deg2 && !deg3);
        if !deg3 {
            area_3d.push(geo.area_3d_m2[f]);
        }
        uv_area.push(if deg2 {
            0.0
        } else {
            geo.signed_uv_area[f].abs()
        });
        if !deg2 {
            chart_signed[con.chart_of_face[f] as usize] += geo.signed_uv_area[f];
        }
    }
    report.area_3d_m2 = numpy::np_sum(&area_3d);
    report.uv_area = numpy::np_sum(&uv_area);
    drop((area_3d, uv_area));
    let chart_positive: Vec<bool> = chart_signed.iter().map(|&s| s >= 0.0).collect();
    for f in 0..nf {
        let a2 = geo.signed_uv_area[f];
        if !geo.uv_degenerate[f] && (a2 > 0.0) != chart_positive[con.chart_of_face[f] as usize] {
            report.flipped += 1;
        }
    }
    let signed_where = |positive: bool| -> Vec<f64> {
        chart_signed
            .iter()
            .zip(&chart_positive)
            .filter(|(_, &p)| p == positive)
            .map(|(&s, _)| s)
            .collect()
    };
    let atlas_positive = numpy::np_sum(&signed_where(true)) >= -numpy::np_sum(&signed_where(false));
    report.charts_minority_orientation = chart_positive
        .iter()
        .filter(|&&p| p != atlas_positive)
        .count();
    if report.area_3d_m2 > 0.0 {
        let sq = report.area_3d_m2.sqrt();
        report.seam_edge_ratio = finite(con.seam_length_3d_m / sq);
        report.boundary_edge_ratio = finite(con.boundary_length_3d_m / sq);
    }

    // Range, bbox, packing.
    let eps = 1e-6;
    let mut bbox = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    let mut any_finite = false;
    for uv in input.corner_uvs {
        let mut out = 0;
        for c in uv {
            let (u, v) = (f64::from(c[0]), f64::from(c[1]));
            let inside = |x: f64| x >= -eps && x <= 1.0 + eps;
            out += usize::from(!(inside(u) && inside(v)));
        }
        report.out_of_range_corners += out;
        report.out_of_range_triangles += usize::from(out > 0);
        if uv.iter().flatten().all(|x| x.is_finite()) {
            any_finite = true;
            for c in uv {
                let (u, v) = (f64::from(c[0]), f64::from(c[1]));
                bbox = [
                    bbox[0].min(u),
                    bbox[1].min(v),
                    bbox[2].max(u),
                    bbox[3].max(v),
                ];
            }
        }
    }
    let pages = f64::from(input.num_pages);
    report.packing_efficiency = report.uv_area / pages;
    if any_finite {
        report.uv_bbox = Some(bbox);
        let bba = (bbox[2] - bbox[0]) * (bbox[3] - bbox[1]);
        if bba > 0.0 {
            report.packing_efficiency_bbox = finite(report.uv_area / (pages * bba));
        }
    }

    // Stretch, distortion, density, per-chart values; raster metrics. The two are independent
    // pure functions of the same inputs, run concurrently.
    let (st, ras) = rayon::join(
        || {
            stretch::stretch(
                mesh,
                input.corner_uvs,
                &geo,
                &con.chart_of_face,
                con.num_charts,
                f64::from(input.width_texels) * f64::from(input.height_texels),
            )
        },
        || {
            raster::rasterize_pages(
                input.corner_uvs,
                input.face_page,
                input.num_pages,
                [input.width_texels, input.height_texels],
                input.padding_texels,
                &con.chart_of_face,
            )
        },
    );
    report.stretch = st.stretch;
    report.angle_distortion = st.angle;
    report.area_distortion = st.area;
    report.texel_density = st.density;
    let page_texels = pages * f64::from(input.width_texels) * f64::from(input.height_texels);
    report.texel_utilization = ras.sampled.covered_texels as f64 / page_texels;
    report.overlap.sampled = ras.sampled;
    report.padding = PaddingReport {
        padding_texels: input.padding_texels,
        violation_texels: ras.padding_violation_texels,
    };

    // Per chart and per page.
    let mut per_chart: Vec<ChartReport> = Vec::with_capacity(con.num_charts);
    let mut pages_out = vec![PageReport::default(); input.num_pages as usize];
    let mut chart_on_page_counted = vec![false; con.num_charts];
    for f in 0..nf {
        let c = con.chart_of_face[f] as usize;
        let page = input.face_page[f];
        if c == per_chart.len() {
            let cs = &st.per_chart[c];
            per_chart.push(ChartReport {
                first_face: FaceId(f as u32),
                page,
                faces: 0,
                area_3d_m2: cs.area_3d_m2,
                uv_area: cs.uv_area,
                signed_uv_area: chart_signed[c],
                l2: cs.l2,
                linf: cs.linf,
                texel_density: cs.texel_density,
            });
        }
        per_chart[c].faces += 1;
        let pr = &mut pages_out[page as usize];
        pr.faces += 1;
        if !geo.uv_degenerate[f] {
            pr.uv_area += geo.signed_uv_area[f].abs();
        }
        if !chart_on_page_counted[c] {
            chart_on_page_counted[c] = true;
            pr.charts += 1;
        }
    }
    for (pr, &covered) in pages_out.iter_mut().zip(&ras.covered_per_page) {
        pr.covered_texels = covered;
    }
    report.per_chart = per_chart;
    report.pages = pages_out;
    (report, con.chart_of_face)
}
