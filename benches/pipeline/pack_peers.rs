//! `--pack-peers`: packing alone, on identical charts, beside xatlas's and uvunwrap's packers.
//!
//! Whole-pipeline rows (`--peers`) compare each tool's own charts, so their packing is not
//! comparable and their pack time is not separate. Here our charts are packed again: per file,
//! `benches/pack_peers.py` reads our output GLB (the atlas in the UV set that our report's
//! `uv_set_per_primitive` names), packs its UV islands with xatlas (density bisected on a fixed
//! page, and one plain call whose page may grow) and uvunwrap (`existing_uvs`), timing the pack
//! calls only, and writes one GLB per packer, ours included. Every GLB is then measured by
//! `atlas_eval.py --input INPUT` at the bench's resolution and padding. Our pack time is the
//! report's `timings_s.pack`. A note says when a peer's output has another chart count than ours
//! (it merged or split charts), scaled charts differently, moved triangles, or needed a page other
//! than the requested one.
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use anyhow::{bail, Context as _};
use serde::{Deserialize, Serialize};

/// The project script that packs our charts with the peers.
pub fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/pack_peers.py")
}

/// What `--pack-peers` needs to run.
#[derive(Debug, Clone)]
pub struct PackPeersConfig {
    /// `benches/pack_peers.py`.
    pub script: PathBuf,
    /// Directory of `atlas_eval.py` and `gltf_write.py`.
    pub eval_dir: PathBuf,
    /// Page side, texels.
    pub resolution: u32,
    /// Padding, texels.
    pub padding: u32,
    /// The script is stopped after this long.
    pub timeout: Duration,
    /// Where the packed GLBs go.
    pub work_dir: PathBuf,
}

/// One packer on one file's charts.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct PackRow {
    /// File name of the input asset.
    pub file: String,
    /// `texatlas`, `xatlas-bisect`, `xatlas-plain` or `uvunwrap`.
    pub packer: String,
    /// Seconds of packing (ours: the report's `timings_s.pack`; peers: their pack calls).
    pub pack_s: Option<f64>,
    /// Packings behind `pack_s` (peers only).
    pub packings: Option<u32>,
    /// The evaluator's measure of the packed GLB.
    pub eval: Option<PackEval>,
    /// What the reader should know about this row (page grown, charts merged…).
    pub notes: Vec<String>,
    /// Why this packer or its measurement failed.
    pub error: Option<String>,
}

/// The evaluator's keys that the pack table shows.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq)]
pub struct PackEval {
    /// Charts (connected by shared position and UV).
    pub charts: u64,
    /// Σ UV area over the unit square.
    pub packing: f64,
    /// Overlapping triangle pairs (sampled at texel centres).
    pub overlaps: u64,
    /// Covered texels with another chart within the padding.
    pub padding_violation_texels: u64,
    /// Corners outside [0, 1].
    pub out_of_range_corners: u64,
    /// Triangles whose positions differ from the input's (round trip).
    pub position_mismatched_triangles: u64,
}

impl PackEval {
    /// The keys of an `atlas_eval.py --input … --json` object; `None` if one is missing.
    pub fn from_eval(v: &serde_json::Value) -> Option<PackEval> {
        let u = |p: &str| v.pointer(p).and_then(serde_json::Value::as_u64);
        Some(PackEval {
            charts: u("/charts")?,
            packing: v
                .pointer("/packing_efficiency")
                .and_then(serde_json::Value::as_f64)?,
            overlaps: u("/overlap/pairs")?,
            padding_violation_texels: u("/padding/violation_texels")?,
            out_of_range_corners: u("/out_of_range_corners")?,
            position_mismatched_triangles: u("/roundtrip/position_mismatched_triangles")?,
        })
    }
}

/// The script's `--json` output.
#[derive(Debug, Deserialize)]
pub struct ScriptOutput {
    pub packers: Vec<ScriptPacker>,
}

/// One packer in the script's output.
#[derive(Debug, Deserialize)]
pub struct ScriptPacker {
    pub packer: String,
    pub glb: PathBuf,
    pub pack_s: Option<f64>,
    pub packings: Option<u32>,
    /// max / min over triangles of (packed UV area / our UV area).
    pub area_scale_spread: Option<f64>,
    pub notes: Vec<String>,
}

/// Packs `ours_glb` (our output of `input`, atlas in `uv_sets`) with every packer and measures the
/// results; ours comes first, with `our_pack_s`. A failure is one row with its error.
pub fn pack_rows(
    file: &str,
    input: &Path,
    ours_glb: &Path,
    uv_sets: &[u64],
    our_pack_s: Option<f64>,
    our_report_charts: Option<u64>,
    config: &PackPeersConfig,
) -> Vec<PackRow> {
    let failed = |e: anyhow::Error| {
        vec![PackRow {
            file: file.into(),
            packer: "pack_peers.py".into(),
            error: Some(format!("{e:#}")),
            ..PackRow::default()
        }]
    };
    let output = match run_script(ours_glb, uv_sets, config) {
        Ok(o) => o,
        Err(e) => return failed(e),
    };
    let mut rows: Vec<PackRow> = output
        .packers
        .into_iter()
        .map(|p| {
            let mut row = PackRow {
                file: file.into(),
                pack_s: if p.packer == "texatlas" {
                    our_pack_s
                } else {
                    p.pack_s
                },
                packings: p.packings,
                notes: p.notes,
                ..PackRow::default()
            };
            if let Some(spread) = p.area_scale_spread.filter(|s| *s > 1.01) {
                row.notes.push(format!(
                    "charts scaled unevenly: UV area ratio to ours spreads ×{spread:.3}"
                ));
            }
            match run_eval(&p.glb, input, config) {
                Ok(q) => row.eval = Some(q),
                Err(e) => row.error = Some(format!("evaluator: {e:#}")),
            }
            row.packer = p.packer;
            row
        })
        .collect();
    add_chart_notes(&mut rows, our_report_charts);
    rows
}

/// Notes where a peer's chart count differs from ours (as the evaluator counts both), where our
/// report counts other charts than the evaluator, and where triangles moved or left the page.
pub fn add_chart_notes(rows: &mut [PackRow], our_report_charts: Option<u64>) {
    let ours = rows
        .iter()
        .find(|r| r.packer == "texatlas")
        .and_then(|r| r.eval)
        .map(|q| q.charts);
    for row in rows.iter_mut() {
        let Some(q) = row.eval else { continue };
        if row.packer == "texatlas" {
            if let Some(n) = our_report_charts.filter(|n| *n != q.charts) {
                row.notes.push(format!("our report counts {n} charts"));
            }
        } else if let Some(n) = ours {
            if q.charts < n {
                row.notes
                    .push(format!("merged charts: {} of our {n}", q.charts));
            } else if q.charts > n {
                row.notes
                    .push(format!("split charts: {} from our {n}", q.charts));
            }
        }
        if q.position_mismatched_triangles > 0 {
            row.notes.push(format!(
                "{} triangles' positions differ from the input",
                q.position_mismatched_triangles
            ));
        }
        if q.out_of_range_corners > 0 {
            row.notes.push(format!(
                "{} UV corners outside [0, 1]",
                q.out_of_range_corners
            ));
        }
    }
}

/// Runs a command under Python's `subprocess.run` timeout (no crate for a child timeout here).
const TIMEOUT_WRAPPER: &str = "import subprocess,sys\n\
sys.exit(subprocess.run(sys.argv[2:],timeout=float(sys.argv[1])).returncode)";

fn run_script(
    ours_glb: &Path,
    uv_sets: &[u64],
    config: &PackPeersConfig,
) -> anyhow::Result<ScriptOutput> {
    if uv_sets.is_empty() {
        bail!("our report names no UV set (uv_set_per_primitive is empty)");
    }
    let sets = uv_sets
        .iter()
        .map(u64::to_string)
        .collect::<Vec<_>>()
        .join(",");
    let o = Command::new("python3")
        .args(["-c", TIMEOUT_WRAPPER])
        .arg(config.timeout.as_secs_f64().to_string())
        .arg("python3")
        .arg(&config.script)
        .arg(ours_glb)
        .arg(&config.work_dir)
        .args(["--uv-sets", &sets])
        .arg("--eval-dir")
        .arg(&config.eval_dir)
        .args(["--resolution", &config.resolution.to_string()])
        .args(["--padding", &config.padding.to_string()])
        .arg("--json")
        .output()
        .context("running python3 benches/pack_peers.py")?;
    if !o.status.success() {
        let stderr = String::from_utf8_lossy(&o.stderr);
        if stderr.contains("TimeoutExpired") {
            bail!(
                "pack_peers.py stopped after {:.0} s",
                config.timeout.as_secs_f64()
            );
        }
        let last = stderr
            .lines()
            .rfind(|l| !l.trim().is_empty())
            .unwrap_or("pack_peers.py failed");
        if stderr.contains("ModuleNotFoundError") {
            bail!("{last} (needs `pip install xatlas uvunwrap numpy`, and --eval-dir at ../shared/eval)");
        }
        bail!("{last}");
    }
    serde_json::from_slice(&o.stdout).context("pack_peers.py's output is not its JSON")
}

fn run_eval(glb: &Path, input: &Path, config: &PackPeersConfig) -> anyhow::Result<PackEval> {
    let v = super::evaluator_json(
        &config.eval_dir,
        glb,
        Some(input),
        None,
        config.resolution,
        config.padding,
    )?;
    PackEval::from_eval(&v).context("the evaluator's JSON lacks a key of the pack table")
}

/// The pack-only table, then per file the pack-time ratios of that run.
pub fn format_pack_table(rows: &[PackRow], resolution: u32, padding: u32) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Packing alone, on our charts ({resolution} px page, {padding} px padding, measured by atlas_eval):\n"
    );
    let _ = writeln!(
        s,
        "| file | packer | charts | pack s | packing efficiency | overlaps | padding violations | notes |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|");
    for r in rows {
        let secs = r.pack_s.map_or_else(|| "–".into(), |t| format!("{t:.3}"));
        let notes = r.notes.join("; ");
        match (&r.error, r.eval) {
            (Some(e), _) => {
                let _ = writeln!(
                    s,
                    "| {} | {} | – | {secs} | – | – | – | failed: {e} |",
                    r.file, r.packer
                );
            }
            (None, Some(q)) => {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {secs} | {:.3} | {} | {} | {notes} |",
                    r.file, r.packer, q.charts, q.packing, q.overlaps, q.padding_violation_texels
                );
            }
            (None, None) => {
                let _ = writeln!(
                    s,
                    "| {} | {} | – | {secs} | – | – | – | not measured |",
                    r.file, r.packer
                );
            }
        }
    }
    let lines = ratio_lines(rows);
    if !lines.is_empty() {
        let _ = writeln!(s, "\nPack time vs ours (same run):");
        for l in lines {
            let _ = writeln!(s, "- {l}");
        }
    }
    s
}

/// Per file: each peer's pack time over ours; for a multi-packing peer also per packing.
fn ratio_lines(rows: &[PackRow]) -> Vec<String> {
    let mut files: Vec<&str> = rows.iter().map(|r| r.file.as_str()).collect();
    files.dedup();
    let mut lines = Vec::new();
    for f in files {
        let ours = rows
            .iter()
            .find(|r| r.file == f && r.packer == "texatlas" && r.error.is_none())
            .and_then(|r| r.pack_s)
            .filter(|t| *t > 0.0);
        let Some(ours) = ours else { continue };
        let parts: Vec<String> = rows
            .iter()
            .filter(|r| r.file == f && r.packer != "texatlas" && r.error.is_none())
            .filter_map(|r| {
                let t = r.pack_s?;
                Some(match r.packings {
                    Some(n) if n > 1 => format!(
                        "{} {:.2}× ({n} packings; one packing {:.2}×)",
                        r.packer,
                        t / ours,
                        t / f64::from(n) / ours
                    ),
                    _ => format!("{} {:.2}×", r.packer, t / ours),
                })
            })
            .collect();
        if !parts.is_empty() {
            lines.push(format!("{f}: {}", parts.join(", ")));
        }
    }
    lines
}
