//! `texatlas unwrap` as a user runs it: the real binary on fixture files and generated assets.
use std::path::PathBuf;
use std::process::Command;

use crate::common::cli::{s, stderr, texatlas};
use crate::common::fixture_path as fixture;
use crate::common::gltf::torus_glb;
use crate::common::proto as proto_common;

use proto_common::violations;
use texatlas::gltf_io::{decode, DecodeLimits, Resources};

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("texatlas-cli-unwrap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir.join(name)
}

#[test]
fn unwraps_a_fixture_with_report_and_preview() {
    let out = tmp("box.glb");
    let report = tmp("box.report.json");
    let preview = tmp("box.png");
    let o = texatlas(&[
        "unwrap",
        s(&fixture("Box.glb")),
        "-o",
        s(&out),
        "--report",
        s(&report),
        "--preview",
        s(&preview),
        "--resolution",
        "256",
        "--padding-texels",
        "4",
        "--max-stretch",
        "none",
        "--merge-passes",
        "2",
    ]);
    assert!(o.status.success(), "unwrap failed: {}", stderr(&o));
    // The output decodes, keeps the triangles and has the new UV set.
    let bytes = std::fs::read(&out).expect("output written");
    let asset = decode(&bytes, &Resources::new(), &DecodeLimits::default()).expect("decodes");
    assert_eq!(asset.mesh_input().triangles.len(), 12);
    assert_eq!(asset.triangle_primitives()[0].texcoord_sets, vec![0]);
    // The report follows its schema and says what it measured.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("JSON");
    let errors = violations("report.schema.json", &json);
    assert!(errors.is_empty(), "report violates its schema: {errors:#?}");
    assert_eq!(json["input"]["triangles"], 12);
    assert_eq!(json["options"]["resolution"], 256);
    assert_eq!(json["options"]["padding_texels"], 4);
    assert_eq!(
        json["options"].get("max_stretch"),
        Some(&serde_json::Value::Null),
        "an explicit null: no stretch bound"
    );
    assert_eq!(json["options"]["merge_passes"], 2);
    assert_eq!(json["quality"]["flipped"], 0);
    assert_eq!(json["pages"][0]["primitives"][0]["triangles"], 12);
    let options_errors = violations("options.schema.json", &json["options"]);
    assert!(options_errors.is_empty(), "{options_errors:#?}");
    // The preview is a PNG of the page size.
    let png = std::fs::read(&preview).expect("preview written");
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let width = u32::from_be_bytes(png[16..20].try_into().expect("4 bytes"));
    let height = u32::from_be_bytes(png[20..24].try_into().expect("4 bytes"));
    assert_eq!((width, height), (256, 256));
}

#[test]
fn gltf_output_follows_the_extension() {
    let out = tmp("fan.gltf");
    let o = texatlas(&[
        "unwrap",
        "-q",
        s(&fixture("Mesh_PrimitiveMode_05_fan.glb")),
        "-o",
        s(&out),
    ]);
    assert!(o.status.success(), "unwrap failed: {}", stderr(&o));
    let text = std::fs::read_to_string(&out).expect("output");
    let json: serde_json::Value = serde_json::from_str(&text).expect(".gltf is JSON");
    assert!(json["buffers"][0]["uri"]
        .as_str()
        .is_some_and(|u| u.starts_with("data:")));
    assert!(
        o.stderr.is_empty(),
        "--quiet prints nothing: {}",
        stderr(&o)
    );
}

#[test]
fn bad_options_and_files_fail_with_a_clear_message() {
    let out = tmp("never.glb");
    for (args, expect) in [
        (vec!["--padding-texels", "600"], "padding_texels"),
        (vec!["--rotations", "0"], "rotations"),
        (vec!["--resolution", "big"], "not a resolution"),
        (vec!["--solver", "magic"], "not a solver"),
        (vec!["--texels-per-unit=-3"], "texels_per_unit"),
        (vec!["--max-stretch", "0.5"], "max_stretch"),
        (vec!["--max-stretch", "loose"], "not a stretch bound"),
    ] {
        let box_glb = fixture("Box.glb");
        let mut all: Vec<String> = ["unwrap", s(&box_glb), "-o", s(&out)]
            .into_iter()
            .map(String::from)
            .collect();
        all.extend(args.iter().map(|a| a.to_string()));
        let refs: Vec<&str> = all.iter().map(String::as_str).collect();
        let o = texatlas(&refs);
        assert!(!o.status.success(), "{args:?} should fail");
        assert!(stderr(&o).contains(expect), "{args:?}: {}", stderr(&o));
    }
    let o = texatlas(&["unwrap", "/nonexistent/x.glb", "-o", s(&out)]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("/nonexistent/x.glb"), "{}", stderr(&o));
    let garbage = tmp("garbage.glb");
    std::fs::write(&garbage, b"glTF\x02\x00\x00\x00junk").expect("write");
    let o = texatlas(&["unwrap", s(&garbage), "-o", s(&out)]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("garbage.glb") && e.contains("GLB header"), "{e}");
    assert!(!out.exists(), "no output on failure");
    // A chart larger than a page at the asked density: the fix is named, and said once.
    let box_glb = fixture("Box.glb");
    let o = texatlas(&[
        "unwrap",
        s(&box_glb),
        "-o",
        s(&out),
        "--resolution",
        "64",
        "--texels-per-unit",
        "1000",
    ]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("lower texels_per_unit"), "{e}");
    assert_eq!(e.matches("packing failed").count(), 1, "said once: {e}");
    assert!(!out.exists(), "no output on failure");
}

#[test]
fn output_and_report_are_identical_whatever_the_thread_count() {
    let input = tmp("torus.glb");
    std::fs::write(&input, torus_glb()).expect("write");
    let mut outputs = Vec::new();
    for threads in ["1", "2", "3"] {
        let out = tmp(&format!("torus-{threads}.glb"));
        let report = tmp(&format!("torus-{threads}.json"));
        let o = Command::new(env!("CARGO_BIN_EXE_texatlas"))
            .env("RAYON_NUM_THREADS", threads)
            .args([
                "unwrap",
                "-q",
                s(&input),
                "-o",
                s(&out),
                "--report",
                s(&report),
            ])
            .output()
            .expect("run texatlas");
        assert!(o.status.success(), "{threads} threads: {}", stderr(&o));
        let mut json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("JSON");
        json.as_object_mut().expect("object").remove("timings_s");
        outputs.push((std::fs::read(&out).expect("output"), json));
    }
    assert!(
        outputs[0].1["pipeline"]["charts"].as_u64().unwrap_or(0) > 1,
        "several charts"
    );
    for (i, o) in outputs.iter().enumerate().skip(1) {
        assert!(
            o.0 == outputs[0].0,
            "GLB with thread count #{i} differs from 1 thread"
        );
        assert_eq!(
            o.1, outputs[0].1,
            "report with thread count #{i} differs from 1 thread"
        );
    }
}
