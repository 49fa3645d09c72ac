//! Packing-aware cuts: a feedback loop from the pack stage into segmentation and validation.
//!
//! It runs at the start of the pack stage (its packing is the stage's packing when no cut is
//! kept), without a cancel checkpoint of its own: it is bounded to a few packings (and on
//! low-poly meshes validations) of a mesh of at most [`PACKING_CUT_MAX_FACES`] faces, or of
//! at most [`LONG_CUT_MAX_FACES`] with a long strip (the long cuts alone). At a fixed density
//! it cuts instead the charts too large for a page ([`cut_to_pages`]).
//! Deterministic.

use super::error::AtlasError;
use super::options::AtlasOptions;
use super::pack::place::{box_sides_m, box_waste_m2, length_pieces, neck_cut};
use super::pack::{
    pack_charts_above, pack_charts_cached, pack_one_page, pack_one_page_horizons,
    too_large_for_a_page, FirstPacker, PackCache, PackChart, PackOptions, Packing, TexelDensity,
    FIT_PROBE_STEP, HOLE_SCORED_MIN_CHARTS, MAX_ROTATIONS,
};
use super::pack_input::{pack_charts_of, pack_inputs};
use super::parameterize;
use super::progress::{Stage, StageProgress};
use super::segment;
use crate::mesh::{FaceId, TriangleMesh};

/// `cut_for_packing` tries cuts only while the estimated packing efficiency is below this
/// (issue 21's target for every mesh). Trade-off: each try costs one packing, and a kept cut a
/// density search; a higher threshold cuts atlases that already pack well into more charts
/// for little gain.
const PACKING_CUT_BELOW: f64 = 0.72;
/// [`PACKING_CUT_BELOW`] on meshes of at most [`LOW_POLY_MAX_FACES`] faces. Six equal squares
/// fill at most 2/3 of a square page, so a cube cannot reach 0.72 with one chart per side;
/// going past that bound means cutting flat sides apart (a 12-triangle cube came out as 8
/// charts at 0.80), which no artist wants.
const PACKING_CUT_BELOW_LOW_POLY: f64 = 0.61;
/// The meshes of [`PACKING_CUT_BELOW_LOW_POLY`], whose cut parts are flattened again instead of
/// keeping their parent's map: a box's cross-shaped chart cut in two gives rectangles when
/// flattened again (Box: 0.695, against 0.629 with the parent's map cut).
const LOW_POLY_MAX_FACES: usize = 100;
/// The last resort of `cut_for_packing` (every chart cut at once) runs only on atlases of at
/// most this many charts: it doubles the seams, which pays on a tube of 4 strips, not on 20
/// charts of a scan.
const PACKING_CUT_ALL_MAX_CHARTS: usize = 8;
/// Levels of the last resort of `cut_for_packing`: every chart cut at once, then every piece
/// again (the parts flattened again). Trade-off: a level costs one validation and packing of
/// the mesh, paid only on the few-chart atlases below the threshold whose single cuts did not
/// pay.
const PACKING_CUT_ALL_LEVELS: usize = 2;
/// ... and only on atlases of at most this many packed charts. Many charts alone do not make a
/// page pack well: PalmTree's 67 charts pack at 0.49 because two of them hold half the page,
/// and one cut takes it to 0.67. Above this count a try's packing costs too much. (The check
/// packs the charts once, and that packing is the stage's own when no cut is kept, so an
/// atlas that already packs well pays nothing.)
const PACKING_CUT_MAX_CHARTS: usize = 256;
/// ... and only on meshes of at most this many faces. Trade-off: the packings of large charts
/// cost more (more texels, more outline triangles) and a try packs once, a kept cut a density
/// search more. On the bunny (69k faces) the cuts took its packing 0.602 → 0.645 (2 cuts) and
/// its pack stage 0.17 → 0.59 s, past issue 22's 0.6 s for its whole pipeline; armadillo
/// (86k) 0.635 → 0.655 for 0.28 → 0.60 s.
const PACKING_CUT_MAX_FACES: usize = 20_000;
/// A cut is kept only when it raises the estimated efficiency by at least this (absolute):
/// every seam costs texture continuity and gutter, so a marginal gain is not worth one.
const PACKING_CUT_MIN_GAIN: f64 = 0.02;
/// At most this many charts tried one at a time (each cut a packing of the whole mesh, two
/// cuts per chart; on low-poly meshes one cut, with a validation).
const PACKING_CUT_MAX_TRIES: usize = 4;

/// A chart longer than this fraction of the page's longer side, at the density where the atlas
/// would reach the efficiency `cut_for_packing` aims at, is cut across its length into pieces
/// no longer than that, all such charts at once (cutting one of two long rails packs no
/// better: the other still sets the density). Trade-off: shorter pieces pack more freely and
/// cost more seams; a strip as long as the page caps the packing however the rest is placed.
const LONG_CUT_FRACTION: f64 = 0.7;
/// ... and whose minimum-area rectangle is at least this many times longer than wide: a
/// compact chart as long as that is only large (few charts share the page), and cutting it
/// first packs worse than the cuts of the charts that waste most (fandisk: a chart of aspect
/// 1.85 cut in two, 0.720 → 0.703; spot: one of aspect 3.17, 0.643 → 0.624). Strips of tubes,
/// planks and rails measure 5 to 60.
const LONG_CUT_MIN_ASPECT: f64 = 4.0;
/// Rounds of the cuts of [`LONG_CUT_FRACTION`]: each kept round raises the density, at which
/// more charts may be too long.
const LONG_CUT_ROUNDS: usize = 3;
/// The long cuts also run on meshes above [`PACKING_CUT_MAX_FACES`] faces, up to this many
/// (alone: no cut by waste, no last resort), when a chart is that long: a strip caps the
/// packing of any mesh (a tube of 22k triangles packed at 0.126). Trade-off: finding the long
/// charts costs every chart's minimum-area rectangle (6 ms on the bunny's 69k faces, 0.113 →
/// 0.119 s); only a mesh that has one pays a packing more per round.
const LONG_CUT_MAX_FACES: usize = 200_000;
/// At most this many pieces per chart and round ([`LONG_CUT_FRACTION`]).
const LONG_CUT_MAX_PIECES: usize = 16;

/// At a fixed density ([`TexelDensity::TexelsPerUnit`]), a chart that fits an empty page in
/// none of the packer's orientations is cut across its length into pieces no longer than this
/// fraction of the page's shorter side, less the padding on both sides ([`cut_to_pages`]): a
/// piece nearly as long as the page would place only in few orientations. Trade-off: shorter
/// pieces place more freely and cost more seams.
const PAGE_CUT_FRACTION: f64 = 0.7;
/// Rounds of [`cut_to_pages`]: a piece cut across the length of a chart larger than a page both
/// ways is still too wide, and is cut across its own length in the next round.
const PAGE_CUT_ROUNDS: usize = 4;
/// At most this many pieces per chart and round ([`PAGE_CUT_FRACTION`]).
const PAGE_CUT_MAX_PIECES: usize = 64;

/// How `cut_for_packing` cuts a chart it picks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Way {
    /// Across its neck ([`neck_cut`]), else across its 3-D diameter.
    Neck,
    /// Across its 3-D diameter (`segment::split_in_two`).
    Diameter,
    /// Across its length into this many pieces of equal length ([`length_pieces`]).
    Lengthwise(usize),
}

/// Whether the packing-aware cuts apply to `mesh` with `options`: fit-to-page packing of at most
/// [`PACKING_CUT_MAX_FACES`] faces.
fn cuts_apply(mesh: &TriangleMesh, options: &AtlasOptions) -> bool {
    options.pack.density == TexelDensity::FitToPage && mesh.num_faces() <= PACKING_CUT_MAX_FACES
}

/// The pack options of every packing of `mesh`: `options.pack`, searching with the horizons
/// first ([`FirstPacker::Horizons`]) on the meshes the cuts apply to, whose choices of cuts were
/// measured that way. With hole filling first inside the cuts' loop, other cuts are kept and
/// the packing moves both ways: craft_speederD 0.681 → 0.625, cakeBirthday 0.686 → 0.664,
/// DepthOfFieldExample 0.711 → 0.736, spot 0.639 → 0.652, fandisk 0.720 → 0.732. A packing
/// after the cuts (a repack of the UV guard) searches as they did.
pub(super) fn pack_options(mesh: &TriangleMesh, options: &AtlasOptions) -> PackOptions {
    if cuts_apply(mesh, options) {
        PackOptions {
            first_packer: FirstPacker::Horizons,
            ..options.pack
        }
    } else {
        options.pack
    }
}

/// Packing-aware cuts (issue 21's packing target, 0.72; 0.61 on low-poly meshes): when the
/// atlas has few charts and packs poorly (a strip, a disc or a chart with long arms wastes
/// much of a square page), first every long strip (longer than [`LONG_CUT_FRACTION`] of the
/// page at the density of the target, and [`LONG_CUT_MIN_ASPECT`] times longer than wide: a
/// tube, a plank, a rail) is cut across its length into pieces no longer than that, all at
/// once ([`length_pieces`], the borders smoothed as the neck cuts' are), while
/// that pays, up to [`LONG_CUT_ROUNDS`] rounds. Then the chart that wastes the most space in
/// its minimum-area rectangle
/// (`pack::place::box_waste_m2`) is cut: first across its narrowest part in UV
/// (`pack::place::neck_cut`: the neck of a dumbbell, the root of an arm), and when that does
/// not pay, in two from the ends of a diameter of its face graph (`segment::split_in_two`);
/// the disk guarantee then makes disks of the sides. Each part keeps its parent's map
/// restricted to it (a cut in UV space: every face keeps its UV shape and nothing is
/// flattened); on low-poly meshes ([`LOW_POLY_MAX_FACES`]) only the diameter cut is tried and
/// the mesh is validated again with it (no merge-back, so the parts stay apart). The charts
/// are packed, and the cut is kept when the estimated efficiency (Σ chart area × density²
/// over the page area: the packer places each chart at exactly that UV area) rises by at least
/// [`PACKING_CUT_MIN_GAIN`]: first one packing at the density of that gain
/// ([`pack_one_page`]), then, when it fits, the density search above that density
/// ([`pack_charts_above`]: each packer only looks for a denser packing, and the one-page packing
/// stands when none finds one). Otherwise the chart wasting the next most is tried, up
/// to [`PACKING_CUT_MAX_TRIES`] charts; when no single cut paid and there are at most
/// [`PACKING_CUT_ALL_MAX_CHARTS`] charts, every chart is cut at once and validated again
/// (then every piece again, up to [`PACKING_CUT_ALL_LEVELS`] levels), the last tries. Only
/// with [`TexelDensity::FitToPage`] (an explicit density does not change with the cut: there
/// only the charts too large for a page are cut, [`cut_to_pages`], and nothing is packed). On
/// meshes above [`PACKING_CUT_MAX_FACES`] faces, up to [`LONG_CUT_MAX_FACES`], only the long
/// cuts run, and only when a chart is that long (else nothing is packed here). Last, on the
/// meshes of up to [`PACKING_CUT_MAX_FACES`] faces whose packing is still below the target, a
/// packing of fewer than [`HOLE_SCORED_MIN_CHARTS`] charts is made denser with more angles per
/// chart where they find one ([`more_angles_above`]).
/// Deterministic (every step is). Returns the charts to use, the number of charts the cuts
/// added and the packing of those charts.
pub(super) fn cut_for_packing(
    mesh: &TriangleMesh,
    validated: parameterize::ParameterizedCharts,
    options: &AtlasOptions,
) -> Result<(parameterize::ParameterizedCharts, usize, Option<Packing>), AtlasError> {
    if let TexelDensity::TexelsPerUnit(texels_per_unit) = options.pack.density {
        let (charts, cuts) = cut_to_pages(mesh, validated, options, texels_per_unit)?;
        return Ok((charts, cuts, None));
    }
    // Above PACKING_CUT_MAX_FACES faces only the long cuts run, up to LONG_CUT_MAX_FACES.
    let long_only = !cuts_apply(mesh, options);
    if long_only
        && !(options.pack.density == TexelDensity::FitToPage
            && mesh.num_faces() <= LONG_CUT_MAX_FACES)
    {
        return Ok((validated, 0, None));
    }
    let pack_options = pack_options(mesh, options);
    let page = f64::from(options.pack.width_texels) * f64::from(options.pack.height_texels);
    let low_poly = mesh.num_faces() <= LOW_POLY_MAX_FACES;
    let below = if low_poly {
        PACKING_CUT_BELOW_LOW_POLY
    } else {
        PACKING_CUT_BELOW
    };
    // Every try packs the same charts but one (cut in two), first at the density of the gain
    // it needs, the same for every try until one pays: the cache keeps their prepared data
    // and their footprints at that density.
    let cache = PackCache::new();
    // The charts of `v` to pack (not degenerate) and their total 3-D area.
    let packed_of = |inputs: &super::pack_input::PackInputs| -> (Vec<usize>, f64) {
        let packed: Vec<usize> = (0..inputs.degenerate.len())
            .filter(|&i| !inputs.degenerate[i])
            .collect();
        let total = packed.iter().map(|&i| inputs.area_m2[i]).sum();
        (packed, total)
    };
    // The estimated efficiency of `v`'s packing, its number of packed charts, and the packing
    // (None above PACKING_CUT_MAX_CHARTS charts, where no cut is tried). With `above`, a
    // density known to fit, the search looks only above it (`pack_charts_above`), and the
    // packing is `None` when it finds nothing there.
    let estimate = |v: &parameterize::ParameterizedCharts,
                    above: Option<f64>|
     -> Result<(f64, usize, Option<Packing>), AtlasError> {
        let inputs = pack_inputs(mesh, v)?;
        let (packed, total) = packed_of(&inputs);
        let n = packed.len();
        if n == 0 || n > PACKING_CUT_MAX_CHARTS {
            return Ok((1.0, n, None));
        }
        let input = pack_charts_of(v, &packed, &inputs.triangles, &inputs.area_m2);
        let progress = &mut StageProgress::ignored(Stage::Pack);
        let packing = match above {
            Some(d) => pack_charts_above(&input, &pack_options, d, &cache, progress)?,
            None => Some(pack_charts_cached(
                &input,
                &pack_options,
                None,
                &cache,
                progress,
            )?),
        };
        let eff = packing
            .as_ref()
            .map_or(0.0, |p| total * p.texels_per_unit.powi(2) / page);
        Ok((eff, n, packing))
    };
    // The density at which `v`'s charts would pack at efficiency `goal`, with the packing,
    // when one page holds them there (`pack_one_page`: the horizons, then the plain first-fit
    // hole filling, each stopping at the first chart that does not fit; a cheap test before
    // the search of `estimate`). The total area is the first try's: every try partitions the
    // same faces, and the sum over other charts differs in its last bits, which would make
    // another density of the same goal, and so another pin that drops the footprints the
    // cache holds for the charts the try leaves alone.
    let reference_total_m2 = std::cell::OnceCell::new();
    let fits_at = |v: &parameterize::ParameterizedCharts,
                   goal: f64|
     -> Result<Option<(f64, Packing)>, AtlasError> {
        let inputs = pack_inputs(mesh, v)?;
        let (packed, total) = packed_of(&inputs);
        if packed.is_empty() || total.is_nan() || total <= 0.0 {
            return Ok(None);
        }
        let total = *reference_total_m2.get_or_init(|| total);
        let density = (goal * page / total).sqrt();
        let input = pack_charts_of(v, &packed, &inputs.triangles, &inputs.area_m2);
        cache.pin(density);
        Ok(pack_one_page(&input, &pack_options, density, Some(&cache))?.map(|p| (density, p)))
    };
    // A candidate's efficiency and packing when they beat `best` by `PACKING_CUT_MIN_GAIN`: the
    // search above it runs only when the candidate fits at the efficiency that would keep it.
    let try_candidate = |v: &parameterize::ParameterizedCharts,
                         best: f64|
     -> Result<Option<(f64, Option<Packing>)>, AtlasError> {
        let goal = best + PACKING_CUT_MIN_GAIN;
        let Some((density, fixed)) = fits_at(v, goal)? else {
            return Ok(None);
        };
        // The search, only above the density that fits: the packing at that density stands
        // when it finds nothing denser.
        let (eff, _, packing) = estimate(v, Some(density))?;
        Ok(Some(match packing {
            Some(p) if eff >= goal => (eff, Some(p)),
            // Above PACKING_CUT_MAX_CHARTS charts: no packing, as for the first estimate.
            None if eff >= goal => (eff, None),
            _ => (goal, Some(fixed)),
        }))
    };
    // The charts of `v` too long for the page at the density of the target efficiency
    // (`LONG_CUT_FRACTION`, `LONG_CUT_MIN_ASPECT`), each with the pieces to cut it into.
    let side_texels = f64::from(options.pack.width_texels.max(options.pack.height_texels));
    let limit_texels = LONG_CUT_FRACTION * side_texels;
    let long_charts =
        |v: &parameterize::ParameterizedCharts| -> Result<Vec<(usize, Way)>, AtlasError> {
            let inputs = pack_inputs(mesh, v)?;
            let (packed, total) = packed_of(&inputs);
            let goal_texels_per_unit = (below * page / total).sqrt();
            if !goal_texels_per_unit.is_finite() {
                return Ok(Vec::new());
            }
            Ok(packed
                .iter()
                .filter_map(|&i| {
                    let (map, _) = v.maps[i].as_ref()?;
                    let [long_m, short_m] = box_sides_m(&PackChart {
                        uv: &map.uv,
                        triangles: &inputs.triangles[i],
                        area_m2: inputs.area_m2[i],
                    });
                    let pieces = (goal_texels_per_unit * long_m / limit_texels).ceil();
                    (v.segmentation.charts[i].len() >= 2
                        && pieces >= 2.0
                        && long_m >= LONG_CUT_MIN_ASPECT * short_m)
                        .then(|| {
                            (
                                i,
                                Way::Lengthwise((pieces as usize).min(LONG_CUT_MAX_PIECES)),
                            )
                        })
                })
                .collect())
        };
    // A large mesh without a long chart is packed by the pack stage alone.
    if long_only && long_charts(&validated)?.is_empty() {
        return Ok((validated, 0, None));
    }
    let (best, n, best_packing) = estimate(&validated, None)?;
    if n == 0 || n > PACKING_CUT_MAX_CHARTS || best >= below {
        return Ok((validated, 0, best_packing));
    }
    let current = validated;
    // `current` with each chart of `picks` cut its way (in two across the neck, else across
    // the 3-D diameter; or across its length into pieces; then made disks), every part keeping
    // its parent's map restricted to it: a cut in UV space, no flattening. Every face keeps its
    // UV shape, so flips, overlaps and each face's angle distortion are those of `current`; the
    // packer scales each part to its own 3-D area, as every chart, so a face's stretch changes
    // by the ratio of its part's scale to its parent's. (The atlas L∞ of craft_speederD and
    // cakeBirthday moves with the cuts both ways, but on 3-D slivers, height ~1e-7 of their
    // length, whose f32 UVs decide it wherever they land.) With `flatten` (low-poly meshes,
    // and the last resort) the mesh is validated again instead.
    // Charts listed in `unresolved` are never picked, so their indices follow their first face.
    let validate_options = parameterize::ParameterizeOptions {
        merge_passes: 0,
        ..options.parameterize
    };
    let cut = |current: &parameterize::ParameterizedCharts,
               picks: &[(usize, Way)],
               flatten: bool|
     -> Result<parameterize::ParameterizedCharts, AtlasError> {
        cut_charts(mesh, current, picks, flatten.then_some(&validate_options))
    };
    // Each chart's waste in its minimum-area rectangle (`pack::place::box_waste_m2`).
    let wastes = |v: &parameterize::ParameterizedCharts| -> Result<Vec<f64>, AtlasError> {
        let inputs = pack_inputs(mesh, v)?;
        Ok((0..v.segmentation.charts.len())
            .map(|i| match &v.maps[i] {
                Some((map, _)) if !inputs.degenerate[i] => box_waste_m2(&PackChart {
                    uv: &map.uv,
                    triangles: &inputs.triangles[i],
                    area_m2: inputs.area_m2[i],
                }),
                _ => 0.0,
            })
            .collect())
    };
    // The cuts that pay, one chart at a time, the chart wasting most first (`PACKING_CUT_MAX_TRIES`
    // tries).
    let waste_cuts = |mut state: CutState| -> Result<CutState, AtlasError> {
        let mut tried: Vec<Vec<FaceId>> = Vec::new();
        let mut waste = wastes(&state.current)?;
        for _ in 0..PACKING_CUT_MAX_TRIES {
            if state.best >= below {
                break;
            }
            // The chart of at least 2 faces not tried yet that wastes the most space.
            let charts = &state.current.segmentation.charts;
            let Some(pick) = (0..charts.len())
                .filter(|&i| charts[i].len() >= 2 && !tried.contains(&charts[i]))
                .max_by(|&a, &b| waste[a].total_cmp(&waste[b]).then(b.cmp(&a)))
            else {
                break;
            };
            tried.push(charts[pick].clone());
            // Across the chart's neck first (kept maps), then across its 3-D diameter.
            let ways: &[Way] = if low_poly {
                &[Way::Diameter]
            } else {
                &[Way::Neck, Way::Diameter]
            };
            let mut missed: Option<parameterize::ParameterizedCharts> = None;
            for &way in ways {
                let candidate = cut(&state.current, &[(pick, way)], low_poly)?;
                // The same charts as the way before (the neck is the diameter) pack the same.
                if missed.as_ref() == Some(&candidate) {
                    continue;
                }
                if let Some((eff, packing)) = try_candidate(&candidate, state.best)? {
                    state.kept(candidate, eff, packing);
                    waste = wastes(&state.current)?;
                    tried.clear();
                    break;
                }
                missed = Some(candidate);
            }
        }
        Ok(state)
    };
    // Every chart too long cut across its length at once, while that pays (`LONG_CUT_ROUNDS`).
    let long_cuts = |mut state: CutState| -> Result<CutState, AtlasError> {
        for _ in 0..LONG_CUT_ROUNDS {
            if state.best >= below {
                break;
            }
            let picks = long_charts(&state.current)?;
            if picks.is_empty() {
                break;
            }
            let candidate = cut(&state.current, &picks, low_poly)?;
            if candidate.segmentation.charts.len() == state.current.segmentation.charts.len() {
                break;
            }
            let Some((eff, packing)) = try_candidate(&candidate, state.best)? else {
                break;
            };
            state.kept(candidate, eff, packing);
        }
        Ok(state)
    };
    // The long charts first: cut by waste first, their pieces get other shapes and the long
    // cuts after them find less (a 66-chart asset with two 30 m rails: 0.715 the long cuts
    // first, 0.635 after; a tube of 8 sides and 15 m, 0.742 against 0.673).
    let start = CutState {
        current,
        best,
        best_packing,
        cuts: 0,
    };
    let CutState {
        mut current,
        mut best,
        mut best_packing,
        mut cuts,
    } = if long_only {
        long_cuts(start)?
    } else {
        waste_cuts(long_cuts(start)?)?
    };
    // No single cut paid (e.g. a tube in four equal strips, where cutting one strip leaves an
    // irregular set): the last tries cut every chart of at least 2 faces at once, and when that
    // does not pay either, every piece once more, up to `PACKING_CUT_ALL_LEVELS` levels (a 2:1
    // rectangle cut into two squares packs no better on a square page; its quarters do).
    if !long_only && cuts == 0 && best < below && n <= PACKING_CUT_ALL_MAX_CHARTS {
        let mut level: Option<(parameterize::ParameterizedCharts, usize)> = None;
        for _ in 0..PACKING_CUT_ALL_LEVELS {
            let (base, cut_before) = match &level {
                Some((l, c)) => (l, *c),
                None => (&current, 0),
            };
            let charts = &base.segmentation.charts;
            let picks: Vec<usize> = (0..charts.len())
                .filter(|&i| charts[i].len() >= 2)
                .collect();
            if picks.is_empty() {
                break;
            }
            let picks: Vec<(usize, Way)> = picks.into_iter().map(|i| (i, Way::Diameter)).collect();
            let candidate = cut(base, &picks, true)?;
            let cut_now = cut_before + picks.len();
            if let Some((eff, packing)) = try_candidate(&candidate, best)? {
                best = eff;
                cuts = cut_now;
                best_packing = packing;
                current = candidate;
                break;
            }
            level = Some((candidate, cut_now));
        }
    }
    // The packing kept, denser with more angles where they find one, while below the target.
    if !long_only && best < below {
        if let Some(packing) = best_packing.as_mut() {
            let inputs = pack_inputs(mesh, &current)?;
            let (packed, _) = packed_of(&inputs);
            if packed.len() < HOLE_SCORED_MIN_CHARTS {
                let input = pack_charts_of(&current, &packed, &inputs.triangles, &inputs.area_m2);
                more_angles_above(&input, &pack_options, packing, &cache)?;
            }
        }
    }
    Ok((current, cuts, best_packing))
}

/// Angle counts that [`more_angles_above`] tries, as multiples of `PackOptions::rotations`
/// (in halves: 3 is 1.5 times as many), those above [`MAX_ROTATIONS`] left out. Only for a
/// count that is a multiple of 8, as `pack::hole_rotations`: a user who asks for 1, 2 or 4
/// rotations (none, half turns, quarter turns) gets no other angle.
const MORE_ANGLES_HALVES: [u32; 2] = [3, 4];
/// Densities that [`more_angles_above`] tries at most per angle count, each
/// [`FIT_PROBE_STEP`] above the last.
const MORE_ANGLES_PROBES: usize = 8;

/// `packing` (of `charts`, a fit-to-page packing of `options`) replaced by a denser one when
/// more angles per chart find one: for each count of [`MORE_ANGLES_HALVES`], one page with the
/// horizons alone ([`pack_one_page_horizons`]) at densities [`FIT_PROBE_STEP`] apart above the
/// packing's, upwards until one does not fit ([`MORE_ANGLES_PROBES`] at most). Whether charts
/// fit is not monotone in the angles: on few large charts the packing moves by ±0.04 with the
/// angle count (docs/benchmarks.md), and the densest of the counts is kept, so the packing
/// never gets less dense. Trade-off: a count that finds nothing costs one horizon packing of
/// one page, stopped at its first chart that does not fit (hole filling after it would find
/// a few more and cost twice as much); `cut_for_packing` runs it only on atlases of fewer
/// than [`HOLE_SCORED_MIN_CHARTS`] charts packed below its target, where a packing is cheap.
/// Deterministic. `packing.trials` counts the packings it ran too.
fn more_angles_above(
    charts: &[PackChart<'_>],
    options: &PackOptions,
    packing: &mut Packing,
    cache: &PackCache,
) -> Result<(), AtlasError> {
    if options.rotations % 8 != 0 {
        return Ok(());
    }
    let mut trials = packing.trials;
    for halves in MORE_ANGLES_HALVES {
        let rotations = options.rotations * halves / 2;
        if rotations > MAX_ROTATIONS {
            continue;
        }
        let more = PackOptions {
            rotations,
            ..*options
        };
        let base = packing.texels_per_unit;
        for k in 1..=MORE_ANGLES_PROBES {
            let density = base * (1.0 + FIT_PROBE_STEP * k as f64);
            trials += 1;
            match pack_one_page_horizons(charts, &more, density, Some(cache))? {
                Some(denser) => *packing = denser,
                None => break,
            }
        }
    }
    packing.trials = trials;
    Ok(())
}

/// `faces` (a chart) cut into the pieces `piece` numbers (one per face, in the order of
/// `faces`, numbered from 0 without gaps): the first piece cut off the rest, then the next,
/// each border smoothed as `segment::smooth_cut` smooths it. Every face lands in one part; a
/// part may be empty or not connected (the caller makes disks).
fn cut_pieces(mesh: &TriangleMesh, faces: &[FaceId], piece: &[usize]) -> Vec<Vec<FaceId>> {
    let mut of: Vec<(FaceId, usize)> = faces.iter().copied().zip(piece.iter().copied()).collect();
    of.sort_unstable_by_key(|&(f, _)| f);
    let piece_of = |f: FaceId| {
        of.binary_search_by_key(&f, |&(g, _)| g)
            .map_or(0, |k| of[k].1)
    };
    let count = piece.iter().max().map_or(1, |&m| m + 1);
    let mut parts = Vec::new();
    let mut rest = faces.to_vec();
    for j in 1..count {
        if rest.is_empty() {
            break;
        }
        let far: Vec<bool> = rest.iter().map(|&f| piece_of(f) >= j).collect();
        let (near, beyond) = segment::smooth_cut(mesh, &rest, &far);
        parts.push(near);
        rest = beyond;
    }
    parts.push(rest);
    parts
}

/// Where `cut_for_packing` stands: the charts, the estimated efficiency of their packing and
/// that packing, and the charts its kept cuts added.
#[derive(Debug, Clone)]
struct CutState {
    current: parameterize::ParameterizedCharts,
    best: f64,
    best_packing: Option<Packing>,
    cuts: usize,
}

impl CutState {
    /// Keeps `candidate`, whose packing `packing` reached efficiency `eff`.
    fn kept(
        &mut self,
        candidate: parameterize::ParameterizedCharts,
        eff: f64,
        packing: Option<Packing>,
    ) {
        self.cuts += candidate.segmentation.charts.len() - self.current.segmentation.charts.len();
        self.best = eff;
        self.best_packing = packing;
        self.current = candidate;
    }
}

/// `current` with each chart of `picks` cut its way (`cut_for_packing`'s comment there); with
/// `validate` (options), the mesh is validated again with the parts instead of each part keeping
/// its parent's map restricted to it.
fn cut_charts(
    mesh: &TriangleMesh,
    current: &parameterize::ParameterizedCharts,
    picks: &[(usize, Way)],
    validate: Option<&parameterize::ParameterizeOptions>,
) -> Result<parameterize::ParameterizedCharts, AtlasError> {
    let charts = &current.segmentation.charts;
    let mut stats = current.segmentation.stats;
    let mut parts: Vec<(Vec<FaceId>, Option<parameterize::LocatedMap>)> = Vec::new();
    for (i, faces) in charts.iter().enumerate() {
        let parent = current.maps[i].as_ref();
        let unresolved = current.unresolved.iter().any(|(c, _)| *c == i);
        let way = picks
            .iter()
            .find(|(c, _)| *c == i)
            .map(|&(_, w)| w)
            .filter(|_| parent.is_some() && !unresolved);
        let Some(way) = way else {
            parts.push((faces.clone(), parent.cloned()));
            continue;
        };
        let pieces: Vec<Vec<FaceId>> = match way {
            Way::Lengthwise(k) => {
                let sliced = parent.and_then(|(map, _)| {
                    let (cm, _) = parameterize::chart_mesh(mesh, faces);
                    let chart = PackChart {
                        uv: &map.uv,
                        triangles: &cm.triangles,
                        area_m2: 0.0,
                    };
                    length_pieces(&chart, k).map(|piece| cut_pieces(mesh, faces, &piece))
                });
                let Some(pieces) = sliced else {
                    // Every centroid in one slice: the chart stays whole.
                    parts.push((faces.clone(), parent.cloned()));
                    continue;
                };
                pieces
            }
            Way::Neck | Way::Diameter => {
                let by_neck = if way == Way::Neck {
                    parent.and_then(|(map, _)| {
                        let (cm, _) = parameterize::chart_mesh(mesh, faces);
                        let side = neck_cut(&PackChart {
                            uv: &map.uv,
                            triangles: &cm.triangles,
                            area_m2: 0.0,
                        })?;
                        // The cut follows triangle edges across the neck: its teeth go to
                        // the other side, as on the borders the segmentation grows.
                        Some(segment::smooth_cut(mesh, faces, &side))
                    })
                } else {
                    None
                };
                let inside = |f: FaceId| faces.binary_search(&f).is_ok();
                let (a, b) = by_neck.unwrap_or_else(|| segment::split_in_two(mesh, faces, &inside));
                vec![a, b]
            }
        };
        for mut part in segment::enforce_disks(mesh, pieces, &mut stats) {
            part.sort_unstable();
            let map = parent.and_then(|p| parameterize::restricted_map(mesh, &part, p));
            parts.push((part, map));
        }
    }
    parts.retain(|(faces, _)| !faces.is_empty());
    // `segment::finish`'s order (by lowest face), so that the maps stay aligned.
    parts.sort_unstable_by_key(|(faces, _)| faces[0]);
    let (proposed, maps): (Vec<_>, Vec<_>) = parts.into_iter().unzip();
    let segmentation = segment::finish(mesh, proposed, stats);
    if let Some(validate_options) = validate {
        return Ok(parameterize::parameterize_charts(
            mesh,
            &segmentation,
            validate_options,
            &mut StageProgress::ignored(Stage::Parameterize),
        )?);
    }
    debug_assert_eq!(segmentation.charts.len(), maps.len());
    let unresolved = current
        .unresolved
        .iter()
        .map(|(c, defect)| {
            let first = charts[*c][0];
            (segmentation.face_chart[first].index(), defect.clone())
        })
        .collect();
    Ok(parameterize::ParameterizedCharts {
        segmentation,
        maps,
        unresolved,
        splits: current.splits,
        degenerate_splits: current.degenerate_splits,
        degenerate_faces: current.degenerate_faces,
        merges: current.merges,
        stretch: current.stretch,
        asp: current.asp,
    })
}

/// At a fixed density (`texels_per_unit`), every chart that fits an empty page in none of the
/// packer's orientations (checked only for charts longer than the pieces) is cut across its
/// length into pieces no longer than [`PAGE_CUT_FRACTION`] of the page's shorter side (padding
/// left out) ([`length_pieces`], at most [`PAGE_CUT_MAX_PIECES`]),
/// each part keeping its parent's map restricted to it, then made disks; and the pieces again,
/// up to [`PAGE_CUT_ROUNDS`] rounds, so that a chart larger than a page both ways ends in
/// pieces that fit. Without it such a chart is [`PackError::ChartTooLarge`]; a chart of one
/// face cannot be cut and still is. Returns the charts and how many charts the cuts added.
/// Deterministic.
///
/// [`PackError::ChartTooLarge`]: super::pack::PackError::ChartTooLarge
fn cut_to_pages(
    mesh: &TriangleMesh,
    validated: parameterize::ParameterizedCharts,
    options: &AtlasOptions,
    texels_per_unit: f64,
) -> Result<(parameterize::ParameterizedCharts, usize), AtlasError> {
    let shorter_side = f64::from(options.pack.width_texels.min(options.pack.height_texels));
    // A chart's footprint takes its padding on both sides and up to a texel more at each end.
    let margin = 2.0 * f64::from(options.pack.padding_texels) + 2.0;
    let limit_texels = PAGE_CUT_FRACTION * (shorter_side - margin);
    let mut current = validated;
    let mut cuts = 0;
    if !(limit_texels > 0.0 && texels_per_unit.is_finite() && texels_per_unit > 0.0) {
        return Ok((current, cuts));
    }
    for _ in 0..PAGE_CUT_ROUNDS {
        let inputs = pack_inputs(mesh, &current)?;
        let picks: Vec<(usize, Way)> = (0..current.segmentation.charts.len())
            .filter(|&i| !inputs.degenerate[i] && current.segmentation.charts[i].len() >= 2)
            .filter_map(|i| {
                let (map, _) = current.maps[i].as_ref()?;
                let chart = PackChart {
                    uv: &map.uv,
                    triangles: &inputs.triangles[i],
                    area_m2: inputs.area_m2[i],
                };
                let [long_m, _] = box_sides_m(&chart);
                // Whether the chart fits an empty page in none of the packer's orientations.
                let too_large = || {
                    too_large_for_a_page(&[chart], &options.pack, texels_per_unit)
                        .ok()
                        .and_then(|v| v.first().copied())
                };
                // A chart no longer than the pieces fits a page in any orientation (its
                // rectangle's diagonal is at most 0.99 of the page side); a longer one is cut
                // when no orientation of the packer fits it (a strip may still fit across the
                // diagonal, and a chart whose rectangle fits may fit in none of the angles tried).
                let pieces = (long_m * texels_per_unit / limit_texels).ceil();
                let fits = pieces <= 1.0 || !too_large().unwrap_or(true);
                (!fits && pieces >= 2.0).then(|| {
                    (
                        i,
                        Way::Lengthwise((pieces as usize).min(PAGE_CUT_MAX_PIECES)),
                    )
                })
            })
            .collect();
        if picks.is_empty() {
            break;
        }
        let candidate = cut_charts(mesh, &current, &picks, None)?;
        let added = candidate
            .segmentation
            .charts
            .len()
            .saturating_sub(current.segmentation.charts.len());
        if added == 0 {
            break;
        }
        cuts += added;
        current = candidate;
    }
    Ok((current, cuts))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atlas::pack::pack_charts;
    use crate::atlas::pack::test_charts::{as_pack_charts, check_packing, mixed_set};

    /// More angles above a fit-to-page packing: never less dense, every guarantee of a
    /// packing kept, the same result twice; and on one of these few-chart sets at least, denser
    /// (1 of the 12 when it was written).
    #[test]
    fn more_angles_keep_every_guarantee_and_find_denser_packings_of_few_charts() {
        let options = PackOptions::default();
        let mut denser = 0;
        for seed in 1..=12 {
            let charts = mixed_set(4 + seed as usize % 5, seed);
            let borrowed = as_pack_charts(&charts);
            let progress = &mut StageProgress::ignored(Stage::Pack);
            let found = pack_charts(&borrowed, &options, progress).unwrap();
            let mut packing = found.clone();
            more_angles_above(&borrowed, &options, &mut packing, &PackCache::new()).unwrap();
            let mut again = found.clone();
            more_angles_above(&borrowed, &options, &mut again, &PackCache::new()).unwrap();
            assert_eq!(again, packing, "seed {seed}: not deterministic");
            assert!(
                packing.trials > found.trials,
                "seed {seed}: no trial counted"
            );
            let d = packing.texels_per_unit;
            assert!(d >= found.texels_per_unit, "seed {seed}: less dense");
            if d > found.texels_per_unit {
                denser += 1;
            }
            let fixed = PackOptions {
                density: TexelDensity::TexelsPerUnit(d),
                ..options
            };
            let check = check_packing(&borrowed, &packing, &fixed);
            assert_eq!(packing.num_pages, 1, "seed {seed}");
            assert_eq!(
                (
                    check.overlap_texels,
                    check.padding_violation_texels,
                    check.edge_violation_texels,
                    check.out_of_range_uvs
                ),
                (0, 0, 0, 0),
                "seed {seed}: {check:?}"
            );
        }
        // Counts that are not a multiple of 8 get no other angle.
        let charts = mixed_set(6, 3);
        let borrowed = as_pack_charts(&charts);
        let quarter = PackOptions {
            rotations: 4,
            ..options
        };
        let found = pack_charts(
            &borrowed,
            &quarter,
            &mut StageProgress::ignored(Stage::Pack),
        );
        let found = found.unwrap();
        let mut packing = found.clone();
        more_angles_above(&borrowed, &quarter, &mut packing, &PackCache::new()).unwrap();
        assert_eq!(packing, found);
        assert!(
            denser >= 1,
            "more angles found a denser packing on {denser} of 12 sets"
        );
    }
}
