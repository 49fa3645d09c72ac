//! `atlas::generate` end to end on generated meshes (no files): the stage contract of
//! GUIDE.md checked independently of the pipeline's own report where possible.
//!
//! For every mesh of the shared fixture suite: every face has UVs inside [0,1]; each chart's
//! faces all sit on the chart's page; no face is flipped relative to its chart (recomputed here
//! from the corner UVs); no two faces of different charts overlap in UV (brute force with exact
//! orientation signs on small meshes); charts share one texel density; the report agrees with
//! those counts; two runs give identical bits; cancellation stops at the stage asked for.
use std::ops::ControlFlow;

use texatlas::atlas::{
    generate, AtlasError, AtlasOptions, NoProgress, Progress, Stage, TexelDensity,
};
use texatlas::mesh::{fixtures, MeshInput, TriangleMesh};

fn meshes() -> Vec<(&'static str, MeshInput)> {
    vec![
        ("grid 12x8", fixtures::grid(12, 8)),
        ("cube", fixtures::cube_split_faces()),
        ("sphere", fixtures::uv_sphere(12, 16, 1.0)),
        ("torus", fixtures::torus(24, 12, 2.0, 0.5)),
        ("open cylinder", fixtures::cylinder_open(16, 6, 0.5, 2.0)),
        ("two components", fixtures::two_components()),
    ]
}

fn signed_area(t: &[[f32; 2]; 3]) -> f64 {
    let p = t.map(|q| q.map(f64::from));
    0.5 * ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]))
}

fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Whether the interiors of two triangles intersect (separating-axis test on the edges).
fn interiors_overlap(a: &[[f32; 2]; 3], b: &[[f32; 2]; 3]) -> bool {
    let a = a.map(|q| q.map(f64::from));
    let b = b.map(|q| q.map(f64::from));
    for (s, o) in [(&a, &b), (&b, &a)] {
        let sign = orient(s[0], s[1], s[2]).signum();
        for k in 0..3 {
            let (p, q) = (s[k], s[(k + 1) % 3]);
            if o.iter().all(|&r| orient(p, q, r) * sign <= 0.0) {
                return false; // this edge separates them
            }
        }
    }
    true
}

#[test]
fn every_fixture_gets_a_valid_atlas() {
    for (name, input) in meshes() {
        let mesh = TriangleMesh::build(&input).expect("builds").mesh;
        let atlas = generate(&mesh, &AtlasOptions::default(), &mut NoProgress)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let n = mesh.num_faces();
        assert_eq!(atlas.corner_uvs.len(), n, "{name}");
        assert_eq!(atlas.face_chart.len(), n, "{name}");
        assert_eq!(atlas.num_pages, 1, "{name}: fit-to-page uses one page");
        for (f, t) in atlas.corner_uvs.iter().enumerate() {
            for uv in t {
                assert!(
                    (0.0..=1.0).contains(&uv[0]) && (0.0..=1.0).contains(&uv[1]),
                    "{name}: face {f} has UV {uv:?} outside [0,1]"
                );
            }
            assert_eq!(
                atlas.face_page[f], atlas.chart_page[atlas.face_chart[f] as usize],
                "{name}"
            );
        }
        // Orientation: every chart's faces share one sign, and none is degenerate.
        let charts = atlas.chart_page.len();
        let mut sign = vec![0i8; charts];
        for (f, t) in atlas.corner_uvs.iter().enumerate() {
            let a = signed_area(t);
            assert!(a != 0.0, "{name}: face {f} has zero UV area");
            let c = atlas.face_chart[f] as usize;
            let s = if a > 0.0 { 1 } else { -1 };
            if sign[c] == 0 {
                sign[c] = s;
            }
            assert_eq!(sign[c], s, "{name}: face {f} is flipped within chart {c}");
        }
        // No overlap between faces of different charts (brute force; the fixtures are small).
        let mut bad = 0;
        for f in 0..n {
            for g in f + 1..n {
                if atlas.face_chart[f] != atlas.face_chart[g]
                    && interiors_overlap(&atlas.corner_uvs[f], &atlas.corner_uvs[g])
                {
                    bad += 1;
                }
            }
        }
        assert_eq!(bad, 0, "{name}: {bad} overlapping face pairs across charts");
        // One texel density: UV area / 3-D area equal over charts (to f32 rounding).
        let mut uv_area = vec![0.0; charts];
        let mut area = vec![0.0; charts];
        for f in mesh.faces() {
            let c = atlas.face_chart[f.index()] as usize;
            uv_area[c] += signed_area(&atlas.corner_uvs[f.index()]).abs();
            area[c] += mesh.face_area_m2(f);
        }
        let density: Vec<f64> = (0..charts).map(|c| (uv_area[c] / area[c]).sqrt()).collect();
        let (lo, hi) = density
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(l, h), &d| (l.min(d), h.max(d)));
        assert!(hi / lo < 1.01, "{name}: texel density spread {lo}..{hi}");
        // The report agrees with what we counted.
        let r = &atlas.report;
        assert_eq!(r.flipped, 0, "{name}: report says flipped");
        assert_eq!(r.overlap.exact.pairs, 0, "{name}: report says overlaps");
        assert!(
            r.stretch.l2.is_some_and(|l2| l2 >= 1.0 && l2.is_finite()),
            "{name}"
        );
        assert!(
            r.packing_efficiency > 0.0 && r.packing_efficiency <= 1.0,
            "{name}: packing {}",
            r.packing_efficiency
        );
    }
}

#[test]
fn a_plane_is_one_chart_with_no_stretch() {
    let mesh = TriangleMesh::build(&fixtures::grid(10, 10))
        .expect("builds")
        .mesh;
    let atlas = generate(&mesh, &AtlasOptions::default(), &mut NoProgress).expect("atlas");
    assert_eq!(atlas.chart_page.len(), 1);
    assert!(
        atlas
            .report
            .stretch
            .l2
            .is_some_and(|l2| (l2 - 1.0).abs() < 1e-4),
        "{:?}",
        atlas.report.stretch.l2
    );
    assert!(
        atlas.report.packing_efficiency > 0.8,
        "a square chart should fill most of the page: {}",
        atlas.report.packing_efficiency
    );
    // Fit-to-page searches the density: a bracket and a bisection, then the probes.
    assert!(atlas.stats.pack_trials > 3, "{:?}", atlas.stats);
    // At the density found, one packing.
    let mut options = AtlasOptions::default();
    options.pack.density = TexelDensity::TexelsPerUnit(atlas.stats.texels_per_unit);
    let fixed = generate(&mesh, &options, &mut NoProgress).expect("atlas");
    assert_eq!(fixed.stats.pack_trials, 1, "{:?}", fixed.stats);
}

#[test]
fn two_runs_give_identical_bits() {
    let mesh = TriangleMesh::build(&fixtures::torus(32, 16, 2.0, 0.6))
        .expect("builds")
        .mesh;
    let a = generate(&mesh, &AtlasOptions::default(), &mut NoProgress).expect("atlas");
    let b = generate(&mesh, &AtlasOptions::default(), &mut NoProgress).expect("atlas");
    assert_eq!(a, b);
}

/// Records the calls and cancels at the first `advance` of one stage.
struct Recorder {
    cancel_at: Option<Stage>,
    calls: Vec<String>,
}

impl Progress for Recorder {
    fn stage_started(&mut self, stage: Stage) {
        self.calls.push(format!("start {}", stage.name()));
    }
    fn advance(&mut self, stage: Stage, done: usize, total: usize) -> ControlFlow<()> {
        assert!(done <= total, "{}: {done} > {total}", stage.name());
        if self.cancel_at == Some(stage) {
            return ControlFlow::Break(());
        }
        ControlFlow::Continue(())
    }
    fn stage_finished(&mut self, stage: Stage) {
        self.calls.push(format!("finish {}", stage.name()));
    }
}

#[test]
fn progress_follows_the_stage_contract_and_cancels_at_every_stage() {
    let mesh = TriangleMesh::build(&fixtures::uv_sphere(10, 12, 1.0))
        .expect("builds")
        .mesh;
    let mut all = Recorder {
        cancel_at: None,
        calls: vec![],
    };
    generate(&mesh, &AtlasOptions::default(), &mut all).expect("atlas");
    let expected: Vec<String> = Stage::ALL
        .iter()
        .flat_map(|s| {
            [
                format!("start {}", s.name()),
                format!("finish {}", s.name()),
            ]
        })
        .collect();
    assert_eq!(all.calls, expected);
    for stage in Stage::ALL {
        let mut p = Recorder {
            cancel_at: Some(stage),
            calls: vec![],
        };
        match generate(&mesh, &AtlasOptions::default(), &mut p) {
            Err(AtlasError::Cancelled { stage: s }) => assert_eq!(s, stage),
            other => panic!("cancel at {}: got {other:?}", stage.name()),
        }
        assert!(!p.calls.contains(&format!("finish {}", stage.name())));
    }
}

#[test]
fn invalid_options_fail_before_any_work() {
    let mesh = TriangleMesh::build(&fixtures::grid(2, 2))
        .expect("builds")
        .mesh;
    let mut options = AtlasOptions::default();
    options.pack.padding_texels = 512;
    let mut p = Recorder {
        cancel_at: None,
        calls: vec![],
    };
    match generate(&mesh, &options, &mut p) {
        Err(AtlasError::InvalidOption { option, detail }) => {
            assert_eq!(option, "padding_texels");
            assert!(detail.contains("512"), "{detail}");
        }
        other => panic!("expected InvalidOption, got {other:?}"),
    }
    assert!(p.calls.is_empty(), "no stage may start: {:?}", p.calls);
}

#[test]
fn a_long_strip_is_cut_when_that_raises_packing() {
    // A flat 32 × 2 strip: one chart of aspect 16 fills about 1/16 of a square page. The
    // packing-aware step of `generate` cuts it (each cut kept only if it raises the packing by
    // at least 0.02), so the atlas packs much better, still with one texel density, no flip and
    // no stretch (flat pieces of a plane).
    let mesh = TriangleMesh::build(&fixtures::grid(32, 2))
        .expect("builds")
        .mesh;
    let atlas = generate(&mesh, &AtlasOptions::default(), &mut NoProgress).expect("atlas");
    assert!(atlas.stats.packing_cuts >= 1, "{:?}", atlas.stats);
    assert_eq!(atlas.chart_page.len(), 1 + atlas.stats.packing_cuts);
    assert!(
        atlas.report.packing_efficiency > 2.0 / 16.0,
        "cutting the strip should at least double the packing: {}",
        atlas.report.packing_efficiency
    );
    assert_eq!(atlas.report.flipped, 0);
    assert!(atlas
        .report
        .stretch
        .l2
        .is_some_and(|l2| (l2 - 1.0).abs() < 1e-4));
}

/// Long strips: two open tubes 15 and 12 m long (radius 0.3 m, 8 sides, a ring of quads every
/// 0.6 m or so) unwrap into strips more than 5 times longer than wide, which at the density of a
/// dense packing are longer than the page. The packing-aware step cuts them across their length
/// into pieces, all at once: 0.62 packing with 9 charts cut off, against 0.48 with the 4 of the
/// cuts by waste alone. One density, no flip, no overlap; the same bits on one thread and on
/// four.
#[test]
fn long_tubes_are_cut_across_their_length() {
    let tubes = fixtures::concat(&[
        fixtures::cylinder_open(8, 24, 0.3, 15.0),
        fixtures::cylinder_open(8, 20, 0.3, 12.0),
    ]);
    let mesh = TriangleMesh::build(&tubes).expect("builds").mesh;
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
            .install(|| generate(&mesh, &AtlasOptions::default(), &mut NoProgress))
            .expect("atlas")
    };
    let (atlas, four) = (run(1), run(4));
    assert_eq!(atlas, four, "depends on the thread count");
    assert_long_charts_cut(&atlas, 0.56);
}

/// Strips that no cut can shorten: three open tubes of one ring (each quad spans its tube's
/// whole length, 10 to 16 m, radius 0.3 m, 8 sides). Their rectangular charts are laid along the
/// page's diagonal, where they can be up to √2 times longer than along a side: 0.444, where
/// the quarter turns alone packed them at 0.277 (`PACKING_ALONG_A_SIDE`, rounded up). One
/// density, no flip, no overlap.
#[test]
fn strips_of_one_quad_pack_along_the_diagonal() {
    const PACKING_ALONG_A_SIDE: f64 = 0.28;
    let tubes = fixtures::concat(&[
        fixtures::cylinder_open(8, 1, 0.3, 16.0),
        fixtures::cylinder_open(8, 1, 0.3, 13.0),
        fixtures::cylinder_open(8, 1, 0.3, 10.0),
    ]);
    let mesh = TriangleMesh::build(&tubes).expect("builds").mesh;
    let atlas = generate(&mesh, &AtlasOptions::default(), &mut NoProgress).expect("atlas");
    assert!(
        atlas.report.packing_efficiency > 1.4 * PACKING_ALONG_A_SIDE,
        "{}",
        atlas.report.packing_efficiency
    );
    assert_eq!(atlas.report.flipped, 0);
    assert_eq!(atlas.report.overlap.exact.pairs, 0);
}

/// The long cuts' outcome: at least 2 charts cut off, packing above `min_packing`, no flip and
/// no overlap in the report.
fn assert_long_charts_cut(atlas: &texatlas::atlas::Atlas, min_packing: f64) {
    assert!(atlas.stats.packing_cuts >= 2, "{:?}", atlas.stats);
    assert!(
        atlas.report.packing_efficiency > min_packing,
        "the long charts should be cut: packing {}",
        atlas.report.packing_efficiency
    );
    assert_eq!(atlas.report.flipped, 0);
    assert_eq!(atlas.report.overlap.exact.pairs, 0);
}

/// The long cuts also run above the 20k faces of the other packing-aware cuts: one open tube of
/// 22,400 triangles (15 m, radius 0.3 m), flattened into 8 strips of aspect 60, packs at 0.53
/// with them cut across their length (19 charts). Without these cuts nothing is cut above 20k
/// faces: a capped tube of the same size packed at 0.126 as one strip.
#[test]
fn a_long_tube_of_many_faces_is_cut_across_its_length() {
    let mesh = TriangleMesh::build(&fixtures::cylinder_open(16, 700, 0.3, 15.0))
        .expect("builds")
        .mesh;
    assert!(mesh.num_faces() > 20_000);
    let atlas = generate(&mesh, &AtlasOptions::default(), &mut NoProgress).expect("atlas");
    assert_long_charts_cut(&atlas, 0.4);
}

/// ASP (`--parameterization asp`): every fixture still gets a valid atlas (no flip, no overlap
/// in the report), the pipeline says which parameterization ran, the result is the same bits on
/// one thread and on four, and on a curved mesh the area distortion falls below LSCM's.
#[test]
fn asp_atlas_is_valid_and_the_same_at_any_thread_count() {
    use texatlas::atlas::parameterize::{Parameterization, StretchOptimization};
    let mut options = AtlasOptions::default();
    options.parameterize.parameterization = Parameterization::Asp;
    options.parameterize.asp_theta = 1.0;
    let mut kept = 0;
    for (name, input) in meshes() {
        let mesh = TriangleMesh::build(&input).expect("builds").mesh;
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool")
                .install(|| generate(&mesh, &options, &mut NoProgress))
                .unwrap_or_else(|e| panic!("{name}: {e}"))
        };
        let (one, four) = (run(1), run(4));
        assert_eq!(one, four, "{name}: depends on the thread count");
        assert_eq!(one.report.flipped, 0, "{name}");
        assert_eq!(one.report.overlap.exact.pairs, 0, "{name}");
        assert_eq!(one.stats.parameterization, Parameterization::Asp, "{name}");
        assert_eq!(one.stats.asp_theta, Some(1.0), "{name}");
        kept += one.stats.asp.charts_relaxed;
    }
    assert!(kept > 0, "no chart kept its ASP map");
    // A sphere's charts are curved: ASP spreads area more evenly than LSCM.
    let mesh = TriangleMesh::build(&fixtures::uv_sphere(24, 32, 1.0))
        .expect("builds")
        .mesh;
    let p95 = |o: &AtlasOptions| {
        generate(&mesh, o, &mut NoProgress)
            .expect("atlas")
            .report
            .area_distortion
            .and_then(|a| a.p95)
            .expect("area distortion")
    };
    // The maps as the parameterizations make them (the default stretch optimisation, run after
    // either, brings both to about the same figure).
    let unoptimized = |mut o: AtlasOptions| {
        o.parameterize.stretch_optimization = StretchOptimization::None;
        o
    };
    let lscm = p95(&unoptimized(AtlasOptions::default()));
    let asp = p95(&unoptimized(options));
    assert!(asp < lscm, "area distortion p95: LSCM {lscm} vs ASP {asp}");
    // And the default (LSCM, then the global stretch descent) lowers it too.
    let global = p95(&AtlasOptions::default());
    assert!(
        global < lscm,
        "area distortion p95: LSCM {lscm} vs LSCM + global descent {global}"
    );
}
