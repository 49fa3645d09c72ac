//! `cargo bench --bench pipeline -- [FILES…] [--peers] [--pack-peers] [--eval] [--eval-dir DIR]`:
//! the whole pipeline per file, beside xatlas and uvunwrap.
//!
//! Purpose: time, memory and quality next to the peers, on the same machine, in the same run.
//!
//! How, per file:
//! - **texatlas** runs in a child process of this executable (subcommand `child`), so its peak
//!   memory (`VmHWM`) is its own. Timed, by `texatlas::unwrap::unwrap_asset` as `texatlas
//!   unwrap` does: mesh build, the four stages, encode (not the file read or write). Quality:
//!   our report (`quality.*`).
//! - with `--peers`, **xatlas** and **uvunwrap** run through `$EVAL_DIR/peer_xatlas.py` and
//!   `peer_uvunwrap.py` (`pip install xatlas uvunwrap numpy`), each in a Python wrapper that
//!   reads the child's peak RSS (`getrusage(RUSAGE_CHILDREN)`); their time is the peer's own
//!   timing of the library calls only (`xatlas_s`, `uvunwrap_s`: no file IO, which favours the
//!   peers). Then `atlas_eval.py` measures **all three outputs** (ours included), so the quality
//!   columns compare like with like; our own report's figures are kept beside them.
//! - with `--pack-peers`, packing alone: our charts packed again by xatlas's and uvunwrap's
//!   packers, a second table (module [`pack_peers`]).
//!
//! `EVAL_DIR` is `--eval-dir`, else `$TEXATLAS_EVAL_DIR`, else `../shared/eval`; the corpus (used
//! when no file is given) is `--corpus`, else `$TEXATLAS_CORPUS_DIR`, else `../shared/corpus`.
//! Paths are relative to the repository root (where `cargo bench` runs the bench).
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::Duration;

use anyhow::{bail, Context as _};
use clap::{Parser, Subcommand};
use serde::{Deserialize, Serialize};
use texatlas::api::{OptionsJson, ResolutionJson};
use texatlas::atlas::NoProgress;
use texatlas::unwrap::unwrap_asset;

mod common;
#[path = "pipeline/pack_peers.rs"]
mod pack_peers;

#[derive(Debug, Parser)]
#[command(
    name = "pipeline",
    about = "The whole pipeline on files, beside xatlas and uvunwrap",
    args_conflicts_with_subcommands = true
)]
struct Cli {
    #[command(subcommand)]
    child: Option<ChildCommand>,
    #[command(flatten)]
    args: PipelineArgs,
}

/// The whole pipeline on files, beside the peers.
#[derive(Debug, clap::Args)]
struct PipelineArgs {
    /// glTF assets to unwrap. Default: every `.glb` in --corpus.
    files: Vec<PathBuf>,
    /// Where to find the corpus when no file is given.
    #[arg(long, env = "TEXATLAS_CORPUS_DIR", default_value = "../shared/corpus")]
    corpus: PathBuf,
    /// Leave out files whose name contains this (repeatable), e.g. `--skip 1M`.
    #[arg(long)]
    skip: Vec<String>,
    /// Also run xatlas and uvunwrap (`pip install xatlas uvunwrap numpy`) on the same files and
    /// measure every output with the evaluator; print the ratios.
    #[arg(long)]
    peers: bool,
    /// Also pack our charts again with xatlas's and uvunwrap's packers (benches/pack_peers.py),
    /// measure every packing with the evaluator and print a pack-only table.
    #[arg(long)]
    pack_peers: bool,
    /// Measure our outputs with the evaluator too (implied by --peers).
    #[arg(long)]
    eval: bool,
    /// Directory of atlas_eval.py and the peer scripts.
    #[arg(long, env = "TEXATLAS_EVAL_DIR", default_value = "../shared/eval")]
    eval_dir: PathBuf,
    /// Page side in texels.
    #[arg(long, default_value_t = 1024)]
    resolution: u32,
    /// Padding in texels.
    #[arg(long, default_value_t = 2)]
    padding: u32,
    /// Stop a peer after this many seconds (xatlas takes minutes on 100k triangles).
    #[arg(long, default_value_t = 900.0)]
    peer_timeout_s: f64,
    /// Print JSON rows instead of the table.
    #[arg(long)]
    json: bool,
    /// Passed by `cargo bench`; ignored.
    #[arg(long = "bench", hide = true)]
    cargo_bench: bool,
}

#[derive(Debug, Subcommand)]
enum ChildCommand {
    /// Internal: unwrap one file in this process and print one JSON row.
    #[command(hide = true)]
    Child(ChildArgs),
}

#[derive(Debug, clap::Args)]
struct ChildArgs {
    #[arg(long)]
    input: PathBuf,
    #[arg(long)]
    output: PathBuf,
    #[arg(long)]
    resolution: u32,
    #[arg(long)]
    padding: u32,
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
            eprintln!("pipeline bench: error: {err:#}");
            ExitCode::from(2)
        }
    }
}

fn bench(args: &PipelineArgs) -> anyhow::Result<()> {
    let json = args.json;
    let BenchRows { rows, pack } = run(args, |row| {
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
    if json && args.pack_peers {
        let both = serde_json::json!({ "pipeline": rows, "pack": pack });
        println!("{}", serde_json::to_string_pretty(&both)?);
    } else if json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        print!("{}", format_table(&rows));
        if args.pack_peers {
            println!();
            print!(
                "{}",
                pack_peers::format_pack_table(&pack, args.resolution, args.padding)
            );
        }
    }
    Ok(())
}

/// The files of `args`, every tool on each.
fn run(args: &PipelineArgs, on_row: impl FnMut(&PipelineRow)) -> anyhow::Result<BenchRows> {
    let mut files = if args.files.is_empty() {
        corpus_files(&args.corpus).with_context(|| {
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
        bail!("no files to benchmark");
    }
    let work_dir = tempfile::Builder::new()
        .prefix("texatlas-bench-")
        .tempdir()
        .context("creating a work directory")?;
    let config = BenchConfig {
        exe: std::env::current_exe()?,
        eval_dir: args.eval_dir.clone(),
        peers: args.peers,
        pack_peers: args.pack_peers,
        eval: args.eval,
        resolution: args.resolution,
        padding: args.padding,
        peer_timeout: Duration::from_secs_f64(args.peer_timeout_s.max(1.0)),
        work_dir: work_dir.path().to_path_buf(),
    };
    run_bench(&files, &config, on_row)
}

fn child(args: &ChildArgs) -> anyhow::Result<()> {
    let loaded = common::load_asset(&args.input)?;
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
        peak_mib: common::peak_rss_mib(),
        eval: None,
        report: Quality::from_report(&report),
        pack_s: report
            .pointer("/timings_s/pack")
            .and_then(serde_json::Value::as_f64),
        uv_sets: report
            .get("uv_set_per_primitive")
            .and_then(serde_json::Value::as_array)
            .map(|a| a.iter().filter_map(serde_json::Value::as_u64).collect()),
        error: None,
    };
    println!("{}", serde_json::to_string(&row)?);
    Ok(())
}

/// One row of the table: one tool on one file.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
struct PipelineRow {
    /// File name.
    file: String,
    /// `texatlas`, `xatlas` or `uvunwrap`.
    tool: String,
    /// Triangles of the input.
    triangles: usize,
    /// Seconds per stage (texatlas only): build, segment, parameterize, pack, measure, encode.
    stages_s: Option<[f64; 6]>,
    /// Seconds of the timed part (see the module doc).
    total_s: f64,
    /// Peak resident memory of the process that did the work, MiB.
    peak_mib: f64,
    /// Quality of the output as the evaluator measured it (`None` without `--peers`/`--eval`).
    eval: Option<Quality>,
    /// Quality from texatlas's own report (texatlas only).
    report: Option<Quality>,
    /// The pack stage's seconds from our report, `timings_s.pack` (texatlas only).
    #[serde(default)]
    pack_s: Option<f64>,
    /// The atlas's TEXCOORD index per triangle primitive, the report's `uv_set_per_primitive`
    /// (texatlas only).
    #[serde(default)]
    uv_sets: Option<Vec<u64>>,
    /// Why the tool failed on this file, if it did.
    error: Option<String>,
}

/// The quality columns.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq)]
struct Quality {
    /// Charts.
    charts: u64,
    /// Sander L2 stretch (global normalisation).
    l2: f64,
    /// Symmetric L∞ stretch.
    linf: f64,
    /// Σ UV area / page area.
    packing: f64,
    /// Flipped triangles.
    flipped: u64,
    /// Overlapping triangle pairs.
    overlaps: u64,
}

impl Quality {
    /// The quality keys of an `atlas_eval.py --json` object.
    fn from_eval(v: &serde_json::Value) -> Option<Quality> {
        let f = |p: &str| v.pointer(p).and_then(serde_json::Value::as_f64);
        let u = |p: &str| v.pointer(p).and_then(serde_json::Value::as_u64);
        Some(Quality {
            charts: u("/charts")?,
            l2: f("/stretch/l2")?,
            linf: f("/stretch/linf").unwrap_or(f64::INFINITY),
            packing: f("/packing_efficiency")?,
            flipped: u("/flipped")?,
            overlaps: u("/overlap/pairs").unwrap_or(0),
        })
    }

    /// The quality keys of a texatlas report (`proto/report.schema.json`).
    fn from_report(v: &serde_json::Value) -> Option<Quality> {
        let f = |p: &str| v.pointer(p).and_then(serde_json::Value::as_f64);
        let u = |p: &str| v.pointer(p).and_then(serde_json::Value::as_u64);
        Some(Quality {
            charts: u("/quality/charts")?,
            l2: f("/quality/stretch/l2")?,
            linf: f("/quality/stretch/linf").unwrap_or(f64::INFINITY),
            packing: f("/quality/packing_efficiency")?,
            flipped: u("/quality/flipped")?,
            overlaps: u("/quality/overlap/exact/pairs")?,
        })
    }
}

/// What to run.
#[derive(Debug, Clone)]
struct BenchConfig {
    /// This bench's executable (the child runs its `child` subcommand).
    exe: PathBuf,
    /// Directory of `atlas_eval.py`, `peer_xatlas.py`, `peer_uvunwrap.py`.
    eval_dir: PathBuf,
    /// Run the peers (implies `eval`).
    peers: bool,
    /// Pack our charts again with the peers' packers.
    pack_peers: bool,
    /// Measure every output with the evaluator.
    eval: bool,
    /// Page side, texels.
    resolution: u32,
    /// Padding, texels.
    padding: u32,
    /// A peer still running after this long is stopped and reported as such.
    peer_timeout: Duration,
    /// Where outputs go.
    work_dir: PathBuf,
}

/// Every corpus `.glb` in `dir`, sorted.
fn corpus_files(dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("reading the corpus directory {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "glb"))
        .collect();
    files.sort();
    Ok(files)
}

/// The rows of a run: whole pipelines, and packing alone (`--pack-peers`).
#[derive(Debug, Default)]
struct BenchRows {
    rows: Vec<PipelineRow>,
    pack: Vec<pack_peers::PackRow>,
}

/// Runs every tool on every file; `on_row` sees each pipeline row as it is measured.
fn run_bench(
    files: &[PathBuf],
    config: &BenchConfig,
    mut on_row: impl FnMut(&PipelineRow),
) -> anyhow::Result<BenchRows> {
    std::fs::create_dir_all(&config.work_dir)
        .with_context(|| format!("creating {}", config.work_dir.display()))?;
    let pack_config = pack_peers::PackPeersConfig {
        script: pack_peers::script(),
        eval_dir: config.eval_dir.clone(),
        resolution: config.resolution,
        padding: config.padding,
        timeout: config.peer_timeout,
        work_dir: config.work_dir.clone(),
    };
    let mut rows = Vec::new();
    let mut pack = Vec::new();
    for file in files {
        let name = file
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let stem = file
            .file_stem()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let ours_out = config.work_dir.join(format!("{stem}.texatlas.glb"));
        let mut row = run_ours(file, &ours_out, config);
        row.file = name.clone();
        if (config.eval || config.peers) && row.error.is_none() {
            // The atlas's UV set (TEXCOORD_1 where the input had a TEXCOORD_0 of its own).
            let uv = row
                .uv_sets
                .as_deref()
                .and_then(|sets| sets.first().copied());
            row.eval = run_eval(&ours_out, uv, config).ok();
        }
        let triangles = row.triangles;
        on_row(&row);
        if config.pack_peers && row.error.is_none() {
            let packed = pack_peers::pack_rows(
                &name,
                file,
                &ours_out,
                row.uv_sets.as_deref().unwrap_or_default(),
                row.pack_s,
                row.report.map(|q| q.charts),
                &pack_config,
            );
            for p in &packed {
                if let Some(e) = &p.error {
                    eprintln!("{} pack {}: failed: {e}", p.file, p.packer);
                }
            }
            pack.extend(packed);
        }
        rows.push(row);
        if config.peers {
            for tool in ["xatlas", "uvunwrap"] {
                let out = config.work_dir.join(format!("{stem}.{tool}.glb"));
                let mut row = run_peer(tool, file, &out, config);
                row.file = name.clone();
                if row.triangles == 0 {
                    row.triangles = triangles;
                }
                if row.error.is_none() {
                    match run_eval(&out, None, config) {
                        Ok(q) => row.eval = Some(q),
                        Err(e) => row.error = Some(format!("evaluator: {e:#}")),
                    }
                }
                on_row(&row);
                rows.push(row);
            }
        }
    }
    Ok(BenchRows { rows, pack })
}

fn run_ours(file: &Path, out: &Path, config: &BenchConfig) -> PipelineRow {
    let result = Command::new(&config.exe)
        .args(["child", "--input"])
        .arg(file)
        .arg("--output")
        .arg(out)
        .args(["--resolution", &config.resolution.to_string()])
        .args(["--padding", &config.padding.to_string()])
        .output();
    let failed = |e: String| PipelineRow {
        tool: "texatlas".into(),
        error: Some(e),
        ..PipelineRow::default()
    };
    match result {
        Err(e) => failed(format!("cannot run {}: {e}", config.exe.display())),
        Ok(o) if !o.status.success() => failed(
            String::from_utf8_lossy(&o.stderr)
                .trim()
                .lines()
                .last()
                .unwrap_or("failed")
                .to_string(),
        ),
        Ok(o) => serde_json::from_slice(&o.stdout)
            .unwrap_or_else(|e| failed(format!("child output is not a row: {e}"))),
    }
}

/// Wraps a command so that its peak RSS (KiB) is written to `rss_file`.
const RSS_WRAPPER: &str = "import json,resource,subprocess,sys\n\
r=subprocess.run(sys.argv[2:],stdout=subprocess.PIPE,stderr=subprocess.PIPE,timeout=float(sys.argv[1]))\n\
sys.stdout.write(r.stdout.decode());sys.stderr.write(r.stderr.decode())\n\
sys.stderr.write('\\nRSS_KIB=%d\\n'%resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n\
sys.exit(r.returncode)";

fn run_peer(tool: &str, file: &Path, out: &Path, config: &BenchConfig) -> PipelineRow {
    let script = config.eval_dir.join(format!("peer_{tool}.py"));
    let mut row = PipelineRow {
        tool: tool.into(),
        ..PipelineRow::default()
    };
    let result = Command::new("python3")
        .args(["-c", RSS_WRAPPER])
        .arg(config.peer_timeout.as_secs_f64().to_string())
        .arg("python3")
        .arg(&script)
        .arg(file)
        .arg(out)
        .args(["--resolution", &config.resolution.to_string()])
        .args(["--padding", &config.padding.to_string()])
        .arg("--json")
        .output();
    let o = match result {
        Ok(o) => o,
        Err(e) => {
            row.error = Some(format!("cannot run python3: {e}"));
            return row;
        }
    };
    let stderr = String::from_utf8_lossy(&o.stderr);
    if let Some(kib) = stderr
        .lines()
        .rev()
        .find_map(|l| l.strip_prefix("RSS_KIB="))
        .and_then(|k| k.trim().parse::<f64>().ok())
    {
        row.peak_mib = kib / 1024.0;
    }
    if !o.status.success() {
        let why = if stderr.contains("TimeoutExpired") {
            format!("stopped after {:.0} s", config.peer_timeout.as_secs_f64())
        } else {
            stderr
                .lines()
                .rfind(|l| !l.trim().is_empty() && !l.starts_with("RSS_KIB="))
                .unwrap_or("failed")
                .to_string()
        };
        row.error = Some(why);
        return row;
    }
    let v: serde_json::Value = match serde_json::from_slice(&o.stdout) {
        Ok(v) => v,
        Err(e) => {
            row.error = Some(format!("peer output is not JSON: {e}"));
            return row;
        }
    };
    row.triangles = v.get("triangles").and_then(|t| t.as_u64()).unwrap_or(0) as usize;
    row.total_s = v
        .get(format!("{tool}_s"))
        .and_then(|t| t.as_f64())
        .unwrap_or(f64::NAN);
    row
}

/// The evaluator's quality of `out`, its atlas in TEXCOORD_`uv` (0 when `None`).
fn run_eval(out: &Path, uv: Option<u64>, config: &BenchConfig) -> anyhow::Result<Quality> {
    let v = evaluator_json(
        &config.eval_dir,
        out,
        None,
        uv,
        config.resolution,
        config.padding,
    )?;
    Quality::from_eval(&v).context("the evaluator's JSON lacks a quality key")
}

/// `atlas_eval.py GLB [--input INPUT] [--uv K] --resolution R --padding P --json` of
/// `eval_dir`, parsed.
fn evaluator_json(
    eval_dir: &Path,
    glb: &Path,
    input: Option<&Path>,
    uv: Option<u64>,
    resolution: u32,
    padding: u32,
) -> anyhow::Result<serde_json::Value> {
    let mut cmd = Command::new("python3");
    cmd.arg(eval_dir.join("atlas_eval.py")).arg(glb);
    if let Some(input) = input {
        cmd.arg("--input").arg(input);
    }
    if let Some(uv) = uv {
        cmd.args(["--uv", &uv.to_string()]);
    }
    let o = cmd
        .args(["--resolution", &resolution.to_string()])
        .args(["--padding", &padding.to_string()])
        .arg("--json")
        .output()
        .context("running python3 atlas_eval.py")?;
    if !o.status.success() {
        bail!("{}", String::from_utf8_lossy(&o.stderr).trim());
    }
    Ok(serde_json::from_slice(&o.stdout)?)
}

/// The table: one line per tool and file, then the time ratios per file.
fn format_table(rows: &[PipelineRow]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| file | tool | triangles | build+segment+param+pack+measure+encode s | total s | peak MiB | charts | L2 | L∞ | packing | flips | overlaps | measured by |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let stages = r.stages_s.map_or_else(
            || "–".to_string(),
            |st| {
                st.iter()
                    .map(|x| format!("{x:.2}"))
                    .collect::<Vec<_>>()
                    .join("+")
            },
        );
        if let Some(e) = &r.error {
            let _ = writeln!(
                s,
                "| {} | {} | {} | – | – | {:.0} | failed: {e} |||||| |",
                r.file, r.tool, r.triangles, r.peak_mib
            );
            continue;
        }
        let mut quality = vec![];
        if let Some(q) = r.eval {
            quality.push((q, "atlas_eval"));
        }
        if let Some(q) = r.report {
            quality.push((q, "own report"));
        }
        for (i, (q, by)) in quality.iter().enumerate() {
            let (stages, total, peak) = if i == 0 {
                (
                    stages.clone(),
                    format!("{:.3}", r.total_s),
                    format!("{:.0}", r.peak_mib),
                )
            } else {
                ("″".into(), "″".into(), "″".into())
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} | {stages} | {total} | {peak} | {} | {:.4} | {:.3} | {:.3} | {} | {} | {by} |",
                r.file, r.tool, r.triangles, q.charts, q.l2, q.linf, q.packing, q.flipped, q.overlaps
            );
        }
    }
    // Ratios, per file, measured in this run.
    let mut files: Vec<&str> = rows.iter().map(|r| r.file.as_str()).collect();
    files.dedup();
    let mut ratio_lines = Vec::new();
    for f in files {
        let get = |tool: &str| {
            rows.iter()
                .find(|r| r.file == f && r.tool == tool && r.error.is_none())
        };
        let Some(ours) = get("texatlas") else {
            continue;
        };
        let mut parts = Vec::new();
        for peer in ["xatlas", "uvunwrap"] {
            if let Some(p) = get(peer) {
                if ours.total_s > 0.0 && p.total_s.is_finite() {
                    parts.push(format!(
                        "{peer} {:.1}× our time, {:.2}× our memory",
                        p.total_s / ours.total_s,
                        p.peak_mib / ours.peak_mib.max(1e-9)
                    ));
                }
            } else if rows.iter().any(|r| r.file == f && r.tool == peer) {
                parts.push(format!("{peer} failed or was stopped"));
            }
        }
        if !parts.is_empty() {
            ratio_lines.push(format!("- {f}: {}", parts.join("; ")));
        }
    }
    if !ratio_lines.is_empty() {
        let _ = writeln!(s, "\nRatios (same run):");
        for l in ratio_lines {
            let _ = writeln!(s, "{l}");
        }
    }
    s
}

/// Run by `cargo test` (this target has `test = true`, `harness = false`).
#[cfg(test)]
mod self_tests {
    use super::*;

    pub const TESTS: &[(&str, fn())] = &[
        (
            "unwraps_a_fixture_in_a_child_process_with_stage_times_and_quality",
            unwraps_a_fixture_in_a_child_process_with_stage_times_and_quality,
        ),
        (
            "a_file_that_fails_is_a_row_with_its_error",
            a_file_that_fails_is_a_row_with_its_error,
        ),
        (
            "pack_eval_reads_the_evaluators_keys_and_refuses_a_missing_one",
            pack_eval_reads_the_evaluators_keys_and_refuses_a_missing_one,
        ),
        (
            "the_pack_script_output_parses",
            the_pack_script_output_parses,
        ),
        (
            "the_pack_table_notes_merged_and_split_charts_and_gives_time_ratios",
            the_pack_table_notes_merged_and_split_charts_and_gives_time_ratios,
        ),
    ];

    fn unwraps_a_fixture_in_a_child_process_with_stage_times_and_quality() {
        let fixture = common::fixture("Box.glb");
        let cli = Cli::try_parse_from(["pipeline".as_ref(), fixture.as_os_str()]).expect("args");
        assert!(cli.child.is_none() && !cli.args.peers && !cli.args.eval);
        let rows = run(&cli.args, |_| {}).expect("bench").rows;
        assert_eq!(rows.len(), 1, "{rows:?}");
        let row = &rows[0];
        assert_eq!(
            (row.file.as_str(), row.tool.as_str()),
            ("Box.glb", "texatlas")
        );
        assert_eq!(row.error, None);
        assert_eq!(row.triangles, 12);
        let stages = row.stages_s.expect("stage times");
        assert!(
            stages.iter().all(|s| s.is_finite() && *s >= 0.0),
            "{stages:?}"
        );
        assert!(row.total_s >= stages.iter().sum::<f64>() * 0.5, "{row:?}");
        assert!(row.peak_mib > 0.0, "VmHWM read from the child");
        let quality = row.report.expect("quality from our report");
        assert!(quality.charts >= 1);
        assert_eq!((quality.flipped, quality.overlaps), (0, 0));
        assert!(row.eval.is_none(), "no evaluator without --eval");
        let pack_s = row.pack_s.expect("timings_s.pack from our report");
        assert!(
            pack_s.is_finite() && pack_s >= 0.0 && pack_s <= row.total_s,
            "{row:?}"
        );
        assert_eq!(
            row.uv_sets.as_ref().map(Vec::len),
            Some(1),
            "one UV set for Box's one triangle primitive: {row:?}"
        );
        let table = format_table(&rows);
        assert!(table.contains("| Box.glb | texatlas | 12 |"), "{table}");
    }

    fn pack_eval_reads_the_evaluators_keys_and_refuses_a_missing_one() {
        let mut v = serde_json::json!({
            "charts": 21,
            "packing_efficiency": 0.6615,
            "overlap": {"pairs": 3, "fraction": 0.0},
            "padding": {"padding": 2, "violation_texels": 17},
            "out_of_range_corners": 0,
            "roundtrip": {"position_mismatched_triangles": 5, "ok": false},
        });
        assert_eq!(
            pack_peers::PackEval::from_eval(&v),
            Some(pack_peers::PackEval {
                charts: 21,
                packing: 0.6615,
                overlaps: 3,
                padding_violation_texels: 17,
                out_of_range_corners: 0,
                position_mismatched_triangles: 5,
            })
        );
        v["padding"]
            .as_object_mut()
            .expect("object")
            .remove("violation_texels");
        assert_eq!(pack_peers::PackEval::from_eval(&v), None);
    }

    fn the_pack_script_output_parses() {
        let text = r#"{"input": "bunny.texatlas.glb", "uv_area": 0.66, "packers": [
            {"packer": "texatlas", "glb": "/w/a.glb", "pack_s": null, "packings": null,
             "page": [1024, 1024], "pages": 1, "area_scale_spread": 1.0, "notes": []},
            {"packer": "xatlas-bisect", "glb": "/w/b.glb", "pack_s": 1.25, "packings": 11,
             "page": [1024, 1024], "pages": 1, "area_scale_spread": null, "notes": ["11 packings"]}]}"#;
        let out: pack_peers::ScriptOutput = serde_json::from_str(text).expect("parses");
        assert_eq!(out.packers.len(), 2);
        let b = &out.packers[1];
        assert_eq!(
            (b.packer.as_str(), b.glb.as_path(), b.pack_s, b.packings),
            ("xatlas-bisect", Path::new("/w/b.glb"), Some(1.25), Some(11))
        );
        assert_eq!((b.area_scale_spread, b.notes.len()), (None, 1));
        assert_eq!(out.packers[0].pack_s, None);
    }

    fn the_pack_table_notes_merged_and_split_charts_and_gives_time_ratios() {
        let row = |packer: &str, pack_s: f64, packings: u32, charts: u64| pack_peers::PackRow {
            file: "bunny.glb".into(),
            packer: packer.into(),
            pack_s: Some(pack_s),
            packings: Some(packings),
            eval: Some(pack_peers::PackEval {
                charts,
                packing: 0.5,
                ..pack_peers::PackEval::default()
            }),
            ..pack_peers::PackRow::default()
        };
        let mut rows = vec![
            row("texatlas", 0.1, 1, 21),
            row("xatlas-bisect", 1.1, 11, 21),
            row("xatlas-plain", 0.05, 1, 20),
            row("uvunwrap", 0.2, 1, 23),
        ];
        pack_peers::add_chart_notes(&mut rows, Some(22));
        assert_eq!(rows[0].notes, ["our report counts 22 charts"]);
        assert!(rows[1].notes.is_empty(), "{:?}", rows[1].notes);
        assert_eq!(rows[2].notes, ["merged charts: 20 of our 21"]);
        assert_eq!(rows[3].notes, ["split charts: 23 from our 21"]);
        let table = pack_peers::format_pack_table(&rows, 1024, 2);
        assert!(
            table.contains("| bunny.glb | xatlas-plain | 20 | 0.050 | 0.500 | 0 | 0 | merged charts: 20 of our 21 |"),
            "{table}"
        );
        assert!(
            table.contains(
                "- bunny.glb: xatlas-bisect 11.00× (11 packings; one packing 1.00×), xatlas-plain 0.50×, uvunwrap 2.00×"
            ),
            "{table}"
        );
    }

    fn a_file_that_fails_is_a_row_with_its_error() {
        let dir = tempfile::tempdir().expect("tmp");
        let bad = dir.path().join("bad.glb");
        std::fs::write(&bad, b"not a glb").expect("write");
        let cli = Cli::try_parse_from(["pipeline".as_ref(), bad.as_os_str()]).expect("args");
        let rows = run(&cli.args, |_| {}).expect("bench").rows;
        assert_eq!(rows.len(), 1);
        assert_eq!(rows[0].file, "bad.glb");
        assert!(
            rows[0].error.as_deref().is_some_and(|e| !e.is_empty()),
            "{rows:?}"
        );
    }
}
