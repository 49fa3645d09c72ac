//! Packing over the shared corpus, when `TEXATLAS_CORPUS_DIR` names it (unset: skipped). For
//! every mesh: segment, validate (flatten), pack with the default options (1024², 2 texels of
//! padding, 16 rotations, fit to page); prints charts, packing efficiency and packing time, and
//! asserts the stage guarantees with the independent checker. The 1M-triangle mesh is left out
//! unless `TEXATLAS_CORPUS_ALL` is set.
//!
//! Run: `TEXATLAS_CORPUS_DIR=../shared/corpus cargo test --release --test corpus -- pack_corpus:: --nocapture`.
use std::path::PathBuf;
use std::time::Instant;

use texatlas::atlas::pack::test_charts::{check_packing, OwnedChart};
use texatlas::atlas::pack::{pack_charts, PackOptions};
use texatlas::atlas::parameterize::{parameterize_charts, ParameterizeOptions};
use texatlas::atlas::segment::{segment_charts, SegmentOptions};
use texatlas::atlas::{Stage, StageProgress};
use texatlas::gltf_io::{decode, DecodeLimits, Resources};
use texatlas::mesh::TriangleMesh;

#[test]
fn pack_every_corpus_mesh() {
    let Some(dir) = std::env::var_os("TEXATLAS_CORPUS_DIR").map(PathBuf::from) else {
        println!("pack_corpus: skipped (TEXATLAS_CORPUS_DIR is unset)");
        return;
    };
    let only = std::env::var("TEXATLAS_CORPUS_ONLY").ok();
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("TEXATLAS_CORPUS_DIR is readable")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "glb"))
        .filter(|p| {
            std::env::var_os("TEXATLAS_CORPUS_ALL").is_some() || !p.to_string_lossy().contains("1M")
        })
        .filter(|p| {
            only.as_ref()
                .is_none_or(|o| p.to_string_lossy().contains(o.as_str()))
        })
        .collect();
    files.sort();
    for path in files {
        let bytes = std::fs::read(&path).expect("readable corpus file");
        let asset = decode(&bytes, &Resources::new(), &DecodeLimits::default()).expect("decodes");
        let mesh = TriangleMesh::build(asset.mesh_input())
            .expect("builds")
            .mesh;
        let seg = segment_charts(
            &mesh,
            &SegmentOptions::default(),
            &mut StageProgress::ignored(Stage::Segment),
        )
        .expect("segments");
        let v = parameterize_charts(
            &mesh,
            &seg,
            &ParameterizeOptions::default(),
            &mut StageProgress::ignored(Stage::Parameterize),
        )
        .expect("validates");
        let mut charts = Vec::new();
        for (faces, map) in v.segmentation.charts.iter().zip(&v.maps) {
            let Some((map, global)) = map else { continue };
            let local: std::collections::BTreeMap<_, u32> = global
                .iter()
                .enumerate()
                .map(|(i, &g)| (g, i as u32))
                .collect();
            let triangles: Vec<[u32; 3]> = faces
                .iter()
                .map(|&f| mesh.face_vertices(f).map(|g| local[&g]))
                .collect();
            let area_m2 = faces.iter().map(|&f| mesh.face_area_m2(f)).sum();
            charts.push(OwnedChart {
                uv: map.uv.clone(),
                triangles,
                area_m2,
            });
        }
        let borrowed: Vec<_> = charts.iter().map(OwnedChart::as_pack_chart).collect();
        let options = PackOptions::default();
        let t = Instant::now();
        let packing = pack_charts(
            &borrowed,
            &options,
            &mut StageProgress::ignored(Stage::Pack),
        )
        .expect("packs");
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let check = check_packing(&borrowed, &packing, &options);
        let name = path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        println!(
            "{name:36} faces {:7} charts {:5} efficiency {:.3} texel utilization {:.3} unresolved {} pack {ms:8.1} ms trials {}  violations {:?}",
            mesh.num_faces(),
            charts.len(),
            check.efficiency,
            check.covered_texels as f64 / (1024.0 * 1024.0),
            v.unresolved.len(),
            packing.trials,
            (check.overlap_texels, check.padding_violation_texels, check.edge_violation_texels, check.out_of_range_uvs)
        );
        assert_eq!(
            check.overlap_texels
                + check.padding_violation_texels
                + check.edge_violation_texels
                + check.out_of_range_uvs,
            0,
            "{name}"
        );
    }
}
