//! Oracle tests of ASP: the energy against an independent formula (the singular values of the
//! texture-to-surface Jacobian from the report's 3-D formulas; at θ = 0 the MIPS energy), the
//! analytic gradient against differences, a developable patch coming out isometric up to a rigid
//! motion, relaxation never flipping (property test over random perturbed charts with slivers
//! and zero-area faces), and determinism.
use proptest::prelude::*;

use super::{
    asp_energy, relax_chart_asp, relax_chart_asp_hierarchical, relax_until, AspFace, MAX_SWEEPS,
};
use crate::atlas::parameterize::defects::{boundary_crossing, vertex_fold};
use crate::atlas::parameterize::stretch::tests::{arb_case, bent_plane, signed2, Case};
use crate::atlas::parameterize::test_meshes::{hemisphere, noisy_height_field, spherical_cap};
use crate::atlas::parameterize::{flatten_chart, ChartMesh, FlattenOptions, StretchChart};
use crate::atlas::progress::{Stage, StageProgress};

/// The singular values `(Γ, γ)` of the affine map from texture to surface of one face
/// (Sander et al. 2001: the 3-D derivatives `Ss`, `St` along u and v, the metric `a, b, c` and
/// its eigenvalues), and the face's model area; `None` when the UV triangle is not positive.
fn inverse_singular_values(p: [[f64; 3]; 3], q: [[f64; 2]; 3]) -> Option<(f64, f64, f64)> {
    let e1 = [0, 1, 2].map(|c| p[1][c] - p[0][c]);
    let e2 = [0, 1, 2].map(|c| p[2][c] - p[0][c]);
    let cr = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    let a3 = 0.5 * (cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]).sqrt();
    let (ds1, dt1) = (q[1][0] - q[0][0], q[1][1] - q[0][1]);
    let (ds2, dt2) = (q[2][0] - q[0][0], q[2][1] - q[0][1]);
    let a2 = 0.5 * (ds1 * dt2 - ds2 * dt1);
    if a2.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let ss: [f64; 3] = std::array::from_fn(|i| (e1[i] * dt2 - e2[i] * dt1) / (2.0 * a2));
    let st: [f64; 3] = std::array::from_fn(|i| (-e1[i] * ds2 + e2[i] * ds1) / (2.0 * a2));
    let dot = |x: [f64; 3], y: [f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    let (a, b, c) = (dot(ss, ss), dot(ss, st), dot(st, st));
    let root = ((a - c) * (a - c) + 4.0 * b * b).sqrt();
    let big = (0.5 * (a + c + root)).sqrt();
    // γ = Γ·γ / Γ, with Γ·γ = sqrt(ac − b²) = A3 / A2 (the area ratio; the determinant form
    // loses all precision on slivers).
    let small = a3 / a2 / big;
    Some((big, small, a3))
}

/// The MIPS energy of one face (Hormann & Greiner): `σ1/σ2 + σ2/σ1` of the surface-to-texture
/// map, whose singular values are `1/γ ≥ 1/Γ`.
fn mips(big: f64, small: f64) -> f64 {
    let (s1, s2) = (1.0 / small, 1.0 / big);
    s1 / s2 + s2 / s1
}

/// The ASP face energy `E_angle · E_area^θ` times model area, from the singular values.
fn oracle_face(p: [[f64; 3]; 3], q: [[f64; 2]; 3], theta: f64) -> Option<f64> {
    let (big, small, a3) = inverse_singular_values(p, q)?;
    let det = 1.0 / (big * small); // σ1·σ2 of surface → texture
    Some(a3 * mips(big, small) * (det + 1.0 / det).powf(theta))
}

/// A deterministic pseudo-random sequence in [-1, 1) (xorshift).
fn rng(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

#[test]
fn energy_equals_the_independent_formula_on_random_triangles() {
    let mut r = rng(22);
    let mut checked = 0;
    for k in 0..2000 {
        let p: [[f64; 3]; 3] = std::array::from_fn(|_| [r() * 3.0, r() * 3.0, r() * 3.0]);
        let mut q: [[f64; 2]; 3] = std::array::from_fn(|_| [r() * 2.0, r() * 2.0]);
        // Slivers in UV or in 3-D now and then.
        if k % 7 == 0 {
            q[2] = [
                0.5 * (q[0][0] + q[1][0]) + 1e-4 * r(),
                0.5 * (q[0][1] + q[1][1]) + 1e-4 * r(),
            ];
        }
        let Some(face) = AspFace::new(p) else {
            continue;
        };
        let theta = [0.0, 0.25, 0.5, 1.0, 2.0, 3.5][k % 6];
        let ours = face.energy(q, theta);
        let oracle = oracle_face(p, q, theta);
        match (ours, oracle) {
            (Some(a), Some(b)) => {
                assert!(
                    (a - b).abs() <= 1e-7 * b.abs(),
                    "θ {theta}: {a} vs oracle {b}"
                );
                checked += 1;
            }
            (None, None) => {}
            // A flipped face: infinite energy on both sides.
            (a, b) => panic!("defined on one side only: {a:?} vs {b:?} (θ {theta})"),
        }
        // θ = 0 is exactly the MIPS energy, written out from the singular values.
        if let (Some(a), Some((big, small, a3))) =
            (face.energy(q, 0.0), inverse_singular_values(p, q))
        {
            let m = a3 * mips(big, small);
            assert!((a - m).abs() <= 1e-7 * m, "MIPS {a} vs {m}");
        }
    }
    assert!(checked > 500, "{checked}");
}

#[test]
fn chart_energy_sums_the_face_oracle_and_isometry_is_its_minimum() {
    let (chart, uv) = bent_plane(6, 4);
    let zero = vec![false; chart.triangles.len()];
    let sc = StretchChart {
        positions_m: &chart.positions_m,
        triangles: &chart.triangles,
        zero_area: &zero,
    };
    let area: f64 = chart
        .triangles
        .iter()
        .map(|t| {
            let p = t.map(|i| chart.positions_m[i as usize]);
            let q = t.map(|i| uv[i as usize]);
            inverse_singular_values(p, q).unwrap().2
        })
        .sum();
    for theta in [0.0, 1.0, 2.0] {
        let e = asp_energy(&sc, &uv, theta).unwrap();
        // The isometric unrolling: σ1 = σ2 = 1, so E = 2·2^θ per unit area.
        let expect = area * 2.0 * 2f64.powf(theta);
        assert!(
            (e - expect).abs() < 1e-9 * expect,
            "θ {theta}: {e} vs {expect}"
        );
        // A uniform scaling keeps the MIPS energy and raises the others.
        let scaled: Vec<[f64; 2]> = uv.iter().map(|p| [1.3 * p[0], 1.3 * p[1]]).collect();
        let es = asp_energy(&sc, &scaled, theta).unwrap();
        if theta == 0.0 {
            assert!((es - e).abs() < 1e-9 * e);
        } else {
            assert!(es > e * (1.0 + 1e-3), "θ {theta}: {es} vs {e}");
        }
    }
    // A flipped face makes the energy undefined (infinite).
    let mut flipped = uv.clone();
    flipped[0] = [5.0, 5.0];
    assert!(asp_energy(&sc, &flipped, 1.0).is_none());
}

#[test]
fn gradient_matches_differences() {
    let mut r = rng(7);
    for k in 0..300 {
        let p: [[f64; 3]; 3] = std::array::from_fn(|_| [r(), r(), r()]);
        let q: [[f64; 2]; 3] = std::array::from_fn(|_| [r(), r()]);
        let Some(face) = AspFace::new(p) else {
            continue;
        };
        let theta = [0.0, 0.5, 1.0, 3.0][k % 4];
        let c = k % 3;
        let Some((e, g)) = face.energy_gradient(q, c, theta) else {
            continue;
        };
        let h = 1e-7;
        for d in 0..2 {
            let (mut qp, mut qm) = (q, q);
            qp[c][d] += h;
            qm[c][d] -= h;
            let (Some(ep), Some(em)) = (face.energy(qp, theta), face.energy(qm, theta)) else {
                continue;
            };
            let fd = (ep - em) / (2.0 * h);
            assert!(
                (fd - g[d]).abs() <= 1e-4 * (g[d].abs() + e),
                "θ {theta} corner {c} dim {d}: {} vs {fd}",
                g[d]
            );
        }
    }
}

/// Edge-length check: every UV edge has its 3-D length within `tol` (relative).
fn max_edge_error(chart: &ChartMesh, uv: &[[f64; 2]]) -> f64 {
    let mut worst = 0.0f64;
    for t in &chart.triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            let (p, q) = (chart.positions_m[a], chart.positions_m[b]);
            let l3 = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
            let l2 = ((uv[a][0] - uv[b][0]).powi(2) + (uv[a][1] - uv[b][1]).powi(2)).sqrt();
            worst = worst.max((l3 - l2).abs() / l3);
        }
    }
    worst
}

/// A developable patch (a cylinder strip cut open) comes out isometric up to a rigid motion:
/// from its LSCM map (conformal, wrong scale) and from a smoothly distorted valid unrolling.
#[test]
fn developable_patch_comes_out_isometric() {
    let (chart, exact) = bent_plane(8, 5);
    let zero = vec![false; chart.triangles.len()];
    let sc = StretchChart {
        positions_m: &chart.positions_m,
        triangles: &chart.triangles,
        zero_area: &zero,
    };
    let lscm = flatten_chart(
        &chart,
        &FlattenOptions::default(),
        &mut StageProgress::ignored(Stage::Parameterize),
    )
    .unwrap()
    .uv;
    let len = exact.iter().map(|p| p[0]).fold(0.0, f64::max);
    let distorted: Vec<[f64; 2]> = exact
        .iter()
        .map(|p| {
            [
                0.7 * (p[0] + 0.3 * p[0] * p[0] / len),
                0.7 * p[1] * (1.0 + 0.25 * p[0] / len),
            ]
        })
        .collect();
    assert!(max_edge_error(&chart, &distorted) > 0.2);
    for (name, start) in [("lscm", lscm), ("distorted", distorted)] {
        for theta in [0.5, 1.0, 2.0] {
            let mut uv = start.clone();
            let out = relax_until(&sc, &mut uv, theta, 2000, 0.0);
            assert!(out.relaxed && out.sweeps_undone == 0, "{name}: {out:?}");
            let err = max_edge_error(&chart, &uv);
            assert!(
                err < 2e-3,
                "{name} θ {theta}: edge length error {err} ({out:?})"
            );
        }
    }
}

/// Runs the relaxation and checks every guarantee with independent predicates.
fn check_never_flips(c: &Case, theta: f64, sweeps: usize) -> Result<(), TestCaseError> {
    let chart = StretchChart {
        positions_m: &c.chart.positions_m,
        triangles: &c.chart.triangles,
        zero_area: &c.zero,
    };
    let solid = ChartMesh {
        positions_m: c.chart.positions_m.clone(),
        triangles: c
            .chart
            .triangles
            .iter()
            .zip(&c.zero)
            .filter(|(_, &z)| !z)
            .map(|(t, _)| *t)
            .collect(),
    };
    let start_valid = c
        .chart
        .triangles
        .iter()
        .zip(&c.zero)
        .all(|(t, &z)| z || signed2(&c.uv, *t) > 0.0)
        && boundary_crossing(&solid, &c.uv).is_none()
        && vertex_fold(&solid, &c.uv).is_none();
    let mut uv = c.uv.clone();
    let out = relax_chart_asp(&chart, &mut uv, theta, sweeps);
    prop_assert_eq!(
        out.sweeps_undone,
        0,
        "a per-move test let an invalid move through"
    );
    if !out.relaxed {
        prop_assert_eq!(&uv, &c.uv, "not relaxed but the map changed");
        prop_assert!(!start_valid, "a valid start was refused: {:?}", out);
        return Ok(());
    }
    prop_assert!(start_valid, "an invalid start was relaxed");
    // The start scaled to UV area = model area: the relaxation never raises its energy.
    let (mut a2, mut a3) = (0.0, 0.0);
    for (t, &z) in c.chart.triangles.iter().zip(&c.zero) {
        if !z {
            a2 += 0.5 * signed2(&c.uv, *t);
            let p = t.map(|i| c.chart.positions_m[i as usize]);
            a3 += inverse_singular_values(p, t.map(|i| c.uv[i as usize])).map_or(0.0, |x| x.2);
        }
    }
    let s = (a3 / a2).sqrt();
    let scaled: Vec<[f64; 2]> = c.uv.iter().map(|p| [p[0] * s, p[1] * s]).collect();
    let oracle = |uv: &[[f64; 2]]| -> Option<f64> {
        let mut sum = 0.0;
        for (t, &z) in c.chart.triangles.iter().zip(&c.zero) {
            if z {
                continue;
            }
            let p = t.map(|i| c.chart.positions_m[i as usize]);
            if AspFace::new(p).is_none() {
                continue;
            }
            sum += oracle_face(p, t.map(|i| uv[i as usize]), theta)?;
        }
        Some(sum)
    };
    let e0 = oracle(&scaled).ok_or_else(|| TestCaseError::fail("start not positive"))?;
    let e1 = oracle(&uv).ok_or_else(|| TestCaseError::fail("a positive-area face flipped"))?;
    prop_assert!(e1 <= e0 * (1.0 + 1e-9), "energy rose: {} -> {}", e0, e1);
    for ((t, &z), k) in c.chart.triangles.iter().zip(&c.zero).zip(0..) {
        let (a0, a1) = (signed2(&scaled, *t), signed2(&uv, *t));
        if z {
            prop_assert!(
                a1 >= a0.min(0.0),
                "zero-area face {} flipped: {} -> {}",
                k,
                a0,
                a1
            );
        } else {
            prop_assert!(a1 > 0.0, "face {} flipped", k);
        }
    }
    prop_assert!(
        boundary_crossing(&solid, &uv).is_none(),
        "boundary crosses itself"
    );
    prop_assert!(vertex_fold(&solid, &uv).is_none(), "a vertex folds");
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    /// Relaxation from a flip-free start never flips a face of positive area, never makes a
    /// zero-area face flipped, never crosses the boundary or folds a vertex, and never raises
    /// the energy — on random height fields with slivers (aspect 1e-6) and zero-area ears, from
    /// projected and perturbed UVs, for θ in [0, 4].
    #[test]
    fn relaxation_from_a_flip_free_start_never_flips(
        c in arb_case(),
        theta in 0.0f64..4.0,
        sweeps in 1usize..8,
    ) {
        check_never_flips(&c, theta, sweeps)?;
    }
}

/// On LSCM maps of curved charts the relaxation lowers the energy and, for θ > 0, the spread of
/// the per-face area ratio; the result is the same bits on a second run (the relaxation is
/// sequential, so it does not depend on the thread count either).
#[test]
fn lowers_area_distortion_of_lscm_maps_deterministically() {
    for (name, chart) in [
        ("hemisphere", hemisphere(24, 10)),
        ("height field", noisy_height_field(16, 0.5, 7)),
    ] {
        let map = flatten_chart(
            &chart,
            &FlattenOptions::default(),
            &mut StageProgress::ignored(Stage::Parameterize),
        )
        .unwrap();
        let zero = vec![false; chart.triangles.len()];
        let sc = StretchChart {
            positions_m: &chart.positions_m,
            triangles: &chart.triangles,
            zero_area: &zero,
        };
        let spread = |uv: &[[f64; 2]]| {
            let ratios: Vec<f64> = chart
                .triangles
                .iter()
                .map(|t| {
                    let p = t.map(|i| chart.positions_m[i as usize]);
                    let (big, small, _) =
                        inverse_singular_values(p, t.map(|i| uv[i as usize])).unwrap();
                    (big * small).ln()
                })
                .collect();
            let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
            (ratios.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / ratios.len() as f64).sqrt()
        };
        let mut uv = map.uv.clone();
        let out = relax_chart_asp(&sc, &mut uv, 1.0, MAX_SWEEPS);
        assert!(out.relaxed && out.moves > 0, "{name}: {out:?}");
        assert!(out.energy_after < out.energy_before, "{name}: {out:?}");
        let (s0, s1) = (spread(&map.uv), spread(&uv));
        assert!(s1 < 0.8 * s0, "{name}: log-area spread {s0} -> {s1}");
        let mut again = map.uv.clone();
        let out2 = relax_chart_asp(&sc, &mut again, 1.0, MAX_SWEEPS);
        assert_eq!(out, out2);
        assert!(uv
            .iter()
            .zip(&again)
            .all(|(a, b)| a[0].to_bits() == b[0].to_bits() && a[1].to_bits() == b[1].to_bits()));
    }
}

/// Independent validity: every face positive, simple boundary, no fold.
fn valid(chart: &ChartMesh, uv: &[[f64; 2]]) -> bool {
    chart.triangles.iter().all(|t| signed2(uv, *t) > 0.0)
        && boundary_crossing(chart, uv).is_none()
        && vertex_fold(chart, uv).is_none()
}

/// The hierarchy runs on charts large enough for several levels, keeps the map valid, and
/// reaches a lower energy than the same sweeps on the finest level alone (area moves across
/// the chart at the coarse levels); bit-identical on a second run.
#[test]
fn hierarchy_is_valid_and_beats_one_level() {
    for (name, chart) in [
        ("hemisphere", hemisphere(48, 20)),
        ("spherical cap", spherical_cap(40, 24, 1.3)),
    ] {
        let map = flatten_chart(
            &chart,
            &FlattenOptions::default(),
            &mut StageProgress::ignored(Stage::Parameterize),
        )
        .unwrap();
        let zero = vec![false; chart.triangles.len()];
        let sc = StretchChart {
            positions_m: &chart.positions_m,
            triangles: &chart.triangles,
            zero_area: &zero,
        };
        for theta in [0.5, 1.0] {
            let mut single = map.uv.clone();
            let one = relax_chart_asp(&sc, &mut single, theta, 8);
            let mut hier = map.uv.clone();
            let h = relax_chart_asp_hierarchical(&sc, &mut hier, theta, 8);
            assert!(h.relaxed && h.levels >= 2, "{name}: {h:?}");
            assert!(valid(&chart, &hier), "{name} θ {theta}: invalid map");
            assert!(h.energy_after <= h.energy_before, "{name}: {h:?}");
            assert!(
                h.energy_after < one.energy_after,
                "{name} θ {theta}: hierarchy {} vs one level {}",
                h.energy_after,
                one.energy_after
            );
            let e = asp_energy(&sc, &hier, theta).unwrap();
            assert!((e - h.energy_after).abs() <= 1e-9 * e, "{e} vs {h:?}");
            let mut again = map.uv.clone();
            assert_eq!(relax_chart_asp_hierarchical(&sc, &mut again, theta, 8), h);
            assert_eq!(again, hier);
        }
    }
}
