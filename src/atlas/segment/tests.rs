//! Tests of the segmentation stage: the disk contract on every fixture category, the paper's
//! expected chart layouts (cube, sphere, torus), features and distances recomputed independently.

use std::ops::ControlFlow;

use super::*;
use crate::atlas::progress::{ProgressFn, Stage, StageProgress};
use crate::mesh::{fixtures, MeshInput};

pub(crate) fn build(input: &MeshInput) -> TriangleMesh {
    TriangleMesh::build(input).expect("fixture builds").mesh
}

/// A cube `[0, n]³` whose sides are `n × n` grids (welded by bit-identical integer positions),
/// outward, `12 n²` faces. Side `s` holds faces `2n²·s .. 2n²·(s+1)`.
pub(crate) fn subdivided_cube(n: u32) -> MeshInput {
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
/// [`check_chart_is_disk`]. (The parameterize stage's tests check, independently, that every
/// chart also passes the parameterizer's own chart validation.)
pub(crate) fn assert_contract(mesh: &TriangleMesh, seg: &Segmentation) {
    let mut count = vec![0u32; mesh.num_faces()];
    for (i, c) in seg.charts.iter().enumerate() {
        assert!(!c.is_empty());
        for &f in c {
            count[f.index()] += 1;
            assert_eq!(seg.face_chart[f], ChartId(i as u32));
        }
        check_chart_is_disk(mesh, c).unwrap_or_else(|e| panic!("chart {i}: {e}"));
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

pub(crate) fn segment(mesh: &TriangleMesh) -> Segmentation {
    segment_charts(
        mesh,
        &SegmentOptions::default(),
        &mut StageProgress::ignored(Stage::Segment),
    )
    .expect("default options are valid")
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
    let feats = detect_features(
        &mesh,
        &Lscm2002Options::default(),
        &mut StageProgress::ignored(Stage::Segment),
    )
    .expect("never cancelled");
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
    let seg = segment_charts(&mesh, &opts, &mut StageProgress::ignored(Stage::Segment))
        .expect("valid options");
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
    let seg = segment_charts(&mesh, &opts, &mut StageProgress::ignored(Stage::Segment))
        .expect("valid options");
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
                border_band_fraction: Some(1.0),
                ..Default::default()
            },
            "border_band_fraction",
        ),
        (
            SegmentOptions {
                border_band_fraction: Some(f64::NAN),
                ..Default::default()
            },
            "border_band_fraction",
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
        match segment_charts(&mesh, &o, &mut StageProgress::ignored(Stage::Segment)) {
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
        &mut StageProgress::ignored(Stage::Segment),
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
    let feats = detect_features(
        &mesh,
        &Lscm2002Options::default(),
        &mut StageProgress::ignored(Stage::Segment),
    )
    .expect("never cancelled");
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

/// Segmentation reports real progress: on a mid-size mesh (19,200 faces), many checkpoints,
/// `done` never decreasing and never above `total`, one `total` throughout, ending at
/// `total`; reporting does not change the charts.
#[test]
fn segmentation_reports_monotone_progress() {
    let mesh = build(&subdivided_cube(40));
    let options = SegmentOptions {
        max_charts: Some(3),
        ..SegmentOptions::default()
    };
    let mut calls: Vec<(Stage, usize, usize)> = Vec::new();
    let mut record = ProgressFn(|stage, done, total| {
        calls.push((stage, done, total));
        ControlFlow::Continue(())
    });
    let seg = segment_charts(
        &mesh,
        &options,
        &mut StageProgress::new(Stage::Segment, &mut record),
    )
    .expect("valid options");
    assert!(calls.len() >= 10, "{calls:?}");
    let total = calls[0].2;
    assert_eq!(total, 4 * mesh.num_faces());
    assert_eq!(calls[0].1, 0);
    assert_eq!(calls.last(), Some(&(Stage::Segment, total, total)));
    for w in calls.windows(2) {
        assert!(w[0].1 <= w[1].1, "done went back: {calls:?}");
    }
    assert!(
        calls
            .iter()
            .all(|&(s, d, t)| s == Stage::Segment && t == total && d <= t),
        "{calls:?}"
    );
    // Checkpoints inside the phases, not only at their ends: several while growing (every
    // 4096 faces), one per batch of grown charts in the disk guarantee (this mesh grows 2).
    let in_phase = |k: usize| {
        let (lo, hi) = (k * mesh.num_faces(), (k + 1) * mesh.num_faces());
        let mut v: Vec<usize> = calls
            .iter()
            .map(|c| c.1)
            .filter(|&d| d > lo && d < hi)
            .collect();
        v.dedup();
        v.len()
    };
    assert!(in_phase(1) >= 2, "growing: {calls:?}");
    assert!(in_phase(2) >= 1, "disk guarantee: {calls:?}");
    assert_eq!(
        seg,
        segment_charts(&mesh, &options, &mut StageProgress::ignored(Stage::Segment))
            .expect("valid options"),
        "progress does not change the result"
    );
}

/// `Break` at any checkpoint of segmentation cancels it, and `generate` reports the
/// cancellation as the segment stage's.
#[test]
fn cancelling_during_segmentation_stops_it() {
    let mesh = build(&subdivided_cube(40));
    let options = SegmentOptions::default();
    let mut count = 0usize;
    let mut counter = ProgressFn(|_, _, _| {
        count += 1;
        ControlFlow::Continue(())
    });
    segment_charts(
        &mesh,
        &options,
        &mut StageProgress::new(Stage::Segment, &mut counter),
    )
    .expect("valid options");
    assert!(count >= 10, "{count} checkpoints");
    for stop in [1, count / 2, count] {
        let mut calls = 0usize;
        let mut cancel = ProgressFn(|_, _, _| {
            calls += 1;
            if calls >= stop {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        });
        let r = segment_charts(
            &mesh,
            &options,
            &mut StageProgress::new(Stage::Segment, &mut cancel),
        );
        assert_eq!(r, Err(SegmentError::Cancelled), "stop at call {stop}");
        assert_eq!(calls, stop, "no call after Break");
    }
    // Through the pipeline: a break in the middle of segmentation is Cancelled { Segment }.
    let mut seen = 0usize;
    let mut cancel = ProgressFn(|stage, _, _| {
        assert_eq!(stage, Stage::Segment, "no later stage runs");
        seen += 1;
        if seen >= count / 2 {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    let r = crate::atlas::generate(&mesh, &crate::atlas::AtlasOptions::default(), &mut cancel);
    assert_eq!(
        r.err(),
        Some(crate::atlas::AtlasError::Cancelled {
            stage: Stage::Segment
        })
    );
}

#[test]
fn hard_edges_are_found_when_the_feature_threshold_is_zero() {
    // A 10 × 4 grid folded by 90° along x = 5: 4 crease edges among ~106 interior edges, so
    // the sharpest 5 % (6 edges) reach the flat ones and τ = 0. Algorithm 1 has nothing to
    // grow, but the crease is a chain of 4 right-angle edges: hard edges all the same.
    let mut input = fixtures::grid(10, 4);
    for p in &mut input.positions_m {
        if p[0] > 5.0 {
            *p = [5.0, p[1], p[0] - 5.0];
        }
    }
    let mesh = build(&input);
    let feats = detect_features(
        &mesh,
        &Lscm2002Options::default(),
        &mut StageProgress::ignored(Stage::Segment),
    )
    .expect("never cancelled");
    assert_eq!(feats.threshold_rad, None, "τ = 0: no curve threshold");
    let crease: Vec<HalfedgeId> = mesh
        .edges()
        .filter(|&h| mesh.dihedral_angle_rad(h).is_some_and(|a| a > 1.0))
        .collect();
    assert_eq!(crease.len(), 4);
    assert_eq!(feats.hard_edges, crease, "every crease edge is hard");
    assert!(crease.iter().all(|&h| feats.is_hard_edge(h)));
}
