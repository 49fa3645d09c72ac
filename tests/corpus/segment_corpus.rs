//! Segmentation over the shared corpus, when `TEXATLAS_CORPUS_DIR` names it (`.ci/run` sets it
//! when `../shared/corpus` exists; unset, the test prints that it skipped). For every mesh:
//! every chart is a disk and every face is in exactly one chart, after segmentation and again
//! after validation (§3.3); the validated maps have 0 flipped faces and no chart is left with
//! a flip or a UV boundary overlap; every chart has a map whose vertex list is its `chart_mesh`
//! vertex list. Prints per mesh the chart count, the time, the largest chart in faces and the
//! global Sander L2 stretch of the validated maps (each chart scaled to UV area = 3-D area, as
//! the packer does). The 1M-triangle mesh is left out unless `TEXATLAS_CORPUS_ALL` is set (it
//! takes minutes in a debug build).
//!
//! Run by hand: `TEXATLAS_CORPUS_DIR=../shared/corpus cargo test --test corpus -- segment_corpus:: --nocapture`
//! (add `TEXATLAS_CORPUS_ONLY=bunny,armadillo` to run only the files whose names contain a word).
use std::path::PathBuf;
use std::time::Instant;

use texatlas::atlas::parameterize::{
    chart_mesh, parameterize_charts, ChartDefect, ParameterizeOptions, ParameterizedCharts,
};
use texatlas::atlas::segment::{check_chart_is_disk, segment_charts, SegmentOptions};
use texatlas::atlas::{Stage, StageProgress};
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
            // TEXATLAS_CORPUS_ONLY=bunny,spot runs only the files whose names contain one of
            // the comma-separated words (for measuring by hand).
            std::env::var("TEXATLAS_CORPUS_ONLY").map_or(true, |only| {
                only.split(',').any(|w| p.to_string_lossy().contains(w))
            })
        })
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
        let seg = segment_charts(
            &mesh,
            &SegmentOptions::default(),
            &mut StageProgress::ignored(Stage::Segment),
        )
        .expect("default options");
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
        // The defaults on every mesh; the paper's area test too on 2CylinderEngine, where it
        // once left two same-chart overlaps of a stretched sliver chart (faces 5369/5707, 5369/5709).
        let mut runs = vec![("default", ParameterizeOptions::default())];
        if name.contains("2CylinderEngine") {
            runs.push(("paper", ParameterizeOptions::paper()));
        }
        for (run, options) in runs {
            let t = Instant::now();
            let v = parameterize_charts(
                &mesh,
                &seg,
                &options,
                &mut StageProgress::ignored(Stage::Parameterize),
            )
            .expect("valid");
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
                "  validated ({run}): charts {:5} largest {:7} time {ms:8.1} ms splits(flip,overlap,area) {:?} degenerate splits {} faces {} merges {} unresolved {} flips {flips} L2 {:.4}",
                v.segmentation.num_charts(),
                largest,
                v.splits,
                v.degenerate_splits,
                v.degenerate_faces,
                v.merges,
                v.unresolved.len(),
                l2_stretch(&mesh, &v)
            );
            for (i, (c, m)) in v.segmentation.charts.iter().zip(&v.maps).enumerate() {
                match m {
                    None => failures.push(format!("{name}: validated chart {i} has no map")),
                    Some((map, global)) => {
                        if *global != chart_mesh(&mesh, c).1 || map.uv.len() != global.len() {
                            failures.push(format!(
                                "{name}: validated chart {i}: the map's vertices are not the chart's"
                            ));
                        }
                    }
                }
            }
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
                if let Some((map, _)) = &v.maps[i] {
                    let (cm, _) = chart_mesh(&mesh, c);
                    if let Some([a, b]) = same_chart_overlap(&cm.triangles, &map.uv) {
                        failures.push(format!(
                            "{name} ({run}): validated chart {i}: faces {} and {} overlap in UV",
                            c[a].index(),
                            c[b].index()
                        ));
                    }
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Global Sander L2 stretch (Sander et al. 2001) of the validated maps, each chart scaled so that
/// its UV area equals its 3-D area: `sqrt(Σ_T A3·(a+c)/2 / Σ_T A3)` over non-degenerate faces,
/// with `a`, `c` the squared lengths of the 3-D derivatives along u and v.
fn l2_stretch(mesh: &TriangleMesh, v: &ParameterizedCharts) -> f64 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for (c, m) in v.segmentation.charts.iter().zip(&v.maps) {
        let Some((map, _)) = m else { continue };
        let (cm, _) = chart_mesh(mesh, c);
        let mut faces = Vec::new();
        let (mut a3_sum, mut auv_sum) = (0.0f64, 0.0f64);
        for t in &cm.triangles {
            let q = t.map(|i| cm.positions_m[i as usize]);
            let p = t.map(|i| map.uv[i as usize]);
            let e1 = [0, 1, 2].map(|k| q[1][k] - q[0][k]);
            let e2 = [0, 1, 2].map(|k| q[2][k] - q[0][k]);
            let cr = [
                e1[1] * e2[2] - e1[2] * e2[1],
                e1[2] * e2[0] - e1[0] * e2[2],
                e1[0] * e2[1] - e1[1] * e2[0],
            ];
            let a3 = 0.5 * (cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]).sqrt();
            let auv = 0.5
                * ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1])
                    - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]));
            if !(a3 > 0.0 && auv > 0.0) {
                continue;
            }
            let (s, t) = (p.map(|x| x[0]), p.map(|x| x[1]));
            let ss = [0, 1, 2].map(|k| {
                (q[0][k] * (t[1] - t[2]) + q[1][k] * (t[2] - t[0]) + q[2][k] * (t[0] - t[1]))
                    / (2.0 * auv)
            });
            let st = [0, 1, 2].map(|k| {
                (q[0][k] * (s[2] - s[1]) + q[1][k] * (s[0] - s[2]) + q[2][k] * (s[1] - s[0]))
                    / (2.0 * auv)
            });
            let a = ss.iter().map(|x| x * x).sum::<f64>();
            let cc = st.iter().map(|x| x * x).sum::<f64>();
            faces.push((a3, 0.5 * (a + cc)));
            a3_sum += a3;
            auv_sum += auv;
        }
        if a3_sum <= 0.0 {
            continue;
        }
        // Scaling UV by k (k² = A3/Auv) divides a and c by k².
        let inv_k2 = auv_sum / a3_sum;
        for (a3, l2sq) in faces {
            num += a3 * l2sq * inv_k2;
            den += a3;
        }
    }
    if den > 0.0 {
        (num / den).sqrt()
    } else {
        1.0
    }
}

/// Two triangles of one chart whose UV images overlap with positive area (an independent
/// check, not validation's boundary test): a sweep over x of the bounding boxes, then the
/// separating axis test on the six edges, touching (within 1e-12 of the edge scale) allowed.
/// Zero-area UV triangles are skipped. Returns chart-local triangle indices.
fn same_chart_overlap(tris: &[[u32; 3]], uv: &[[f64; 2]]) -> Option<[usize; 2]> {
    let orient = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    };
    // (x min, x max, y min, y max, triangle, corners)
    type Item = (f64, f64, f64, f64, usize, [[f64; 2]; 3]);
    let mut items: Vec<Item> = Vec::new();
    for (k, t) in tris.iter().enumerate() {
        let p = t.map(|i| uv[i as usize]);
        if orient(p[0], p[1], p[2]) <= 0.0 {
            continue;
        }
        let (x0, x1) = (
            p[0][0].min(p[1][0]).min(p[2][0]),
            p[0][0].max(p[1][0]).max(p[2][0]),
        );
        let (y0, y1) = (
            p[0][1].min(p[1][1]).min(p[2][1]),
            p[0][1].max(p[1][1]).max(p[2][1]),
        );
        items.push((x0, x1, y0, y1, k, p));
    }
    items.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.4.cmp(&b.4)));
    let separated = |p: &[[f64; 2]; 3], q: &[[f64; 2]; 3]| {
        (0..3).any(|e| {
            let (a, b) = (p[e], p[(e + 1) % 3]);
            let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
            q.iter().all(|&c| {
                let scale = len * ((c[0] - a[0]).abs() + (c[1] - a[1]).abs()).max(len);
                orient(a, b, c) <= 1e-12 * scale
            })
        })
    };
    for i in 0..items.len() {
        let (_, x1, y0, y1, ki, p) = items[i];
        for it in &items[i + 1..] {
            if it.0 >= x1 {
                break;
            }
            if it.2 >= y1 || it.3 <= y0 {
                continue;
            }
            if !separated(&p, &it.5) && !separated(&it.5, &p) {
                return Some([ki, it.4]);
            }
        }
    }
    None
}
