//! The loop of the parameterize stage ([`parameterize_charts`]): Lévy et al. 2002 §3.3,
//! "validate charts".
//!
//! Purpose: flatten every chart of the segmentation and split each chart whose map is not
//! usable, until every chart is valid; then merge valid charts back into a neighbour while the
//! union stays valid. A map is not usable when it has (tests in [`super::defects`]):
//! - a **flipped triangle** (LSCM cannot flip in exact arithmetic, §2.6 and A.5, but HLSCM and
//!   rounding can): split from the ends of a diameter of the chart's face graph;
//! - a **boundary self-intersection** in UV (the overlaps of §3.3, Figure 6) or a **fold at a
//!   vertex** (UV angles around it past a full turn): re-grown in two from the faces of the two
//!   crossing segments, or of the vertex's fan (the paper cuts along the border of the
//!   overlapped zone; re-growing is the simpler alternative);
//! - too much **area distortion**: the chart's Sander L2 stretch above
//!   [`ParameterizeOptions::max_stretch`] (the default), or the paper's test, max / min of the
//!   per-face model area per UV area above [`ParameterizeOptions::max_area_ratio`]
//!   ([`ParameterizeOptions::paper`]); split from the faces of smallest and largest ratio, as in
//!   the paper, or lengthwise when the chart is sock-shaped ([`super::sock`]).
//!
//!   Deviation from the paper: the default bounds the stretch instead of max / min, which single
//!   outlier faces decide (it over-splits scanned meshes); the stretch bound is area-weighted,
//!   measures what the report measures, and bounds the atlas' global L2 stretch by construction.
//!
//! With the stretch optimisation on ([`ParameterizeOptions::stretch_optimization`], `Global` by
//! default), the stretch bounds are tested on the map the optimisation makes: a freshly flattened
//! chart that fails them first goes through its global descent (`degenerate`'s flattening, via
//! `stretch::descend_for_bound`) and is tested again, so a chart the descent brings under the
//! bounds is neither split nor refused as a merge. Last, every valid chart's map is optimised for
//! stretch (`optimize_stretch_charts`, `super::stretch`); it keeps every guarantee above and never
//! raises a chart's L2 or L∞.
//!
//! Every part is passed through the disk guarantee again, so the result still satisfies the
//! segmentation contract. A part first tries its parent's map restricted to it
//! (`warm_start`); zero-area faces are handled by `degenerate`. A chart the
//! parameterizer rejects for another reason is split by diameter; a single face that still
//! fails keeps the line map and is listed in `unresolved` as
//! [`ChartDefect::Unparameterizable`]. So no chart is ever left without a map.
//!
//! Invariants: terminates — each split makes one more chart, a single triangle never splits,
//! and the number of splits is bounded by the face count. Deterministic: the charts of one round
//! are flattened in parallel (pure functions of the chart and its parent's map) and consumed in
//! chart order; the merge-back is sequential, and its speculative parallel flattening
//! (`schedule`) uses a result only under the exact chart versions it was queued for.
//!
//! Units: area ratios are plain ratios (model area per UV area, divided by its minimum over the
//! chart); UVs in model units, as the parameterizer returns them.
//!
//! References: B. Lévy, S. Petitjean, N. Ray, J. Maillot, "Least Squares Conformal Maps for
//! Automatic Texture Atlas Generation", SIGGRAPH 2002, §3.3 (area-ratio threshold 2).
use std::sync::Arc;

use super::asp::{relax_chart_asp_hierarchical, AspStats, MAX_SWEEPS};
use super::defects::find_defect;
use super::defects::ChartDefect;
use super::degenerate::{
    flatten_around_degenerate, line_map, place_on_zero_area_faces, split_off_degenerate, Attempt,
};
use super::merge::merge_back;
use super::options::Parameterization;
use super::schedule::in_parallel_largest_first;
use super::split::split_for;
use super::stretch::{
    optimize_chart_stretch, zero_model_area, ChartStretchOutcome, StretchChart,
    StretchOptimization, StretchStats,
};
use super::warm_start::restrict_map;
use super::{chart_mesh, conformal_energy, flipped_faces};
use super::{LocatedMap, ParameterizeChartsError, ParameterizeOptions};
use crate::atlas::progress::StageProgress;
use crate::atlas::segment::{disk_check, enforce_disks, finish, SegmentStats, Segmentation};
use crate::mesh::{FaceId, TriangleMesh};
use rayon::prelude::*;

/// The validated charts and their maps.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterizedCharts {
    /// The final charts (each a disk; see [`Segmentation`]).
    pub segmentation: Segmentation,
    /// The map of each chart (same order as `segmentation.charts`). **Contract:** every entry is
    /// `Some`, and its vertex list is exactly `chart_mesh(mesh, &segmentation.charts[i]).1`, so
    /// it covers every vertex of the chart's faces and `uv[l]` is the UV of the chart-local
    /// vertex `l` of [`chart_mesh`]'s triangles. (`Option` is kept for the stable type; `None`
    /// is never returned.) Zero-area faces map to (near-)degenerate UV triangles (module doc).
    pub maps: Vec<Option<LocatedMap>>,
    /// Charts returned although not valid: chart index and why. Such a chart still has a map
    /// (a single face that failed to flatten gets the fallback line map of the module doc).
    pub unresolved: Vec<(usize, ChartDefect)>,
    /// Splits made, by cause: flips, overlaps, area distortion (the area-ratio test or the
    /// stretch bound).
    pub splits: [usize; 3],
    /// Splits made because a chart without its zero-area faces was not a disk, or because the
    /// parameterizer failed on it (split by diameter).
    pub degenerate_splits: usize,
    /// Zero-area (or repeated-vertex) faces in the mesh, left out of every flattening and
    /// mapped from their neighbours' UVs.
    pub degenerate_faces: usize,
    /// Small charts merged back into a neighbour after splitting.
    pub merges: usize,
    /// What the stretch optimisation of the final maps did (`super::stretch`).
    pub stretch: StretchStats,
    /// What ASP did to the final maps (`super::asp`; zero with [`Parameterization::Lscm`]).
    pub asp: AspStats,
}

/// The parameterize stage: flattens every chart of `seg`, splits invalid ones until all are
/// valid, and merges valid charts back (module doc).
///
/// `progress` is advanced between charts with `(done, known)`: the charts finished so far and
/// the charts known so far (finished, queued, and parts of splits; it grows as charts are split,
/// and falls as the merge-back removes charts). `Break` stops the work and returns
/// [`ParameterizeChartsError::Cancelled`]. Progress does not change the result.
///
/// Errors: [`ParameterizeChartsError::InvalidOption`] (see [`ParameterizeOptions::check`]);
/// [`ParameterizeChartsError::Cancelled`].
/// Cost: one parameterization per chart, plus one per part after each split, plus one per
/// merge-back try. Charts of one round are flattened in parallel (rayon); results are consumed
/// in chart order, so the output does not depend on the thread count.
pub fn parameterize_charts(
    mesh: &TriangleMesh,
    seg: &Segmentation,
    options: &ParameterizeOptions,
    progress: &mut StageProgress<'_>,
) -> Result<ParameterizedCharts, ParameterizeChartsError> {
    options.check()?;
    let mut stats: SegmentStats = seg.stats;
    // Each pending chart carries the map of the chart it was split from, if any: its
    // restriction is tried before flattening (`restrict_map`, module doc "warm start").
    let mut pending: Vec<(Vec<FaceId>, Option<Arc<LocatedMap>>)> =
        seg.charts.iter().map(|c| (c.clone(), None)).collect();
    let mut done: Vec<(Vec<FaceId>, LocatedMap)> = Vec::new();
    let mut unresolved_faces: Vec<(FaceId, ChartDefect)> = Vec::new();
    let mut splits = [0usize; 3];
    let mut degenerate_splits = 0usize;
    let max_splits = mesh.num_faces();
    // Rounds: flatten every pending chart and split the invalid ones (in parallel: both are
    // pure functions of the chart and its parent's map, `process_chart`), then, in chart order,
    // keep the valid ones and queue the parts of the others for the next round.
    while !pending.is_empty() {
        for (faces, _) in &mut pending {
            faces.sort_unstable();
        }
        let steps = in_parallel_largest_first(&pending, |(faces, parent)| {
            process_chart(mesh, faces, parent.as_deref(), options)
        });
        let round = pending.len();
        let mut next: Vec<(Vec<FaceId>, Option<Arc<LocatedMap>>)> = Vec::new();
        for (k, ((faces, _), step)) in pending.into_iter().zip(steps).enumerate() {
            if progress
                .advance(done.len(), done.len() + round - k + next.len())
                .is_break()
            {
                return Err(ParameterizeChartsError::Cancelled);
            }
            // Never reached (each split makes one more chart and there are at most as many
            // charts as faces), but kept so that termination does not rest on that argument.
            let budget_left = splits.iter().sum::<usize>() + degenerate_splits < max_splits;
            match step {
                Step::Keep { map, defect } => {
                    if let Some(defect) = defect {
                        unresolved_faces.push((faces[0], defect));
                    }
                    done.push((faces, map));
                }
                Step::SplitDegenerate { parts, disk_splits } if budget_left => {
                    degenerate_splits += 1;
                    stats.disk_splits += disk_splits;
                    next.extend(parts.into_iter().map(|p| (p, None)));
                }
                Step::SplitDegenerate { .. } => {
                    let map = line_map(mesh, &faces);
                    done.push((faces, map));
                }
                Step::Split {
                    parts,
                    cause,
                    disk_splits,
                    map,
                    ..
                } if budget_left => {
                    match cause {
                        Some(cause) => splits[cause] += 1,
                        None => degenerate_splits += 1,
                    }
                    stats.disk_splits += disk_splits;
                    let parent = map.map(Arc::new);
                    next.extend(parts.into_iter().map(|p| (p, parent.clone())));
                }
                Step::Split { map, defect, .. } => {
                    // The split budget is spent: keep it, with a map.
                    unresolved_faces.push((faces[0], defect));
                    let map = map.unwrap_or_else(|| line_map(mesh, &faces));
                    done.push((faces, map));
                }
            }
        }
        pending = next;
    }
    let unresolved: std::collections::BTreeSet<FaceId> =
        unresolved_faces.iter().map(|(f, _)| *f).collect();
    let merges = merge_back(mesh, &mut done, &unresolved, options, progress)?;
    // Order by lowest face like `segment_charts`, keeping maps aligned. Every chart's faces are
    // already ascending, and its map is in `chart_mesh` order of those faces.
    done.sort_by_key(|(faces, _)| faces[0]);
    let charts: Vec<Vec<FaceId>> = done.iter().map(|(f, _)| f.clone()).collect();
    let segmentation = finish(mesh, charts, stats);
    let unresolved = unresolved_faces
        .into_iter()
        .map(|(f, d)| (segmentation.face_chart[f].index(), d))
        .collect();
    let degenerate_faces = mesh
        .faces()
        .filter(|&f| mesh.face_degeneracy(f).is_some())
        .count();
    let mut result = ParameterizedCharts {
        segmentation,
        maps: done.into_iter().map(|(_, m)| Some(m)).collect(),
        unresolved,
        splits,
        degenerate_splits,
        degenerate_faces,
        merges,
        stretch: StretchStats::default(),
        asp: AspStats::default(),
    };
    // On the final valid maps: ASP (a map is kept only when it passes the stage's tests).
    if options.parameterization == Parameterization::Asp {
        result.asp = relax_asp_charts(mesh, &mut result, options);
    }
    // Last, on the final valid maps: the stretch optimisation (it keeps every guarantee).
    result.stretch = optimize_stretch_charts(
        mesh,
        &mut result,
        options.stretch_optimization,
        options.stretch_passes,
    );
    Ok(result)
}

/// What one round does with one chart (`process_chart`).
pub(super) enum Step {
    /// Keep the chart with this map; with a defect when it is invalid but cannot be split
    /// (one face), listed in `unresolved`.
    Keep {
        map: LocatedMap,
        defect: Option<ChartDefect>,
    },
    /// The chart without its zero-area faces is not a disk: these parts (`split_off_degenerate`),
    /// flattened from scratch. `disk_splits` is what the disk guarantee added to the stats.
    SplitDegenerate {
        parts: Vec<Vec<FaceId>>,
        disk_splits: usize,
    },
    /// The chart's map has `defect`: these parts (disks, faces ascending), each first given the
    /// restriction of `map` (module doc, "warm start"). `cause` is the `splits` index (`None`:
    /// a parameterizer failure, split by diameter).
    Split {
        parts: Vec<Vec<FaceId>>,
        cause: Option<usize>,
        disk_splits: usize,
        map: Option<LocatedMap>,
        defect: ChartDefect,
    },
}

/// Flattens the chart `faces` (ascending; first the restriction of `parent`'s map when there is
/// one) and, when the map has a defect, splits it. Pure (no shared state: chart membership is
/// by binary search in `faces`), so the charts of a round are processed in parallel.
pub(super) fn process_chart(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    parent: Option<&LocatedMap>,
    options: &ParameterizeOptions,
) -> Step {
    let outcome = parent
        .and_then(|p| restrict_map(mesh, faces, p, options))
        .map(|map| Attempt::Mapped { map, defect: None })
        .unwrap_or_else(|| flatten_around_degenerate(mesh, faces, options));
    let (map, defect) = match outcome {
        Attempt::Mapped { map, defect } => (Some(map), defect),
        Attempt::NotADiskWithoutDegenerate => {
            let mut stats = SegmentStats::default();
            let parts = split_off_degenerate(mesh, faces, &mut stats);
            return Step::SplitDegenerate {
                parts,
                disk_splits: stats.disk_splits,
            };
        }
        Attempt::Failed(e) => (None, Some(ChartDefect::Unparameterizable(e))),
    };
    let Some(defect) = defect else {
        let map = map.unwrap_or_else(|| line_map(mesh, faces));
        return Step::Keep { map, defect: None };
    };
    let parts = if faces.len() >= 2 {
        split_for(mesh, faces, &defect)
    } else {
        None
    };
    let Some((pa, pb, cause)) = parts else {
        // Cannot split (one face): keep it, with a map.
        let map = map.unwrap_or_else(|| line_map(mesh, faces));
        return Step::Keep {
            map,
            defect: Some(defect),
        };
    };
    let mut stats = SegmentStats::default();
    let parts = enforce_disks(mesh, vec![pa, pb], &mut stats)
        .into_iter()
        .map(|mut part| {
            part.sort_unstable();
            debug_assert!(disk_check(mesh, &part, &|f| part.binary_search(&f).is_ok()).is_ok());
            part
        })
        .collect();
    Step::Split {
        parts,
        cause,
        disk_splits: stats.disk_splits,
        map,
        defect,
    }
}

/// One chart's result: its index, its new UVs and conformal energy when a move was kept, and
/// the outcome.
type ChartResult = (usize, Option<(Vec<[f64; 2]>, f64)>, ChartStretchOutcome);

/// Optimises every chart of `v` (`super::stretch`) with `passes` passes of each phase; charts in
/// parallel, results in chart order (deterministic). Charts with a defect listed in
/// `v.unresolved` other than a bound are left alone, as are charts made only of zero-area
/// faces.
pub(super) fn optimize_stretch_charts(
    mesh: &TriangleMesh,
    v: &mut ParameterizedCharts,
    method: StretchOptimization,
    passes: u32,
) -> StretchStats {
    let mut stats = StretchStats::default();
    let passes = match method {
        StretchOptimization::None => return stats,
        StretchOptimization::Global => 0,
        StretchOptimization::LinfL2 => passes,
    };
    let bad: Vec<usize> = v
        .unresolved
        .iter()
        .filter(|(_, d)| {
            !matches!(
                d,
                ChartDefect::Stretch { .. } | ChartDefect::AreaRatio { .. }
            )
        })
        .map(|(c, _)| *c)
        .collect();
    let charts = &v.segmentation.charts;
    let mut order: Vec<usize> = (0..charts.len()).filter(|i| !bad.contains(i)).collect();
    // Largest first, so that a big chart does not start last; results go back by index.
    order.sort_by_key(|&i| (std::cmp::Reverse(charts[i].len()), i));
    let results: Vec<ChartResult> = order
        .into_par_iter()
        .with_max_len(1)
        .map(|i| {
            let faces = &charts[i];
            let Some((map, _)) = v.maps[i].as_ref() else {
                return (i, None, ChartStretchOutcome::default());
            };
            let (cm, _) = chart_mesh(mesh, faces);
            let zero_area: Vec<bool> = faces
                .iter()
                .zip(&cm.triangles)
                .map(|(&f, t)| mesh.face_degeneracy(f).is_some() || zero_model_area(&cm, t))
                .collect();
            if zero_area.iter().all(|&z| z) || map.uv.len() != cm.positions_m.len() {
                return (i, None, ChartStretchOutcome::default());
            }
            let mut uv = map.uv.clone();
            let chart = StretchChart {
                positions_m: &cm.positions_m,
                triangles: &cm.triangles,
                zero_area: &zero_area,
            };
            let outcome = optimize_chart_stretch(&chart, &mut uv, passes);
            if outcome.moves == 0 && outcome.global_steps == 0 {
                return (i, None, outcome);
            }
            follow_zero_area_faces(&cm, &zero_area, &mut uv);
            let energy = solid_conformal_energy(&cm, &zero_area, &uv);
            (i, Some((uv, energy)), outcome)
        })
        .collect();
    let mut by_chart: Vec<Option<ChartResult>> = (0..charts.len()).map(|_| None).collect();
    for r in results {
        let i = r.0;
        by_chart[i] = Some(r);
    }
    for (i, r) in by_chart.into_iter().enumerate() {
        let Some((_, new, outcome)) = r else {
            continue;
        };
        if outcome.optimized {
            stats.charts_optimized += 1;
        } else if v.maps[i].is_some() {
            stats.charts_skipped += 1;
        }
        stats.moves += outcome.moves;
        stats.passes_undone += outcome.passes_undone;
        if let (Some((uv, energy)), Some((map, _))) = (new, v.maps[i].as_mut()) {
            map.uv = uv;
            map.conformal_energy = energy;
        }
    }
    stats
}

/// Puts back every vertex that only zero-area faces use (the optimiser does not move it, but it
/// moves their other corners) by `degenerate`'s rule, so that those faces stay degenerate in UV
/// as they are in 3-D (`super::degenerate`'s module doc).
fn follow_zero_area_faces(cm: &super::ChartMesh, zero_area: &[bool], uv: &mut [[f64; 2]]) {
    let zero_tris: Vec<usize> = (0..zero_area.len()).filter(|&k| zero_area[k]).collect();
    if zero_tris.is_empty() {
        return;
    }
    let mut placed: Vec<Option<[f64; 2]>> = vec![None; uv.len()];
    for (t, _) in cm.triangles.iter().zip(zero_area).filter(|(_, &z)| !z) {
        for &v in t {
            placed[v as usize] = Some(uv[v as usize]);
        }
    }
    place_on_zero_area_faces(cm, &zero_tris, &mut placed);
    for (p, q) in uv.iter_mut().zip(placed) {
        if let Some(q) = q {
            *p = q;
        }
    }
}

/// The conformal energy of `uv` over the faces of positive area (not `zero_area`), as the
/// parameterizer measures it: zero-area faces have none (their `1/√d_T` weight is infinite, and
/// the energy over them is NaN).
fn solid_conformal_energy(cm: &super::ChartMesh, zero_area: &[bool], uv: &[[f64; 2]]) -> f64 {
    let solid = super::ChartMesh {
        positions_m: cm.positions_m.clone(),
        triangles: cm
            .triangles
            .iter()
            .zip(zero_area)
            .filter(|(_, &z)| !z)
            .map(|(t, _)| *t)
            .collect(),
    };
    conformal_energy(&solid, uv)
}

/// One chart's ASP result: its index, its new UVs and conformal energy when kept, the outcome.
type AspResult = (usize, Option<(Vec<[f64; 2]>, f64)>, super::AspOutcome);

/// Relaxes every valid chart's map of `v` for ASP (`super::asp`) with θ =
/// `options.asp_theta`; charts in parallel, results in chart order (deterministic). A relaxed
/// map replaces the chart's map only when it passes the stage's tests (`find_defect`: flips,
/// boundary crossings, folds, and the stretch or area-ratio bound); charts with zero-area faces
/// (which `find_defect`'s chart validation rejects) are checked against the L2 and L∞ bounds
/// with `stretch::chart_stretch` instead, and left alone under the area-ratio test; their
/// vertices that only zero-area faces use follow those faces (`follow_zero_area_faces`). Charts
/// listed in `v.unresolved` are left alone.
pub(super) fn relax_asp_charts(
    mesh: &TriangleMesh,
    v: &mut ParameterizedCharts,
    options: &ParameterizeOptions,
) -> AspStats {
    let mut stats = AspStats::default();
    let bad: Vec<usize> = v.unresolved.iter().map(|(c, _)| *c).collect();
    let charts = &v.segmentation.charts;
    let mut order: Vec<usize> = (0..charts.len()).filter(|i| !bad.contains(i)).collect();
    // Largest first, so that a big chart does not start last; results go back by index.
    order.sort_by_key(|&i| (std::cmp::Reverse(charts[i].len()), i));
    let maps = &v.maps;
    let results: Vec<AspResult> = order
        .into_par_iter()
        .with_max_len(1)
        .map(|i| {
            let faces = &charts[i];
            let none = (i, None, super::AspOutcome::default());
            let Some((map, _)) = maps[i].as_ref() else {
                return none;
            };
            let (cm, _) = chart_mesh(mesh, faces);
            let zero_area: Vec<bool> = faces
                .iter()
                .zip(&cm.triangles)
                .map(|(&f, t)| mesh.face_degeneracy(f).is_some() || zero_model_area(&cm, t))
                .collect();
            if map.uv.len() != cm.positions_m.len() {
                return none;
            }
            let mut uv = map.uv.clone();
            let chart = StretchChart {
                positions_m: &cm.positions_m,
                triangles: &cm.triangles,
                zero_area: &zero_area,
            };
            let outcome =
                relax_chart_asp_hierarchical(&chart, &mut uv, options.asp_theta, MAX_SWEEPS);
            if !outcome.relaxed {
                return (i, None, outcome);
            }
            follow_zero_area_faces(&cm, &zero_area, &mut uv);
            let passes = match cm.validate() {
                Ok(topology) => {
                    let mut candidate = map.clone();
                    candidate.flipped_faces = flipped_faces(&cm, &uv);
                    candidate.uv = uv.clone();
                    find_defect(faces, &cm, &topology.boundary_loop, &candidate, options).is_none()
                }
                Err(_) => {
                    options.max_area_ratio.is_none()
                        && super::stretch::chart_stretch(&chart, &uv).is_some_and(|(l2, linf)| {
                            options.max_stretch.is_none_or(|bound| l2 <= bound)
                                && options.max_linf.is_none_or(|bound| linf <= bound)
                        })
                }
            };
            if !passes {
                return (i, None, outcome);
            }
            let energy = solid_conformal_energy(&cm, &zero_area, &uv);
            (i, Some((uv, energy)), outcome)
        })
        .collect();
    let mut by_chart: Vec<Option<AspResult>> = (0..charts.len()).map(|_| None).collect();
    for r in results {
        let i = r.0;
        by_chart[i] = Some(r);
    }
    for (i, r) in by_chart.into_iter().enumerate() {
        let Some((_, new, outcome)) = r else {
            continue;
        };
        match (new, v.maps[i].as_mut()) {
            (Some((uv, energy)), Some((map, _))) => {
                map.uv = uv;
                map.conformal_energy = energy;
                stats.charts_relaxed += 1;
                stats.moves += outcome.moves;
                stats.sweeps += outcome.sweeps;
            }
            _ => stats.charts_kept_lscm += 1,
        }
    }
    stats
}
