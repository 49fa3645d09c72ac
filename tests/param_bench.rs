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
