//! Shared by the bench targets (`benches/pipeline.rs`, `benches/parameterize.rs`): asset loading,
//! peak memory, and the small test runner their self-tests use.
//!
//! The benches are not part of the shipped library or binary: `cargo bench` builds them (with the
//! `bench` profile, which inherits `release`); `cargo test` builds them in test mode and runs
//! their self-tests (`test = true`, `harness = false` in Cargo.toml). Each bench re-runs its own
//! executable as a child process (subcommand `child`) for every measurement, so that the
//! measured peak memory is that of one measurement alone.
#![allow(dead_code)] // each bench uses a part of this module

use std::path::Path;
use std::process::ExitCode;

/// The CLI's loader (`src/cli/load.rs`, part of the binary crate, not of the library), compiled
/// into the bench too so that both read assets the same way.
#[path = "../../src/cli/load.rs"]
mod load;

pub use load::load_asset;

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

/// A file of `tests/fixtures`.
pub fn fixture(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// Whether a bench compiled with `cfg(test)` was started to run its self-tests: by `cargo test`,
/// not as a measurement child (`EXE child …`) and not by `cargo bench`, which also compiles the
/// benches with `cfg(test)` (they have `test = true`) and passes `--bench`.
pub fn is_self_test_invocation() -> bool {
    let args: Vec<String> = std::env::args().skip(1).collect();
    args.first().map(String::as_str) != Some("child") && !args.iter().any(|a| a == "--bench")
}

/// The test runner of a bench built by `cargo test` (the bench targets have no libtest harness):
/// runs every test whose name contains one of the non-flag arguments (all without one), prints
/// `test NAME ... ok|FAILED` and fails when any test panicked.
pub fn run_self_tests(tests: &[(&str, fn())]) -> ExitCode {
    let filters: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let selected: Vec<_> = tests
        .iter()
        .filter(|(name, _)| filters.is_empty() || filters.iter().any(|f| name.contains(f.as_str())))
        .collect();
    let total = selected.len();
    println!("\nrunning {total} tests");
    let mut failed = Vec::new();
    for (name, test) in selected {
        print!("test {name} ... ");
        let _ = std::io::Write::flush(&mut std::io::stdout());
        match std::panic::catch_unwind(test) {
            Ok(()) => println!("ok"),
            Err(_) => {
                println!("FAILED");
                failed.push(*name);
            }
        }
    }
    if failed.is_empty() {
        println!("\ntest result: ok. {total} passed");
        ExitCode::SUCCESS
    } else {
        println!(
            "\ntest result: FAILED. {} passed, {} failed: {}",
            total - failed.len(),
            failed.len(),
            failed.join(", ")
        );
        ExitCode::FAILURE
    }
}
