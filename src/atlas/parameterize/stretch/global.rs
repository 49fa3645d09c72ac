//! Global descent of a chart's L2 stretch: the first step of [`super::optimize_chart_stretch`].
//!
//! Purpose: the vertex moves of the L∞ and L2 phases are Gauss–Seidel sweeps, which lower
//! local distortion fast but spread a chart-wide scale error (an LSCM map shrinks the far end of
//! a long arm) by one ring per pass. This step moves every vertex at once along the gradient of
//! the chart's L2 stretch preconditioned by the chart's graph Laplacian with cotangent weights (the
//! quadratic proxy of Kovalsky, Galun, Lipman, "Accelerated Quadratic Proxy for Geometric
//! Optimization", SIGGRAPH 2016), so that a low-frequency error is corrected in a few steps.
//!
//! Objective: `E = (Σ 2·A2) · Σ A3·(Γ² + γ²)/2` over the faces of positive model area, which is
//! `2·(ΣA3)²·L2²` for the scaled L2 of the module doc of `stretch` (scale invariant, so the
//! chart's size is free). `Γ² + γ²` is the squared Frobenius norm of `M = Q·P⁻¹` (`FrameFace`),
//! which grows without bound as a face's UV area goes to 0: a barrier against flips.
//!
//! Each step: the gradient `g` (analytic), the direction `d` from `(L + δI)·d = −g` for both
//! coordinates (`L` factored once), the largest step along `d` for which no face of positive
//! model area reaches zero UV area and no zero-area face goes below `min(0, its signed area)`
//! (a quadratic in the step per face), then a backtracking line search with Armijo's condition
//! whose point must also pass the stage's invariants (`State::check`: no flip, a simple boundary,
//! no fold) with a chart L∞ no higher than at the start. The descent stops after
//! [`GLOBAL_STEPS`] steps, when a step gains less than [`GLOBAL_MIN_GAIN`] of `E`, or when no
//! step is accepted. Deterministic and sequential.
//!
//! Units: UVs in model units; `E` in (model units)⁴ (only its ratios are used).
use super::{
    clearance, crossing_among, exceeds, optimize_chart_stretch, sub2, zero_model_area, ChartMesh,
    FrameFace, State, StretchChart, FOLD_MARGIN_RAD,
};
use crate::numerics::{CsrMatrix, SparseCholesky, Triplet};

/// Steps of the global descent, at most. Trade-off: each costs one gradient, two triangular
/// solves and a few evaluations of the chart; the gain per step falls fast after ~10.
pub(super) const GLOBAL_STEPS: usize = 24;
/// The descent stops when a step lowers `E` by less than this fraction.
const GLOBAL_MIN_GAIN: f64 = 1e-4;
/// Halvings of a step in the line search, at most.
const GLOBAL_BACKTRACKS: usize = 30;
/// Armijo's sufficient-decrease constant.
const ARMIJO: f64 = 1e-4;
/// The step stays below this fraction of the largest flip-free step.
const FLIP_MARGIN: f64 = 0.9;
/// Cotangent weights of the preconditioner are clamped to `[0, COT_MAX]`: negative weights
/// (obtuse angles) could make it indefinite, and a sliver's huge weight only slows the solve.
const COT_MAX: f64 = 1e3;

/// `E` with the chart's `Σ 2·A2`, largest `Γ` and smallest `γ` (unscaled).
#[derive(Debug, Clone, Copy)]
pub(super) struct Energy {
    pub(super) value: f64,
    sum_det: f64,
    big_max: f64,
    small_min: f64,
}

impl Energy {
    /// The chart's L∞ in the scaled metric of the module doc of `stretch`.
    fn linf(&self, a3_total: f64) -> f64 {
        let s = (0.5 * self.sum_det / a3_total).sqrt();
        (self.big_max * s).max(1.0 / (self.small_min * s))
    }
}

/// Per face of positive model area: its corners and the gradients of `2·A2` and of
/// `A3·|M|²/2` with respect to them (scratch of [`energy`]).
type FaceGrad = ([u32; 3], [[f64; 2]; 3], [[f64; 2]; 3]);

/// `E` and, when `grad` is given, its gradient per vertex (`scratch` is reused between calls);
/// `None` when a face of positive model area is not positively oriented.
pub(super) fn energy(
    st: &State<'_>,
    uv: &[[f64; 2]],
    grad: Option<&mut [[f64; 2]]>,
    scratch: &mut Vec<FaceGrad>,
) -> Option<Energy> {
    let (mut sum_det, mut sum_e) = (0.0, 0.0);
    let (mut big_max, mut small_min) = (0.0f64, f64::INFINITY);
    let want = grad.is_some();
    scratch.clear();
    for (f, t) in st.chart.triangles.iter().enumerate() {
        let Some(frame) = st.frames[f] else {
            continue;
        };
        let q = t.map(|i| uv[i as usize]);
        let (det, e, big, small) = if want {
            let terms = face_terms(&frame, q)?;
            scratch.push((*t, terms.ddet, terms.de));
            (terms.det, terms.e, terms.big, terms.small)
        } else {
            let core = face_core(&frame, q)?;
            (core.det, core.e, core.big, core.small)
        };
        sum_det += det;
        sum_e += e;
        big_max = big_max.max(big);
        small_min = small_min.min(small);
    }
    if let Some(g) = grad {
        g.iter_mut().for_each(|x| *x = [0.0; 2]);
        for (t, ddet, de) in scratch.iter() {
            for k in 0..3 {
                let v = t[k] as usize;
                g[v][0] += sum_e * ddet[k][0] + sum_det * de[k][0];
                g[v][1] += sum_e * ddet[k][1] + sum_det * de[k][1];
            }
        }
    }
    Some(Energy {
        value: sum_det * sum_e,
        sum_det,
        big_max,
        small_min,
    })
}

/// One face's terms: `2·A2`, `A3·|M|²/2`, their gradients with respect to the three UV corners,
/// and the singular values `Γ ≥ γ` of `M`.
struct FaceTerms {
    det: f64,
    e: f64,
    ddet: [[f64; 2]; 3],
    de: [[f64; 2]; 3],
    big: f64,
    small: f64,
}

/// One face's value terms: `2·A2` (`det`), `A3·|M|²/2` (`e`), `Γ ≥ γ` of `M`, and what the
/// gradient of [`face_terms`] needs (`u1`, `u2`, `1/det`, `M`). `None` when the UV triangle is
/// not positively oriented. The line search needs only the values: it calls this alone.
struct FaceCore {
    u1: [f64; 2],
    u2: [f64; 2],
    det: f64,
    inv: f64,
    m: [f64; 4],
    e: f64,
    big: f64,
    small: f64,
}

/// One face's [`FaceCore`].
#[inline]
fn face_core(frame: &FrameFace, q: [[f64; 2]; 3]) -> Option<FaceCore> {
    let u1 = sub2(q[1], q[0]);
    let u2 = sub2(q[2], q[0]);
    let det = u1[0] * u2[1] - u1[1] * u2[0];
    if !(det > 0.0 && det.is_finite()) {
        return None;
    }
    let inv = 1.0 / det;
    // M = Q·P⁻¹ with P = [u1 u2] (columns), Q = [[l1, x2], [0, y2]].
    let m00 = (frame.l1 * u2[1] - frame.x2 * u1[1]) * inv;
    let m01 = (frame.x2 * u1[0] - frame.l1 * u2[0]) * inv;
    let m10 = -frame.y2 * u1[1] * inv;
    let m11 = frame.y2 * u1[0] * inv;
    let norm2 = m00 * m00 + m01 * m01 + m10 * m10 + m11 * m11;
    let e = 0.5 * frame.a3 * norm2;
    // Singular values as in `FrameFace::singular_values`.
    let (ce, cf) = (0.5 * (m00 + m11), 0.5 * (m00 - m11));
    let (cg, ch) = (0.5 * (m10 + m01), 0.5 * (m10 - m01));
    let big = (ce * ce + ch * ch).sqrt() + (cf * cf + cg * cg).sqrt();
    let small = frame.l1 * frame.y2 * inv / big;
    (e.is_finite() && big.is_finite() && small > 0.0).then_some(FaceCore {
        u1,
        u2,
        det,
        inv,
        m: [m00, m01, m10, m11],
        e,
        big,
        small,
    })
}

/// One face's [`FaceTerms`]; `None` when the UV triangle is not positively oriented.
fn face_terms(frame: &FrameFace, q: [[f64; 2]; 3]) -> Option<FaceTerms> {
    let FaceCore {
        u1,
        u2,
        det,
        inv,
        m: [m00, m01, m10, m11],
        e,
        big,
        small,
    } = face_core(frame, q)?;
    // d|M|²/dP = −2·MᵀM·P⁻ᵀ; N = MᵀM.
    let n00 = m00 * m00 + m10 * m10;
    let n01 = m00 * m01 + m10 * m11;
    let n11 = m01 * m01 + m11 * m11;
    // P⁻ᵀ = (1/det)·[[u2y, −u1y], [−u2x, u1x]].
    let pit = [[u2[1] * inv, -u1[1] * inv], [-u2[0] * inv, u1[0] * inv]];
    let s = -frame.a3; // d e / dP = −A3·N·P⁻ᵀ
    let g00 = s * (n00 * pit[0][0] + n01 * pit[1][0]);
    let g01 = s * (n00 * pit[0][1] + n01 * pit[1][1]);
    let g10 = s * (n01 * pit[0][0] + n11 * pit[1][0]);
    let g11 = s * (n01 * pit[0][1] + n11 * pit[1][1]);
    // Column 0 of dP is u1 (corner 1), column 1 is u2 (corner 2); corner 0 takes minus both.
    let de1 = [g00, g10];
    let de2 = [g01, g11];
    let dd1 = [u2[1], -u2[0]];
    let dd2 = [-u1[1], u1[0]];
    let de = [[-de1[0] - de2[0], -de1[1] - de2[1]], de1, de2];
    let ddet = [[-dd1[0] - dd2[0], -dd1[1] - dd2[1]], dd1, dd2];
    Some(FaceTerms {
        det,
        e,
        ddet,
        de,
        big,
        small,
    })
}

/// The largest `t` such that, moving every vertex by `t·d`, no face of positive model area
/// reaches zero UV area and no zero-area face goes below `min(0, its signed area)`.
fn flip_free_step(st: &State<'_>, uv: &[[f64; 2]], d: &[[f64; 2]]) -> f64 {
    let mut t_max = f64::INFINITY;
    for (f, t) in st.chart.triangles.iter().enumerate() {
        let q = t.map(|i| uv[i as usize]);
        let dq = t.map(|i| d[i as usize]);
        let u1 = sub2(q[1], q[0]);
        let u2 = sub2(q[2], q[0]);
        let a = sub2(dq[1], dq[0]);
        let b = sub2(dq[2], dq[0]);
        let det0 = u1[0] * u2[1] - u1[1] * u2[0];
        let floor = if st.frames[f].is_some() {
            0.0
        } else {
            det0.min(0.0)
        };
        // det(t) − floor = c0 + c1·t + c2·t².
        let c0 = det0 - floor;
        let c1 = (u1[0] * b[1] - u1[1] * b[0]) + (a[0] * u2[1] - a[1] * u2[0]);
        let c2 = a[0] * b[1] - a[1] * b[0];
        if let Some(r) = smallest_positive_root(c0, c1, c2) {
            t_max = t_max.min(r);
        }
    }
    t_max
}

/// The smallest `t > 0` with `c0 + c1·t + c2·t² = 0` where the polynomial goes from `c0 ≥ 0` to
/// negative; `None` when it stays non-negative for every `t > 0`.
fn smallest_positive_root(c0: f64, c1: f64, c2: f64) -> Option<f64> {
    if c0 <= 0.0 {
        // Already on the floor: any step that lowers it at once is not allowed; one that
        // raises it first comes back down at −c1/c2 when c2 < 0.
        if c1 < 0.0 || (c1 == 0.0 && c2 < 0.0) {
            return Some(0.0);
        }
        return (c2 < 0.0).then(|| -c1 / c2);
    }
    if c2.abs() <= 1e-300 {
        return (c1 < 0.0).then(|| -c0 / c1);
    }
    let disc = c1 * c1 - 4.0 * c2 * c0;
    if disc < 0.0 {
        return None; // c2 > 0 (c0 > 0 and no real root): positive everywhere
    }
    let sq = disc.sqrt();
    // Stable roots: q = −(c1 + sign(c1)·sq)/2, roots q/c2 and c0/q.
    let qv = -0.5 * (c1 + c1.signum() * sq);
    let mut roots = [f64::INFINITY; 2];
    if qv != 0.0 {
        roots[0] = qv / c2;
        roots[1] = c0 / qv;
    }
    roots
        .into_iter()
        .filter(|r| *r > 0.0 && r.is_finite())
        .min_by(|a, b| a.total_cmp(b))
}

/// The preconditioner `L + δI` over all chart vertices, factored: `L` the graph Laplacian with
/// clamped cotangent weights of the faces of positive model area, `δ` a small fraction of its
/// mean diagonal (it fixes the translation and keeps unused vertices in place).
fn preconditioner(st: &State<'_>, n: usize) -> Option<SparseCholesky> {
    let mut trip: Vec<Triplet> = Vec::with_capacity(9 * st.chart.triangles.len() + n);
    let mut diag = vec![0.0; n];
    for (f, t) in st.chart.triangles.iter().enumerate() {
        let Some(frame) = st.frames[f] else {
            continue;
        };
        let p = [[0.0, 0.0], [frame.l1, 0.0], [frame.x2, frame.y2]];
        for k in 0..3 {
            let (a, b) = ((k + 1) % 3, (k + 2) % 3);
            let ea = sub2(p[a], p[k]);
            let eb = sub2(p[b], p[k]);
            let cross = (ea[0] * eb[1] - ea[1] * eb[0]).abs();
            let cot = (ea[0] * eb[0] + ea[1] * eb[1]) / cross;
            let w = 0.5 * cot.clamp(0.0, COT_MAX);
            if !exceeds(w, 0.0) {
                continue;
            }
            let (i, j) = (t[a], t[b]);
            trip.push(Triplet {
                row: i,
                col: j,
                value: -w,
            });
            trip.push(Triplet {
                row: j,
                col: i,
                value: -w,
            });
            diag[i as usize] += w;
            diag[j as usize] += w;
        }
    }
    let used: Vec<f64> = diag.iter().copied().filter(|&x| x > 0.0).collect();
    if used.is_empty() {
        return None;
    }
    let delta = 1e-8 * used.iter().sum::<f64>() / used.len() as f64;
    for (i, d) in diag.iter().enumerate() {
        trip.push(Triplet {
            row: i as u32,
            col: i as u32,
            value: d + delta,
        });
    }
    let a = CsrMatrix::from_triplets(n, n, &trip).ok()?;
    SparseCholesky::factor(&a).ok()
}

/// Whether the boundary of the positive-area faces is simple and no boundary vertex folds (its
/// UV angles sum to less than 2π − `FOLD_MARGIN_RAD`). An interior vertex needs no test here:
/// along a path on which its faces stay positive, its fan's winding number cannot change. The
/// caller checks everything once more at the end (`State::check`).
fn boundary_ok(st: &State<'_>, uv: &[[f64; 2]]) -> bool {
    if crossing_among(&st.segs, uv).is_some() {
        return false;
    }
    let limit = std::f64::consts::TAU - FOLD_MARGIN_RAD;
    for &(w, _, _) in &st.segs {
        let w = w as usize;
        let mut sum = 0.0;
        for (f, c) in st.inc.of(w) {
            if st.frames[f].is_none() {
                continue;
            }
            let t = st.chart.triangles[f];
            let (pw, pa, pb) = (
                uv[t[c] as usize],
                uv[t[(c + 1) % 3] as usize],
                uv[t[(c + 2) % 3] as usize],
            );
            let (e1, e2) = (sub2(pa, pw), sub2(pb, pw));
            sum += (e1[0] * e2[1] - e1[1] * e2[0])
                .atan2(e1[0] * e2[0] + e1[1] * e2[1])
                .abs();
        }
        if !exceeds(limit, sum) {
            return false;
        }
    }
    true
}

/// The global descent (`global`) of a freshly flattened chart's map (`cm`, `uv`), for the stage's
/// stretch bound: the bound is tested on the map the stretch optimisation would make, so that a
/// chart it can bring under the bound is not split. Returns the descended UVs, or `None` when
/// the map does not meet the optimiser's preconditions or no step was kept. The same guarantees
/// as `optimize_chart_stretch` (no flip, no boundary crossing or fold, L∞ not raised).
pub(in crate::atlas::parameterize) fn descend_for_bound(
    cm: &ChartMesh,
    uv: &[[f64; 2]],
) -> Option<Vec<[f64; 2]>> {
    let zero_area: Vec<bool> = cm
        .triangles
        .iter()
        .map(|t| zero_model_area(cm, t))
        .collect();
    if zero_area.iter().all(|&z| z) || uv.len() != cm.positions_m.len() {
        return None;
    }
    let chart = StretchChart {
        positions_m: &cm.positions_m,
        triangles: &cm.triangles,
        zero_area: &zero_area,
    };
    let mut out = uv.to_vec();
    let outcome = optimize_chart_stretch(&chart, &mut out, 0);
    (outcome.global_steps > 0).then_some(out)
}

/// Runs the global descent on `uv` (module doc); returns the number of steps kept. `uv` must
/// satisfy the invariants on entry (`State::check`), and does on return.
pub(super) fn descend(st: &State<'_>, uv: &mut [[f64; 2]], linf_cap: f64) -> usize {
    let n = uv.len();
    let Some(chol) = preconditioner(st, n) else {
        return 0;
    };
    let mut grad = vec![[0.0; 2]; n];
    let mut scratch = Vec::new();
    let Some(mut e) = energy(st, uv, Some(&mut grad), &mut scratch).map(|x| x.value) else {
        return 0;
    };
    let mut steps = 0;
    let mut t_prev: Option<f64> = None;
    let mut cand = uv.to_vec();
    // The border's clearance (`clearance`'s module doc), from the map the descent starts from.
    let start = uv.to_vec();
    let clearance = clearance::CLEARANCE_RELATIVE * clearance::extent(&start);
    for _ in 0..GLOBAL_STEPS {
        let gx: Vec<f64> = grad.iter().map(|g| -g[0]).collect();
        let gy: Vec<f64> = grad.iter().map(|g| -g[1]).collect();
        let Ok((dx, dy)) = chol.solve_pair(&gx, &gy) else {
            break;
        };
        let d: Vec<[f64; 2]> = dx.iter().zip(&dy).map(|(&x, &y)| [x, y]).collect();
        let slope: f64 = grad
            .iter()
            .zip(&d)
            .map(|(g, d)| g[0] * d[0] + g[1] * d[1])
            .sum();
        if !(slope < 0.0 && slope.is_finite()) {
            break;
        }
        let hi = FLIP_MARGIN * flip_free_step(st, uv, &d);
        if !exceeds(hi, 0.0) {
            break;
        }
        let mut t = match t_prev {
            Some(tp) => (2.0 * tp).min(hi),
            None => hi.min(1.0),
        };
        let mut accepted: Option<f64> = None;
        // The first try, usually the one kept, also computes its gradient (into `grad`, which
        // the line search no longer reads), so that a kept first try needs no second pass.
        let mut grad_at_cand = false;
        for k in 0..GLOBAL_BACKTRACKS {
            for (c, (p, dv)) in cand.iter_mut().zip(uv.iter().zip(&d)) {
                *c = [p[0] + t * dv[0], p[1] + t * dv[1]];
            }
            let want_grad = k == 0;
            let value = energy(st, &cand, want_grad.then_some(&mut grad[..]), &mut scratch);
            grad_at_cand = want_grad && value.is_some();
            if let Some(ec) = value {
                if ec.value <= e + ARMIJO * t * slope
                    && ec.linf(st.a3_total) <= linf_cap
                    && boundary_ok(st, &cand)
                    && !clearance::too_close(
                        st.chart.triangles,
                        &st.segs,
                        &cand,
                        Some(&start),
                        clearance,
                    )
                {
                    accepted = Some(ec.value);
                    break;
                }
            }
            t *= 0.5;
        }
        let Some(ec) = accepted else {
            break;
        };
        uv.copy_from_slice(&cand);
        steps += 1;
        t_prev = Some(t);
        let gain = e - ec;
        e = if grad_at_cand {
            ec
        } else {
            match energy(st, uv, Some(&mut grad), &mut scratch) {
                Some(x) => x.value,
                None => break,
            }
        };
        if gain < GLOBAL_MIN_GAIN * ec {
            break;
        }
    }
    steps
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(p: [[f64; 3]; 3]) -> FrameFace {
        FrameFace::new(p).unwrap()
    }

    /// The analytic gradient of one face's terms against central differences.
    #[test]
    fn face_gradient_matches_finite_differences() {
        let cases = [
            (
                [[0.0, 0.0, 0.0], [1.0, 0.0, 0.2], [0.3, 0.9, -0.1]],
                [[0.1, 0.2], [1.3, 0.1], [0.5, 1.4]],
            ),
            (
                [[1.0, 2.0, 0.0], [1.5, 2.0, 1.0], [0.0, 3.0, 0.5]],
                [[0.0, 0.0], [0.2, 0.01], [0.05, 0.3]],
            ),
            (
                [[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [1.5, 0.01, 0.0]],
                [[0.0, 0.0], [2.0, 0.5], [1.0, 1.0]],
            ),
        ];
        for (p, q) in cases {
            let fr = frame(p);
            let FaceTerms { ddet, de, .. } = face_terms(&fr, q).unwrap();
            for k in 0..3 {
                for c in 0..2 {
                    let h = 1e-6;
                    let mut qp = q;
                    let mut qm = q;
                    qp[k][c] += h;
                    qm[k][c] -= h;
                    let p = face_terms(&fr, qp).unwrap();
                    let m = face_terms(&fr, qm).unwrap();
                    let (dp, ep, dm, em) = (p.det, p.e, m.det, m.e);
                    let fd_det = (dp - dm) / (2.0 * h);
                    let fd_e = (ep - em) / (2.0 * h);
                    assert!(
                        (fd_det - ddet[k][c]).abs() <= 1e-6 * (1.0 + fd_det.abs()),
                        "det {k} {c}: {fd_det} vs {}",
                        ddet[k][c]
                    );
                    assert!(
                        (fd_e - de[k][c]).abs() <= 1e-5 * (1.0 + fd_e.abs()),
                        "e {k} {c}: {fd_e} vs {}",
                        de[k][c]
                    );
                }
            }
        }
    }

    /// `|M|²` is Γ² + γ² of `FrameFace::singular_values`.
    #[test]
    fn face_energy_is_the_l2_integrand() {
        let fr = frame([[0.0, 0.0, 0.0], [1.0, 0.0, 0.2], [0.3, 0.9, -0.1]]);
        let q = [[0.1, 0.2], [1.3, 0.1], [0.5, 1.4]];
        let FaceTerms {
            det,
            e,
            big: b,
            small: sm,
            ..
        } = face_terms(&fr, q).unwrap();
        let (big, small, det2) = fr.singular_values(q).unwrap();
        assert!((det - det2).abs() <= 1e-12);
        assert!((b - big).abs() <= 1e-12 * big && (sm - small).abs() <= 1e-12 * small);
        let want = 0.5 * fr.a3 * (big * big + small * small);
        assert!((e - want).abs() <= 1e-12 * want, "{e} vs {want}");
    }

    #[test]
    fn smallest_positive_root_cases() {
        // 1 − t: root 1.
        assert_eq!(smallest_positive_root(1.0, -1.0, 0.0), Some(1.0));
        // 1 + t: none.
        assert_eq!(smallest_positive_root(1.0, 1.0, 0.0), None);
        // (t − 1)(t − 2) = 2 − 3t + t²: root 1.
        let r = smallest_positive_root(2.0, -3.0, 1.0).unwrap();
        assert!((r - 1.0).abs() < 1e-12);
        // 1 + t²: none.
        assert_eq!(smallest_positive_root(1.0, 0.0, 1.0), None);
        // 1 − t²: root 1.
        let r = smallest_positive_root(1.0, 0.0, -1.0).unwrap();
        assert!((r - 1.0).abs() < 1e-12);
        // On the floor, going down: 0.
        assert_eq!(smallest_positive_root(0.0, -1.0, 0.0), Some(0.0));
        // On the floor, going up then down: t − t² comes back to 0 at 1.
        assert_eq!(smallest_positive_root(0.0, 1.0, -1.0), Some(1.0));
        // On the floor, going up for good: t + t².
        assert_eq!(smallest_positive_root(0.0, 1.0, 1.0), None);
    }
}
