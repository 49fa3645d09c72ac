//! `texatlas bench parameterize`: LSCM direct vs single-level Jacobi-CG vs HLSCM.
//!
//! Purpose: the measurement behind issue 3's targets and behind
//! [`crate::atlas::parameterize::FlattenOptions::auto_hierarchical_min_vertices`].
//!
//! How: the parent generates (or is given) each chart, writes it once to a raw file in the
//! temp directory, then runs every method in a child process of the same binary (hidden
//! subcommand `bench parameterize-child`), so that each method's peak memory (`VmHWM` of the
//! child, read from `/proc/self/status`) is isolated. Order per chart: `lscm_direct` first (its
//! energy is the reference), then `hlscm`, then `lscm_cg`, which runs Jacobi-CG from zero until
//! its energy is within `1e-4` relative of the direct energy, or the timeout (default 300 s).
//!
//! Timed: chart validation, pin selection, assembly and solve (everything
//! `flatten_chart` does). Not timed: mesh generation and file IO.
//!
//! This module is NOT core: it uses wall-clock time, processes and the filesystem.
use std::io::{Read, Write};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context};
use serde::{Deserialize, Serialize};

use crate::atlas::parameterize::chart::ChartMesh;
use crate::atlas::parameterize::hlscm::{build_hierarchy, HlscmOptions};
use crate::atlas::parameterize::lscm::{diameter_pins, LscmSystem};
use crate::atlas::parameterize::{
    conformal_energy, flatten_chart, flipped_faces, FlattenOptions, ParameterizeMethod,
};
use crate::atlas::{Stage, StageProgress};
use crate::numerics::CgOptions;

/// The three benchmarked methods.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum BenchMethod {
    /// Sparse Cholesky on the normal equations.
    LscmDirect,
    /// Cascadic multigrid (HLSCM).
    Hlscm,
    /// Single-level Jacobi-CG from zero to the direct energy (or timeout).
    LscmCg,
}

impl BenchMethod {
    /// Name used in tables and JSON.
    pub fn name(self) -> &'static str {
        match self {
            BenchMethod::LscmDirect => "lscm_direct",
            BenchMethod::Hlscm => "hlscm",
            BenchMethod::LscmCg => "lscm_cg",
        }
    }
}

/// One measured row.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BenchRow {
    /// Chart label (e.g. `heightfield-1000000`).
    pub chart: String,
    /// Chart triangles.
    pub triangles: usize,
    /// Chart vertices.
    pub vertices: usize,
    /// Method name.
    pub method: String,
    /// Wall-clock seconds of the timed part.
    pub seconds: f64,
    /// Peak resident memory of the child process, MiB (`VmHWM`).
    pub peak_mib: f64,
    /// CG iterations (finest level for HLSCM; 0 for direct).
    pub iterations: usize,
    /// `C(U)` recomputed from the UVs.
    pub energy: f64,
    /// `|C − C_direct| / C_direct` (0 for the direct row).
    pub energy_rel_to_direct: Option<f64>,
    /// Whether the method met its stopping rule (CG: reached the direct energy in time).
    pub converged: bool,
    /// Flipped faces in the result.
    pub flipped_faces: usize,
    /// HLSCM levels (vertices, iterations), coarsest first.
    pub levels: Vec<(usize, usize)>,
    /// Seconds per phase, when the method has phases (HLSCM).
    pub phases: Vec<(String, f64)>,
}

/// Deterministic disk-topology height field with multi-scale bumps, about `triangles`
/// triangles: an `m × m` grid over the unit square (`2m²` triangles) with heights summed from
/// five octaves of products of sines and a few Gaussian bumps, from a fixed-seed generator.
pub fn height_field(triangles: usize) -> ChartMesh {
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
pub fn write_chart(path: &Path, chart: &ChartMesh) -> anyhow::Result<()> {
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
pub fn read_chart(path: &Path) -> anyhow::Result<ChartMesh> {
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

/// Peak resident set size of this process in MiB (`VmHWM`), 0 if unavailable.
pub fn peak_rss_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map(|kb| kb / 1024.0)
        .unwrap_or(0.0)
}

/// Runs one method on one chart in this process (the child side). `reference_energy` is the
/// direct energy, the target of `lscm_cg`.
pub fn run_method(
    label: &str,
    chart: &ChartMesh,
    method: BenchMethod,
    reference_energy: Option<f64>,
    cg_timeout_s: f64,
) -> anyhow::Result<BenchRow> {
    let start = Instant::now();
    let mut phases: Vec<(String, f64)> = Vec::new();
    let (uv, iterations, converged, levels) = match method {
        BenchMethod::LscmDirect => {
            let options = FlattenOptions {
                method: ParameterizeMethod::Direct,
                ..FlattenOptions::default()
            };
            let map = flatten_chart(
                chart,
                &options,
                &mut StageProgress::ignored(Stage::Parameterize),
            )?;
            (map.uv, map.iterations, true, Vec::new())
        }
        BenchMethod::Hlscm => {
            // Same steps as `flatten_chart` with `Hierarchical`, split to time the phases
            // as hlscm-2003 Table 1 does ("PM construction" vs "multigrid").
            let options = hlscm_options_from_env();
            let topology = chart.validate()?;
            let pins = diameter_pins(chart, &topology);
            let t0 = Instant::now();
            let hierarchy = build_hierarchy(chart, &topology, &pins, &options)?;
            let t1 = Instant::now();
            let (uv, report) =
                hierarchy.solve(&options, &mut StageProgress::ignored(Stage::Parameterize))?;
            let t2 = Instant::now();
            phases = vec![
                ("validate+pins".to_string(), (t0 - start).as_secs_f64()),
                ("hierarchy".to_string(), (t1 - t0).as_secs_f64()),
                ("cascadic solve".to_string(), (t2 - t1).as_secs_f64()),
            ];
            let levels = report
                .levels
                .iter()
                .map(|l| (l.vertices, l.iterations))
                .collect();
            (uv, report.finest_iterations, report.converged, levels)
        }
        BenchMethod::LscmCg => {
            let topology = chart.validate()?;
            let pins = diameter_pins(chart, &topology);
            let system = LscmSystem::assemble(chart, &topology, &pins)?;
            let mut x = vec![0.0; system.unknowns()];
            let target =
                reference_energy.map(|e| e + ENERGY_REL_TOLERANCE * energy_scale(chart, e));
            let mut reached = false;
            let options = CgOptions {
                tolerance: 0.0,
                max_iterations: usize::MAX,
            };
            let outcome = system.solve_cg(&mut x, &options, &mut |step| {
                if let Some(t) = target {
                    if system.energy_from_residual(step.x, step.residual) <= t {
                        reached = true;
                        return ControlFlow::Break(());
                    }
                }
                if start.elapsed().as_secs_f64() > cg_timeout_s {
                    return ControlFlow::Break(());
                }
                ControlFlow::Continue(())
            })?;
            (
                system.uv_from_solution(&x),
                outcome.iterations,
                reached,
                Vec::new(),
            )
        }
    };
    let seconds = start.elapsed().as_secs_f64();
    let energy = conformal_energy(chart, &uv);
    Ok(BenchRow {
        chart: label.to_string(),
        triangles: chart.triangles.len(),
        vertices: chart.positions_m.len(),
        method: method.name().to_string(),
        seconds,
        peak_mib: peak_rss_mib(),
        iterations,
        energy,
        energy_rel_to_direct: reference_energy.map(|e| (energy - e).abs() / energy_scale(chart, e)),
        converged,
        flipped_faces: flipped_faces(chart, &uv).len(),
        levels,
        phases,
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
/// that would call an equally exact solution "not converged"; CG's running energy estimate
/// itself is only good to ~1e-16·‖b‖² (see `LscmSystem::energy_from_residual`), so the floor
/// must sit well above that. Curved charts have energies far above the floor (the bench height
/// fields: ~1e-5 × area), where it changes nothing.
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
pub fn run_bench(
    exe: &Path,
    charts: &[(String, ChartMesh)],
    methods: &[BenchMethod],
    cg_timeout_s: f64,
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
            cmd.args(["bench", "parameterize-child", "--chart-file"])
                .arg(&path)
                .args([
                    "--label",
                    label,
                    "--method",
                    clap::ValueEnum::to_possible_value(&method)
                        .map(|v| v.get_name().to_string())
                        .unwrap_or_default()
                        .as_str(),
                ])
                .args(["--cg-timeout-s", &cg_timeout_s.to_string()]);
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
                reference = Some(row.energy);
            }
            on_row(&row);
            rows.push(row);
        }
        let _ = std::fs::remove_file(&path);
    }
    Ok(rows)
}

/// Formats rows as a text table.
pub fn format_table(rows: &[BenchRow]) -> String {
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
    for r in rows {
        let levels: Vec<String> = r.levels.iter().map(|(v, i)| format!("{v}:{i}")).collect();
        s.push_str(&format!(
            "{:<22} {:>9} {:<12} {:>9.3} {:>9.1} {:>7} {:>14.8e} {:>10} {:>5} {:>5}  {}\n",
            r.chart,
            r.triangles,
            r.method,
            r.seconds,
            r.peak_mib,
            r.iterations,
            r.energy,
            r.energy_rel_to_direct
                .map(|e| format!("{e:.2e}"))
                .unwrap_or_else(|| "-".into()),
            r.converged,
            r.flipped_faces,
            levels.join(" ")
        ));
        for (name, secs) in &r.phases {
            s.push_str(&format!("{:<22}   phase {name}: {secs:.3} s\n", ""));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn height_field_is_a_deterministic_disk_of_the_requested_size() {
        let a = height_field(5_000);
        let b = height_field(5_000);
        assert_eq!(a, b);
        assert!((a.triangles.len() as f64 - 5_000.0).abs() < 200.0);
        a.validate().expect("disk");
        let zmax = a.positions_m.iter().map(|p| p[2].abs()).fold(0.0, f64::max);
        assert!(zmax > 0.01 && zmax < 0.5, "{zmax}");
    }

    #[test]
    fn chart_file_round_trips_and_rejects_truncation() {
        let chart = height_field(200);
        let dir = std::env::temp_dir().join(format!("texatlas-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        let path = dir.join("c.chart");
        write_chart(&path, &chart).expect("write");
        assert_eq!(read_chart(&path).expect("read"), chart);
        let bytes = std::fs::read(&path).expect("read");
        std::fs::write(&path, &bytes[..bytes.len() - 3]).expect("write");
        assert!(read_chart(&path).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn run_method_in_process_reports_consistent_rows() {
        let chart = height_field(2_000);
        let direct = run_method("t", &chart, BenchMethod::LscmDirect, None, 10.0).expect("direct");
        let cg =
            run_method("t", &chart, BenchMethod::LscmCg, Some(direct.energy), 30.0).expect("cg");
        assert!(cg.converged, "{cg:?}");
        assert!(cg.energy <= direct.energy * (1.0 + 1e-4) + 1e-15);
        assert!(cg.iterations > 0 && direct.flipped_faces == 0);
        assert!(format_table(&[direct, cg]).lines().count() == 3);
    }
}
