//! The fit-to-page density search: the largest density at which one page holds every chart,
//! with the packer of a [`Context`] (its trials, [`Context::run`]).

use std::ops::ControlFlow;

use super::{
    uv_extent, Context, PackError, Steps, Trial, FIT_PROBES, FIT_PROBE_STEP, FIT_TOLERANCE,
    HOLE_FILL_BELOW, HOLE_FIT_TOLERANCE, HOLE_SCORED_MIN_CHARTS, MAX_FIT_TRIALS,
};
/// The largest density (within [`FIT_TOLERANCE`]) at which one page holds every chart: a
/// search on log density: steps from the last trial's fill ratio until a density that fits and
/// one that does not are known, then bisection; then the [`FIT_PROBES`] densities above the
/// bracket, upwards until one does not fit ([`FitSearch`]). A failing trial stops at its first
/// chart that does not fit (with hole filling, after
/// [`HOLE_SKIPS_MAX`](super::HOLE_SKIPS_MAX) until a density has fitted: only then does the
/// search step by how much did not fit), so it costs at most a full one. Deterministic;
/// at most [`MAX_FIT_TRIALS`] + [`FIT_PROBES`] trials (+1 last-resort trial at a density where every
/// chart is below a texel). The trials run one after another, each using every thread
/// (footprints, horizon sides, hole-search orientations).
pub(super) fn fit_to_page(
    ctx: &Context<'_, '_>,
    start: FitStart,
    monitor: &mut dyn FnMut((usize, usize)) -> ControlFlow<()>,
) -> Result<Trial, PackError> {
    fit_to_page_after(ctx, start, None, monitor)
}

/// [`fit_to_page`] whose first trial is `missed` when that is a trial at the density the search
/// starts from (one that did not fit, as [`fit_to_page_unless_first_misses`] gives it back, of
/// the same context): it is not packed again. The same search and result.
pub(super) fn fit_to_page_after(
    ctx: &Context<'_, '_>,
    start: FitStart,
    missed: Option<Trial>,
    monitor: &mut dyn FnMut((usize, usize)) -> ControlFlow<()>,
) -> Result<Trial, PackError> {
    match search_density(ctx, start, monitor, false, missed)? {
        FirstTry::Found(t) => Ok(t),
        // Only a search that gives up at its first miss returns no packing.
        FirstTry::Missed(_) => Err(PackError::DoesNotFit {
            charts: ctx.order.len(),
            page_texels: ctx.page(),
            padding_texels: ctx.options.padding_texels,
        }),
    }
}

/// What [`fit_to_page_unless_first_misses`] found.
pub(super) enum FirstTry {
    /// The packing of the whole search.
    Found(Trial),
    /// The search's first trial, which did not fit: the search gave up there
    /// ([`fit_to_page_after`] goes on from it).
    Missed(Trial),
}

/// [`fit_to_page`], given up when its first trial (at the density the search starts from) does
/// not fit: [`FirstTry::Missed`] then, after that one trial. Otherwise the same search and
/// result; so also when that first trial ends the whole search ([`FitStart::Beat`] starting at
/// its floor: [`PackError::DoesNotFit`], as [`fit_to_page`] would give after the same trial).
pub(super) fn fit_to_page_unless_first_misses(
    ctx: &Context<'_, '_>,
    start: FitStart,
    monitor: &mut dyn FnMut((usize, usize)) -> ControlFlow<()>,
) -> Result<FirstTry, PackError> {
    search_density(ctx, start, monitor, true, None)
}

/// The search of [`fit_to_page_after`]; with `give_up_at_first_miss`, [`FirstTry::Missed`]
/// when the first trial does not fit and the search would go on.
fn search_density(
    ctx: &Context<'_, '_>,
    start: FitStart,
    monitor: &mut dyn FnMut((usize, usize)) -> ControlFlow<()>,
    give_up_at_first_miss: bool,
    mut missed: Option<Trial>,
) -> Result<FirstTry, PackError> {
    let [w, h] = ctx.page();
    let mut progress = Steps::new(monitor, ctx.order.len() * (MAX_FIT_TRIALS + FIT_PROBES + 1));
    let total_area: f64 = ctx.order.iter().map(|&i| ctx.prepared[i].area_m2).sum();
    let does_not_fit = || PackError::DoesNotFit {
        charts: ctx.order.len(),
        page_texels: [w, h],
        padding_texels: ctx.options.padding_texels,
    };
    if total_area.is_nan() || total_area <= 0.0 {
        // Only degenerate charts: one texel each, any density.
        let t = ctx.run(1.0, false, &mut progress)?;
        progress.finish()?;
        return if t.unplaced == 0 {
            Ok(FirstTry::Found(t))
        } else if give_up_at_first_miss {
            Ok(FirstTry::Missed(t))
        } else {
            Err(does_not_fit())
        };
    }
    let clamp_d = |d: f64| d.clamp(1e-300, 1e300);
    // How much the packing would have to shrink (> 1) or could grow (< 1).
    let ratio_of = |t: &Trial| {
        if t.unplaced == 0 {
            let [x0, y0, x1, y1] = t.pages[0].bbox().unwrap_or([0, 0, 1, 1]);
            (f64::from(x1 - x0) / f64::from(w)).max(f64::from(y1 - y0) / f64::from(h))
        } else {
            let placed = (total_area - t.unplaced_area_m2).max(total_area * 1e-6);
            (total_area / placed)
                .sqrt()
                .max(t.worst_size_ratio)
                .max(1.0 + FIT_TOLERANCE)
        }
    };
    let fill = fill_density(total_area, [w, h]);
    let (d, beat, guessed) = match start {
        FitStart::Fill => (fill, None, false),
        FitStart::FillAsGuess => (fill, None, true),
        FitStart::Guess(d) => (d, None, true),
        FitStart::Beat(b) => {
            let above = clamp_d(b * (1.0 + FIT_TOLERANCE));
            (above.max(fill), Some(above), true)
        }
    };
    let mut d = clamp_d(d);
    // With many charts, the horizons' packing is packed again by hole filling when it stays
    // below `HOLE_FILL_BELOW` (`super::pack_charts_with`), searching only above its density:
    // probes that cannot lift it to that efficiency would only raise the floor of that search.
    let probes_from = if !ctx.holes && ctx.order.len() >= HOLE_SCORED_MIN_CHARTS {
        (HOLE_FILL_BELOW * f64::from(w) * f64::from(h) / total_area).sqrt()
    } else {
        0.0
    };
    let mut search = FitSearch {
        probes: if ctx.holes { 0 } else { FIT_PROBES },
        probes_from,
        tolerance: if ctx.holes {
            HOLE_FIT_TOLERANCE
        } else {
            FIT_TOLERANCE
        },
        guessed,
        floor: beat,
        ..FitSearch::default()
    };
    let mut fit: Option<Trial> = None;
    loop {
        // Once a density is known to fit (or when a failure here ends the search), a trial
        // that does not fit only closes the bracket: the search does not read how much did not
        // fit (`FitSearch::next` bisects), so hole filling need not go on past its first miss.
        // (The caller's missed trial, when it is this first one, is not packed again.)
        let known = missed
            .take()
            .filter(|m| m.texels_per_unit == d && m.unplaced > 0);
        let t = if let Some(m) = known {
            m
        } else if fit.is_some() || beat.is_some_and(|b| d <= b) {
            ctx.run_to_first_miss(d, &mut progress)?
        } else {
            ctx.run(d, false, &mut progress)?
        };
        let fitted = t.unplaced == 0;
        if !fitted && beat.is_some_and(|b| d <= b) {
            // Nothing above the density to beat fits where it was tried: the search ends here,
            // given up or not.
            break;
        }
        if !fitted && give_up_at_first_miss && search.steps == 0 {
            return Ok(FirstTry::Missed(t));
        }
        let next = search.next(d, fitted, ratio_of(&t)).map(clamp_d);
        if fitted && fit.as_ref().is_none_or(|f| d > f.texels_per_unit) {
            fit = Some(t);
        }
        let Some(n) = next else { break };
        d = n;
    }
    let t = match fit {
        Some(t) => t,
        None if beat.is_some() => return Err(does_not_fit()),
        None => {
            // Last resort: a density at which every chart is below a texel.
            let extent = ctx
                .order
                .iter()
                .map(|&i| ctx.prepared[i].unit_scale * uv_extent(&ctx.charts[i]))
                .fold(0.0, f64::max);
            let tiny = if extent > 0.0 {
                clamp_d(0.25 / extent)
            } else {
                1.0
            };
            let t = ctx.run(tiny, false, &mut progress)?;
            if t.unplaced > 0 {
                return Err(does_not_fit());
            }
            t
        }
    };
    progress.finish()?;
    Ok(FirstTry::Found(t))
}

/// The density at which charts of `total_area_m2` would cover [`FIT_START_FILL`] of a page of
/// `page` texels ([`FitStart::Fill`]).
pub(super) fn fill_density(total_area_m2: f64, page: [u32; 2]) -> f64 {
    (FIT_START_FILL * f64::from(page[0]) * f64::from(page[1]) / total_area_m2).sqrt()
}

/// The fill ratio a fit-to-page search ([`super::pack_charts`]) starts at when the caller gives
/// no density.
pub const FIT_START_FILL: f64 = 0.6;

/// The density search of [`fit_to_page`] as a state machine: which density to pack next,
/// given the last one and its outcome.
#[derive(Debug, Clone, Default)]
pub(super) struct FitSearch {
    /// Largest density known to fit, smallest known not to fit (search phase).
    lo: Option<f64>,
    hi: Option<f64>,
    /// Search trials run so far.
    steps: usize,
    /// Probes to run after the search ([`FIT_PROBES`], 0 when filling holes), and the probe
    /// running (`k ≥ 1`: density `base · (1 + k · FIT_PROBE_STEP)`), with its base `lo`.
    probes: usize,
    probe: usize,
    probe_base: f64,
    /// The probes run only when the last of them, `lo · (1 + probes · FIT_PROBE_STEP)`,
    /// would reach this density (0: always).
    probes_from: f64,
    /// The bracket closes at this ratio: [`FIT_TOLERANCE`], or [`HOLE_FIT_TOLERANCE`] when
    /// filling holes.
    tolerance: f64,
    /// The search started at a caller's density ([`FitStart::Guess`], [`FitStart::Beat`]),
    /// expected to be close: its first growth is [`FIT_GUESS_GROWTH`], not 5%.
    guessed: bool,
    /// Trials that fitted before the first that did not (each grows the next step).
    fits_in_a_row: usize,
    /// [`FitStart::Beat`]'s density just above the one to beat: no step goes below it while
    /// nothing has fitted (the caller stops when it fails).
    floor: Option<f64>,
}

/// Where [`fit_to_page`] starts its search.
#[derive(Debug, Clone, Copy)]
pub(super) enum FitStart {
    /// Where the charts would cover [`FIT_START_FILL`] of the page.
    Fill,
    /// Where [`FitStart::Fill`] starts, searched as a guess (its first step up is
    /// [`FIT_GUESS_GROWTH`]).
    FillAsGuess,
    /// A density the caller expects to fit.
    Guess(f64),
    /// Only a density above this one is wanted (another packing reached it): the search starts
    /// where [`FitStart::Fill`] does, or [`FIT_TOLERANCE`] above this density when that is
    /// higher; until a trial fits, the steps down stop at that density, and a failure there
    /// ends the search.
    Beat(f64),
}

/// The first growth of a search that started at a caller's density (expected close to the
/// largest that fits): a bracket of 1% closes in two bisections, where the usual 5% takes
/// four. Trade-off: when the guess is far below, one more trial is spent before the 5% steps.
pub const FIT_GUESS_GROWTH: f64 = 1.01;

impl FitSearch {
    /// Records that density `d` fitted or not (`ratio`: how much the packing would have to
    /// shrink, > 1, or could grow, < 1) and returns the density to pack next, or `None` when
    /// the search is over.
    fn next(&mut self, d: f64, fitted: bool, ratio: f64) -> Option<f64> {
        let probe_density = |s: &Self| s.probe_base * (1.0 + FIT_PROBE_STEP * s.probe as f64);
        if self.probe > 0 {
            // Probes go upwards while they fit.
            if !fitted || self.probe >= self.probes {
                return None;
            }
            self.probe += 1;
            return Some(probe_density(self));
        }
        self.steps += 1;
        if fitted {
            if self.lo.is_none_or(|l| d > l) {
                self.lo = Some(d);
            }
        } else if self.hi.is_none_or(|n| d < n) {
            self.hi = Some(d);
        }
        let closed =
            matches!((self.lo, self.hi), (Some(l), Some(n)) if n <= l * (1.0 + self.tolerance));
        if closed || self.steps >= MAX_FIT_TRIALS {
            let lo = self.lo?;
            let highest_probe = lo * (1.0 + FIT_PROBE_STEP * self.probes as f64);
            if self.probes == 0 || highest_probe < self.probes_from {
                return None;
            }
            self.probe = 1;
            self.probe_base = lo;
            return Some(probe_density(self));
        }
        // Once bracketed, bisect (log scale); before, step by the fill ratio (a packing's size
        // is about linear in density), growing by at least 5%, 10%, 20%, 40% while it fits.
        Some(match (self.lo, self.hi) {
            (Some(l), Some(n)) => (l * n).sqrt(),
            _ if fitted => {
                // Consecutive fits grow by 5%, 10%, 20%, 40% (a caller's guess by 1% first).
                self.fits_in_a_row += 1;
                let growth = if self.guessed && self.steps == 1 {
                    FIT_GUESS_GROWTH
                } else {
                    let k = self.fits_in_a_row - usize::from(self.guessed);
                    1.0 + 0.05 * f64::from(1u32 << k.clamp(1, 4).saturating_sub(1))
                };
                d / ratio.min(1.0 / growth)
            }
            (None, _) if self.floor.is_some() => (d / ratio).max(self.floor?),
            _ => d / ratio,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The probes above a closed bracket run only when the last of them would reach
    /// `probes_from`; otherwise the search ends at the bracket.
    #[test]
    fn probes_run_only_when_they_could_reach_their_floor() {
        let bracket = |probes_from: f64| {
            let mut s = FitSearch {
                probes: FIT_PROBES,
                tolerance: FIT_TOLERANCE,
                probes_from,
                ..FitSearch::default()
            };
            // 100 fits, 100.2 does not: the bracket closes (0.2 % < FIT_TOLERANCE).
            s.next(100.0, true, 0.999);
            s.next(100.2, false, 1.01)
        };
        let highest = 100.0 * (1.0 + FIT_PROBE_STEP * FIT_PROBES as f64);
        assert_eq!(bracket(0.0), Some(100.0 * (1.0 + FIT_PROBE_STEP)));
        assert_eq!(bracket(highest), Some(100.0 * (1.0 + FIT_PROBE_STEP)));
        assert_eq!(bracket(highest * 1.001), None);
    }

    /// What `fit_to_page` relies on to stop a failing trial at its first miss once a density
    /// has fitted: from then on the search never reads how much a failing trial left out.
    #[test]
    fn after_a_fit_a_failure_steers_the_search_whatever_its_ratio() {
        for (probes, tolerance, guessed) in [
            (FIT_PROBES, FIT_TOLERANCE, false),
            (0, HOLE_FIT_TOLERANCE, true),
        ] {
            let fresh = FitSearch {
                probes,
                tolerance,
                guessed,
                ..FitSearch::default()
            };
            // Every pattern of fits and failures over 8 trials, each failure tried with two
            // very different ratios once a fit is known: the same next densities.
            for pattern in 0u32..256 {
                let (mut a, mut b) = (fresh.clone(), fresh.clone());
                let mut d = 100.0;
                let mut fitted_once = false;
                for k in 0..8 {
                    let fits = pattern >> k & 1 == 1;
                    let (ra, rb) = if fits || !fitted_once {
                        (0.9, 0.9)
                    } else {
                        (1.01, 7.0)
                    };
                    let (na, nb) = (a.next(d, fits, ra), b.next(d, fits, rb));
                    assert_eq!(na, nb, "pattern {pattern:08b}, trial {k}");
                    fitted_once |= fits;
                    match na {
                        Some(n) => d = n,
                        None => break,
                    }
                }
            }
        }
    }
}
