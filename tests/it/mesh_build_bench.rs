//! Manual measurement of `TriangleMesh::build` at scale (ignored by default; run with
//! `cargo test --release --test it -- mesh_build_bench:: --ignored --nocapture`).
//!
//! - `build_1m_triangle_grid`: a generated 707 × 707 grid (999,698 triangles, 501,264 vertices).
//! - `build_raw_mesh_from_env`: a mesh dumped to a raw file named by `TEXATLAS_RAW_MESH`
//!   (little-endian `u32 num_positions, u32 num_triangles`, then `f32 x,y,z` per position, then
//!   `u32 a,b,c` per triangle), for checks on real assets before `gltf_io` exists. Skipped when
//!   the variable is unset.
use std::time::Instant;

use texatlas::mesh::{fixtures, MeshInput, TriangleMesh};

fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// CPU seconds (user + system, all threads) used by this process so far, from /proc (10 ms
/// ticks). Less sensitive than wall time to other jobs on a shared machine.
fn cpu_secs() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let after = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

fn measure(name: &str, input: &MeshInput) {
    // Best of 3, so one-off page faults of the first run do not dominate.
    let mut best = f64::INFINITY;
    let mut best_cpu = f64::INFINITY;
    let mut summary = String::new();
    for _ in 0..3 {
        let t = Instant::now();
        let cpu0 = cpu_secs().unwrap_or(f64::NAN);
        let built = TriangleMesh::build(input);
        let secs = t.elapsed().as_secs_f64();
        best_cpu = best_cpu.min(cpu_secs().unwrap_or(f64::NAN) - cpu0);
        best = best.min(secs);
        let built = match built {
            Ok(b) => b,
            Err(e) => panic!("{name}: {e}"),
        };
        let mut by_code = std::collections::BTreeMap::new();
        for d in &built.defects {
            *by_code.entry(d.code()).or_insert(0usize) += 1;
        }
        let t = Instant::now();
        let comps = built.mesh.components();
        let comp_secs = t.elapsed().as_secs_f64();
        let genus: Vec<(u32, usize, i64)> = comps
            .components
            .iter()
            .take(5)
            .map(|c| (c.genus, c.num_boundary_loops, c.euler_characteristic))
            .collect();
        summary = format!(
            "{} faces, {} vertices ({} welded), defects {:?} (first: {}), {} components (first 5 as (genus, loops, χ): {genus:?}), {} boundary loops; components() {:.3} s",
            built.mesh.num_faces(),
            built.mesh.num_vertices(),
            built.num_welded_vertices,
            by_code,
            built.defects.first().map(|d| d.to_string()).unwrap_or_default(),
            comps.len(),
            built.mesh.boundary_loops().len(),
            comp_secs
        );
    }
    println!(
        "{name}: build best of 3 = {best:.3} s wall, {best_cpu:.2} s CPU; {summary}; peak RSS {:.0} MB",
        peak_rss_mb().unwrap_or(f64::NAN)
    );
}

#[test]
#[ignore = "measurement; run in release with --ignored --nocapture"]
fn build_1m_triangle_grid() {
    let input = fixtures::grid(707, 707);
    assert_eq!(input.triangles.len(), 999_698);
    measure("grid 707x707", &input);
}

#[test]
#[ignore = "measurement; needs TEXATLAS_RAW_MESH"]
fn build_raw_mesh_from_env() {
    let Ok(path) = std::env::var("TEXATLAS_RAW_MESH") else {
        return;
    };
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let word = |i: usize| {
        u32::from_le_bytes([
            bytes[4 * i],
            bytes[4 * i + 1],
            bytes[4 * i + 2],
            bytes[4 * i + 3],
        ])
    };
    let (np, nt) = (word(0) as usize, word(1) as usize);
    assert_eq!(bytes.len(), 8 + 12 * np + 12 * nt, "raw mesh size");
    let positions_m = (0..np)
        .map(|v| [0, 1, 2].map(|k| f64::from(f32::from_bits(word(2 + 3 * v + k)))))
        .collect();
    let triangles = (0..nt)
        .map(|t| [0, 1, 2].map(|k| word(2 + 3 * np + 3 * t + k)))
        .collect();
    let input = MeshInput {
        positions_m,
        triangles,
        weld_group: vec![0; np],
    };
    measure(&path, &input);
}
