//! Segmentation over the shared corpus, when `TEXATLAS_CORPUS_DIR` names it (`.ci/run` sets it
//! when `../shared/corpus` exists; unset, the test prints that it skipped). For every mesh:
//! every chart is a disk and every face is in exactly one chart, after segmentation and again
//! after validation (§3.3); the validated maps have 0 flipped faces and no chart is left with
//! a flip or a UV boundary overlap. Prints per mesh the chart count, the time and the largest
//! chart in faces. The 1M-triangle mesh is left out unless `TEXATLAS_CORPUS_ALL` is set (it
//! takes minutes in a debug build).
//!
//! Run by hand: `TEXATLAS_CORPUS_DIR=../shared/corpus cargo test --test segment_corpus -- --nocapture`.
use std::path::PathBuf;
use std::time::Instant;

use texatlas::atlas::segment::{
    check_chart_is_disk, segment_charts, validate_charts, ChartDefect, SegmentOptions,
    ValidateOptions,
};
use texatlas::gltf_io::{decode, DecodeLimits, Resources};
use texatlas::mesh::TriangleMesh;

#[test]
fn segment_every_corpus_mesh() {
    let Some(dir) = std::env::var_os("TEXATLAS_CORPUS_DIR").map(PathBuf::from) else {
        println!("segment_corpus: skipped (TEXATLAS_CORPUS_DIR is unset)");
        return;
    };
    let entries = std::fs::read_dir(&dir).expect("TEXATLAS_CORPUS_DIR is readable");
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
        {
            let t = Instant::now();
            let v = validate_charts(&mesh, &seg, &ValidateOptions::default()).expect("valid");
            let ms = t.elapsed().as_secs_f64() * 1e3;
            let largest = v
                .segmentation
                .charts
                .iter()
                .map(Vec::len)
                .max()
                .unwrap_or(0);
            let flips: usize = v
                .maps
                .iter()
                .flatten()
                .map(|(m, _)| m.flipped_faces.len())
                .sum();
            println!(
                "  validated: charts {:5} largest {:7} time {ms:8.1} ms splits(flip,overlap,area) {:?} merges {} unresolved {} flips {flips}",
                v.segmentation.num_charts(),
                largest,
                v.splits,
                v.merges,
                v.unresolved.len()
            );
            let mut kinds: std::collections::BTreeMap<String, usize> = Default::default();
            for (_, d) in &v.unresolved {
                let k = format!("{d:?}");
                let k = k.split(['(', ' ', '{']).next().unwrap_or("?").to_owned();
                let k = match d {
                    ChartDefect::Unparameterizable(e) => {
                        format!(
                            "{k}:{}",
                            format!("{e:?}")
                                .split([' ', '{', '('])
                                .next()
                                .unwrap_or("?")
                        )
                    }
                    _ => k,
                };
                *kinds.entry(k).or_default() += 1;
            }
            if !kinds.is_empty() {
                println!("  unresolved by kind: {kinds:?}");
            }
            if flips != 0 {
                failures.push(format!("{name}: {flips} flipped faces after validation"));
            }
            for (i, d) in &v.unresolved {
                if matches!(
                    d,
                    ChartDefect::Flipped { .. } | ChartDefect::BoundaryOverlap { .. }
                ) {
                    failures.push(format!("{name}: chart {i} left with {d:?}"));
                }
            }
            for (i, c) in v.segmentation.charts.iter().enumerate() {
                if let Err(e) = check_chart_is_disk(&mesh, c) {
                    failures.push(format!("{name}: validated chart {i}: {e}"));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
