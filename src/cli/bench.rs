//! `texatlas bench …`
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context as _;
use texatlas::api::{OptionsJson, ResolutionJson};
use texatlas::atlas::parameterize::chart_mesh;
use texatlas::atlas::parameterize::ChartMesh;
use texatlas::atlas::segment::check_chart_is_disk;
use texatlas::atlas::NoProgress;
use texatlas::bench::pipeline::{self, BenchConfig, PipelineRow, Quality};
use texatlas::mesh::TriangleMesh;
use texatlas::unwrap::unwrap_asset;

use texatlas::bench::parameterize::{
    format_table, height_field, read_chart, run_bench, run_method, BenchMethod,
};

/// `texatlas bench [FILES…] [--peers]`, or one of the sub-benchmarks.
#[derive(Debug, clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct BenchArgs {
    #[command(subcommand)]
    pub command: Option<BenchCommand>,
    #[command(flatten)]
    pub pipeline: PipelineArgs,
}

/// The whole pipeline on files, beside the peers.
#[derive(Debug, clap::Args)]
pub struct PipelineArgs {
    /// glTF assets to unwrap. Default: every `.glb` in --corpus.
    pub files: Vec<PathBuf>,
    /// Where to find the corpus when no file is given.
    #[arg(long, default_value = "../shared/corpus")]
    pub corpus: PathBuf,
    /// Leave out files whose name contains this (repeatable), e.g. `--skip 1M`.
    #[arg(long)]
    pub skip: Vec<String>,
    /// Also run xatlas and uvunwrap (`pip install xatlas uvunwrap numpy`) on the same files and
    /// measure every output with the evaluator; print the ratios.
    #[arg(long)]
    pub peers: bool,
    /// Measure our outputs with the evaluator too (implied by --peers).
    #[arg(long)]
    pub eval: bool,
    /// Directory of atlas_eval.py and the peer scripts.
    #[arg(long, default_value = "../shared/eval")]
    pub eval_dir: PathBuf,
    /// Page side in texels.
    #[arg(long, default_value_t = 1024)]
    pub resolution: u32,
    /// Padding in texels.
    #[arg(long, default_value_t = 2)]
    pub padding: u32,
    /// Stop a peer after this many seconds (xatlas takes minutes on 100k triangles).
    #[arg(long, default_value_t = 900.0)]
    pub peer_timeout_s: f64,
    /// Print JSON rows instead of the table.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, clap::Subcommand)]
pub enum BenchCommand {
    /// LSCM direct vs single-level Jacobi-CG vs HLSCM on generated disk-shaped height fields.
    Parameterize(ParameterizeArgs),
    /// Internal: run one method in this process and print one JSON row.
    #[command(hide = true)]
    ParameterizeChild(ChildArgs),
    /// Internal: unwrap one file in this process and print one JSON row.
    #[command(hide = true)]
    PipelineChild(PipelineChildArgs),
}

#[derive(Debug, clap::Args)]
pub struct PipelineChildArgs {
    #[arg(long)]
    pub input: PathBuf,
    #[arg(long)]
    pub output: PathBuf,
    #[arg(long)]
    pub resolution: u32,
    #[arg(long)]
    pub padding: u32,
}

#[derive(Debug, clap::Args)]
pub struct ParameterizeArgs {
    /// Triangle counts of the generated height fields.
    #[arg(long, value_delimiter = ',', default_values_t = [50_000usize, 250_000, 1_000_000])]
    pub sizes: Vec<usize>,
    /// Methods to run (lscm_direct always runs first when listed: it is the reference energy).
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [BenchMethod::LscmDirect, BenchMethod::Hlscm, BenchMethod::LscmCg])]
    pub methods: Vec<BenchMethod>,
    /// Stop single-level CG after this many seconds and report it as not converged.
    #[arg(long, default_value_t = 300.0)]
    pub cg_timeout_s: f64,
    /// Print JSON (one array of rows) instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Flatten the triangle mesh of this glTF asset instead of the generated height fields
    /// (repeatable). Its triangles, welded by position, must form one topological disk.
    #[arg(long)]
    pub input: Vec<PathBuf>,
}

#[derive(Debug, clap::Args)]
pub struct ChildArgs {
    #[arg(long)]
    pub chart_file: PathBuf,
    #[arg(long)]
    pub label: String,
    #[arg(long, value_enum)]
    pub method: BenchMethod,
    #[arg(long)]
    pub reference_energy: Option<f64>,
    #[arg(long, default_value_t = 300.0)]
    pub cg_timeout_s: f64,
}

pub fn run(args: &BenchArgs) -> anyhow::Result<ExitCode> {
    let Some(command) = &args.command else {
        return run_pipeline(&args.pipeline);
    };
    match command {
        BenchCommand::PipelineChild(args) => pipeline_child(args),
        BenchCommand::Parameterize(args) => {
            let exe = std::env::current_exe()?;
            let charts: Vec<_> = if args.input.is_empty() {
                args.sizes
                    .iter()
                    .map(|&n| (format!("heightfield-{n}"), height_field(n)))
                    .collect()
            } else {
                args.input
                    .iter()
                    .map(|path| disk_chart(path))
                    .collect::<anyhow::Result<_>>()?
            };
            let json = args.json;
            let rows = run_bench(&exe, &charts, &args.methods, args.cg_timeout_s, |row| {
                if !json {
                    eprintln!(
                        "{} {}: {:.3} s, {:.0} MiB, {} iterations",
                        row.chart, row.method, row.seconds, row.peak_mib, row.iterations
                    );
                }
            })?;
            if json {
                println!("{}", serde_json::to_string_pretty(&rows)?);
            } else {
                print!("{}", format_table(&rows));
            }
            Ok(ExitCode::SUCCESS)
        }
        BenchCommand::ParameterizeChild(args) => {
            let chart = read_chart(&args.chart_file)?;
            let row = run_method(
                &args.label,
                &chart,
                args.method,
                args.reference_energy,
                args.cg_timeout_s,
            )?;
            println!("{}", serde_json::to_string(&row)?);
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// The whole triangle mesh of a glTF asset as one chart, labelled by its file name; an error
/// (saying why) unless its welded triangles form one topological disk.
fn disk_chart(path: &Path) -> anyhow::Result<(String, ChartMesh)> {
    let loaded = super::load::load_asset(path)?;
    let built = TriangleMesh::build(loaded.asset.mesh_input())
        .with_context(|| format!("building the mesh of {}", path.display()))?;
    let faces: Vec<_> = built.mesh.faces().collect();
    check_chart_is_disk(&built.mesh, &faces).with_context(|| {
        format!(
            "{} is not one topological disk, so it cannot be flattened as one chart; \
             give a disk-shaped mesh (one connected piece, one boundary loop, no handles)",
            path.display()
        )
    })?;
    let (chart, _) = chart_mesh(&built.mesh, &faces);
    let label = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string());
    Ok((label, chart))
}

fn run_pipeline(args: &PipelineArgs) -> anyhow::Result<ExitCode> {
    let mut files = if args.files.is_empty() {
        pipeline::corpus_files(&args.corpus).with_context(|| {
            "no files given and no corpus found; pass files or --corpus DIR".to_string()
        })?
    } else {
        args.files.clone()
    };
    files.retain(|f| {
        let name = f.to_string_lossy();
        !args.skip.iter().any(|s| name.contains(s.as_str()))
    });
    if files.is_empty() {
        anyhow::bail!("no files to benchmark");
    }
    let config = BenchConfig {
        exe: std::env::current_exe()?,
        eval_dir: args.eval_dir.clone(),
        peers: args.peers,
        eval: args.eval,
        resolution: args.resolution,
        padding: args.padding,
        peer_timeout: std::time::Duration::from_secs_f64(args.peer_timeout_s.max(1.0)),
        work_dir: std::env::temp_dir().join(format!("texatlas-bench-{}", std::process::id())),
    };
    let json = args.json;
    let rows = pipeline::run_bench(&files, &config, |row| {
        if !json {
            match &row.error {
                Some(e) => eprintln!("{} {}: failed: {e}", row.file, row.tool),
                None => eprintln!(
                    "{} {}: {:.3} s, {:.0} MiB",
                    row.file, row.tool, row.total_s, row.peak_mib
                ),
            }
        }
    })?;
    let _ = std::fs::remove_dir_all(&config.work_dir);
    if json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        print!("{}", pipeline::format_table(&rows));
    }
    Ok(ExitCode::SUCCESS)
}

fn pipeline_child(args: &PipelineChildArgs) -> anyhow::Result<ExitCode> {
    let loaded = super::load::load_asset(&args.input)?;
    let options = OptionsJson {
        resolution: Some(ResolutionJson::Square(args.resolution)),
        padding_texels: Some(args.padding),
        ..OptionsJson::default()
    };
    let settings = options.to_settings()?;
    let unwrapped = unwrap_asset(&loaded.asset, &settings, &mut NoProgress)
        .with_context(|| format!("unwrapping {}", args.input.display()))?;
    std::fs::write(&args.output, &unwrapped.encoded.bytes)
        .with_context(|| format!("writing {}", args.output.display()))?;
    let t = &unwrapped.timings;
    let report = serde_json::to_value(&unwrapped.report)?;
    let row = PipelineRow {
        file: String::new(),
        tool: "texatlas".into(),
        triangles: unwrapped.triangles,
        stages_s: Some([
            t.build_s,
            t.stages_s[0],
            t.stages_s[1],
            t.stages_s[2],
            t.stages_s[3],
            t.encode_s,
        ]),
        total_s: t.total_s,
        peak_mib: texatlas::bench::parameterize::peak_rss_mib(),
        eval: None,
        report: Quality::from_report(&report),
        error: None,
    };
    println!("{}", serde_json::to_string(&row)?);
    Ok(ExitCode::SUCCESS)
}
