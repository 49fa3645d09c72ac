//! The flip promise on defective meshes (issue 22 item 5): generated meshes with degenerate
//! (zero-area, repeated-vertex), near-degenerate (slivers, needles, heights down to 1e-9 of an
//! edge, needles to a stray vertex 1e15 or 1e30 away) and non-manifold parts (fins, duplicated
//! and reversed faces, bowties) go through `atlas::generate`, and neither the report nor an
//! independent recomputation from the `f32` corner UVs finds a flipped face or a face that is
//! degenerate in UV but has 3-D area.
//!
//! The recomputation here follows the evaluator's definitions (`../shared/eval/atlas_eval.py`:
//! "degenerate", "Charts", "Orientation") with its own union-find over corner keys, not the
//! crate's `measure` code.
use proptest::prelude::*;
use texatlas::atlas::{generate, AtlasError, AtlasOptions, NoProgress, PackError, TexelDensity};
use texatlas::mesh::{fixtures, FaceId, MeshInput, TriangleMesh, VertexId};

/// One defect applied to the soup: `kind`, the face it starts from (index modulo the current
/// face count), and two parameters in [0, 1).
#[derive(Debug, Clone, Copy)]
struct Defect {
    kind: u8,
    face: u32,
    s: f64,
    h: f64,
}

/// Split positions along an edge (needles at the ends) and heights off it (slivers), relative.
const SPLITS: [f64; 5] = [1e-7, 0.01, 0.5, 0.9, 1.0 - 1e-7];
const HEIGHTS: [f64; 6] = [0.0, 1e-9, 1e-7, 1e-5, 1e-3, 0.0];

fn lerp(a: [f64; 3], b: [f64; 3], s: f64) -> [f64; 3] {
    [0, 1, 2].map(|i| a[i] + s * (b[i] - a[i]))
}

fn push(m: &mut MeshInput, p: [f64; 3]) -> u32 {
    m.positions_m.push(p);
    m.weld_group.push(0);
    (m.positions_m.len() - 1) as u32
}

fn apply(m: &mut MeshInput, d: Defect) {
    let t = d.face as usize % m.triangles.len();
    let [a, b, c] = m.triangles[t];
    let (pa, pb, pc) = (
        m.positions_m[a as usize],
        m.positions_m[b as usize],
        m.positions_m[c as usize],
    );
    match d.kind {
        // Edge a–b split at `m` (a T-junction sealed by a zero-area face when the height is 0, a
        // sliver otherwise; a needle when the split is near an end): [a,m,c], [m,b,c], [a,b,m].
        0..=2 => {
            let s = SPLITS[(d.s * SPLITS.len() as f64) as usize];
            let h = HEIGHTS[(d.h * HEIGHTS.len() as f64) as usize];
            let foot = lerp(pa, pb, s);
            let v = push(m, lerp(foot, pc, h));
            m.triangles[t] = [a, v, c];
            m.triangles.push([v, b, c]);
            m.triangles.push([a, b, v]);
        }
        // A repeated vertex, with either order.
        3 => m
            .triangles
            .push(if d.s < 0.5 { [a, a, b] } else { [b, a, b] }),
        // A repeated position (a copy of `a` that welds to it).
        4 => {
            let v = push(m, pa);
            m.triangles.push([a, v, c]);
        }
        // A fin on edge a–b (three faces on one edge).
        5 => {
            let n = lerp(lerp(pa, pb, 0.5), pc, -0.5);
            let v = push(m, [n[0], n[1], n[2] + 0.3 + d.h]);
            m.triangles.push([a, b, v]);
        }
        // The same face again, as is or reversed.
        6 => m
            .triangles
            .push(if d.s < 0.5 { [a, b, c] } else { [a, c, b] }),
        // A bowtie: a face touching `a` only.
        7 => {
            let p = lerp(pa, pb, -0.4 - d.s);
            let q = lerp(pa, pc, -0.4 - d.h);
            let (v, w) = (push(m, p), push(m, q));
            m.triangles.push([a, v, w]);
        }
        // A needle from edge b–a to a stray vertex far along a–c (zero-area relative to its
        // own length; its short edge is a real edge of the surface).
        9 => {
            let far = if d.h < 0.5 { 1e15 } else { 1e30 };
            let v = push(m, lerp(pa, pc, far * (1.0 + d.s)));
            m.triangles.push([b, a, v]);
        }
        // A zero-area face on three collinear points of edge a–c, none shared.
        _ => {
            let v = push(m, lerp(pa, pc, 0.25));
            let w = push(m, lerp(pa, pc, 0.25 + 0.5 * d.s));
            m.triangles.push([a, v, w]);
        }
    }
}

/// `base(kind, n)` with `defects` applied in order.
fn defective(kind: u8, n: u32, defects: impl IntoIterator<Item = Defect>) -> MeshInput {
    let mut input = base(kind, n);
    for d in defects {
        apply(&mut input, d);
    }
    input
}

fn base(kind: u8, n: u32) -> MeshInput {
    match kind {
        0 => {
            // A bumpy grid (a curved disk).
            let mut g = fixtures::grid(n + 1, n);
            for p in &mut g.positions_m {
                p[2] = 0.3 * (p[0] * 0.9).sin() * (p[1] * 0.7).cos();
            }
            g
        }
        1 => fixtures::cylinder_open(4 + 2 * n, 2 + n, 0.5, 2.0),
        _ => fixtures::uv_sphere(3 + n, 4 + n, 1.0),
    }
}

/// Evaluator-rule counts from the corner UVs: (flipped, UV-degenerate with 3-D area).
fn recount(mesh: &TriangleMesh, uvs: &[[[f32; 2]; 3]], face_page: &[u32]) -> (usize, usize) {
    let nf = mesh.num_faces();
    let bits = |x: f64| if x == 0.0 { 0u64 } else { x.to_bits() };
    let key = |f: usize, k: usize| {
        let v: VertexId = mesh.face_vertices(FaceId(f as u32))[k];
        let p = mesh.corner_position(FaceId(f as u32).corner(k));
        (
            mesh.vertex_weld_group(v),
            p.map(bits),
            face_page[f],
            uvs[f][k].map(|x| bits(f64::from(x))),
        )
    };
    // Union-find of faces over shared unordered corner-key pairs.
    let mut parent: Vec<usize> = (0..nf).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    let mut edges = Vec::with_capacity(3 * nf);
    for f in 0..nf {
        for k in 0..3 {
            let (a, b) = (key(f, k), key(f, (k + 1) % 3));
            edges.push((a.min(b), a.max(b), f));
        }
    }
    edges.sort();
    for w in edges.windows(2) {
        if (w[0].0, w[0].1) == (w[1].0, w[1].1) {
            let (x, y) = (find(&mut parent, w[0].2), find(&mut parent, w[1].2));
            parent[x.max(y)] = x.min(y);
        }
    }
    let mut a2 = vec![0.0; nf];
    let mut deg2 = vec![false; nf];
    let mut deg_uv_3d = 0;
    let mut sum = vec![0.0f64; nf];
    for f in 0..nf {
        let u = uvs[f].map(|c| c.map(f64::from));
        let (ds1, dt1, ds2, dt2) = (
            u[1][0] - u[0][0],
            u[1][1] - u[0][1],
            u[2][0] - u[0][0],
            u[2][1] - u[0][1],
        );
        a2[f] = 0.5 * (ds1 * dt2 - ds2 * dt1);
        let l2 = ds1
            .hypot(dt1)
            .max(ds2.hypot(dt2))
            .max((u[2][0] - u[1][0]).hypot(u[2][1] - u[1][1]));
        // The evaluator's `~(x > tol)`: NaN is degenerate.
        let gt = |x: f64, tol: f64| x.partial_cmp(&tol) == Some(std::cmp::Ordering::Greater);
        deg2[f] = !gt(a2[f].abs(), 1e-12 * l2 * l2);
        // The file's positions of the corners (`corner_position`), as the evaluator reads
        // them: a join of the weld moves no position, so a face it collapsed has its area here.
        let p = mesh
            .face_corners(FaceId(f as u32))
            .map(|c| mesh.corner_position(c));
        let e = |i: usize, j: usize| [0, 1, 2].map(|c| p[j][c] - p[i][c]);
        let (e1, e2, e3) = (e(0, 1), e(0, 2), e(1, 2));
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let len = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let a3 = 0.5 * len(n);
        let l3 = len(e1).max(len(e2)).max(len(e3));
        let deg3 = !gt(a3, 1e-12 * l3 * l3);
        deg_uv_3d += usize::from(deg2[f] && !deg3);
        if !deg2[f] {
            let r = find(&mut parent, f);
            sum[r] += a2[f];
        }
    }
    let flipped = (0..nf)
        .filter(|&f| !deg2[f] && (a2[f] > 0.0) != (sum[find(&mut parent, f)] >= 0.0))
        .count();
    (flipped, deg_uv_3d)
}

fn defect() -> impl Strategy<Value = Defect> {
    (0u8..10, any::<u32>(), 0.0..1.0f64, 0.0..1.0f64).prop_map(|(kind, face, s, h)| Defect {
        kind,
        face,
        s,
        h,
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    /// Any base surface with up to 12 defects, drawn once or twice (a second glTF mesh on the
    /// same positions, whose vertices do not weld to the first's): 0 flips and 0 UV-degenerate
    /// faces with 3-D area, by the report and by the recomputation; the report's counts equal
    /// the recomputation's; no padding violation, no sampled and no exact overlap in the report.
    #[test]
    fn defective_meshes_get_no_flips(
        kind in 0u8..3,
        n in 1u32..5,
        defects in prop::collection::vec(defect(), 1..12),
        copies in 1u32..3,
    ) {
        let mut input = defective(kind, n, defects);
        // A second glTF mesh (weld group) on the same positions: an instance drawn twice.
        for copy in 1..copies {
            let nv = input.positions_m.len() as u32;
            let nt = input.triangles.len();
            input.positions_m.extend_from_within(..nv as usize);
            input.weld_group.extend(std::iter::repeat_n(copy, nv as usize));
            for t in 0..nt {
                let tri = input.triangles[t].map(|v| v + nv);
                input.triangles.push(tri);
            }
        }
        let mesh = TriangleMesh::build(&input).expect("builds").mesh;
        let atlas = generate(&mesh, &AtlasOptions::default(), &mut NoProgress)
            .expect("generates");
        let (flipped, deg_uv_3d) = recount(&mesh, &atlas.corner_uvs, &atlas.face_page);
        prop_assert_eq!(
            (atlas.report.flipped, atlas.report.degenerate_uv_with_3d_area),
            (flipped, deg_uv_3d)
        );
        prop_assert_eq!((flipped, deg_uv_3d), (0, 0), "stats {:?}", atlas.stats);
        // The padding and both overlap tests hold too (the cases below were found here).
        prop_assert_eq!(atlas.report.padding.violation_texels, 0, "stats {:?}", atlas.stats);
        prop_assert_eq!(atlas.report.overlap.sampled.overlapping_texels, 0);
        prop_assert_eq!(atlas.report.overlap.exact.pairs, 0, "{:?}", atlas.report.overlap.exact);
    }
}

/// A UV sphere as naive generators write it: a grid of `n × m` quads whose first and last rows are
/// copies of the poles, each quad two triangles, so that every pole quad gives one real face and
/// one zero-area slit between two pole copies. The south pole's copies come from `sin(π)`
/// (about 1.2e-16, not 0), so they differ by rounding and do not weld by position. Positions
/// are rounded to `f32`, as a glTF file holds them.
fn sphere_with_rounded_pole_copies(n: u32, m: u32) -> MeshInput {
    let mut positions_m = Vec::new();
    for j in 0..=m {
        for i in 0..=n {
            let (u, v) = (f64::from(i) / f64::from(n), f64::from(j) / f64::from(m));
            let (theta, phi) = (std::f64::consts::PI * v, 2.0 * std::f64::consts::PI * u);
            positions_m.push(
                [
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                ]
                .map(|x| f64::from(x as f32)),
            );
        }
    }
    let mut triangles = Vec::new();
    for j in 0..m {
        for i in 0..n {
            let a = j * (n + 1) + i;
            let (b, c) = (a + 1, a + n + 1);
            triangles.push([a, b, c + 1]);
            triangles.push([a, c + 1, c]);
        }
    }
    let weld_group = vec![0; positions_m.len()];
    MeshInput {
        positions_m,
        triangles,
        weld_group,
    }
}

/// The pole copies that differ by rounding are one vertex (the weld rule's near-coincident ends
/// of zero-area faces): every real face at the south pole uses the same vertex there, and the
/// atlas keeps the padding everywhere. Without that join the faces around the pole met only
/// through the slits, their chart flattened each copy apart, and the written atlas split into
/// pieces with no padding between them (453 violation texels on a 32 × 16 sphere).
#[test]
fn rounded_pole_copies_are_one_vertex_and_the_atlas_keeps_its_padding() {
    let input = sphere_with_rounded_pole_copies(32, 16);
    let south = input.positions_m.len() - 1;
    assert_ne!(
        input.positions_m[south],
        input.positions_m[south - 1],
        "the copies must differ by rounding for this test to mean anything"
    );
    let mesh = TriangleMesh::build(&input).expect("builds").mesh;
    let at_pole: std::collections::BTreeSet<VertexId> = (0..mesh.num_faces())
        .map(|f| FaceId(f as u32))
        .filter(|&f| mesh.face_degeneracy(f).is_none())
        .flat_map(|f| mesh.face_vertices(f))
        .filter(|&v| mesh.position(v)[2] < -1.0 + 1e-12)
        .collect();
    assert_eq!(
        at_pole.len(),
        1,
        "south pole vertices of real faces: {at_pole:?}"
    );
    let atlas = generate(&mesh, &AtlasOptions::default(), &mut NoProgress).expect("generates");
    assert_eq!(atlas.report.padding.violation_texels, 0);
    // The slits, isolated as repeated-vertex faces, lie along edges of the packed faces around
    // the pole and join their charts: the measured charts are the packed ones.
    let packed = atlas.chart_page.len() - atlas.stats.degenerate_charts;
    assert_eq!(atlas.report.charts, packed);
    assert_eq!(atlas.report.overlap.sampled.overlapping_texels, 0);
    assert_eq!(atlas.report.overlap.exact.pairs, 0);
    let (flipped, deg_uv_3d) = recount(&mesh, &atlas.corner_uvs, &atlas.face_page);
    assert_eq!((flipped, deg_uv_3d), (0, 0));
}

/// `base(kind, n)` with `defects` (`(kind, face, s, h)` of [`Defect`]) applied, built, and
/// its atlas at defaults.
fn generated(
    (kind, n): (u8, u32),
    defects: &[(u8, u32, f64, f64)],
) -> (TriangleMesh, texatlas::atlas::Atlas) {
    let defects = defects
        .iter()
        .map(|&(kind, face, s, h)| Defect { kind, face, s, h });
    let mesh = TriangleMesh::build(&defective(kind, n, defects))
        .expect("builds")
        .mesh;
    let atlas = generate(&mesh, &AtlasOptions::default(), &mut NoProgress).expect("generates");
    (mesh, atlas)
}

/// The promises of the property above, on one of the cases it found.
fn assert_clean(mesh: &TriangleMesh, atlas: &texatlas::atlas::Atlas) {
    let stats = &atlas.stats;
    assert_eq!(recount(mesh, &atlas.corner_uvs, &atlas.face_page), (0, 0));
    assert_eq!(atlas.report.padding.violation_texels, 0, "{stats:?}");
    assert_eq!(
        atlas.report.overlap.sampled.overlapping_texels, 0,
        "{stats:?}"
    );
    assert_eq!(atlas.report.overlap.exact.pairs, 0, "{stats:?}");
}

/// A cylinder with three needles (splits 1e-7 along an edge, 1e-5 off it), a bowtie and a
/// duplicated face: each packing rounds one needle's apex across the next face of its chart,
/// a different needle each round once the last one is split off. Two split rounds left one
/// such crossing in the output; the guard now has rounds enough.
#[test]
fn needles_rounded_across_their_neighbours_are_split_off_until_none_is_left() {
    let (mesh, atlas) = generated(
        (1, 2),
        &[
            (0, 1058395756, 0.0, 0.6646387098090472),
            (0, 592778441, 0.0, 0.6771534092242367),
            (0, 1935419501, 0.0, 0.8314827374095486),
            (7, 122111046, 0.6902769865843618, 0.02151989273485399),
            (6, 31568233, 0.0, 0.0),
        ],
    );
    assert!(atlas.stats.uv_guard_splits >= 3, "{:?}", atlas.stats);
    assert_clean(&mesh, &atlas);
}

/// A fan of 200 faces about a centre, flattened to 1e-5 of its width (an ellipse of semi-axes 1
/// and 1e-5): near the rim every face is a sliver thinner than the report's raster snaps (1/256
/// texel), so each packing snaps others over their neighbours. Split off one at a time, 1,671
/// texels were still covered twice after the four split rounds; the last split now takes every
/// such sliver apart.
#[test]
fn a_fan_of_slivers_thinner_than_the_raster_is_split_until_nothing_overlaps() {
    let n = 200u32;
    let mut positions = vec![[0.0, 0.0, 0.0]];
    positions.extend((0..n).map(|k| {
        let t = 2.0 * std::f64::consts::PI * f64::from(k) / f64::from(n);
        [t.cos(), 1e-5 * t.sin(), 0.0]
    }));
    let triangles = (1..n).map(|k| [0, k, k + 1]).collect();
    let mesh = TriangleMesh::build(&MeshInput::single_group(positions, triangles))
        .expect("builds")
        .mesh;
    let atlas = generate(&mesh, &AtlasOptions::default(), &mut NoProgress).expect("generates");
    assert!(atlas.stats.uv_guard_splits > 0, "{:?}", atlas.stats);
    assert_clean(&mesh, &atlas);
}

/// A cylinder whose needle end lies 4e-15 from a corner, beside faces of area as short as 4e-8,
/// one of which has both. The weld used to join them (the ends of a zero-area face): the chart
/// was flattened as one piece, but in the file two of its faces met the rest only through that
/// copy, and the report's charts (as the evaluator's) saw two charts side by side with no
/// padding (476 violation texels), until the guard split the torn part off. Now the face of
/// area keeps the two apart (the weld rule), and the atlas keeps every promise.
#[test]
fn a_needle_end_beside_a_corner_of_a_face_of_area_stays_apart_and_keeps_its_padding() {
    let (mesh, atlas) = generated(
        (1, 4),
        &[
            (6, 1975943810, 0.9216163315533094, 0.0),
            (3, 0, 0.0, 0.0),
            (3, 0, 0.0, 0.0),
            (3, 0, 0.0, 0.0),
            (3, 0, 0.0, 0.0),
            (0, 2218113669, 0.0, 0.0),
            (0, 283889046, 0.0, 0.0),
            (3, 0, 0.0, 0.0),
            (0, 3532764, 0.0, 0.0),
        ],
    );
    assert!(!mesh.has_moved_sources(), "a face of area has both ends");
    assert_clean(&mesh, &atlas);
}

/// A zero-area face (a T-junction's seal) and its reversed duplicate get the same three UV
/// points on a segment: no area in `f64`, but the raster's fixed-point rounding gave both a
/// sliver over one common texel centre (an overlap in the report and the evaluator). The
/// guard now collapses them to two equal corners, which no rounding gives area.
#[test]
fn a_zero_area_face_and_its_duplicate_are_collapsed_and_cover_no_texel() {
    let (mesh, atlas) = generated(
        (0, 2),
        &[
            (3, 4024509331, 0.7649145354483752, 0.0),
            (0, 3926211400, 0.0, 0.0),
            (0, 1982152077, 0.4795665152538809, 0.0),
            (3, 0, 0.0, 0.0),
            (7, 2946787052, 0.8157139797642405, 0.0),
            (7, 2438822654, 0.6622859511576451, 0.2563491539139982),
            (3, 0, 0.0, 0.0),
            (0, 154138586, 0.0, 0.0),
            (5, 2395144290, 0.0, 0.04742847787334393),
            (6, 1207666032, 0.7199015754608591, 0.0),
            (5, 4211079879, 0.0, 0.21516802178756644),
        ],
    );
    assert!(atlas.stats.uv_collapsed_faces >= 2, "{:?}", atlas.stats);
    assert_clean(&mesh, &atlas);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// The same promises over several pages: 256-texel pages at a fixed density that needs one
    /// to three of them for these meshes (charts larger than a page are cut into pieces that
    /// fit; a mesh with a triangle larger than a page gets the typed error, and is skipped).
    #[test]
    fn defective_meshes_on_several_pages_keep_every_promise(
        kind in 0u8..3,
        n in 1u32..5,
        defects in prop::collection::vec(defect(), 1..12),
    ) {
        let mesh = TriangleMesh::build(&defective(kind, n, defects)).expect("builds").mesh;
        let mut options = AtlasOptions::default();
        options.pack.width_texels = 256;
        options.pack.height_texels = 256;
        options.pack.density = TexelDensity::TexelsPerUnit(90.0);
        let atlas = match generate(&mesh, &options, &mut NoProgress) {
            Ok(atlas) => atlas,
            Err(AtlasError::Pack(PackError::ChartTooLarge { .. })) => return Ok(()),
            Err(e) => panic!("{e}"),
        };
        assert_clean(&mesh, &atlas);
    }
}

/// Two joins of the weld that are each allowed alone (no face of area has both ends of either)
/// but chain a grid corner to the origin through a split vertex beside it: a needle to a far
/// vertex makes a real edge "near-coincident", and a split at 1e-7 of an edge gives the other.
/// Joined transitively, the two corners of three faces of area became one vertex: collapsed in
/// UV where the file gives them area (the evaluator's `degenerate_uv_with_3d_area` was 3, our
/// report 0, since it measured at the joined positions). The weld now refuses a join that
/// would put two corners of a face of area into one group. Found by the property above once it
/// counted 3-D area at the file's positions.
#[test]
fn joins_that_would_chain_two_corners_of_a_face_of_area_are_refused() {
    let (mesh, atlas) = generated(
        (0, 1),
        &[
            (3, 0, 0.0, 0.0),
            (0, 0, 0.0, 0.0),
            (3, 0, 0.0, 0.0),
            (0, 0, 0.0, 0.0),
            (3, 0, 0.0, 0.0),
            (3, 0, 0.0, 0.0),
            (3, 0, 0.0, 0.0),
            (9, 450_473_882, 0.0, 0.998_502_032_617_889_1),
            (0, 40_622_106, 0.0, 0.0),
            (0, 1_219_662_381, 0.0, 0.0),
        ],
    );
    assert_eq!(atlas.report.degenerate_uv_with_3d_area, 0);
    assert_clean(&mesh, &atlas);
}

/// A needle to a far vertex makes the real edge (1, 0)–(2, 0) of a grid "near-coincident"
/// (1e-9 of the needle's length), and no face of area has both its ends, so the weld joined
/// them: a thin face of area at (2, 0) was then measured at (1, 0), zero-area at the joined
/// positions where the file gives it area 5e-6 (relative), and came out collapsed in UV (the
/// evaluator's `degenerate_uv_with_3d_area` 1, our report 0). A join now also needs its edge to
/// be at most 1e-9 of the shortest edge of every face of area at either end. Found by the
/// property above once it counted 3-D area at the file's positions.
#[test]
fn a_real_edge_beside_a_needle_is_not_joined() {
    let (mesh, atlas) = generated(
        (0, 1),
        &[
            (9, 2_750_194_590, 0.0, 0.0),
            (
                0,
                2_826_848_257,
                0.692_772_200_942_599_4,
                0.512_166_907_427_940_4,
            ),
            (3, 0, 0.0, 0.0),
            (0, 2_916_840_406, 0.0, 0.0),
        ],
    );
    assert_eq!(atlas.report.degenerate_uv_with_3d_area, 0);
    assert_clean(&mesh, &atlas);
}
