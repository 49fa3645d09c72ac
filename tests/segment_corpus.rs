//! Segmentation over the shared corpus (`../shared/corpus`, or `$TEXATLAS_CORPUS`), when present:
//! every chart of every mesh is a disk, every face is in one chart; prints per mesh the chart
//! count, the time and the largest chart in faces. `#[ignore]`d: run it with
//! `cargo test --test segment_corpus -- --ignored --nocapture` (it skips when the corpus is absent).
use std::path::PathBuf;
use std::time::Instant;

use texatlas::atlas::segment::{check_chart_is_disk, segment_charts, SegmentOptions};
use texatlas::gltf_io::{decode, DecodeLimits, Resources};
use texatlas::mesh::TriangleMesh;

fn corpus_dir() -> PathBuf {
    std::env::var_os("TEXATLAS_CORPUS").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/corpus"),
        PathBuf::from,
    )
}

#[test]
#[ignore = "corpus measurement; needs ../shared/corpus"]
fn segment_every_corpus_mesh() {
    let dir = corpus_dir();
    let Ok(entries) = std::fs::read_dir(&dir) else {
        eprintln!("no corpus at {}; skipped", dir.display());
        return;
    };
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "glb"))
        .filter(|p| {
            // The 1M-face mesh takes minutes in a debug build; opt in with TEXATLAS_CORPUS_ALL.
            std::env::var_os("TEXATLAS_CORPUS_ALL").is_some() || !p.to_string_lossy().contains("1M")
        })
        .collect();
    files.sort();
    let mut failures = Vec::new();
    for path in files {
        let bytes = std::fs::read(&path).expect("readable corpus file");
        let asset = decode(&bytes, &Resources::new(), &DecodeLimits::default()).expect("decodes");
        let mesh = TriangleMesh::build(asset.mesh_input())
            .expect("builds")
            .mesh;
        let t = Instant::now();
        let seg = segment_charts(&mesh, &SegmentOptions::default()).expect("default options");
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let largest = seg.charts.iter().map(Vec::len).max().unwrap_or(0);
        let name = path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        println!(
            "{name:40} faces {:7} components {:5} charts {:5} largest {:7} time {ms:8.1} ms  {:?}",
            mesh.num_faces(),
            mesh.components().len(),
            seg.num_charts(),
            largest,
            seg.stats
        );
        let mut seen = vec![0u8; mesh.num_faces()];
        for (i, c) in seg.charts.iter().enumerate() {
            for f in c {
                seen[f.index()] += 1;
            }
            if let Err(e) = check_chart_is_disk(&mesh, c) {
                failures.push(format!("{name}: chart {i}: {e}"));
            }
        }
        if seen.iter().any(|&n| n != 1) {
            failures.push(format!("{name}: a face is not in exactly one chart"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
