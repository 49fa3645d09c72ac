//! ASP, the adaptable surface parameterization of Degener, Meseth, Klein 2003: a chart's map
//! relaxed for an energy that trades angle against area distortion with one parameter θ.
//!
//! Energy (asp-2003 §3–4). With `σ1 ≥ σ2 > 0` the singular values of the map's Jacobian on a
//! face (the square roots of the eigenvalues of the first fundamental form), the face's energy is
//! `E_angle · E_area^θ`, with the MIPS angle term `E_angle = σ1/σ2 + σ2/σ1` (Hormann & Greiner)
//! and the area term `E_area = σ1σ2 + 1/(σ1σ2)` (`det + det⁻¹`, minimal at area kept). Both
//! terms are invariant under `σ → 1/σ`, so the direction of the map does not matter. The chart's
//! energy is the sum over its faces of the face energy times the face's model area. θ = 0 is the
//! MIPS energy (angles only, any conformal map is optimal); larger θ keeps area at the cost of
//! angles; θ = 1 is `σ1² + σ2² + σ1⁻² + σ2⁻²` (the paper's "uniform sampling" energy). The
//! energy is infinite on a degenerate or flipped face, so a descent from a flip-free map never
//! flips. On one face it is computed from the cotangent form of the Dirichlet energy,
//! `σ1² + σ2² = Σ cot αᵢ |eᵢ|² / (2 A3)` (αᵢ the model angle opposite UV edge `eᵢ`) and
//! `σ1σ2 = A2 / A3`; the tests recompute it from the singular values of an explicit Jacobian.
//!
//! Algorithm ([`relax_chart_asp`], one level; [`relax_chart_asp_hierarchical`] runs it coarse
//! to fine), the paper's vertex relaxation: per sweep, the movable
//! vertices (used by a face of positive model area) are visited by decreasing energy of their
//! one ring; each is moved to lower its ring's energy with the others fixed, inside the kernel
//! of its ring (every face of positive model area keeps a positive UV area; a zero-area face
//! never becomes flipped), so a sweep never flips a face and never raises the energy. Free
//! boundary: a boundary vertex moves like an interior one, and a move is kept only if its two
//! boundary segments cross no other and no boundary vertex of its ring folds (the stretch
//! optimiser's guard, `stretch::boundary_move_ok`); otherwise the step is halved, at most
//! `BOUNDARY_RETRIES` times. The start is the stage's LSCM map scaled to UV area = model area
//! (a similarity: the start stays flip-free and the area term starts near its minimum).
//!
//! Deviations from the paper:
//! - the local step is a damped Newton step on the vertex's two coordinates (the 2×2 Hessian by
//!   differences of the analytic gradient; the negative gradient when it is not positive
//!   definite) with an Armijo backtracking line search clipped to the kernel, instead of
//!   Polak–Ribière CG: the local problem has two unknowns, so Newton needs fewer ring
//!   evaluations; the kernel restriction and the monotone decrease are the paper's;
//! - the hierarchy ([`relax_chart_asp_hierarchical`], `hierarchy.rs`) reuses HLSCM's
//!   progressive mesh and starts from the LSCM map restricted to its coarsest valid level instead
//!   of one triangle (the LSCM map is the conformal optimum, the θ = 0 end of the trade-off);
//!   re-inserted vertices take the coarse correction of the LSCM map's local shape, and fall back
//!   to the paper's ray casting into the ring kernel.
//!
//! Invariants (checked from scratch after each sweep, the sweep undone when one fails, so they
//! hold whatever the per-move arithmetic did): no face of positive model area flips or
//! collapses, no zero-area face becomes flipped, the boundary stays simple and no vertex folds
//! (the tests the stage validated the map with); the chart's energy does not rise. A map that
//! does not satisfy them on entry is returned unchanged. Work is bounded by [`MAX_SWEEPS`]
//! sweeps of at most [`NEWTON_STEPS`] local steps per vertex; no wall clock. Deterministic: one
//! chart is relaxed sequentially, in an order that depends only on its data.
//!
//! Units: positions and UVs in model units (UVs not yet normalised); θ and energies are
//! dimensionless per unit model area (an isometric face has energy `2·2^θ`).
//!
//! References: P. Degener, J. Meseth, R. Klein, "An Adaptable Surface Parameterization Method",
//! 12th International Meshing Roundtable, 2003 (§3 the energy, §4 the relaxation in the
//! kernel); K. Hormann, G. Greiner, "MIPS: An Efficient Global Parametrization Method", 2000.
use super::chart::exceeds;
use super::defects::{crossing_among, fold_with_boundary};
use super::options::ASP_MAX_THETA;
use super::stretch::{
    boundary_move_ok, boundary_segments, cross2, sub2, BoundaryView, Incidence, StretchChart,
};
use super::ChartMesh;

/// Sweeps over a chart's vertices, at most. Trade-off: each sweep costs about `NEWTON_STEPS`
/// ring evaluations per vertex; Gauss–Seidel sweeps move area slowly across a large chart, so
/// more sweeps keep lowering the area distortion of large charts for linear extra time.
pub const MAX_SWEEPS: usize = 24;
/// A relaxation stops when a sweep lowers the chart's energy by less than this fraction.
pub const SWEEP_TOLERANCE: f64 = 1e-4;
/// Local Newton steps per vertex visit. Trade-off: the neighbours move next, so an exact local
/// minimum is wasted work; two steps already take most of the local decrease.
pub const NEWTON_STEPS: usize = 2;
/// Halvings of a boundary vertex's step when its move would make the boundary cross itself or
/// fold.
const BOUNDARY_RETRIES: usize = 4;
/// Halvings of the Armijo backtracking line search.
const BACKTRACKS: usize = 16;
/// The step is kept at most this fraction of the way to the kernel's edge.
const KERNEL_FRACTION: f64 = 0.9;

/// One face of positive model area: its model area and its cotangent weights
/// `cot αᵢ / (2·A3)` (`αᵢ` the model angle at corner `i`), so that `σ1² + σ2² = Σ wᵢ |eᵢ|²`
/// with `eᵢ` the UV edge opposite corner `i`.
#[derive(Debug, Clone, Copy)]
pub(super) struct AspFace {
    a3: f64,
    w: [f64; 3],
}

impl AspFace {
    /// `None` for a face of zero (or non-finite) model area.
    pub(super) fn new(p: [[f64; 3]; 3]) -> Option<Self> {
        let d = |a: [f64; 3], b: [f64; 3]| [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let (e1, e2) = (d(p[0], p[1]), d(p[0], p[2]));
        let cr = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let twice = dot(cr, cr).sqrt();
        if !(exceeds(twice, 0.0) && twice.is_finite()) {
            return None;
        }
        // cot αᵢ = (edge · edge) / |cross| at corner i; divided by 2·A3 = twice.
        let w: [f64; 3] = std::array::from_fn(|i| {
            let (o, a, b) = (p[i], p[(i + 1) % 3], p[(i + 2) % 3]);
            dot(d(o, a), d(o, b)) / (twice * twice)
        });
        w.iter()
            .all(|x| x.is_finite())
            .then_some(Self { a3: 0.5 * twice, w })
    }

    /// The face's energy times its model area with UV corners `q`; `None` when the UV triangle
    /// is not positively oriented (the energy is infinite there).
    #[inline]
    pub(super) fn energy(&self, q: [[f64; 2]; 3], theta: f64) -> Option<f64> {
        let a2 = 0.5 * cross2(sub2(q[1], q[0]), sub2(q[2], q[0]));
        if !exceeds(a2, 0.0) {
            return None;
        }
        let f = self.dirichlet(q);
        let det = a2 / self.a3;
        let e = self.a3 * f / det * pow_theta(det + 1.0 / det, theta);
        e.is_finite().then_some(e)
    }

    /// `σ1² + σ2²` of the map with UV corners `q`.
    #[inline]
    fn dirichlet(&self, q: [[f64; 2]; 3]) -> f64 {
        (0..3)
            .map(|i| {
                let e = sub2(q[(i + 2) % 3], q[(i + 1) % 3]);
                self.w[i] * (e[0] * e[0] + e[1] * e[1])
            })
            .sum()
    }

    /// The energy (times model area) and its gradient with respect to corner `c`'s UV.
    #[inline]
    fn energy_gradient(&self, q: [[f64; 2]; 3], c: usize, theta: f64) -> Option<(f64, [f64; 2])> {
        let a2 = 0.5 * cross2(sub2(q[1], q[0]), sub2(q[2], q[0]));
        if !exceeds(a2, 0.0) {
            return None;
        }
        let (j, k) = ((c + 1) % 3, (c + 2) % 3);
        let f = self.dirichlet(q);
        let det = a2 / self.a3;
        let g = det + 1.0 / det;
        let g_theta = pow_theta(g, theta);
        let e = self.a3 * f / det * g_theta;
        // d(σ1²+σ2²)/dq_c: the edges opposite j (c–k) and k (c–j).
        let (qc, qj, qk) = (q[c], q[j], q[k]);
        let df = [
            2.0 * (self.w[j] * (qc[0] - qk[0]) + self.w[k] * (qc[0] - qj[0])),
            2.0 * (self.w[j] * (qc[1] - qk[1]) + self.w[k] * (qc[1] - qj[1])),
        ];
        // dA2/dq_c = ½ (q_j.y − q_k.y, q_k.x − q_j.x); det = A2 / A3.
        let ddet = [
            0.5 * (qj[1] - qk[1]) / self.a3,
            0.5 * (qk[0] - qj[0]) / self.a3,
        ];
        let de_df = g_theta / det;
        let de_ddet = -f / (det * det) * g_theta
            + if theta == 0.0 {
                0.0
            } else {
                f / det * theta * g_theta / g * (1.0 - 1.0 / (det * det))
            };
        let grad = [
            self.a3 * (de_df * df[0] + de_ddet * ddet[0]),
            self.a3 * (de_df * df[1] + de_ddet * ddet[1]),
        ];
        (e.is_finite() && grad[0].is_finite() && grad[1].is_finite()).then_some((e, grad))
    }
}

/// `g^θ` for the area term (`g ≥ 2`), with `powi` for whole θ (θ = 1 is the default; `powf`
/// is the relaxation's main cost otherwise).
#[inline]
fn pow_theta(g: f64, theta: f64) -> f64 {
    if theta == 0.0 {
        1.0
    } else if theta == 1.0 {
        g
    } else if theta.fract() == 0.0 {
        g.powi(theta as i32)
    } else {
        g.powf(theta)
    }
}

/// The chart's ASP energy `Σ A3 · E_angle · E_area^θ` over its faces of positive model area
/// (module doc), or `None` when such a face is not positively oriented in `uv`.
pub fn asp_energy(chart: &StretchChart<'_>, uv: &[[f64; 2]], theta: f64) -> Option<f64> {
    let mut sum = 0.0;
    for (t, &z) in chart.triangles.iter().zip(chart.zero_area) {
        if z {
            continue;
        }
        let Some(face) = AspFace::new(t.map(|i| chart.positions_m[i as usize])) else {
            continue;
        };
        sum += face.energy(t.map(|i| uv[i as usize]), theta)?;
    }
    Some(sum)
}

/// What [`relax_chart_asp`] did to one chart.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AspOutcome {
    /// The map met the preconditions and was relaxed (possibly with no move kept).
    pub relaxed: bool,
    /// Levels relaxed: 1 for [`relax_chart_asp`], the levels of the hierarchy for
    /// [`relax_chart_asp_hierarchical`] (1 when it fell back to one level).
    pub levels: usize,
    /// Sweeps run (over all levels).
    pub sweeps: usize,
    /// Vertex moves kept.
    pub moves: usize,
    /// Sweeps undone by the per-sweep check (a per-move test was too weak; should stay 0).
    pub sweeps_undone: usize,
    /// The chart's energy before (after the scaling to UV area = model area) and after.
    pub energy_before: f64,
    /// See `energy_before`.
    pub energy_after: f64,
}

/// Counters of ASP over all charts (`stage::relax_asp_charts`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct AspStats {
    /// Charts whose ASP map was kept.
    pub charts_relaxed: usize,
    /// Charts that kept their LSCM map: the ASP map failed the stage's tests (the stretch or
    /// area-ratio bound), or the map did not meet the relaxation's preconditions.
    pub charts_kept_lscm: usize,
    /// Vertex moves kept, over the charts whose ASP map was kept.
    pub moves: usize,
    /// Sweeps run, over the charts whose ASP map was kept.
    pub sweeps: usize,
}

/// The relaxation's state for one chart.
struct State<'a> {
    chart: StretchChart<'a>,
    theta: f64,
    faces: Vec<Option<AspFace>>,
    inc: Incidence,
    movable: Vec<bool>,
    segs: Vec<(u32, u32, usize)>,
    on_boundary: Vec<bool>,
    vertex_segs: Vec<[u32; 2]>,
    /// The positive-area faces as a chart (same vertex numbering), for `fold_with_boundary`.
    solid: ChartMesh,
}

/// Relaxes `uv` (one per chart vertex, model units; a valid map: no flipped face of positive
/// model area, simple boundary, no fold) for the ASP energy with parameter `theta` (module
/// doc), at most `max_sweeps` sweeps. The result is scaled so that its UV area equals the
/// chart's model area. Pure and sequential. A map that is not valid on entry, or a chart with no
/// face of positive model area, is left unchanged (`relaxed` false).
pub fn relax_chart_asp(
    chart: &StretchChart<'_>,
    uv: &mut [[f64; 2]],
    theta: f64,
    max_sweeps: usize,
) -> AspOutcome {
    relax_until(chart, uv, theta, max_sweeps, SWEEP_TOLERANCE)
}

/// [`relax_chart_asp`] stopping when a sweep gains less than `tolerance` (relative); the tests
/// run it to convergence.
fn relax_until(
    chart: &StretchChart<'_>,
    uv: &mut [[f64; 2]],
    theta: f64,
    max_sweeps: usize,
    tolerance: f64,
) -> AspOutcome {
    let mut out = AspOutcome::default();
    if !(0.0..=ASP_MAX_THETA).contains(&theta) {
        return out;
    }
    let Some(st) = State::new(chart, uv, theta) else {
        return out;
    };
    if !st.valid(uv) {
        return out;
    }
    let original = uv.to_vec();
    // Scale to UV area = model area (a similarity about the origin: stays valid).
    let (mut a2, mut a3) = (0.0, 0.0);
    for (t, f) in chart.triangles.iter().zip(&st.faces) {
        if let Some(f) = f {
            let q = t.map(|i| uv[i as usize]);
            a2 += 0.5 * cross2(sub2(q[1], q[0]), sub2(q[2], q[0]));
            a3 += f.a3;
        }
    }
    let s = (a3 / a2).sqrt();
    if !(s.is_finite() && s > 0.0) {
        return out;
    }
    for p in uv.iter_mut() {
        *p = [p[0] * s, p[1] * s];
    }
    let Some(mut energy) = st.energy(uv).filter(|_| st.valid(uv)) else {
        uv.copy_from_slice(&original);
        return out;
    };
    out.relaxed = true;
    out.levels = 1;
    out.energy_before = energy;
    let mut order: Vec<(f64, u32)> = Vec::new();
    for _ in 0..max_sweeps {
        out.sweeps += 1;
        let snapshot = uv.to_vec();
        // The paper's order: by decreasing energy of the vertex's ring (ties by index).
        order.clear();
        order.extend(
            (0..uv.len())
                .filter(|&v| st.movable[v])
                .map(|v| (st.ring_energy(uv, v, uv[v]).unwrap_or(0.0), v as u32)),
        );
        order.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut moved = 0usize;
        for &(_, v) in &order {
            for _ in 0..NEWTON_STEPS {
                if st.move_vertex(uv, v as usize) {
                    moved += 1;
                } else {
                    break;
                }
            }
        }
        // The tolerance covers the rounding of the sum (every move lowers its ring's energy).
        match st
            .energy(uv)
            .filter(|&e| e <= energy * (1.0 + 1e-12) && st.valid(uv))
        {
            Some(e) => {
                let gain = energy - e;
                energy = e;
                out.moves += moved;
                if moved == 0 || gain < tolerance * energy {
                    break;
                }
            }
            None => {
                uv.copy_from_slice(&snapshot);
                out.sweeps_undone += 1;
                break;
            }
        }
    }
    out.energy_after = energy;
    out
}

impl<'a> State<'a> {
    fn new(chart: &StretchChart<'a>, uv: &[[f64; 2]], theta: f64) -> Option<Self> {
        let n = uv.len();
        if chart.positions_m.len() != n || chart.zero_area.len() != chart.triangles.len() {
            return None;
        }
        if chart.triangles.iter().flatten().any(|&i| i as usize >= n) {
            return None;
        }
        let faces: Vec<Option<AspFace>> = chart
            .triangles
            .iter()
            .zip(chart.zero_area)
            .map(|(t, &z)| {
                if z || t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                    None
                } else {
                    AspFace::new(t.map(|i| chart.positions_m[i as usize]))
                }
            })
            .collect();
        let solid_face: Vec<bool> = faces.iter().map(Option::is_some).collect();
        let solid_tris: Vec<[u32; 3]> = chart
            .triangles
            .iter()
            .zip(&solid_face)
            .filter(|(_, &s)| s)
            .map(|(t, _)| *t)
            .collect();
        if solid_tris.is_empty() {
            return None;
        }
        let mut movable = vec![false; n];
        for t in &solid_tris {
            for &v in t {
                movable[v as usize] = true;
            }
        }
        let (segs, on_boundary, vertex_segs) = boundary_segments(n, chart.triangles, &solid_face)?;
        Some(Self {
            chart: *chart,
            theta,
            faces,
            inc: Incidence::new(n, chart.triangles),
            movable,
            segs,
            on_boundary,
            vertex_segs,
            solid: ChartMesh {
                positions_m: chart.positions_m.to_vec(),
                triangles: solid_tris,
            },
        })
    }

    /// The chart's energy, `None` when a solid face is not positive or a UV is not finite.
    fn energy(&self, uv: &[[f64; 2]]) -> Option<f64> {
        let mut sum = 0.0;
        for (t, f) in self.chart.triangles.iter().zip(&self.faces) {
            let q = t.map(|i| uv[i as usize]);
            if !q.iter().all(|p| p[0].is_finite() && p[1].is_finite()) {
                return None;
            }
            if let Some(f) = f {
                sum += f.energy(q, self.theta)?;
            }
        }
        Some(sum)
    }

    /// The stage's validity tests: simple boundary, no fold (flips are in `energy`).
    fn valid(&self, uv: &[[f64; 2]]) -> bool {
        self.energy(uv).is_some()
            && crossing_among(&self.segs, uv).is_none()
            && fold_with_boundary(&self.solid, uv, &self.on_boundary).is_none()
    }

    /// The energy of `v`'s ring with `v` at `p`; `None` when a solid face would not be positive
    /// or a zero-area face would become flipped.
    fn ring_energy(&self, uv: &[[f64; 2]], v: usize, p: [f64; 2]) -> Option<f64> {
        self.ring(uv, v, p, false).map(|(e, _)| e)
    }

    /// [`Self::ring_energy`] and, with `gradient`, its gradient in `p`.
    fn ring(
        &self,
        uv: &[[f64; 2]],
        v: usize,
        p: [f64; 2],
        gradient: bool,
    ) -> Option<(f64, [f64; 2])> {
        let (mut e, mut g) = (0.0, [0.0, 0.0]);
        for (f, c) in self.inc.of(v) {
            let t = self.chart.triangles[f];
            let mut q = t.map(|i| uv[i as usize]);
            q[c] = p;
            match &self.faces[f] {
                Some(face) if gradient => {
                    let (fe, fg) = face.energy_gradient(q, c, self.theta)?;
                    e += fe;
                    g[0] += fg[0];
                    g[1] += fg[1];
                }
                Some(face) => e += face.energy(q, self.theta)?,
                None => {
                    let before = {
                        let o = t.map(|i| uv[i as usize]);
                        cross2(sub2(o[1], o[0]), sub2(o[2], o[0]))
                    };
                    let after = cross2(sub2(q[1], q[0]), sub2(q[2], q[0]));
                    if after < before.min(0.0) {
                        return None;
                    }
                }
            }
        }
        Some((e, g))
    }

    /// One damped Newton step of `v` inside its kernel (module doc); whether it moved.
    fn move_vertex(&self, uv: &mut [[f64; 2]], v: usize) -> bool {
        let p0 = uv[v];
        let Some((e0, g0)) = self.ring(uv, v, p0, true) else {
            return false;
        };
        let gn = (g0[0] * g0[0] + g0[1] * g0[1]).sqrt();
        if !(gn > 0.0 && gn.is_finite()) {
            return false;
        }
        // Local length: the mean incident UV edge length.
        let (mut len, mut cnt) = (0.0, 0usize);
        for (f, c) in self.inc.of(v) {
            let t = self.chart.triangles[f];
            for k in [1, 2] {
                let e = sub2(uv[t[(c + k) % 3] as usize], p0);
                len += (e[0] * e[0] + e[1] * e[1]).sqrt();
                cnt += 1;
            }
        }
        if cnt == 0 || !exceeds(len, 0.0) {
            return false;
        }
        let scale_len = len / cnt as f64;
        // Hessian by forward differences of the analytic gradient.
        let h = 1e-6 * scale_len;
        let dir = match (
            self.ring(uv, v, [p0[0] + h, p0[1]], true),
            self.ring(uv, v, [p0[0], p0[1] + h], true),
        ) {
            (Some((_, gx)), Some((_, gy))) => {
                let hxx = (gx[0] - g0[0]) / h;
                let hyy = (gy[1] - g0[1]) / h;
                let hxy = 0.5 * ((gx[1] - g0[1]) / h + (gy[0] - g0[0]) / h);
                let det = hxx * hyy - hxy * hxy;
                if hxx > 0.0 && det > 0.0 && det.is_finite() {
                    [
                        -(hyy * g0[0] - hxy * g0[1]) / det,
                        -(hxx * g0[1] - hxy * g0[0]) / det,
                    ]
                } else {
                    [-g0[0] / gn * scale_len, -g0[1] / gn * scale_len]
                }
            }
            _ => [-g0[0] / gn * scale_len, -g0[1] / gn * scale_len],
        };
        let slope0 = dir[0] * g0[0] + dir[1] * g0[1];
        if !(slope0 < 0.0 && slope0.is_finite()) {
            return false;
        }
        // Clip t to the kernel: each face's signed area is linear in t.
        let mut t_max = 1.0 / KERNEL_FRACTION;
        if self.on_boundary[v] {
            let dl = (dir[0] * dir[0] + dir[1] * dir[1]).sqrt();
            t_max = t_max.min(scale_len / dl);
        }
        for (f, c) in self.inc.of(v) {
            let t = self.chart.triangles[f];
            let u = sub2(uv[t[(c + 1) % 3] as usize], p0);
            let w = sub2(uv[t[(c + 2) % 3] as usize], p0);
            let a0 = cross2(u, w);
            let slope = -cross2(dir, sub2(w, u));
            let floor = if self.faces[f].is_some() {
                0.0
            } else {
                a0.min(0.0)
            };
            if slope < 0.0 {
                t_max = t_max.min((a0 - floor).max(0.0) / -slope);
            }
        }
        if !(t_max > 0.0 && t_max.is_finite()) {
            return false;
        }
        let mut t = KERNEL_FRACTION * t_max;
        let at = |t: f64| [p0[0] + t * dir[0], p0[1] + t * dir[1]];
        // Armijo backtracking.
        let mut found = false;
        for _ in 0..BACKTRACKS {
            match self.ring_energy(uv, v, at(t)) {
                Some(e) if e <= e0 + 1e-4 * t * slope0 && e < e0 => {
                    found = true;
                    break;
                }
                _ => t *= 0.5,
            }
        }
        if !found {
            return false;
        }
        if self.on_boundary[v] {
            let view = BoundaryView {
                segs: &self.segs,
                vertex_segs: &self.vertex_segs,
                on_boundary: &self.on_boundary,
                inc: &self.inc,
                triangles: self.chart.triangles,
                solid: &|f| self.faces[f].is_some(),
            };
            let mut ok = false;
            for _ in 0..=BOUNDARY_RETRIES {
                if boundary_move_ok(&view, uv, v, at(t))
                    && self.ring_energy(uv, v, at(t)).is_some_and(|e| e < e0)
                {
                    ok = true;
                    break;
                }
                t *= 0.5;
            }
            if !ok {
                return false;
            }
        }
        uv[v] = at(t);
        true
    }
}

mod hierarchy;
pub use hierarchy::{relax_chart_asp_hierarchical, COARSEST_VERTICES, LEVEL_RATIO};

#[cfg(test)]
mod tests;
