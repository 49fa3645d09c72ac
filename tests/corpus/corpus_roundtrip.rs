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
    let k = encoded.uv_set;
    if encoded.uv_set_per_primitive.iter().any(|&s| s != k) {
        return Err(format!(
            "UV sets differ between primitives: {:?}",
            encoded.uv_set_per_primitive
        ));
    }
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
    // Their primitives differ in existing UV sets (the kitchen sink: TEXCOORD_0 on one, none
    // on two; mixed_sets: none, TEXCOORD_0, TEXCOORD_0 + TEXCOORD_1): first_free puts the
    // atlas in the one set no primitive has, an explicit set replaces it everywhere; either
    // way the primitives with fewer sets get gap-filling sets and the output must be valid.
    let cases = [
        (
            "kitchen_sink",
            gltf_common::kitchen_sink().glb(),
            UvTarget::FirstFree,
        ),
        (
            "kitchen_sink",
            gltf_common::kitchen_sink().glb(),
            UvTarget::Replace(0),
        ),
        ("mixed_sets", mixed_sets().glb(), UvTarget::FirstFree),
        ("mixed_sets", mixed_sets().glb(), UvTarget::Replace(1)),
    ];
    let mut failures = Vec::new();
    for (name, glb, uv_target) in cases {
        let input = dir.join(format!("{name}.glb"));
        std::fs::write(&input, glb).expect("write");
        let options = EncodeOptions {
            uv_target,
            ..EncodeOptions::default()
        };
        let result = tools_common::validate(&input)
            .and_then(|_| check_file(&input, &dir.join(format!("{name}_out.glb")), &options));
        match result {
            Ok(line) => println!("{name}.glb ({uv_target:?}): {line}"),
            Err(why) => failures.push(format!("{name}.glb ({uv_target:?}): {why}")),
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Three primitives of one 2 × 2 quad grid each, in three meshes: no UVs, `TEXCOORD_0`, and
/// `TEXCOORD_0` + `TEXCOORD_1` (a lightmap).
fn mixed_sets() -> gltf_common::Builder {
    let mut b = gltf_common::Builder::new();
    let mut positions = Vec::new();
    for y in 0..3 {
        for x in 0..3 {
            positions.push([x as f32, y as f32, 0.0f32]);
        }
    }
    let mut indices = Vec::new();
    for y in 0..2u32 {
        for x in 0..2u32 {
            let v = y * 3 + x;
            indices.extend([v, v + 1, v + 4, v, v + 4, v + 3]);
        }
    }
    for (m, sets) in [0u32, 1, 2].into_iter().enumerate() {
        let shifted: Vec<[f32; 3]> = positions
            .iter()
            .map(|p| [p[0] + 3.0 * m as f32, p[1], p[2]])
            .collect();
        let mut attributes = serde_json::json!({"POSITION": b.floats(&shifted)});
        for j in 0..sets {
            let uv: Vec<[f32; 2]> = positions
                .iter()
                .map(|p| [p[0] / 2.0, (p[1] + j as f32) / 3.0])
                .collect();
            attributes[format!("TEXCOORD_{j}")] = serde_json::json!(b.floats(&uv));
        }
        let indices = b.indices(&indices);
        let mesh = b.push(
            "meshes",
            serde_json::json!({"primitives": [{"attributes": attributes, "indices": indices}]}),
        );
        b.push("nodes", serde_json::json!({"mesh": mesh}));
    }
    b.push("scenes", serde_json::json!({"nodes": [0, 1, 2]}));
    b
}
