//! Oracle tests of the stretch optimiser: L∞ never rises and nothing flips or crosses (property
//! test over random and perturbed charts with slivers and zero-area faces), recomputed with the
//! report's 3-D formulas (independent of the optimiser's 2-D frame code); a developable patch
//! stays isometric; a distorted developable patch gets close to isometric.
use proptest::prelude::*;

use super::{chart_stretch, optimize_chart_stretch, StretchChart};
use crate::atlas::parameterize::defects::{boundary_crossing, vertex_fold};
use crate::atlas::parameterize::test_meshes::grid;
use crate::atlas::parameterize::{flatten_chart, ChartMesh, FlattenOptions};
use crate::atlas::progress::{Stage, StageProgress};

/// The chart's (L2, L∞) by the report's formulas (`measure/stretch.rs`: the 3-D Jacobian
/// columns `Ss`, `St`, the metric `a, b, c`, its eigenvalues), with the chart's own scale
/// `k = Σ|A2| / ΣA3`, over the faces not flagged zero-area; `None` when such a face is not
/// positively oriented.
fn oracle_stretch(cm: &ChartMesh, zero: &[bool], uv: &[[f64; 2]]) -> Option<(f64, f64)> {
    let mut faces = Vec::new();
    let (mut sum2, mut sum3) = (0.0, 0.0);
    for (t, &z) in cm.triangles.iter().zip(zero) {
        if z {
            continue;
        }
        let p = t.map(|i| cm.positions_m[i as usize]);
        let q = t.map(|i| uv[i as usize]);
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
        faces.push((dot(ss, ss), dot(ss, st), dot(st, st), a3));
        sum2 += a2;
        sum3 += a3;
    }
    let k = sum2 / sum3;
    let (mut l2, mut linf) = (0.0, 0.0f64);
    for (a, b, c, a3) in faces {
        let (a, b, c) = (a * k, b * k, c * k);
        let root = ((a - c) * (a - c) + 4.0 * b * b).sqrt();
        let big = (0.5 * (a + c + root)).sqrt();
        let small = (0.5 * (a + c - root)).max(0.0).sqrt();
        l2 += 0.5 * (a + c) * a3;
        linf = linf.max(big).max(1.0 / small);
    }
    Some(((l2 / sum3).sqrt(), linf))
}

pub(crate) fn signed2(uv: &[[f64; 2]], t: [u32; 3]) -> f64 {
    let q = t.map(|i| uv[i as usize]);
    (q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[2][0] - q[0][0]) * (q[1][1] - q[0][1])
}

/// A random chart: an `n × m` grid height field (heights, xy jitter) with optional sliver rows
/// (3-D row spacing `sliver`), zero-area "ears" on the bottom boundary (a vertex at the 3-D
/// midpoint of a boundary edge), and its UV: the xy projection (valid for a height field),
/// randomly perturbed where that stays valid.
#[derive(Debug, Clone)]
pub(crate) struct Case {
    pub(crate) chart: ChartMesh,
    pub(crate) zero: Vec<bool>,
    pub(crate) uv: Vec<[f64; 2]>,
}

#[allow(clippy::too_many_arguments)] // one per random ingredient of a case
pub(crate) fn case(
    n: usize,
    m: usize,
    heights: &[f64],
    jitter: &[(f64, f64)],
    sliver_row: Option<(usize, f64)>,
    ears: &[usize],
    uv_noise: &[(f64, f64)],
    uv_amp: f64,
) -> Case {
    let row_y = |j: usize| -> f64 {
        let mut y = 0.0;
        for r in 0..j {
            y += match sliver_row {
                Some((s, h)) if s == r => h,
                _ => 1.0,
            };
        }
        y
    };
    let mut chart = grid(n, m, |x, y| {
        let (i, j) = (x as usize, y as usize);
        let k = (j * (n + 1) + i) % heights.len();
        let (jx, jy) = jitter[k % jitter.len()];
        let inner = i > 0 && i < n && j > 0 && j < m;
        let (dx, dy) = if inner { (jx, jy) } else { (0.0, 0.0) };
        // Jitter is a fraction of the smaller of the two adjacent row spacings.
        let h = |r: usize| match sliver_row {
            Some((s, hh)) if s == r => hh,
            _ => 1.0,
        };
        let sy = if j > 0 { h(j - 1).min(h(j)) } else { h(0) };
        [x + 0.2 * dx, row_y(j) + 0.2 * dy * sy, heights[k]]
    });
    let mut uv: Vec<[f64; 2]> = chart.positions_m.iter().map(|p| [p[0], p[1]]).collect();
    let mut zero = vec![false; chart.triangles.len()];
    // Ears on the bottom row: edge (i,0)→(i+1,0) is a boundary edge of triangle
    // [(i,0),(i+1,0),(i+1,1)], traversed i → i+1; the ear is (i+1, i, mid) (reverse direction).
    for &i in ears {
        let i = i % n;
        let (a, b) = (i as u32, i as u32 + 1);
        let (pa, pb) = (chart.positions_m[a as usize], chart.positions_m[b as usize]);
        let mid = [0, 1, 2].map(|c| 0.5 * (pa[c] + pb[c]));
        let v = chart.positions_m.len() as u32;
        let has = |x: u32, y: u32| {
            chart
                .triangles
                .iter()
                .any(|t| (0..3).any(|k| t[k] == x && t[(k + 1) % 3] == y))
        };
        if has(a, b) && !has(b, a) {
            chart.positions_m.push(mid);
            let (ua, ub) = (uv[a as usize], uv[b as usize]);
            uv.push([0.5 * (ua[0] + ub[0]), 0.5 * (ua[1] + ub[1])]);
            chart.triangles.push([b, a, v]);
            zero.push(true);
        }
    }
    // Perturb UVs of vertices used only by positive faces where every face stays positive.
    for (v, &(dx, dy)) in uv_noise.iter().enumerate() {
        let v = v % (chart.positions_m.len());
        let old = uv[v];
        uv[v] = [old[0] + uv_amp * dx, old[1] + uv_amp * dy];
        let ok = chart.triangles.iter().zip(&zero).all(|(t, &z)| {
            !t.contains(&(v as u32)) || {
                let a = signed2(&uv, *t);
                if z {
                    a >= 0.0
                } else {
                    a > 0.0
                }
            }
        }) && boundary_crossing(&chart, &uv).is_none();
        if !ok {
            uv[v] = old;
        }
    }
    Case { chart, zero, uv }
}

pub(crate) fn arb_case() -> impl Strategy<Value = Case> {
    (2usize..7, 2usize..7)
        .prop_flat_map(|(n, m)| {
            let verts = (n + 1) * (m + 1);
            (
                Just(n),
                Just(m),
                prop::collection::vec(-1.5f64..1.5, verts),
                prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0), verts),
                prop::option::of((0usize..m, prop_oneof![Just(1e-6), Just(1e-3), Just(0.05)])),
                prop::collection::vec(0usize..8, 0..3),
                prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0), 0..40),
                prop_oneof![Just(0.0), Just(0.1), Just(0.4)],
            )
        })
        .prop_map(|(n, m, h, j, s, e, u, a)| case(n, m, &h, &j, s, &e, &u, a))
}

/// The oracle's (L2, L∞) before, and the optimised UVs.
type Checked = (Option<(f64, f64)>, Vec<[f64; 2]>);

/// Runs the optimiser and checks every guarantee with the oracle.
fn check_guarantees(c: &Case, passes: u32) -> Result<Checked, TestCaseError> {
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
    let before = oracle_stretch(&c.chart, &c.zero, &c.uv);
    let mut uv = c.uv.clone();
    let outcome = optimize_chart_stretch(&chart, &mut uv, passes);
    prop_assert_eq!(
        outcome.passes_undone,
        0,
        "a per-move test let an invalid move through"
    );
    if outcome.moves == 0 && outcome.global_steps == 0 {
        prop_assert_eq!(&uv, &c.uv, "no move kept but the map changed");
        return Ok((before, uv));
    }
    let (l2_0, linf_0) = before.expect("a moved chart was valid");
    let (l2_1, linf_1) = oracle_stretch(&c.chart, &c.zero, &uv)
        .ok_or_else(|| TestCaseError::fail("a positive-area face flipped or collapsed"))?;
    prop_assert!(
        linf_1 <= linf_0 * (1.0 + 1e-9),
        "L∞ rose: {} -> {}",
        linf_0,
        linf_1
    );
    prop_assert!(l2_1 <= l2_0 * (1.0 + 1e-9), "L2 rose: {} -> {}", l2_0, l2_1);
    for ((t, &z), k) in c.chart.triangles.iter().zip(&c.zero).zip(0..) {
        let (a0, a1) = (signed2(&c.uv, *t), signed2(&uv, *t));
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
    Ok((before, uv))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    /// The optimiser never raises L∞ (nor L2), never flips a face of positive area, never makes
    /// a zero-area face flipped, never crosses the boundary or folds a vertex — on random height
    /// fields with slivers (aspect 1e-6) and zero-area ears, from projected and perturbed UVs.
    #[test]
    fn never_raises_linf_never_flips(c in arb_case(), passes in 1u32..6) {
        check_guarantees(&c, passes)?;
    }
}

/// A cylinder section (developable: a bent strip of planar quads) with `n × m` quads, and
/// its exact unrolling.
pub(crate) fn bent_plane(n: usize, m: usize) -> (ChartMesh, Vec<[f64; 2]>) {
    let radius = 2.0;
    let angle = 2.0; // radians of arc
    let chart = grid(n, m, |x, y| {
        let a = angle * x / n as f64;
        [radius * a.sin(), y * 0.5, radius * (1.0 - a.cos())]
    });
    let uv = chart
        .positions_m
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let i = k % (n + 1);
            // Adjacent columns are a chord apart in 3-D.
            let chord = 2.0 * radius * (0.5 * angle / n as f64).sin();
            [chord * i as f64, p[1]]
        })
        .collect();
    (chart, uv)
}

/// A developable patch unrolled exactly stays isometric: L2 and L∞ stay 1.
#[test]
fn developable_patch_stays_isometric() {
    let (chart, uv0) = bent_plane(10, 6);
    let zero = vec![false; chart.triangles.len()];
    let (l2, linf) = oracle_stretch(&chart, &zero, &uv0).unwrap();
    assert!(
        (l2 - 1.0).abs() < 1e-9 && (linf - 1.0).abs() < 1e-9,
        "{l2} {linf}"
    );
    let mut uv = uv0.clone();
    let sc = StretchChart {
        positions_m: &chart.positions_m,
        triangles: &chart.triangles,
        zero_area: &zero,
    };
    optimize_chart_stretch(&sc, &mut uv, 6);
    let (l2, linf) = oracle_stretch(&chart, &zero, &uv).unwrap();
    assert!((l2 - 1.0).abs() < 1e-9, "L2 {l2}");
    assert!((linf - 1.0).abs() < 1e-9, "L∞ {linf}");
    // Isometric up to a rigid motion: every UV edge keeps its 3-D length.
    for t in &chart.triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            let (p, q) = (chart.positions_m[a], chart.positions_m[b]);
            let l3 = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
            let l2d = ((uv[a][0] - uv[b][0]).powi(2) + (uv[a][1] - uv[b][1]).powi(2)).sqrt();
            assert!(
                (l3 - l2d).abs() < 1e-9 * l3.max(1.0),
                "edge {a}-{b}: {l3} vs {l2d}"
            );
        }
    }
}

/// From a smoothly distorted (valid) unrolling of a developable patch, the optimiser moves
/// most of the way back to isometric: the excess L2 and L∞ shrink a lot.
#[test]
fn distorted_developable_patch_gets_close_to_isometric() {
    let (chart, uv0) = bent_plane(12, 8);
    let zero = vec![false; chart.triangles.len()];
    // u' = u + 0.25 u² / len: area grows toward one end (a valid, non-isometric map).
    let len = uv0.iter().map(|p| p[0]).fold(0.0, f64::max);
    let mut uv: Vec<[f64; 2]> = uv0
        .iter()
        .map(|p| {
            [
                p[0] + 0.25 * p[0] * p[0] / len,
                p[1] * (1.0 + 0.2 * p[0] / len),
            ]
        })
        .collect();
    let (l2_0, linf_0) = oracle_stretch(&chart, &zero, &uv).unwrap();
    assert!(l2_0 > 1.01 && linf_0 > 1.2, "{l2_0} {linf_0}");
    let sc = StretchChart {
        positions_m: &chart.positions_m,
        triangles: &chart.triangles,
        zero_area: &zero,
    };
    let outcome = optimize_chart_stretch(&sc, &mut uv, 20);
    let (l2_1, linf_1) = oracle_stretch(&chart, &zero, &uv).unwrap();
    assert!(outcome.moves > 0);
    assert!(l2_1 - 1.0 < 0.5 * (l2_0 - 1.0), "L2 {l2_0} -> {l2_1}");
    assert!(
        linf_1 - 1.0 < 0.7 * (linf_0 - 1.0),
        "L∞ {linf_0} -> {linf_1}"
    );
    // The optimiser's own figures agree with the oracle.
    let own = chart_stretch(&sc, &uv).unwrap();
    assert!((own.0 - l2_1).abs() < 1e-9 && (own.1 - linf_1).abs() < 1e-9 * linf_1);
}

/// On LSCM maps of curved charts (hemisphere, noisy height field) the optimiser lowers L∞ and
/// L2, within its guarantees.
#[test]
fn lowers_stretch_of_lscm_maps() {
    use crate::atlas::parameterize::test_meshes::{hemisphere, noisy_height_field};
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
        let c = Case {
            chart: chart.clone(),
            zero,
            uv: map.uv.clone(),
        };
        let (before, uv) = check_guarantees(&c, 4).unwrap();
        let (l2_0, linf_0) = before.unwrap();
        let (l2_1, linf_1) = oracle_stretch(&c.chart, &c.zero, &uv).unwrap();
        assert!(
            l2_1 < l2_0 && linf_1 < linf_0,
            "{name}: L2 {l2_0} -> {l2_1}, L∞ {linf_0} -> {linf_1}"
        );
    }
}

/// Zero-area faces do not block the chart: with ears on every bottom edge, the interior still
/// moves and stretch still drops.
#[test]
fn zero_area_faces_do_not_block() {
    let n = 6;
    let heights: Vec<f64> = (0..49).map(|k| ((k * 7919) % 13) as f64 * 0.15).collect();
    let c = case(
        n,
        n,
        &heights,
        &[(0.0, 0.0)],
        None,
        &[0, 1, 2, 3, 4, 5],
        &[],
        0.0,
    );
    assert!(c.zero.iter().filter(|&&z| z).count() >= 5);
    let (before, uv) = check_guarantees(&c, 4).unwrap();
    let after = oracle_stretch(&c.chart, &c.zero, &uv).unwrap();
    assert!(after.0 < before.unwrap().0, "{before:?} -> {after:?}");
}
