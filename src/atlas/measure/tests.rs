//! Hand-computed cases for `measure_atlas`: each states its input and the exact expected values.
use super::numpy::{np_sum, percentile_linear, percentile_weighted, stable_order};
use super::*;
use crate::mesh::MeshInput;

/// A mesh from positions and triangles (one glTF mesh), with per-face corner UVs, on page 0.
struct Case {
    mesh: TriangleMesh,
    uvs: Vec<[[f32; 2]; 3]>,
    pages: Vec<u32>,
}

fn case(positions: &[[f64; 3]], tris: &[[u32; 3]], uvs: &[[[f32; 2]; 3]]) -> Case {
    let input = MeshInput::single_group(positions.to_vec(), tris.to_vec());
    let mesh = TriangleMesh::build(&input).expect("valid mesh").mesh;
    Case {
        mesh,
        uvs: uvs.to_vec(),
        pages: vec![0; uvs.len()],
    }
}

fn measure(c: &Case, size: [u32; 2], padding: u32, num_pages: u32) -> AtlasReport {
    measure_atlas(&MeasureInput {
        mesh: &c.mesh,
        corner_uvs: &c.uvs,
        face_page: &c.pages,
        num_pages,
        width_texels: size[0],
        height_texels: size[1],
        padding_texels: padding,
    })
}

fn close(a: Option<f64>, b: f64) -> bool {
    a.is_some_and(|a| (a - b).abs() <= 1e-12 * b.abs().max(1.0))
}

const SQUARE: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
];
const SQUARE_TRIS: [[u32; 3]; 2] = [[0, 1, 2], [0, 2, 3]];

/// Two unit squares 5 apart in x (two charts in 3-D), two faces each: positions and triangles.
fn two_squares() -> (Vec<[f64; 3]>, [[u32; 3]; 4]) {
    let mut pos = SQUARE.to_vec();
    pos.extend(SQUARE.iter().map(|p| [p[0] + 5.0, p[1], p[2]]));
    (pos, [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
}

/// UVs of the square's two faces under `(x, y) ↦ (ox + sx·x, oy + sy·y)`.
fn square_uvs(o: [f32; 2], s: [f32; 2]) -> Vec<[[f32; 2]; 3]> {
    let uv = |i: usize| {
        let p = SQUARE[i];
        [o[0] + s[0] * p[0] as f32, o[1] + s[1] * p[1] as f32]
    };
    SQUARE_TRIS
        .iter()
        .map(|t| t.map(|v| uv(v as usize)))
        .collect()
}

#[test]
fn isometric_right_triangle_has_unit_stretch() {
    // A right triangle with legs 1 m mapped to legs 0.5: a similarity, so after the global
    // normalisation (k = 0.125 / 0.5 = 0.25) the map is an isometry.
    let c = case(
        &SQUARE[..3],
        &[[0, 1, 2]],
        &[[[0.0, 0.0], [0.5, 0.0], [0.5, 0.5]]],
    );
    let r = measure(&c, [64, 64], 0, 1);
    assert!(close(r.stretch.l2, 1.0), "{:?}", r.stretch);
    assert!(close(r.stretch.linf, 1.0));
    assert!(close(r.stretch.linf_sander, 1.0));
    assert!(close(r.stretch.uv_area_over_3d_area, 0.25));
    assert!(!r.stretch.strict_infinite);
    let a = r.angle_distortion.expect("used faces");
    assert!(close(a.conformal_ratio_mean, 1.0));
    assert!(close(a.angle_deviation_deg_mean.map(|d| d + 1.0), 1.0));
    let ar = r.area_distortion.expect("used faces");
    assert!(close(ar.p50, 1.0) && close(ar.p5_aw, 1.0));
    assert_eq!((r.charts, r.flipped, r.degenerate), (1, 0, 0));
    assert!(close(Some(r.packing_efficiency), 0.125));
    assert!(close(Some(r.area_3d_m2), 0.5));
    assert_eq!(r.per_chart.len(), 1);
    assert!(close(r.per_chart[0].l2, 1.0) && close(r.per_chart[0].linf, 1.0));
    assert!(close(r.per_chart[0].texel_density, 0.5));
    let d = r.texel_density.expect("density");
    assert!(close(d.texels_per_unit, 0.5 * 64.0));
    assert!(close(d.max_over_min, 1.0) && close(d.cv, 0.0));
}

#[test]
fn anisotropic_scale_has_the_analytic_stretch() {
    // u = 0.5 x, v = 0.125 y: k = 1/16; dq/ds = 2, dq/dt = 8, normalised a = 0.25, c = 4,
    // so Γ = 2, γ = 0.5: L2 = sqrt((a + c)/2) = sqrt(2.125), L∞ = max(Γ, 1/γ) = 2,
    // conformal ratio 4, angle deviation 0, area ratio 1 everywhere.
    let c = case(&SQUARE, &SQUARE_TRIS, &square_uvs([0.0, 0.0], [0.5, 0.125]));
    let r = measure(&c, [64, 64], 0, 1);
    assert!(close(r.stretch.uv_area_over_3d_area, 0.0625));
    assert!(close(r.stretch.l2, 2.125f64.sqrt()), "{:?}", r.stretch);
    assert!(close(r.stretch.linf, 2.0));
    assert!(close(r.stretch.linf_sander, 2.0));
    let a = r.angle_distortion.expect("used faces");
    assert!(close(a.conformal_ratio_p95, 4.0) && close(a.conformal_ratio_mean_aw, 4.0));
    assert!(a.angle_deviation_deg_p95.is_some_and(|d| d.abs() < 1e-9));
    let ar = r.area_distortion.expect("used faces");
    assert!(close(ar.p5, 1.0) && close(ar.p95_aw, 1.0));
    assert_eq!(r.charts, 1);
    // Two faces sharing the diagonal never overlap, exactly or sampled.
    assert_eq!(r.overlap.exact.pairs, 0);
    assert_eq!(r.overlap.sampled.overlapping_texels, 0);
}

#[test]
fn two_stacked_charts_overlap() {
    // Two separate squares (different positions → two charts) on the same UVs.
    let (pos, tris) = two_squares();
    let mut uvs = square_uvs([0.25, 0.25], [0.5, 0.5]);
    uvs.extend(square_uvs([0.25, 0.25], [0.5, 0.5]));
    let c = case(&pos, &tris, &uvs);
    let r = measure(&c, [32, 32], 0, 1);
    assert_eq!(r.charts, 2);
    // Each face of one square meets both faces of the other... except the pair of opposite
    // halves, which only share the diagonal: (0,2), (1,3) overlap fully; (0,3), (1,2) touch
    // along the diagonal only. So 2 exact pairs, cross-chart.
    assert_eq!(r.overlap.exact.pairs, 2, "{:?}", r.overlap.exact);
    assert_eq!(r.overlap.exact.pairs_cross_chart, 2);
    assert_eq!(
        r.overlap.exact.examples,
        vec![[FaceId(0), FaceId(2)], [FaceId(1), FaceId(3)]]
    );
    // Sampled: 16 × 16 texels covered twice, the same two pairs.
    assert_eq!(r.overlap.sampled.covered_texels, 256);
    assert_eq!(r.overlap.sampled.overlapping_texels, 256);
    assert_eq!(r.overlap.sampled.texels_cross_chart, 256);
    assert_eq!(r.overlap.sampled.pairs, 2);
    assert_eq!(r.packing_efficiency, 0.5);
    // On two pages they do not overlap.
    let mut c2 = c;
    c2.pages = vec![0, 0, 1, 1];
    let r2 = measure(&c2, [32, 32], 0, 2);
    assert_eq!((r2.overlap.exact.pairs, r2.overlap.sampled.pairs), (0, 0));
    assert_eq!(r2.pages.len(), 2);
    assert_eq!((r2.pages[1].faces, r2.pages[1].charts), (2, 1));
    assert_eq!(r2.pages[1].covered_texels, 256);
    assert_eq!(r2.texel_utilization, 512.0 / 2048.0);
    assert_eq!(r2.packing_efficiency, 0.25);
}

#[test]
fn folded_triangle_is_flipped_and_overlaps_its_neighbour() {
    // Face 1 = (v0, v2, v3) with v3's UV moved across the shared diagonal: still glued to
    // face 0 (same chart) but clockwise, inside face 0.
    let uv = [[0.1, 0.1], [0.9, 0.1], [0.9, 0.9], [0.6, 0.4]];
    let uvs: Vec<[[f32; 2]; 3]> = SQUARE_TRIS
        .iter()
        .map(|t| t.map(|v| uv[v as usize]))
        .collect();
    let c = case(&SQUARE, &SQUARE_TRIS, &uvs);
    let r = measure(&c, [64, 64], 0, 1);
    assert_eq!(r.charts, 1);
    assert_eq!(r.flipped, 1);
    assert_eq!(r.charts_minority_orientation, 0);
    assert_eq!(r.overlap.exact.pairs, 1);
    assert_eq!(r.overlap.exact.pairs_same_chart, 1);
    assert!(r.overlap.sampled.texels_same_chart > 0);
    // The same two faces mapped with both orientations consistent: no flip, no overlap.
    let c = case(&SQUARE, &SQUARE_TRIS, &square_uvs([0.1, 0.1], [0.8, 0.8]));
    let r = measure(&c, [64, 64], 0, 1);
    assert_eq!((r.flipped, r.overlap.exact.pairs), (0, 0));
}

#[test]
fn mirrored_chart_is_minority_not_flipped() {
    let (pos, tris) = two_squares();
    let mut uvs = square_uvs([0.0, 0.0], [0.4, 0.4]);
    // Second square mirrored in u (smaller, so it is the minority).
    uvs.extend(square_uvs([0.9, 0.5], [-0.3, 0.3]));
    let r = measure(&case(&pos, &tris, &uvs), [64, 64], 0, 1);
    assert_eq!(
        (r.charts, r.flipped, r.charts_minority_orientation),
        (2, 0, 1)
    );
    assert!(r.per_chart[1].signed_uv_area < 0.0 && r.per_chart[0].signed_uv_area > 0.0);
}

#[test]
fn padding_violation_at_exactly_padding_but_not_one_more() {
    // Chart A covers texel columns 0..=3 and rows 0..=3 of a 16² page; chart B the same rows
    // and columns 3+d..=6+d. The Chebyshev distance between them is d.
    let p = 2;
    for (d, expected) in [(p, 8), (p + 1, 0)] {
        let mut pos = SQUARE.to_vec();
        pos.extend(SQUARE.iter().map(|q| [q[0] + 5.0, q[1], q[2]]));
        let tris = [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]];
        let t = 1.0 / 16.0;
        let mut uvs = square_uvs([0.0, 0.0], [4.0 * t, 4.0 * t]);
        uvs.extend(square_uvs([(3 + d) as f32 * t, 0.0], [4.0 * t, 4.0 * t]));
        let r = measure(&case(&pos, &tris, &uvs), [16, 16], p, 1);
        assert_eq!(r.overlap.sampled.covered_texels, 32);
        assert_eq!(r.padding.violation_texels, expected, "distance {d}");
        // Padding 0 disables the check.
        let r0 = measure(&case(&pos, &tris, &uvs), [16, 16], 0, 1);
        assert_eq!(r0.padding.violation_texels, 0);
    }
}

#[test]
fn out_of_range_corners_use_the_evaluator_tolerance() {
    let uvs = [[[-0.01, 0.5], [0.5, 0.5], [0.5, 1.0 + 1e-7]]];
    let r = measure(&case(&SQUARE[..3], &[[0, 1, 2]], &uvs), [16, 16], 0, 1);
    assert_eq!((r.out_of_range_corners, r.out_of_range_triangles), (1, 1));
    let bbox = r.uv_bbox.expect("finite");
    assert_eq!(bbox[0], f64::from(-0.01f32));
    assert_eq!(bbox[3], f64::from(1.0f32 + 1e-7));
}

#[test]
fn seam_on_the_diagonal_makes_two_charts() {
    // Face 1 shifted right by 0.5 in UV: the diagonal is a seam, the 4 sides open borders.
    let mut uvs = square_uvs([0.0, 0.0], [0.4, 0.4]);
    uvs[1] = uvs[1].map(|c| [c[0] + 0.5, c[1]]);
    let r = measure(&case(&SQUARE, &SQUARE_TRIS, &uvs), [32, 32], 0, 1);
    assert_eq!((r.charts, r.seam_edges), (2, 1));
    assert!(close(Some(r.seam_length_3d_m), 2f64.sqrt()));
    assert!(close(Some(r.open_border_length_3d_m), 4.0));
    assert!(close(r.boundary_edge_ratio, 4.0 + 2.0 * 2f64.sqrt()));
    assert!(close(r.seam_edge_ratio, 2f64.sqrt()));
    assert_eq!(r.unique_corners, 6);
    assert_eq!(r.per_chart.iter().map(|c| c.faces).sum::<usize>(), 2);
}

#[test]
fn uv_degenerate_face_with_area_is_strictly_infinite() {
    let uvs = [
        [[0.1, 0.1], [0.5, 0.1], [0.5, 0.5]],
        [[0.1, 0.1], [0.5, 0.5], [0.3, 0.3]], // collinear
    ];
    let r = measure(&case(&SQUARE, &SQUARE_TRIS, &uvs), [16, 16], 0, 1);
    assert_eq!((r.degenerate, r.degenerate_uv_with_3d_area), (1, 1));
    assert!(r.stretch.strict_infinite);
    assert_eq!(r.stretch.triangles_used, 1);
    assert!(close(r.stretch.linf, 1.0));
    // A zero-area face has no interior: it overlaps nothing.
    assert_eq!(r.overlap.exact.pairs, 0);
}

#[test]
fn shared_edge_samples_are_covered_once_and_pages_can_be_rectangular() {
    // The unit square filling an 8 × 4 page: texel centres on the diagonal belong to one face.
    let r = measure(
        &case(&SQUARE, &SQUARE_TRIS, &square_uvs([0.0, 0.0], [1.0, 1.0])),
        [8, 4],
        1,
        1,
    );
    assert_eq!(r.overlap.sampled.covered_texels, 32);
    assert_eq!(r.overlap.sampled.overlapping_texels, 0);
    assert_eq!(r.texel_utilization, 1.0);
    assert_eq!(r.padding.violation_texels, 0);
    assert!(close(
        r.texel_density.and_then(|d| d.texels_per_unit),
        32f64.sqrt()
    ));
}

#[test]
fn exact_overlap_is_exact_on_touching_and_barely_crossing_faces() {
    let a: [[f32; 2]; 3] = [[0.0, 0.0], [0.5, 0.0], [0.0, 0.5]];
    // Sharing the hypotenuse from the other side: touching, no overlap.
    let b: [[f32; 2]; 3] = [[0.5, 0.0], [0.5, 0.5], [0.0, 0.5]];
    assert!(!overlap::interiors_intersect(
        &overlap::ccw_triangle(&a).unwrap(),
        &overlap::ccw_triangle(&b).unwrap()
    ));
    // The same face pushed one f32 ulp across the hypotenuse: overlapping.
    let e = f32::EPSILON / 4.0;
    let c: [[f32; 2]; 3] = [[0.5 - e, 0.0], [0.5, 0.5], [0.0, 0.5 - e]];
    assert!(overlap::interiors_intersect(
        &overlap::ccw_triangle(&a).unwrap(),
        &overlap::ccw_triangle(&c).unwrap()
    ));
    // Only a shared vertex: no overlap.
    let d: [[f32; 2]; 3] = [[0.5, 0.0], [1.0, 0.0], [0.75, 0.5]];
    assert!(!overlap::interiors_intersect(
        &overlap::ccw_triangle(&a).unwrap(),
        &overlap::ccw_triangle(&d).unwrap()
    ));
    // The shared-edge shortcut agrees with the full test on all of these, both ways round,
    // and on faces folded over a shared edge (same side) or sharing all three corners.
    let folded: [[f32; 2]; 3] = [[0.5, 0.0], [0.0, 0.5], [0.1, 0.1]];
    let shuffled: [[f32; 2]; 3] = [a[1], a[2], a[0]];
    for (x, y) in [
        (a, b),
        (a, c),
        (a, d),
        (a, folded),
        (a, shuffled),
        (b, folded),
    ] {
        let (x, y) = (
            overlap::ccw_triangle(&x).unwrap(),
            overlap::ccw_triangle(&y).unwrap(),
        );
        let full = overlap::interiors_intersect(&x, &y);
        assert_eq!(overlap::interiors_intersect_pair(&x, &y), full);
        assert_eq!(overlap::interiors_intersect_pair(&y, &x), full);
    }
    assert!(overlap::interiors_intersect_pair(
        &overlap::ccw_triangle(&a).unwrap(),
        &overlap::ccw_triangle(&folded).unwrap()
    ));
    // Zero area: no interior.
    assert!(overlap::ccw_triangle(&[[0.0, 0.0], [0.25, 0.25], [0.5, 0.5]]).is_none());
}

#[test]
fn percentiles_follow_numpy() {
    // numpy.percentile([1, 2, 3, 4], 95) == 3.85; ([1, 2, 3, 4], 5) == 1.15; median 2.5.
    let x = [4.0, 1.0, 3.0, 2.0];
    let o = stable_order(&x);
    let sorted: Vec<f64> = o.iter().map(|&i| x[i as usize]).collect();
    assert!(close(percentile_linear(&sorted, 95.0), 3.85));
    assert!(close(percentile_linear(&sorted, 5.0), 1.15));
    assert!(close(percentile_linear(&sorted, 50.0), 2.5));
    // Weighted (inverted CDF): weights 1, 1, 2 on 1, 2, 3: CDF 1, 2, 4; q50 → 2 reached at x=2.
    let (x, w) = ([3.0, 1.0, 2.0], [2.0, 1.0, 1.0]);
    let o = stable_order(&x);
    assert_eq!(percentile_weighted(&x, &w, &o, 50.0), Some(2.0));
    assert_eq!(percentile_weighted(&x, &w, &o, 51.0), Some(3.0));
    assert_eq!(percentile_weighted(&x, &w, &o, 5.0), Some(1.0));
}

#[test]
fn stable_order_is_the_stable_total_order_permutation() {
    // Long enough for the radix path: ties, signed zeros, infinities and NaN included.
    let specials = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
        -f64::NAN,
        1e-300,
        -1e300,
        f64::MIN_POSITIVE,
        5e-324,
    ];
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let x: Vec<f64> = (0..5000)
        .map(|i| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            match i % 4 {
                0 => specials[(state >> 33) as usize % specials.len()],
                1 => ((state >> 40) % 7) as f64,
                _ => f64::from_bits(state) * 1e-3,
            }
        })
        .collect();
    let mut expected: Vec<u32> = (0..x.len() as u32).collect();
    expected.sort_by(|&a, &b| x[a as usize].total_cmp(&x[b as usize]));
    assert_eq!(stable_order(&x), expected);
    assert_eq!(stable_order(&x[..100]), {
        let mut e: Vec<u32> = (0..100).collect();
        e.sort_by(|&a, &b| x[a as usize].total_cmp(&x[b as usize]));
        e
    });
}

#[test]
fn pairwise_sum_matches_numpy() {
    // numpy 2.x: np.sum(np.full(1000, 0.1)) == 100.00000000000001; a sequential sum gives
    // 99.9999999999986.
    let x = vec![0.1f64; 1000];
    assert_eq!(np_sum(&x), 100.000_000_000_000_01);
    assert_eq!(x.iter().fold(0.0, |s, &v| s + v), 99.999_999_999_998_6);
    assert_eq!(np_sum(&[1.0, 2.0, 3.0]), 6.0);
    assert_eq!(np_sum(&[]), 0.0);
}

#[test]
fn packing_bound_adds_half_the_padding_around_each_chart() {
    // Two unit squares (separate charts) on a 32 × 16 texel page, each 4 × 4 texels: UV
    // 4/32 wide and 4/16 high. With padding 2 (r = 1 texel) each padded square is
    // 16 + 16·1 + π texels² (area, perimeter × r, the four quarter discs at the corners):
    // bound = 2 (32 + π) / 512; efficiency = 32 / 512.
    let mut pos = SQUARE.to_vec();
    pos.extend(SQUARE.iter().map(|p| [p[0] + 2.0, p[1], p[2]]));
    let tris: Vec<[u32; 3]> = SQUARE_TRIS
        .iter()
        .copied()
        .chain(SQUARE_TRIS.iter().map(|t| t.map(|v| v + 4)))
        .collect();
    let s = [4.0 / 32.0, 4.0 / 16.0];
    let mut uvs = square_uvs([2.0 / 32.0, 2.0 / 16.0], s);
    uvs.extend(square_uvs([20.0 / 32.0, 8.0 / 16.0], s));
    let c = case(&pos, &tris, &uvs);
    let r = measure(&c, [32, 16], 2, 1);
    assert_eq!(r.charts, 2);
    assert_eq!(r.packing_efficiency, 32.0 / 512.0);
    let want = 2.0 * (32.0 + std::f64::consts::PI) / 512.0;
    assert!(
        close(Some(r.packing_bound), want),
        "{} vs {want}",
        r.packing_bound
    );
    // Padding 0: the bound is the efficiency. Padding 4 (r = 2): 16 + 16·2 + 4π per square.
    assert_eq!(measure(&c, [32, 16], 0, 1).packing_bound, 32.0 / 512.0);
    let want4 = 2.0 * (48.0 + 4.0 * std::f64::consts::PI) / 512.0;
    assert!(close(
        Some(measure(&c, [32, 16], 4, 1).packing_bound),
        want4
    ));
    // On two pages the page area doubles.
    let mut c2 = c;
    c2.pages = vec![0, 0, 1, 1];
    assert!(close(
        Some(measure(&c2, [32, 16], 2, 2).packing_bound),
        want / 2.0
    ));
}

#[test]
fn packing_bound_counts_the_boundary_of_a_hole() {
    // A 3 × 3 grid of unit cells without its centre cell: one chart, a square ring. On a
    // 16 × 16 page at 1 texel per unit: area 8 texels², boundary 12 (outside) + 4 (hole)
    // texels; padding 2 (r = 1): 8 + 16 + π.
    let pos: Vec<[f64; 3]> = (0..4)
        .flat_map(|j| (0..4).map(move |i| [f64::from(i), f64::from(j), 0.0]))
        .collect();
    let id = |i: u32, j: u32| j * 4 + i;
    let tris: Vec<[u32; 3]> = (0..3)
        .flat_map(|j| (0..3).map(move |i| (i, j)))
        .filter(|&(i, j)| (i, j) != (1, 1))
        .flat_map(|(i, j)| {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            [[a, b, c], [a, c, d]]
        })
        .collect();
    let uvs: Vec<[[f32; 2]; 3]> = tris
        .iter()
        .map(|t| {
            t.map(|v| {
                let p = pos[v as usize];
                [(2.0 + p[0] as f32) / 16.0, (2.0 + p[1] as f32) / 16.0]
            })
        })
        .collect();
    let c = case(&pos, &tris, &uvs);
    let r = measure(&c, [16, 16], 2, 1);
    assert_eq!(r.charts, 1);
    let want = (8.0 + 16.0 + std::f64::consts::PI) / 256.0;
    assert!(
        close(Some(r.packing_bound), want),
        "{} vs {want}",
        r.packing_bound
    );
}

#[test]
fn reusing_the_guards_searches_gives_the_same_report() {
    // Two squares on the same UVs (overlaps, two charts), the second cut along its diagonal
    // (a seam) and on a second page in one variant: every combination of what is reused
    // gives measure_atlas's report.
    let (pos, tris) = two_squares();
    let mut uvs = square_uvs([0.25, 0.25], [0.5, 0.5]);
    let mut second = square_uvs([0.25, 0.25], [0.5, 0.5]);
    second[1] = second[1].map(|[u, v]| [u + 0.01, v]);
    uvs.extend(second);
    for pages in [vec![0, 0, 0, 0], vec![0, 0, 1, 1]] {
        let mut c = case(&pos, &tris, &uvs);
        c.pages = pages;
        let num_pages = 1 + c.pages.iter().max().copied().unwrap_or(0);
        let input = MeasureInput {
            mesh: &c.mesh,
            corner_uvs: &c.uvs,
            face_page: &c.pages,
            num_pages,
            width_texels: 32,
            height_texels: 32,
            padding_texels: 2,
        };
        let expected = measure_atlas(&input);
        assert!(expected.charts >= 2);
        for (with_exact, with_check) in [(true, false), (false, true), (true, true)] {
            let reuse = Reuse {
                exact: with_exact.then(|| exact_overlaps(&c.uvs, &c.pages, num_pages)),
                check: with_check.then(|| orientation_check(&c.mesh, &c.uvs, &c.pages)),
            };
            assert_eq!(
                measure_atlas_reusing(&input, reuse),
                expected,
                "exact {with_exact}, check {with_check}"
            );
        }
    }
}
