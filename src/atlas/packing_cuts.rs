//! Packing-aware cuts: a feedback loop from the pack stage into segmentation and validation.
//!
//! It runs at the start of the pack stage (its packing is the stage's packing when no cut is
//! kept), without a cancel checkpoint of its own: it is bounded to a few validations and
//! packings of a mesh of at most [`PACKING_CUT_MAX_FACES`] faces. Deterministic.

use super::error::AtlasError;
use super::options::AtlasOptions;
use super::pack::{pack_charts, pack_charts_from, PackError, PackOptions, Packing, TexelDensity};
use super::pack_input::{pack_charts_of, pack_inputs};
use super::parameterize;
use super::progress::{Stage, StageProgress};
use super::segment;
use crate::mesh::TriangleMesh;

/// `cut_for_packing` tries cuts only while the estimated packing efficiency is below this
/// (the packing target is 0.60, plus a margin for the estimate). Trade-off: a higher threshold
/// cuts atlases that already pack well into many more charts for little gain.
const PACKING_CUT_BELOW: f64 = 0.61;
/// The last resort of `cut_for_packing` (every chart cut at once) runs only on atlases of at
/// most this many charts: it doubles the seams, which pays on a tube of 4 strips, not on 20
/// charts of a scan.
const PACKING_CUT_ALL_MAX_CHARTS: usize = 8;
/// Levels of the last resort of `cut_for_packing`: every chart cut at once, then every piece
/// again. Trade-off: a level costs one validation and packing of the mesh, paid only on the
/// few-chart atlases below [`PACKING_CUT_BELOW`] whose single cuts did not pay.
const PACKING_CUT_ALL_LEVELS: usize = 2;
/// ... and only on atlases of at most this many packed charts. Many charts alone do not make a
/// page pack well: PalmTree's 67 charts pack at 0.49 because two of them hold half the page,
/// and one cut takes it to 0.67. Above this count a try's re-validation and re-packing cost
/// too much. (The check packs the charts once, and that packing is the stage's own when no
/// cut is kept, so an atlas that already packs well pays nothing.)
const PACKING_CUT_MAX_CHARTS: usize = 256;
/// ... and only on meshes of at most this many faces: the check alone packs the mesh once more,
/// and each try validates and packs it again, which costs a large share of the pipeline on
/// larger meshes, whose many charts pack well anyway.
const PACKING_CUT_MAX_FACES: usize = 20_000;
/// A cut is kept only when it raises the estimated efficiency by at least this (absolute):
/// every seam costs texture continuity and gutter, so a marginal gain is not worth one.
const PACKING_CUT_MIN_GAIN: f64 = 0.02;
/// At most this many tries (each a validation and a packing of the whole mesh).
const PACKING_CUT_MAX_TRIES: usize = 4;

/// Packing-aware cuts (packing target 0.60): when the atlas has few charts and packs
/// poorly (a strip or a disc wastes most of a square page), the largest-area chart is cut in two
/// from the ends of a diameter of its face graph (`segment::split_in_two`, then the disk
/// guarantee), the mesh is validated again with the cut (no merge-back, so the halves stay
/// apart) and packed, and the cut is kept when the estimated efficiency (Σ chart area × density²
/// over the page area: the packer places each chart at exactly that UV area) rises by at least
/// [`PACKING_CUT_MIN_GAIN`]; otherwise the next largest chart is tried, up to
/// [`PACKING_CUT_MAX_TRIES`] tries; when no single cut paid and there are at most
/// [`PACKING_CUT_ALL_MAX_CHARTS`] charts, every chart is cut at once (then every piece again, up to [`PACKING_CUT_ALL_LEVELS`] levels), the last tries. Only with [`TexelDensity::FitToPage`] (an explicit density
/// does not change with the cut). Deterministic (every step is). Returns the charts to use and the
/// number of cuts kept.
pub(super) fn cut_for_packing(
    mesh: &TriangleMesh,
    validated: parameterize::ParameterizedCharts,
    options: &AtlasOptions,
) -> Result<(parameterize::ParameterizedCharts, usize, Option<Packing>), AtlasError> {
    if options.pack.density != TexelDensity::FitToPage || mesh.num_faces() > PACKING_CUT_MAX_FACES {
        return Ok((validated, 0, None));
    }
    let page = f64::from(options.pack.width_texels) * f64::from(options.pack.height_texels);
    // The charts of `v` to pack (not degenerate) and their total 3-D area.
    let packed_of = |inputs: &super::pack_input::PackInputs| -> (Vec<usize>, f64) {
        let packed: Vec<usize> = (0..inputs.degenerate.len())
            .filter(|&i| !inputs.degenerate[i])
            .collect();
        let total = packed.iter().map(|&i| inputs.area_m2[i]).sum();
        (packed, total)
    };
    // The estimated efficiency of `v`'s packing, its number of packed charts, and the packing
    // (None above PACKING_CUT_MAX_CHARTS charts, where no cut is tried). The density search
    // starts at `start` when given.
    let estimate = |v: &parameterize::ParameterizedCharts,
                    start: Option<f64>|
     -> Result<(f64, usize, Option<Packing>), AtlasError> {
        let inputs = pack_inputs(mesh, v)?;
        let (packed, total) = packed_of(&inputs);
        let n = packed.len();
        if n == 0 || n > PACKING_CUT_MAX_CHARTS {
            return Ok((1.0, n, None));
        }
        let input = pack_charts_of(v, &packed, &inputs.triangles, &inputs.area_m2);
        let packing = pack_charts_from(
            &input,
            &options.pack,
            start,
            &mut StageProgress::ignored(Stage::Pack),
        )?;
        Ok((
            total * packing.texels_per_unit.powi(2) / page,
            n,
            Some(packing),
        ))
    };
    // The density at which `v`'s charts would pack at efficiency `goal`, when one page holds
    // them there (one packing at that fixed density, two when the horizons need a second page:
    // a cheap test before the full search of `estimate`).
    let fits_at =
        |v: &parameterize::ParameterizedCharts, goal: f64| -> Result<Option<f64>, AtlasError> {
            let inputs = pack_inputs(mesh, v)?;
            let (packed, total) = packed_of(&inputs);
            if packed.is_empty() || total.is_nan() || total <= 0.0 {
                return Ok(None);
            }
            let density = (goal * page / total).sqrt();
            let input = pack_charts_of(v, &packed, &inputs.triangles, &inputs.area_m2);
            let fixed = PackOptions {
                density: TexelDensity::TexelsPerUnit(density),
                ..options.pack
            };
            match pack_charts(&input, &fixed, &mut StageProgress::ignored(Stage::Pack)) {
                Ok(p) if p.num_pages == 1 => Ok(Some(density)),
                Ok(_) | Err(PackError::ChartTooLarge { .. }) => Ok(None),
                Err(e) => Err(e.into()),
            }
        };
    // A candidate's efficiency and packing when they beat `best` by `PACKING_CUT_MIN_GAIN`: the
    // full search runs only when the candidate fits at the efficiency that would keep it.
    let try_candidate = |v: &parameterize::ParameterizedCharts,
                         best: f64|
     -> Result<Option<(f64, Option<Packing>)>, AtlasError> {
        let goal = best + PACKING_CUT_MIN_GAIN;
        let Some(density) = fits_at(v, goal)? else {
            return Ok(None);
        };
        let (eff, _, packing) = estimate(v, Some(density))?;
        Ok((eff >= goal).then_some((eff, packing)))
    };
    let (mut best, n, mut best_packing) = estimate(&validated, None)?;
    if n == 0 || n > PACKING_CUT_MAX_CHARTS || best >= PACKING_CUT_BELOW {
        return Ok((validated, 0, best_packing));
    }
    let mut current = validated;
    let mut cuts = 0;
    let mut tried: Vec<Vec<crate::mesh::FaceId>> = Vec::new();
    let validate_options = parameterize::ParameterizeOptions {
        merge_passes: 0,
        ..options.parameterize
    };
    // `current` with the charts `picks` each cut in two, validated again.
    let cut = |current: &parameterize::ParameterizedCharts,
               picks: &[usize]|
     -> Result<parameterize::ParameterizedCharts, AtlasError> {
        let charts = &current.segmentation.charts;
        let mut stats = current.segmentation.stats;
        let mut proposed: Vec<Vec<crate::mesh::FaceId>> = Vec::new();
        for (i, faces) in charts.iter().enumerate() {
            if !picks.contains(&i) {
                proposed.push(faces.clone());
                continue;
            }
            let inside = |f: crate::mesh::FaceId| faces.binary_search(&f).is_ok();
            let (a, b) = segment::split_in_two(mesh, faces, &inside);
            proposed.extend(segment::enforce_disks(mesh, vec![a, b], &mut stats));
        }
        let seg = segment::finish(mesh, proposed, stats);
        Ok(parameterize::parameterize_charts(
            mesh,
            &seg,
            &validate_options,
            &mut StageProgress::ignored(Stage::Parameterize),
        )?)
    };
    let area = |c: &[crate::mesh::FaceId]| -> f64 { c.iter().map(|&f| mesh.face_area_m2(f)).sum() };
    for _ in 0..PACKING_CUT_MAX_TRIES {
        if best >= PACKING_CUT_BELOW {
            break;
        }
        // The largest-area chart of at least 2 faces not tried yet.
        let charts = &current.segmentation.charts;
        let Some(pick) = (0..charts.len())
            .filter(|&i| charts[i].len() >= 2 && !tried.contains(&charts[i]))
            .max_by(|&a, &b| {
                area(&charts[a])
                    .total_cmp(&area(&charts[b]))
                    .then(b.cmp(&a))
            })
        else {
            break;
        };
        tried.push(charts[pick].clone());
        let candidate = cut(&current, &[pick])?;
        if let Some((eff, packing)) = try_candidate(&candidate, best)? {
            best = eff;
            best_packing = packing;
            cuts += 1;
            current = candidate;
            tried.clear();
        }
    }
    // No single cut paid (e.g. a tube in four equal strips, where cutting one strip leaves an
    // irregular set): the last tries cut every chart of at least 2 faces at once, and when that
    // does not pay either, every piece once more, up to `PACKING_CUT_ALL_LEVELS` levels (a 2:1
    // rectangle cut into two squares packs no better on a square page; its quarters do).
    if cuts == 0 && best < PACKING_CUT_BELOW && n <= PACKING_CUT_ALL_MAX_CHARTS {
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
            let candidate = cut(base, &picks)?;
            let cut_now = cut_before + picks.len();
            if let Some((_, packing)) = try_candidate(&candidate, best)? {
                cuts = cut_now;
                best_packing = packing;
                current = candidate;
                break;
            }
            level = Some((candidate, cut_now));
        }
    }
    Ok((current, cuts, best_packing))
}
