//! The parameterize benchmark end to end: the real binary's hidden child subcommand, one small
//! generated chart, every method (no timing assertions: timings are printed, not tested).
use std::path::Path;

use texatlas::bench::parameterize::{height_field, run_bench, BenchMethod};

#[test]
fn bench_runs_every_method_in_child_processes() {
    let exe = Path::new(env!("CARGO_BIN_EXE_texatlas"));
    let charts = vec![("tiny".to_string(), height_field(3_000))];
    let mut seen = 0;
    let rows = run_bench(
        exe,
        &charts,
        &[
            BenchMethod::LscmCg,
            BenchMethod::Hlscm,
            BenchMethod::LscmDirect,
        ],
        60.0,
        |_| seen += 1,
    )
    .expect("bench");
    assert_eq!(seen, 3);
    let names: Vec<&str> = rows.iter().map(|r| r.method.as_str()).collect();
    // The direct solve runs first: it is the reference energy of the others.
    assert_eq!(names, ["lscm_direct", "hlscm", "lscm_cg"]);
    let direct = &rows[0];
    for r in &rows {
        assert!(r.peak_mib > 0.0, "VmHWM read from the child");
        assert_eq!(r.flipped_faces, 0);
        assert!(r.converged, "{r:?}");
        assert_eq!(r.triangles, charts[0].1.triangles.len());
    }
    for r in &rows[1..] {
        let rel = r.energy_rel_to_direct.expect("relative to direct");
        assert!(rel <= 1e-4, "{} {rel}", r.method);
        assert!((r.energy - direct.energy).abs() <= 1e-4 * direct.energy);
    }
}

fn fixture(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
        .display()
        .to_string()
}

#[test]
fn bench_input_flattens_a_disk_shaped_asset() {
    // The strip fixture is a quad (2 triangles): one disk.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_texatlas"))
        .args([
            "bench",
            "parameterize",
            "--json",
            "--methods",
            "lscm-direct,hlscm",
            "--input",
        ])
        .arg(fixture("Mesh_PrimitiveMode_04_strip.glb"))
        .output()
        .expect("run");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json rows");
    let rows = rows.as_array().expect("array");
    assert_eq!(rows.len(), 2);
    for r in rows {
        assert_eq!(r["chart"], "Mesh_PrimitiveMode_04_strip");
        assert_eq!(r["triangles"], 2);
        assert_eq!(r["flipped_faces"], 0);
    }
}

#[test]
fn bench_input_refuses_a_closed_mesh_and_says_why() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_texatlas"))
        .args(["bench", "parameterize", "--input"])
        .arg(fixture("Box.glb"))
        .output()
        .expect("run");
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("not one topological disk"), "{err}");
    assert!(err.contains("χ = 2"), "{err}");
}
