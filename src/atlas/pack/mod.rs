//! Packing: place flattened charts on texture pages.
//!
//! Purpose: the third stage of the atlas pipeline. [`pack_charts`] scales every chart to one
//! texel density, turns it (a nearly rectangular chart, [`place::RECTANGULAR_FILL`], to its
//! minimum-area enclosing rectangle, axis-aligned, trying only its quarter turns, or its eighth
//! turns when it is a strip long for the page; any other chart to its diameter, trying the
//! angles of [`chart_rotations`]), and places it with two packers, keeping the denser
//! packing. The horizon ("Tetris") packer of lscm-2002 §4, extended as isocharts-2004 §6
//! (insertion from four directions, 16 rotations), and *hole filling* ([`hole`], an extension
//! of the papers). A fit-to-page packing searches its
//! density with the packer of [`PackOptions::first_packer`] first (hole filling first only
//! below [`HOLE_SCORED_MIN_CHARTS`] charts), then with the other only above the density found
//! ([`FirstPacker::Horizons`] runs hole filling only where the
//! horizons leave much of the page empty: efficiency below [`HOLE_FILL_BELOW`] with many
//! charts, [`HOLE_FILL_BELOW_FEW_CHARTS`] with few; with many charts, when the horizons' first
//! trial does not fit, hole filling searches from there at once and the horizons' search goes
//! on only when hole filling does not fit there either); a fixed density packs with the horizons,
//! and again with hole filling when it needs more than one page. Then it writes normalized
//! page UVs. Hole filling places the charts in the order of `padded_box_order` (largest
//! padded UV box first):
//! each chart goes to a position of the page where its padded footprint meets no placed
//! footprint (exact occupancy of every placed chart, an exhaustive bit-parallel search), near
//! the top and touching placed charts most (the contact score of [`hole`], with the angles of
//! [`hole_rotations`]; the plain first fit below [`HOLE_SCORED_MIN_CHARTS`] charts).
//!
//! Stage contract. Charts never overlap, keep `padding_texels` empty texels between each other
//! and from the page edge, and stay inside \[0,1\]². Exactly: the footprints of two charts on
//! a page (every texel whose centre lies in a triangle grown by [`place::CENTRE_GROW_TEXELS`],
//! a superset of the texel-centre sampled coverage that [`crate::atlas::measure`] checks, also
//! after `f32` rounding) are at Chebyshev distance `> padding_texels`, and every footprint
//! texel is at least `padding_texels` from the page edge (the report's
//! `padding.violation_texels` is 0). A chart with no texel centre inside it by more than the
//! grow (a *core* centre) uses its conservative footprint (every texel touched): a chart that
//! only grazes centres within the grow would otherwise leave out touched texels next to its
//! one-texel footprint and sit one texel short of the padding; the touched texels of thin parts (slivers,
//! spikes) away from the sampled footprint are added to it (see `place::orientation`), so that
//! no two charts' triangles overlap exactly either. The whole chart stays inside its grid,
//! which stays on the page (UVs in \[0,1\]). Every chart has the same density: placed UV area
//! = `area_m2 × texels_per_unit²` texels².
//!
//! Invariant: deterministic. Integer horizons, fixed orders, ties by index, no hash maps; the
//! parallel parts (footprints of a batch of charts, the sides of a horizon search, the
//! orientations of a hole search) are reduced in a fixed order, so the result does not
//! depend on the thread count.
//!
//! Units: chart UVs come in model units (as the parameterizer returns them); placed UVs are
//! normalized page coordinates in \[0,1\]² (u right, v down, glTF convention); sizes on the page
//! are in texels (`_texels`); densities in texels per model unit.
//!
//! Code map: `types.rs` (options, input chart, packing, errors), [`raster`] (centre-sampled and
//! conservative footprints, Chebyshev dilation), [`place`] (density, base orientation,
//! rotations, per-line footprint extents, footprint bits), `hull.rs` (convex hull, diameter,
//! minimum-area rectangle), [`outline`] (boundary chain and outline triangles of a chart), [`horizon`] (the
//! four-direction horizon packer, one page), [`hole`] (the occupancy of a page and the search
//! inside its box), [`placement`] (the position both searches return), this file (the
//! fit-to-page density search, output).
//!
//! References: B. Lévy, S. Petitjean, N. Ray, J. Maillot, "Least Squares Conformal Maps for
//! Automatic Texture Atlas Generation", SIGGRAPH 2002, §4; K. Zhou, J. Snyder, B. Guo,
//! H.-Y. Shum, "Iso-charts", SGP 2004, §6.
pub mod hole;
pub mod horizon;
mod one_page;
pub mod place;
pub mod raster;
mod rotations;
#[cfg(any(test, feature = "test-support"))]
pub mod test_charts;

#[cfg(test)]
mod invariant_tests;
#[cfg(test)]
mod tests;

use std::ops::ControlFlow;

use super::progress::StageProgress;

mod cache;
mod fit;
mod hull;
pub mod outline;
pub mod placement;
mod types;

pub use cache::PackCache;
use fit::{fit_to_page, fit_to_page_after, fit_to_page_unless_first_misses, FirstTry, FitStart};
pub use fit::{FIT_GUESS_GROWTH, FIT_START_FILL};
pub use one_page::{pack_one_page, pack_one_page_horizons};
pub use rotations::{
    chart_rotations, hole_rotations, DIAGONAL_MIN_ASPECT, DIAGONAL_MIN_PAGE_FRACTION,
    SMALL_CHART_TEXELS,
};
pub use types::{
    FirstPacker, PackChart, PackError, PackOptions, Packing, PlacedChart, TexelDensity,
};

/// Largest page side accepted, texels (`width_texels`, `height_texels`): bounds the memory of
/// the horizons (O(side)) and of a footprint (at most one page of bits).
pub const MAX_PAGE_TEXELS: u32 = 16384;

/// Largest `rotations` accepted (each rotation costs one footprint search per chart).
pub const MAX_ROTATIONS: u32 = 64;

/// Packing trials at most of [`TexelDensity::FitToPage`] (each is a full packing).
pub const MAX_FIT_TRIALS: usize = 16;

/// [`TexelDensity::FitToPage`] stops when the largest density known to fit is within this
/// ratio of the smallest known not to fit.
pub const FIT_TOLERANCE: f64 = 3e-3;

/// [`FIT_TOLERANCE`] of the search that packs again with hole filling. Trade-off: a hole-filling
/// trial costs up to a second on thousands of charts (2CylinderEngine), and near the largest
/// density that fits, whether a trial fits is not monotone, so the last bisections of a 0.3%
/// bracket mostly fail; at 1% the packing found may be up to 1% less dense (2% less
/// efficient). Measured: 2CylinderEngine's pack stage 6.8 → 5.5 s at the same packing, and
/// the same packing on six more files that fill holes except spot (0.6139 → 0.6121).
pub const HOLE_FIT_TOLERANCE: f64 = 1e-2;

/// Densities tried above the bracket of [`TexelDensity::FitToPage`]: whether the charts fit is
/// not monotone in the density (a slightly larger density can fit where a smaller did not),
/// so after the bracket closes, `lo · (1 + k · FIT_PROBE_STEP)` for `k = 1, 2, …` up to
/// `FIT_PROBES` are packed too, upwards until the first that does not fit; the last that fits
/// wins (never less than the bracket's own result). Not used when the charts are packed again
/// with hole filling, nor by the horizons on [`HOLE_SCORED_MIN_CHARTS`] charts or more when
/// even the last probe would leave them below [`HOLE_FILL_BELOW`]: hole filling then packs
/// them again above their density, and the probes would only raise its floor (2CylinderEngine
/// skips 3 probes, a generated asset of 356 charts 6, each a packing of every chart).
/// Trade-off: each probe is one more full packing, for about +0.01 of
/// packing efficiency on large meshes (the armadillo's probes fitted up to +4%: 0.633 with
/// 3 probes, 0.645 with 8); stopping at the first failure keeps the cost at one packing where
/// probes do not fit.
pub const FIT_PROBES: usize = 8;

/// Packings with hole filling of at least this many charts use the contact-scored search and
/// [`hole_rotations`] ([`hole`]); fewer charts take the plain first fit with `rotations`.
/// Trade-off: the scored search packs many charts tighter at about twice the cost (four times
/// on the bunny's 15 charts); on few charts neither wins everywhere (bunny 0.618 plain against
/// 0.625 scored, armadillo 0.635 against 0.627). The same count decides how sparse the
/// horizons' packing must be for hole filling to run ([`HOLE_FILL_BELOW`]).
pub const HOLE_SCORED_MIN_CHARTS: usize = 33;
/// A single-page trial with hole filling that meets a chart it cannot place goes on with the
/// next charts until more than this many did not fit, or their area is above
/// [`HOLE_SKIPS_AREA_FRACTION`] of all charts; then (and in a horizon trial at the first
/// failure) it stops and counts the charts not tried as not placed too; once a density has
/// fitted, the search's trials stop at their first miss (it then only bisects). The fit-to-page
/// search shrinks the density by what was not placed: charts after a failure often still fit in the
/// gaps, so counting them all overstates the shrink, and the bisection back up costs full
/// packings. Trade-off: a failing trial costs a little more (a search of the whole page per
/// chart skipped); 2CylinderEngine's pack stage 6.6 s → 3.4 s (17 → 14 trials, packing
/// 0.5971 → 0.5964, within the search's tolerance), no change elsewhere on the corpus.
pub const HOLE_SKIPS_MAX: usize = 16;

/// See [`HOLE_SKIPS_MAX`]: the area of the charts not placed, as a fraction of all charts',
/// above which a hole-filling trial stops (a large chart that does not fit says enough).
pub const HOLE_SKIPS_AREA_FRACTION: f64 = 0.02;
/// Density step of the probes of [`FIT_PROBES`], as a ratio.
pub const FIT_PROBE_STEP: f64 = 0.01;

/// Places every chart on pages without overlap, keeping `padding_texels` between charts and from
/// the page edge, all UVs in \[0,1\]. `monitor((done, total))` is called between charts; `Break`
/// cancels with [`PackError::Cancelled`].
///
/// Guarantees: the footprints ([`raster::fill_chain`], a superset of texel-centre
/// sampled coverage) of any two charts on a page are more than `padding_texels` apart
/// (Chebyshev) and at least `padding_texels` from the page edge; every chart has the same density (placed UV area =
/// `area_m2 × texels_per_unit²` texels²); UVs finite in \[0,1\]; deterministic.
///
/// Errors: [`PackError::InvalidOption`], [`PackError::InvalidChart`],
/// [`PackError::ChartTooLarge`] (fixed density only), [`PackError::DoesNotFit`] (fit-to-page
/// only), [`PackError::Cancelled`].
///
/// Cost: one packing per density trial (one with a fixed density, at most
/// [`MAX_FIT_TRIALS`] + [`FIT_PROBES`] + 1 per fit-to-page search, typically 6–11; the second
/// packer's search stops at its first trial when it cannot beat the first's density); a
/// packing rasterizes `⌈rotations / 4⌉` footprints per chart (or `rotations` when not a
/// multiple of 4) and runs the horizon search of [`horizon`] or the search of [`hole`] for
/// every orientation.
pub fn pack_charts(
    charts: &[PackChart<'_>],
    options: &PackOptions,
    progress: &mut StageProgress<'_>,
) -> Result<Packing, PackError> {
    pack_charts_from(charts, options, None, progress)
}

/// [`pack_charts`], with the fit-to-page density search starting at `start_texels_per_unit`
/// (a density the caller expects to fit, such as one a similar packing reached) instead of
/// where the charts would cover [`FIT_START_FILL`] of the page: fewer trials when the guess is
/// close. Same contract and guarantees; the density found may differ from [`pack_charts`]'s within the
/// search's tolerance. Ignored with [`TexelDensity::TexelsPerUnit`] or when not finite and
/// positive.
pub fn pack_charts_from(
    charts: &[PackChart<'_>],
    options: &PackOptions,
    start_texels_per_unit: Option<f64>,
    progress: &mut StageProgress<'_>,
) -> Result<Packing, PackError> {
    let from = SearchFrom::guess(start_texels_per_unit);
    pack_charts_with(charts, options, from, None, progress)
}

/// [`pack_charts_from`] through `cache` ([`PackCache`]): what the cache holds for these charts
/// is not computed again, and what is computed is kept there. The same packing.
pub fn pack_charts_cached(
    charts: &[PackChart<'_>],
    options: &PackOptions,
    start_texels_per_unit: Option<f64>,
    cache: &PackCache,
    progress: &mut StageProgress<'_>,
) -> Result<Packing, PackError> {
    let from = SearchFrom::guess(start_texels_per_unit);
    pack_charts_with(charts, options, from, Some(cache), progress)
}

/// A fit-to-page packing denser than `fits_texels_per_unit`, a density at which one page is
/// known to hold the charts (the caller packed them there, e.g. with [`pack_one_page`]), through
/// `cache`; `Ok(None)` when no packer finds one. The density search of each packer only looks
/// above that density: it starts just above it, never steps below it, and gives up at its first
/// trial that does not fit before one has (a search from a guess instead steps down and climbs
/// back to densities the caller already has). Same contract and guarantees as
/// [`pack_charts`] for the packing it returns. [`PackError::InvalidOption`] unless the density
/// is [`TexelDensity::FitToPage`] and `fits_texels_per_unit` is finite and positive.
pub fn pack_charts_above(
    charts: &[PackChart<'_>],
    options: &PackOptions,
    fits_texels_per_unit: f64,
    cache: &PackCache,
    progress: &mut StageProgress<'_>,
) -> Result<Option<Packing>, PackError> {
    if options.density != TexelDensity::FitToPage {
        return Err(PackError::InvalidOption {
            option: "density",
            detail: "a search above a known density needs fit-to-page packing".into(),
        });
    }
    if !(fits_texels_per_unit.is_finite() && fits_texels_per_unit > 0.0) {
        return Err(PackError::InvalidOption {
            option: "fits_texels_per_unit",
            detail: format!("{fits_texels_per_unit} is not a finite positive density"),
        });
    }
    let from = SearchFrom::Above(fits_texels_per_unit);
    match pack_charts_with(charts, options, from, Some(cache), progress) {
        Ok(p) => Ok(Some(p)),
        Err(PackError::DoesNotFit { .. }) => Ok(None),
        Err(e) => Err(e),
    }
}

/// Whether each of `charts`, packed at the fixed density `texels_per_unit`, fits an empty page
/// in none of the orientations the packer tries: the charts [`pack_charts`] would refuse there
/// with [`PackError::ChartTooLarge`]. Cost: each chart's footprints at that density, and one
/// placement test on an empty page per chart.
///
/// Errors: [`PackError::InvalidOption`], [`PackError::InvalidChart`].
pub fn too_large_for_a_page(
    charts: &[PackChart<'_>],
    options: &PackOptions,
    texels_per_unit: f64,
) -> Result<Vec<bool>, PackError> {
    let options = &PackOptions {
        density: TexelDensity::TexelsPerUnit(texels_per_unit),
        ..*options
    };
    options.check()?;
    let (prepared, _) = prepare_all(charts, None)?;
    let all: Vec<usize> = (0..charts.len()).collect();
    let ctx = Context::new(charts, &prepared, &all, options);
    Ok(ctx
        .footprints(&all, texels_per_unit)
        .iter()
        .map(|orientations| ctx.new_page().find(orientations).is_none())
        .collect())
}

/// Where the fit-to-page search of [`pack_charts_with`] starts.
#[derive(Debug, Clone, Copy)]
enum SearchFrom {
    /// Where the charts would cover [`FIT_START_FILL`] of the page.
    Fill,
    /// A density the caller expects to fit ([`pack_charts_from`]).
    Guess(f64),
    /// Only densities above this one, known to fit ([`pack_charts_above`]).
    Above(f64),
}

impl SearchFrom {
    /// From the caller's guess when it is a finite positive density, else from the fill.
    fn guess(start_texels_per_unit: Option<f64>) -> Self {
        match start_texels_per_unit {
            Some(d) if d.is_finite() && d > 0.0 => SearchFrom::Guess(d),
            _ => SearchFrom::Fill,
        }
    }
}

fn pack_charts_with(
    charts: &[PackChart<'_>],
    options: &PackOptions,
    from: SearchFrom,
    cache: Option<&PackCache>,
    progress: &mut StageProgress<'_>,
) -> Result<Packing, PackError> {
    options.check()?;
    let (start, above) = match from {
        SearchFrom::Fill => (FitStart::Fill, None),
        SearchFrom::Guess(d) => (FitStart::Guess(d), None),
        SearchFrom::Above(d) => (FitStart::Beat(d), Some(d)),
    };
    // With `above`, a packer that finds nothing above it is not an error: the other packer may
    // still find one (`None`).
    let found = |r: Result<Trial, PackError>| match r {
        Ok(t) => Ok(Some(t)),
        Err(PackError::DoesNotFit { .. }) if above.is_some() => Ok(None),
        Err(e) => Err(e),
    };
    let monitor = &mut |(done, total): (usize, usize)| progress.advance(done, total);
    let (prepared, ids) = prepare_all(charts, cache)?;
    let order = largest_first(&prepared);
    let mut ctx = Context::new(charts, &prepared, &order, options);
    ctx.cache = cache.zip(ids.as_deref());
    // The first packer's or hole filling's search; `missed`, a trial of the same search given
    // up at its first miss, is not packed again (`fit::fit_to_page_after`).
    let pack = |ctx: &Context<'_, '_>,
                start: FitStart,
                missed: Option<Trial>,
                monitor: &mut dyn FnMut((usize, usize)) -> ControlFlow<()>|
     -> Result<Trial, PackError> {
        match options.density {
            TexelDensity::TexelsPerUnit(d) => {
                let mut progress = Steps::new(monitor, order.len());
                let t = ctx.run(d, true, &mut progress)?;
                progress.finish()?;
                Ok(t)
            }
            TexelDensity::FitToPage => fit_to_page_after(ctx, start, missed, monitor),
        }
    };
    if options.first_packer == FirstPacker::HoleFilling
        && options.density == TexelDensity::FitToPage
        && order.len() < HOLE_SCORED_MIN_CHARTS
    {
        // Hole filling first (the plain first fit: fewer than HOLE_SCORED_MIN_CHARTS charts),
        // started at the fill density as a guess (its first step up is small): the search hole
        // filling ran when it followed the horizons and they left the page sparse, but for
        // their density as its floor. Then the horizons, kept only when they pack denser.
        let total_area_m2: f64 = order.iter().map(|&i| prepared[i].area_m2).sum();
        let hole_order = padded_box_order(charts, &prepared, &order, options, total_area_m2);
        ctx.holes = true;
        ctx.scored = false;
        ctx.order = &hole_order;
        let start = match start {
            FitStart::Fill => FitStart::FillAsGuess,
            given => given,
        };
        let holes = found(fit_to_page(&ctx, start, monitor))?;
        ctx.holes = false;
        ctx.scored = false;
        ctx.order = &order;
        // The stage's progress stays at its end; the monitor can still cancel.
        let mut at_end = |_: (usize, usize)| monitor((1, 1));
        // Hole filling's density, or the caller's when it found none above it (`found` gives
        // `None` only then).
        let floor = holes
            .as_ref()
            .map_or(above.unwrap_or(0.0), |h| h.texels_per_unit);
        let trial = match (fit_to_page(&ctx, FitStart::Beat(floor), &mut at_end), holes) {
            (Ok(t), Some(h)) if t.texels_per_unit <= h.texels_per_unit => h,
            (Ok(t), _) => t,
            (Err(PackError::Cancelled), _) => return Err(PackError::Cancelled),
            // Nothing above hole filling's density fits.
            (Err(_), Some(h)) => h,
            (Err(e), None) => return Err(e),
        };
        return Ok(ctx.output(&trial));
    }
    let total_area_m2: f64 = order.iter().map(|&i| prepared[i].area_m2).sum();
    // Many charts, fit to page: the horizons' search gives up when its first trial does not
    // fit; hole filling then searches from that same density, and when it fits there, its
    // packing is the one the whole horizons' search and hole filling after it would give
    // (`fit::fit_to_page_unless_first_misses`), without the rest of the horizons' search. (One
    // exception: when the horizons' density would have ended within `FIT_TOLERANCE` below that
    // first trial's, hole filling used to start just above theirs; it starts at the first
    // trial's now, a search as good within its tolerance.) When hole filling does not fit there
    // either, both searches run as below, each from its first trial (not packed again). When
    // the horizons' first trial is already their whole search (a search above `above` that
    // misses at its floor: `DoesNotFit`), hole filling runs only below, as its whole search, and
    // not first here (where it would pack the same first trial, then the horizons' search its
    // one trial again).
    let first_hole_order;
    // The first trials of the two searches when they were given up there: the whole searches
    // below start from them.
    let (mut horizons_missed, mut holes_missed) = (None, None);
    let first =
        if options.density == TexelDensity::FitToPage && order.len() >= HOLE_SCORED_MIN_CHARTS {
            match fit_to_page_unless_first_misses(&ctx, start, monitor) {
                Ok(FirstTry::Found(t)) => Some(Some(t)),
                Ok(FirstTry::Missed(missed)) => {
                    horizons_missed = Some(missed);
                    first_hole_order =
                        padded_box_order(charts, &prepared, &order, options, total_area_m2);
                    ctx.holes = true;
                    ctx.scored = true;
                    ctx.order = &first_hole_order;
                    // Where hole filling would start after the horizons (their density is below
                    // this first trial's, and never the floor of a search that fits at once).
                    let from = FitStart::Beat(above.unwrap_or(0.0));
                    match fit_to_page_unless_first_misses(&ctx, from, monitor) {
                        Ok(FirstTry::Found(t)) => return Ok(ctx.output(&t)),
                        Ok(FirstTry::Missed(missed)) => holes_missed = Some(missed),
                        Err(PackError::DoesNotFit { .. }) => {}
                        Err(e) => return Err(e),
                    }
                    ctx.holes = false;
                    ctx.scored = false;
                    ctx.order = &order;
                    None
                }
                Err(e) => Some(found(Err(e))?),
            }
        } else {
            None
        };
    let mut trial = match first {
        Some(t) => t,
        None => found(pack(&ctx, start, horizons_missed.take(), monitor))?,
    };
    // Hole filling ([`hole`]) where the horizons leave much of the page empty: fit-to-page
    // below `HOLE_FILL_BELOW` (`HOLE_FILL_BELOW_FEW_CHARTS` with few charts), or a fixed
    // density that needs more than one page. The better
    // packing is kept (higher density, or fewer pages; ties: the horizons').
    let [w, h] = ctx.page();
    let efficiency = |d: f64| total_area_m2 * d * d / (f64::from(w) * f64::from(h));
    // The density to beat: the first packer's, or the caller's when it found none above it
    // (then hole filling is the only packer left to try).
    let floor = trial.as_ref().map(|t| t.texels_per_unit).or(above);
    let sparse = match (options.density, &trial) {
        (TexelDensity::FitToPage, Some(t)) if order.len() >= HOLE_SCORED_MIN_CHARTS => {
            efficiency(t.texels_per_unit) < HOLE_FILL_BELOW
        }
        (TexelDensity::FitToPage, Some(t)) => {
            efficiency(t.texels_per_unit) < HOLE_FILL_BELOW_FEW_CHARTS
        }
        (TexelDensity::FitToPage, None) => true,
        (TexelDensity::TexelsPerUnit(_), t) => t.as_ref().is_some_and(|t| t.pages.len() > 1),
    };
    let hole_order;
    if sparse {
        ctx.holes = true;
        ctx.scored = order.len() >= HOLE_SCORED_MIN_CHARTS;
        hole_order = padded_box_order(charts, &prepared, &order, options, total_area_m2);
        ctx.order = &hole_order;
        // The stage's progress stays at its end; the monitor can still cancel.
        let mut at_end = |_: (usize, usize)| monitor((1, 1));
        // Hole filling is kept only when it packs denser than the horizons: its search starts
        // just above their density (the caller's, when they found none above it) and gives up
        // when that does not fit.
        let from = FitStart::Beat(floor.unwrap_or(0.0));
        match pack(&ctx, from, holes_missed.take(), &mut at_end) {
            Ok(t) => {
                let better = match (options.density, &trial) {
                    (_, None) => true,
                    (TexelDensity::FitToPage, Some(h)) => t.texels_per_unit > h.texels_per_unit,
                    (TexelDensity::TexelsPerUnit(_), Some(h)) => t.pages.len() < h.pages.len(),
                };
                if better {
                    trial = Some(t);
                }
            }
            Err(PackError::Cancelled) => return Err(PackError::Cancelled),
            // The horizons' packing stands (hole filling never places fewer charts, but a
            // fit-to-page search could in principle bracket differently).
            Err(_) => {}
        }
    }
    match trial {
        Some(t) => Ok(ctx.output(&t)),
        None => Err(PackError::DoesNotFit {
            charts: order.len(),
            page_texels: [w, h],
            padding_texels: options.padding_texels,
        }),
    }
}

/// Each chart's density-independent data ([`place::prepare_chart`]), computed in parallel,
/// then the first error in chart order, whatever the thread count; through `cache` when given
/// (with the charts' ids there).
type Prepared = (Vec<place::PreparedChart>, Option<Vec<usize>>);
fn prepare_all(charts: &[PackChart<'_>], cache: Option<&PackCache>) -> Result<Prepared, PackError> {
    use rayon::prelude::*;
    if let Some(cache) = cache {
        let (prepared, ids) = cache::prepare_cached(charts, cache)?;
        return Ok((prepared, Some(ids)));
    }
    let prepared = charts
        .par_iter()
        .enumerate()
        .map(|(i, c)| place::prepare_chart(i, c))
        .collect::<Vec<_>>()
        .into_iter()
        .collect::<Result<_, _>>()?;
    Ok((prepared, None))
}

/// The charts with vertices, largest area first (lscm-2002 §4 step 2, isocharts-2004 §6 step
/// 2); ties by index.
fn largest_first(prepared: &[place::PreparedChart]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..prepared.len())
        .filter(|&i| prepared[i].has_vertices)
        .collect();
    order.sort_by(|&a, &b| {
        prepared[b]
            .area_m2
            .total_cmp(&prepared[a].area_m2)
            .then(a.cmp(&b))
    });
    order
}

/// The order of the packing with hole filling: largest padded bounding box first (ties by
/// index), the box of each chart's referenced UVs in its own frame at the density where the
/// charts would cover [`HOLE_ORDER_FILL`] of the page, grown by the padding on every side.
/// The box, not the area, says how hard a chart is to fit (long thin or branched charts), and
/// first fit packs the hard ones best while the page is empty.
fn padded_box_order(
    charts: &[PackChart<'_>],
    prepared: &[place::PreparedChart],
    order: &[usize],
    options: &PackOptions,
    total_area_m2: f64,
) -> Vec<usize> {
    let page = f64::from(options.width_texels) * f64::from(options.height_texels);
    let density = match options.density {
        TexelDensity::TexelsPerUnit(d) => d,
        TexelDensity::FitToPage if total_area_m2 > 0.0 => {
            (HOLE_ORDER_FILL * page / total_area_m2).sqrt()
        }
        TexelDensity::FitToPage => 1.0,
    };
    let pad = 2.0 * f64::from(options.padding_texels);
    let key: Vec<f64> = order
        .iter()
        .map(|&i| {
            let [ex, ey] = uv_box(&charts[i]);
            let s = prepared[i].unit_scale * density;
            let k = (ex * s + pad) * (ey * s + pad);
            if k.is_finite() {
                k
            } else {
                f64::MAX
            }
        })
        .collect();
    let mut by_key: Vec<usize> = (0..order.len()).collect();
    by_key.sort_by(|&a, &b| key[b].total_cmp(&key[a]).then(order[a].cmp(&order[b])));
    by_key.into_iter().map(|k| order[k]).collect()
}

/// Fill ratio of the density of `padded_box_order`.
pub const HOLE_ORDER_FILL: f64 = 0.55;

/// Fit-to-page packings with the horizons first (see [`FirstPacker`]) of at least
/// [`HOLE_SCORED_MIN_CHARTS`] charts that the horizons alone pack below this efficiency
/// (placed UV area / page area) are packed again with hole filling ([`hole`]), keeping the
/// better: issue 21's target for every mesh. Fewer charts are packed
/// again only below [`HOLE_FILL_BELOW_FEW_CHARTS`]. Trade-off: where hole filling cannot beat
/// the horizons its search stops after one trial (just above their density), where it can it
/// costs up to twice the pack stage. Measured against 0.60: beast_sub2_1M (248 charts) 0.656 →
/// 0.769 and MixedLightingExample (68) 0.702 → 0.721, each for 6–8 more trials (beast's whole
/// command +10%); PalmTree (68) keeps the horizons' packing for one more trial.
pub const HOLE_FILL_BELOW: f64 = 0.72;

/// [`HOLE_FILL_BELOW`] for packings of fewer than [`HOLE_SCORED_MIN_CHARTS`] charts. Trade-off:
/// few large charts leave few holes that another chart fits; at 0.72, of the 12 corpus files
/// with fewer charts that the horizons pack between 0.60 and 0.72, only the bunny gained
/// (0.602 → 0.618, for +7.5% on its whole command), and the 11 others paid one more trial.
pub const HOLE_FILL_BELOW_FEW_CHARTS: f64 = 0.60;

impl PackOptions {
    /// Rejects meaningless values with [`PackError::InvalidOption`], naming the option and what
    /// to use; the one check of packing options ([`pack_charts`] and
    /// [`crate::atlas::AtlasOptions::check`] both call it).
    pub fn check(&self) -> Result<(), PackError> {
        check_options(self)
    }
}

fn check_options(o: &PackOptions) -> Result<(), PackError> {
    for (name, v) in [
        ("width_texels", o.width_texels),
        ("height_texels", o.height_texels),
    ] {
        if !(1..=MAX_PAGE_TEXELS).contains(&v) {
            return Err(PackError::InvalidOption {
                option: name,
                detail: format!(
                    "{v} texels is outside 1..={MAX_PAGE_TEXELS}; use e.g. 1024, or pages of at most {MAX_PAGE_TEXELS} with TexelsPerUnit for more"
                ),
            });
        }
    }
    let side = o.width_texels.min(o.height_texels);
    if u64::from(o.padding_texels) * 2 + 1 > u64::from(side) {
        return Err(PackError::InvalidOption {
            option: "padding_texels",
            detail: format!(
                "{} leaves no room for a chart on a {}×{} page (2·padding + 1 must be at most {side}); use a smaller padding, e.g. 2",
                o.padding_texels, o.width_texels, o.height_texels
            ),
        });
    }
    if !(1..=MAX_ROTATIONS).contains(&o.rotations) {
        return Err(PackError::InvalidOption {
            option: "rotations",
            detail: format!(
                "{} is outside 1..={MAX_ROTATIONS}; use 1 (diameter vertical only) up to 16 (isocharts-2004)",
                o.rotations
            ),
        });
    }
    if let TexelDensity::TexelsPerUnit(d) = o.density {
        if !(d.is_finite() && d > 0.0) {
            return Err(PackError::InvalidOption {
                option: "density",
                detail: format!(
                    "{d} texels per unit is not a finite density > 0; use e.g. 256, or fit to the page (TexelDensity::FitToPage; on the wire, leave texels_per_unit unset)"
                ),
            });
        }
    }
    Ok(())
}

/// Forwards progress to the caller's monitor, monotonically.
struct Steps<'m> {
    monitor: &'m mut dyn FnMut((usize, usize)) -> ControlFlow<()>,
    done: usize,
    total: usize,
}

impl<'m> Steps<'m> {
    fn new(monitor: &'m mut dyn FnMut((usize, usize)) -> ControlFlow<()>, total: usize) -> Self {
        Self {
            monitor,
            done: 0,
            total,
        }
    }

    fn step(&mut self) -> Result<(), PackError> {
        self.done = (self.done + 1).min(self.total);
        match (self.monitor)((self.done, self.total)) {
            ControlFlow::Continue(()) => Ok(()),
            ControlFlow::Break(()) => Err(PackError::Cancelled),
        }
    }

    fn finish(&mut self) -> Result<(), PackError> {
        self.done = self.total;
        match (self.monitor)((self.total, self.total)) {
            ControlFlow::Continue(()) => Ok(()),
            ControlFlow::Break(()) => Err(PackError::Cancelled),
        }
    }
}

/// Everything a trial needs.
struct Context<'c, 'a> {
    charts: &'c [PackChart<'a>],
    prepared: &'c [place::PreparedChart],
    order: &'c [usize],
    options: &'c PackOptions,
    /// Packings run so far.
    trials: std::sync::atomic::AtomicU32,
    /// Whether pages fill holes ([`horizon::HorizonPage::with_holes`]).
    holes: bool,
    /// With `holes`: whether the hole search scores candidates by contact and tries
    /// [`hole_rotations`] ([`HOLE_SCORED_MIN_CHARTS`]), or takes the plain first fit.
    scored: bool,
    /// Whether a single-page trial stops at its first chart that does not fit, even with
    /// `holes` (a yes-or-no test, [`pack_one_page`]).
    first_miss_stops: bool,
    /// The cache of the packing and the charts' ids there ([`PackCache`]).
    cache: Option<(&'c PackCache, &'c [usize])>,
}

/// Where one chart went in a trial.
#[derive(Debug, Clone)]
struct Placed {
    page: u32,
    affine: [[f64; 3]; 2],
    x: i32,
    y: i32,
}

/// The outcome of packing at one density.
struct Trial {
    texels_per_unit: f64,
    placed: Vec<Option<Placed>>,
    pages: Vec<horizon::HorizonPage>,
    /// Σ area_m2 of the charts not placed (single-page trials stop at the first that does not
    /// fit, hole filling after [`HOLE_SKIPS_MAX`]; the charts not tried count as not placed).
    unplaced_area_m2: f64,
    /// Charts a single-page trial met and could not place (0: every chart placed).
    unplaced: usize,
    /// The largest, over charts, of the smallest page-size ratio any orientation needs.
    worst_size_ratio: f64,
}

impl<'c, 'a> Context<'c, 'a> {
    /// A context for horizon packings (no hole filling), no trial run yet.
    fn new(
        charts: &'c [PackChart<'a>],
        prepared: &'c [place::PreparedChart],
        order: &'c [usize],
        options: &'c PackOptions,
    ) -> Self {
        Self {
            charts,
            prepared,
            order,
            options,
            trials: std::sync::atomic::AtomicU32::new(0),
            holes: false,
            scored: false,
            first_miss_stops: false,
            cache: None,
        }
    }

    fn page(&self) -> [u32; 2] {
        [self.options.width_texels, self.options.height_texels]
    }

    fn new_page(&self) -> horizon::HorizonPage {
        let [w, h] = self.page();
        if self.holes {
            horizon::HorizonPage::with_holes(w, h, self.scored)
        } else {
            horizon::HorizonPage::new(w, h)
        }
    }

    /// Packs every chart at `texels_per_unit`. With `multi_page`, charts that do not fit open
    /// pages (an error when one does not fit an empty page); otherwise there is one page and
    /// charts that do not fit are counted in `unplaced`.
    fn run(
        &self,
        texels_per_unit: f64,
        multi_page: bool,
        progress: &mut Steps<'_>,
    ) -> Result<Trial, PackError> {
        self.run_with(texels_per_unit, multi_page, self.first_miss_stops, progress)
    }

    /// [`Context::run`] on one page that stops at its first chart that does not fit, even
    /// with `holes`: for a caller that only needs to know whether every chart fits (then the
    /// trial is complete and the same), not how much did not.
    fn run_to_first_miss(
        &self,
        texels_per_unit: f64,
        progress: &mut Steps<'_>,
    ) -> Result<Trial, PackError> {
        self.run_with(texels_per_unit, false, true, progress)
    }

    fn run_with(
        &self,
        texels_per_unit: f64,
        multi_page: bool,
        first_miss_stops: bool,
        progress: &mut Steps<'_>,
    ) -> Result<Trial, PackError> {
        self.trials
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let [w, h] = self.page();
        let order_area_m2: f64 = self.order.iter().map(|&j| self.prepared[j].area_m2).sum();
        let mut trial = Trial {
            texels_per_unit,
            placed: vec![None; self.charts.len()],
            pages: vec![self.new_page()],
            unplaced_area_m2: 0.0,
            unplaced: 0,
            worst_size_ratio: 0.0,
        };
        // Footprints are made in parallel, a batch of charts at a time (a failing trial stops
        // early, so not all up front); each chart's are independent of the others: the same
        // result whatever the thread count.
        const BATCH: usize = 16;
        let mut batch: Vec<std::sync::Arc<Vec<place::Orientation>>> = Vec::new();
        for (n, &i) in self.order.iter().enumerate() {
            progress.step()?;
            if n % BATCH == 0 {
                let end = (n + BATCH).min(self.order.len());
                batch = self.footprints(&self.order[n..end], texels_per_unit);
                batch.reverse();
            }
            let orients = batch.pop().unwrap_or_default();
            let ratio = orients
                .iter()
                .map(|o| {
                    (o.width_texels as f64 / f64::from(w))
                        .max(o.height_texels as f64 / f64::from(h))
                })
                .fold(f64::INFINITY, f64::min);
            trial.worst_size_ratio = trial.worst_size_ratio.max(ratio);
            let mut found = None;
            for (p, page) in trial.pages.iter().enumerate() {
                if let Some(pl) = page.find(&orients) {
                    found = Some((p, pl));
                    break;
                }
            }
            if found.is_none() && multi_page {
                let page = self.new_page();
                match page.find(&orients) {
                    Some(pl) => {
                        trial.pages.push(page);
                        found = Some((trial.pages.len() - 1, pl));
                    }
                    None => {
                        let needed = orients
                            .iter()
                            .map(|o| [o.width_texels as u64, o.height_texels as u64])
                            .min_by_key(|d| (d[0].max(d[1]), d[0].saturating_mul(d[1])))
                            .unwrap_or([0, 0]);
                        return Err(PackError::ChartTooLarge {
                            chart: i,
                            needed_texels: needed,
                            page_texels: [w, h],
                        });
                    }
                }
            }
            match found {
                Some((p, pl)) => {
                    let orient = &orients[pl.orientation];
                    trial.pages[p].commit(orient, pl);
                    trial.placed[i] = Some(Placed {
                        page: p as u32,
                        affine: orient.affine,
                        x: pl.x,
                        y: pl.y,
                    });
                }
                None => {
                    // This density fails; what is left tells the search how much to shrink.
                    // Hole filling goes on with the next charts ([`HOLE_SKIPS_MAX`]).
                    trial.unplaced += 1;
                    trial.unplaced_area_m2 += self.prepared[i].area_m2;
                    if !self.holes
                        || first_miss_stops
                        || trial.unplaced > HOLE_SKIPS_MAX
                        || trial.unplaced_area_m2 > HOLE_SKIPS_AREA_FRACTION * order_area_m2
                    {
                        trial.unplaced_area_m2 += self
                            .order
                            .iter()
                            .skip_while(|&&j| j != i)
                            .skip(1)
                            .map(|&j| self.prepared[j].area_m2)
                            .sum::<f64>();
                        break;
                    }
                }
            }
        }
        Ok(trial)
    }

    /// Normalized page UVs of a complete trial: each page's box is centred on the page.
    fn output(&self, trial: &Trial) -> Packing {
        let [w, h] = self.page();
        let shifts: Vec<[i64; 2]> = trial
            .pages
            .iter()
            .map(|p| match p.bbox() {
                Some([x0, y0, x1, y1]) => [
                    -i64::from(x0) + (i64::from(w) - i64::from(x1 - x0)) / 2,
                    -i64::from(y0) + (i64::from(h) - i64::from(y1 - y0)) / 2,
                ],
                None => [0, 0],
            })
            .collect();
        let charts = self
            .charts
            .iter()
            .enumerate()
            .map(|(i, chart)| match &trial.placed[i] {
                None => PlacedChart {
                    page: 0,
                    uv: vec![[0.0, 0.0]; chart.uv.len()],
                },
                Some(pl) => {
                    let s = shifts[pl.page as usize];
                    let ox = (i64::from(pl.x) + s[0]) as f64;
                    let oy = (i64::from(pl.y) + s[1]) as f64;
                    let c = self.prepared[i].centre;
                    let a = &pl.affine;
                    let uv = chart
                        .uv
                        .iter()
                        .map(|p| {
                            let (x, y) = (p[0] - c[0], p[1] - c[1]);
                            let qx = a[0][0] * x + a[0][1] * y + a[0][2] + ox;
                            let qy = a[1][0] * x + a[1][1] * y + a[1][2] + oy;
                            [unit(qx / f64::from(w)), unit(qy / f64::from(h))]
                        })
                        .collect();
                    PlacedChart { page: pl.page, uv }
                }
            })
            .collect();
        Packing {
            charts,
            num_pages: trial.pages.len() as u32,
            texels_per_unit: trial.texels_per_unit,
            trials: self.trials.load(std::sync::atomic::Ordering::Relaxed),
        }
    }
}

/// Clamps into \[0,1\] (only unreferenced vertices can be outside), NaN to 0.
fn unit(v: f64) -> f64 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

/// Largest side of the UV bounding box of a chart's referenced vertices, model units.
fn uv_extent(chart: &PackChart<'_>) -> f64 {
    let [w, h] = uv_box(chart);
    w.max(h)
}

/// Width and height of the UV bounding box of a chart's referenced vertices, model units (0
/// without triangles).
fn uv_box(chart: &PackChart<'_>) -> [f64; 2] {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for t in chart.triangles {
        for &i in t {
            let p = chart.uv[i as usize];
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    if lo[0] > hi[0] {
        [0.0, 0.0]
    } else {
        [hi[0] - lo[0], hi[1] - lo[1]]
    }
}
