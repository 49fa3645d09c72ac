//! Tests of the parameterize stage: charts extract as valid chart meshes, validation splits what
//! it must (overlap, area ratio, stretch, sock charts, folds), every chart gets a map (zero-area
//! faces included), the monitor, the merge-back's disk test and chart size bound.
use std::ops::ControlFlow;

use proptest::prelude::*;

use super::defects::segments_intersect;
use super::merge::union_arc;
use super::*;
use crate::atlas::progress::{ProgressFn, Stage, StageProgress};
use crate::atlas::segment::tests::{
    assert_contract as assert_segment_contract, build, segment, subdivided_cube,
};
use crate::atlas::segment::{
    check_chart_is_disk, enforce_disks, finish, grow_two, segment_charts, Lscm2002Options,
    NotADisk, SegmentOptions, SegmentStats, Segmentation,
};
use crate::mesh::{fixtures, FaceId, MeshInput, TriangleMesh};

/// The segmentation contract, and every chart extracts ([`chart_mesh`]) with its faces in order
/// and the positions of its vertices, and passes the parameterizer's own chart validation
/// (`ChartMesh::validate`: connected, manifold, one boundary loop, χ = 1) unless a face is
/// zero-area (which that validation rejects for numerical reasons, not topological ones).
fn assert_contract(mesh: &TriangleMesh, seg: &Segmentation) {
    assert_segment_contract(mesh, seg);
    for (i, c) in seg.charts.iter().enumerate() {
        let (cm, global) = chart_mesh(mesh, c);
        assert_eq!(cm.triangles.len(), c.len());
        for (l, g) in global.iter().enumerate() {
            assert_eq!(cm.positions_m[l], mesh.position(*g));
        }
        if c.iter().all(|&f| mesh.face_normal(f).is_some()) {
            cm.validate()
                .unwrap_or_else(|e| panic!("chart {i} fails ChartMesh::validate: {e}"));
        }
    }
}

/// Every chart segmentation makes of every fixture category is a valid chart mesh for the
/// parameterizer (moved here from the segmentation tests' contract check).
#[test]
fn every_segmented_fixture_chart_extracts_as_a_valid_chart_mesh() {
    let inputs = [
        fixtures::grid(3, 2),
        fixtures::cube_split_faces(),
        fixtures::uv_sphere(4, 6, 1.0),
        fixtures::uv_sphere(8, 12, 1.0),
        fixtures::torus(6, 4, 2.0, 0.5),
        fixtures::torus(12, 6, 2.0, 0.5),
        fixtures::cylinder_open(5, 2, 1.0, 1.0),
        fixtures::two_components(),
        fixtures::bowtie(),
        fixtures::fin(),
        fixtures::flipped_face(),
        fixtures::degenerate(),
        subdivided_cube(4),
    ];
    for input in &inputs {
        let mesh = build(input);
        assert_contract(&mesh, &segment(&mesh));
    }
}

/// The merge-back's disk test from two charts' intersection (`union_arc`) gives
/// the answer of [`check_chart_is_disk`] on the union, for every pair of charts of partitions
/// into small disks (blocks of consecutive faces cut into disks by the disk guarantee) of
/// closed, open and flat meshes; unions that are disks, annuli, pinched or apart all occur.
/// For a disk it returns the vertices both charts use (the glued arc), ascending.
#[test]
fn union_arc_agrees_with_the_disk_check_of_the_union() {
    let inputs = [
        fixtures::torus(12, 6, 2.0, 0.5),
        fixtures::uv_sphere(6, 10, 1.0),
        fixtures::cylinder_open(8, 4, 1.0, 2.0),
        subdivided_cube(3),
        fixtures::grid(6, 5),
        fixtures::fin(),
        fixtures::bowtie(),
    ];
    let (mut disks, mut glued_non_disks, mut apart) = (0, 0, 0);
    for input in &inputs {
        let mesh = build(input);
        for block in [2usize, 3, 5, 8, 13] {
            let ids: Vec<FaceId> = mesh.faces().collect();
            let work: Vec<Vec<FaceId>> = ids.chunks(block).map(<[FaceId]>::to_vec).collect();
            let charts = enforce_disks(&mesh, work, &mut SegmentStats::default());
            let mut label = vec![u32::MAX; mesh.num_faces()];
            for (i, c) in charts.iter().enumerate() {
                for f in c {
                    label[f.index()] = i as u32;
                }
            }
            for i in 0..charts.len() {
                for j in i + 1..charts.len() {
                    let mut union = charts[i].clone();
                    union.extend_from_slice(&charts[j]);
                    let expected = check_chart_is_disk(&mesh, &union);
                    let arc = union_arc(&mesh, &charts[i], &charts[j], &label, i as u32, j as u32);
                    assert_eq!(
                        arc.is_some(),
                        expected.is_ok(),
                        "block {block}, charts {i} and {j}: disk check says {expected:?}"
                    );
                    if let Some(arc) = arc {
                        let vertices_of = |c: &[FaceId]| {
                            let mut v: Vec<_> =
                                c.iter().flat_map(|&f| mesh.face_vertices(f)).collect();
                            v.sort_unstable();
                            v.dedup();
                            v
                        };
                        let b = vertices_of(&charts[j]);
                        let common: Vec<_> = vertices_of(&charts[i])
                            .into_iter()
                            .filter(|v| b.binary_search(v).is_ok())
                            .collect();
                        assert_eq!(arc, common, "block {block}, charts {i} and {j}");
                    }
                    match expected {
                        Ok(_) => disks += 1,
                        Err(NotADisk::Disconnected { .. }) => apart += 1,
                        Err(_) => glued_non_disks += 1,
                    }
                }
            }
        }
    }
    assert!(
        disks > 0 && glued_non_disks > 0 && apart > 0,
        "{disks} disks, {glued_non_disks} glued non-disks, {apart} apart"
    );
}

#[test]
fn a_restricted_map_gives_every_vertex_of_the_part_its_parent_uv() {
    // A 4 × 4 grid flattened as one chart; its left half keeps, vertex by vertex, the UVs of
    // the whole map (a cut in UV space), in the numbering of its own chart mesh, and no face
    // flips. Faces outside the parent are refused.
    let mesh = build(&fixtures::grid(4, 4));
    let all: Vec<FaceId> = (0..mesh.num_faces() as u32).map(FaceId).collect();
    let (cm, global) = chart_mesh(&mesh, &all);
    let map = flatten_chart(
        &cm,
        &FlattenOptions::default(),
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .expect("flattens");
    let uv_of = |v: crate::mesh::VertexId| map.uv[global.iter().position(|&g| g == v).unwrap()];
    let parent: LocatedMap = (map.clone(), global.clone());
    let half: Vec<FaceId> = all[..all.len() / 2].to_vec();
    let (part, part_global) = restricted_map(&mesh, &half, &parent).expect("a part of the parent");
    assert_eq!(part_global, chart_mesh(&mesh, &half).1);
    assert_eq!(part.uv.len(), part_global.len());
    for (l, &v) in part_global.iter().enumerate() {
        assert_eq!(part.uv[l], uv_of(v), "vertex {v:?}");
    }
    assert!(part.is_valid(), "{:?}", part.flipped_faces);
    // A parent that is only the first face does not hold the rest of the half.
    let (small_cm, small_global) = chart_mesh(&mesh, &all[..1]);
    let small: LocatedMap = (
        ChartMap {
            uv: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
            ..map
        },
        small_global,
    );
    assert_eq!(small_cm.triangles.len(), 1);
    assert!(restricted_map(&mesh, &half, &small).is_none());
}

#[test]
fn chart_mesh_maps_local_to_global() {
    let mesh = build(&fixtures::grid(2, 2));
    let faces = [FaceId(5), FaceId(2)];
    let (cm, global) = chart_mesh(&mesh, &faces);
    assert_eq!(cm.triangles.len(), 2);
    for (t, &f) in cm.triangles.iter().zip(&faces) {
        let g = mesh.face_vertices(f);
        for k in 0..3 {
            assert_eq!(global[t[k] as usize], g[k]);
        }
    }
    let mut sorted = global.clone();
    sorted.sort_unstable();
    sorted.dedup();
    assert_eq!(sorted.len(), global.len(), "no vertex twice");
}

fn noisy_grid(nx: u32, ny: u32, noise: &[f64], holes: &[bool]) -> MeshInput {
    let mut g = fixtures::grid(nx, ny);
    for (i, p) in g.positions_m.iter_mut().enumerate() {
        p[2] = noise[i % noise.len()];
    }
    let tris: Vec<[u32; 3]> = g
        .triangles
        .iter()
        .enumerate()
        .filter(|(i, _)| !holes[i % holes.len()])
        .map(|(_, t)| *t)
        .collect();
    if tris.is_empty() {
        g.triangles.truncate(1);
    } else {
        g.triangles = tris;
    }
    g
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
    #[test]
    fn random_meshes_give_disk_charts(
        nx in 1u32..9,
        ny in 1u32..9,
        noise in proptest::collection::vec(-0.8f64..0.8, 1..40),
        holes in proptest::collection::vec(proptest::bool::weighted(0.15), 1..30),
        bend in proptest::bool::ANY,
    ) {
        let input = if bend {
            // A bent tube part: a torus with noise exercises closed surfaces with handles.
            let mut t = fixtures::torus(nx + 3, ny + 3, 2.0, 0.7);
            for (i, p) in t.positions_m.iter_mut().enumerate() {
                p[2] += 0.1 * noise[i % noise.len()];
            }
            t
        } else {
            noisy_grid(nx, ny, &noise, &holes)
        };
        let mesh = build(&input);
        let opts = SegmentOptions {
            lscm: Lscm2002Options { min_feature_length: 2, ..Default::default() },
            ..Default::default()
        };
        let seg = segment_charts(&mesh, &opts, &mut StageProgress::ignored(Stage::Segment)).expect("valid options");
        assert_contract(&mesh, &seg);
    }
}

/// A helical ramp: `turns` turns of an annulus strip between radii 1 and 2, rising by `rise_m`
/// per turn. Almost planar, so its conformal flattening is close to an annulus sector of
/// `turns · 360°`, which overlaps itself when `turns > 1`.
fn helix_strip(turns: f64, n_around: u32, n_across: u32, rise_m: f64) -> MeshInput {
    let mut positions = Vec::new();
    for i in 0..=n_around {
        let t = turns * f64::from(i) / f64::from(n_around);
        let a = 2.0 * std::f64::consts::PI * t;
        for j in 0..=n_across {
            let r = 1.0 + f64::from(j) / f64::from(n_across);
            positions.push([r * a.cos(), r * a.sin(), rise_m * t]);
        }
    }
    let id = |i: u32, j: u32| i * (n_across + 1) + j;
    let mut tris = Vec::new();
    for i in 0..n_around {
        for j in 0..n_across {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            tris.push([a, c, b]);
            tris.push([a, d, c]);
        }
    }
    MeshInput::single_group(positions, tris)
}

/// Brute force over all pairs of non-adjacent boundary edges: independent of the grid.
fn brute_force_crossing(cm: &crate::atlas::parameterize::ChartMesh, uv: &[[f64; 2]]) -> bool {
    let mut directed = Vec::new();
    for t in &cm.triangles {
        for s in 0..3 {
            directed.push((t[s], t[(s + 1) % 3]));
        }
    }
    let set: std::collections::BTreeSet<(u32, u32)> = directed.iter().copied().collect();
    let segs: Vec<(u32, u32)> = directed
        .into_iter()
        .filter(|&(a, b)| !set.contains(&(b, a)))
        .collect();
    let o = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    };
    for (i, &(a, b)) in segs.iter().enumerate() {
        for &(c, d) in &segs[i + 1..] {
            if a == c || a == d || b == c || b == d {
                continue;
            }
            let (pa, pb, pc, pd) = (
                uv[a as usize],
                uv[b as usize],
                uv[c as usize],
                uv[d as usize],
            );
            if o(pa, pb, pc) * o(pa, pb, pd) < 0.0 && o(pc, pd, pa) * o(pc, pd, pb) < 0.0 {
                return true;
            }
        }
    }
    false
}

fn area_ratio(cm: &crate::atlas::parameterize::ChartMesh, uv: &[[f64; 2]]) -> f64 {
    let mut lo = f64::INFINITY;
    let mut hi = 0.0f64;
    for t in &cm.triangles {
        let [a, b, c] = t.map(|i| cm.positions_m[i as usize]);
        let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let ac = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        // Heron-free: |ab|²|ac|² − (ab·ac)² = |ab × ac|².
        let dot = ab[0] * ac[0] + ab[1] * ac[1] + ab[2] * ac[2];
        let n2 = (ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2])
            * (ac[0] * ac[0] + ac[1] * ac[1] + ac[2] * ac[2]);
        let a3 = 0.5 * (n2 - dot * dot).max(0.0).sqrt();
        let [p, q, r] = t.map(|i| uv[i as usize]);
        let a2 = 0.5 * ((q[0] - p[0]) * (r[1] - p[1]) - (r[0] - p[0]) * (q[1] - p[1]));
        lo = lo.min(a3 / a2);
        hi = hi.max(a3 / a2);
    }
    hi / lo
}

#[test]
fn validation_splits_a_self_overlapping_helix_strip() {
    let mesh = build(&helix_strip(1.6, 96, 4, 0.05));
    let all: Vec<FaceId> = mesh.faces().collect();
    let one = finish(&mesh, vec![all.clone()], SegmentStats::default());
    // The whole strip, flattened, overlaps itself (checked by brute force).
    let (cm, _) = chart_mesh(&mesh, &all);
    let map = crate::atlas::parameterize::flatten_chart(
        &cm,
        &Default::default(),
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .expect("the strip is a disk");
    assert!(
        brute_force_crossing(&cm, &map.uv),
        "test premise: the strip overlaps"
    );
    assert!(boundary_crossing(&cm, &map.uv).is_some());
    let opts = ParameterizeOptions {
        max_area_ratio: None,
        ..Default::default()
    };
    let v = parameterize_charts(
        &mesh,
        &one,
        &opts,
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .expect("valid options");
    assert!(v.splits[1] >= 1, "{:?}", v.splits);
    assert!(v.unresolved.is_empty(), "{:?}", v.unresolved);
    assert_contract(&mesh, &v.segmentation);
    for (c, m) in v.segmentation.charts.iter().zip(&v.maps) {
        let (cm, _) = chart_mesh(&mesh, c);
        let (map, _) = m.as_ref().expect("parameterized");
        assert!(map.flipped_faces.is_empty());
        assert!(!brute_force_crossing(&cm, &map.uv));
    }
}

#[test]
fn validation_bounds_the_area_ratio() {
    // A hemisphere flattened conformally shrinks its rim relative to its pole by far more than 2.
    let mesh = build(&fixtures::uv_sphere(16, 24, 1.0));
    let north: Vec<FaceId> = mesh
        .faces()
        .filter(|&f| mesh.face_positions(f).iter().all(|p| p[2] >= -1e-12))
        .collect();
    let south: Vec<FaceId> = mesh
        .faces()
        .filter(|f| north.binary_search(f).is_err())
        .collect();
    let seg = finish(&mesh, vec![north.clone(), south], SegmentStats::default());
    let (cm, _) = chart_mesh(&mesh, &north);
    let map = crate::atlas::parameterize::flatten_chart(
        &cm,
        &Default::default(),
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .expect("a hemisphere is a disk");
    assert!(area_ratio(&cm, &map.uv) > 2.0, "test premise");
    let v = parameterize_charts(
        &mesh,
        &seg,
        &ParameterizeOptions::paper(),
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .expect("valid options");
    assert!(v.splits[2] >= 2, "{:?}", v.splits);
    assert!(v.unresolved.is_empty(), "{:?}", v.unresolved);
    // Bookkeeping: every split adds a chart (the disk guarantee may add more), every merge
    // removes one.
    let extra = v.segmentation.stats.disk_splits - seg.stats.disk_splits;
    assert_eq!(
        v.segmentation.num_charts(),
        2 + v.splits.iter().sum::<usize>() + extra - v.merges
    );
    assert_contract(&mesh, &v.segmentation);
    for (c, m) in v.segmentation.charts.iter().zip(&v.maps) {
        let (cm, _) = chart_mesh(&mesh, c);
        let (map, _) = m.as_ref().expect("parameterized");
        let r = area_ratio(&cm, &map.uv);
        assert!(r <= 2.0 + 1e-9, "chart of {} faces has ratio {r}", c.len());
    }
}

/// Signed UV area of triangle `t`.
fn uv_area(uv: &[[f64; 2]], t: [u32; 3]) -> f64 {
    let [p, q, r] = t.map(|i| uv[i as usize]);
    0.5 * ((q[0] - p[0]) * (r[1] - p[1]) - (r[0] - p[0]) * (q[1] - p[1]))
}

/// The `maps` contract of [`ParameterizedCharts`]: every chart has a map, its vertex list is the
/// chart's [`chart_mesh`] vertex list, UVs are finite, every non-degenerate face has a positive
/// UV area and every zero-area face a UV area within rounding of 0 (relative to the chart's UV
/// extent). Returns the number of zero-area faces seen.
fn assert_maps_contract(mesh: &TriangleMesh, v: &ParameterizedCharts) -> usize {
    assert_eq!(v.maps.len(), v.segmentation.num_charts());
    let mut zero_area = 0;
    for (i, (c, m)) in v.segmentation.charts.iter().zip(&v.maps).enumerate() {
        let (map, global) = m.as_ref().unwrap_or_else(|| panic!("chart {i} has no map"));
        let (cm, expected) = chart_mesh(mesh, c);
        assert_eq!(global, &expected, "chart {i}: vertex list");
        assert_eq!(map.uv.len(), global.len(), "chart {i}: one UV per vertex");
        assert!(map.uv.iter().flatten().all(|x| x.is_finite()));
        assert!(map.flipped_faces.is_empty(), "chart {i}: flips");
        let extent = map
            .uv
            .iter()
            .flatten()
            .fold(0.0f64, |m, x| m.max(x.abs()))
            .max(1e-300);
        for (k, &f) in c.iter().enumerate() {
            let a = uv_area(&map.uv, cm.triangles[k]);
            if mesh.face_degeneracy(f).is_some() {
                zero_area += 1;
                assert!(
                    a.abs() <= 1e-9 * extent * extent,
                    "chart {i} face {f:?}: {a}"
                );
            } else {
                assert!(a > 0.0, "chart {i} face {f:?}: UV area {a}");
            }
        }
    }
    zero_area
}

/// A flat 4×4 grid (1 m cells) with two zero-area faces: one inside, closing a T-junction at
/// the midpoint `m` of the edge (1,1)–(2,1) (without it the grid has a hole), and one on the
/// bottom border, whose third vertex, at x = 2.25 m on the edge (2,0)–(3,0), no other face uses.
fn grid_with_zero_area_faces() -> MeshInput {
    let mut g = fixtures::grid(4, 4);
    let id = |i: u32, j: u32| j * 5 + i;
    let (a, b, c) = (id(1, 1), id(2, 1), id(2, 2));
    let k = g
        .triangles
        .iter()
        .position(|t| *t == [a, b, c])
        .expect("grid triangle");
    let m = g.positions_m.len() as u32;
    g.positions_m.push([1.5, 1.0, 0.0]);
    g.weld_group.push(0);
    g.triangles[k] = [a, m, c];
    g.triangles.push([m, b, c]);
    g.triangles.push([a, b, m]);
    let (p, q) = (id(2, 0), id(3, 0));
    let e = g.positions_m.len() as u32;
    g.positions_m.push([2.25, 0.0, 0.0]);
    g.weld_group.push(0);
    g.triangles.push([q, p, e]);
    g
}

#[test]
fn every_chart_gets_a_map_even_with_zero_area_faces() {
    let mesh = build(&grid_with_zero_area_faces());
    let interior = FaceId(mesh.num_faces() as u32 - 2);
    let border = FaceId(mesh.num_faces() as u32 - 1);
    assert!(mesh.face_degeneracy(interior).is_some() && mesh.face_degeneracy(border).is_some());
    // The whole grid as one chart: a disk, but not without its inner zero-area face.
    let all: Vec<FaceId> = mesh.faces().collect();
    check_chart_is_disk(&mesh, &all).expect("premise: the whole grid is a disk");
    let seg = finish(&mesh, vec![all], SegmentStats::default());
    let v = parameterize_charts(
        &mesh,
        &seg,
        &ParameterizeOptions::default(),
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .expect("valid");
    assert_contract(&mesh, &v.segmentation);
    assert_eq!(assert_maps_contract(&mesh, &v), 2);
    assert_eq!(v.degenerate_faces, 2);
    assert!(
        v.degenerate_splits >= 1,
        "the inner zero-area face forces a split"
    );
    assert!(v.unresolved.is_empty(), "{:?}", v.unresolved);
    // The border vertex at x = 2.25 lies a quarter of the way along its edge in UV too.
    let c = v.segmentation.face_chart[border].index();
    let (map, global) = v.maps[c].as_ref().expect("map");
    let uv_of = |x: [f64; 3]| {
        let l = global
            .iter()
            .position(|&g| mesh.position(g) == x)
            .expect("vertex in chart");
        map.uv[l]
    };
    let (up, uq, ue) = (
        uv_of([2.0, 0.0, 0.0]),
        uv_of([3.0, 0.0, 0.0]),
        uv_of([2.25, 0.0, 0.0]),
    );
    for k in 0..2 {
        assert!(
            (ue[k] - (0.75 * up[k] + 0.25 * uq[k])).abs() < 1e-9,
            "{ue:?} {up:?} {uq:?}"
        );
    }
    // Deterministic.
    assert_eq!(
        v,
        parameterize_charts(
            &mesh,
            &seg,
            &ParameterizeOptions::default(),
            &mut StageProgress::ignored(Stage::Parameterize)
        )
        .expect("valid")
    );
}

#[test]
fn validation_maps_degenerate_fixture_charts_and_rejects_bad_ratio() {
    let mesh = build(&fixtures::degenerate());
    let seg = segment(&mesh);
    let v = parameterize_charts(
        &mesh,
        &seg,
        &ParameterizeOptions::default(),
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .expect("valid");
    assert_contract(&mesh, &v.segmentation);
    // Face 2 is zero-area and glued to face 0; faces 3 and 4 repeat a vertex (isolated, all
    // degenerate: the line map). All of them get maps, none is unresolved.
    assert_eq!(assert_maps_contract(&mesh, &v), 3);
    assert!(v.unresolved.is_empty(), "{:?}", v.unresolved);
    let bad = ParameterizeOptions {
        max_area_ratio: Some(0.5),
        ..Default::default()
    };
    assert!(matches!(
        parameterize_charts(
            &mesh,
            &seg,
            &bad,
            &mut StageProgress::ignored(Stage::Parameterize)
        ),
        Err(ParameterizeChartsError::InvalidOption {
            option: "max_area_ratio",
            ..
        })
    ));
}

#[test]
fn the_monitor_sees_every_chart_and_can_cancel() {
    let mesh = build(&fixtures::uv_sphere(16, 24, 1.0));
    let seg = segment(&mesh);
    let mut calls: Vec<(Stage, usize, usize)> = Vec::new();
    let mut record = ProgressFn(|stage, d, k| {
        calls.push((stage, d, k));
        ControlFlow::Continue(())
    });
    let v = parameterize_charts(
        &mesh,
        &seg,
        &ParameterizeOptions::default(),
        &mut StageProgress::new(Stage::Parameterize, &mut record),
    )
    .expect("valid");
    assert!(calls.len() >= seg.num_charts(), "{calls:?}");
    assert!(
        calls
            .iter()
            .all(|&(s, d, k)| s == Stage::Parameterize && d <= k),
        "{calls:?}"
    );
    assert_eq!(
        v,
        parameterize_charts(
            &mesh,
            &seg,
            &ParameterizeOptions::default(),
            &mut StageProgress::ignored(Stage::Parameterize)
        )
        .expect("valid"),
        "the monitor does not change the result"
    );
    let mut n = 0;
    let mut stop_at_second = ProgressFn(|_, _, _| {
        n += 1;
        if n > 1 {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    let r = parameterize_charts(
        &mesh,
        &seg,
        &ParameterizeOptions::default(),
        &mut StageProgress::new(Stage::Parameterize, &mut stop_at_second),
    );
    assert_eq!(r, Err(ParameterizeChartsError::Cancelled));
}

/// Sander L2 stretch of one chart map, the chart scaled to UV area = model area, recomputed
/// from the singular values of each face's Jacobian (the validator uses the derivative
/// vectors): `L2² = Σ A3·(Γ² + γ²)/2 / Σ A3` with `Γ`, `γ` of the UV → 3-D map.
fn chart_stretch(cm: &crate::atlas::parameterize::ChartMesh, uv: &[[f64; 2]]) -> f64 {
    let (mut num, mut a3s, mut a2s) = (0.0, 0.0, 0.0);
    for t in &cm.triangles {
        let [p0, p1, p2] = t.map(|i| cm.positions_m[i as usize]);
        // An orthonormal frame of the 3-D triangle: e1 along p0p1.
        let d1 = [p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]];
        let d2 = [p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]];
        let l1 = (d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]).sqrt();
        let x2 = (d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2]) / l1;
        let y2 = ((d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2]) - x2 * x2)
            .max(0.0)
            .sqrt();
        let a3 = 0.5 * l1 * y2;
        let [q0, q1, q2] = t.map(|i| uv[i as usize]);
        let e = [
            [q1[0] - q0[0], q2[0] - q0[0]],
            [q1[1] - q0[1], q2[1] - q0[1]],
        ];
        // J (3-D frame → UV) = E · X⁻¹ with X = [[l1, x2], [0, y2]]; the UV → 3-D map is J⁻¹.
        let xi = [[1.0 / l1, -x2 / (l1 * y2)], [0.0, 1.0 / y2]];
        let j = [
            [e[0][0] * xi[0][0], e[0][0] * xi[0][1] + e[0][1] * xi[1][1]],
            [e[1][0] * xi[0][0], e[1][0] * xi[0][1] + e[1][1] * xi[1][1]],
        ];
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        let fro2 = j.iter().flatten().map(|x| x * x).sum::<f64>();
        // Singular values of J⁻¹ are 1/σ of J: Γ² + γ² = (σ1² + σ2²) / (σ1 σ2)² = |J|²_F / det².
        num += a3 * 0.5 * fro2 / (det * det);
        a3s += a3;
        a2s += 0.5 * det * l1 * y2;
    }
    (num / a3s * a2s / a3s).sqrt()
}

#[test]
fn validation_bounds_the_chart_stretch_by_default() {
    // A sphere cut into a large cap (down to z = -0.75) and a small one: the large cap
    // flattened conformally has an L2 stretch far above 1.1.
    let mesh = build(&fixtures::uv_sphere(16, 24, 1.0));
    let north: Vec<FaceId> = mesh
        .faces()
        .filter(|&f| mesh.face_positions(f).iter().all(|p| p[2] >= -0.75))
        .collect();
    let south: Vec<FaceId> = mesh
        .faces()
        .filter(|f| north.binary_search(f).is_err())
        .collect();
    let seg = finish(&mesh, vec![north.clone(), south], SegmentStats::default());
    let (cm, _) = chart_mesh(&mesh, &north);
    let map = crate::atlas::parameterize::flatten_chart(
        &cm,
        &Default::default(),
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .expect("a hemisphere is a disk");
    let bound = ParameterizeOptions::default()
        .max_stretch
        .expect("a default bound");
    let l2 = chart_stretch(&cm, &map.uv);
    assert!(l2 > bound, "test premise: {l2}");
    let v = parameterize_charts(
        &mesh,
        &seg,
        &ParameterizeOptions::default(),
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .expect("valid options");
    assert!(v.splits[2] >= 1, "{:?}", v.splits);
    assert!(v.unresolved.is_empty(), "{:?}", v.unresolved);
    assert_contract(&mesh, &v.segmentation);
    assert_maps_contract(&mesh, &v);
    for (c, m) in v.segmentation.charts.iter().zip(&v.maps) {
        let (cm, _) = chart_mesh(&mesh, c);
        let (map, _) = m.as_ref().expect("parameterized");
        let l2 = chart_stretch(&cm, &map.uv);
        assert!(l2 <= bound + 1e-9, "chart of {} faces has L2 {l2}", c.len());
    }
    for bad in [
        ParameterizeOptions {
            max_stretch: Some(0.9),
            ..Default::default()
        },
        ParameterizeOptions {
            area_ratio_trim: 0.5,
            ..Default::default()
        },
    ] {
        assert!(matches!(
            parameterize_charts(
                &mesh,
                &seg,
                &bad,
                &mut StageProgress::ignored(Stage::Parameterize)
            ),
            Err(ParameterizeChartsError::InvalidOption { .. })
        ));
    }
}

/// A fan around vertex 0 with `n` triangles of `step_deg` degrees each, ring radius 1; closed
/// (`n` ring vertices, the last triangle back to the first ring vertex) or open.
fn fan(
    n: usize,
    step_deg: f64,
    closed: bool,
) -> (crate::atlas::parameterize::ChartMesh, Vec<[f64; 2]>) {
    let ring = if closed { n } else { n + 1 };
    let mut uv = vec![[0.0, 0.0]];
    for k in 0..ring {
        let a = (k as f64 * step_deg).to_radians();
        uv.push([a.cos(), a.sin()]);
    }
    let triangles: Vec<[u32; 3]> = (0..n)
        .map(|k| [0, 1 + k as u32, 1 + ((k + 1) % ring) as u32])
        .collect();
    let positions_m = uv.iter().map(|p| [p[0], p[1], 0.0]).collect();
    (
        crate::atlas::parameterize::ChartMesh {
            positions_m,
            triangles,
        },
        uv,
    )
}

#[test]
fn vertex_fold_finds_fans_that_wrap_past_a_full_turn() {
    // Open fans (vertex 0 on the boundary): 4 × 80° = 320° is fine, 5 × 80° = 400° folds.
    let (cm, uv) = fan(4, 80.0, false);
    assert_eq!(vertex_fold(&cm, &uv), None);
    let (cm, uv) = fan(5, 80.0, false);
    assert!(crate::atlas::parameterize::flipped_faces(&cm, &uv).is_empty());
    assert_eq!(vertex_fold(&cm, &uv), Some([0, 4]));
    // Closed fans (vertex 0 interior): 8 × 45° is a disk, 8 × 90° wraps twice.
    let (cm, uv) = fan(8, 45.0, true);
    assert_eq!(vertex_fold(&cm, &uv), None);
    let (cm, uv) = fan(8, 90.0, true);
    assert!(crate::atlas::parameterize::flipped_faces(&cm, &uv).is_empty());
    assert!(vertex_fold(&cm, &uv).is_some());
}

#[test]
fn near_collinear_overlapping_segments_count_as_crossing() {
    // Points on y = x / 3 up to rounding: the orientation signs are noise, the segments overlap.
    let (a, b, c, d) = ([0.0, 0.0], [0.9, 0.3], [0.3, 0.1], [1.2, 0.4]);
    assert!(segments_intersect(a, b, c, d));
    assert!(segments_intersect(c, d, a, b));
    // Clearly apart segments still do not.
    assert!(!segments_intersect(a, b, [0.3, 0.2], [1.2, 0.5]));
}

/// A finger: a cylinder of radius `r_m` and length `length_m` along z (open at `z = −length_m`)
/// closed at the top by a hemisphere ending in a pole vertex; `n_around` segments, `n_cyl`
/// rings of quads on the cylinder and `n_cap` on the cap. A sock-shaped extremal cylinder
/// (LSCM paper §3.2, Figure 5-B): a disk with one boundary loop (the rim).
fn finger(n_around: u32, n_cyl: u32, n_cap: u32, r_m: f64, length_m: f64) -> MeshInput {
    use std::f64::consts::PI;
    let mut positions = Vec::new();
    for i in 0..=n_cyl {
        let z = -length_m + length_m * f64::from(i) / f64::from(n_cyl);
        for j in 0..n_around {
            let phi = 2.0 * PI * f64::from(j) / f64::from(n_around);
            positions.push([r_m * phi.cos(), r_m * phi.sin(), z]);
        }
    }
    for k in 1..n_cap {
        let e = 0.5 * PI * f64::from(k) / f64::from(n_cap);
        for j in 0..n_around {
            let phi = 2.0 * PI * f64::from(j) / f64::from(n_around);
            positions.push([
                r_m * e.cos() * phi.cos(),
                r_m * e.cos() * phi.sin(),
                r_m * e.sin(),
            ]);
        }
    }
    let rings = n_cyl + n_cap;
    let pole = rings * n_around;
    positions.push([0.0, 0.0, r_m]);
    let id = |i: u32, j: u32| i * n_around + j % n_around;
    let mut tris = Vec::new();
    for i in 0..rings - 1 {
        for j in 0..n_around {
            let (a, b, c, d) = (id(i, j), id(i, j + 1), id(i + 1, j + 1), id(i + 1, j));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    for j in 0..n_around {
        tris.push([id(rings - 1, j), id(rings - 1, j + 1), pole]);
    }
    MeshInput::single_group(positions, tris)
}

#[test]
fn sock_chart_is_split_lengthwise_from_its_rim_into_two_flat_halves() {
    let mesh = build(&finger(24, 12, 6, 1.0, 4.0));
    let all: Vec<FaceId> = mesh.faces().collect();
    check_chart_is_disk(&mesh, &all).expect("a finger is a disk");
    let bound = ParameterizeOptions::default()
        .max_stretch
        .expect("a default bound");
    let (cm, _) = chart_mesh(&mesh, &all);
    let map = crate::atlas::parameterize::flatten_chart(
        &cm,
        &Default::default(),
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .expect("a disk flattens");
    let whole = chart_stretch(&cm, &map.uv);
    assert!(
        whole > 2.0 * bound,
        "test premise: the whole sock is over-stretched ({whole})"
    );
    // The tip (a pole face) is the most squeezed face, a rim face the least.
    let tip = *all.last().expect("faces");
    let rim_face = all[0];
    let inside = |_: FaceId| true;
    let (a, b) = super::sock::stretch_split_seeds(&mesh, &all, &inside, rim_face, tip);
    let on_rim = |f: FaceId| {
        mesh.face_halfedges(f)
            .into_iter()
            .any(|h| mesh.opposite(h).is_none())
    };
    assert!(a != b && on_rim(a) && on_rim(b), "seeds {a:?} {b:?}");
    let (half_a, half_b) = grow_two(&mesh, &all, &inside, a, b);
    // Lengthwise: each half reaches the tip ring and holds about half the faces.
    for half in [&half_a, &half_b] {
        check_chart_is_disk(&mesh, half).expect("each half is a disk");
        assert!(
            half.len() * 5 > all.len() * 2,
            "{} of {}",
            half.len(),
            all.len()
        );
        let (cm, _) = chart_mesh(&mesh, half);
        let map = crate::atlas::parameterize::flatten_chart(
            &cm,
            &Default::default(),
            &mut StageProgress::ignored(Stage::Parameterize),
        )
        .expect("a disk flattens");
        // The stage tests the bound on the map after the chart's global stretch descent (the
        // default stretch optimisation).
        let uv = super::stretch::descend_for_bound(&cm, &map.uv).unwrap_or(map.uv);
        let l2 = chart_stretch(&cm, &uv);
        assert!(
            l2 <= bound,
            "half of {} faces has L2 {l2} (whole {whole})",
            half.len()
        );
    }
    // The whole validation: the sock leaves as at most two charts, each within the bound.
    let seg = finish(&mesh, vec![all.clone()], SegmentStats::default());
    let v = parameterize_charts(
        &mesh,
        &seg,
        &ParameterizeOptions::default(),
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .expect("valid options");
    assert_contract(&mesh, &v.segmentation);
    assert_maps_contract(&mesh, &v);
    assert!(
        v.segmentation.num_charts() <= 2,
        "{} charts, splits {:?}",
        v.segmentation.num_charts(),
        v.splits
    );
    for (c, m) in v.segmentation.charts.iter().zip(&v.maps) {
        let (cm, _) = chart_mesh(&mesh, c);
        let (map, _) = m.as_ref().expect("parameterized");
        assert!(chart_stretch(&cm, &map.uv) <= bound + 1e-9);
    }
    // A chart whose most squeezed face is on its rim keeps the paper's seeds.
    assert_eq!(
        super::sock::stretch_split_seeds(&mesh, &all, &inside, tip, rim_face),
        (tip, rim_face)
    );
}

#[test]
fn merge_back_respects_the_chart_size_bound() {
    // A flat 100 × 60 grid (12,000 faces) given as 20 strips of 3 rows (600 faces each): every
    // union of strips is a valid disk, so only the size bound stops the merging.
    let mesh = build(&fixtures::grid(100, 60));
    let mut strips: Vec<Vec<FaceId>> = vec![Vec::new(); 20];
    for f in mesh.faces() {
        let y = mesh.face_positions(f).iter().map(|p| p[1]).sum::<f64>() / 3.0;
        strips[(y / 3.0) as usize].push(f);
    }
    let seg = finish(&mesh, strips, SegmentStats::default());
    let largest = |v: &ParameterizedCharts| v.segmentation.charts.iter().map(Vec::len).max();
    let unbounded = ParameterizeOptions {
        merge_passes: 8,
        merge_max_chart_fraction: None,
        ..Default::default()
    };
    let free = parameterize_charts(
        &mesh,
        &seg,
        &unbounded,
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .expect("valid options");
    assert!(
        largest(&free) > Some(MERGE_CAP_FLOOR_FACES),
        "test premise: unbounded merging makes a chart above the floor, {:?}",
        largest(&free)
    );
    for (fraction, limit) in [(0.1, MERGE_CAP_FLOOR_FACES), (0.5, 6_000)] {
        let bounded = ParameterizeOptions {
            merge_max_chart_fraction: Some(fraction),
            ..unbounded
        };
        let v = parameterize_charts(
            &mesh,
            &seg,
            &bounded,
            &mut StageProgress::ignored(Stage::Parameterize),
        )
        .expect("valid options");
        assert!(v.merges > 0, "{fraction}: no merge at all");
        assert!(
            largest(&v) <= Some(limit),
            "{fraction}: a merged chart of {:?} faces, bound {limit}",
            largest(&v)
        );
        assert!(v.segmentation.charts.len() > free.segmentation.charts.len());
        assert_contract(&mesh, &v.segmentation);
        assert_maps_contract(&mesh, &v);
    }
    for bad in [0.0, -0.1, 1.5, f64::NAN] {
        let o = ParameterizeOptions {
            merge_max_chart_fraction: Some(bad),
            ..Default::default()
        };
        assert!(
            parameterize_charts(
                &mesh,
                &seg,
                &o,
                &mut StageProgress::ignored(Stage::Parameterize)
            )
            .is_err(),
            "{bad} accepted"
        );
    }
}

#[test]
fn the_linf_bound_alone_flags_a_chart_and_none_lets_it_pass() {
    // A finger flattened whole: its worst face is far more stretched than its mean.
    let mesh = build(&finger(24, 12, 6, 1.0, 4.0));
    let all: Vec<FaceId> = mesh.faces().collect();
    let (cm, _) = chart_mesh(&mesh, &all);
    let topology = cm.validate().expect("a disk");
    let map = crate::atlas::parameterize::flatten_chart(
        &cm,
        &Default::default(),
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .expect("a disk flattens");
    let zero = vec![false; cm.triangles.len()];
    let (l2, linf) = super::stretch::chart_stretch(
        &super::stretch::StretchChart {
            positions_m: &cm.positions_m,
            triangles: &cm.triangles,
            zero_area: &zero,
        },
        &map.uv,
    )
    .expect("flip-free");
    assert!(
        linf > 1.5 * l2,
        "test premise: L∞ {linf} well above L2 {l2}"
    );
    let options = |max_linf: Option<f64>| ParameterizeOptions {
        max_stretch: None,
        max_linf,
        ..ParameterizeOptions::default()
    };
    let defect = |o: &ParameterizeOptions| {
        super::defects::find_defect(&all, &cm, &topology.boundary_loop, &map, o)
    };
    match defect(&options(Some(0.5 * (l2 + linf)))) {
        Some(ChartDefect::Stretch { linf: Some(x), .. }) => assert!((x - linf).abs() < 1e-9 * linf),
        other => panic!("expected an L∞ stretch defect, got {other:?}"),
    }
    assert_eq!(defect(&options(Some(linf * 1.01))), None);
    assert_eq!(defect(&options(None)), None);
    // A bound below 1 is refused with the option's name.
    assert!(matches!(
        options(Some(0.9)).check(),
        Err(ParameterizeChartsError::InvalidOption {
            option: "max_linf",
            ..
        })
    ));
}
