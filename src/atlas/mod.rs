//! The atlas pipeline: pure, synchronous and deterministic.
//!
//! [`generate`] is the one call that joins the geometry core to the service and the CLI, and
//! this file holds only the stage order: segment → parameterize → pack → measure. Each stage is
//! one function of the previous stage's output and its own options:
//! - [`segment`]: `segment_charts` cuts a [`TriangleMesh`] into charts that are each a topological
//!   disk (Lévy et al. 2002 §3.1–3.2);
//! - [`parameterize`]: `parameterize_charts` flattens every chart (LSCM, Lévy et al. 2002 §2;
//!   hierarchical LSCM, Ray & Lévy 2003) and splits and merges charts until every map is valid
//!   (§3.3); last, optionally, every valid map's stretch is optimised (Sander et al. 2001,
//!   `stretch.rs`);
//! - [`pack`]: `pack_charts` places the flattened charts on texture pages at one texel density,
//!   with padding (the horizon packer, Lévy et al. 2002 §4, from four directions with rotations,
//!   Zhou et al. 2004 §6). At the stage's start, on small meshes with few charts that pack
//!   poorly, the packing-aware cuts (`packing_cuts.rs`, a feedback loop into the parameterize
//!   stage) cut charts in two when that raises the packing efficiency; the packer's input is
//!   built in `pack_input.rs`, and charts made only of degenerate faces get their UVs in
//!   `degenerate.rs`.
//!   After packing, the written `f32` corner UVs pass the flip promise's last line of defence
//!   (`uv_guard.rs`): by the report's own rules, a 3-D-degenerate face with UV area is collapsed
//!   to a segment, a flipped or UV-degenerate face with 3-D area has one UV vertex nudged by a
//!   few `f32` spacings, and a face no nudge repairs is split off into a chart of its own and the
//!   charts packed again. **Guarantee:** the atlas has no flipped face and no face degenerate in
//!   UV but not in 3-D, by the report and by the evaluator, on every input (degenerate,
//!   near-degenerate and non-manifold parts included); the report shows the counts, so a
//!   violation would never be hidden;
//! - [`measure`]: `measure_atlas`, the quality report, with its definitions.
//!
//! Progress and cancellation: one [`Progress`] from the caller, seen by each stage through a
//! [`StageProgress`]. Errors: [`AtlasError`] (`error.rs`).
//!
//! Invariant: no IO, no serde, no wall-clock time, no logging; same input, same output bits
//! whatever the thread count (`tests/architecture.rs` checks the `use` lines). Stage timings are
//! measured by the caller through [`Progress`].
mod degenerate;
mod error;
pub mod measure;
pub mod options;
pub mod pack;
mod pack_input;
mod packing_cuts;
pub mod parameterize;
pub mod progress;
pub mod segment;
mod uv_guard;

use std::ops::ControlFlow;

pub use error::AtlasError;
pub use measure::{measure_atlas, AtlasReport, MeasureInput};
pub use options::AtlasOptions;
pub use pack::{pack_charts, PackChart, PackError, PackOptions, TexelDensity};
pub use progress::{NoProgress, Progress, ProgressFn, Stage, StageProgress};

use crate::mesh::{FaceId, TriangleMesh};
use degenerate::place_degenerate;
use pack_input::{pack_charts_of, pack_inputs, PackInputs};
use packing_cuts::cut_for_packing;
use parameterize::{parameterize_charts, ChartDefect};
use segment::{segment_charts_with, SegmentMethod};
use uv_guard::{folds, guard_uvs, raster_slivers, restore_slivers, split_off, torn_parts};

/// Counters of one [`generate`] run.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PipelineStats {
    /// Charts proposed by segmentation (after its disk guarantee).
    pub segmented_charts: usize,
    /// Splits made by the parameterize stage: flips, UV boundary overlaps, area ratio.
    pub parameterize_splits: [usize; 3],
    /// Small charts merged back by the parameterize stage.
    pub parameterize_merges: usize,
    /// Charts added by the pack stage's cuts (`cut_for_packing`): cuts that raised the packing
    /// efficiency, or at a fixed density the pieces of charts too large for a page.
    pub packing_cuts: usize,
    /// Charts kept although their stretch or area ratio is above the bound (could not be split
    /// further).
    pub bound_unresolved: usize,
    /// Charts flattened by the direct solve and by HLSCM.
    pub charts_direct: usize,
    /// See `charts_direct`.
    pub charts_hierarchical: usize,
    /// The texel density used, texels per model unit.
    pub texels_per_unit: f64,
    /// Packings run to choose the density ([`pack::Packing::trials`]: 1 at a fixed density; with
    /// fit-to-page, every trial density, hole filling's included), a cost diagnostic.
    pub pack_trials: u32,
    /// Charts made only of degenerate faces (zero area or a repeated vertex): not packed, their
    /// corners take the UV of a coincident vertex of a packed chart (see [`generate`]).
    pub degenerate_charts: usize,
    /// The segmentation method that ran.
    pub segmentation: SegmentMethod,
    /// Charts split by the stretch segmentation's spectral clustering.
    pub spectral_splits: usize,
    /// Faces the border smoothing moved into the chart they stuck into, at the end of
    /// segmentation (`segment/smooth.rs`; the smoothing inside later splits is not counted).
    pub border_faces_smoothed: usize,
    /// The stretch optimisation that ran on the final maps (`parameterize::stretch`).
    pub stretch_optimization: parameterize::StretchOptimization,
    /// What it did: charts optimised and skipped, vertex moves kept.
    pub stretch: parameterize::StretchStats,
    /// The parameterization of the final maps (`lscm`, or `asp` with θ; `parameterize::asp`).
    pub parameterization: parameterize::Parameterization,
    /// ASP's θ when `parameterization` is ASP.
    pub asp_theta: Option<f64>,
    /// What ASP did: charts whose relaxed map was kept, charts that kept their LSCM map.
    pub asp: parameterize::AspStats,
    /// The last line of defence (`uv_guard.rs`): 3-D-degenerate faces whose written UV triangle
    /// had area and was collapsed to a segment.
    pub uv_collapsed_faces: usize,
    /// ... UV vertices moved by a few `f32` spacings to unflip a face with 3-D area, or to give
    /// a sliver back the UV height rounding took from it (`uv_guard/slivers.rs`).
    pub uv_nudged_vertices: usize,
    /// ... faces split off their chart (then packed again): faces that no nudge repaired or that
    /// overlapped another face of their chart (each into a chart of its own), and the parts of a
    /// chart that the output's connectivity tore apart (`uv_guard::torn_parts`).
    pub uv_guard_splits: usize,
}

/// The atlas of one mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Atlas {
    /// UVs of the 3 corners of each face of the mesh, in face and corner order: normalized page
    /// coordinates in \[0,1\]², as the `f32` values to be written to the file.
    pub corner_uvs: Vec<[[f32; 2]; 3]>,
    /// The chart of each face (index into the parameterized charts, ordered by lowest face).
    pub face_chart: Vec<u32>,
    /// The page of each chart.
    pub chart_page: Vec<u32>,
    /// The page of each face.
    pub face_page: Vec<u32>,
    /// Pages used.
    pub num_pages: u32,
    /// What happened on the way.
    pub stats: PipelineStats,
    /// The quality report, measured on `corner_uvs`.
    pub report: AtlasReport,
}

/// Runs the whole pipeline on `mesh`: segment → parameterize → pack → measure.
///
/// Degenerate faces: a chart made only of faces with zero area or a repeated vertex (the mesh
/// builder isolates the latter, so each arrives as a chart of its own) is not packed: it covers
/// nothing in 3-D, so it must cover nothing in UV. Each of its corners takes the UV (and page) of
/// a vertex of a packed chart at the bit-identical position in the same glTF mesh, or the page
/// origin when there is none; its UV image is then a point or a segment (zero UV area: never a
/// flip, never an overlap), and a face lying along an edge of a packed chart joins that chart.
///
/// Progress is reported per stage through `progress`, which can cancel at every checkpoint
/// ([`AtlasError::Cancelled`]). Deterministic: the same mesh and options give the same bits.
///
/// Errors: [`AtlasError::InvalidOption`] before any work; [`AtlasError::Unparameterizable`] when a
/// chart has no usable map; [`AtlasError::Pack`] when packing cannot place a chart.
pub fn generate(
    mesh: &TriangleMesh,
    options: &AtlasOptions,
    progress: &mut dyn Progress,
) -> Result<Atlas, AtlasError> {
    options.check()?;
    // The stretch-driven segmentation's bound also bounds the parameterize stage's, so that its
    // merge-back does not undo the splits.
    let bounded;
    let options = if options.segment.method == SegmentMethod::Stretch {
        let mut o = *options;
        let bound = o.segment.stretch.max_stretch;
        o.parameterize.max_stretch =
            Some(o.parameterize.max_stretch.map_or(bound, |m| m.min(bound)));
        bounded = o;
        &bounded
    } else {
        options
    };
    let check = |flow: ControlFlow<()>, stage: Stage| match flow {
        ControlFlow::Continue(()) => Ok(()),
        ControlFlow::Break(()) => Err(AtlasError::Cancelled { stage }),
    };

    // 1. Segment.
    progress.stage_started(Stage::Segment);
    let flatten = options.parameterize.flatten;
    let measure = move |faces: &[crate::mesh::FaceId]| flattened_l2_stretch(mesh, faces, &flatten);
    let seg = segment_charts_with(
        mesh,
        &options.segment,
        Some(&measure),
        &mut StageProgress::new(Stage::Segment, progress),
    )?;
    progress.stage_finished(Stage::Segment);

    // 2. Parameterize.
    progress.stage_started(Stage::Parameterize);
    check(
        progress.advance(Stage::Parameterize, 0, seg.num_charts()),
        Stage::Parameterize,
    )?;
    let parameterized = parameterize_charts(
        mesh,
        &seg,
        &options.parameterize,
        &mut StageProgress::new(Stage::Parameterize, progress),
    )?;
    let n = parameterized.segmentation.charts.len();
    check(
        progress.advance(Stage::Parameterize, n, n),
        Stage::Parameterize,
    )?;
    progress.stage_finished(Stage::Parameterize);

    // 3. Pack. First the packing-aware cuts (a feedback loop of the packer: they re-validate
    //    the cut charts and pack again), then the packing itself, reused from the cut step when
    //    it packed these very charts. Charts made only of degenerate faces (zero area, or a
    //    repeated vertex: such faces are isolated by the mesh builder and arrive as charts of
    //    their own) have nothing to texture; they take no page space and get their UVs
    //    afterwards (`place_degenerate`).
    progress.stage_started(Stage::Pack);
    let (parameterized, packing_cuts, packing_of_cut_step) =
        cut_for_packing(mesh, parameterized, options)?;
    let mut stats = PipelineStats {
        segmented_charts: seg.num_charts(),
        parameterize_splits: parameterized.splits,
        parameterize_merges: parameterized.merges,
        packing_cuts,
        segmentation: options.segment.method,
        spectral_splits: seg.stats.spectral_splits,
        border_faces_smoothed: seg.stats.border_faces_moved,
        stretch_optimization: options.parameterize.stretch_optimization,
        stretch: parameterized.stretch,
        parameterization: options.parameterize.parameterization,
        asp_theta: (options.parameterize.parameterization == parameterize::Parameterization::Asp)
            .then_some(options.parameterize.asp_theta),
        asp: parameterized.asp,
        ..PipelineStats::default()
    };
    for (chart, defect) in &parameterized.unresolved {
        match defect {
            ChartDefect::AreaRatio { .. } | ChartDefect::Stretch { .. } => {
                stats.bound_unresolved += 1
            }
            ChartDefect::Unparameterizable(e) => {
                return Err(AtlasError::Unparameterizable {
                    chart: *chart,
                    faces: parameterized.segmentation.charts[*chart].len(),
                    detail: e.to_string(),
                })
            }
            // Validation never leaves a flip or an overlap (its contract); if it ever did, the
            // measured report below shows it, so nothing is hidden.
            ChartDefect::Flipped { .. } | ChartDefect::BoundaryOverlap { .. } => {}
        }
    }
    for (map, _) in parameterized.maps.iter().flatten() {
        match map.method_used {
            parameterize::ParameterizeMethod::Hierarchical => stats.charts_hierarchical += 1,
            _ => stats.charts_direct += 1,
        }
    }
    // Pack and write the `f32` corner UVs, then the last line of defence (`uv_guard.rs`):
    // faults the guard cannot repair in place, and the parts of a chart that the output's
    // connectivity tears apart, are split off into charts of their own and the charts packed
    // again, at most `GUARD_SPLIT_ROUNDS` times; when faults are left after that, once more
    // with every sliver thin enough for the report's raster to flip
    // (`uv_guard::raster_slivers`).
    let mut parameterized = parameterized;
    let mut packing_of_cut_step = packing_of_cut_step;
    let mut round = 0;
    let (written, charts, reuse) = loop {
        let mut exact_found = None;
        let mut written = pack_and_write(
            mesh,
            &parameterized,
            packing_of_cut_step.take(),
            options,
            progress,
        )?;
        let (outcome, check) = guard_uvs(mesh, &mut written.corner_uvs, &written.face_page);
        stats.uv_collapsed_faces += outcome.collapsed_faces;
        stats.uv_nudged_vertices += outcome.nudged_vertices;
        let face_chart: Vec<u32> = parameterized
            .segmentation
            .face_chart
            .iter()
            .map(|(_, c)| c.index() as u32)
            .collect();
        let size = [options.pack.width_texels, options.pack.height_texels];
        let mut slivers = restore_slivers(mesh, &check, &mut written.corner_uvs, size);
        let single = |faces: Vec<FaceId>| -> Vec<Vec<FaceId>> {
            faces.into_iter().map(|f| vec![f]).collect()
        };
        let mut faults = single(outcome.unrepaired);
        // After the round that splits the slivers off too, nothing more is split.
        let last = round > GUARD_SPLIT_ROUNDS;
        if faults.is_empty() || last {
            // In the last round too, for the sliver moves at an overlap to be undone.
            let (overlapping, exact) = folds(
                mesh,
                &mut written.corner_uvs,
                (&written.face_page, written.packing.num_pages),
                size,
                &face_chart,
                &mut slivers,
            );
            if faults.is_empty() {
                faults = single(overlapping);
            }
            exact_found = exact;
        }
        if faults.is_empty() {
            faults = torn_parts(mesh, &check, &face_chart);
        }
        let moved = slivers.vertices_moved();
        stats.uv_nudged_vertices += moved;
        if faults.is_empty() || last {
            // The report reuses the guard's searches on these UVs: its exact overlaps, and its
            // orientation check, brought up to date where the sliver repair moved a vertex
            // since (undone moves put every corner back, bit for bit).
            let check = if moved == 0 {
                Some(check)
            } else {
                check.after_uv_moves(&written.corner_uvs, &written.face_page, &slivers.faces())
            };
            let reuse = measure::Reuse {
                exact: exact_found,
                check,
            };
            break (written, parameterized.segmentation.charts, reuse);
        }
        if round == GUARD_SPLIT_ROUNDS {
            // Faults are left after every split round: the last split takes every sliver that
            // the sampling's snapping could flip apart too (`uv_guard::raster_slivers`), so that
            // the last packing cannot lay another one over its neighbours.
            let mut taken = vec![false; mesh.num_faces()];
            for f in faults.iter().flatten() {
                taken[f.index()] = true;
            }
            let rasterized = raster_slivers(
                &check,
                &written.corner_uvs,
                size,
                &parameterized.segmentation.charts,
            );
            faults.extend(
                rasterized
                    .into_iter()
                    .filter(|f| !taken[f.index()])
                    .map(|f| vec![f]),
            );
        }
        stats.uv_guard_splits += faults.iter().map(Vec::len).sum::<usize>();
        parameterized = split_off(mesh, &parameterized, &faults, options)?;
        round += 1;
    };
    let Written {
        corner_uvs,
        face_page,
        chart_page,
        packing,
        degenerate_charts,
    } = written;
    stats.texels_per_unit = packing.texels_per_unit;
    stats.pack_trials = packing.trials;
    stats.degenerate_charts = degenerate_charts;
    let mut face_chart = vec![0u32; mesh.num_faces()];
    for (i, faces) in charts.iter().enumerate() {
        for &f in faces {
            face_chart[f.index()] = i as u32;
        }
    }
    progress.stage_finished(Stage::Pack);

    // 4. Measure.
    progress.stage_started(Stage::Measure);
    check(progress.advance(Stage::Measure, 0, 1), Stage::Measure)?;
    let input = MeasureInput {
        mesh,
        corner_uvs: &corner_uvs,
        face_page: &face_page,
        num_pages: packing.num_pages,
        width_texels: options.pack.width_texels,
        height_texels: options.pack.height_texels,
        padding_texels: options.pack.padding_texels,
    };
    let report = measure::measure_atlas_reusing(&input, reuse);
    check(progress.advance(Stage::Measure, 1, 1), Stage::Measure)?;
    progress.stage_finished(Stage::Measure);

    Ok(Atlas {
        corner_uvs,
        face_chart,
        chart_page,
        face_page,
        num_pages: packing.num_pages,
        stats,
        report,
    })
}

/// Splits of the last line of defence (`uv_guard.rs`) of the faults it finds, before one last
/// split that also takes every sliver apart (`uv_guard::raster_slivers`), after which the report
/// shows whatever is left. Each round packs again, which rounds every chart anew: a cylinder
/// with three needles 1e-7 long needed three rounds, one needle each (4,096 generated defective
/// meshes needed at most that); a fan of 1,000 faces 1e-6 thick still had crossings after 12,
/// each packing flipping other slivers in the report's raster. The bound caps the cost of a
/// pathological input (at most `GUARD_SPLIT_ROUNDS + 2` packings).
const GUARD_SPLIT_ROUNDS: usize = 4;

/// The written UVs of one packing.
struct Written {
    corner_uvs: Vec<[[f32; 2]; 3]>,
    face_page: Vec<u32>,
    chart_page: Vec<u32>,
    packing: pack::Packing,
    degenerate_charts: usize,
}

/// Packs the charts of `parameterized` (or takes `packing`, the packing of exactly these charts
/// by the packing-aware cuts) and writes each face's `f32` corner UVs and page; charts made
/// only of degenerate faces are not packed and get their UVs from `place_degenerate`.
fn pack_and_write(
    mesh: &TriangleMesh,
    parameterized: &parameterize::ParameterizedCharts,
    packing: Option<pack::Packing>,
    options: &AtlasOptions,
    progress: &mut dyn Progress,
) -> Result<Written, AtlasError> {
    let charts = &parameterized.segmentation.charts;
    let PackInputs {
        triangles: chart_triangles,
        area_m2: chart_area_m2,
        degenerate,
    } = pack_inputs(mesh, parameterized)?;
    let packed: Vec<usize> = (0..charts.len()).filter(|&i| !degenerate[i]).collect();
    let packing = match packing {
        // The cut step packed exactly these charts already (same inputs, deterministic).
        Some(p) => {
            if progress.advance(Stage::Pack, packed.len(), packed.len()) == ControlFlow::Break(()) {
                return Err(AtlasError::Cancelled { stage: Stage::Pack });
            }
            p
        }
        None => {
            let pack_input =
                pack_charts_of(parameterized, &packed, &chart_triangles, &chart_area_m2);
            pack_charts(
                &pack_input,
                &packing_cuts::pack_options(mesh, options),
                &mut StageProgress::new(Stage::Pack, progress),
            )?
        }
    };
    let mut corner_uvs = vec![[[0.0f32; 2]; 3]; mesh.num_faces()];
    let mut face_page = vec![0u32; mesh.num_faces()];
    let mut chart_page = vec![0u32; charts.len()];
    for (placed, &i) in packing.charts.iter().zip(&packed) {
        chart_page[i] = placed.page;
        for (&f, t) in charts[i].iter().zip(&chart_triangles[i]) {
            corner_uvs[f.index()] = t.map(|l| {
                let p = placed.uv[l as usize];
                [p[0] as f32, p[1] as f32]
            });
            face_page[f.index()] = placed.page;
        }
    }
    place_degenerate(
        mesh,
        charts,
        &degenerate,
        &mut corner_uvs,
        &mut face_page,
        &mut chart_page,
    );
    Ok(Written {
        corner_uvs,
        face_page,
        chart_page,
        degenerate_charts: charts.len() - packed.len(),
        packing,
    })
}

/// The Sander L2 stretch of the chart `faces`' flattening by the parameterize stage's solver (the
/// chart scaled to UV area = model area), `f64::INFINITY` when the map flips a face, `None` when
/// the chart cannot be flattened as it is (not a disk, a degenerate face: the parameterize stage
/// deals with it). The measure the stretch-driven segmentation splits by.
fn flattened_l2_stretch(
    mesh: &TriangleMesh,
    faces: &[crate::mesh::FaceId],
    flatten: &parameterize::FlattenOptions,
) -> Option<f64> {
    let (cm, _) = parameterize::chart_mesh(mesh, faces);
    let map =
        parameterize::flatten_chart(&cm, flatten, &mut StageProgress::ignored(Stage::Segment))
            .ok()?;
    if !map.is_valid() {
        return Some(f64::INFINITY);
    }
    let zero_area = vec![false; cm.triangles.len()];
    let chart = parameterize::StretchChart {
        positions_m: &cm.positions_m,
        triangles: &cm.triangles,
        zero_area: &zero_area,
    };
    Some(parameterize::stretch::chart_stretch(&chart, &map.uv).map_or(f64::INFINITY, |(l2, _)| l2))
}
