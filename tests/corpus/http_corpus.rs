//! The service over the shared corpus (runs when `TEXATLAS_CORPUS_DIR` is set, as in `.ci/run`):
//! the bunny-sized and glTF-feature assets go upload → poll → result through the real server and
//! the real pipeline; each result decodes with every triangle, its report validates against
//! `proto/report.schema.json`, and (when `TEXATLAS_GLTF_VALIDATOR` and `TEXATLAS_EVAL_DIR` are
//! set) the Khronos glTF-Validator reports 0 errors and the independent evaluator
//! (`atlas_eval.py --input`) finds the round trip ok, 0 flips, 0 overlaps, 0 padding violations.
use crate::common::http as http_common;
use crate::common::tools as tools_common;

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use http_common::*;
use serde_json::Value;
use texatlas::jobs::UnwrapProcessor;

const ASSETS: &[&str] = &[
    "bunny.glb",
    "SimpleSkin.glb",
    "AnimatedMorphCube.glb",
    "BoxInterleaved.glb",
];

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn corpus_assets_through_the_service() {
    let Some(corpus) = std::env::var_os("TEXATLAS_CORPUS_DIR").map(PathBuf::from) else {
        eprintln!("TEXATLAS_CORPUS_DIR not set: the HTTP corpus test is skipped");
        return;
    };
    let s = Server::start_with(Arc::new(UnwrapProcessor::default()), |_| {}).await;
    let c = reqwest::Client::new();
    let out = tempfile::tempdir().unwrap();
    for name in ASSETS {
        let path = corpus.join(name);
        let Ok(bytes) = std::fs::read(&path) else {
            eprintln!("{} missing: skipped", path.display());
            continue;
        };
        let job = submit_ok(&c, &s, bytes, "").await;
        let id = job["id"].as_str().unwrap();
        let done = poll_until(
            &c,
            &s.url(&format!("/v1/jobs/{id}")),
            Duration::from_secs(600),
            is_terminal,
        )
        .await;
        assert_eq!(done["status"], "succeeded", "{name}: {done:#}");
        let glb = get_bytes(&c, s.url(&format!("/v1/jobs/{id}/result"))).await;
        let asset = texatlas::gltf_io::decode(
            &glb,
            &texatlas::gltf_io::Resources::new(),
            &texatlas::gltf_io::DecodeLimits::default(),
        )
        .unwrap_or_else(|e| panic!("{name}: result does not decode: {e}"));
        assert_eq!(
            asset.mesh_input().triangles.len() as u64,
            done["triangles"].as_u64().unwrap(),
            "{name}"
        );
        let report: Value = get_json(&c, s.url(&format!("/v1/jobs/{id}/report"))).await;
        assert_schema("Report", &report);
        assert_eq!(report["quality"]["flipped"], 0, "{name}");
        if let (Some(_), Some(eval)) = (
            std::env::var_os("TEXATLAS_GLTF_VALIDATOR"),
            tools_common::eval_dir_from_env(),
        ) {
            let file = out.path().join(name);
            std::fs::write(&file, &glb).unwrap();
            if let Err(why) = tools_common::validate(&file) {
                panic!("{name}: {why}");
            }
            // The independent evaluator's round trip: every input attribute and position comes
            // back per corner, and the atlas has no flip, overlap or padding violation.
            let k = report["uv_set"].as_u64().expect("a UV set");
            assert!(
                report["uv_set_per_primitive"]
                    .as_array()
                    .is_some_and(|s| s.iter().all(|s| s.as_u64() == Some(k))),
                "{name}: one UV set: {report:#}"
            );
            let k = k.to_string();
            let e = tools_common::evaluate(
                &eval,
                &file,
                &["--input", &path.to_string_lossy(), "--uv", &k],
            )
            .unwrap_or_else(|why| panic!("{name}: {why}"));
            assert_eq!(
                e["roundtrip"]["ok"], true,
                "{name}: round trip {}",
                e["roundtrip"]
            );
            assert_eq!(e["flipped"], 0, "{name}");
            assert_eq!(e["overlap"]["pairs"], 0, "{name}");
            assert_eq!(e["padding"]["violation_texels"], 0, "{name}");
        }
        println!("{name}: {} triangles, succeeded", done["triangles"]);
    }
    s.stop().await.unwrap();
}
