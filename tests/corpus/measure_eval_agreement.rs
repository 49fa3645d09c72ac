//! Agreement of `atlas::measure` with the independent evaluator (issue 5 acceptance: our L2, L∞,
//! charts and packing within 1% of `atlas_eval.py` on every file; we check every key both
//! report, counts exactly and floats within 1e-9 relative).
//!
//! Each asset gets deterministic test UVs (`test_uvs`): per connected component, two halves
//! (split across the longest axis), each planar-projected onto the component's two longest
//! axes into its own grid cell, the odd halves squeezed in v (anisotropic stretch). Closed
//! surfaces fold front onto back (flips and same-chart overlaps); one face is folded over its
//! neighbour (a flip inside a chart); the last group is shifted half a cell onto its neighbour
//! (cross-chart overlaps, padding violations) and the first slightly out of [0,1] (out of range,
//! clipped rasterisation). The asset is encoded with `gltf_io::encode`, the evaluator is run on
//! the file (`--resolution R --padding P --json --uv K`, one square page `R = W = H`), and
//! `measure_atlas` on the same mesh and `f32` UVs.
//!
//! `TEXATLAS_EVAL_DIR` unset: skipped with a message (a fresh clone passes). Set (`.ci/run`
//! sets it): the fixtures in `tests/fixtures` and generated meshes must agree. With
//! `TEXATLAS_CORPUS_DIR` also set, every corpus `.glb` is compared too, except the 1M-triangle
//! one, which is only timed (the evaluator needs ~12 s and 1.7 GB on it); a table is printed.
use crate::common::gltf as gltf_common;
use crate::common::per_face_cell_uvs;
use crate::common::tools as tools_common;

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde_json::Value;
use texatlas::atlas::measure::{measure_atlas, AtlasReport, MeasureInput};
use texatlas::gltf_io::{decode, encode, DecodeLimits, EncodeOptions, Resources};
use texatlas::mesh::{fixtures, FaceId, MeshInput, TriangleMesh};

/// Deterministic test UVs exercising several charts, stretch, flips, overlaps, out of range.
fn test_uvs(mesh: &TriangleMesh) -> Vec<[[f32; 2]; 3]> {
    let nf = mesh.num_faces();
    let comps = mesh.components();
    let nc = comps.len();
    // Per component: bounding box, axes by extent.
    let mut lo = vec![[f64::INFINITY; 3]; nc];
    let mut hi = vec![[f64::NEG_INFINITY; 3]; nc];
    for f in mesh.faces() {
        let c = comps.of_face(f).index();
        for p in mesh.face_positions(f) {
            for k in 0..3 {
                lo[c][k] = lo[c][k].min(p[k]);
                hi[c][k] = hi[c][k].max(p[k]);
            }
        }
    }
    let axes: Vec<[usize; 2]> = (0..nc)
        .map(|c| {
            let mut ax = [0usize, 1, 2];
            ax.sort_by(|&a, &b| (hi[c][b] - lo[c][b]).total_cmp(&(hi[c][a] - lo[c][a])));
            [ax[0], ax[1]]
        })
        .collect();
    let group_of = |f: FaceId| {
        let c = comps.of_face(f).index();
        let a = axes[c][0];
        let centroid = mesh.face_positions(f).iter().map(|p| p[a]).sum::<f64>() / 3.0;
        2 * c + usize::from(centroid > 0.5 * (lo[c][a] + hi[c][a]))
    };
    let groups = 2 * nc;
    let mut glo = vec![[f64::INFINITY; 2]; groups];
    let mut ghi = vec![[f64::NEG_INFINITY; 2]; groups];
    let face_group: Vec<usize> = mesh.faces().map(group_of).collect();
    for f in mesh.faces() {
        let g = face_group[f.index()];
        let ax = axes[g / 2];
        for p in mesh.face_positions(f) {
            for k in 0..2 {
                glo[g][k] = glo[g][k].min(p[ax[k]]);
                ghi[g][k] = ghi[g][k].max(p[ax[k]]);
            }
        }
    }
    let side = (groups as f64).sqrt().ceil() as usize;
    let cell = 1.0 / side as f64;
    let mut uvs = Vec::with_capacity(nf);
    for f in mesh.faces() {
        let g = face_group[f.index()];
        let ax = axes[g / 2];
        let extent = (ghi[g][0] - glo[g][0])
            .max(ghi[g][1] - glo[g][1])
            .max(1e-30);
        let scale = 0.9 * cell / extent;
        let squeeze = if g % 2 == 1 { 0.6 } else { 1.0 };
        let mut origin = [(g % side) as f64 * cell, (g / side) as f64 * cell];
        if g == 0 {
            origin[0] -= 0.03; // out of range
        }
        if g == groups - 1 && groups > 1 {
            origin[0] -= 0.5 * cell; // onto its neighbour
        }
        let uv = mesh.face_positions(f).map(|p| {
            [
                (origin[0] + 0.05 * cell + (p[ax[0]] - glo[g][0]) * scale) as f32,
                (origin[1] + 0.05 * cell + (p[ax[1]] - glo[g][1]) * scale * squeeze) as f32,
            ]
        });
        uvs.push(uv);
    }
    // Fold one face over its neighbour: reflect the UV of a vertex used by that face alone
    // across the line through its other two corners.
    'fold: for f in mesh.faces() {
        for (k, v) in mesh.face_vertices(f).into_iter().enumerate() {
            if mesh.vertex_face_count(v) == 1 {
                let t = &mut uvs[f.index()];
                let (a, b, p) = (t[(k + 1) % 3], t[(k + 2) % 3], t[k]);
                let [ax, ay, bx, by, px, py] = [a[0], a[1], b[0], b[1], p[0], p[1]].map(f64::from);
                let (dx, dy) = (bx - ax, by - ay);
                let l2 = dx * dx + dy * dy;
                if l2 == 0.0 {
                    continue;
                }
                let s = ((px - ax) * dx + (py - ay) * dy) / l2;
                let (fx, fy) = (ax + s * dx, ay + s * dy);
                t[k] = [(2.0 * fx - px) as f32, (2.0 * fy - py) as f32];
                break 'fold;
            }
        }
    }
    uvs
}

/// One comparison: our value, the evaluator's (by JSON pointer).
enum Expect {
    Count(u64),
    Bool(bool),
    Float(Option<f64>),
}

fn expectations(r: &AtlasReport) -> Vec<(&'static str, Expect)> {
    use Expect::{Bool, Count, Float};
    let c = |x: usize| Count(x as u64);
    let st = &r.stretch;
    let mut v = vec![
        ("/triangles", c(r.triangles)),
        ("/unique_corners", c(r.unique_corners)),
        ("/area_3d", Float(Some(r.area_3d_m2))),
        ("/uv_area", Float(Some(r.uv_area))),
        ("/degenerate", c(r.degenerate)),
        ("/degenerate_3d", c(r.degenerate_3d)),
        (
            "/degenerate_uv_with_3d_area",
            c(r.degenerate_uv_with_3d_area),
        ),
        ("/charts", c(r.charts)),
        ("/seam_edges", c(r.seam_edges)),
        ("/seam_length_3d", Float(Some(r.seam_length_3d_m))),
        ("/seam_edge_ratio", Float(r.seam_edge_ratio)),
        ("/boundary_edge_ratio", Float(r.boundary_edge_ratio)),
        (
            "/open_border_length_3d",
            Float(Some(r.open_border_length_3d_m)),
        ),
        ("/flipped", c(r.flipped)),
        (
            "/charts_minority_orientation",
            c(r.charts_minority_orientation),
        ),
        ("/out_of_range_corners", c(r.out_of_range_corners)),
        ("/out_of_range_triangles", c(r.out_of_range_triangles)),
        ("/packing_efficiency", Float(Some(r.packing_efficiency))),
        ("/packing_efficiency_bbox", Float(r.packing_efficiency_bbox)),
        ("/texel_utilization", Float(Some(r.texel_utilization))),
        ("/uv_area_over_3d_area", Float(st.uv_area_over_3d_area)),
        ("/stretch/l2", Float(st.l2)),
        ("/stretch/linf", Float(st.linf)),
        ("/stretch/linf_sander", Float(st.linf_sander)),
        ("/stretch/strict_infinite", Bool(st.strict_infinite)),
        ("/stretch/triangles_used", c(st.triangles_used)),
        (
            "/stretch/excluded_uv_degenerate",
            c(st.excluded_uv_degenerate),
        ),
        (
            "/stretch/excluded_3d_degenerate",
            c(st.excluded_3d_degenerate),
        ),
    ];
    let s = &r.overlap.sampled;
    v.extend([
        ("/overlap/covered_texels", Count(s.covered_texels)),
        ("/overlap/overlapping_texels", Count(s.overlapping_texels)),
        ("/overlap/fraction", Float(Some(s.fraction))),
        ("/overlap/texels_cross_chart", Count(s.texels_cross_chart)),
        ("/overlap/texels_same_chart", Count(s.texels_same_chart)),
        ("/overlap/pairs", Count(s.pairs)),
        ("/overlap/pairs_same_chart", Count(s.pairs_same_chart)),
        ("/overlap/pairs_cross_chart", Count(s.pairs_cross_chart)),
        ("/overlap/pairs_truncated", Bool(s.pairs_truncated)),
        (
            "/overlap/raster_skipped_triangles",
            Count(s.raster_skipped_triangles),
        ),
        (
            "/padding/violation_texels",
            Count(r.padding.violation_texels),
        ),
    ]);
    if let Some(b) = r.uv_bbox {
        v.extend([
            ("/uv_bbox/0", Float(Some(b[0]))),
            ("/uv_bbox/1", Float(Some(b[1]))),
            ("/uv_bbox/2", Float(Some(b[2]))),
            ("/uv_bbox/3", Float(Some(b[3]))),
        ]);
    }
    if let Some(a) = &r.angle_distortion {
        let p = "/angle_distortion/";
        for (k, x) in [
            ("angle_deviation_deg_mean", a.angle_deviation_deg_mean),
            ("angle_deviation_deg_p95", a.angle_deviation_deg_p95),
            ("angle_deviation_deg_mean_aw", a.angle_deviation_deg_mean_aw),
            ("angle_deviation_deg_p95_aw", a.angle_deviation_deg_p95_aw),
            ("conformal_ratio_mean", a.conformal_ratio_mean),
            ("conformal_ratio_p95", a.conformal_ratio_p95),
            ("conformal_ratio_mean_aw", a.conformal_ratio_mean_aw),
            ("conformal_ratio_p95_aw", a.conformal_ratio_p95_aw),
        ] {
            v.push((leak(format!("{p}{k}")), Float(x)));
        }
    }
    if let Some(a) = &r.area_distortion {
        for (k, x) in [
            ("p5", a.p5),
            ("p50", a.p50),
            ("p95", a.p95),
            ("p5_aw", a.p5_aw),
            ("p50_aw", a.p50_aw),
            ("p95_aw", a.p95_aw),
        ] {
            v.push((leak(format!("/area_distortion/{k}")), Float(x)));
        }
    }
    if let Some(d) = &r.texel_density {
        v.push((
            "/texel_density/charts_measured",
            Count(d.charts_measured as u64),
        ));
        for (k, x) in [
            ("min", Some(d.min)),
            ("max", Some(d.max)),
            ("max_over_min", d.max_over_min),
            ("cv", d.cv),
            ("cv_aw", d.cv_aw),
            ("texels_per_unit", d.texels_per_unit),
        ] {
            v.push((leak(format!("/texel_density/{k}")), Float(x)));
        }
    }
    v
}

fn leak(s: String) -> &'static str {
    Box::leak(s.into_boxed_str())
}

/// Every disagreement between our report and the evaluator's JSON, plus the objects the
/// evaluator reports that we have as `None` (or the reverse).
fn compare(ours: &AtlasReport, eval: &Value) -> Vec<String> {
    let mut bad = Vec::new();
    for (key, obj) in [
        ("/angle_distortion", ours.angle_distortion.is_some()),
        ("/area_distortion", ours.area_distortion.is_some()),
        ("/texel_density", ours.texel_density.is_some()),
    ] {
        if eval.pointer(key).is_some_and(|v| !v.is_null()) != obj {
            bad.push(format!(
                "{key}: present here {obj}, evaluator {:?}",
                eval.pointer(key)
            ));
        }
    }
    for (key, expect) in expectations(ours) {
        let theirs = eval.pointer(key);
        let ok = match (&expect, theirs) {
            (Expect::Count(n), Some(t)) => t.as_u64() == Some(*n),
            (Expect::Bool(b), Some(t)) => t.as_bool() == Some(*b),
            (Expect::Float(None), Some(t)) => t.is_null(),
            (Expect::Float(Some(x)), Some(t)) => t
                .as_f64()
                .is_some_and(|y| (x - y).abs() <= 1e-9 * x.abs().max(y.abs()) + 1e-12),
            (_, None) => false,
        };
        if !ok {
            let mine = match expect {
                Expect::Count(n) => n.to_string(),
                Expect::Bool(b) => b.to_string(),
                Expect::Float(x) => format!("{x:?}"),
            };
            bad.push(format!("{key}: ours {mine}, evaluator {theirs:?}"));
        }
    }
    bad
}

struct Outcome {
    line: String,
    disagreements: Vec<String>,
}

/// Encodes `glb` with test UVs, measures it and, unless `timing_only`, runs the evaluator and
/// compares. `Ok(None)` when the asset cannot be measured (no triangles): skipped.
fn check_asset(
    name: &str,
    glb: &[u8],
    dir: &Path,
    resolution: u32,
    padding: u32,
    evaluator: Option<&Path>,
) -> Result<Option<Outcome>, String> {
    let asset =
        decode(glb, &Resources::new(), &DecodeLimits::default()).map_err(|e| e.to_string())?;
    let Ok(built) = TriangleMesh::build(asset.mesh_input()) else {
        return Ok(None);
    };
    let mesh = built.mesh;
    let uvs = test_uvs(&mesh);
    let pages = vec![0u32; uvs.len()];
    let t0 = Instant::now();
    let ours = measure_atlas(&MeasureInput {
        mesh: &mesh,
        corner_uvs: &uvs,
        face_page: &pages,
        num_pages: 1,
        width_texels: resolution,
        height_texels: resolution,
        padding_texels: padding,
    });
    let measure_ms = t0.elapsed().as_secs_f64() * 1e3;
    let mut line = format!(
        "{name:<34} {:>8} {:>6} {:>9.5} {:>9.4} {:>7.4} {:>6} {:>8} {:>8} {:>8.1}",
        ours.triangles,
        ours.charts,
        ours.stretch.l2.unwrap_or(f64::NAN),
        ours.stretch.linf.unwrap_or(f64::NAN),
        ours.packing_efficiency,
        ours.flipped,
        ours.overlap.sampled.pairs,
        ours.overlap.exact.pairs,
        measure_ms
    );
    let Some(evaluator) = evaluator else {
        line.push_str("  (timed only)");
        return Ok(Some(Outcome {
            line,
            disagreements: Vec::new(),
        }));
    };
    let encoded = encode(&asset, &uvs, &EncodeOptions::default()).map_err(|e| e.to_string())?;
    let k = encoded.uv_set;
    if encoded.uv_set_per_primitive.iter().any(|&s| s != k) {
        return Err(format!(
            "UV sets differ: {:?}",
            encoded.uv_set_per_primitive
        ));
    }
    let path = dir.join(format!("{name}.out.glb"));
    std::fs::write(&path, &encoded.bytes).map_err(|e| e.to_string())?;
    let (resolution, padding, k) = (resolution.to_string(), padding.to_string(), k.to_string());
    let eval = tools_common::evaluate(
        evaluator,
        &path,
        &[
            "--resolution",
            &resolution,
            "--padding",
            &padding,
            "--uv",
            &k,
        ],
    )?;
    let disagreements = compare(&ours, &eval);
    let num = |p: &str| eval.pointer(p).and_then(Value::as_f64).unwrap_or(f64::NAN);
    line.push_str(&format!(
        "  eval: charts {} l2 {:.5} linf {:.4} pack {:.4} pairs {} → {}",
        num("/charts"),
        num("/stretch/l2"),
        num("/stretch/linf"),
        num("/packing_efficiency"),
        num("/overlap/pairs"),
        if disagreements.is_empty() {
            "agree".to_string()
        } else {
            format!("{} DISAGREE", disagreements.len())
        }
    ));
    Ok(Some(Outcome {
        line,
        disagreements,
    }))
}

const HEADER: &str = "file                               triangles charts        l2      linf    pack  flips s.pairs  x.pairs  meas_ms";

/// `tag` names this run's temp dir: the tests run in parallel in one process.
fn run_all(tag: &str, assets: Vec<(String, Vec<u8>, u32, bool)>, evaluator: &Path) {
    let dir = std::env::temp_dir().join(format!("texatlas-measure-{}-{tag}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    println!("{HEADER}");
    let mut failures = Vec::new();
    let mut compared = 0;
    for (name, glb, resolution, timing_only) in assets {
        let ev = (!timing_only).then_some(evaluator);
        match check_asset(&name, &glb, &dir, resolution, 2, ev) {
            Ok(Some(o)) => {
                println!("{}", o.line);
                compared += usize::from(!timing_only);
                for d in &o.disagreements {
                    println!("    {d}");
                }
                if !o.disagreements.is_empty() {
                    failures.push(format!("{name}: {}", o.disagreements.join("; ")));
                }
            }
            Ok(None) => println!("{name}: skipped (no measurable triangles)"),
            Err(e) => failures.push(format!("{name}: {e}")),
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(compared > 0, "nothing was compared");
    assert!(
        failures.is_empty(),
        "disagreements:\n{}",
        failures.join("\n")
    );
}

#[test]
fn measure_agrees_with_the_evaluator_on_fixtures_and_generated_meshes() {
    let Some(evaluator) = tools_common::eval_dir_from_env() else {
        println!("measure_eval_agreement: skipped (TEXATLAS_EVAL_DIR is unset)");
        return;
    };
    let fixtures_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&fixtures_dir)
        .expect("fixtures")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "glb"))
        .collect();
    files.sort();
    let mut assets: Vec<(String, Vec<u8>, u32, bool)> = files
        .iter()
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(p).expect("read fixture"), 64, false)
        })
        .collect();
    let generated: Vec<(&str, Vec<MeshInput>)> = vec![
        ("gen_grid_12x9", vec![fixtures::grid(12, 9)]),
        (
            "gen_torus_and_sphere",
            vec![
                fixtures::torus(24, 12, 1.0, 0.3),
                fixtures::uv_sphere(12, 24, 0.7),
            ],
        ),
        (
            "gen_cylinder",
            vec![fixtures::cylinder_open(16, 5, 0.5, 2.0)],
        ),
        ("gen_cube", vec![fixtures::cube_split_faces()]),
        ("gen_two_components", vec![fixtures::two_components()]),
    ];
    for (name, parts) in generated {
        assets.push((
            format!("{name}.glb"),
            gltf_common::glb_of_meshes(&parts),
            256,
            false,
        ));
    }
    run_all("fixtures", assets, &evaluator);
}

#[test]
fn measure_agrees_with_the_evaluator_on_the_corpus() {
    let (Some(evaluator), Some(corpus)) = (
        tools_common::eval_dir_from_env(),
        std::env::var_os("TEXATLAS_CORPUS_DIR"),
    ) else {
        println!("measure_eval_agreement corpus: skipped (TEXATLAS_EVAL_DIR or TEXATLAS_CORPUS_DIR unset)");
        return;
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(PathBuf::from(corpus))
        .expect("corpus dir readable")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "glb"))
        .collect();
    files.sort();
    let only = std::env::var("TEXATLAS_CORPUS_ONLY").ok();
    let assets = files
        .iter()
        .filter_map(|p| {
            let name = p.file_name()?.to_string_lossy().into_owned();
            if only.as_deref().is_some_and(|o| !name.contains(o)) {
                return None;
            }
            let bytes = std::fs::read(p).ok()?;
            // The 1M-triangle asset is measured and timed, not compared (evaluator too slow),
            // and only in release builds.
            let huge = bytes.len() > 10_000_000;
            if huge && cfg!(debug_assertions) {
                println!("{name}: skipped in a debug build (timed in release only)");
                return None;
            }
            Some((name, bytes, 1024, huge))
        })
        .collect();
    run_all("corpus", assets, &evaluator);
}

/// CPU time of this process (all threads), seconds, from `/proc/self/stat` (Linux; 0 elsewhere).
/// The machine is shared, so wall time overstates the cost; CPU time does not.
fn process_cpu_s() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the parenthesised command: utime and stime are fields 14 and 15.
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|x| x.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

fn time_measure(name: &str, mesh: &TriangleMesh, uvs: &[[[f32; 2]; 3]], resolution: u32) {
    let pages = vec![0u32; uvs.len()];
    let cpu0 = process_cpu_s();
    let t0 = Instant::now();
    let r = measure_atlas(&MeasureInput {
        mesh,
        corner_uvs: uvs,
        face_page: &pages,
        num_pages: 1,
        width_texels: resolution,
        height_texels: resolution,
        padding_texels: 2,
    });
    println!(
        "{name:<40} {:>8} faces {:>8} charts  {resolution}²  exact pairs {:>8}  wall {:>8.1} ms  cpu {:>6.0} ms",
        r.triangles,
        r.charts,
        r.overlap.exact.pairs,
        t0.elapsed().as_secs_f64() * 1e3,
        (process_cpu_s() - cpu0) * 1e3
    );
}

/// Timings of `measure_atlas` on overlap-free atlases (printed, not asserted: the machine is
/// shared). Release builds only; the corpus files when `TEXATLAS_CORPUS_DIR` is set.
#[test]
fn measure_speed() {
    if cfg!(debug_assertions) {
        println!("measure_speed: skipped (debug build; run with --release)");
        return;
    }
    // A 1M-face grid mapped isometrically: one chart.
    let grid = fixtures::grid(720, 720);
    let mesh = TriangleMesh::build(&grid).expect("grid").mesh;
    let uvs: Vec<[[f32; 2]; 3]> = mesh
        .faces()
        .map(|f| {
            mesh.face_positions(f)
                .map(|p| [(p[0] / 720.0) as f32, (p[1] / 720.0) as f32])
        })
        .collect();
    time_measure("grid 720x720, one chart", &mesh, &uvs, 1024);
    time_measure("grid 720x720, one chart", &mesh, &uvs, 4096);
    time_measure(
        "grid 720x720, per-face charts",
        &mesh,
        &per_face_cell_uvs(mesh.num_faces()),
        1024,
    );
    let Some(corpus) = std::env::var_os("TEXATLAS_CORPUS_DIR") else {
        return;
    };
    for name in ["bunny.glb", "beast_sub2_1M.glb"] {
        let Ok(bytes) = std::fs::read(PathBuf::from(&corpus).join(name)) else {
            continue;
        };
        let asset = decode(&bytes, &Resources::new(), &DecodeLimits::default()).expect("decode");
        let mesh = TriangleMesh::build(asset.mesh_input()).expect("build").mesh;
        time_measure(
            &format!("{name}, per-face charts"),
            &mesh,
            &per_face_cell_uvs(mesh.num_faces()),
            1024,
        );
        time_measure(
            &format!("{name}, folded test UVs"),
            &mesh,
            &test_uvs(&mesh),
            1024,
        );
        if mesh.num_faces() <= 100_000 {
            // The atlas the pipeline really makes (default options), as in `texatlas unwrap`.
            let atlas = texatlas::atlas::generate(
                &mesh,
                &texatlas::atlas::AtlasOptions::default(),
                &mut texatlas::atlas::NoProgress,
            )
            .expect("generate");
            for _ in 0..3 {
                time_measure(
                    &format!("{name}, atlas::generate's atlas"),
                    &mesh,
                    &atlas.corner_uvs,
                    1024,
                );
            }
        }
    }
}
