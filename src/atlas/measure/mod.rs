//! Measuring an atlas: the quality report.
//!
//! # Purpose
//! [`measure_atlas`] turns the *final* data of an atlas — each face's 3-D corner positions, the
//! `f32` corner UVs exactly as written to the file, the glTF mesh of each face and its page —
//! into an [`AtlasReport`]: stretch, angle and area distortion, charts and seams, flips,
//! overlaps (exact and sampled), packing, padding, range and texel density. It never trusts
//! pipeline-internal chart ids: every figure is computed from the output alone, by the
//! definitions below. `tests/corpus/measure_eval_agreement.rs` checks them against an independent
//! implementation (the reason for the numpy-exact arithmetic of `numpy.rs`).
//!
//! # Definitions
//! Per face `T`: 3-D corners `q1, q2, q3` and UVs `(s_i, t_i)` (the `f32` values widened to
//! `f64`, exact). Sums marked Σ are numpy's pairwise sums (`numpy.rs`) unless said otherwise.
//!
//! - **Areas.** `e1 = q2 - q1`, `e2 = q3 - q1`; `A3 = |e1 × e2| / 2`. With `ds1 = s2 - s1`,
//!   `dt1 = t2 - t1`, `ds2 = s3 - s1`, `dt2 = t3 - t1`: `A2 = (ds1·dt2 - ds2·dt1) / 2`
//!   (signed, page units²).
//! - **Degenerate.** UV-degenerate unless `|A2| > 1e-12 · ℓ2²`, `ℓ2` the longest UV edge (a NaN
//!   anywhere makes the face degenerate); 3-D degenerate unless `A3 > 1e-12 · ℓ3²`, `ℓ3` the
//!   longest 3-D edge. A face is *used* (for stretch, angle, area distortion and density) when
//!   it is neither. `area_3d_m2` = Σ `A3` over the non-3-D-degenerate faces; `uv_area` = Σ `|A2|`
//!   over the non-UV-degenerate faces, all pages.
//! - **Normalisation.** `k = Σ|A2| / ΣA3` over the used faces (UV units² per model unit²): the
//!   whole atlas is rescaled so that its UV area equals its 3-D area, so that 1.0 means
//!   isometric whatever the texel density. Per-chart values use the same global `k`.
//! - **Stretch** (Sander, Snyder, Gortler, Hoppe 2001, "Texture mapping progressive meshes" §3).
//!   Per used face, the Jacobian of the affine map from texture to surface has the columns
//!   `Ss = ∂q/∂s = (e1·dt2 - e2·dt1) / (2 A2)` and `St = ∂q/∂t = (e2·ds1 - e1·ds2) / (2 A2)`.
//!   Its metric tensor, normalised: `a = k Ss·Ss`, `b = k Ss·St`, `c = k St·St` (dot products in
//!   numpy's `einsum` order). Its singular values: `Γ = sqrt(((a + c) + r) / 2)`,
//!   `γ = sqrt(max(0, ((a + c) - r) / 2))`, `r = sqrt((a - c)² + 4b²)`.
//!   - `stretch.l2` = `sqrt(Σ ((a + c)/2 · A3) / Σ A3)` over the used faces: the area-weighted
//!     RMS of the singular values, 1.0 for an isometry up to the global scale;
//!   - `stretch.linf` = the largest `max(Γ, 1/γ)` over the used faces (`1/γ = ∞` when
//!     `γ = 0`), the symmetric L∞ of Iso-charts (Zhou et al. 2004 §4); `stretch.linf_sander` =
//!     the largest `Γ`, Sander's L∞. Both are 1.0 for an isometry.
//!   - Per chart, `l2` and `linf` are the same over the chart's used faces (plain sequential
//!     sums), with the global `k`, so a chart at another texel density than the rest has
//!     `l2 ≠ 1`. A non-finite value is reported as `None`.
//! - **Angle distortion**, per used face: the deviation `|acos(clamp(b / sqrt(a·c), -1, 1)) -
//!   90°|` (90° when that is NaN) and the conformal ratio `Γ/γ` (`∞` when `γ = 0`).
//! - **Area distortion**, per used face: `(|A2| / A3) / k` (1 where the face keeps its share of
//!   the area).
//! - **Means and percentiles** of these per-face values. Unweighted mean: Σx / n. Area-weighted
//!   (`_aw`, weight `A3`): Σ(x·A3) / ΣA3. The means of `Γ/γ` leave out its infinite values; the
//!   percentiles keep them. Unweighted percentile `p`: numpy's linear method on the sorted
//!   values, virtual index `h = n·p/100 + (1 - p/100) - 1`, interpolated between the values at
//!   `⌊h⌋` and `⌊h⌋ + 1` (clamped to the ends). Area-weighted percentile `p`: the inverted CDF,
//!   the first value in the stable ascending order at which the sequential cumulative weight
//!   reaches `p/100 · ΣA3`. Reported: deviation mean, p95 and their `_aw` forms; `Γ/γ` mean, p95
//!   and their `_aw` forms; area ratio p5, p50, p95 and their `_aw` forms.
//! - **Charts** are recomputed from the output: a corner's key is (glTF mesh
//!   ([`TriangleMesh::vertex_weld_group`]), 3-D position, page, UV), exact bits with
//!   `-0.0 == 0.0`; two faces are connected when they have a half-edge with the same unordered
//!   pair of corner keys; charts are the connected components, numbered by lowest face. Seams
//!   and boundaries: see `charts.rs`; `seam_edge_ratio` = seam length / `sqrt(area_3d_m2)`,
//!   `boundary_edge_ratio` = chart-boundary half-edge length / `sqrt(area_3d_m2)`.
//! - **Flips.** A chart's orientation is the sign of the sequential sum of `A2` over its
//!   non-UV-degenerate faces (positive when ≥ 0). `flipped` counts the non-UV-degenerate faces
//!   whose `A2 > 0` differs from their chart's orientation. The atlas's orientation is positive
//!   when Σ of the positive charts' sums ≥ −Σ of the negative charts' sums;
//!   `charts_minority_orientation` counts the charts of the other orientation (mirrored charts,
//!   not flips).
//! - **Exact overlaps.** Unordered pairs of faces on the same page whose *open* UV triangles
//!   intersect: two triangles with interiors intersect iff no edge line of either (made
//!   counter-clockwise) has all of the other on or right of it, decided with Shewchuk's exact
//!   `orient2d` (`overlap.rs`). Faces of exactly zero UV area or with non-finite UVs have no
//!   interior and never overlap; faces sharing an edge or a vertex overlap only when one folds
//!   over the other. Split into same-chart (fold-overs) and cross-chart pairs.
//! - **Sampled overlaps and coverage.** On each `W × H` page, texel `(i, j)` is sampled at its
//!   centre only; UVs are snapped to `1/256` texel fixed point and covered centres decided with
//!   exact integer edge functions and a top-left tie rule, so faces sharing an edge never both
//!   cover a centre (`raster.rs`). `covered_texels`: centres covered by at least one face;
//!   `overlapping_texels`: by at least two; `fraction` = overlapping / covered; `pairs`: distinct
//!   face pairs covering a common centre (capped at [`SAMPLED_PAIR_CANDIDATES_MAX`] candidates).
//! - **Padding.** A covered texel of chart `c` violates when a texel of another chart lies
//!   within Chebyshev distance ≤ `padding_texels` on the same page (texels covered by several
//!   charts count under overlap only).
//! - **Packing efficiency** = `uv_area / num_pages` (a page is the unit square, so this is the
//!   share of the page area covered; overlaps count twice); `packing_efficiency_bbox` =
//!   `uv_area / (num_pages · area of uv_bbox)`, `uv_bbox` the box of the corners of the faces
//!   whose UVs are all finite, all pages overlaid.
//! - **Packing bound** = Σ over charts of the *padded chart area* / (`num_pages · W · H`), in
//!   texels: a chart's padded area is `A + L·r + π·r²` with `r = padding_texels / 2`, `A` its
//!   UV area in texels² (Σ `|A2|·W·H` over its non-UV-degenerate faces, as `uv_area`) and `L`
//!   the length in texels (`sqrt((W·Δu)² + (H·Δv)²)`, finite edges only) of its UV boundary:
//!   the half-edges whose corner-key pair no other half-edge has, holes included. For a convex
//!   chart this is the area of the chart grown by `r` on every side (Steiner's formula); for
//!   any other chart it is at least that area. Charts kept about `padding_texels` apart and
//!   from the page edge have nearly disjoint grown shapes inside the page, so the bound is the
//!   share of the pages taken by the charts and the padding they need: near 1 when packed as
//!   tightly as the padding allows. `packing_efficiency ≤ packing_bound`, equal with padding 0.
//! - **Texel utilisation** = `covered_texels / (num_pages · W · H)`.
//! - **Range.** A corner is out of range when `u` or `v` is outside `[-1e-6, 1 + 1e-6]` or NaN.
//! - **Texel density.** Per chart with used area, `d = sqrt(Σ|A2| / ΣA3)` over its used faces
//!   (UV units per model unit); reported: min, max, max/min, `cv` = population standard
//!   deviation / mean, `cv_aw` the same with weights `ΣA3` per chart, and the atlas's
//!   `texels_per_unit` = `sqrt(k · W · H)`.
//!
//! # Invariants
//! Pure and deterministic: the same input gives the same report bits whatever the thread count
//! (every parallel reduction is over integers or is done in a fixed order). No IO, no logging.
//!
//! # Units
//! 3-D lengths in model units (`_m`), areas `_m2`; UV lengths and areas in normalized page units
//! (a page is the unit square); raster quantities in texels (`_texels`); angles in the report in
//! degrees (`_deg`); stretch and ratios are dimensionless (1 ideal).
//!
//! # Cost
//! Linear in faces plus linear in page texels: one pass per face for geometry and stretch,
//! bucket sorts (no comparison sort over all corners) for connectivity, one rasterisation pass
//! per page (plus a second only when texels are covered twice), a separable `O(W·H·padding)`
//! padding scan, and a uniform grid for exact overlaps (about 3 candidate pairs per face on
//! a well-packed atlas). Memory about 100 bytes per face plus 5 bytes per page texel, plus 8
//! bytes per exact overlap pair found (none on a correct atlas; at most
//! [`EXACT_OVERLAP_PAIRS_MAX`]). The exact-overlap search runs concurrently with everything
//! else (it needs no chart ids; its pairs are classified by chart at the end).
//!
//! # Code map
//! - `geometry.rs`: per-face areas, degeneracy, edge lengths.
//! - `charts.rs`: corner keys, charts, seams, boundaries.
//! - `stretch.rs`: stretch, angle and area distortion, texel density.
//! - `numpy.rs`: numpy-exact numerics (pairwise sums, einsum order, percentiles).
//! - `raster.rs`: centre-sampled coverage, sampled overlap, padding violations.
//! - `overlap.rs`: exact overlap pairs on a uniform grid.
use crate::mesh::{FaceId, TriangleMesh};

mod charts;
mod geometry;
mod moved;
mod numpy;
mod overlap;
mod raster;
mod stretch;
pub(crate) use stretch::face_metric;
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
    /// Σ padded chart area / (`num_pages · W · H`), texels (module doc): how close the packing
    /// came to what the padding allows; `≥ packing_efficiency`.
    pub packing_bound: f64,
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

/// The packing bound of the module doc: `uv_area` (page units², as the efficiency's) and
/// `num_charts` from the connectivity, `uv_boundary` per half-edge. Sequential sum in
/// half-edge order (deterministic).
fn packing_bound(
    input: &MeasureInput<'_>,
    uv_boundary: &[bool],
    uv_area: f64,
    num_charts: usize,
) -> f64 {
    let (w, h) = (
        f64::from(input.width_texels),
        f64::from(input.height_texels),
    );
    let r_texels = f64::from(input.padding_texels) / 2.0;
    let mut boundary_texels = 0.0;
    for (e, _) in uv_boundary.iter().enumerate().filter(|(_, &b)| b) {
        let uv = &input.corner_uvs[e / 3];
        let (a, b) = (uv[e % 3], uv[(e + 1) % 3]);
        let du = w * (f64::from(b[0]) - f64::from(a[0]));
        let dv = h * (f64::from(b[1]) - f64::from(a[1]));
        let len = du.hypot(dv);
        if len.is_finite() {
            boundary_texels += len;
        }
    }
    let page_texels = f64::from(input.num_pages) * w * h;
    let padded_texels = uv_area * w * h
        + boundary_texels * r_texels
        + num_charts as f64 * std::f64::consts::PI * r_texels * r_texels;
    padded_texels / page_texels
}

/// The face pairs `(a, b)`, `a < b`, that cover a common texel centre by the report's own
/// sampling (the evaluator's fixed-point raster: its `overlap.pairs_same_chart` when
/// `chart_of_face` is the report's charts) and lie in one chart of `chart_of_face`, ascending.
/// `size = [W, H]` texels. For the pipeline's last line of defence (`uv_guard.rs`). Pure and
/// deterministic; the cost of the report's rasterization.
pub(crate) fn sampled_same_chart_pairs(
    corner_uvs: &[[[f32; 2]; 3]],
    face_page: &[u32],
    num_pages: u32,
    size: [u32; 2],
    chart_of_face: &[u32],
) -> Vec<(u32, u32)> {
    raster::rasterize_pages(corner_uvs, face_page, num_pages, size, 0, chart_of_face)
        .same_chart_pairs
}

/// The report's exact overlap pairs (`overlap.exact`: Shewchuk's predicates on the `f32` UVs,
/// at most [`EXACT_OVERLAP_PAIRS_MAX`]) of one set of written UVs, found before the atlas is
/// measured ([`exact_overlaps`]): for the pipeline's last line of defence (`uv_guard.rs`),
/// where a fold thinner than the raster's rounding covers no texel centre and only this test
/// sees it, and then for [`measure_atlas_reusing`] on the same UVs, which does not search
/// again.
pub(crate) struct ExactOverlaps {
    pairs: overlap::ExactPairs,
    /// What the pairs were found on (`corner_uvs.len()`, `num_pages`), checked when measuring.
    shape: (usize, u32),
}

impl ExactOverlaps {
    /// The pairs `(a, b)`, `a < b`, whose faces lie in one chart of `chart_of_face`, ascending.
    pub(crate) fn same_chart(&self, chart_of_face: &[u32]) -> Vec<(u32, u32)> {
        self.pairs.same_chart(chart_of_face)
    }

    /// The faces in any pair, ascending, once each.
    pub(crate) fn faces(&self) -> Vec<u32> {
        self.pairs.faces()
    }
}

/// Searches the exact overlap pairs of `corner_uvs` ([`ExactOverlaps`]). Pure and
/// deterministic; the cost of the report's exact search.
pub(crate) fn exact_overlaps(
    corner_uvs: &[[[f32; 2]; 3]],
    face_page: &[u32],
    num_pages: u32,
) -> ExactOverlaps {
    ExactOverlaps {
        pairs: overlap::exact_overlap_pairs(corner_uvs, face_page, num_pages),
        shape: (corner_uvs.len(), num_pages),
    }
}

/// What [`measure_atlas_reusing`] need not compute again: searches and checks already run on
/// the very UVs it measures.
#[derive(Default)]
pub(crate) struct Reuse {
    /// [`exact_overlaps`] of `input.corner_uvs`, `input.face_page`, `input.num_pages`.
    pub exact: Option<ExactOverlaps>,
    /// [`orientation_check`] of `input.mesh`, `input.corner_uvs`, `input.face_page`.
    pub check: Option<OrientationCheck>,
}

/// [`measure_atlas`] with what `reuse` holds already found on these very UVs: the same report,
/// without computing it again. Debug builds compute it again and check that it agrees.
pub(crate) fn measure_atlas_reusing(input: &MeasureInput<'_>, reuse: Reuse) -> AtlasReport {
    assert_input(input);
    let Reuse { exact, check } = reuse;
    if let Some(check) = &check {
        assert_eq!(
            (check.signed_uv_area.len(), check.corner_id.len()),
            (input.corner_uvs.len(), 3 * input.corner_uvs.len()),
            "an orientation check of other UVs"
        );
        debug_assert!(
            same_check(
                check,
                &orientation_check(input.mesh, input.corner_uvs, input.face_page)
            ),
            "an orientation check of other UVs"
        );
    }
    let Some(exact) = exact else {
        // The exact-overlap search needs no chart ids (its pairs are classified at the end), so
        // it runs concurrently with everything else.
        let ((mut report, chart_of_face), exact_pairs) = rayon::join(
            || measure_without_exact_overlaps(input, check),
            || overlap::exact_overlap_pairs(input.corner_uvs, input.face_page, input.num_pages),
        );
        report.overlap.exact = exact_pairs.classify(&chart_of_face);
        return report;
    };
    assert_eq!(
        exact.shape,
        (input.corner_uvs.len(), input.num_pages),
        "exact overlap pairs of other UVs"
    );
    debug_assert!(
        exact.pairs.same_pairs(&overlap::exact_overlap_pairs(
            input.corner_uvs,
            input.face_page,
            input.num_pages
        )),
        "exact overlap pairs of other UVs"
    );
    let (mut report, chart_of_face) = measure_without_exact_overlaps(input, check);
    report.overlap.exact = exact.pairs.classify(&chart_of_face);
    report
}

/// Whether two orientation checks agree bit for bit (debug builds' check of a reused one).
fn same_check(a: &OrientationCheck, b: &OrientationCheck) -> bool {
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let edges = |v: &[[f64; 3]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
    let (ra, rb) = (&a.rest, &b.rest);
    bits(&a.signed_uv_area) == bits(&b.signed_uv_area)
        && a.uv_degenerate == b.uv_degenerate
        && a.degenerate_3d == b.degenerate_3d
        && a.chart_of_face == b.chart_of_face
        && a.chart_positive == b.chart_positive
        && a.corner_id == b.corner_id
        && a.uv_boundary == b.uv_boundary
        && ra.corner_pid == rb.corner_pid
        && bits(&ra.area_3d_m2) == bits(&rb.area_3d_m2)
        && edges(&ra.edge_len_m) == edges(&rb.edge_len_m)
        && (ra.num_charts, ra.unique_corners, ra.seam_edges)
            == (rb.num_charts, rb.unique_corners, rb.seam_edges)
        && [
            ra.seam_length_3d_m,
            ra.boundary_length_3d_m,
            ra.open_border_length_3d_m,
        ]
        .map(f64::to_bits)
            == [
                rb.seam_length_3d_m,
                rb.boundary_length_3d_m,
                rb.open_border_length_3d_m,
            ]
            .map(f64::to_bits)
}

/// Measures the atlas. Pure and deterministic. Panics on the precondition violations listed on
/// [`MeasureInput`]. Cost: see the module doc.
pub fn measure_atlas(input: &MeasureInput<'_>) -> AtlasReport {
    measure_atlas_reusing(input, Reuse::default())
}

/// Panics on the precondition violations listed on [`MeasureInput`].
fn assert_input(input: &MeasureInput<'_>) {
    let nf = input.mesh.num_faces();
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
}

/// Per chart, the sequential sum of `A2` over its non-UV-degenerate faces in face order (as
/// the evaluator's `bincount`: a chart whose front and back cancel, a closed surface projected
/// flat, has a signed area near 0, and its sign must come out the same) and its orientation
/// (positive when the sum is ≥ 0).
fn chart_orientation(
    geo: &geometry::FaceGeometry,
    chart_of_face: &[u32],
    num_charts: usize,
) -> (Vec<f64>, Vec<bool>) {
    chart_orientation_of(
        &geo.signed_uv_area,
        &geo.uv_degenerate,
        chart_of_face,
        num_charts,
    )
}

/// [`chart_orientation`] of the faces' `A2` and UV degeneracy.
fn chart_orientation_of(
    signed_uv_area: &[f64],
    uv_degenerate: &[bool],
    chart_of_face: &[u32],
    num_charts: usize,
) -> (Vec<f64>, Vec<bool>) {
    let mut chart_signed = vec![0.0f64; num_charts];
    for (f, &c) in chart_of_face.iter().enumerate() {
        if !uv_degenerate[f] {
            chart_signed[c as usize] += signed_uv_area[f];
        }
    }
    let positive = chart_signed.iter().map(|&s| s >= 0.0).collect();
    (chart_signed, positive)
}

/// The report's flip rule: `f` is not UV-degenerate and the sign of its `A2` differs from its
/// chart's orientation.
fn is_flipped(
    geo: &geometry::FaceGeometry,
    chart_of_face: &[u32],
    chart_positive: &[bool],
    f: usize,
) -> bool {
    !geo.uv_degenerate[f]
        && (geo.signed_uv_area[f] > 0.0) != chart_positive[chart_of_face[f] as usize]
}

/// What the report would say about the orientation of each face of final corner UVs: the
/// pipeline's last line of defence (`uv_guard.rs`) checks its output with the very rules of
/// the report (module doc: "Degenerate", "Charts", "Flips"), so that both agree.
pub(crate) struct OrientationCheck {
    /// `A2` of each face (page units², the `f32` corners widened exactly).
    pub signed_uv_area: Vec<f64>,
    /// UV-degenerate, per face.
    pub uv_degenerate: Vec<bool>,
    /// 3-D-degenerate, per face.
    pub degenerate_3d: Vec<bool>,
    /// The chart of each face, recomputed from the output.
    pub chart_of_face: Vec<u32>,
    /// Orientation of each chart (positive when its signed area is ≥ 0).
    pub chart_positive: Vec<bool>,
    /// Per corner `3f + k`: the id of its UV vertex (the output's vertex key: glTF mesh,
    /// position, page and UV bits, `-0.0` as `0.0`), numbered `0..unique_corners`.
    pub corner_id: Vec<u32>,
    /// Per half-edge `3f + k`: no other half-edge joins the same two UV vertices (it lies on
    /// its chart's UV boundary).
    pub uv_boundary: Vec<bool>,
    /// The rest of the report's geometry and connectivity of these UVs, for the report to
    /// reuse ([`measure_atlas_reusing`]).
    rest: CheckRest,
}

/// What [`OrientationCheck`] keeps of [`geometry::FaceGeometry`] and [`charts::Connectivity`]
/// beyond its public fields.
struct CheckRest {
    corner_pid: Vec<u32>,
    area_3d_m2: Vec<f64>,
    edge_len_m: Vec<[f64; 3]>,
    num_charts: usize,
    unique_corners: usize,
    seam_edges: usize,
    seam_length_3d_m: f64,
    boundary_length_3d_m: f64,
    open_border_length_3d_m: f64,
}

impl OrientationCheck {
    /// The geometry and connectivity the check was computed from, whole again.
    fn into_parts(self) -> (geometry::FaceGeometry, charts::Connectivity) {
        let r = self.rest;
        let geo = geometry::FaceGeometry {
            area_3d_m2: r.area_3d_m2,
            signed_uv_area: self.signed_uv_area,
            uv_degenerate: self.uv_degenerate,
            degenerate_3d: self.degenerate_3d,
            edge_len_m: r.edge_len_m,
        };
        let con = charts::Connectivity {
            chart_of_face: self.chart_of_face,
            num_charts: r.num_charts,
            unique_corners: r.unique_corners,
            seam_edges: r.seam_edges,
            seam_length_3d_m: r.seam_length_3d_m,
            boundary_length_3d_m: r.boundary_length_3d_m,
            open_border_length_3d_m: r.open_border_length_3d_m,
            uv_boundary: self.uv_boundary,
            corner_id: self.corner_id,
            corner_pid: r.corner_pid,
        };
        (geo, con)
    }
}

impl OrientationCheck {
    /// Counted in `flipped` by the report.
    pub fn flipped(&self, f: usize) -> bool {
        !self.uv_degenerate[f]
            && (self.signed_uv_area[f] > 0.0) != self.chart_positive[self.chart_of_face[f] as usize]
    }
    /// A fault for the guard: flipped, UV-degenerate with 3-D area (counted in
    /// `degenerate_uv_with_3d_area`), or 3-D-degenerate with UV area (it covers texels for
    /// nothing and can overlap its neighbours).
    pub fn fault(&self, f: usize) -> bool {
        self.flipped(f) || self.uv_degenerate[f] != self.degenerate_3d[f]
    }
}

/// [`OrientationCheck`] of `corner_uvs` (same preconditions as [`MeasureInput`]). Cost: the
/// geometry and connectivity passes of [`measure_atlas`], O(faces).
pub(crate) fn orientation_check(
    mesh: &TriangleMesh,
    corner_uvs: &[[[f32; 2]; 3]],
    face_page: &[u32],
) -> OrientationCheck {
    let geo = geometry::face_geometry(mesh, corner_uvs);
    let con = charts::connectivity(mesh, corner_uvs, face_page, &geo.edge_len_m);
    let (_, chart_positive) = chart_orientation(&geo, &con.chart_of_face, con.num_charts);
    OrientationCheck {
        signed_uv_area: geo.signed_uv_area,
        uv_degenerate: geo.uv_degenerate,
        degenerate_3d: geo.degenerate_3d,
        chart_of_face: con.chart_of_face,
        chart_positive,
        corner_id: con.corner_id,
        uv_boundary: con.uv_boundary,
        rest: CheckRest {
            corner_pid: con.corner_pid,
            area_3d_m2: geo.area_3d_m2,
            edge_len_m: geo.edge_len_m,
            num_charts: con.num_charts,
            unique_corners: con.unique_corners,
            seam_edges: con.seam_edges,
            seam_length_3d_m: con.seam_length_3d_m,
            boundary_length_3d_m: con.boundary_length_3d_m,
            open_border_length_3d_m: con.open_border_length_3d_m,
        },
    }
}

/// Everything [`measure_atlas`] measures but the exact overlaps, and the chart of each face;
/// with `check`, the [`orientation_check`] of these very UVs, its geometry and connectivity
/// are not computed again.
fn measure_without_exact_overlaps(
    input: &MeasureInput<'_>,
    check: Option<OrientationCheck>,
) -> (AtlasReport, Vec<u32>) {
    let mesh = input.mesh;
    let nf = mesh.num_faces();
    let (geo, con) = match check {
        Some(check) => check.into_parts(),
        None => {
            let geo = geometry::face_geometry(mesh, input.corner_uvs);
            let con =
                charts::connectivity(mesh, input.corner_uvs, input.face_page, &geo.edge_len_m);
            (geo, con)
        }
    };
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
    }
    report.area_3d_m2 = numpy::np_sum(&area_3d);
    report.uv_area = numpy::np_sum(&uv_area);
    drop((area_3d, uv_area));
    let (chart_signed, chart_positive) =
        chart_orientation(&geo, &con.chart_of_face, con.num_charts);
    report.flipped = (0..nf)
        .filter(|&f| is_flipped(&geo, &con.chart_of_face, &chart_positive, f))
        .count();
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

    report.packing_bound = packing_bound(input, &con.uv_boundary, report.uv_area, con.num_charts);

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
