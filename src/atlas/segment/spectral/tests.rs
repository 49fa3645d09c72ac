//! Tests of the stretch-driven segmentation: the neck split, the contract on the fixtures,
//! determinism, the knee rule.
use super::*;
use crate::atlas::progress::Stage;
use crate::atlas::segment::tests::{assert_contract, build};
use crate::atlas::segment::{segment_charts, segment_charts_with, SegmentMethod, SegmentOptions};
use crate::mesh::{fixtures, MeshInput};

/// A closed surface of revolution about the z axis through the profile polyline `profile`
/// (`(radius, z)` points from the top pole to the bottom pole, radius 0 at both ends), sampled
/// every `step` along the polyline (corners kept), with `segments` around.
fn revolution(profile: &[(f64, f64)], step: f64, segments: u32) -> MeshInput {
    let mut samples: Vec<(f64, f64)> = vec![profile[0]];
    for w in profile.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
        let n = (len / step).ceil().max(1.0) as u32;
        for k in 1..=n {
            let t = f64::from(k) / f64::from(n);
            samples.push((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
        }
    }
    let rings = samples.len() as u32 - 2;
    let mut positions = vec![[0.0, 0.0, samples[0].1]];
    for &(r, z) in &samples[1..samples.len() - 1] {
        for j in 0..segments {
            let phi = 2.0 * std::f64::consts::PI * f64::from(j) / f64::from(segments);
            positions.push([r * phi.cos(), r * phi.sin(), z]);
        }
    }
    positions.push([0.0, 0.0, samples[samples.len() - 1].1]);
    let south = 1 + rings * segments;
    let ring = |i: u32, j: u32| 1 + (i - 1) * segments + (j % segments);
    let mut tris = Vec::new();
    for j in 0..segments {
        tris.push([0, ring(1, j), ring(1, j + 1)]);
    }
    for i in 1..rings {
        for j in 0..segments {
            let (a, b, c, d) = (
                ring(i, j),
                ring(i + 1, j),
                ring(i + 1, j + 1),
                ring(i, j + 1),
            );
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    for j in 0..segments {
        tris.push([ring(rings, j), south, ring(rings, j + 1)]);
    }
    MeshInput::single_group(positions, tris)
}

/// Two unit-radius cylinders ("boxes" of revolution), z in [0, 2] and [3, 5], joined by a neck
/// of radius 0.2 for z in [2, 3].
fn dumbbell() -> MeshInput {
    revolution(
        &[
            (0.0, 5.0),
            (1.0, 5.0),
            (1.0, 3.0),
            (0.2, 3.0),
            (0.2, 2.0),
            (1.0, 2.0),
            (1.0, 0.0),
            (0.0, 0.0),
        ],
        0.25,
        16,
    )
}

fn stretch_options() -> SegmentOptions {
    SegmentOptions {
        method: SegmentMethod::Stretch,
        ..SegmentOptions::default()
    }
}

fn centroid_z(mesh: &TriangleMesh, f: FaceId) -> f64 {
    mesh.face_vertices(f)
        .iter()
        .map(|&v| mesh.position(v)[2])
        .sum::<f64>()
        / 3.0
}

#[test]
fn the_spectral_split_of_two_boxes_joined_by_a_neck_separates_at_the_neck() {
    let mesh = build(&dumbbell());
    let faces: Vec<FaceId> = mesh.faces().collect();
    let graph = ChartGraph::new(&mesh, &faces);
    let (landmarks, dists) = farthest_point_landmarks(&graph, 25);
    // The binary split (every split after a component's first): the extremes of the leading
    // coordinate are the two ends, and the border lies in the neck.
    let e = Embedding::new(&graph, &landmarks, &dists, 1).expect("an embedding");
    let (parts, general) = e.cluster(&mesh, &faces, &graph, 1).expect("a split");
    assert!(!general);
    assert_eq!(parts.len(), 2);
    let upper = |p: &[FaceId]| p.iter().all(|&f| centroid_z(&mesh, f) > 2.0);
    let lower = |p: &[FaceId]| p.iter().all(|&f| centroid_z(&mesh, f) < 3.0);
    assert!(
        (upper(&parts[0]) && lower(&parts[1])) || (lower(&parts[0]) && upper(&parts[1])),
        "the border leaves the neck"
    );
    // The first split of the component (general clustering when the three leading eigenvalues
    // hold less than 90 % of the energy, as here with graph distances): no part spans the neck.
    let e0 = Embedding::new(&graph, &landmarks, &dists, 0).expect("an embedding");
    let (parts0, _) = e0.cluster(&mesh, &faces, &graph, 0).expect("a split");
    assert!(parts0.len() >= 2);
    for p in &parts0 {
        assert!(upper(p) || lower(p), "a part spans the neck");
    }
    for p in &parts {
        check_chart_is_disk(&mesh, p).expect("each half of a sphere-like surface is a disk");
    }
}

#[test]
fn stretch_segmentation_never_puts_both_boxes_in_one_chart() {
    let mesh = build(&dumbbell());
    let seg = segment_charts(
        &mesh,
        &stretch_options(),
        &mut StageProgress::ignored(Stage::Segment),
    )
    .expect("valid options");
    assert_contract(&mesh, &seg);
    assert!(seg.stats.spectral_splits >= 1);
    for c in &seg.charts {
        let zs: Vec<f64> = c.iter().map(|&f| centroid_z(&mesh, f)).collect();
        let both = zs.iter().any(|&z| z < 2.0) && zs.iter().any(|&z| z > 3.0);
        assert!(!both, "a chart spans both boxes");
    }
}

use crate::atlas::segment::check_chart_is_disk;

#[test]
fn every_chart_is_a_disk_and_the_bound_holds_with_a_measure() {
    let inputs = [
        fixtures::grid(3, 2),
        fixtures::cube_split_faces(),
        fixtures::uv_sphere(8, 12, 1.0),
        fixtures::torus(12, 8, 2.0, 0.5),
        fixtures::cylinder_open(10, 6, 1.0, 1.0),
        fixtures::two_components(),
        fixtures::bowtie(),
        fixtures::fin(),
        fixtures::flipped_face(),
        fixtures::degenerate(),
        dumbbell(),
    ];
    for (i, input) in inputs.iter().enumerate() {
        let mesh = build(input);
        // Without a measure (the embedding's estimate).
        let seg = segment_charts(
            &mesh,
            &stretch_options(),
            &mut StageProgress::ignored(Stage::Segment),
        )
        .expect("valid options");
        assert_contract(&mesh, &seg);
        // With a measure: a chart "stretches" by its face count; every chart of at least
        // `min_split_faces` faces must end within the bound (at most 40 faces).
        let options = stretch_options();
        let measure = |faces: &[FaceId]| Some(faces.len() as f64 / 40.0);
        let seg = segment_charts_with(
            &mesh,
            &options,
            Some(&measure),
            &mut StageProgress::ignored(Stage::Segment),
        )
        .expect("valid options");
        assert_contract(&mesh, &seg);
        for c in &seg.charts {
            assert!(
                c.len() as f64 / 40.0 <= options.stretch.max_stretch
                    || c.len() < options.stretch.min_split_faces,
                "fixture {i}: a chart of {} faces",
                c.len()
            );
        }
    }
}

#[test]
fn stretch_segmentation_is_deterministic_for_any_thread_count() {
    let mesh = build(&dumbbell());
    let sphere = build(&fixtures::uv_sphere(16, 24, 1.0));
    let run = |mesh: &TriangleMesh| {
        segment_charts(
            mesh,
            &stretch_options(),
            &mut StageProgress::ignored(Stage::Segment),
        )
        .expect("valid options")
    };
    for m in [&mesh, &sphere] {
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| run(m));
        let four = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap()
            .install(|| run(m));
        assert_eq!(one, four);
        assert_eq!(one, run(m));
    }
}

#[test]
fn the_knee_is_the_largest_drop_from_the_third_eigenvalue_on() {
    // λ: 100, 50, 40, 30, 3, 2, 1 → ratios from n = 3: 40/30, 30/3 (n = 4), 3/2, 2/1.
    let l = [100.0, 50.0, 40.0, 30.0, 3.0, 2.0, 1.0];
    assert_eq!(knee(&l, 7), 4);
    assert_eq!(knee(&l, 3), 3);
    assert_eq!(knee(&l, 2), 2);
}

#[test]
fn invalid_stretch_options_are_refused() {
    let mut o = stretch_options();
    o.stretch.max_stretch = 0.9;
    assert!(o.check().is_err());
    let mut o = stretch_options();
    o.stretch.landmarks = 2;
    assert!(o.check().is_err());
    let mut o = stretch_options();
    o.stretch.min_split_faces = 1;
    assert!(o.check().is_err());
}
