//! The independent checkers the corpus suites call, in one place: the evaluator
//! (`$TEXATLAS_EVAL_DIR/atlas_eval.py`, not written by this project) and the Khronos
//! glTF-Validator (`$TEXATLAS_EVAL_DIR/gltf_validate.js` with `NODE_PATH=$TEXATLAS_GLTF_VALIDATOR`).
//! Both are run as child processes and their JSON is returned as is; the suites decide what to
//! assert.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

/// `$TEXATLAS_EVAL_DIR` when set and not empty.
pub fn eval_dir_from_env() -> Option<PathBuf> {
    std::env::var_os("TEXATLAS_EVAL_DIR")
        .filter(|d| !d.is_empty())
        .map(PathBuf::from)
}

/// `$TEXATLAS_EVAL_DIR`, else `../shared/eval` (the layout of CI).
pub fn eval_dir() -> PathBuf {
    eval_dir_from_env().unwrap_or_else(|| PathBuf::from("../shared/eval"))
}

/// `$TEXATLAS_CORPUS_DIR` when set.
pub fn corpus_dir() -> Option<PathBuf> {
    std::env::var_os("TEXATLAS_CORPUS_DIR").map(PathBuf::from)
}

/// Runs `python3 EVAL_DIR/atlas_eval.py OUTPUT ARGS... --json` and parses its JSON.
pub fn evaluate(eval_dir: &Path, output: &Path, args: &[&str]) -> Result<Value, String> {
    let run = Command::new("python3")
        .arg(eval_dir.join("atlas_eval.py"))
        .arg(output)
        .args(args)
        .arg("--json")
        .output()
        .map_err(|e| format!("cannot run python3: {e}"))?;
    serde_json::from_slice(&run.stdout).map_err(|e| {
        format!(
            "evaluator output is not JSON ({e}); stderr: {}",
            String::from_utf8_lossy(&run.stderr)
        )
    })
}

/// The Khronos validator's JSON report on `file` when `$TEXATLAS_GLTF_VALIDATOR` is set
/// (`Ok(None)` when it is not configured).
pub fn validator_report(file: &Path) -> Result<Option<Value>, String> {
    let Some(node_modules) = std::env::var_os("TEXATLAS_GLTF_VALIDATOR") else {
        return Ok(None);
    };
    let run = Command::new("node")
        .env("NODE_PATH", node_modules)
        .arg(eval_dir().join("gltf_validate.js"))
        .arg(file)
        .output()
        .map_err(|e| format!("cannot run node: {e}"))?;
    serde_json::from_slice(&run.stdout).map(Some).map_err(|e| {
        format!(
            "validator output is not JSON ({e}); stderr: {}",
            String::from_utf8_lossy(&run.stderr)
        )
    })
}

/// The `(code, pointer)` of every error (severity 0) of a validator report.
fn validator_errors(report: &Value) -> Vec<(String, String)> {
    let mut errors: Vec<(String, String)> = report
        .get("messages")
        .and_then(Value::as_array)
        .map(|m| {
            m.iter()
                .filter(|m| m.get("severity").and_then(Value::as_u64) == Some(0))
                .map(|m| {
                    let text = |k: &str| m.get(k).and_then(Value::as_str).unwrap_or("").to_string();
                    (text("code"), text("pointer"))
                })
                .collect()
        })
        .unwrap_or_default();
    errors.sort();
    errors
}

/// [`validate`] for a file made from `input`: `output` may carry the validator errors that
/// `input` already has (an asset comes back untouched, its defects included), and no other.
/// `Ok(None)` when the validator is not configured, `Ok(Some(warnings))` otherwise.
pub fn validate_against_input(output: &Path, input: &Path) -> Result<Option<u64>, String> {
    let (Some(out), Some(inp)) = (validator_report(output)?, validator_report(input)?) else {
        return Ok(None);
    };
    let input_errors = validator_errors(&inp);
    let new: Vec<(String, String)> = validator_errors(&out)
        .into_iter()
        .filter(|e| !input_errors.contains(e))
        .collect();
    // The report counts errors beyond the messages it lists too: the count may not grow.
    let count = |r: &Value| r.get("errors").and_then(Value::as_u64);
    let (Some(out_count), Some(input_count)) = (count(&out), count(&inp)) else {
        return Err(format!(
            "validator report without an error count: {out} / {inp}"
        ));
    };
    if !new.is_empty() || out_count > input_count {
        return Err(format!("validator (errors the input does not have): {out}"));
    }
    Ok(Some(
        out.get("warnings").and_then(Value::as_u64).unwrap_or(0),
    ))
}

/// Runs the Khronos validator on `file` when `$TEXATLAS_GLTF_VALIDATOR` is set: `Ok(None)` when
/// it is not configured, `Ok(Some(warnings))` on 0 errors, `Err` with the validator's report
/// otherwise.
pub fn validate(file: &Path) -> Result<Option<u64>, String> {
    let Some(report) = validator_report(file)? else {
        return Ok(None);
    };
    if report.get("errors").and_then(Value::as_u64) != Some(0) {
        return Err(format!("validator: {report}"));
    }
    Ok(Some(
        report.get("warnings").and_then(Value::as_u64).unwrap_or(0),
    ))
}
