//! `texatlas unwrap IN -o OUT [--report R.json] [--preview P.png] [options]`.
//!
//! Runs the same pipeline as the service ([`texatlas::unwrap::unwrap_asset`]) on one file, with
//! a progress bar on stderr (stage names; off with `--quiet` or when stderr is not a terminal).
//! The option flags are the wire options of `proto/options.schema.json` with `-` for `_`.
use std::io::IsTerminal as _;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context as _};
use indicatif::{ProgressBar, ProgressStyle};
use texatlas::api::{
    OptionsJson, OutputFormatJson, ParameterizationJson, ResolutionJson, SegmentationJson,
    SolverJson, StretchOptimizationJson, UvSetJson, UvSetName,
};
use texatlas::atlas::{Progress, Stage};
use texatlas::preview::{preview_size_px, render_preview};
use texatlas::unwrap::unwrap_asset;

use super::load::load_asset;

#[derive(Debug, clap::Args)]
pub struct UnwrapArgs {
    /// The glTF asset: `.glb`, or `.gltf` with `data:` URIs or with its buffers and images in its
    /// own directory.
    pub input: PathBuf,
    /// Where to write the asset with the atlas UVs (`.glb`, or `.gltf` for JSON with an embedded
    /// buffer, unless --output-format says otherwise).
    #[arg(short = 'o', long)]
    pub output: PathBuf,
    /// Also write the JSON report (proto/report.schema.json) here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Also draw the UV layout as a PNG here (pages after the first get `-1`, `-2`… suffixes).
    #[arg(long)]
    pub preview: Option<PathBuf>,
    /// No progress bar and no summary line.
    #[arg(short, long)]
    pub quiet: bool,
    #[command(flatten)]
    pub options: OptionFlags,
}

/// The wire options as flags (names and meanings: proto/options.schema.json).
#[derive(Debug, Default, clap::Args)]
pub struct OptionFlags {
    /// Page size in texels: `1024` (square) or `2048x1024` (width x height). Default 1024.
    #[arg(long, value_parser = parse_resolution)]
    pub resolution: Option<ResolutionJson>,
    /// Empty texels between charts and from the page edge. Default 2.
    #[arg(long)]
    pub padding_texels: Option<u32>,
    /// Fixed texel density in texels per model unit (more pages open when needed, and charts
    /// larger than a page are cut). Default: the largest density that fits everything on one
    /// page.
    #[arg(long)]
    pub texels_per_unit: Option<f64>,
    /// Rotations tried per chart when packing (1..=64; a multiple of 8 up to twice as many on a
    /// small atlas that packs below 0.72). Default 16.
    #[arg(long)]
    pub rotations: Option<u32>,
    /// Upper bound on the number of charts after segmentation (best effort). Default: none.
    #[arg(long)]
    pub max_charts: Option<usize>,
    /// Largest Sander L2 stretch of a chart before validation splits it (>= 1), or `none` for
    /// no bound. Default 1.07.
    #[arg(long, value_parser = parse_max_stretch)]
    pub max_stretch: Option<OrNone>,
    /// Largest Sander L∞ stretch of a chart before validation splits it (>= 1), or `none` for
    /// no bound. Default 3.
    #[arg(long, value_parser = parse_max_linf)]
    pub max_linf: Option<OrNone>,
    /// The LSCM paper's area test: largest per-chart spread of face area ratios before a chart
    /// is split (>= 1, the paper uses 2). Default: off.
    #[arg(long)]
    pub max_area_ratio: Option<f64>,
    /// Passes of merging valid charts back into a neighbour (0 disables). Default 3 (the first
    /// pass only on meshes above 500k triangles).
    #[arg(long)]
    pub merge_passes: Option<usize>,
    /// Largest chart the merge-back may make, as a fraction of the mesh's faces, (0, 1], or
    /// `none` (unions of at most 4,096 faces are always tried). Default 0.1.
    #[arg(long, value_parser = parse_fraction)]
    pub merge_max_chart_fraction: Option<OrNone>,
    /// Segmentation: features (feature curves and chart growing, Lévy et al. 2002) or stretch
    /// (stretch-driven spectral segmentation, Iso-charts 2004). Default features.
    #[arg(long, value_parser = parse_segmentation)]
    pub segmentation: Option<SegmentationJson>,
    /// The stretch segmentation's bound: charts are split while their flattening's L2 stretch
    /// is above it (>= 1); it also bounds --max-stretch. Default 1.03.
    #[arg(long)]
    pub segmentation_max_stretch: Option<f64>,
    /// Fraction of edges kept as feature candidates, (0, 1]. Default 0.05.
    #[arg(long)]
    pub feature_fraction: Option<f64>,
    /// Graph-cut border optimisation: the band around each border between two charts takes up
    /// to this fraction of each chart's area, (0, 1), e.g. 0.3, or `none` to keep the borders
    /// as grown. Default none.
    #[arg(long, value_parser = parse_fraction)]
    pub border_band_fraction: Option<OrNone>,
    /// Dihedral angle in degrees, (0, 180], from which an edge is a hard edge (a feature on
    /// parts where the paper's feature curves find none, e.g. low-poly boxes), or `none`.
    /// Default 60.
    #[arg(long, value_parser = parse_hard_edge_angle)]
    pub hard_edge_angle_deg: Option<OrNone>,
    /// Solver: auto, direct or hierarchical. Default auto.
    #[arg(long, value_parser = parse_solver)]
    pub solver: Option<SolverJson>,
    /// Stretch optimisation of every chart's map after validation: global (a descent of each
    /// chart's L2 stretch, all vertices at once, never flipping), linf_l2 (global, then Sander
    /// et al. 2001's vertex passes: L∞ then L2) or none. Default global.
    #[arg(long, value_parser = parse_stretch_optimization)]
    pub stretch_optimization: Option<StretchOptimizationJson>,
    /// Passes of each vertex phase of linf_l2 (>= 1). Default 4.
    #[arg(long)]
    pub stretch_passes: Option<u32>,
    /// Parameterization of the final maps: lscm (conformal) or asp (Degener et al. 2003: the
    /// LSCM maps relaxed for an angle/area trade-off, see --asp-theta). Default lscm.
    #[arg(long, value_parser = parse_parameterization)]
    pub parameterization: Option<ParameterizationJson>,
    /// ASP's θ, the weight of area against angles, in [0, 8]: 0 keeps angles only (MIPS),
    /// larger values keep area more. Default 1. Used with --parameterization asp.
    #[arg(long)]
    pub asp_theta: Option<f64>,
    /// Which TEXCOORD_k receives the atlas, one set for every primitive: `first_free` (the
    /// lowest set no primitive has) or a set number k to replace. Default first_free.
    #[arg(long, value_parser = parse_uv_set)]
    pub uv_set: Option<UvSetJson>,
    /// Output container: glb or gltf. Default: from the output file's extension.
    #[arg(long, value_parser = parse_format)]
    pub output_format: Option<OutputFormatJson>,
}

impl OptionFlags {
    /// The wire options these flags stand for.
    pub fn to_json(&self) -> OptionsJson {
        OptionsJson {
            resolution: self.resolution,
            padding_texels: self.padding_texels,
            texels_per_unit: self.texels_per_unit,
            rotations: self.rotations,
            max_charts: self.max_charts,
            max_stretch: self.max_stretch.map(|b| b.0),
            max_linf: self.max_linf.map(|b| b.0),
            max_area_ratio: self.max_area_ratio,
            merge_passes: self.merge_passes,
            merge_max_chart_fraction: self.merge_max_chart_fraction.map(|b| b.0),
            segmentation: self.segmentation,
            segmentation_max_stretch: self.segmentation_max_stretch,
            feature_fraction: self.feature_fraction,
            border_band_fraction: self.border_band_fraction.map(|b| b.0),
            hard_edge_angle_deg: self.hard_edge_angle_deg.map(|b| b.0),
            solver: self.solver,
            stretch_optimization: self.stretch_optimization,
            stretch_passes: self.stretch_passes,
            parameterization: self.parameterization,
            asp_theta: self.asp_theta,
            uv_set: self.uv_set,
            output_format: self.output_format,
        }
    }
}

fn parse_resolution(s: &str) -> Result<ResolutionJson, String> {
    let num = |t: &str| {
        t.trim()
            .parse::<u32>()
            .map_err(|_| format!("`{s}` is not a resolution; use e.g. 1024 or 2048x1024"))
    };
    match s.split_once(['x', 'X']) {
        Some((w, h)) => Ok(ResolutionJson::Rect([num(w)?, num(h)?])),
        None => Ok(ResolutionJson::Square(num(s)?)),
    }
}

/// `--max-stretch`, `--max-linf` and `--hard-edge-angle-deg`: a number, or `none` (a newtype: clap reads a
/// bare `Option<Option<_>>` as "flag with an optional value").
#[derive(Debug, Clone, Copy)]
pub struct OrNone(pub Option<f64>);

fn parse_or_none(s: &str, what: &str, example: &str) -> Result<OrNone, String> {
    if s == "none" {
        return Ok(OrNone(None));
    }
    s.parse::<f64>()
        .map(|b| OrNone(Some(b)))
        .map_err(|_| format!("`{s}` is not {what}; use e.g. {example}, or none"))
}

fn parse_max_stretch(s: &str) -> Result<OrNone, String> {
    parse_or_none(s, "a stretch bound", "1.07")
}

fn parse_max_linf(s: &str) -> Result<OrNone, String> {
    parse_or_none(s, "a stretch bound", "3")
}

fn parse_fraction(s: &str) -> Result<OrNone, String> {
    parse_or_none(s, "a fraction", "0.1")
}

fn parse_hard_edge_angle(s: &str) -> Result<OrNone, String> {
    parse_or_none(s, "an angle in degrees", "60")
}

fn parse_solver(s: &str) -> Result<SolverJson, String> {
    match s {
        "auto" => Ok(SolverJson::Auto),
        "direct" => Ok(SolverJson::Direct),
        "hierarchical" => Ok(SolverJson::Hierarchical),
        _ => Err(format!(
            "`{s}` is not a solver; use auto, direct or hierarchical"
        )),
    }
}

fn parse_segmentation(s: &str) -> Result<SegmentationJson, String> {
    match s {
        "features" => Ok(SegmentationJson::Features),
        "stretch" => Ok(SegmentationJson::Stretch),
        _ => Err(format!(
            "`{s}` is not a segmentation; use features or stretch"
        )),
    }
}

fn parse_stretch_optimization(s: &str) -> Result<StretchOptimizationJson, String> {
    match s {
        "linf_l2" => Ok(StretchOptimizationJson::LinfL2),
        "global" => Ok(StretchOptimizationJson::Global),
        "none" => Ok(StretchOptimizationJson::None),
        _ => Err(format!(
            "`{s}` is not a stretch optimisation; use global, linf_l2 or none"
        )),
    }
}

fn parse_parameterization(s: &str) -> Result<ParameterizationJson, String> {
    match s {
        "lscm" => Ok(ParameterizationJson::Lscm),
        "asp" => Ok(ParameterizationJson::Asp),
        _ => Err(format!("`{s}` is not a parameterization; use lscm or asp")),
    }
}

fn parse_uv_set(s: &str) -> Result<UvSetJson, String> {
    if s == "first_free" {
        return Ok(UvSetJson::Named(UvSetName::FirstFree));
    }
    s.parse::<u32>()
        .map(UvSetJson::Index)
        .map_err(|_| format!("`{s}` is not a UV set; use first_free or a set number like 1"))
}

fn parse_format(s: &str) -> Result<OutputFormatJson, String> {
    match s {
        "glb" => Ok(OutputFormatJson::Glb),
        "gltf" => Ok(OutputFormatJson::Gltf),
        _ => Err(format!("`{s}` is not an output format; use glb or gltf")),
    }
}

/// A progress bar with the stage name as prefix.
struct Bar(ProgressBar);

impl Progress for Bar {
    fn stage_started(&mut self, stage: Stage) {
        self.0.set_prefix(stage.name());
        self.0.set_length(1);
        self.0.set_position(0);
    }
    fn advance(&mut self, _stage: Stage, done: usize, total: usize) -> ControlFlow<()> {
        self.0.set_length(total.max(1) as u64);
        self.0.set_position(done as u64);
        ControlFlow::Continue(())
    }
}

pub fn run(args: &UnwrapArgs) -> anyhow::Result<ExitCode> {
    let mut options = args.options.to_json();
    if options.output_format.is_none() {
        let is_gltf = args
            .output
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("gltf"));
        options.output_format = Some(if is_gltf {
            OutputFormatJson::Gltf
        } else {
            OutputFormatJson::Glb
        });
    }
    let settings = options.to_settings().context("checking the options")?;
    let loaded = load_asset(&args.input)?;
    let bar = if args.quiet || !std::io::stderr().is_terminal() {
        ProgressBar::hidden()
    } else {
        let bar = ProgressBar::new(1);
        bar.set_style(
            ProgressStyle::with_template("{prefix:>12.bold} [{bar:32}] {pos}/{len} {elapsed}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar
    };
    let mut progress = Bar(bar.clone());
    let result = unwrap_asset(&loaded.asset, &settings, &mut progress);
    bar.finish_and_clear();
    let unwrapped = result.with_context(|| format!("unwrapping {}", args.input.display()))?;
    write(&args.output, &unwrapped.encoded.bytes)?;
    if let Some(path) = &args.report {
        let text = serde_json::to_string_pretty(&unwrapped.report)?;
        write(path, text.as_bytes())?;
    }
    if let Some(path) = &args.preview {
        let pack = &settings.atlas.pack;
        let (w, h) = preview_size_px(pack.width_texels, pack.height_texels);
        for page in 0..unwrapped.atlas.num_pages {
            let png = render_preview(&unwrapped.atlas, page, w, h);
            write(&page_path(path, page), &png)?;
        }
    }
    if !args.quiet {
        let r = &unwrapped.report;
        eprintln!(
            "{}: {} triangles, {} charts on {} page(s), {:.2} s",
            args.output.display(),
            r.input.triangles,
            r.pipeline.charts,
            r.pages.len(),
            r.timings_s.total,
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// `preview.png` for page 0, `preview-1.png` for page 1, …
fn page_path(path: &Path, page: u32) -> PathBuf {
    if page == 0 {
        return path.to_path_buf();
    }
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy())
        .unwrap_or_default();
    let name = match path.extension() {
        Some(ext) => format!("{stem}-{page}.{}", ext.to_string_lossy()),
        None => format!("{stem}-{page}"),
    };
    path.with_file_name(name)
}

/// Writes atomically enough for a CLI: a temp file beside the target, then a rename.
fn write(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    if path.as_os_str().is_empty() {
        bail!("an output path is empty");
    }
    let tmp = path.with_extension("texatlas-tmp");
    std::fs::write(&tmp, bytes).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
