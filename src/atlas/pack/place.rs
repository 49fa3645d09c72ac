//! Chart placement geometry: uniform texel density, base orientation, rotations, footprints.
//!
//! Purpose: turn one input chart into the candidate *orientations* the horizon packer chooses
//! from. Each orientation is an affine map from the chart's UVs (model units) to local texel
//! coordinates, with the chart's footprint `F` (texel centres in its slightly grown triangles,
//! computed as the nonzero-winding fill of the boundary chain of its well-shaped triangles,
//! [`super::raster::fill_chain`], plus [`super::raster::rasterize_centres`] of the thin or
//! reversed ones; the conservative raster of its outline triangles when
//! no centre lies inside it by more than the grow, see `raster::fill_chain_with_core`) and `F`
//! dilated
//! by the padding (`D`), both summarised as per-column and per-row extents (the horizons of
//! lscm-2002 §4 step 3, "with an additional margin").
//!
//! - Density (lscm-2002 §4 step 1, isocharts-2004 §6 step 1): every chart is scaled by
//!   `sqrt(area_m2 / uv_area) × texels_per_unit`, so placed UV area = `area_m2 ×
//!   texels_per_unit²` texels² for every chart (rotations preserve it).
//! - Orientation (lscm-2002 §4 step 2): the chart's maximum diameter (the farthest pair of its
//!   convex hull, rotating calipers) is turned vertical; then `rotations` angles evenly spaced
//!   over a full turn are tried (isocharts-2004 §6: 16). A chart that fills at least
//!   [`RECTANGULAR_FILL`] of its minimum-area enclosing rectangle (rotating calipers over the
//!   hull edges, as xatlas and Blender orient charts) is turned so that this rectangle is
//!   axis-aligned, longer side vertical, instead: a quad lands with its sides along the page
//!   axes (the contact-scored hole search keeps the diameter's angles for every chart). When `rotations` is a multiple of 4,
//!   only the first quarter is rasterized: a quarter turn maps the texel grid onto itself, so
//!   the other footprints are the same extents re-indexed (exact, no re-rasterization).
//! - Layout: the chart is centred in its texel span (a margin of [`LAYOUT_EPS_TEXELS`] from
//!   the texel lines) inside a grid with a `padding`-texel margin on every side; the grid is
//!   then trimmed to the union of `D` and that span (so the packer's box holds the whole chart
//!   and `D`).
//! - Degenerate charts (zero UV area, zero 3-D area, no triangles) collapse to a point at a
//!   texel centre: a one-texel footprint, never a NaN.
//!
//! Preconditions: checked by [`prepare_chart`] (finite UVs and area, indices in range).
//!
//! Units: chart UVs in model units; `_texels` on the page; `texels_per_unit` per model unit.
//!
//! Cost: per orientation rasterized, O(boundary edges × rows per edge, plus loose triangles ×
//! rows, plus D texels / 64 × padding); orientations wider or taller than the page are not
//! rasterized (bounded memory whatever the trial density).
use super::hull::{convex_hull, diameter, min_area_box};
use super::outline::{boundary_chain, outline_triangles};
use super::raster::{
    fill_chain_with_core, rasterize_centres, rasterize_conservative, rasterize_touching, Mask,
};
use super::types::{PackChart, PackError};

/// Margin kept between a chart's extreme vertices and the texel lines of its span, texels.
pub const LAYOUT_EPS_TEXELS: f64 = 1e-3;

/// How far each triangle is grown before its texel centres are sampled, texels: far above the
/// `f32` rounding of written UVs (2⁻²⁴ × page side ≤ 10⁻³ texels for pages ≤ 16384).
pub const CENTRE_GROW_TEXELS: f64 = 0.01;

/// A chart whose UV area is at least this fraction of its minimum-area enclosing rectangle is
/// *rectangular* ([`PreparedChart::rectangular`]): it is turned axis-aligned and tries only the
/// quarter turns (the eighth turns when it is a strip long for the page,
/// [`super::DIAGONAL_MIN_ASPECT`]). Trade-off: for such charts the other angles only grow the
/// padded box (a rectangle's least box is its own), while each costs a footprint and a search;
/// charts that fill their box less (L shapes, discs) keep every angle, since a turned bay can
/// take a neighbour.
pub const RECTANGULAR_FILL: f64 = 0.95;

/// Empty line of an extents array.
pub const EMPTY: (i32, i32) = (i32::MAX, i32::MIN);

/// What does not depend on the density: validated once per chart.
#[derive(Debug, Clone)]
pub struct PreparedChart {
    /// Centre of the UV bounding box of the referenced vertices (model units).
    pub centre: [f64; 2],
    /// Texels per model UV unit at density 1 (`sqrt(area_m2 / uv_area)`); 0 for a degenerate
    /// chart.
    pub unit_scale: f64,
    /// The chart's base orientation, radians: the rotation that turns its minimum-area
    /// enclosing rectangle axis-aligned (longer side vertical) for a [`Self::rectangular`]
    /// chart, else the one that turns its maximum diameter vertical.
    pub base_angle_rad: f64,
    /// The rotation that turns the maximum diameter vertical, radians (`base_angle_rad` of a
    /// chart that is not rectangular); the base of every chart in the contact-scored hole
    /// search ([`orientations`] with `padded_bits`).
    pub diameter_angle_rad: f64,
    /// Whether the chart fills at least [`RECTANGULAR_FILL`] of its minimum-area enclosing
    /// rectangle: then only the quarter turns of its axis-aligned base orientation are tried,
    /// or its eighth turns when it is long for the page (the packer's callers,
    /// [`super::chart_rotations`]).
    pub rectangular: bool,
    /// [`box_sides_m`] of a [`Self::rectangular`] chart (`[0.0, 0.0]` for the other charts),
    /// from the rectangle found here: whether it is long for the page
    /// ([`super::chart_rotations`]).
    pub box_sides_m: [f64; 2],
    /// The 3-D area (sort key and area accounting), model units².
    pub area_m2: f64,
    /// False for a chart without vertices (nothing to place).
    pub has_vertices: bool,
    /// Indices of the *outline* triangles ([`outline_triangles`]): the only ones rasterized,
    /// since they cover the boundary of the chart and so decide every per-line extent.
    pub outline: Vec<u32>,
    /// The boundary chain of the well-shaped triangles of the majority orientation (directed
    /// vertex pairs, interior edges cancelled against their opposite): their union is its
    /// nonzero-winding fill ([`super::raster::fill_chain`]).
    pub chain: Vec<[u32; 2]>,
    /// The other triangles (thin, or of the minority orientation), rasterized one by one.
    pub loose: Vec<u32>,
}

/// The space a chart wastes in its minimum-area enclosing rectangle, model units²: the
/// rectangle's area minus the chart's UV area, both at the chart's packing scale (UV area =
/// 3-D area, as [`PreparedChart::unit_scale`] scales it). 0 for a chart with no UV area or a
/// non-finite UV. Which charts a cut would help most: long arms and concave bays waste most.
pub fn box_waste_m2(chart: &PackChart<'_>) -> f64 {
    // `box_sides_m` alone, without the rest of `prepare_chart` (outline triangles, boundary
    // chain): the packing-aware cuts ask this of every chart after every kept cut.
    let [long_m, short_m] = box_sides_m(chart);
    let waste = long_m * short_m - chart.area_m2;
    if waste.is_finite() {
        waste.max(0.0)
    } else {
        0.0
    }
}

/// A cut of a chart across its narrowest part: `Some(side)` with `side[t]` true for the
/// triangles on the far side, or `None` for a chart without UV area or with one side empty.
/// The line runs across the long side of the chart's minimum-area rectangle, where the UV area
/// of the triangles whose centroids lie within a slice along that side is least (the neck of a
/// dumbbell, the root of an arm), among [`NECK_SLICES`] slices in the middle
/// [`NECK_MIDDLE`] of the rectangle (ties to the slice nearest the middle); triangles go to the
/// side of their centroid. The sides need not be connected: the caller makes disks of them.
pub fn neck_cut(chart: &PackChart<'_>) -> Option<Vec<bool>> {
    let area = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| chart.uv[i as usize]);
        0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])).abs()
    };
    let LongAxis { s, lo, len } = long_axis(chart)?;
    let mut slices = vec![0.0; NECK_SLICES];
    for (t, &x) in chart.triangles.iter().zip(&s) {
        let k = (((x - lo) / len) * NECK_SLICES as f64).floor();
        slices[(k.max(0.0) as usize).min(NECK_SLICES - 1)] += area(t);
    }
    let margin = ((1.0 - NECK_MIDDLE) / 2.0 * NECK_SLICES as f64).round() as usize;
    let middle = NECK_SLICES as f64 / 2.0;
    let k = (margin..NECK_SLICES - margin).min_by(|&a, &b| {
        slices[a].total_cmp(&slices[b]).then(
            (a as f64 + 0.5 - middle)
                .abs()
                .total_cmp(&(b as f64 + 0.5 - middle).abs()),
        )
    })?;
    let cut = lo + len * (k as f64 + 0.5) / NECK_SLICES as f64;
    let side: Vec<bool> = s.iter().map(|&x| x > cut).collect();
    (side.iter().any(|&v| v) && side.iter().any(|&v| !v)).then_some(side)
}

/// Slices of [`neck_cut`] along the chart's long side.
pub const NECK_SLICES: usize = 32;
/// The share of the long side, centred, in which [`neck_cut`] looks for the neck: cuts nearer
/// an end only trim a tip.
pub const NECK_MIDDLE: f64 = 0.7;

/// Where each triangle of a chart lies along the long side of the chart's minimum-area
/// rectangle: its centroid's coordinate `s[t]` along that side, the least coordinate `lo` of
/// any corner, and the side's length `len` (UV units, finite and positive).
struct LongAxis {
    s: Vec<f64>,
    lo: f64,
    len: f64,
}

/// [`LongAxis`] of `chart`, or `None` for a non-finite UV or a chart without UV extent.
fn long_axis(chart: &PackChart<'_>) -> Option<LongAxis> {
    let points: Vec<[f64; 2]> = chart
        .triangles
        .iter()
        .flat_map(|t| t.iter().map(|&i| chart.uv[i as usize]))
        .collect();
    if points
        .iter()
        .any(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        return None;
    }
    let b = min_area_box(&convex_hull(&points))?;
    let axis = if b.along >= b.across {
        b.dir
    } else {
        [-b.dir[1], b.dir[0]]
    };
    let s: Vec<f64> = chart
        .triangles
        .iter()
        .map(|t| {
            let c = t.iter().fold([0.0, 0.0], |acc, &i| {
                let p = chart.uv[i as usize];
                [acc[0] + p[0] / 3.0, acc[1] + p[1] / 3.0]
            });
            c[0] * axis[0] + c[1] * axis[1]
        })
        .collect();
    let lo = points
        .iter()
        .map(|p| p[0] * axis[0] + p[1] * axis[1])
        .fold(f64::INFINITY, f64::min);
    let len = b.along.max(b.across);
    (len > 0.0 && len.is_finite()).then_some(LongAxis { s, lo, len })
}

/// The long and the short side of a chart's minimum-area enclosing rectangle at its packing
/// scale (UV area = 3-D area, as [`PreparedChart::unit_scale`] scales it), model units: at
/// `texels_per_unit`, the chart is `long × texels_per_unit` texels long. `[0, 0]` for a chart
/// without UV area, with a non-finite UV or with a triangle index out of range.
pub fn box_sides_m(chart: &PackChart<'_>) -> [f64; 2] {
    // The referenced vertices only (each once), without the rest of `prepare_chart`: the
    // caller asks this of every chart of meshes up to hundreds of thousands of faces.
    let mut referenced = vec![false; chart.uv.len()];
    let mut uv_area = 0.0;
    for t in chart.triangles {
        let corner = |k: usize| chart.uv.get(t[k] as usize).copied();
        let (Some(a), Some(b), Some(c)) = (corner(0), corner(1), corner(2)) else {
            return [0.0; 2];
        };
        for &i in t {
            referenced[i as usize] = true;
        }
        uv_area += 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])).abs();
    }
    let scale = (chart.area_m2 / uv_area).sqrt();
    if !(scale.is_finite() && scale > 0.0) {
        return [0.0; 2];
    }
    let points: Vec<[f64; 2]> = chart
        .uv
        .iter()
        .zip(&referenced)
        .filter(|&(_, &r)| r)
        .map(|(p, _)| *p)
        .collect();
    match min_area_box(&convex_hull(&points)) {
        Some(b) => [b.along.max(b.across) * scale, b.along.min(b.across) * scale],
        None => [0.0; 2],
    }
}

/// A cut of a chart into `pieces` slices of equal length along the long side of its
/// minimum-area rectangle: `Some(piece)` with `piece[t]` the slice of triangle `t`'s centroid,
/// numbered from 0 along the side without gaps (a slice that holds no centroid, between long
/// triangles, gets no number). `None` when `pieces < 2`, the chart has no UV extent or a
/// non-finite UV, or every centroid falls in one slice. The pieces need not be connected: the
/// caller makes disks of them.
pub fn length_pieces(chart: &PackChart<'_>, pieces: usize) -> Option<Vec<usize>> {
    if pieces < 2 {
        return None;
    }
    let LongAxis { s, lo, len } = long_axis(chart)?;
    let slice: Vec<usize> = s
        .iter()
        .map(|&x| ((((x - lo) / len) * pieces as f64).floor().max(0.0) as usize).min(pieces - 1))
        .collect();
    let mut used = vec![false; pieces];
    for &k in &slice {
        used[k] = true;
    }
    let mut number = vec![0usize; pieces];
    let mut next = 0;
    for k in 0..pieces {
        number[k] = next;
        next += usize::from(used[k]);
    }
    (next >= 2).then(|| slice.iter().map(|&k| number[k]).collect())
}

/// Validates a chart and computes its density-independent data.
///
/// Errors: [`PackError::InvalidChart`] for a non-finite UV, a negative or non-finite area, or a
/// triangle index out of range.
pub fn prepare_chart(index: usize, chart: &PackChart<'_>) -> Result<PreparedChart, PackError> {
    let invalid = |detail: String| PackError::InvalidChart {
        chart: index,
        detail,
    };
    if !(chart.area_m2.is_finite() && chart.area_m2 >= 0.0) {
        return Err(invalid(format!(
            "area_m2 is {}; pass the chart's finite, non-negative 3-D area",
            chart.area_m2
        )));
    }
    if let Some(v) = chart
        .uv
        .iter()
        .position(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        return Err(invalid(format!(
            "vertex {v} has a non-finite UV; repair the parameterization"
        )));
    }
    let n = chart.uv.len();
    let mut referenced = vec![false; n];
    for (t, tri) in chart.triangles.iter().enumerate() {
        for &i in tri {
            if i as usize >= n {
                return Err(invalid(format!(
                    "triangle {t} refers to vertex {i} but the chart has {n} UVs; fix the chart extraction"
                )));
            }
            referenced[i as usize] = true;
        }
    }
    let points: Vec<[f64; 2]> = chart
        .uv
        .iter()
        .zip(&referenced)
        .filter(|(_, &r)| r)
        .map(|(p, _)| *p)
        .collect();
    let (lo, hi) = bounds(points.iter().copied());
    let centre = if points.is_empty() {
        [0.0, 0.0]
    } else {
        [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])]
    };
    let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]);
    // UV area in coordinates normalized by the extent, so that finite inputs never overflow.
    let mut unit_scale = 0.0;
    let mut base_angle_rad = 0.0;
    let mut rectangular = false;
    let mut box_sides_m = [0.0; 2];
    let mut diameter_angle_rad = 0.0;
    if extent > 0.0 && extent.is_finite() {
        let norm = |p: [f64; 2]| [(p[0] - centre[0]) / extent, (p[1] - centre[1]) / extent];
        let uv_area_normalized: f64 = chart
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| norm(chart.uv[i as usize]));
                0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])).abs()
            })
            .sum();
        if uv_area_normalized > 0.0 && chart.area_m2 > 0.0 {
            let s = (chart.area_m2 / uv_area_normalized).sqrt() / extent;
            if s.is_finite() && s > 0.0 {
                unit_scale = s;
                let normalized: Vec<[f64; 2]> = points.iter().map(|&p| norm(p)).collect();
                let hull = convex_hull(&normalized);
                let (a, b) = diameter(&hull);
                let v = [hull[b][0] - hull[a][0], hull[b][1] - hull[a][1]];
                base_angle_rad = std::f64::consts::FRAC_PI_2 - v[1].atan2(v[0]);
                diameter_angle_rad = base_angle_rad;
                if let Some(mbox) = min_area_box(&hull) {
                    let box_area = mbox.along * mbox.across;
                    if box_area > 0.0 && uv_area_normalized >= RECTANGULAR_FILL * box_area {
                        rectangular = true;
                        // Normalized units to model units at the packing scale: `extent · s`.
                        let model = |side: f64| side * extent * s;
                        box_sides_m = [
                            model(mbox.along.max(mbox.across)),
                            model(mbox.along.min(mbox.across)),
                        ];
                        // The edge direction horizontal, then a quarter turn when the box is
                        // longer along it (longer side vertical, as the diameter otherwise).
                        let theta = mbox.dir[1].atan2(mbox.dir[0]);
                        base_angle_rad = if mbox.along > mbox.across {
                            std::f64::consts::FRAC_PI_2 - theta
                        } else {
                            -theta
                        };
                    }
                }
            }
        }
    }
    let chain = boundary_chain(chart.uv, chart.triangles);
    Ok(PreparedChart {
        centre,
        unit_scale,
        base_angle_rad,
        diameter_angle_rad,
        rectangular,
        box_sides_m,
        area_m2: if unit_scale > 0.0 { chart.area_m2 } else { 0.0 },
        has_vertices: !chart.uv.is_empty(),
        outline: outline_triangles(chart.uv, chart.triangles),
        chain: chain.0,
        loose: chain.1,
    })
}

/// Per-line extents of a footprint: for each column the first and last row, for each row the
/// first and last column ([`EMPTY`] when the line is empty). Local texel indices.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Extents {
    /// Per column `(min_row, max_row)`.
    pub cols: Vec<(i32, i32)>,
    /// Per row `(min_col, max_col)`.
    pub rows: Vec<(i32, i32)>,
}

impl Extents {
    fn of(mask: &Mask) -> Self {
        let conv = |e: Option<(u32, u32)>| e.map_or(EMPTY, |(a, b)| (a as i32, b as i32));
        Self {
            cols: mask.column_extents().into_iter().map(conv).collect(),
            rows: mask.row_extents().into_iter().map(conv).collect(),
        }
    }

    /// The extents of the mask grown by `r` texels in the Chebyshev metric and clipped to its
    /// grid, from these extents alone: exactly `Extents::of(&mask.dilate(r))` when `self` is
    /// `Extents::of(&mask)`. A row of the grown mask is the union of the rows within `r` of it,
    /// each grown by `r` sideways, so its first column is the least first column of those rows
    /// less `r` (at least 0) and its last the greatest last column plus `r` (at most the
    /// width − 1); columns alike. Cost: O((width + height) × r), instead of growing the mask
    /// (O(width × height / 64 × r)) and scanning it.
    fn dilated(&self, r: u32) -> Self {
        let grow = |lines: &[(i32, i32)], across: usize| -> Vec<(i32, i32)> {
            let n = lines.len();
            let r = r as usize;
            (0..n)
                .map(|y| {
                    let window = &lines[y.saturating_sub(r)..(y + r + 1).min(n)];
                    let lo = window.iter().map(|e| e.0).min().unwrap_or(EMPTY.0);
                    let hi = window.iter().map(|e| e.1).max().unwrap_or(EMPTY.1);
                    if lo > hi {
                        EMPTY
                    } else {
                        (
                            (lo - r as i32).max(0),
                            (hi + r as i32).min(across as i32 - 1),
                        )
                    }
                })
                .collect()
        };
        Self {
            cols: grow(&self.cols, self.rows.len()),
            rows: grow(&self.rows, self.cols.len()),
        }
    }

    /// The extents after the quarter turn `(x, y) → (height - y, x)` of a `width × height`
    /// grid: texel `(i, j)` goes to `(height - 1 - j, i)`.
    fn rotate90(&self) -> Self {
        let h = self.rows.len() as i32;
        let flip = |(a, b): (i32, i32)| {
            if (a, b) == EMPTY {
                EMPTY
            } else {
                (h - 1 - b, h - 1 - a)
            }
        };
        Self {
            // New column i' is old row h-1-i', same range of (new) rows = old columns.
            cols: self.rows.iter().rev().copied().collect(),
            // New row j' is old column j', its columns are h-1-(old rows).
            rows: self.cols.iter().map(|&e| flip(e)).collect(),
        }
    }
}

/// One candidate orientation of a chart at a given density.
#[derive(Debug, Clone)]
pub struct Orientation {
    /// `q = A · (uv - centre) + b`: local texel coordinates, rows `[a00, a01, b0]`, `[a10, a11, b1]`.
    pub affine: [[f64; 3]; 2],
    /// Grid width = width of `D`, texels.
    pub width_texels: i64,
    /// Grid height = height of `D`, texels.
    pub height_texels: i64,
    /// Extents of `D` (footprint dilated by the padding); `None` when the grid exceeds the page
    /// (not rasterized).
    pub dilated: Option<Extents>,
    /// Extents of `F` (the footprint itself), same grid.
    pub footprint: Option<Extents>,
    /// The texels of `F` themselves, same grid (for the occupancy of [`super::hole`]); `None`
    /// when not rasterized.
    pub footprint_bits: Option<FootprintBits>,
    /// The texels of `D` themselves, same grid and window as `footprint_bits` (the exact
    /// padded footprint that [`super::hole`] tests, row run by row run); `None` when not
    /// rasterized.
    pub dilated_bits: Option<FootprintBits>,
}

/// The texels of a footprint `F` on its orientation's grid: a rasterized mask, a window of it
/// (the trimmed grid), and a number of quarter turns, so that the quarter turns of one
/// rasterized angle share one mask (turned only when a chart is committed).
#[derive(Debug, Clone)]
pub struct FootprintBits {
    mask: std::sync::Arc<Mask>,
    /// Top-left of the window in the mask, texels.
    origin: [u32; 2],
    /// Window size before turning (width, height), texels.
    size: [u32; 2],
    /// Quarter turns `(x, y) → (height - 1 - y, x)` applied to the window, `0..4`.
    turns: u8,
}

impl FootprintBits {
    /// Calls `f(row, first, last)` for every run of set texels of the turned window (inclusive
    /// columns, grid coordinates), row by row. Cost: O(window area / 64 + runs) unturned or
    /// half-turned; the odd quarter turns first transpose the bits by 64 × 64 blocks
    /// ([`Mask::transposed_window`], O(window area / 64 × 6)).
    pub fn for_each_run(&self, mut f: impl FnMut(u32, u32, u32)) {
        let [ox, oy] = self.origin;
        let [w, h] = self.size;
        let mut runs = Vec::new();
        match self.turns {
            0 | 2 => {
                for j in 0..h {
                    self.mask.runs_in(oy + j, ox, ox + w, &mut runs);
                    for &(a, b) in &runs {
                        let (a, b) = (a - ox, b - ox);
                        if self.turns == 0 {
                            f(j, a, b);
                        } else {
                            f(h - 1 - j, w - 1 - b, w - 1 - a);
                        }
                    }
                }
            }
            _ => {
                // Odd turns: the turned grid is h wide and w tall; its row i is the window's
                // column i (turn 1: column x = h - 1 - j; turn 3: row w - 1 - i, column j).
                // `t` is the window transposed (row i = column i, column j = row j).
                let t = self.mask.transposed_window(ox, oy, w, h);
                if self.turns == 1 {
                    for i in 0..w {
                        t.runs_in(i, 0, h, &mut runs);
                        for &(a, b) in runs.iter().rev() {
                            f(i, h - 1 - b, h - 1 - a);
                        }
                    }
                } else {
                    for i in 0..w {
                        t.runs_in(w - 1 - i, 0, h, &mut runs);
                        for &(a, b) in &runs {
                            f(i, a, b);
                        }
                    }
                }
            }
        }
    }

    /// Whether these bits are `other`'s turned by a half turn more (the same mask and window):
    /// then [`Self::runs_from_half_turn`] gives their runs from `other`'s.
    pub fn is_half_turn_of(&self, other: &FootprintBits) -> bool {
        std::sync::Arc::ptr_eq(&self.mask, &other.mask)
            && self.origin == other.origin
            && self.size == other.size
            && self.turns == other.turns + 2
    }

    /// The runs [`Self::for_each_run`] gives, in its order, from `runs`, those it gives for the
    /// bits half a turn back ([`Self::is_half_turn_of`]): a half turn maps `(x, y)` to
    /// `(width - 1 - x, height - 1 - y)` on the turned grid. No transpose and no bit scan.
    pub fn runs_from_half_turn(&self, runs: &[(i32, i32, i32)]) -> Vec<(i32, i32, i32)> {
        let [w, h] = self.size.map(|v| v as i32);
        // The turned grid: `w × h` for an even number of quarter turns, `h × w` for an odd one.
        let (gw, gh) = if self.turns % 2 == 0 { (w, h) } else { (h, w) };
        let turn = |&(r, a, b): &(i32, i32, i32)| (gh - 1 - r, gw - 1 - b, gw - 1 - a);
        if self.turns % 2 == 0 {
            // Half-turned: rows from the bottom, as the window's rows are read top down.
            runs.iter().map(turn).collect()
        } else {
            // Three quarter turns: rows from the top, each left to right.
            runs.iter().rev().map(turn).collect()
        }
    }

    fn rotate90(&self) -> Self {
        Self {
            turns: (self.turns + 1) % 4,
            ..self.clone()
        }
    }
}

impl Orientation {
    /// Local texel coordinates of a chart UV.
    pub fn apply(&self, centre: [f64; 2], uv: [f64; 2]) -> [f64; 2] {
        let (x, y) = (uv[0] - centre[0], uv[1] - centre[1]);
        let a = &self.affine;
        [
            a[0][0] * x + a[0][1] * y + a[0][2],
            a[1][0] * x + a[1][1] * y + a[1][2],
        ]
    }

    fn rotate90(&self) -> Self {
        let a = &self.affine;
        let h = self.height_texels as f64;
        // (x, y) → (h - y, x).
        Self {
            affine: [
                [-a[1][0], -a[1][1], h - a[1][2]],
                [a[0][0], a[0][1], a[0][2]],
            ],
            width_texels: self.height_texels,
            height_texels: self.width_texels,
            dilated: self.dilated.as_ref().map(Extents::rotate90),
            footprint: self.footprint.as_ref().map(Extents::rotate90),
            footprint_bits: self.footprint_bits.as_ref().map(FootprintBits::rotate90),
            dilated_bits: self.dilated_bits.as_ref().map(FootprintBits::rotate90),
        }
    }
}

/// The `rotations` orientations of a chart at `texels_per_unit`, for a page of `page_texels`
/// with `padding_texels`. Angle `k` is `base + 2πk / rotations`, with `base` the chart's
/// [`PreparedChart::base_angle_rad`], or its [`PreparedChart::diameter_angle_rad`] with
/// `padded_bits` (the contact-scored hole search, whose many-chart packings were tuned on the
/// diameter's angles). With
/// `padded_bits`, each rasterized orientation also keeps the texels of `D`
/// ([`Orientation::dilated_bits`], one more dilation of the mask); only the hole search of
/// [`super::hole`] reads them, and only when it scores candidates
/// ([`super::HOLE_SCORED_MIN_CHARTS`]; its plain first fit tests the per-row extents), so the
/// other packings pass `false` and get `None` there.
pub fn orientations(
    chart: &PackChart<'_>,
    prep: &PreparedChart,
    texels_per_unit: f64,
    rotations: u32,
    padding_texels: u32,
    page_texels: [u32; 2],
    padded_bits: bool,
) -> Vec<Orientation> {
    let rotations = rotations.max(1) as usize;
    let quarter = rotations % 4 == 0 && prep.unit_scale > 0.0;
    let direct = if quarter { rotations / 4 } else { rotations };
    let base = if padded_bits {
        prep.diameter_angle_rad
    } else {
        prep.base_angle_rad
    };
    let mut out: Vec<Orientation> = (0..direct)
        .map(|k| {
            let angle = base + 2.0 * std::f64::consts::PI * k as f64 / rotations as f64;
            orient(
                chart,
                prep,
                angle,
                texels_per_unit,
                padding_texels,
                page_texels,
                padded_bits,
            )
        })
        .collect();
    if quarter {
        for k in direct..rotations {
            let prev = &out[k - direct];
            let o = if prev.dilated.is_some() {
                prev.rotate90()
            } else {
                // Not rasterized (too large in that orientation): do the turned one directly.
                let angle = base + 2.0 * std::f64::consts::PI * k as f64 / rotations as f64;
                orient(
                    chart,
                    prep,
                    angle,
                    texels_per_unit,
                    padding_texels,
                    page_texels,
                    padded_bits,
                )
            };
            out.push(o);
        }
    }
    out
}

fn orient(
    chart: &PackChart<'_>,
    prep: &PreparedChart,
    angle_rad: f64,
    texels_per_unit: f64,
    padding_texels: u32,
    page_texels: [u32; 2],
    padded_bits: bool,
) -> Orientation {
    let sigma = prep.unit_scale * texels_per_unit;
    let sigma = if sigma.is_finite() { sigma } else { 0.0 };
    let (s, c) = angle_rad.sin_cos();
    let m = [[sigma * c, -sigma * s], [sigma * s, sigma * c]];
    let rotated = |p: [f64; 2]| {
        let (x, y) = (p[0] - prep.centre[0], p[1] - prep.centre[1]);
        [m[0][0] * x + m[0][1] * y, m[1][0] * x + m[1][1] * y]
    };
    // Every corner of the outline triangles, without collecting them (a chart of a scan has
    // thousands).
    let (lo, hi) = bounds(prep.outline.iter().flat_map(|&t| {
        chart.triangles[t as usize]
            .iter()
            .map(|&i| rotated(chart.uv[i as usize]))
    }));
    let (lo, hi) = if lo[0] <= hi[0] {
        (lo, hi)
    } else {
        ([0.0; 2], [0.0; 2])
    };
    // The mask keeps one texel more than the padding around the chart's texel span: the
    // touched texels of the footprint can reach one texel past that span, and `D`, the
    // footprint grown by the padding, must not be cut off by the mask's edge (the grid is
    // trimmed to `D` below).
    let margin = padding_texels as usize + 1;
    let mut affine = [[m[0][0], m[0][1], 0.0], [m[1][0], m[1][1], 0.0]];
    let mut dims = [0i64; 2];
    for axis in 0..2 {
        let e = hi[axis] - lo[axis];
        let n = (e + 2.0 * LAYOUT_EPS_TEXELS).ceil().max(1.0);
        // Saturating: a chart far larger than any page is only measured, never rasterized.
        dims[axis] = if n < 1e15 {
            n as i64 + 2 * i64::from(padding_texels)
        } else {
            i64::MAX / 4
        };
        affine[axis][2] = margin as f64 + 0.5 * (n - e) - lo[axis];
    }
    let mut o = Orientation {
        affine,
        width_texels: dims[0],
        height_texels: dims[1],
        dilated: None,
        footprint: None,
        footprint_bits: None,
        dilated_bits: None,
    };
    if dims[0] > i64::from(page_texels[0]) || dims[1] > i64::from(page_texels[1]) {
        return o;
    }
    let mut mask = Mask::new(dims[0] as u32 + 2, dims[1] as u32 + 2);
    // Every vertex once (not once per triangle corner).
    let local: Vec<[f64; 2]> = chart.uv.iter().map(|&p| o.apply(prep.centre, p)).collect();
    // The union of the well-shaped triangles from their boundary chain (cost of the boundary,
    // not of the triangles), the others one by one.
    let edges: Vec<[[f64; 2]; 2]> = prep
        .chain
        .iter()
        .map(|e| e.map(|i| local[i as usize]))
        .collect();
    // `core`: a centre inside the well-shaped triangles by more than the grow, which the
    // chart covers exactly, also after rounding (the footprint's exactness below).
    let (filled, core) = fill_chain_with_core(&mut mask, &edges, CENTRE_GROW_TEXELS);
    let loose = rasterize_centres(
        &mut mask,
        prep.loose
            .iter()
            .map(|&t| chart.triangles[t as usize].map(|i| local[i as usize])),
        CENTRE_GROW_TEXELS,
    );
    let sampled = filled || loose;
    if !sampled {
        // Samples no texel centre (a tiny chart): its conservative footprint, never empty.
        rasterize_conservative(
            &mut mask,
            prep.outline
                .iter()
                .map(|&t| chart.triangles[t as usize].map(|i| local[i as usize])),
        );
    }
    if sampled {
        // Exact non-overlap. The sampled footprint `L` misses the parts of a chart that cover
        // no texel centre (slivers, thin spikes); another chart could be laid over them. `T`,
        // the texels touched by the boundary chain and by the loose triangles, holds every
        // texel the chart touches whose centre is not in `L` (such a texel meets the chart and
        // its complement, hence the chart's boundary). The footprint becomes
        // `M = L ∪ (T \ dilate(L, ⌊p/2⌋))`: two footprints more than `p` apart (what the packer
        // enforces) then have disjoint touched texels, so their triangles' interiors cannot
        // meet — a touched texel of A within ⌊p/2⌋ of `L_A` and one of B within ⌊p/2⌋ of `L_B`
        // would put `L_A` and `L_B` within `p`. For ordinary charts `T ⊆ dilate(L, 1)` and
        // nothing changes when `p ≥ 2`.
        //
        // Unless no texel centre is known to be covered by more than the grow (`core` false,
        // see `fill_chain_with_core`): the chart may only come within the grow of centres,
        // and cover none at all, exactly or after rounding. The contract gives such a chart its conservative footprint (every
        // texel touched), so `M = L ∪ T`; leaving out its touched texels next to `L` put it
        // one texel short of the padding (issue 21's property tests,
        // `tiny_charts_keep_the_full_padding`). A chart with a core centre covers it in the
        // output too, and is checked by its sampled texels, a subset of `L`.
        let mut touched = Mask::new(mask.width(), mask.height());
        rasterize_touching(
            &mut touched,
            edges.iter().map(|&[p, q]| [p, q, q]).chain(
                prep.loose
                    .iter()
                    .map(|&t| chart.triangles[t as usize].map(|i| local[i as usize])),
            ),
            CENTRE_GROW_TEXELS,
        );
        if core {
            mask.add_except_dilated(&touched, padding_texels / 2);
        } else {
            mask.add_except(&touched, &Mask::new(mask.width(), mask.height()));
        }
    }
    if chart.triangles.is_empty() {
        // A chart without triangles still gets its one texel.
        let m = margin as u32;
        mask.set_span(m, m, m);
    }
    let f = Extents::of(&mask);
    // The padded footprint's texels (for the contact-scored hole search); its extents from
    // the footprint's, the same as the mask's (`Extents::dilated`).
    let dmask = padded_bits.then(|| std::sync::Arc::new(mask.dilate(padding_texels)));
    let d = f.dilated(padding_texels);
    debug_assert!(dmask.as_ref().is_none_or(|m| d == Extents::of(m)));
    let mask = std::sync::Arc::new(mask);
    // Sampled footprints need not reach the grid's margin: trim the grid to `D` (the grid is
    // the chart's box for the packer).
    let span = |v: &[(i32, i32)]| {
        let first = v.iter().position(|&e| e != EMPTY)?;
        let last = v.iter().rposition(|&e| e != EMPTY)?;
        Some((first, last))
    };
    let (Some((x0, x1)), Some((y0, y1))) = (span(&d.cols), span(&d.rows)) else {
        o.dilated_bits = dmask.map(|dmask| FootprintBits {
            size: [mask.width(), mask.height()],
            mask: dmask,
            origin: [0, 0],
            turns: 0,
        });
        o.footprint_bits = Some(FootprintBits {
            size: [mask.width(), mask.height()],
            mask,
            origin: [0, 0],
            turns: 0,
        });
        o.footprint = Some(f);
        o.dilated = Some(d);
        return o;
    };
    // The grid keeps the whole chart too (its texel span, inside the padding margin), so that
    // keeping the grid on the page keeps every UV in [0,1].
    let (x0, x1) = (x0.min(margin), x1.max(mask.width() as usize - 1 - margin));
    let (y0, y1) = (y0.min(margin), y1.max(mask.height() as usize - 1 - margin));
    let cut = |e: &Extents| {
        let shift = |v: &[(i32, i32)], by: i32| -> Vec<(i32, i32)> {
            v.iter()
                .map(|&(a, b)| {
                    if (a, b) == EMPTY {
                        EMPTY
                    } else {
                        (a - by, b - by)
                    }
                })
                .collect()
        };
        Extents {
            cols: shift(&e.cols[x0..=x1], y0 as i32),
            rows: shift(&e.rows[y0..=y1], x0 as i32),
        }
    };
    o.affine[0][2] -= x0 as f64;
    o.affine[1][2] -= y0 as f64;
    o.width_texels = (x1 - x0 + 1) as i64;
    o.height_texels = (y1 - y0 + 1) as i64;
    o.footprint = Some(cut(&f));
    o.dilated = Some(cut(&d));
    o.dilated_bits = dmask.map(|dmask| FootprintBits {
        mask: dmask,
        origin: [x0 as u32, y0 as u32],
        size: [(x1 - x0 + 1) as u32, (y1 - y0 + 1) as u32],
        turns: 0,
    });
    o.footprint_bits = Some(FootprintBits {
        mask,
        origin: [x0 as u32, y0 as u32],
        size: [(x1 - x0 + 1) as u32, (y1 - y0 + 1) as u32],
        turns: 0,
    });
    o
}

fn bounds(points: impl IntoIterator<Item = [f64; 2]>) -> ([f64; 2], [f64; 2]) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in points {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

#[cfg(test)]
mod tests;
