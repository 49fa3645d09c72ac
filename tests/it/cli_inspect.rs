//! `texatlas inspect` as a user runs it: the real binary on fixture files.
use std::path::{Path, PathBuf};

use crate::common::cli::{stderr, stdout, texatlas};
use crate::common::fixture_path as fixture;

fn schema() -> jsonschema::Validator {
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("proto/inspect.schema.json"),
    )
    .expect("schema file");
    let schema: serde_json::Value = serde_json::from_str(&text).expect("schema is JSON");
    jsonschema::validator_for(&schema).expect("schema compiles")
}

fn inspect_json(path: &Path) -> serde_json::Value {
    let out = texatlas(&["inspect", "--json", path.to_str().expect("utf-8 path")]);
    assert!(out.status.success(), "inspect failed: {}", stderr(&out));
    let json: serde_json::Value = serde_json::from_str(&stdout(&out)).expect("stdout is JSON");
    let errors: Vec<String> = schema().iter_errors(&json).map(|e| e.to_string()).collect();
    assert!(
        errors.is_empty(),
        "output violates proto/inspect.schema.json: {errors:#?}"
    );
    json
}

/// Splits a GLB into its JSON text and BIN chunk (the fixtures are well formed).
fn split_glb(glb: &[u8]) -> (serde_json::Value, Vec<u8>) {
    let u32_at = |o: usize| u32::from_le_bytes(glb[o..o + 4].try_into().expect("4 bytes")) as usize;
    let json_len = u32_at(12);
    let json: serde_json::Value =
        serde_json::from_slice(&glb[20..20 + json_len]).expect("json chunk");
    let bin_start = 20 + json_len;
    let bin_len = u32_at(bin_start);
    (json, glb[bin_start + 8..bin_start + 8 + bin_len].to_vec())
}

/// A `.gltf` + `.bin` pair in a fresh temporary directory, from the Box fixture, with buffer 0's
/// URI set to `uri`.
fn gltf_with_external_buffer(dir_name: &str, uri: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("texatlas-cli-{}-{dir_name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    let (mut json, bin) = split_glb(&std::fs::read(fixture("Box.glb")).expect("Box.glb"));
    json["buffers"][0]["uri"] = serde_json::Value::String(uri.to_string());
    std::fs::write(dir.join("box.bin"), &bin).expect("write bin");
    let path = dir.join("box.gltf");
    std::fs::write(&path, serde_json::to_vec(&json).expect("json")).expect("write gltf");
    path
}

#[test]
fn box_text_report_names_the_topology() {
    let out = texatlas(&["inspect", fixture("Box.glb").to_str().expect("path")]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    assert!(text.contains("triangles: 12"), "{text}");
    assert!(text.contains("8 welded vertices"), "{text}");
    assert!(text.contains("χ=2 genus=0"), "{text}");
    assert!(text.contains("defects: none"), "{text}");
}

#[test]
fn box_json_report_matches_schema_and_counts() {
    let json = inspect_json(&fixture("Box.glb"));
    assert_eq!(json["format"], "glb");
    assert_eq!(json["triangles"], 12);
    assert_eq!(json["source_vertices"], 24);
    assert_eq!(json["surface"]["welded_vertices"], 8);
    assert_eq!(json["surface"]["components"][0]["genus"], 0);
    assert_eq!(json["surface"]["components"][0]["euler_characteristic"], 2);
}

#[test]
fn every_fixture_inspects_and_matches_the_schema() {
    let mut seen = 0;
    let mut entries: Vec<_> = std::fs::read_dir(fixture(""))
        .expect("fixtures dir")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "glb"))
        .collect();
    entries.sort();
    for path in entries {
        let json = inspect_json(&path);
        assert!(
            json["triangles"].as_u64().expect("triangles") > 0,
            "{}",
            path.display()
        );
        seen += 1;
    }
    assert!(
        seen >= 5,
        "expected the Khronos fixtures in tests/fixtures, found {seen}"
    );
}

#[test]
fn gltf_with_a_bin_beside_it_is_read() {
    let path = gltf_with_external_buffer("beside", "box.bin");
    let json = inspect_json(&path);
    assert_eq!(json["format"], "gltf");
    assert_eq!(json["surface"]["welded_vertices"], 8);
}

#[test]
fn escaping_uris_are_refused_and_nothing_outside_is_opened() {
    for (name, uri) in [
        ("dotdot", "../box.bin"),
        ("etc", "../../../../../../etc/passwd"),
        ("file", "file:///etc/passwd"),
        ("http", "http://127.0.0.1:1/box.bin"),
        ("absolute", "/etc/passwd"),
    ] {
        let path = gltf_with_external_buffer(name, uri);
        let out = texatlas(&["inspect", path.to_str().expect("path")]);
        assert_eq!(out.status.code(), Some(2), "uri {uri}: {}", stdout(&out));
        let err = stderr(&out);
        assert!(
            err.contains("/buffers/0/uri"),
            "uri {uri}: error must name the JSON path: {err}"
        );
    }
}

#[cfg(unix)]
#[test]
fn a_symlink_out_of_the_directory_is_not_followed() {
    let path = gltf_with_external_buffer("symlink", "link.bin");
    let dir = path.parent().expect("dir");
    let outside = dir
        .parent()
        .expect("parent")
        .join(format!("texatlas-outside-{}.bin", std::process::id()));
    std::fs::copy(dir.join("box.bin"), &outside).expect("copy");
    std::os::unix::fs::symlink(&outside, dir.join("link.bin")).expect("symlink");
    let out = texatlas(&["inspect", path.to_str().expect("path")]);
    let _ = std::fs::remove_file(&outside);
    assert_eq!(out.status.code(), Some(2), "{}", stdout(&out));
    assert!(
        stderr(&out).contains("resource_missing"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn a_missing_file_is_a_clear_error() {
    let out = texatlas(&["inspect", "/nonexistent/texatlas/asset.glb"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("/nonexistent/texatlas/asset.glb"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn a_truncated_glb_is_a_clear_error() {
    let dir = std::env::temp_dir().join(format!("texatlas-cli-{}-trunc", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let bytes = std::fs::read(fixture("Box.glb")).expect("Box.glb");
    let path = dir.join("truncated.glb");
    std::fs::write(&path, &bytes[..bytes.len() / 2]).expect("write");
    let out = texatlas(&["inspect", path.to_str().expect("path")]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("glb_container"), "{}", stderr(&out));
}
