//! The atlas pipeline: pure, synchronous and deterministic.
//!
//! [`generate`] is the one call that joins the geometry core to the service and the CLI:
//! segment → parameterize + validate → pack → measure. Each stage is a function of the previous
//! stage's output and its own options:
//! - [`segment`]: `segment_charts` cuts a [`TriangleMesh`] into charts that are each a topological
//!   disk (Lévy et al. 2002 §3.1–3.2), and `parameterize_charts` flattens them with [`parameterize`]
//!   and splits those with flips, UV boundary crossings or too much area distortion (§3.3);
//!   then, on small meshes with few charts that pack poorly, `cut_for_packing` (in this file)
//!   cuts charts in two when that raises the packing efficiency (issue 5's 0.60 target; each cut
//!   kept only for a measured gain). It runs at the start of the pack stage (its packing is the
//!   stage's packing when no cut is kept), without a cancel checkpoint of its own (at most 5
//!   validations and packings of a mesh of ≤ 20k faces);
//! - [`parameterize`]: flattens one chart (LSCM, Lévy et al. 2002 §2; hierarchical LSCM, Ray &
//!   Lévy 2003);
//! - [`pack`]: places the flattened charts on texture pages at one texel density, with padding
//!   (the horizon packer, Lévy et al. 2002 §4, from four directions with rotations, Zhou et al.
//!   2004 §6);
//! - [`measure`]: the quality report, with the definitions of the independent evaluator.
//!
//! Invariant: no IO, no serde, no wall-clock time, no logging; same input, same output bits
//! whatever the thread count (`tests/architecture.rs` checks the `use` lines). Stage timings are
//! measured by the caller through [`Progress`].
pub mod measure;
pub mod options;
pub mod pack;
pub mod parameterize;
pub mod progress;
pub mod segment;

use std::ops::ControlFlow;

pub use measure::{measure_atlas, AtlasReport, MeasureInput};
pub use options::AtlasOptions;
pub use pack::{pack_charts, PackChart, PackError, PackOptions, TexelDensity};
pub use progress::{NoProgress, Progress, ProgressFn, Stage, StageProgress};

use crate::mesh::{TriangleMesh, VertexId};
use pack::Packing;
use parameterize::{parameterize_charts, ChartDefect, ParameterizeChartsError};
use segment::{segment_charts, SegmentError};

/// Errors of [`generate`]. Each says what is wrong and how to fix it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AtlasError {
    /// An option has a meaningless value.
    #[error("invalid option `{option}`: {detail}")]
    InvalidOption {
        /// The option's name, as on the wire (e.g. `padding_texels`).
        option: &'static str,
        /// What is wrong and what to use instead.
        detail: String,
    },
    /// The caller's [`Progress`] asked to stop.
    #[error("cancelled during the {} stage", .stage.name())]
    Cancelled {
        /// The stage that was running.
        stage: Stage,
    },
    /// A chart could not be flattened (e.g. all its triangles have zero area).
    #[error("chart {chart} ({faces} faces) could not be flattened: {detail}; repair or remove the degenerate triangles")]
    Unparameterizable {
        /// Index of the chart in the validated segmentation.
        chart: usize,
        /// Its face count.
        faces: usize,
        /// The parameterizer's reason.
        detail: String,
    },
    /// Packing failed (e.g. one chart is larger than a page at the requested density).
    #[error("packing failed: {0}")]
    Pack(PackError),
}

impl From<SegmentError> for AtlasError {
    fn from(e: SegmentError) -> Self {
        match e {
            SegmentError::InvalidOption { option, detail } => {
                AtlasError::InvalidOption { option, detail }
            }
            SegmentError::Cancelled => AtlasError::Cancelled {
                stage: Stage::Segment,
            },
        }
    }
}

impl From<ParameterizeChartsError> for AtlasError {
    fn from(e: ParameterizeChartsError) -> Self {
        match e {
            ParameterizeChartsError::InvalidOption { option, detail } => {
                AtlasError::InvalidOption { option, detail }
            }
            ParameterizeChartsError::Cancelled => AtlasError::Cancelled {
                stage: Stage::Parameterize,
            },
        }
    }
}

impl From<PackError> for AtlasError {
    fn from(e: PackError) -> Self {
        match e {
            // The packer names its options as the wire does, but for the density field.
            PackError::InvalidOption { option, detail } => AtlasError::InvalidOption {
                option: if option == "density" {
                    "texels_per_unit"
                } else {
                    option
                },
                detail,
            },
            PackError::Cancelled => AtlasError::Cancelled { stage: Stage::Pack },
            other => AtlasError::Pack(other),
        }
    }
}

/// Counters of one [`generate`] run.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PipelineStats {
    /// Charts proposed by segmentation (after its disk guarantee).
    pub segmented_charts: usize,
    /// Splits made by validation: flips, UV boundary overlaps, area ratio.
    pub validation_splits: [usize; 3],
    /// Small charts merged back by validation.
    pub validation_merges: usize,
    /// Charts cut in two because that raised the packing efficiency (`cut_for_packing`).
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
}

/// The atlas of one mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Atlas {
    /// UVs of the 3 corners of each face of the mesh, in face and corner order: normalized page
    /// coordinates in \[0,1\]², as the `f32` values to be written to the file.
    pub corner_uvs: Vec<[[f32; 2]; 3]>,
    /// The chart of each face (index into the validated charts, ordered by lowest face).
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

/// Runs the whole pipeline on `mesh`: segment → parameterize + validate → pack → measure.
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
    let check = |flow: ControlFlow<()>, stage: Stage| match flow {
        ControlFlow::Continue(()) => Ok(()),
        ControlFlow::Break(()) => Err(AtlasError::Cancelled { stage }),
    };

    // 1. Segment.
    progress.stage_started(Stage::Segment);
    let seg = segment_charts(
        mesh,
        &options.segment,
        &mut StageProgress::new(Stage::Segment, progress),
    )?;
    progress.stage_finished(Stage::Segment);

    // 2. Parameterize and validate.
    progress.stage_started(Stage::Parameterize);
    check(
        progress.advance(Stage::Parameterize, 0, seg.num_charts()),
        Stage::Parameterize,
    )?;
    let validated = parameterize_charts(
        mesh,
        &seg,
        &options.parameterize,
        &mut StageProgress::new(Stage::Parameterize, progress),
    )?;
    let n = validated.segmentation.charts.len();
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
    let (validated, packing_cuts, packing_of_cut_step) = cut_for_packing(mesh, validated, options)?;
    let charts = &validated.segmentation.charts;
    let mut stats = PipelineStats {
        segmented_charts: seg.num_charts(),
        validation_splits: validated.splits,
        validation_merges: validated.merges,
        packing_cuts,
        ..PipelineStats::default()
    };
    for (chart, defect) in &validated.unresolved {
        match defect {
            ChartDefect::AreaRatio { .. } | ChartDefect::Stretch { .. } => {
                stats.bound_unresolved += 1
            }
            ChartDefect::Unparameterizable(e) => {
                return Err(AtlasError::Unparameterizable {
                    chart: *chart,
                    faces: charts[*chart].len(),
                    detail: e.to_string(),
                })
            }
            // Validation never leaves a flip or an overlap (its contract); if it ever did, the
            // measured report below shows it, so nothing is hidden.
            ChartDefect::Flipped { .. } | ChartDefect::BoundaryOverlap { .. } => {}
        }
    }
    for (map, _) in validated.maps.iter().flatten() {
        match map.method_used {
            parameterize::ParameterizeMethod::Hierarchical => stats.charts_hierarchical += 1,
            _ => stats.charts_direct += 1,
        }
    }
    let PackInputs {
        triangles: chart_triangles,
        area_m2: chart_area_m2,
        degenerate,
    } = pack_inputs(mesh, &validated)?;
    let packed: Vec<usize> = (0..charts.len()).filter(|&i| !degenerate[i]).collect();
    let packing = match packing_of_cut_step {
        // The cut step packed exactly these charts already (same inputs, deterministic).
        Some(p) => {
            check(
                progress.advance(Stage::Pack, packed.len(), packed.len()),
                Stage::Pack,
            )?;
            p
        }
        None => {
            let pack_input = pack_charts_of(&validated, &packed, &chart_triangles, &chart_area_m2);
            pack_charts(&pack_input, &options.pack, &mut |(done, total)| {
                progress.advance(Stage::Pack, done, total)
            })?
        }
    };
    stats.texels_per_unit = packing.texels_per_unit;
    stats.pack_trials = packing.trials;
    stats.degenerate_charts = charts.len() - packed.len();
    let mut corner_uvs = vec![[[0.0f32; 2]; 3]; mesh.num_faces()];
    let mut face_chart = vec![0u32; mesh.num_faces()];
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
    for (i, faces) in charts.iter().enumerate() {
        for &f in faces {
            face_chart[f.index()] = i as u32;
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
    progress.stage_finished(Stage::Pack);

    // 4. Measure.
    progress.stage_started(Stage::Measure);
    check(progress.advance(Stage::Measure, 0, 1), Stage::Measure)?;
    let report = measure_atlas(&MeasureInput {
        mesh,
        corner_uvs: &corner_uvs,
        face_page: &face_page,
        num_pages: packing.num_pages,
        width_texels: options.pack.width_texels,
        height_texels: options.pack.height_texels,
        padding_texels: options.pack.padding_texels,
    });
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

/// `cut_for_packing` tries cuts only while the estimated packing efficiency is below this
/// (issue 5's target for every mesh is 0.60; the estimate matched the measured packing to 0.001
/// on the corpus meshes it ran on, so 0.01 is a margin). Not higher: spot packs at 0.619 uncut,
/// and a threshold of 0.62 cut all its 21 charts (42 charts for 0.636, +0.5 s).
const PACKING_CUT_BELOW: f64 = 0.61;
/// The last resort of `cut_for_packing` (every chart cut at once) runs only on atlases of at
/// most this many charts: it doubles the seams, which pays on a tube of 4 strips, not on 20
/// charts of a scan.
const PACKING_CUT_ALL_MAX_CHARTS: usize = 8;
/// ... and only on atlases of at most this many packed charts: with many charts the shapes
/// average out and a cut would not pay for its re-validation and re-packing.
const PACKING_CUT_MAX_CHARTS: usize = 32;
/// ... and only on meshes of at most this many faces: the check alone packs the mesh once more,
/// and each try validates and packs it again (measured on bunny, 69k faces and 28 charts: the
/// check alone added ~0.2 s to a 1 s pipeline, for a packing already at 0.638).
const PACKING_CUT_MAX_FACES: usize = 20_000;
/// A cut is kept only when it raises the estimated efficiency by at least this (absolute):
/// every seam costs texture continuity and gutter, so a marginal gain is not worth one.
const PACKING_CUT_MIN_GAIN: f64 = 0.02;
/// At most this many tries (each a validation and a packing of the whole mesh).
const PACKING_CUT_MAX_TRIES: usize = 4;

/// Packing-aware cuts (issue 5: packing ≥ 0.60): when the atlas has few charts and packs
/// poorly (a strip or a disc wastes most of a square page), the largest-area chart is cut in two
/// from the ends of a diameter of its face graph (`segment::split_in_two`, then the disk
/// guarantee), the mesh is validated again with the cut (no merge-back, so the halves stay
/// apart) and packed, and the cut is kept when the estimated efficiency (Σ chart area × density²
/// over the page area: the packer places each chart at exactly that UV area) rises by at least
/// [`PACKING_CUT_MIN_GAIN`]; otherwise the next largest chart is tried, up to
/// [`PACKING_CUT_MAX_TRIES`] tries; when no single cut paid and there are at most
/// [`PACKING_CUT_ALL_MAX_CHARTS`] charts, every chart is cut at once, one last try. Only with [`TexelDensity::FitToPage`] (an explicit density
/// does not change with the cut). Deterministic (every step is). Returns the charts to use and the
/// number of cuts kept.
fn cut_for_packing(
    mesh: &TriangleMesh,
    validated: parameterize::ParameterizedCharts,
    options: &AtlasOptions,
) -> Result<(parameterize::ParameterizedCharts, usize, Option<Packing>), AtlasError> {
    if options.pack.density != TexelDensity::FitToPage || mesh.num_faces() > PACKING_CUT_MAX_FACES {
        return Ok((validated, 0, None));
    }
    // The estimated efficiency of `v`'s packing, its number of packed charts, and the packing
    // (None above PACKING_CUT_MAX_CHARTS charts, where no cut is tried).
    let estimate =
        |v: &parameterize::ParameterizedCharts| -> Result<(f64, usize, Option<Packing>), AtlasError> {
            let inputs = pack_inputs(mesh, v)?;
            let packed: Vec<usize> = (0..inputs.degenerate.len())
                .filter(|&i| !inputs.degenerate[i])
                .collect();
            let n = packed.len();
            if n == 0 || n > PACKING_CUT_MAX_CHARTS {
                return Ok((1.0, n, None));
            }
            let input = pack_charts_of(v, &packed, &inputs.triangles, &inputs.area_m2);
            let packing = pack_charts(&input, &options.pack, &mut |_| ControlFlow::Continue(()))?;
            let page = f64::from(options.pack.width_texels)
                * f64::from(options.pack.height_texels)
                * f64::from(packing.num_pages.max(1));
            let total: f64 = packed.iter().map(|&i| inputs.area_m2[i]).sum();
            Ok((
                total * packing.texels_per_unit.powi(2) / page,
                n,
                Some(packing),
            ))
        };
    let (mut best, n, mut best_packing) = estimate(&validated)?;
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
        let (eff, _, packing) = estimate(&candidate)?;
        if eff >= best + PACKING_CUT_MIN_GAIN {
            best = eff;
            best_packing = packing;
            cuts += 1;
            current = candidate;
            tried.clear();
        }
    }
    // No single cut paid (e.g. a tube in four equal strips, where cutting one strip leaves an
    // irregular set): one last try cuts every chart of at least 2 faces at once.
    if cuts == 0 && best < PACKING_CUT_BELOW && n <= PACKING_CUT_ALL_MAX_CHARTS {
        let charts = &current.segmentation.charts;
        let picks: Vec<usize> = (0..charts.len())
            .filter(|&i| charts[i].len() >= 2)
            .collect();
        if !picks.is_empty() {
            let candidate = cut(&current, &picks)?;
            let (eff, _, packing) = estimate(&candidate)?;
            if eff >= best + PACKING_CUT_MIN_GAIN {
                cuts = picks.len();
                best_packing = packing;
                current = candidate;
            }
        }
    }
    Ok((current, cuts, best_packing))
}

/// What the packer needs of validated charts, per chart: triangles in the numbering of the
/// chart's map, 3-D area (model units²), and whether every face is degenerate (such charts are
/// not packed, see [`generate`]).
struct PackInputs {
    triangles: Vec<Vec<[u32; 3]>>,
    area_m2: Vec<f64>,
    degenerate: Vec<bool>,
}

/// [`PackInputs`] of `v`; the one builder of packer input, so that the packing of
/// `cut_for_packing` and the pack stage see the same charts. Errors when a chart has no map.
fn pack_inputs(
    mesh: &TriangleMesh,
    v: &parameterize::ParameterizedCharts,
) -> Result<PackInputs, AtlasError> {
    let charts = &v.segmentation.charts;
    let mut local_of = vec![u32::MAX; mesh.num_vertices()];
    let mut out = PackInputs {
        triangles: Vec::with_capacity(charts.len()),
        area_m2: Vec::with_capacity(charts.len()),
        degenerate: Vec::with_capacity(charts.len()),
    };
    for (i, faces) in charts.iter().enumerate() {
        let Some((map, global)) = v.maps[i].as_ref() else {
            // The parameterizer's own reason when validation recorded one.
            let detail = v
                .unresolved
                .iter()
                .find_map(|(c, d)| match d {
                    ChartDefect::Unparameterizable(e) if *c == i => Some(e.to_string()),
                    _ => None,
                })
                .unwrap_or_else(|| "no map was produced".into());
            return Err(AtlasError::Unparameterizable {
                chart: i,
                faces: faces.len(),
                detail,
            });
        };
        for (l, g) in global.iter().enumerate() {
            local_of[g.index()] = l as u32;
        }
        let mut tris = Vec::with_capacity(faces.len());
        let mut area = 0.0;
        for &f in faces {
            let t = mesh.face_vertices(f).map(|g: VertexId| local_of[g.index()]);
            debug_assert!(t.iter().all(|&l| (l as usize) < map.uv.len()));
            tris.push(t);
            area += mesh.face_area_m2(f);
        }
        for g in global {
            local_of[g.index()] = u32::MAX;
        }
        out.triangles.push(tris);
        out.area_m2.push(area);
        out.degenerate
            .push(faces.iter().all(|&f| mesh.face_degeneracy(f).is_some()));
    }
    Ok(out)
}

/// The packer's view of the charts `packed` of `v` (see [`pack_inputs`]).
fn pack_charts_of<'a>(
    v: &'a parameterize::ParameterizedCharts,
    packed: &[usize],
    triangles: &'a [Vec<[u32; 3]>],
    area_m2: &[f64],
) -> Vec<PackChart<'a>> {
    packed
        .iter()
        .map(|&i| PackChart {
            uv: v.maps[i].as_ref().map_or(&[][..], |(m, _)| &m.uv),
            triangles: &triangles[i],
            area_m2: area_m2[i],
        })
        .collect()
}

/// UVs for the corners of degenerate charts (see [`generate`]). Each degenerate face follows one
/// packed chart: the lowest chart with a vertex at the position of its first matched corner;
/// its other corners take that chart's vertex at their position when it has one, else the first
/// corner's UV. A face with no match at all collapses to `[0, 0]` on page 0.
fn place_degenerate(
    mesh: &TriangleMesh,
    charts: &[Vec<crate::mesh::FaceId>],
    degenerate: &[bool],
    corner_uvs: &mut [[[f32; 2]; 3]],
    face_page: &mut [u32],
    chart_page: &mut [u32],
) {
    if !degenerate.iter().any(|&d| d) {
        return;
    }
    type Key = (u32, [u64; 3]);
    let key = |v: VertexId| -> Key {
        let p = mesh
            .position(v)
            .map(|x| if x == 0.0 { 0 } else { x.to_bits() });
        (mesh.vertex_weld_group(v), p)
    };
    // (position key, chart) → (page, uv), one entry per vertex of each packed chart.
    let mut known: Vec<(Key, u32, u32, [f32; 2])> = Vec::new();
    for (i, faces) in charts.iter().enumerate() {
        if degenerate[i] {
            continue;
        }
        for &f in faces {
            for (k, v) in mesh.face_vertices(f).into_iter().enumerate() {
                known.push((
                    key(v),
                    i as u32,
                    face_page[f.index()],
                    corner_uvs[f.index()][k],
                ));
            }
        }
    }
    known.sort_by_key(|a| (a.0, a.1));
    known.dedup_by(|a, b| (a.0, a.1) == (b.0, b.1));
    // The lowest chart at `k`, or the entry of chart `c` at `k`.
    let first_at = |k: &Key| {
        let j = known.partition_point(|e| e.0 < *k);
        known.get(j).filter(|e| e.0 == *k)
    };
    let in_chart = |k: &Key, c: u32| {
        known
            .binary_search_by(|e| (e.0, e.1).cmp(&(*k, c)))
            .ok()
            .map(|j| &known[j])
    };
    for (i, faces) in charts.iter().enumerate() {
        if !degenerate[i] {
            continue;
        }
        let mut page = None;
        for &f in faces {
            let keys = mesh.face_vertices(f).map(key);
            let Some(&(_, chart, p, uv0)) = keys.iter().find_map(first_at) else {
                corner_uvs[f.index()] = [[0.0; 2]; 3];
                face_page[f.index()] = 0;
                continue;
            };
            corner_uvs[f.index()] = keys.map(|k| in_chart(&k, chart).map_or(uv0, |e| e.3));
            face_page[f.index()] = p;
            page.get_or_insert(p);
        }
        chart_page[i] = page.unwrap_or(0);
    }
}
