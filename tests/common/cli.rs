//! The real `texatlas` binary, run as a user runs it.
use std::path::Path;
use std::process::{Command, Output};

/// `texatlas ARGS...`, run to completion.
pub fn texatlas(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_texatlas"))
        .args(args)
        .output()
        .expect("run texatlas")
}

/// The captured standard output, lossily decoded.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The captured standard error, lossily decoded.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A path as a command-line argument.
pub fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}
