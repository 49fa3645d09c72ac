//! Tests of the segmentation stage: the disk contract on every fixture category, the paper's
//! expected chart layouts (cube, sphere, torus), features and distances recomputed independently.
use proptest::prelude::*;

use std::ops::ControlFlow;

use super::*;
use crate::mesh::{fixtures, MeshInput};

fn build(input: &MeshInput) -> TriangleMesh {
    TriangleMesh::build(input).expect("fixture builds").mesh
}

/// A cube `[0, n]³` whose sides are `n × n` grids (welded by bit-identical integer positions),
/// outward, `12 n²` faces. Side `s` holds faces `2n²·s .. 2n²·(s+1)`.
fn subdivided_cube(n: u32) -> MeshInput {
    let sides: [([f64; 3], [f64; 3], [f64; 3]); 6] = [
        ([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]),
        ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]),
        ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
        ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
    ];
    let nf = f64::from(n);
    let mut parts = Vec::new();
    for (o, u, v) in sides {
        let mut g = fixtures::grid(n, n);
        for p in &mut g.positions_m {
            let (a, b) = (p[0], p[1]);
            *p = [0, 1, 2].map(|k| o[k] * nf + a * u[k] + b * v[k]);
        }
        parts.push(g);
    }
    fixtures::concat(&parts)
}

/// Every face in exactly one chart, the map and the lists agree, every chart passes
/// [`check_chart_is_disk`] and, independently, the parameterizer's own chart validation
/// (`ChartMesh::validate`: connected, manifold, one boundary loop, χ = 1) unless a face is
/// zero-area (which that validation rejects for numerical reasons, not topological ones).
fn assert_contract(mesh: &TriangleMesh, seg: &Segmentation) {
    let mut count = vec![0u32; mesh.num_faces()];
    for (i, c) in seg.charts.iter().enumerate() {
        assert!(!c.is_empty());
        for &f in c {
            count[f.index()] += 1;
            assert_eq!(seg.face_chart[f], ChartId(i as u32));
        }
        check_chart_is_disk(mesh, c).unwrap_or_else(|e| panic!("chart {i}: {e}"));
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
    assert!(
        count.iter().all(|&n| n == 1),
        "every face in exactly one chart"
    );
    // Charts never span components.
    let comps = mesh.components();
    for c in &seg.charts {
        assert!(c.iter().all(|&f| comps.of_face(f) == comps.of_face(c[0])));
    }
    // Ordered by lowest face id.
    assert!(seg.charts.windows(2).all(|w| w[0][0] < w[1][0]));
}

fn segment(mesh: &TriangleMesh) -> Segmentation {
    segment_charts(mesh, &SegmentOptions::default()).expect("default options are valid")
}

#[test]
fn subdivided_cube_gives_one_chart_per_side() {
    let n = 8;
    let mesh = build(&subdivided_cube(n));
    let seg = segment(&mesh);
    assert_contract(&mesh, &seg);
    assert_eq!(seg.num_charts(), 6, "stats {:?}", seg.stats);
    // Each chart is exactly one side: all its normals agree.
    for c in &seg.charts {
        assert_eq!(c.len() as u32, 2 * n * n);
        let n0 = mesh.face_normal(c[0]).expect("non-degenerate");
        for &f in c {
            let nf = mesh.face_normal(f).expect("non-degenerate");
            assert!((0..3).all(|k| (nf[k] - n0[k]).abs() < 1e-12));
        }
    }
}

#[test]
fn subdivided_cube_features_are_the_cube_edges() {
    let n = 8;
    let mesh = build(&subdivided_cube(n));
    let feats = detect_features(&mesh, &Lscm2002Options::default());
    let tau = feats.threshold_rad.expect("the cube has sharp edges");
    assert!((tau - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
    // Every feature edge is a right-angle edge (recomputed from the face normals), and every
    // cube edge (12 · n mesh edges) is found.
    let mut found = 0;
    for h in mesh.edges() {
        let o = mesh.opposite(h).expect("closed");
        let a = mesh.face_normal(h.face()).expect("non-degenerate");
        let b = mesh.face_normal(o.face()).expect("non-degenerate");
        let right_angle = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).abs() < 1e-9;
        assert_eq!(feats.is_feature_edge(h), right_angle, "edge {h:?}");
        assert_eq!(feats.is_feature_edge(h), feats.is_feature_edge(o));
        found += usize::from(right_angle);
    }
    assert_eq!(found, 12 * n as usize);
    assert_eq!(feats.num_feature_edges(), found);
}

#[test]
fn small_cube_without_long_features_still_gives_disks() {
    // 12 faces: no feature reaches 15 edges, so without hard edges the cube is a closed
    // featureless surface and is split by the diameter rule.
    let mesh = build(&fixtures::cube_split_faces());
    let opts = SegmentOptions {
        lscm: Lscm2002Options {
            hard_edge_angle_rad: None,
            ..Lscm2002Options::default()
        },
        ..SegmentOptions::default()
    };
    let seg = segment_charts(&mesh, &opts).expect("valid options");
    assert_contract(&mesh, &seg);
    assert_eq!(seg.stats.feature_edges, 0);
    assert!((2..=6).contains(&seg.num_charts()), "{}", seg.num_charts());
}

#[test]
fn small_cube_gives_one_chart_per_side_by_its_hard_edges() {
    // 12 faces, the corpus' Box.glb: Algorithm 1 keeps no curve, so the 12 right-angle edges
    // are hard-edge features (default 60°) and each side is a chart of its 2 coplanar triangles.
    let mesh = build(&fixtures::cube_split_faces());
    let seg = segment(&mesh);
    assert_contract(&mesh, &seg);
    assert_eq!(seg.stats.feature_edges, 12, "stats {:?}", seg.stats);
    assert_eq!(seg.num_charts(), 6, "stats {:?}", seg.stats);
    for c in &seg.charts {
        assert_eq!(c.len(), 2);
        let a = mesh.face_normal(c[0]).expect("non-degenerate");
        let b = mesh.face_normal(c[1]).expect("non-degenerate");
        assert!((0..3).all(|k| (a[k] - b[k]).abs() < 1e-12), "{a:?} {b:?}");
    }
}

#[test]
fn small_box_with_unequal_sides_gives_one_chart_per_side() {
    // A 3 × 2 × 1 box: the faces of the big sides are farther from the edges than those of the
    // small sides, so a local maximum over the whole vertex fan would seed the big sides only;
    // compared only on their side of the hard edges, every side gets its seed.
    let mut input = fixtures::cube_split_faces();
    for p in &mut input.positions_m {
        p[0] *= 3.0;
        p[1] *= 2.0;
    }
    let mesh = build(&input);
    let seg = segment(&mesh);
    assert_contract(&mesh, &seg);
    assert_eq!(seg.num_charts(), 6, "stats {:?}", seg.stats);
}

#[test]
fn featureless_sphere_is_split_by_the_diameter_rule() {
    let mesh = build(&fixtures::uv_sphere(12, 24, 1.0));
    let opts = SegmentOptions {
        lscm: Lscm2002Options {
            // No curve on a smooth sphere is this long: the sphere has no features.
            min_feature_length: usize::MAX,
            ..Lscm2002Options::default()
        },
        ..SegmentOptions::default()
    };
    let seg = segment_charts(&mesh, &opts).expect("valid options");
    assert_contract(&mesh, &seg);
    assert_eq!(seg.stats.feature_edges, 0);
    assert_eq!(seg.stats.seeds, 2);
    assert_eq!(seg.num_charts(), 2);
    // The two caps are balanced: each holds between a third and two thirds of the area.
    let total = mesh.surface_area_m2();
    let a0: f64 = seg.charts[0].iter().map(|&f| mesh.face_area_m2(f)).sum();
    assert!(
        a0 > total / 3.0 && a0 < 2.0 * total / 3.0,
        "{a0} of {total}"
    );
}

#[test]
fn sphere_with_default_options_gives_disks() {
    let mesh = build(&fixtures::uv_sphere(12, 24, 1.0));
    let seg = segment(&mesh);
    assert_contract(&mesh, &seg);
}

#[test]
fn torus_gives_disk_charts() {
    let mesh = build(&fixtures::torus(24, 12, 2.0, 0.5));
    let seg = segment(&mesh);
    assert_contract(&mesh, &seg);
    // A torus is not a disk: at least two charts (one chart would need a cut, not a split).
    assert!(seg.num_charts() >= 2);
    assert!(seg.stats.disk_splits >= 1 || seg.stats.grown_charts >= 2);
}

#[test]
fn open_cylinder_gives_disk_charts() {
    let mesh = build(&fixtures::cylinder_open(16, 6, 1.0, 3.0));
    let seg = segment(&mesh);
    assert_contract(&mesh, &seg);
    assert!(seg.num_charts() >= 2, "an annulus needs a split");
}

#[test]
fn flat_grid_is_one_chart() {
    let mesh = build(&fixtures::grid(10, 10));
    let seg = segment(&mesh);
    assert_contract(&mesh, &seg);
    assert_eq!(seg.stats.feature_edges, 0);
    assert_eq!(seg.num_charts(), 1, "{:?}", seg.stats);
}

#[test]
fn every_fixture_category_gives_disks() {
    let inputs = [
        fixtures::grid(3, 2),
        fixtures::cube_split_faces(),
        fixtures::uv_sphere(4, 6, 1.0),
        fixtures::torus(6, 4, 2.0, 0.5),
        fixtures::cylinder_open(5, 2, 1.0, 1.0),
        fixtures::two_components(),
        fixtures::bowtie(),
        fixtures::fin(),
        fixtures::flipped_face(),
        fixtures::degenerate(),
    ];
    for (i, input) in inputs.iter().enumerate() {
        let mesh = build(input);
        let seg = segment(&mesh);
        assert_contract(&mesh, &seg);
        // Deterministic: a second run gives the same charts.
        assert_eq!(seg, segment(&mesh), "fixture {i}");
    }
}

#[test]
fn degenerate_faces_are_their_own_or_a_neighbours_chart() {
    let mesh = build(&fixtures::degenerate());
    let seg = segment(&mesh);
    assert_contract(&mesh, &seg);
    // Faces 3 and 4 repeat a vertex: isolated by the build, each is a chart of its own.
    for f in [FaceId(3), FaceId(4)] {
        assert_eq!(seg.chart_faces(seg.face_chart[f]), &[f]);
    }
}

#[test]
fn disk_check_rejects_non_disks() {
    let torus = build(&fixtures::torus(6, 4, 2.0, 0.5));
    let all: Vec<FaceId> = torus.faces().collect();
    assert_eq!(
        check_chart_is_disk(&torus, &all),
        Err(NotADisk::Topology {
            euler_characteristic: 0,
            boundary_loops: 0
        })
    );
    let cyl = build(&fixtures::cylinder_open(5, 2, 1.0, 1.0));
    let all: Vec<FaceId> = cyl.faces().collect();
    assert_eq!(
        check_chart_is_disk(&cyl, &all),
        Err(NotADisk::Topology {
            euler_characteristic: 0,
            boundary_loops: 2
        })
    );
    let sphere = build(&fixtures::uv_sphere(4, 6, 1.0));
    let all: Vec<FaceId> = sphere.faces().collect();
    assert_eq!(
        check_chart_is_disk(&sphere, &all),
        Err(NotADisk::Topology {
            euler_characteristic: 2,
            boundary_loops: 0
        })
    );
    // Grid 2×2: faces 0 and 7 are the two far corners, not adjacent.
    let grid = build(&fixtures::grid(2, 2));
    assert!(matches!(
        check_chart_is_disk(&grid, &[FaceId(0), FaceId(7)]),
        Err(NotADisk::Disconnected {
            reached: 1,
            faces: 2
        })
    ));
    // Faces 1 (lower left, upper triangle) and 6 (upper right, lower triangle) share only the
    // centre vertex... but they are not glued: disconnected. A pinch needs a connected chart:
    // a 3×3 grid ring around the centre square minus one face touches itself at a vertex.
    assert_eq!(check_chart_is_disk(&grid, &[]), Err(NotADisk::Empty));
    assert_eq!(
        check_chart_is_disk(&grid, &[FaceId(0), FaceId(0)]),
        Err(NotADisk::BadFace(FaceId(0)))
    );
    assert_eq!(
        check_chart_is_disk(&grid, &[FaceId(99)]),
        Err(NotADisk::BadFace(FaceId(99)))
    );
    let all: Vec<FaceId> = grid.faces().collect();
    let info = check_chart_is_disk(&grid, &all).expect("a grid is a disk");
    assert_eq!(
        (info.num_faces, info.num_vertices, info.num_edges),
        (8, 9, 16)
    );
    assert_eq!(info.num_boundary_edges, 8);
}

#[test]
fn disk_check_on_grid_subsets() {
    // 3×3 grid; cell (i, j) holds faces 2(3j + i) = [(i,j), (i+1,j), (i+1,j+1)] and
    // 2(3j + i) + 1 = [(i,j), (i+1,j+1), (i,j+1)].
    let grid = build(&fixtures::grid(3, 3));
    let cell = |i: u32, j: u32| [FaceId(2 * (3 * j + i)), FaceId(2 * (3 * j + i) + 1)];
    // Cells (0,0) and (1,1) joined by the lower triangle of cell (0,1), which is glued to both:
    // the only face at vertex (1,1) outside the chart is the upper triangle of cell (1,0), one
    // gap, so one fan, and the chart is a disk.
    let mut faces = Vec::new();
    faces.extend(cell(0, 0));
    faces.extend(cell(1, 1));
    faces.push(cell(0, 1)[0]);
    let info = check_chart_is_disk(&grid, &faces).expect("a disk");
    assert_eq!((info.num_faces, info.num_vertices), (5, 7));
    // The ring of 8 cells around the centre cell is an annulus: χ = 0, two loops.
    let ring: Vec<FaceId> = [
        (0, 0),
        (1, 0),
        (2, 0),
        (2, 1),
        (2, 2),
        (1, 2),
        (0, 2),
        (0, 1),
    ]
    .iter()
    .flat_map(|&(i, j)| cell(i, j))
    .collect();
    assert_eq!(
        check_chart_is_disk(&grid, &ring),
        Err(NotADisk::Topology {
            euler_characteristic: 0,
            boundary_loops: 2
        })
    );
    // Cells (0,0) and (1,1) alone touch at one vertex only: not glued, so disconnected.
    let mut corner = Vec::new();
    corner.extend(cell(0, 0));
    corner.extend(cell(1, 1));
    assert!(matches!(
        check_chart_is_disk(&grid, &corner),
        Err(NotADisk::Disconnected {
            reached: 2,
            faces: 4
        })
    ));
}

/// The merge-back's disk test from two charts' intersection (`validate::union_arc`) gives
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
                    let arc = validate::union_arc(
                        &mesh, &charts[i], &charts[j], &label, i as u32, j as u32,
                    );
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
fn pinched_chart_is_reported_as_pinched() {
    // A fan of 6 triangles around a centre vertex (a hexagon) minus two non-adjacent triangles
    // leaves two runs at the centre, and the hexagon's rim would need the removed faces to
    // connect them... Instead use a hexagonal fan ring of two layers: inner fan of 6 around the
    // centre, outer ring glued to it. Remove inner triangles 0 and 3: the centre has two fans,
    // and the chart is still connected through the outer ring.
    let mut positions = vec![[0.0, 0.0, 0.0]];
    for r in [1.0, 2.0] {
        for k in 0..6 {
            let a = std::f64::consts::PI / 3.0 * f64::from(k);
            positions.push([r * a.cos(), r * a.sin(), 0.0]);
        }
    }
    let inner = |k: u32| 1 + k % 6;
    let outer = |k: u32| 7 + k % 6;
    let mut tris = Vec::new();
    for k in 0..6 {
        tris.push([0, inner(k), inner(k + 1)]);
    }
    for k in 0..6 {
        tris.push([inner(k), outer(k), outer(k + 1)]);
        tris.push([inner(k), outer(k + 1), inner(k + 1)]);
    }
    let mesh = build(&MeshInput::single_group(positions, tris));
    let faces: Vec<FaceId> = mesh.faces().filter(|f| f.0 != 0 && f.0 != 3).collect();
    assert!(matches!(
        check_chart_is_disk(&mesh, &faces),
        Err(NotADisk::Pinched { fans: 2, .. })
    ));
    // segment_charts never returns such a chart; the whole hexagon is one flat chart.
    let seg = segment(&mesh);
    assert_contract(&mesh, &seg);
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

#[test]
fn invalid_options_are_rejected_with_the_option_name() {
    let bad = [
        (
            SegmentOptions {
                max_charts: Some(0),
                ..Default::default()
            },
            "max_charts",
        ),
        (
            SegmentOptions {
                lscm: Lscm2002Options {
                    feature_fraction: 0.0,
                    ..Default::default()
                },
                ..Default::default()
            },
            "lscm.feature_fraction",
        ),
        (
            SegmentOptions {
                lscm: Lscm2002Options {
                    max_string_length: 0,
                    ..Default::default()
                },
                ..Default::default()
            },
            "lscm.max_string_length",
        ),
        (
            SegmentOptions {
                lscm: Lscm2002Options {
                    merge_epsilon_fraction: f64::NAN,
                    ..Default::default()
                },
                ..Default::default()
            },
            "lscm.merge_epsilon_fraction",
        ),
        (
            SegmentOptions {
                lscm: Lscm2002Options {
                    hard_edge_angle_rad: Some(0.0),
                    ..Default::default()
                },
                ..Default::default()
            },
            "lscm.hard_edge_angle_rad",
        ),
    ];
    let mesh = build(&fixtures::grid(1, 1));
    for (o, name) in bad {
        match segment_charts(&mesh, &o) {
            Err(SegmentError::InvalidOption { option, .. }) => assert_eq!(option, name),
            other => panic!("{name}: {other:?}"),
        }
    }
}

#[test]
fn chart_cap_merges_while_disks_remain() {
    let mesh = build(&subdivided_cube(4));
    let free = segment(&mesh);
    assert_eq!(free.num_charts(), 6);
    let capped = segment_charts(
        &mesh,
        &SegmentOptions {
            max_charts: Some(2),
            ..Default::default()
        },
    )
    .expect("valid");
    assert_contract(&mesh, &capped);
    // 6 sides can be merged into 2 disks (e.g. two "U" strips of 3 sides), and each merge keeps a
    // disk, so the cap is reached.
    assert!(capped.num_charts() <= 2, "{}", capped.num_charts());
    assert_eq!(capped.stats.cap_merges, 6 - capped.num_charts());
}

#[test]
fn distance_to_features_is_bounded_by_the_straight_line() {
    // Flat 10×10 grid: no features, sources are the border faces. The face-graph distance of a
    // face is a path through centroids ending at a border-edge midpoint, so it is at least the
    // straight-line distance from its centroid to the square's border, and (a monotone path)
    // at most twice that plus one cell diagonal.
    let mesh = build(&fixtures::grid(10, 10));
    let feats = detect_features(&mesh, &Lscm2002Options::default());
    assert!(feats.threshold_rad.is_none(), "flat: no positive sharpness");
    let d = distance_to_features(&mesh, &feats);
    for f in mesh.faces() {
        let p = mesh.face_positions(f);
        let c = [0, 1].map(|k| (p[0][k] + p[1][k] + p[2][k]) / 3.0);
        let to_border = c[0].min(10.0 - c[0]).min(c[1]).min(10.0 - c[1]);
        let x = d[f.index()];
        assert!(x >= to_border - 1e-12, "{f:?}: {x} < {to_border}");
        assert!(x <= 2.0 * to_border + 2f64.sqrt(), "{f:?}: {x}");
    }
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
        let seg = segment_charts(&mesh, &opts).expect("valid options");
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
    let map = crate::atlas::parameterize::parameterize_chart(&cm, &Default::default())
        .expect("the strip is a disk");
    assert!(
        brute_force_crossing(&cm, &map.uv),
        "test premise: the strip overlaps"
    );
    assert!(validate::boundary_crossing(&cm, &map.uv).is_some());
    let opts = ValidateOptions {
        max_area_ratio: None,
        ..Default::default()
    };
    let v = validate_charts(&mesh, &one, &opts).expect("valid options");
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
    let map = crate::atlas::parameterize::parameterize_chart(&cm, &Default::default())
        .expect("a hemisphere is a disk");
    assert!(area_ratio(&cm, &map.uv) > 2.0, "test premise");
    let v = validate_charts(&mesh, &seg, &ValidateOptions::paper()).expect("valid options");
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

/// The `maps` contract of [`ValidatedCharts`]: every chart has a map, its vertex list is the
/// chart's [`chart_mesh`] vertex list, UVs are finite, every non-degenerate face has a positive
/// UV area and every zero-area face a UV area within rounding of 0 (relative to the chart's UV
/// extent). Returns the number of zero-area faces seen.
fn assert_maps_contract(mesh: &TriangleMesh, v: &ValidatedCharts) -> usize {
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
    let v = validate_charts(&mesh, &seg, &ValidateOptions::default()).expect("valid");
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
        validate_charts(&mesh, &seg, &ValidateOptions::default()).expect("valid")
    );
}

#[test]
fn validation_maps_degenerate_fixture_charts_and_rejects_bad_ratio() {
    let mesh = build(&fixtures::degenerate());
    let seg = segment(&mesh);
    let v = validate_charts(&mesh, &seg, &ValidateOptions::default()).expect("valid");
    assert_contract(&mesh, &v.segmentation);
    // Face 2 is zero-area and glued to face 0; faces 3 and 4 repeat a vertex (isolated, all
    // degenerate: the line map). All of them get maps, none is unresolved.
    assert_eq!(assert_maps_contract(&mesh, &v), 3);
    assert!(v.unresolved.is_empty(), "{:?}", v.unresolved);
    let bad = ValidateOptions {
        max_area_ratio: Some(0.5),
        ..Default::default()
    };
    assert!(matches!(
        validate_charts(&mesh, &seg, &bad),
        Err(SegmentError::InvalidOption {
            option: "max_area_ratio",
            ..
        })
    ));
}

#[test]
fn the_monitor_sees_every_chart_and_can_cancel() {
    let mesh = build(&fixtures::uv_sphere(16, 24, 1.0));
    let seg = segment(&mesh);
    let mut calls: Vec<(usize, usize)> = Vec::new();
    let v = validate_charts_with_monitor(&mesh, &seg, &ValidateOptions::default(), &mut |p| {
        calls.push(p);
        ControlFlow::Continue(())
    })
    .expect("valid");
    assert!(calls.len() >= seg.num_charts(), "{calls:?}");
    assert!(calls.iter().all(|&(d, k)| d <= k), "{calls:?}");
    assert_eq!(
        v,
        validate_charts(&mesh, &seg, &ValidateOptions::default()).expect("valid"),
        "the monitor does not change the result"
    );
    let mut n = 0;
    let r = validate_charts_with_monitor(&mesh, &seg, &ValidateOptions::default(), &mut |_| {
        n += 1;
        if n > 1 {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    assert_eq!(r, Err(SegmentError::Cancelled));
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
    let map = crate::atlas::parameterize::parameterize_chart(&cm, &Default::default())
        .expect("a hemisphere is a disk");
    let bound = ValidateOptions::default()
        .max_stretch
        .expect("a default bound");
    let l2 = chart_stretch(&cm, &map.uv);
    assert!(l2 > bound, "test premise: {l2}");
    let v = validate_charts(&mesh, &seg, &ValidateOptions::default()).expect("valid options");
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
        ValidateOptions {
            max_stretch: Some(0.9),
            ..Default::default()
        },
        ValidateOptions {
            area_ratio_trim: 0.5,
            ..Default::default()
        },
    ] {
        assert!(matches!(
            validate_charts(&mesh, &seg, &bad),
            Err(SegmentError::InvalidOption { .. })
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
    assert_eq!(validate::vertex_fold(&cm, &uv), None);
    let (cm, uv) = fan(5, 80.0, false);
    assert!(crate::atlas::parameterize::flipped_faces(&cm, &uv).is_empty());
    assert_eq!(validate::vertex_fold(&cm, &uv), Some([0, 4]));
    // Closed fans (vertex 0 interior): 8 × 45° is a disk, 8 × 90° wraps twice.
    let (cm, uv) = fan(8, 45.0, true);
    assert_eq!(validate::vertex_fold(&cm, &uv), None);
    let (cm, uv) = fan(8, 90.0, true);
    assert!(crate::atlas::parameterize::flipped_faces(&cm, &uv).is_empty());
    assert!(validate::vertex_fold(&cm, &uv).is_some());
}

#[test]
fn near_collinear_overlapping_segments_count_as_crossing() {
    // Points on y = x / 3 up to rounding: the orientation signs are noise, the segments overlap.
    let (a, b, c, d) = ([0.0, 0.0], [0.9, 0.3], [0.3, 0.1], [1.2, 0.4]);
    assert!(validate::segments_intersect(a, b, c, d));
    assert!(validate::segments_intersect(c, d, a, b));
    // Clearly apart segments still do not.
    assert!(!validate::segments_intersect(a, b, [0.3, 0.2], [1.2, 0.5]));
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
    let bound = ValidateOptions::default()
        .max_stretch
        .expect("a default bound");
    let (cm, _) = chart_mesh(&mesh, &all);
    let map = crate::atlas::parameterize::parameterize_chart(&cm, &Default::default())
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
        let map = crate::atlas::parameterize::parameterize_chart(&cm, &Default::default())
            .expect("a disk flattens");
        let l2 = chart_stretch(&cm, &map.uv);
        assert!(
            l2 <= bound,
            "half of {} faces has L2 {l2} (whole {whole})",
            half.len()
        );
    }
    // The whole validation: the sock leaves as at most two charts, each within the bound.
    let seg = finish(&mesh, vec![all.clone()], SegmentStats::default());
    let v = validate_charts(&mesh, &seg, &ValidateOptions::default()).expect("valid options");
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
    let largest = |v: &ValidatedCharts| v.segmentation.charts.iter().map(Vec::len).max();
    let unbounded = ValidateOptions {
        merge_passes: 8,
        merge_max_chart_fraction: None,
        ..Default::default()
    };
    let free = validate_charts(&mesh, &seg, &unbounded).expect("valid options");
    assert!(
        largest(&free) > Some(MERGE_CAP_FLOOR_FACES),
        "test premise: unbounded merging makes a chart above the floor, {:?}",
        largest(&free)
    );
    for (fraction, limit) in [(0.1, MERGE_CAP_FLOOR_FACES), (0.5, 6_000)] {
        let bounded = ValidateOptions {
            merge_max_chart_fraction: Some(fraction),
            ..unbounded
        };
        let v = validate_charts(&mesh, &seg, &bounded).expect("valid options");
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
        let o = ValidateOptions {
            merge_max_chart_fraction: Some(bad),
            ..Default::default()
        };
        assert!(validate_charts(&mesh, &seg, &o).is_err(), "{bad} accepted");
    }
}
