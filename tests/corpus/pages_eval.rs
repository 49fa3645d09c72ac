//! Multi-page atlases checked by the independent evaluator, one page at a time. The evaluator
//! reads one `[0,1]²` UV set, so on a multi-page file it would see every page on top of the
//! others; here each page of a real `texatlas unwrap` output (explicit texel density, so that
//! more pages open) is cut out with the independent reader (`gltf_common`, no project code),
//! written as a GLB of its own and measured: 0 flips, 0 overlaps, 0 padding violations, 0 UVs
//! out of range, and the evaluator's chart and triangle counts equal the report's for that page.
//! Skipped (with a message) when `TEXATLAS_EVAL_DIR` is unset; `.ci/run` sets it.
use crate::common::cli::s;
use crate::common::gltf as gltf_common;
use crate::common::gltf::torus_glb;
use crate::common::tools as tools_common;

use std::path::PathBuf;
use std::process::Command;

use serde_json::{json, Value};

/// The triangles of `primitives` (`(mesh, primitive)` of `doc`) as one non-indexed primitive
/// with POSITION and TEXCOORD_0 per corner, and its triangle count.
fn page_glb(doc: &gltf_common::Doc, primitives: &[(usize, usize)]) -> (Vec<u8>, usize) {
    let (mut positions, mut uvs): (Vec<[f32; 3]>, Vec<[f32; 2]>) = (Vec::new(), Vec::new());
    for &(m, p) in primitives {
        let prim = &doc.json["meshes"][m]["primitives"][p];
        let accessor = |name: &str| {
            prim["attributes"][name]
                .as_u64()
                .unwrap_or_else(|| panic!("mesh {m} primitive {p} has no {name}"))
                as usize
        };
        let pos = doc.floats(accessor("POSITION"));
        let uv = doc.floats(accessor("TEXCOORD_0"));
        for corner in doc.corners(prim).into_iter().flatten() {
            positions.push([pos[corner][0], pos[corner][1], pos[corner][2]]);
            uvs.push([uv[corner][0], uv[corner][1]]);
        }
    }
    let mut b = gltf_common::Builder::new();
    let pos = b.floats(&positions);
    let uv = b.floats(&uvs);
    b.push(
        "meshes",
        json!({"primitives": [{"attributes": {"POSITION": pos, "TEXCOORD_0": uv}}]}),
    );
    b.push("nodes", json!({"mesh": 0}));
    (b.glb(), positions.len() / 3)
}

#[test]
fn every_page_of_a_multi_page_atlas_passes_the_evaluator() {
    let Some(eval) = tools_common::eval_dir_from_env() else {
        println!("pages_eval: skipped (TEXATLAS_EVAL_DIR is unset)");
        return;
    };
    let dir: PathBuf =
        std::env::temp_dir().join(format!("texatlas-pages-eval-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    // The torus has 47.4 m² of surface: at 30 texels per unit that is ~43k texels of charts in 4
    // charts of ~200² texels each, more than one 256² page holds (the largest chart still fits a
    // page). At 90, each chart is ~600² texels, larger than a page: the pack stage cuts them
    // into pieces that fit (`packing_cuts`), where it used to fail with ChartTooLarge.
    for (texels_per_unit, cut) in [("30", false), ("90", true)] {
        let report = check_pages(&eval, &dir, texels_per_unit);
        let cuts = report["pipeline"]["packing_cuts"]
            .as_u64()
            .expect("packing_cuts");
        assert_eq!(
            cuts > 0,
            cut,
            "at {texels_per_unit} texels per unit: {cuts} cuts"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Unwraps the torus at `texels_per_unit` on 256² pages, checks every page with the evaluator
/// (panics on a problem) and returns the report.
fn check_pages(eval: &std::path::Path, dir: &std::path::Path, texels_per_unit: &str) -> Value {
    let (input, output, report) = (
        dir.join("torus.glb"),
        dir.join("torus-atlas.glb"),
        dir.join("report.json"),
    );
    std::fs::write(&input, torus_glb()).expect("write input");
    let run = Command::new(env!("CARGO_BIN_EXE_texatlas"))
        .args([
            "unwrap",
            s(&input),
            "-o",
            s(&output),
            "--report",
            s(&report),
        ])
        .args(["--resolution", "256", "--padding-texels", "2"])
        .args(["--texels-per-unit", texels_per_unit, "--quiet"])
        .output()
        .expect("run texatlas");
    assert!(
        run.status.success(),
        "unwrap failed: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    let report: Value =
        serde_json::from_slice(&std::fs::read(&report).expect("report")).expect("report JSON");
    let doc = gltf_common::parse(&std::fs::read(&output).expect("output"));
    let pages = report["pages"].as_array().expect("pages");
    assert!(
        pages.len() >= 2,
        "expected several pages, got {}",
        pages.len()
    );
    let mut problems = Vec::new();
    let mut total_triangles = 0;
    for page in pages {
        let n = page["page"].as_u64().expect("page number");
        let primitives: Vec<(usize, usize)> = page["primitives"]
            .as_array()
            .expect("primitives")
            .iter()
            .map(|p| {
                (
                    p["mesh"].as_u64().expect("mesh") as usize,
                    p["primitive"].as_u64().expect("primitive") as usize,
                )
            })
            .collect();
        let (glb, triangles) = page_glb(&doc, &primitives);
        total_triangles += triangles;
        let file = dir.join(format!("page-{n}.glb"));
        std::fs::write(&file, glb).expect("write page");
        let e = tools_common::evaluate(eval, &file, &["--resolution", "256", "--padding", "2"])
            .unwrap_or_else(|why| panic!("page {n}: {why}"));
        for (key, pointer) in [
            ("flipped", "/flipped"),
            ("overlap pairs", "/overlap/pairs"),
            ("padding violations", "/padding/violation_texels"),
            ("out of range corners", "/out_of_range_corners"),
        ] {
            if e.pointer(pointer).and_then(Value::as_u64) != Some(0) {
                problems.push(format!("page {n}: {key} {:?}", e.pointer(pointer)));
            }
        }
        if e["charts"] != page["charts"] || json!(triangles) != page["triangles"] {
            problems.push(format!(
                "page {n}: evaluator {} charts / {triangles} triangles, report {} / {}",
                e["charts"], page["charts"], page["triangles"]
            ));
        }
        println!(
            "page {n}: {triangles} triangles, {} charts, packing {}, flipped {}, overlaps {}, padding violations {}",
            e["charts"], e["packing_efficiency"], e["flipped"], e["overlap"]["pairs"],
            e["padding"]["violation_texels"]
        );
    }
    assert_eq!(
        json!(total_triangles),
        report["input"]["triangles"],
        "every triangle is on exactly one page"
    );
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    report
}
