//! Corpus round trip: for every `.glb` in `$TEXATLAS_CORPUS_DIR`, decode, assign seam-creating
//! test UVs, encode, and check with the independent evaluator
//! (`$TEXATLAS_EVAL_DIR/atlas_eval.py --input IN --uv K --json` → `roundtrip.ok == true`) and,
//! when `$TEXATLAS_GLTF_VALIDATOR` names a node_modules dir with gltf-validator, with the Khronos
//! validator (0 errors). Skipped (with a message) when `TEXATLAS_CORPUS_DIR` is unset.
//! `TEXATLAS_CORPUS_ONLY=substr` restricts the run to matching file names.
use crate::common::gltf as gltf_common;
use crate::common::tools as tools_common;
// Deterministic per-corner UVs that create seams: no two faces share a UV, every edge is a seam.
use crate::common::per_face_cell_uvs as test_uvs;

use std::path::{Path, PathBuf};

use texatlas::gltf_io::{decode, encode, DecodeLimits, EncodeOptions, Resources, UvTarget};

#[test]
fn corpus_round_trips_through_the_evaluator_and_validator() {
    let Some(corpus) = std::env::var_os("TEXATLAS_CORPUS_DIR") else {
        println!("corpus_roundtrip: skipped (TEXATLAS_CORPUS_DIR is unset)");
        return;
    };
    let corpus = PathBuf::from(corpus);
    // TEXATLAS_CORPUS_KEEP=DIR keeps the encoded files there for inspection.
    let keep = std::env::var_os("TEXATLAS_CORPUS_KEEP").map(PathBuf::from);
    let out_dir = keep.clone().unwrap_or_else(|| {
        std::env::temp_dir().join(format!("texatlas-corpus-{}", std::process::id()))
    });
    std::fs::create_dir_all(&out_dir).expect("temp dir");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&corpus)
        .expect("corpus dir readable")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "glb"))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no .glb in {}", corpus.display());
    let only = std::env::var("TEXATLAS_CORPUS_ONLY").ok();
    let mut failures = Vec::new();
    for input in &files {
        let name = input
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or("?")
            .to_string();
        if only.as_deref().is_some_and(|o| !name.contains(o)) {
            continue;
        }
        match check_file(input, &out_dir.join(&name), &EncodeOptions::default()) {
            Ok(line) => println!("{name}: {line}"),
            Err(why) => {
                println!("{name}: FAIL {why}");
                failures.push(format!("{name}: {why}"));
            }
        }
    }
    if keep.is_none() {
        let _ = std::fs::remove_dir_all(&out_dir);
    }
    assert!(
        failures.is_empty(),
        "corpus failures:\n{}",
        failures.join("\n")
    );
}

fn check_file(input: &Path, output: &Path, options: &EncodeOptions) -> Result<String, String> {
    let bytes = std::fs::read(input).map_err(|e| e.to_string())?;
    let asset =
        decode(&bytes, &Resources::new(), &DecodeLimits::default()).map_err(|e| e.to_string())?;
    let faces = asset.mesh_input().triangles.len();
    let encoded = encode(&asset, &test_uvs(faces), options).map_err(|e| e.to_string())?;
    let k = encoded.common_uv_set().ok_or_else(|| {
        format!(
            "UV sets differ between primitives: {:?}",
            encoded.uv_set_per_primitive
        )
    })?;
    std::fs::write(output, &encoded.bytes).map_err(|e| e.to_string())?;
    let k_arg = k.to_string();
    let report = tools_common::evaluate(
        &tools_common::eval_dir(),
        output,
        &[
            "--uv",
            &k_arg,
            "--resolution",
            "64",
            "--input",
            &input.to_string_lossy(),
        ],
    )?;
    if report.pointer("/roundtrip/ok") != Some(&serde_json::Value::Bool(true)) {
        return Err(format!(
            "roundtrip not ok: {}",
            report.get("roundtrip").cloned().unwrap_or_default()
        ));
    }
    let mut line = format!("{faces} triangles, TEXCOORD_{k}, roundtrip ok");
    if let Some(warnings) = tools_common::validate(output)? {
        line.push_str(&format!(", validator 0 errors / {warnings} warnings"));
    }
    Ok(line)
}

/// The generated kitchen-sink asset (what the corpus lacks: quantized, sparse, interleaved,
/// custom attributes, morph targets, instancing, points/lines, unknown extensions) and its
/// encoded forms must pass the validator too, and the evaluator's round-trip check.
#[test]
fn generated_asset_passes_the_validator_and_evaluator() {
    if std::env::var_os("TEXATLAS_CORPUS_DIR").is_none() {
        println!("generated asset check: skipped (TEXATLAS_CORPUS_DIR is unset)");
        return;
    }
    let dir = std::env::temp_dir().join(format!("texatlas-generated-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let input = dir.join("kitchen_sink.glb");
    std::fs::write(&input, gltf_common::kitchen_sink().glb()).expect("write");
    // Its meshes differ in existing UV sets; replacing set 0 gives the evaluator one set to read.
    let options = EncodeOptions {
        uv_target: UvTarget::Replace(0),
        ..EncodeOptions::default()
    };
    let result = tools_common::validate(&input)
        .and_then(|_| check_file(&input, &dir.join("kitchen_sink_out.glb"), &options));
    let _ = std::fs::remove_dir_all(&dir);
    match result {
        Ok(line) => println!("kitchen_sink.glb: {line}"),
        Err(why) => panic!("kitchen_sink.glb: {why}"),
    }
}
