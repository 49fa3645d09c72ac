//! Oracle tests of chart parameterization through the public API only: every method on every
//! disk-shaped test mesh (generated here, no external files), checked against quantities
//! recomputed independently of the solvers.
use std::ops::ControlFlow;

use texatlas::atlas::parameterize::test_meshes::{
    self, cotan_conformal_energy as cotan_energy, spherical_cap as cap,
};
use texatlas::atlas::parameterize::{
    flatten_chart, ChartMesh, FlattenOptions, HlscmOptions, ParameterizeError, ParameterizeMethod,
};
use texatlas::atlas::{ProgressFn, Stage, StageProgress};

/// An `n × n` grid over the unit square lifted to the height field `height(x, y)`.
fn grid(n: usize, height: impl Fn(f64, f64) -> f64) -> ChartMesh {
    test_meshes::grid(n, n, |i, j| {
        let (x, y) = (i / n as f64, j / n as f64);
        [x, y, height(x, y)]
    })
}

fn signed_areas(chart: &ChartMesh, uv: &[[f64; 2]]) -> Vec<f64> {
    chart
        .triangles
        .iter()
        .map(|t| {
            let q = t.map(|i| uv[i as usize]);
            (q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[2][0] - q[0][0]) * (q[1][1] - q[0][1])
        })
        .collect()
}

fn meshes() -> Vec<(&'static str, ChartMesh)> {
    vec![
        ("flat", grid(20, |_, _| 0.0)),
        (
            "bumps",
            grid(40, |x, y| 0.1 * (6.0 * x).sin() * (5.0 * y).cos()),
        ),
        (
            "noisy",
            grid(30, |x, y| {
                0.05 * (9.0 * x).sin() + 0.004 * ((x * 997.0 + y * 131.0).sin())
            }),
        ),
        ("hemisphere", cap(40, 20, std::f64::consts::FRAC_PI_2)),
        ("deep cap", cap(32, 24, 2.2)),
    ]
}

fn options(method: ParameterizeMethod) -> FlattenOptions {
    FlattenOptions {
        method,
        hlscm: HlscmOptions {
            coarsest_max_vertices: 150,
            ..HlscmOptions::default()
        },
        ..FlattenOptions::default()
    }
}

#[test]
fn every_method_gives_finite_unflipped_maps_with_the_reported_energy() {
    for (name, chart) in meshes() {
        let direct = flatten_chart(
            &chart,
            &options(ParameterizeMethod::Direct),
            &mut StageProgress::ignored(Stage::Parameterize),
        )
        .expect(name);
        for method in [
            ParameterizeMethod::Direct,
            ParameterizeMethod::Hierarchical,
            ParameterizeMethod::ConjugateGradient,
            ParameterizeMethod::Auto,
        ] {
            let map = flatten_chart(
                &chart,
                &options(method),
                &mut StageProgress::ignored(Stage::Parameterize),
            )
            .expect(name);
            assert_eq!(map.uv.len(), chart.positions_m.len());
            assert!(
                map.uv.iter().all(|p| p[0].is_finite() && p[1].is_finite()),
                "{name}"
            );
            // The typed flip list agrees with an independent signed-area computation.
            let flips = signed_areas(&chart, &map.uv)
                .iter()
                .filter(|&&a| a <= 0.0)
                .count();
            assert_eq!(flips, map.flipped_faces.len(), "{name} {method:?}");
            assert!(
                map.is_valid(),
                "{name} {method:?}: {} flips",
                map.flipped_faces.len()
            );
            // Reported energy equals the cotangent-formula recomputation.
            let e = cotan_energy(&chart, &map.uv);
            let scale: f64 = map
                .uv
                .iter()
                .map(|p| p[0] * p[0] + p[1] * p[1])
                .sum::<f64>()
                / map.uv.len() as f64;
            assert!(
                (e - map.conformal_energy).abs()
                    <= 1e-9 * map.conformal_energy.abs() + 1e-12 * scale,
                "{name} {method:?}: {e} vs {}",
                map.conformal_energy
            );
            // Every method reaches the direct solve's energy within 1e-4 relative (or the
            // absolute rounding floor on the developable flat patch).
            let floor = 1e-10 * scale;
            assert!(
                (map.conformal_energy - direct.conformal_energy).abs()
                    <= 1e-4 * direct.conformal_energy + floor,
                "{name} {method:?}: {} vs direct {}",
                map.conformal_energy,
                direct.conformal_energy
            );
            assert_ne!(map.method_used, ParameterizeMethod::Auto);
        }
    }
}

#[test]
fn hierarchical_really_uses_several_levels_here() {
    let (_, chart) = meshes().swap_remove(1);
    let map = flatten_chart(
        &chart,
        &options(ParameterizeMethod::Hierarchical),
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .expect("ok");
    let report = map.hlscm.expect("report");
    assert!(report.levels.len() >= 2, "{report:?}");
    assert!(report.converged);
    assert!(report
        .levels
        .windows(2)
        .all(|w| w[0].vertices < w[1].vertices));
    assert_eq!(
        report.levels.last().map(|l| l.vertices),
        Some(chart.positions_m.len())
    );
}

#[test]
fn results_are_bit_identical_whatever_the_thread_count() {
    let (_, chart) = meshes().swap_remove(2);
    for method in [ParameterizeMethod::Direct, ParameterizeMethod::Hierarchical] {
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool")
                .install(|| {
                    flatten_chart(
                        &chart,
                        &options(method),
                        &mut StageProgress::ignored(Stage::Parameterize),
                    )
                    .expect("ok")
                })
        };
        let (a, b) = (run(1), run(3));
        assert!(a
            .uv
            .iter()
            .zip(&b.uv)
            .all(|(p, q)| p[0].to_bits() == q[0].to_bits() && p[1].to_bits() == q[1].to_bits()));
        assert_eq!(a.conformal_energy.to_bits(), b.conformal_energy.to_bits());
    }
}

#[test]
fn monitor_can_cancel_iterative_solves() {
    let (_, chart) = meshes().swap_remove(1);
    for method in [
        ParameterizeMethod::ConjugateGradient,
        ParameterizeMethod::Hierarchical,
    ] {
        let mut calls = 0;
        let mut stop = ProgressFn(|_, _, _| {
            calls += 1;
            ControlFlow::Break(())
        });
        let result = flatten_chart(
            &chart,
            &options(method),
            &mut StageProgress::new(Stage::Parameterize, &mut stop),
        );
        assert_eq!(result, Err(ParameterizeError::Cancelled), "{method:?}");
        assert_eq!(calls, 1);
    }
}

#[test]
fn bad_charts_are_typed_errors_never_panics() {
    let mut chart = grid(3, |_, _| 0.0);
    chart.triangles.push([0, 1, 99]);
    assert!(matches!(
        flatten_chart(
            &chart,
            &FlattenOptions::default(),
            &mut StageProgress::ignored(Stage::Parameterize)
        ),
        Err(ParameterizeError::IndexOutOfRange { .. })
    ));
    let closed = ChartMesh {
        positions_m: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]],
    };
    assert!(matches!(
        flatten_chart(
            &closed,
            &FlattenOptions::default(),
            &mut StageProgress::ignored(Stage::Parameterize)
        ),
        Err(ParameterizeError::NotADisk { .. })
    ));
}
