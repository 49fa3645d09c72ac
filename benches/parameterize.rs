//! `cargo bench --bench parameterize -- [--sizes 50000,250000,1000000] [--methods …] [--input FILE]…`:
//! LSCM direct vs single-level Jacobi-CG vs HLSCM, through the public parameterize entry
//! (`flatten_chart` with `FlattenOptions::method`).
//!
//! Purpose: the measurement behind
//! `texatlas::atlas::parameterize::FlattenOptions::auto_hierarchical_min_vertices`.
//!
//! How: the parent generates (or is given) each chart, writes it once to a raw file in the
//! temp directory, then runs every method in a child process of this executable (subcommand
//! `child`), so that each method's peak memory (`VmHWM` of the child) is its own. Order per
//! chart: `lscm_direct` first (its energy is the reference), then `hlscm`, then `lscm_cg`
//! (the solver's `ConjugateGradient` method: Jacobi-CG from zero until its relative residual
//! is below `--cg-tolerance` or `--cg-max-iterations`, cancelled after `--cg-timeout-s`).
//!
//! Timed: everything `flatten_chart` does (chart validation, pins, assembly, solve). Not
//! timed: mesh generation and file IO.
use std::io::{Read, Write};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context as _};
use clap::{Parser, Subcommand};
use serde::{Deserialize, Serialize};
use texatlas::atlas::parameterize::{
    chart_mesh, flatten_chart, ChartMesh, FlattenOptions, HlscmOptions, ParameterizeError,
    ParameterizeMethod,
};
use texatlas::atlas::segment::check_chart_is_disk;
use texatlas::atlas::{ProgressFn, Stage, StageProgress};
use texatlas::mesh::TriangleMesh;
use texatlas::numerics::CgOptions;

mod common;

#[derive(Debug, Parser)]
#[command(
    name = "parameterize",
    about = "LSCM direct vs single-level Jacobi-CG vs HLSCM on generated disk-shaped height fields",
    args_conflicts_with_subcommands = true
)]
struct Cli {
    #[command(subcommand)]
    child: Option<ChildCommand>,
    #[command(flatten)]
    args: BenchArgs,
}

#[derive(Debug, clap::Args)]
struct BenchArgs {
    /// Triangle counts of the generated height fields.
    #[arg(long, value_delimiter = ',', default_values_t = [50_000usize, 250_000, 1_000_000])]
    sizes: Vec<usize>,
    /// Methods to run (lscm_direct always runs first when listed: it is the reference energy).
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [BenchMethod::LscmDirect, BenchMethod::Hlscm, BenchMethod::LscmCg])]
    methods: Vec<BenchMethod>,
    #[command(flatten)]
    cg: CgArgs,
    /// Print JSON (one array of rows) instead of a table.
    #[arg(long)]
    json: bool,
    /// Flatten the triangle mesh of this glTF asset instead of the generated height fields
    /// (repeatable). Its triangles, welded by position, must form one topological disk.
    #[arg(long)]
    input: Vec<PathBuf>,
    /// Passed by `cargo bench`; ignored.
    #[arg(long = "bench", hide = true)]
    cargo_bench: bool,
}

/// The stopping rules of `lscm_cg`.
#[derive(Debug, Clone, Copy, clap::Args)]
struct CgArgs {
    /// Cancel single-level CG after this many seconds and report it as not converged.
    #[arg(long, default_value_t = 300.0)]
    cg_timeout_s: f64,
    /// Relative residual at which single-level CG stops (default: the solver's own).
    #[arg(long, default_value_t = FlattenOptions::default().cg.tolerance)]
    cg_tolerance: f64,
    /// Iteration cap of single-level CG (default: the solver's own).
    #[arg(long, default_value_t = FlattenOptions::default().cg.max_iterations)]
    cg_max_iterations: usize,
}

#[derive(Debug, Subcommand)]
enum ChildCommand {
    /// Internal: run one method in this process and print one JSON row.
    #[command(hide = true)]
    Child(ChildArgs),
}

#[derive(Debug, clap::Args)]
struct ChildArgs {
    #[arg(long)]
    chart_file: PathBuf,
    #[arg(long)]
    label: String,
    #[arg(long, value_enum)]
    method: BenchMethod,
    #[arg(long)]
    reference_energy: Option<f64>,
    #[command(flatten)]
    cg: CgArgs,
}

/// The three benchmarked methods.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
enum BenchMethod {
    /// Sparse Cholesky on the normal equations.
    LscmDirect,
    /// Cascadic multigrid (HLSCM).
    Hlscm,
    /// Single-level Jacobi-CG from zero.
    LscmCg,
}

impl BenchMethod {
    /// Name used in tables and JSON.
    fn name(self) -> &'static str {
        match self {
            BenchMethod::LscmDirect => "lscm_direct",
            BenchMethod::Hlscm => "hlscm",
            BenchMethod::LscmCg => "lscm_cg",
        }
    }

    /// The command-line spelling (`lscm-direct`, …).
    fn arg(self) -> String {
        clap::ValueEnum::to_possible_value(&self)
            .map(|v| v.get_name().to_string())
            .unwrap_or_default()
    }
}

/// One measured row.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct BenchRow {
    /// Chart label (e.g. `heightfield-1000000`).
    chart: String,
    /// Chart triangles.
    triangles: usize,
    /// Chart vertices.
    vertices: usize,
    /// Method name.
    method: String,
    /// Wall-clock seconds of the timed part.
    seconds: f64,
    /// Peak resident memory of the child process, MiB (`VmHWM`).
    peak_mib: f64,
    /// CG iterations (finest level for HLSCM; 0 for direct; the last seen when cancelled).
    iterations: usize,
    /// `C(U)` of the map (`None`: cancelled at the timeout, no map).
    energy: Option<f64>,
    /// `|C − C_direct| / C_direct` (0 for the direct row).
    energy_rel_to_direct: Option<f64>,
    /// Whether the method met its stopping rule: HLSCM its own; CG its tolerance before the
    /// cap and the timeout, and within 1e-4 of the direct energy.
    converged: bool,
    /// Flipped faces in the result (`None`: no map).
    flipped_faces: Option<usize>,
    /// HLSCM levels (vertices, iterations), coarsest first.
    levels: Vec<(usize, usize)>,
}

fn main() -> ExitCode {
    #[cfg(test)]
    if common::is_self_test_invocation() {
        return common::run_self_tests(self_tests::TESTS);
    }
    let cli = Cli::parse();
    let result = match &cli.child {
        Some(ChildCommand::Child(args)) => child(args),
        None => bench(&cli.args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("parameterize bench: error: {err:#}");
            ExitCode::from(2)
        }
    }
}

fn bench(args: &BenchArgs) -> anyhow::Result<()> {
    let json = args.json;
    let rows = run(args, |row| {
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
    Ok(())
}

/// The charts of `args` (generated or read), every method on each in a child process.
fn run(args: &BenchArgs, on_row: impl FnMut(&BenchRow)) -> anyhow::Result<Vec<BenchRow>> {
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
    let exe = std::env::current_exe()?;
    run_bench(&exe, &charts, &args.methods, args.cg, on_row)
}

fn child(args: &ChildArgs) -> anyhow::Result<()> {
    let chart = read_chart(&args.chart_file)?;
    let row = run_method(
        &args.label,
        &chart,
        args.method,
        args.reference_energy,
        args.cg,
    )?;
    println!("{}", serde_json::to_string(&row)?);
    Ok(())
}

/// The whole triangle mesh of a glTF asset as one chart, labelled by its file name; an error
/// (saying why) unless its welded triangles form one topological disk.
fn disk_chart(path: &Path) -> anyhow::Result<(String, ChartMesh)> {
    let loaded = common::load_asset(path)?;
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

/// Deterministic disk-topology height field with multi-scale bumps, about `triangles`
/// triangles: an `m × m` grid over the unit square (`2m²` triangles) with heights summed from
/// five octaves of products of sines and a few Gaussian bumps, from a fixed-seed generator.
fn height_field(triangles: usize) -> ChartMesh {
    let m = ((triangles as f64 / 2.0).sqrt().round() as usize).max(2);
    let mut seed: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut octaves = Vec::new();
    for k in 0..5 {
        let f = 2.0 * std::f64::consts::PI * (1u32 << k) as f64;
        octaves.push((
            0.06 / (1u32 << k) as f64,
            f * (0.8 + 0.4 * next()),
            f * (0.8 + 0.4 * next()),
            6.3 * next(),
            6.3 * next(),
        ));
    }
    let mut bumps = Vec::new();
    for _ in 0..12 {
        bumps.push((next(), next(), 0.02 + 0.08 * next(), 0.1 * (next() - 0.5)));
    }
    let height = |x: f64, y: f64| {
        let mut z = 0.0;
        for &(a, fx, fy, px, py) in &octaves {
            z += a * (fx * x + px).sin() * (fy * y + py).sin();
        }
        for &(cx, cy, r, a) in &bumps {
            let d2 = (x - cx).powi(2) + (y - cy).powi(2);
            z += a * (-d2 / (r * r)).exp();
        }
        z
    };
    let mut positions_m = Vec::with_capacity((m + 1) * (m + 1));
    for j in 0..=m {
        for i in 0..=m {
            let (x, y) = (i as f64 / m as f64, j as f64 / m as f64);
            positions_m.push([x, y, height(x, y)]);
        }
    }
    let id = |i: usize, j: usize| (j * (m + 1) + i) as u32;
    let mut tris = Vec::with_capacity(2 * m * m);
    for j in 0..m {
        for i in 0..m {
            // Alternate the diagonal so the mesh has no preferred direction.
            if (i + j) % 2 == 0 {
                tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            } else {
                tris.push([id(i, j), id(i + 1, j), id(i, j + 1)]);
                tris.push([id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
    }
    ChartMesh {
        positions_m,
        triangles: tris,
    }
}

/// Writes a chart as raw little-endian data (`u64` counts, `f64` positions, `u32` indices).
fn write_chart(path: &Path, chart: &ChartMesh) -> anyhow::Result<()> {
    let mut bytes =
        Vec::with_capacity(16 + chart.positions_m.len() * 24 + chart.triangles.len() * 12);
    bytes.extend_from_slice(&(chart.positions_m.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&(chart.triangles.len() as u64).to_le_bytes());
    for p in &chart.positions_m {
        for c in p {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    for t in &chart.triangles {
        for i in t {
            bytes.extend_from_slice(&i.to_le_bytes());
        }
    }
    let mut f =
        std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
    f.write_all(&bytes)?;
    Ok(())
}

/// Reads a chart written by [`write_chart`], checking every size against the file length.
fn read_chart(path: &Path) -> anyhow::Result<ChartMesh> {
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .with_context(|| format!("opening {}", path.display()))?
        .read_to_end(&mut bytes)?;
    let u64_at = |o: usize| -> anyhow::Result<u64> {
        let s = bytes.get(o..o + 8).context("truncated chart file")?;
        Ok(u64::from_le_bytes(s.try_into()?))
    };
    let n = usize::try_from(u64_at(0)?)?;
    let f = usize::try_from(u64_at(8)?)?;
    let expected = n
        .checked_mul(24)
        .and_then(|a| f.checked_mul(12).and_then(|b| a.checked_add(b)))
        .and_then(|s| s.checked_add(16))
        .context("chart file sizes overflow")?;
    if expected != bytes.len() {
        bail!(
            "chart file {} has {} bytes, header says {expected}",
            path.display(),
            bytes.len()
        );
    }
    let mut positions_m = Vec::with_capacity(n);
    let mut o = 16;
    for _ in 0..n {
        let mut p = [0.0; 3];
        for c in &mut p {
            *c = f64::from_le_bytes(bytes[o..o + 8].try_into()?);
            o += 8;
        }
        positions_m.push(p);
    }
    let mut triangles = Vec::with_capacity(f);
    for _ in 0..f {
        let mut t = [0u32; 3];
        for i in &mut t {
            *i = u32::from_le_bytes(bytes[o..o + 4].try_into()?);
            o += 4;
        }
        triangles.push(t);
    }
    Ok(ChartMesh {
        positions_m,
        triangles,
    })
}

/// Runs one method on one chart in this process (the child side). `reference_energy` is the
/// direct energy, against which the others are measured.
fn run_method(
    label: &str,
    chart: &ChartMesh,
    method: BenchMethod,
    reference_energy: Option<f64>,
    cg: CgArgs,
) -> anyhow::Result<BenchRow> {
    let options = FlattenOptions {
        method: match method {
            BenchMethod::LscmDirect => ParameterizeMethod::Direct,
            BenchMethod::Hlscm => ParameterizeMethod::Hierarchical,
            BenchMethod::LscmCg => ParameterizeMethod::ConjugateGradient,
        },
        hlscm: hlscm_options_from_env(),
        cg: CgOptions {
            tolerance: cg.cg_tolerance,
            max_iterations: cg.cg_max_iterations,
        },
        ..FlattenOptions::default()
    };
    let start = Instant::now();
    let mut last_iteration = 0;
    let result = if method == BenchMethod::LscmCg {
        let mut timeout = ProgressFn(|_: Stage, done: usize, _: usize| {
            last_iteration = done;
            if start.elapsed().as_secs_f64() > cg.cg_timeout_s {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        });
        flatten_chart(
            chart,
            &options,
            &mut StageProgress::new(Stage::Parameterize, &mut timeout),
        )
    } else {
        flatten_chart(
            chart,
            &options,
            &mut StageProgress::ignored(Stage::Parameterize),
        )
    };
    let seconds = start.elapsed().as_secs_f64();
    let map = match result {
        Ok(map) => Some(map),
        Err(ParameterizeError::Cancelled) => None,
        Err(e) => return Err(e).with_context(|| format!("{label}: {}", method.name())),
    };
    let energy = map.as_ref().map(|m| m.conformal_energy);
    let energy_rel_to_direct = reference_energy
        .zip(energy)
        .map(|(reference, e)| (e - reference).abs() / energy_scale(chart, reference));
    let within_reference = energy_rel_to_direct.is_none_or(|rel| rel <= ENERGY_REL_TOLERANCE);
    let converged = match (&map, method) {
        (None, _) => false,
        (Some(_), BenchMethod::LscmDirect) => true,
        (Some(m), BenchMethod::Hlscm) => m.hlscm.as_ref().is_some_and(|r| r.converged),
        (Some(m), BenchMethod::LscmCg) => m.iterations < cg.cg_max_iterations && within_reference,
    };
    Ok(BenchRow {
        chart: label.to_string(),
        triangles: chart.triangles.len(),
        vertices: chart.positions_m.len(),
        method: method.name().to_string(),
        seconds,
        peak_mib: common::peak_rss_mib(),
        iterations: map.as_ref().map_or(last_iteration, |m| m.iterations),
        energy,
        energy_rel_to_direct,
        converged,
        flipped_faces: map.as_ref().map(|m| m.flipped_faces.len()),
        levels: map
            .as_ref()
            .and_then(|m| m.hlscm.as_ref())
            .map(|r| {
                r.levels
                    .iter()
                    .map(|l| (l.vertices, l.iterations))
                    .collect()
            })
            .unwrap_or_default(),
    })
}

/// HLSCM options of the bench: the defaults, except for tuning experiments through
/// `TEXATLAS_BENCH_HLSCM_COARSEST_MAX_VERTICES`, `TEXATLAS_BENCH_HLSCM_LEVEL_RATIO`,
/// `TEXATLAS_BENCH_HLSCM_RELAX_ITERATIONS` and
/// `TEXATLAS_BENCH_HLSCM_FINAL_ENERGY_TOLERANCE` (unset in every figure we publish).
fn hlscm_options_from_env() -> HlscmOptions {
    let mut o = HlscmOptions::default();
    let var = |name: &str| std::env::var(name).ok();
    if let Some(v) = var("TEXATLAS_BENCH_HLSCM_COARSEST_MAX_VERTICES").and_then(|v| v.parse().ok())
    {
        o.coarsest_max_vertices = v;
    }
    if let Some(v) = var("TEXATLAS_BENCH_HLSCM_LEVEL_RATIO").and_then(|v| v.parse().ok()) {
        o.level_ratio = v;
    }
    if let Some(v) = var("TEXATLAS_BENCH_HLSCM_RELAX_ITERATIONS").and_then(|v| v.parse().ok()) {
        o.relax_iterations = v;
    }
    if let Some(v) = var("TEXATLAS_BENCH_HLSCM_FINAL_ENERGY_TOLERANCE").and_then(|v| v.parse().ok())
    {
        o.final_energy_tolerance = v;
    }
    o
}

/// "The same final energy as the direct solve" means within this fraction of it.
const ENERGY_REL_TOLERANCE: f64 = 1e-4;

/// What energy differences are measured against: the direct energy, but never less than
/// 1e-10 × the chart's 3D area (the energy's own unit, m²). A developable chart (a flat grid, a
/// cut cylinder) has a direct energy of pure round-off, ~1e-23, and a relative error against
/// that would call an equally exact solution "not converged". Curved charts have energies far
/// above the floor (the bench height fields: ~1e-5 × area), where it changes nothing.
fn energy_scale(chart: &ChartMesh, direct_energy: f64) -> f64 {
    let area_m2: f64 = chart
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| chart.positions_m[i as usize]);
            let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let n = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
        })
        .sum();
    direct_energy.max(1e-10 * area_m2)
}

/// Runs every method on every chart, each in a child process of `exe`, and returns the rows.
fn run_bench(
    exe: &Path,
    charts: &[(String, ChartMesh)],
    methods: &[BenchMethod],
    cg: CgArgs,
    mut on_row: impl FnMut(&BenchRow),
) -> anyhow::Result<Vec<BenchRow>> {
    let mut rows = Vec::new();
    for (label, chart) in charts {
        let path: PathBuf = std::env::temp_dir().join(format!(
            "texatlas-bench-{}-{label}.chart",
            std::process::id()
        ));
        write_chart(&path, chart)?;
        let mut reference: Option<f64> = None;
        let mut ordered: Vec<BenchMethod> = methods.to_vec();
        ordered.sort_by_key(|m| match m {
            BenchMethod::LscmDirect => 0,
            BenchMethod::Hlscm => 1,
            BenchMethod::LscmCg => 2,
        });
        for method in ordered {
            let mut cmd = std::process::Command::new(exe);
            cmd.args(["child", "--chart-file"])
                .arg(&path)
                .args(["--label", label, "--method", &method.arg()])
                .args(["--cg-timeout-s", &cg.cg_timeout_s.to_string()])
                .args(["--cg-tolerance", &format!("{:e}", cg.cg_tolerance)])
                .args(["--cg-max-iterations", &cg.cg_max_iterations.to_string()]);
            if let Some(e) = reference {
                cmd.args(["--reference-energy", &format!("{e:e}")]);
            }
            let out = cmd.output().context("spawning the bench child")?;
            if !out.status.success() {
                let _ = std::fs::remove_file(&path);
                bail!(
                    "bench child for {label}/{} failed: {}",
                    method.name(),
                    String::from_utf8_lossy(&out.stderr)
                );
            }
            let row: BenchRow =
                serde_json::from_slice(&out.stdout).context("parsing the bench child's JSON")?;
            if method == BenchMethod::LscmDirect {
                reference = row.energy;
            }
            on_row(&row);
            rows.push(row);
        }
        let _ = std::fs::remove_file(&path);
    }
    Ok(rows)
}

/// Formats rows as a text table.
fn format_table(rows: &[BenchRow]) -> String {
    let mut s = format!(
        "{:<22} {:>9} {:<12} {:>9} {:>9} {:>7} {:>14} {:>10} {:>5} {:>5}  levels(vertices:iters)\n",
        "chart",
        "triangles",
        "method",
        "seconds",
        "peak_MiB",
        "iters",
        "energy",
        "rel_err",
        "conv",
        "flips"
    );
    let or_dash = |x: Option<String>| x.unwrap_or_else(|| "-".into());
    for r in rows {
        let levels: Vec<String> = r.levels.iter().map(|(v, i)| format!("{v}:{i}")).collect();
        s.push_str(&format!(
            "{:<22} {:>9} {:<12} {:>9.3} {:>9.1} {:>7} {:>14} {:>10} {:>5} {:>5}  {}\n",
            r.chart,
            r.triangles,
            r.method,
            r.seconds,
            r.peak_mib,
            r.iterations,
            or_dash(r.energy.map(|e| format!("{e:.8e}"))),
            or_dash(r.energy_rel_to_direct.map(|e| format!("{e:.2e}"))),
            r.converged,
            or_dash(r.flipped_faces.map(|f| f.to_string())),
            levels.join(" ")
        ));
    }
    s
}

/// Run by `cargo test` (this target has `test = true`, `harness = false`).
#[cfg(test)]
mod self_tests {
    use super::*;

    pub const TESTS: &[(&str, fn())] = &[
        (
            "height_field_is_a_deterministic_disk_of_the_requested_size",
            height_field_is_a_deterministic_disk_of_the_requested_size,
        ),
        (
            "chart_file_round_trips_and_rejects_truncation",
            chart_file_round_trips_and_rejects_truncation,
        ),
        (
            "run_method_in_process_reports_consistent_rows",
            run_method_in_process_reports_consistent_rows,
        ),
        (
            "bench_runs_every_method_in_child_processes",
            bench_runs_every_method_in_child_processes,
        ),
        (
            "bench_input_flattens_a_disk_shaped_asset",
            bench_input_flattens_a_disk_shaped_asset,
        ),
        (
            "bench_input_refuses_a_closed_mesh_and_says_why",
            bench_input_refuses_a_closed_mesh_and_says_why,
        ),
        (
            "cg_cancelled_at_the_timeout_is_not_converged",
            cg_cancelled_at_the_timeout_is_not_converged,
        ),
    ];

    fn cg(timeout_s: f64) -> CgArgs {
        CgArgs {
            cg_timeout_s: timeout_s,
            cg_tolerance: FlattenOptions::default().cg.tolerance,
            cg_max_iterations: FlattenOptions::default().cg.max_iterations,
        }
    }

    fn height_field_is_a_deterministic_disk_of_the_requested_size() {
        let a = height_field(5_000);
        let b = height_field(5_000);
        assert_eq!(a, b);
        assert!((a.triangles.len() as f64 - 5_000.0).abs() < 200.0);
        a.validate().expect("disk");
        let zmax = a.positions_m.iter().map(|p| p[2].abs()).fold(0.0, f64::max);
        assert!(zmax > 0.01 && zmax < 0.5, "{zmax}");
    }

    fn chart_file_round_trips_and_rejects_truncation() {
        let chart = height_field(200);
        let dir = tempfile::tempdir().expect("tmp");
        let path = dir.path().join("c.chart");
        write_chart(&path, &chart).expect("write");
        assert_eq!(read_chart(&path).expect("read"), chart);
        let bytes = std::fs::read(&path).expect("read");
        std::fs::write(&path, &bytes[..bytes.len() - 3]).expect("write");
        assert!(read_chart(&path).is_err());
    }

    fn run_method_in_process_reports_consistent_rows() {
        let chart = height_field(2_000);
        let direct =
            run_method("t", &chart, BenchMethod::LscmDirect, None, cg(10.0)).expect("direct");
        let direct_energy = direct.energy.expect("direct energy");
        let cg = run_method(
            "t",
            &chart,
            BenchMethod::LscmCg,
            Some(direct_energy),
            cg(30.0),
        )
        .expect("cg");
        assert!(cg.converged, "{cg:?}");
        assert!(cg.energy.expect("cg energy") <= direct_energy * (1.0 + 1e-4) + 1e-15);
        assert!(cg.iterations > 0 && direct.flipped_faces == Some(0));
        assert!(format_table(&[direct, cg]).lines().count() == 3);
    }

    fn bench_runs_every_method_in_child_processes() {
        let exe = std::env::current_exe().expect("exe");
        let charts = vec![("tiny".to_string(), height_field(3_000))];
        let mut seen = 0;
        let rows = run_bench(
            &exe,
            &charts,
            &[
                BenchMethod::LscmCg,
                BenchMethod::Hlscm,
                BenchMethod::LscmDirect,
            ],
            cg(60.0),
            |_| seen += 1,
        )
        .expect("bench");
        assert_eq!(seen, 3);
        let names: Vec<&str> = rows.iter().map(|r| r.method.as_str()).collect();
        // The direct solve runs first: it is the reference energy of the others.
        assert_eq!(names, ["lscm_direct", "hlscm", "lscm_cg"]);
        let direct = rows[0].energy.expect("direct energy");
        for r in &rows {
            assert!(r.peak_mib > 0.0, "VmHWM read from the child");
            assert_eq!(r.flipped_faces, Some(0));
            assert!(r.converged, "{r:?}");
            assert_eq!(r.triangles, charts[0].1.triangles.len());
        }
        assert!(!rows[1].levels.is_empty(), "HLSCM reports its levels");
        for r in &rows[1..] {
            let rel = r.energy_rel_to_direct.expect("relative to direct");
            assert!(rel <= 1e-4, "{} {rel}", r.method);
            assert!((r.energy.expect("energy") - direct).abs() <= 1e-4 * direct);
        }
    }

    fn bench_input_flattens_a_disk_shaped_asset() {
        // The strip fixture is a quad (2 triangles): one disk.
        let fixture = common::fixture("Mesh_PrimitiveMode_04_strip.glb");
        let cli = Cli::try_parse_from([
            "parameterize".as_ref(),
            "--json".as_ref(),
            "--methods".as_ref(),
            "lscm-direct,hlscm".as_ref(),
            "--input".as_ref(),
            fixture.as_os_str(),
        ])
        .expect("arguments");
        assert!(cli.child.is_none());
        let rows = run(&cli.args, |_| {}).expect("bench");
        assert_eq!(rows.len(), 2);
        for r in &rows {
            assert_eq!(r.chart, "Mesh_PrimitiveMode_04_strip");
            assert_eq!(r.triangles, 2);
            assert_eq!(r.flipped_faces, Some(0));
        }
        // What `--json` prints.
        let printed: serde_json::Value =
            serde_json::from_str(&serde_json::to_string_pretty(&rows).expect("json"))
                .expect("json rows");
        assert_eq!(printed[0]["method"], "lscm_direct");
        assert_eq!(printed[1]["method"], "hlscm");
    }

    fn bench_input_refuses_a_closed_mesh_and_says_why() {
        let fixture = common::fixture("Box.glb");
        let cli = Cli::try_parse_from([
            "parameterize".as_ref(),
            "--input".as_ref(),
            fixture.as_os_str(),
        ])
        .expect("arguments");
        let err = run(&cli.args, |_| {}).expect_err("a closed box is not a disk");
        let err = format!("{err:#}");
        assert!(err.contains("not one topological disk"), "{err}");
        assert!(err.contains("χ = 2"), "{err}");
    }

    fn cg_cancelled_at_the_timeout_is_not_converged() {
        let chart = height_field(20_000);
        let row = run_method("t", &chart, BenchMethod::LscmCg, Some(1.0), cg(0.0)).expect("row");
        assert!(!row.converged, "{row:?}");
        assert_eq!(row.energy, None);
        assert_eq!(row.flipped_faces, None);
        assert!(row.seconds < 30.0, "{row:?}");
    }
}
