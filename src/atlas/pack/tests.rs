//! The stage guarantees of `pack_charts`, checked with the independent checker of
//! [`super::test_charts`] (centre sampling, the evaluator's definitions).
use std::ops::ControlFlow;

use super::fit::fill_density;
use super::test_charts::{
    as_pack_charts, check_packing, disc, l_shape, mixed_set, realistic_set, strip, triangle,
    OwnedChart, PackCheck,
};
use super::*;
use crate::atlas::progress::{ProgressFn, Stage};

/// No progress wanted, never cancelled.
fn go() -> StageProgress<'static> {
    StageProgress::ignored(Stage::Pack)
}

/// Each chart prepared, the charts in `pack_charts`'s order (largest first) and their total
/// 3-D area: what a test needs to run the density search or a trial of its own.
fn prepared_in_order(charts: &[PackChart<'_>]) -> (Vec<place::PreparedChart>, Vec<usize>, f64) {
    let prepared: Vec<place::PreparedChart> = charts
        .iter()
        .enumerate()
        .map(|(i, c)| place::prepare_chart(i, c).unwrap())
        .collect();
    let order = largest_first(&prepared);
    let total = order.iter().map(|&i| prepared[i].area_m2).sum();
    (prepared, order, total)
}

fn pack(charts: &[OwnedChart], options: &PackOptions) -> (Packing, PackCheck) {
    let borrowed = as_pack_charts(charts);
    let packing = pack_charts(&borrowed, options, &mut go()).unwrap_or_else(|e| panic!("{e}"));
    let check = check_packing(&borrowed, &packing, options);
    (packing, check)
}

fn assert_guarantees(check: &PackCheck, what: &str) {
    assert_eq!(check.overlap_texels, 0, "{what}: overlap {check:?}");
    assert_eq!(
        check.padding_violation_texels, 0,
        "{what}: padding {check:?}"
    );
    assert_eq!(
        check.edge_violation_texels, 0,
        "{what}: page edge {check:?}"
    );
    assert_eq!(check.out_of_range_uvs, 0, "{what}: range {check:?}");
    assert!(check.density_spread < 1e-9, "{what}: density {check:?}");
    assert!(
        check.covered_texels > 0,
        "{what}: nothing covered {check:?}"
    );
}

#[test]
fn mixed_shapes_fit_one_page_with_padding_and_good_efficiency() {
    let charts = mixed_set(60, 3);
    let options = PackOptions::default();
    let (packing, check) = pack(&charts, &options);
    assert_eq!(packing.num_pages, 1);
    assert_guarantees(&check, "mixed 60");
    // Floor well under what the packer reaches (see tests/it/pack_bench.rs for the figures).
    assert!(check.efficiency > 0.55, "efficiency {check:?}");
}

#[test]
fn realistic_lscm_charts_pack_tightly() {
    let charts = realistic_set(8);
    let options = PackOptions::default();
    let (_, check) = pack(&charts, &options);
    assert_guarantees(&check, "realistic 48");
    assert!(check.efficiency > 0.55, "efficiency {check:?}");
}

#[test]
fn every_rotation_count_and_padding_keeps_the_guarantees() {
    let charts = mixed_set(25, 11);
    for (rotations, padding) in [(1, 0), (3, 1), (4, 4), (16, 2), (7, 3)] {
        let options = PackOptions {
            width_texels: 300,
            height_texels: 200,
            padding_texels: padding,
            rotations,
            ..PackOptions::default()
        };
        let (_, check) = pack(&charts, &options);
        assert_guarantees(&check, &format!("rotations {rotations} padding {padding}"));
    }
}

#[test]
fn packing_is_deterministic() {
    let charts = mixed_set(40, 5);
    let options = PackOptions::default();
    let (a, _) = pack(&charts, &options);
    let (b, _) = pack(&charts, &options);
    assert_eq!(a, b);
}

#[test]
fn fixed_density_opens_pages_and_keeps_each_page_clean() {
    // 60 charts: enough area that they need several 256² pages at this density (40 of them
    // fit on one since rectangular charts are turned axis-aligned).
    let charts = mixed_set(60, 9);
    let options = PackOptions {
        width_texels: 256,
        height_texels: 256,
        density: TexelDensity::TexelsPerUnit(30.0),
        ..PackOptions::default()
    };
    let (packing, check) = pack(&charts, &options);
    assert!(
        packing.num_pages > 1,
        "expected several pages, got {}",
        packing.num_pages
    );
    assert_eq!(packing.texels_per_unit, 30.0);
    assert_guarantees(&check, "multi-page");
    // The density is the one asked for: UV area in texels² = area_m2 × 30².
    let borrowed = as_pack_charts(&charts);
    let c = &borrowed[0];
    let uv = &packing.charts[0].uv;
    let a: f64 = c
        .triangles
        .iter()
        .map(|t| {
            let [p, q, r] = t.map(|i| [uv[i as usize][0] * 256.0, uv[i as usize][1] * 256.0]);
            0.5 * ((q[0] - p[0]) * (r[1] - p[1]) - (r[0] - p[0]) * (q[1] - p[1])).abs()
        })
        .sum();
    assert!((a / (c.area_m2 * 900.0) - 1.0).abs() < 1e-9);
}

#[test]
fn a_chart_larger_than_a_page_is_reported() {
    let charts = vec![disc(16, 1.0), disc(16, 20.0)];
    let options = PackOptions {
        width_texels: 128,
        height_texels: 128,
        density: TexelDensity::TexelsPerUnit(10.0),
        ..PackOptions::default()
    };
    let err = pack_charts(&as_pack_charts(&charts), &options, &mut go()).unwrap_err();
    assert!(
        matches!(
            err,
            PackError::ChartTooLarge {
                chart: 1,
                page_texels: [128, 128],
                ..
            }
        ),
        "{err:?}"
    );
}

#[test]
fn invalid_options_say_what_to_use() {
    let charts = vec![disc(8, 1.0)];
    let bad = [
        PackOptions {
            width_texels: 0,
            ..PackOptions::default()
        },
        PackOptions {
            height_texels: MAX_PAGE_TEXELS + 1,
            ..PackOptions::default()
        },
        PackOptions {
            rotations: 0,
            ..PackOptions::default()
        },
        PackOptions {
            padding_texels: 512,
            ..PackOptions::default()
        },
        PackOptions {
            density: TexelDensity::TexelsPerUnit(f64::NAN),
            ..PackOptions::default()
        },
        PackOptions {
            density: TexelDensity::TexelsPerUnit(-1.0),
            ..PackOptions::default()
        },
    ];
    for o in bad {
        match pack_charts(&as_pack_charts(&charts), &o, &mut go()) {
            Err(PackError::InvalidOption { detail, .. }) => {
                assert!(detail.contains("use"), "{detail}")
            }
            other => panic!("{o:?}: {other:?}"),
        }
    }
}

#[test]
fn invalid_charts_are_errors_not_panics() {
    let uv = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
    let nan = [[0.0, 0.0], [f64::NAN, 0.0], [0.0, 1.0]];
    let cases = [
        PackChart {
            uv: &uv,
            triangles: &[[0, 1, 3]],
            area_m2: 1.0,
        },
        PackChart {
            uv: &nan,
            triangles: &[[0, 1, 2]],
            area_m2: 1.0,
        },
        PackChart {
            uv: &uv,
            triangles: &[[0, 1, 2]],
            area_m2: -1.0,
        },
        PackChart {
            uv: &uv,
            triangles: &[[0, 1, 2]],
            area_m2: f64::INFINITY,
        },
    ];
    for c in cases {
        let err = pack_charts(&[c], &PackOptions::default(), &mut go()).unwrap_err();
        assert!(
            matches!(err, PackError::InvalidChart { chart: 0, .. }),
            "{err:?}"
        );
    }
}

#[test]
fn degenerate_charts_get_a_texel_and_no_nan() {
    let collinear = OwnedChart {
        uv: vec![[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]],
        triangles: vec![[0, 1, 2]],
        area_m2: 0.5,
    };
    let no_area = OwnedChart {
        area_m2: 0.0,
        ..triangle([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    };
    let no_triangles = OwnedChart {
        uv: vec![[3.0, 4.0]],
        triangles: vec![],
        area_m2: 0.0,
    };
    let empty = OwnedChart {
        uv: vec![],
        triangles: vec![],
        area_m2: 0.0,
    };
    let unreferenced = OwnedChart {
        uv: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1e9, -1e9]],
        ..triangle([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    };
    let charts = vec![
        collinear,
        disc(12, 1.0),
        no_area,
        no_triangles,
        empty,
        unreferenced,
    ];
    for density in [TexelDensity::FitToPage, TexelDensity::TexelsPerUnit(50.0)] {
        let options = PackOptions {
            width_texels: 256,
            height_texels: 256,
            density,
            ..PackOptions::default()
        };
        let (packing, check) = pack(&charts, &options);
        assert_guarantees(&check, &format!("degenerate {density:?}"));
        assert!(packing.texels_per_unit.is_finite() && packing.texels_per_unit > 0.0);
        assert!(packing
            .charts
            .iter()
            .all(|c| c.uv.iter().all(|q| q[0].is_finite() && q[1].is_finite())));
        assert_eq!(packing.charts[4].uv.len(), 0);
    }
    // Only degenerate charts.
    let only = vec![OwnedChart {
        area_m2: 0.0,
        ..triangle([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    }];
    let (p, c) = pack(&only, &PackOptions::default());
    assert_eq!(c.out_of_range_uvs, 0);
    assert!(p.texels_per_unit > 0.0);
}

#[test]
fn thousands_of_tiny_charts_fit_or_are_refused() {
    let charts: Vec<OwnedChart> = (0..3000)
        .map(|i| {
            let s = 1.0 + (i % 7) as f64;
            triangle([[0.0, 0.0], [s, 0.0], [0.3 * s, s]])
        })
        .collect();
    let options = PackOptions {
        width_texels: 512,
        height_texels: 512,
        ..PackOptions::default()
    };
    let (packing, check) = pack(&charts, &options);
    assert_eq!(packing.num_pages, 1);
    assert_guarantees(&check, "3000 triangles");
    // 3000 charts each needing at least (1 + 2)² texels cannot fit 64×64 with padding 2.
    let small = PackOptions {
        width_texels: 64,
        height_texels: 64,
        ..PackOptions::default()
    };
    let err = pack_charts(&as_pack_charts(&charts), &small, &mut go()).unwrap_err();
    assert!(
        matches!(err, PackError::DoesNotFit { charts: 3000, .. }),
        "{err:?}"
    );
}

#[test]
fn the_checker_catches_overlap_and_padding_violations() {
    let charts = vec![disc(16, 1.0), l_shape(2.0, 0.5), strip(3.0, 0.4, 6, 0.0)];
    let options = PackOptions {
        width_texels: 128,
        height_texels: 128,
        ..PackOptions::default()
    };
    let borrowed = as_pack_charts(&charts);
    let packing = pack_charts(&borrowed, &options, &mut go()).unwrap();
    assert_guarantees(&check_packing(&borrowed, &packing, &options), "baseline");
    // Stack chart 1 onto chart 0: the L's corner vertex 0 (all its triangles meet there) onto
    // the disc's centre vertex 0: overlap.
    let mut stacked = packing.clone();
    let (d0, l0) = (packing.charts[0].uv[0], packing.charts[1].uv[0]);
    stacked.charts[1].uv = packing.charts[1]
        .uv
        .iter()
        .map(|p| [p[0] - l0[0] + d0[0], p[1] - l0[1] + d0[1]])
        .collect();
    assert!(check_packing(&borrowed, &stacked, &options).overlap_texels > 0);
    // Move chart 2 until it is within the padding of another chart, one texel at a time.
    let mut found = false;
    for step in 1..128 {
        let mut moved = packing.clone();
        for (dx, dy) in [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)] {
            moved.charts[2].uv = packing.charts[2]
                .uv
                .iter()
                .map(|p| {
                    [
                        p[0] + dx * step as f64 / 128.0,
                        p[1] + dy * step as f64 / 128.0,
                    ]
                })
                .collect();
            let c = check_packing(&borrowed, &moved, &options);
            if c.padding_violation_texels > 0 && c.overlap_texels == 0 {
                found = true;
            }
        }
        if found {
            break;
        }
    }
    assert!(found, "no padding violation detected by moving a chart");
}

#[test]
fn cancellation_stops_with_cancelled() {
    let charts = mixed_set(10, 1);
    let mut calls = 0;
    let err = pack_charts(
        &as_pack_charts(&charts),
        &PackOptions::default(),
        &mut StageProgress::new(
            Stage::Pack,
            &mut ProgressFn(|_: Stage, _: usize, _: usize| {
                calls += 1;
                if calls > 3 {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            }),
        ),
    )
    .unwrap_err();
    assert_eq!(err, PackError::Cancelled);
}

#[test]
fn non_square_pages_follow_the_page_aspect() {
    let charts = mixed_set(50, 21);
    let options = PackOptions {
        width_texels: 1024,
        height_texels: 256,
        ..PackOptions::default()
    };
    let (_, check) = pack(&charts, &options);
    assert_guarantees(&check, "1024×256");
    assert!(check.efficiency > 0.45, "{check:?}");
}

/// Whether the open interiors of two triangles meet (no separating edge line; `f64` is enough
/// here: placed charts are texels apart, far from any tie).
fn interiors_meet(a: [[f64; 2]; 3], b: [[f64; 2]; 3]) -> bool {
    let side = |p: [f64; 2], q: [f64; 2], r: [f64; 2]| {
        (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
    };
    let separated_by_edge_of = |t: [[f64; 2]; 3], u: [[f64; 2]; 3]| {
        let orient = side(t[0], t[1], t[2]).signum();
        (0..3).any(|e| {
            let (p, q) = (t[e], t[(e + 1) % 3]);
            u.iter().all(|&r| orient * side(p, q, r) <= 0.0)
        })
    };
    !(separated_by_edge_of(a, b) || separated_by_edge_of(b, a))
}

#[test]
fn slivers_that_cover_no_texel_centre_are_never_overlapped() {
    // Long triangles a fraction of a texel thick cover few or no texel centres, so a
    // centre-sampled footprint would let other charts lie on them; the footprint must hold
    // every texel they touch.
    let mut charts: Vec<OwnedChart> = (0..12)
        .map(|k| {
            let (len, thick) = (40.0 + 7.0 * f64::from(k), 0.2 + 0.05 * f64::from(k % 4));
            triangle([[0.0, 0.0], [len, 0.0], [0.5 * len, thick]])
        })
        .collect();
    charts.extend(mixed_set(30, 4));
    for padding_texels in [0, 1, 2, 4] {
        let options = PackOptions {
            width_texels: 512,
            height_texels: 512,
            padding_texels,
            ..PackOptions::default()
        };
        let (packing, check) = pack(&charts, &options);
        assert_guarantees(&check, "slivers");
        let borrowed = as_pack_charts(&charts);
        let placed: Vec<(u32, usize, [[f64; 2]; 3])> = borrowed
            .iter()
            .enumerate()
            .flat_map(|(c, chart)| {
                let p = &packing.charts[c];
                chart
                    .triangles
                    .iter()
                    .map(move |t| (p.page, c, t.map(|i| p.uv[i as usize])))
            })
            .collect();
        let mut pairs = 0;
        for (i, a) in placed.iter().enumerate() {
            for b in &placed[i + 1..] {
                if a.0 == b.0 && a.1 != b.1 && interiors_meet(a.2, b.2) {
                    pairs += 1;
                }
            }
        }
        assert_eq!(
            pairs, 0,
            "padding {padding_texels}: overlapping triangle pairs"
        );
    }
}

#[test]
fn one_or_two_threads_give_the_same_packing() {
    // The parallel parts (footprints, horizon sides, the orientations of the hole search)
    // reduce in a fixed order: the same packing, density and trial count either way, on
    // several chart sets.
    for (n, seed) in [(40, 5), (25, 11), (60, 3)] {
        let charts = mixed_set(n, seed);
        let options = PackOptions::default();
        let on = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| pack(&charts, &options).0)
        };
        let one = on(1);
        assert_eq!(one, on(2), "{n} charts, seed {seed}");
        assert!(one.trials > 1);
    }
}

#[test]
fn fit_to_page_probes_keep_the_largest_density_that_fits() {
    // The density chosen (possibly by a probe above the bracket) packs on one page at that
    // fixed density too, with every guarantee; the search ran the bracket and the probes.
    let charts = mixed_set(40, 11);
    let fit = PackOptions::default();
    let (packing, check) = pack(&charts, &fit);
    assert_guarantees(&check, "fit to page");
    // At least a fit and a failure to close the bracket, and one probe above it.
    assert!(packing.trials >= 3, "{} trials", packing.trials);
    let fixed = PackOptions {
        density: TexelDensity::TexelsPerUnit(packing.texels_per_unit),
        ..fit
    };
    let (again, check) = pack(&charts, &fixed);
    assert_eq!(again.num_pages, 1);
    assert_guarantees(&check, "fixed at the chosen density");
    assert_eq!(again.charts, packing.charts);
}

/// Whether `placed` is `chart` turned by a multiple of 90° from its diameter-vertical
/// orientation: its longest edge (the diameter of a triangle) is axis-aligned on the page.
fn diameter_axis_aligned(chart: &OwnedChart, placed: &PlacedChart) -> bool {
    let [a, b] = [0usize, 1, 2]
        .iter()
        .flat_map(|&i| [0usize, 1, 2].iter().map(move |&j| [i, j]))
        .max_by(|p, q| {
            let l = |[i, j]: [usize; 2]| {
                let (u, v) = (chart.uv[i], chart.uv[j]);
                (u[0] - v[0]).hypot(u[1] - v[1])
            };
            l(*p).total_cmp(&l(*q))
        })
        .unwrap();
    let (p, q) = (placed.uv[a], placed.uv[b]);
    let (dx, dy) = ((p[0] - q[0]).abs(), (p[1] - q[1]).abs());
    dx.min(dy) < 1e-9 * dx.max(dy).max(1e-300) + 1e-12
}

#[test]
fn thousands_of_small_charts_try_quarter_turns_only_and_keep_the_guarantees() {
    // 1,500 small triangles (far below SMALL_CHART_TEXELS): at a density where the horizons
    // pack them on one page, each is placed turned by a multiple of 90° from its
    // diameter-vertical orientation; fitted to the page, where the horizons leave the page
    // sparse and the hole-filling packing wins, every angle is tried, and some triangle takes
    // one that is not a quarter turn. The guarantees hold in both.
    let mut state = 99u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let charts: Vec<OwnedChart> = (0..1500)
        .map(|_| {
            triangle([
                [0.0, 0.0],
                [1.0 + next(), 0.2 * next()],
                [0.3 + 0.4 * next(), 0.4 + 0.3 * next()],
            ])
        })
        .collect();
    let options = PackOptions::default();
    let (fitted, check) = pack(&charts, &options);
    assert_guarantees(&check, "1500 small triangles, fitted");
    let d = fitted.texels_per_unit;
    assert!(charts
        .iter()
        .all(|c| c.area_m2 * d * d < SMALL_CHART_TEXELS));
    let turned = charts
        .iter()
        .zip(&fitted.charts)
        .filter(|(c, p)| !diameter_axis_aligned(c, p))
        .count();
    assert!(turned > 0, "hole filling tried the quarter turns only");

    // Half the fitted density: a quarter of the area, one page by the horizons alone.
    let options = PackOptions {
        density: TexelDensity::TexelsPerUnit(0.5 * d),
        ..PackOptions::default()
    };
    let (packing, check) = pack(&charts, &options);
    assert_eq!(packing.num_pages, 1);
    assert_guarantees(&check, "1500 small triangles, half density");
    for (chart, placed) in charts.iter().zip(&packing.charts) {
        assert!(diameter_axis_aligned(chart, placed), "{:?}", placed.uv);
    }
}

#[test]
fn small_charts_fill_the_hole_of_a_ring_instead_of_growing_the_box() {
    // A square ring (outer side 10, inner side 4) and small squares that fit its hole, on a
    // page that leaves no room beside the ring: the horizons alone can only put the squares
    // outside the ring (its hole is behind every horizon), so they open a second page; the
    // packer then fills holes, and every square must land inside the hole, on one page, keeping
    // every guarantee.
    let o = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
    let i = [[3.0, 3.0], [7.0, 3.0], [7.0, 7.0], [3.0, 7.0]];
    let mut uv: Vec<[f64; 2]> = o.to_vec();
    uv.extend(i);
    let mut triangles = Vec::new();
    for k in 0..4u32 {
        let n = (k + 1) % 4;
        triangles.push([k, n, 4 + n]);
        triangles.push([k, 4 + n, 4 + k]);
    }
    let mut charts = vec![OwnedChart {
        uv,
        triangles,
        area_m2: 84.0,
    }];
    for _ in 0..5 {
        charts.push(OwnedChart {
            uv: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            area_m2: 1.0,
        });
    }
    let options = PackOptions {
        width_texels: 212,
        height_texels: 212,
        density: TexelDensity::TexelsPerUnit(20.0),
        ..PackOptions::default()
    };
    let (packing, check) = pack(&charts, &options);
    assert_eq!(
        packing.num_pages, 1,
        "the squares did not go into the ring's hole"
    );
    assert_guarantees(&check, "ring");
    // The ring's hole on the page: the box of its inner vertices.
    let ring = &packing.charts[0].uv;
    let lo = [0, 1].map(|k| (4..8).map(|v| ring[v][k]).fold(f64::INFINITY, f64::min));
    let hi = [0, 1].map(|k| (4..8).map(|v| ring[v][k]).fold(f64::NEG_INFINITY, f64::max));
    for (c, placed) in packing.charts.iter().enumerate().skip(1) {
        for p in &placed.uv {
            assert!(
                (0..2).all(|k| lo[k] < p[k] && p[k] < hi[k]),
                "small chart {c} at {p:?} is outside the ring's hole {lo:?}..{hi:?}"
            );
        }
    }
}

#[test]
fn a_failing_hole_filling_trial_counts_only_the_charts_it_could_not_place() {
    // Above the density that fits, a hole-filling trial goes on past the charts it cannot
    // place: every chart is then placed or counted as not placed, and no more than the charts
    // it met and skipped are counted; a horizon trial counts every chart from its first failure.
    let charts = mixed_set(400, 9);
    let borrowed = as_pack_charts(&charts);
    let options = PackOptions::default();
    let fit = pack_charts(&borrowed, &options, &mut go()).unwrap();
    let (prepared, order, total) = prepared_in_order(&borrowed);
    let mut skipped_some = false;
    for holes in [true, false] {
        let ctx = Context {
            holes,
            scored: holes,
            ..Context::new(&borrowed, &prepared, &order, &options)
        };
        for grow in [1.02, 1.05, 1.10, 1.15, 1.20, 1.30] {
            let mut quiet = |_: (usize, usize)| ControlFlow::Continue(());
            let t = ctx
                .run(
                    fit.texels_per_unit * grow,
                    false,
                    &mut Steps::new(&mut quiet, 1),
                )
                .unwrap();
            if t.unplaced == 0 {
                continue;
            }
            let placed: f64 = order
                .iter()
                .filter(|&&i| t.placed[i].is_some())
                .map(|&i| prepared[i].area_m2)
                .sum();
            let accounted = (placed + t.unplaced_area_m2 - total).abs() <= 1e-9 * total;
            assert!(
                accounted,
                "holes {holes}: placed and not placed make up every chart"
            );
            let not_placed = order.iter().filter(|&&i| t.placed[i].is_none()).count();
            if holes {
                assert!(t.unplaced <= HOLE_SKIPS_MAX + 1, "{}", t.unplaced);
                let stopped = t.unplaced > HOLE_SKIPS_MAX
                    || t.unplaced_area_m2 > HOLE_SKIPS_AREA_FRACTION * total;
                if !stopped {
                    // It met every chart: only those it skipped are not placed.
                    assert_eq!(not_placed, t.unplaced, "grow {grow}");
                    skipped_some |= t.unplaced > 1;
                }
            } else {
                assert_eq!(t.unplaced, 1, "a horizon trial stops at its first failure");
            }
        }
    }
    assert!(skipped_some, "no hole-filling trial went on past a failure");
}

#[test]
fn a_search_given_up_at_its_first_miss_is_the_whole_search_trial_for_trial() {
    // A search above a density (`FitStart::Beat`) whose first trial, at its floor, does not
    // fit ends there, whether it gives up at a first miss or not: both say `DoesNotFit` after
    // that one trial (so `pack_charts_with` runs no search twice). From a floor below what fits,
    // both find the same packing. A search given up elsewhere gives its trial back, and the
    // whole search goes on from it.
    let charts = mixed_set(40, 5);
    let borrowed = as_pack_charts(&charts);
    let options = PackOptions::default();
    let (prepared, order, total) = prepared_in_order(&borrowed);
    let page = [options.width_texels, options.height_texels];
    let too_dense = fill_density(total, page) * (2.0 / FIT_START_FILL).sqrt();
    let mut quiet = |_: (usize, usize)| ControlFlow::Continue(());
    for holes in [false, true] {
        let ctx = || Context {
            holes,
            scored: holes,
            ..Context::new(&borrowed, &prepared, &order, &options)
        };
        let trials = |c: &Context<'_, '_>| c.trials.load(std::sync::atomic::Ordering::Relaxed);
        let (given_up, whole) = (ctx(), ctx());
        let r = fit_to_page_unless_first_misses(&given_up, FitStart::Beat(too_dense), &mut quiet);
        assert!(
            matches!(r, Err(PackError::DoesNotFit { .. })),
            "holes {holes}: {:?}",
            r.as_ref().err()
        );
        let r = fit_to_page(&whole, FitStart::Beat(too_dense), &mut quiet);
        assert!(
            matches!(r, Err(PackError::DoesNotFit { .. })),
            "holes {holes}: {:?}",
            r.as_ref().err()
        );
        assert_eq!((trials(&given_up), trials(&whole)), (1, 1), "holes {holes}");
        // From a floor that fits: the same search, the same packing.
        let low = fill_density(total, page) * 0.5;
        let (a, b) = (ctx(), ctx());
        let Ok(FirstTry::Found(given_up)) =
            fit_to_page_unless_first_misses(&a, FitStart::Beat(low), &mut quiet)
        else {
            panic!("holes {holes}: nothing found above {low}");
        };
        let whole = fit_to_page(&b, FitStart::Beat(low), &mut quiet).unwrap();
        assert_eq!(
            (given_up.texels_per_unit, format!("{:?}", given_up.placed)),
            (whole.texels_per_unit, format!("{:?}", whole.placed)),
            "holes {holes}"
        );
        assert_eq!(trials(&a), trials(&b), "holes {holes}");
        // From a guess too dense, the given-up search gives its first trial back, and the whole
        // search from it finds the same packing without packing that trial again.
        let guess = FitStart::Guess(whole.texels_per_unit * 1.3);
        let (a, b, c) = (ctx(), ctx(), ctx());
        let Ok(FirstTry::Missed(missed)) = fit_to_page_unless_first_misses(&a, guess, &mut quiet)
        else {
            panic!("holes {holes}: the guess fits");
        };
        let after = fit_to_page_after(&b, guess, Some(missed), &mut quiet).unwrap();
        let whole = fit_to_page(&c, guess, &mut quiet).unwrap();
        assert_eq!(
            (after.texels_per_unit, format!("{:?}", after.placed)),
            (whole.texels_per_unit, format!("{:?}", whole.placed)),
            "holes {holes}"
        );
        assert_eq!(
            (trials(&a), trials(&b) + 1),
            (1, trials(&c)),
            "holes {holes}"
        );
    }
}

#[test]
fn one_page_at_a_fixed_density_is_packed_with_every_guarantee_or_refused() {
    // Below the fit-to-page density every chart fits one page, with every guarantee and at
    // exactly that density; far above it nothing fits and the answer is None.
    let charts = mixed_set(40, 5);
    let borrowed = as_pack_charts(&charts);
    let options = PackOptions::default();
    let fit = pack_charts(&borrowed, &options, &mut go()).unwrap();
    let below = fit.texels_per_unit * 0.9;
    let packing = pack_one_page(&borrowed, &options, below, None)
        .unwrap()
        .expect("one page holds the charts below the fit-to-page density");
    assert_eq!(packing.num_pages, 1);
    assert_eq!(packing.texels_per_unit, below);
    let fixed = PackOptions {
        density: TexelDensity::TexelsPerUnit(below),
        ..options
    };
    assert_guarantees(&check_packing(&borrowed, &packing, &fixed), "one page");
    let far_above = fit.texels_per_unit * 2.0;
    assert!(pack_one_page(&borrowed, &options, far_above, None)
        .unwrap()
        .is_none());
}

#[test]
fn a_cache_changes_no_packing_and_makes_no_footprint_twice() {
    let charts = mixed_set(30, 11);
    let borrowed = as_pack_charts(&charts);
    let options = PackOptions::default();
    let cache = PackCache::new();
    // A density search through the cache: the same packing; with no density pinned, only the
    // prepared charts are kept.
    let plain = pack_charts(&borrowed, &options, &mut go()).unwrap();
    let cached = pack_charts_cached(&borrowed, &options, None, &cache, &mut go()).unwrap();
    assert_eq!(cached, plain);
    assert_eq!(cache.kept(), (30, 0));
    // One page at the pinned density: the same packing, and the footprints are kept ...
    let d = plain.texels_per_unit * 0.9;
    cache.pin(d);
    let first = pack_one_page(&borrowed, &options, d, Some(&cache)).unwrap();
    assert!(first.is_some());
    assert_eq!(first, pack_one_page(&borrowed, &options, d, None).unwrap());
    let kept = cache.kept().1;
    assert!(kept >= 30, "{kept} footprint sets kept for 30 charts");
    // ... so the same charts again make none.
    assert_eq!(
        pack_one_page(&borrowed, &options, d, Some(&cache)).unwrap(),
        first
    );
    assert_eq!(cache.kept().1, kept);
    // Charts rebuilt with the same content are found again: with one chart replaced, only its
    // footprints are made (at most two sets: the horizons' and the hole filling's).
    let mut rebuilt = mixed_set(30, 11);
    rebuilt[0] = disc(12, 3.0);
    let borrowed = as_pack_charts(&rebuilt);
    let again = pack_one_page(&borrowed, &options, d, Some(&cache)).unwrap();
    assert_eq!(again, pack_one_page(&borrowed, &options, d, None).unwrap());
    assert_eq!(cache.kept().0, 31);
    assert!((kept + 1..=kept + 2).contains(&cache.kept().1));
    // Another density drops the footprints.
    cache.pin(d * 0.95);
    assert_eq!(cache.kept(), (31, 0));
}

#[test]
fn box_waste_is_the_empty_part_of_the_minimum_area_rectangle() {
    // A rectangle wastes nothing; an L of two unit-wide arms 4 long (area 7) lies in a 4 × 4
    // square whatever the scale, so it wastes 9 of the 16 at the scale where UV area = 3-D area.
    let rect = strip(8.0, 2.0, 8, 0.0);
    assert!(place::box_waste_m2(&rect.as_pack_chart()).abs() < 1e-6 * rect.area_m2);
    let l = l_shape(4.0, 1.0);
    let waste = place::box_waste_m2(&l.as_pack_chart());
    let expected = l.area_m2 * 9.0 / 7.0;
    assert!(
        (waste - expected).abs() < 1e-6 * expected,
        "waste {waste}, expected {expected} (area {})",
        l.area_m2
    );
}

#[test]
fn box_sides_are_the_minimum_area_rectangle_at_the_packing_scale() {
    // A 32 × 2 strip turned by 0.5 rad, with 3-D area 16 (a quarter of its UV area 64): at the
    // packing scale (UV area = 3-D area) its sides are halved, 16 × 1, whatever the turn.
    let mut turned = strip(32.0, 2.0, 16, 0.0);
    let (s, c) = 0.5f64.sin_cos();
    for p in &mut turned.uv {
        *p = [c * p[0] - s * p[1], s * p[0] + c * p[1]];
    }
    turned.area_m2 = 16.0;
    let [long, short] = place::box_sides_m(&turned.as_pack_chart());
    assert!(
        (long - 16.0).abs() < 1e-9 && (short - 1.0).abs() < 1e-9,
        "{long} × {short}"
    );
    // No UV area: no sides.
    let flat = OwnedChart {
        uv: vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]],
        triangles: vec![[0, 1, 2]],
        area_m2: 1.0,
    };
    assert_eq!(place::box_sides_m(&flat.as_pack_chart()), [0.0, 0.0]);
}

#[test]
fn length_pieces_slice_a_strip_into_equal_lengths() {
    // A 12 × 1 strip of 12 quads along x: 3 pieces of 4 quads (8 triangles) each, numbered
    // along the strip, whichever end the long axis starts from.
    let long = strip(12.0, 1.0, 12, 0.0);
    let piece = place::length_pieces(&long.as_pack_chart(), 3).expect("pieces");
    assert_eq!(piece.len(), 24);
    for k in 0..3 {
        assert_eq!(piece.iter().filter(|&&p| p == k).count(), 8, "{piece:?}");
    }
    // Neighbouring quads share a piece or follow each other, so each piece is one run.
    let per_quad: Vec<usize> = piece.chunks(2).map(|q| q[0]).collect();
    assert!(piece.chunks(2).all(|q| q[0] == q[1]), "{piece:?}");
    assert!(
        per_quad.windows(2).all(|w| w[0].abs_diff(w[1]) <= 1),
        "{per_quad:?}"
    );
    // Slices that hold no centroid get no number: the 6 triangles of 3 long quads (9 × 1, their
    // centroids at x = 1, 2, 4, 5, 7, 8) in 8 slices of 9/8 fall in slices 0, 1, 3, 4, 6 and 7,
    // numbered 0 to 5 in order.
    let coarse = strip(9.0, 1.0, 3, 0.0);
    let piece = place::length_pieces(&coarse.as_pack_chart(), 8).expect("pieces");
    let mut sorted = piece.clone();
    sorted.sort_unstable();
    assert_eq!(sorted, vec![0, 1, 2, 3, 4, 5], "{piece:?}");
    // Fewer than 2 pieces, or one slice holding every centroid: no cut.
    assert!(place::length_pieces(&long.as_pack_chart(), 1).is_none());
    let one = triangle([[0.0, 0.0], [10.0, 0.0], [0.0, 1.0]]);
    assert!(place::length_pieces(&one.as_pack_chart(), 4).is_none());
}

#[test]
fn a_dumbbell_is_cut_across_its_bar() {
    // Two 4 × 4 squares joined by a 4 × 0.5 bar along x (length 12): the neck is in the bar,
    // so one side holds the left square's triangles and the other the right square's.
    let mut uv: Vec<[f64; 2]> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut quad = |x0: f64, y0: f64, x1: f64, y1: f64| {
        let k = uv.len() as u32;
        uv.extend([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]);
        triangles.extend([[k, k + 1, k + 2], [k, k + 2, k + 3]]);
    };
    quad(0.0, 0.0, 4.0, 4.0);
    quad(4.0, 1.75, 8.0, 2.25);
    quad(8.0, 0.0, 12.0, 4.0);
    let dumbbell = OwnedChart {
        uv,
        triangles,
        area_m2: 34.0,
    };
    let side = place::neck_cut(&dumbbell.as_pack_chart()).expect("a cut");
    assert_eq!(side.len(), 6);
    assert_eq!(side[0], side[1], "the left square stays together");
    assert_eq!(side[4], side[5], "the right square stays together");
    assert_ne!(side[0], side[4], "the squares are on either side");
    // A chart with no UV area has no neck.
    let flat = OwnedChart {
        uv: vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]],
        triangles: vec![[0, 1, 2]],
        area_m2: 1.0,
    };
    assert!(place::neck_cut(&flat.as_pack_chart()).is_none());
}

#[test]
fn hole_filling_first_keeps_the_denser_search_and_skips_the_horizons_where_they_lose() {
    // `FirstPacker::HoleFilling` (fewer than HOLE_SCORED_MIN_CHARTS charts) keeps the denser
    // of hole filling's own density search and the horizons' search above it: never below hole
    // filling alone. Where the horizons leave the page sparse, hole filling is the search that
    // followed them (but for their density as a floor), so the packing is as dense as the
    // horizons-first one within the search's tolerance, in fewer trials (the horizons' full
    // search is not run).
    let quiet = || |_: (usize, usize)| ControlFlow::Continue(());
    let mut sparse_sets = 0;
    for (what, charts) in [
        ("mixed 12", mixed_set(12, 9)),
        ("mixed 20", mixed_set(20, 4)),
        ("mixed 32", mixed_set(32, 3)),
        ("realistic 18", realistic_set(3)),
        ("realistic 30", realistic_set(5)),
        (
            "bent strips",
            (0..10)
                .map(|k| strip(4.0 + 0.5 * f64::from(k), 0.6, 16, 1.5 + 0.3 * f64::from(k)))
                .collect(),
        ),
        (
            "l shapes",
            (0..12)
                .map(|k| l_shape(3.0 + 0.3 * f64::from(k), 0.8))
                .collect(),
        ),
    ] {
        assert!(charts.len() < HOLE_SCORED_MIN_CHARTS);
        let borrowed = as_pack_charts(&charts);
        let holes_first = PackOptions::default();
        assert_eq!(holes_first.first_packer, FirstPacker::HoleFilling);
        let horizons_first = PackOptions {
            first_packer: FirstPacker::Horizons,
            ..holes_first
        };
        let packing = pack_charts(&borrowed, &holes_first, &mut go()).unwrap();
        assert_guarantees(&check_packing(&borrowed, &packing, &holes_first), what);
        // Hole filling's search alone, as `pack_charts` starts it (the plain first fit).
        let (prepared, order, total) = prepared_in_order(&borrowed);
        let hole_order = padded_box_order(&borrowed, &prepared, &order, &holes_first, total);
        let ctx = Context {
            holes: true,
            ..Context::new(&borrowed, &prepared, &hole_order, &holes_first)
        };
        let alone = fit_to_page(&ctx, FitStart::FillAsGuess, &mut quiet()).unwrap();
        assert!(
            packing.texels_per_unit >= alone.texels_per_unit,
            "{what}: {} below hole filling's own {}",
            packing.texels_per_unit,
            alone.texels_per_unit
        );
        // The horizons' own search: where it is sparse, horizons first runs hole filling after
        // it, from the same start when the fill density is above the horizons'.
        let horizons = fit_to_page(
            &Context::new(&borrowed, &prepared, &order, &horizons_first),
            FitStart::Fill,
            &mut quiet(),
        )
        .unwrap();
        let fill = fill_density(total, ctx.page());
        if horizons.texels_per_unit * (1.0 + FIT_TOLERANCE) < fill {
            sparse_sets += 1;
            let before = pack_charts(&borrowed, &horizons_first, &mut go()).unwrap();
            // The same hole-filling search, except below the horizons' density, where
            // horizons first stops it (its floor): within the search's tolerance.
            assert!(
                packing.texels_per_unit >= before.texels_per_unit * (1.0 - HOLE_FIT_TOLERANCE),
                "{what}: {} below horizons first's {}",
                packing.texels_per_unit,
                before.texels_per_unit
            );
            assert!(
                packing.trials < before.trials,
                "{what}: {} trials, horizons first {}",
                packing.trials,
                before.trials
            );
        }
    }
    assert!(
        sparse_sets > 0,
        "no set where the horizons leave the page sparse"
    );
    // More charts take the contact-scored search: they search with the horizons first.
    let charts = mixed_set(60, 3);
    let borrowed = as_pack_charts(&charts);
    let horizons_first = PackOptions {
        first_packer: FirstPacker::Horizons,
        ..PackOptions::default()
    };
    assert_eq!(
        pack_charts(&borrowed, &PackOptions::default(), &mut go()).unwrap(),
        pack_charts(&borrowed, &horizons_first, &mut go()).unwrap()
    );
}

#[test]
fn many_charts_skip_the_horizons_search_where_hole_filling_fits_at_its_start() {
    // With HOLE_SCORED_MIN_CHARTS charts or more, fit to page, the horizons search first and
    // hole filling (contact-scored) after them, from their density, where they leave the page
    // sparse. When the horizons' first trial (at the fill density) does not fit, their density
    // ends below it, so hole filling starts at the fill density whatever it is: `pack_charts`
    // then gives the horizons up and packs with hole filling from there, when that fits. The
    // same packing as the full horizons' search followed by hole filling, in fewer trials.
    let quiet = || |_: (usize, usize)| ControlFlow::Continue(());
    let (mut skipped, mut fell_back) = (0, 0);
    for (what, charts) in [
        // The horizons fit at the fill density: their search as ever.
        ("mixed 60", mixed_set(60, 3)),
        // Rings and arcs with small discs: the horizons miss at the fill density, hole
        // filling fits there (discs inside the rings).
        (
            "rings and small discs",
            (0..60)
                .map(|k| {
                    if k < 20 {
                        strip(3.0 + 0.1 * f64::from(k), 0.4, 24, 3.5 + 0.1 * f64::from(k))
                    } else {
                        disc(12, 0.2 + 0.01 * f64::from(k))
                    }
                })
                .collect(),
        ),
        (
            "arcs and small discs",
            (0..60)
                .map(|k| {
                    if k < 15 {
                        strip(4.0 + 0.2 * f64::from(k), 0.5, 24, 2.5 + 0.1 * f64::from(k))
                    } else {
                        disc(10, 0.3 + 0.01 * f64::from(k))
                    }
                })
                .collect(),
        ),
        // Both miss at the fill density: both searches run.
        (
            "bent strips",
            (0..40)
                .map(|k| strip(2.0 + 0.2 * f64::from(k), 0.5, 12, 0.5 + 0.1 * f64::from(k)))
                .collect(),
        ),
    ] {
        assert!(charts.len() >= HOLE_SCORED_MIN_CHARTS);
        let borrowed = as_pack_charts(&charts);
        let options = PackOptions::default();
        let packing = pack_charts(&borrowed, &options, &mut go()).unwrap();
        assert_guarantees(&check_packing(&borrowed, &packing, &options), what);
        let (prepared, order, total) = prepared_in_order(&borrowed);
        let horizons_ctx = Context::new(&borrowed, &prepared, &order, &options);
        // The horizons' whole search, and whether its first trial fits.
        let horizons = fit_to_page(&horizons_ctx, FitStart::Fill, &mut quiet()).unwrap();
        let first =
            fit_to_page_unless_first_misses(&horizons_ctx, FitStart::Fill, &mut quiet()).unwrap();
        if let FirstTry::Found(t) = &first {
            // A first trial that fits: the search goes on as `fit_to_page`'s.
            assert_eq!(t.texels_per_unit, horizons.texels_per_unit, "{what}");
            continue;
        }
        let fill = fill_density(total, horizons_ctx.page());
        assert!(horizons.texels_per_unit < fill, "{what}");
        let hole_order = padded_box_order(&borrowed, &prepared, &order, &options, total);
        let hole_ctx = Context {
            holes: true,
            scored: true,
            ..Context::new(&borrowed, &prepared, &hole_order, &options)
        };
        // Hole filling at the fill density, and its search after the horizons.
        let fits_at_fill =
            fit_to_page_unless_first_misses(&hole_ctx, FitStart::Beat(0.0), &mut quiet()).unwrap();
        let fits_at_fill = matches!(fits_at_fill, FirstTry::Found(_));
        if !fits_at_fill {
            // Both searches run, as without the skip: never below the horizons.
            fell_back += 1;
            assert!(
                packing.texels_per_unit >= horizons.texels_per_unit,
                "{what}"
            );
            continue;
        }
        // (Within the search's tolerance below the fill density, hole filling after the
        // horizons would start just above it.)
        assert!(
            horizons.texels_per_unit * (1.0 + FIT_TOLERANCE) < fill,
            "{what}"
        );
        skipped += 1;
        // Fresh contexts count the trials of each search alone.
        let horizons_trials = {
            let ctx = Context::new(&borrowed, &prepared, &order, &options);
            fit_to_page(&ctx, FitStart::Fill, &mut quiet()).unwrap();
            ctx.trials.into_inner()
        };
        let after_ctx = Context {
            holes: true,
            scored: true,
            ..Context::new(&borrowed, &prepared, &hole_order, &options)
        };
        let after = fit_to_page(
            &after_ctx,
            FitStart::Beat(horizons.texels_per_unit),
            &mut quiet(),
        )
        .unwrap();
        let reference = after_ctx.output(&after);
        assert!(
            reference.texels_per_unit > horizons.texels_per_unit,
            "{what}"
        );
        // The horizons' first trial, then the same hole-filling search.
        assert_eq!(packing.trials, 1 + reference.trials, "{what}");
        assert!(horizons_trials > 1, "{what}");
        assert_eq!(
            Packing {
                trials: reference.trials,
                ..packing
            },
            reference,
            "{what}"
        );
    }
    assert_eq!((skipped, fell_back), (2, 1));
}

#[test]
fn a_search_above_a_density_that_fits_packs_denser_or_gives_up() {
    let sets = [
        ("12 mixed charts", mixed_set(12, 3), FirstPacker::Horizons),
        (
            "12 mixed charts, hole filling first",
            mixed_set(12, 3),
            FirstPacker::HoleFilling,
        ),
        (
            "40 mixed charts (contact-scored holes)",
            mixed_set(40, 5),
            FirstPacker::Horizons,
        ),
    ];
    for (what, charts, first_packer) in sets {
        let borrowed = as_pack_charts(&charts);
        let options = PackOptions {
            first_packer,
            ..PackOptions::default()
        };
        let best = pack_charts(&borrowed, &options, &mut go()).unwrap();
        let cache = PackCache::new();
        // Below the density the full search reaches: a denser packing, with every guarantee.
        let low = best.texels_per_unit * 0.9;
        let above = pack_charts_above(&borrowed, &options, low, &cache, &mut go())
            .unwrap()
            .unwrap_or_else(|| panic!("{what}: nothing found above {low}"));
        assert!(
            above.texels_per_unit > low,
            "{what}: {}",
            above.texels_per_unit
        );
        assert_guarantees(&check_packing(&borrowed, &above, &options), what);
        // Where the charts would cover twice the page, nothing fits above: the search gives up
        // instead of stepping down to what fits.
        let (_, _, total_area_m2) = prepared_in_order(&borrowed);
        let page = [options.width_texels, options.height_texels];
        let too_dense = fill_density(total_area_m2, page) * (2.0 / FIT_START_FILL).sqrt();
        let none = pack_charts_above(&borrowed, &options, too_dense, &cache, &mut go()).unwrap();
        assert!(
            none.is_none(),
            "{what}: a packing above an impossible density"
        );
    }
    // Only fit-to-page, from a finite positive density.
    let charts = mixed_set(4, 1);
    let borrowed = as_pack_charts(&charts);
    let cache = PackCache::new();
    let fixed = PackOptions {
        density: TexelDensity::TexelsPerUnit(10.0),
        ..PackOptions::default()
    };
    for (options, d) in [
        (fixed, 10.0),
        (PackOptions::default(), f64::NAN),
        (PackOptions::default(), 0.0),
    ] {
        let r = pack_charts_above(&borrowed, &options, d, &cache, &mut go());
        assert!(
            matches!(r, Err(PackError::InvalidOption { .. })),
            "{d}: {r:?}"
        );
    }
}

/// Strips that no cut can shorten (one quad each, 20 times longer than wide) set the density by
/// their length: laid along the page's diagonal they pack denser than along a side, which is
/// all that 4 rotations allow (only 90° turns), and their guarantees hold.
#[test]
fn long_strips_pack_along_the_diagonal() {
    let charts: Vec<OwnedChart> = (0..3).map(|_| strip(20.0, 1.0, 1, 0.0)).collect();
    let efficiency = |rotations: u32| {
        let options = PackOptions {
            rotations,
            ..PackOptions::default()
        };
        let (packing, check) = pack(&charts, &options);
        assert_guarantees(&check, &format!("{rotations} rotations"));
        let d = packing.texels_per_unit;
        (60.0 * d * d / (1024.0 * 1024.0), packing)
    };
    let (along_sides, _) = efficiency(4);
    let (diagonal, packing) = efficiency(16);
    // Along a side: at most the page's side per 20 m, 3 · 20 m² at 1024/20 texels per metre.
    assert!(along_sides <= 0.15 + 1e-9, "{along_sides}");
    assert!(
        diagonal >= 1.4 * along_sides,
        "{diagonal} against {along_sides}"
    );
    // Some strip is turned an eighth: its long edge runs at 45° on the page.
    let turned = packing.charts.iter().any(|c| {
        let (a, b) = (c.uv[0], c.uv[2]);
        let (dx, dy) = ((b[0] - a[0]).abs(), (b[1] - a[1]).abs());
        dx > 0.1 && (dx - dy).abs() < 1e-3 * dx
    });
    assert!(turned, "{:?}", packing.charts);
}
