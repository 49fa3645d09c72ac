//! `texatlas bench …`
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context as _;
use texatlas::atlas::parameterize::ChartMesh;
use texatlas::atlas::segment::{chart_mesh, check_chart_is_disk};
use texatlas::mesh::TriangleMesh;

use texatlas::bench::parameterize::{
    format_table, height_field, read_chart, run_bench, run_method, BenchMethod,
};

#[derive(Debug, clap::Subcommand)]
pub enum BenchCommand {
    /// LSCM direct vs single-level Jacobi-CG vs HLSCM on generated disk-shaped height fields.
    Parameterize(ParameterizeArgs),
    /// Internal: run one method in this process and print one JSON row.
    #[command(hide = true)]
    ParameterizeChild(ChildArgs),
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

pub fn run(command: &BenchCommand) -> anyhow::Result<ExitCode> {
    match command {
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
