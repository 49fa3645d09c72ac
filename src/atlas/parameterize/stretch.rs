//! Stretch optimisation of a chart's map: first a global descent of the chart's L2 stretch, all
//! vertices at once (`global`, the quadratic proxy of Kovalsky et al. 2016), then, when passes
//! are asked for, Sander, Snyder, Gortler, Hoppe 2001 §4 (as used by Iso-charts 2004 §3–4): the
//! chart's L∞ stretch, then its L2 stretch, by moving one vertex at a time along a line search
//! inside the region where none of its triangles flips.
//!
//! Purpose: LSCM maps are conformal, so their area (and thus texel density) varies over a chart;
//! Sander's geometric stretch measures that. [`optimize_chart_stretch`] lowers it on a valid map
//! without ever making it invalid; `stage::optimize_stretch_charts` runs it on every chart of
//! the parameterize stage's result, in parallel.
//!
//! Metric (the report's, `measure/stretch.rs`): per face, the singular values `Γ ≥ γ` of the
//! Jacobian of the affine map from texture to surface; the chart is scaled so that its UV area
//! equals its model area (the packer places every chart at one texel density, so this is its
//! scale in the atlas): with `r = ΣA2 / ΣA3` over the chart, the scaled values are `Γ·√r`,
//! `γ·√r`. L2 = `sqrt(r · Σ (Γ² + γ²)/2 · A3 / ΣA3)`; L∞ = `max(Γ√r, 1/(γ√r))` over the faces
//! (Iso-charts' symmetric L∞, which also penalises shrinking).
//!
//! Algorithm, per pass over the movable vertices (used by a face of positive model area):
//! - the direction is the negative gradient (forward differences) of the phase's local
//!   objective at the vertex: L∞ phase, `Σ A3·(v_f / v_max)^8` over its faces (a smooth proxy
//!   of their maximum, `v_f = max(Γ√r, 1/(γ√r))`); L2 phase, `ΣA2 · Σ (Γ²+γ²)/2·A3` of the chart
//!   (∝ L2², local terms only change);
//! - the line is clipped to the vertex's kernel: every face of positive model area keeps a
//!   positive signed UV area (its area is linear along the line, so positive at both ends means
//!   positive throughout), and every zero-area face keeps a signed UV area ≥ `min(0, before)`
//!   (it never becomes flipped, and it does not drive the move: it is not in the objective);
//!   a boundary vertex's outward step is capped at its mean incident UV edge length;
//! - golden-section search on the clipped segment for the phase's objective: L∞ phase, the
//!   maximum of `v_f` over the vertex's faces, with the chart's L∞ not allowed to rise; L2 phase,
//!   the chart's L2, with the chart's L∞ not allowed to rise above its value after the L∞ phase;
//! - a move of a boundary vertex is kept only if its two boundary segments cross no other
//!   (`defects::segments_intersect`) and no boundary vertex of its fan folds (UV angle sum
//!   below 2π); otherwise the step is halved, at most `BOUNDARY_RETRIES` times.
//!
//! The L∞ phase visits, by decreasing local maximum, only the vertices whose local maximum's
//! excess over 1 is at least [`LINF_VISIT_FRACTION`] of the chart's; the L2 phase visits every movable vertex
//! in index order (Gauss–Seidel).
//!
//! Invariants (checked from scratch after each pass, the pass undone when one fails, so they
//! hold whatever the per-move arithmetic did): no face of positive model area flips or
//! collapses; no zero-area face becomes flipped; the boundary stays simple (`crossing_among`)
//! and no vertex folds (`fold_with_boundary`) — the tests the stage validated the map with; the
//! chart's L∞ does not rise (up to 1e-12 relative, the rounding of the chart's area sum) and its
//! L2 does not rise at the end. A chart whose map does not satisfy them on entry (or is not a
//! manifold disk without its zero-area faces) is returned unchanged. Work is bounded by the pass
//! counts: at most `passes` passes of each phase, each at most [`EVALS_PER_MOVE`] evaluations of
//! a vertex's fan per vertex; no wall clock. Deterministic: one chart is optimised sequentially,
//! charts in parallel with results in chart order, so the bits do not depend on the thread
//! count.
//!
//! Units: positions and UVs in model units (UVs are not yet normalised, the packer scales each
//! chart); stretch values are dimensionless (1 is isometric).
//!
//! References: P. Sander, J. Snyder, S. Gortler, H. Hoppe, "Texture Mapping Progressive
//! Meshes", SIGGRAPH 2001, §3 (the L2 and L∞ stretch norms) and §4 (the optimisation: L∞
//! first, then L2; vertex moves by line search along a direction, within the kernel of the
//! vertex's neighbourhood); K. Zhou, J. Snyder, B. Guo, H.-Y. Shum, "Iso-charts", SGP 2004,
//! §3 (the symmetric L∞ `max(Γ, 1/γ)`) and §4 (a few stretch-minimising iterations after the
//! initial map).
use super::chart::exceeds;
use super::defects::{crossing_among, fold_with_boundary, segments_intersect};
pub use super::options::StretchOptimization;
use super::ChartMesh;

/// The L∞ phase visits the vertices whose local maximum of `v_f` exceeds 1 by at least this
/// fraction of the chart's L∞'s excess over 1. Trade-off: lower visits more vertices (more cost) for a tail that the next
/// pass would reach anyway.
pub const LINF_VISIT_FRACTION: f64 = 0.8;
/// Evaluations of a vertex's fan per move, at most: 2 for the gradient, 1 at the start, the
/// line search (golden-section steps in the L∞ phase, fewer in the L2 phase) and the boundary
/// retries.
pub const EVALS_PER_MOVE: usize =
    3 + if GOLDEN_STEPS > PARABOLA_EVALS {
        GOLDEN_STEPS
    } else {
        PARABOLA_EVALS
    } + BOUNDARY_RETRIES;
/// Halvings of a boundary vertex's step when its move would make the boundary cross itself or
/// fold.
const BOUNDARY_RETRIES: usize = 3;
/// Relative tolerance of the per-pass L∞ check: the scaled values depend on the chart's UV area
/// sum, whose rounding changes with the summation order.
const LINF_ROUNDING: f64 = 1e-12;
/// A boundary vertex folds when its UV angles sum to at least 2π − this (radians); stricter than
/// the stage's 1e-9 so the stage's own test never sees a near-fold made here.
const FOLD_MARGIN_RAD: f64 = 1e-6;

/// The chart to optimise: positions (model units), triangles (counter-clockwise), and which
/// triangles have zero model area (excluded from the objective, kept from flipping).
#[derive(Debug, Clone, Copy)]
pub struct StretchChart<'a> {
    /// Vertex positions, model units.
    pub positions_m: &'a [[f64; 3]],
    /// Triangles as vertex indices.
    pub triangles: &'a [[u32; 3]],
    /// Per triangle: zero model area (collinear corners or a repeated vertex).
    pub zero_area: &'a [bool],
}

/// What [`optimize_chart_stretch`] did to one chart.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ChartStretchOutcome {
    /// The map satisfied the preconditions and was optimised (possibly with no move kept).
    pub optimized: bool,
    /// Vertex moves kept.
    pub moves: usize,
    /// Passes undone by the per-pass check (a per-move test was too weak; should stay 0).
    pub passes_undone: usize,
    /// Steps of the global descent kept (`global`).
    pub global_steps: usize,
    /// The chart's L2 and L∞ before and after (the scaled metric of the module doc); `None`
    /// when not optimised.
    pub before: Option<(f64, f64)>,
    /// See `before`.
    pub after: Option<(f64, f64)>,
}

/// Counters of the stretch optimisation over all charts (`stage::optimize_stretch_charts`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StretchStats {
    /// Charts whose map was optimised.
    pub charts_optimized: usize,
    /// Charts left unchanged because their map did not meet the preconditions.
    pub charts_skipped: usize,
    /// Vertex moves kept over all charts.
    pub moves: usize,
    /// Passes undone by the per-pass check (0 expected).
    pub passes_undone: usize,
}

/// The parameterizer's own zero-area test (`ChartMesh::validate`): twice the area at most 1e-12
/// of the longest edge squared.
pub(super) fn zero_model_area(cm: &ChartMesh, t: &[u32; 3]) -> bool {
    let [a, b, c] = t.map(|i| cm.positions_m[i as usize]);
    let e0 = sub3(b, a);
    let e1 = sub3(c, a);
    let e2 = sub3(c, b);
    let longest2 = dot3(e0, e0).max(dot3(e1, e1)).max(dot3(e2, e2));
    let cr = cross3(e0, e1);
    let twice = dot3(cr, cr).sqrt();
    !exceeds(twice, 1e-12 * longest2)
}

fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub(super) fn cross2(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}
pub(super) fn sub2(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

/// A face of positive model area in its own orthonormal frame: corner 0 at the origin, corner 1
/// at `(l1, 0)`, corner 2 at `(x2, y2)` with `y2 > 0`.
#[derive(Debug, Clone, Copy)]
struct FrameFace {
    l1: f64,
    x2: f64,
    y2: f64,
    a3: f64,
}

impl FrameFace {
    fn new(p: [[f64; 3]; 3]) -> Option<Self> {
        let e1 = sub3(p[1], p[0]);
        let e2 = sub3(p[2], p[0]);
        let l1 = dot3(e1, e1).sqrt();
        let cr = cross3(e1, e2);
        let twice = dot3(cr, cr).sqrt();
        if !(l1 > 0.0 && twice > 0.0) {
            return None;
        }
        let x2 = dot3(e1, e2) / l1;
        let y2 = twice / l1;
        (x2.is_finite() && y2.is_finite()).then_some(Self {
            l1,
            x2,
            y2,
            a3: 0.5 * twice,
        })
    }

    /// `(Γ, γ, 2·A2)` of the map with UV corners `q`, unscaled; `None` when the UV triangle is
    /// not positively oriented (or not finite).
    #[inline]
    fn singular_values(&self, q: [[f64; 2]; 3]) -> Option<(f64, f64, f64)> {
        let u1 = sub2(q[1], q[0]);
        let u2 = sub2(q[2], q[0]);
        let det = cross2(u1, u2);
        if !exceeds(det, 0.0) {
            return None;
        }
        // M = Q·P⁻¹, Q = [[l1, x2], [0, y2]] (model edges), P = [u1 u2] (UV edges).
        let inv = 1.0 / det;
        let m00 = (self.l1 * u2[1] - self.x2 * u1[1]) * inv;
        let m01 = (self.x2 * u1[0] - self.l1 * u2[0]) * inv;
        let m10 = -self.y2 * u1[1] * inv;
        let m11 = self.y2 * u1[0] * inv;
        let (e, f) = (0.5 * (m00 + m11), 0.5 * (m00 - m11));
        let (g, h) = (0.5 * (m10 + m01), 0.5 * (m10 - m01));
        let big = (e * e + h * h).sqrt() + (f * f + g * g).sqrt();
        // det M = det Q / det P > 0; γ = det M / Γ keeps its precision when γ ≪ Γ.
        let small = self.l1 * self.y2 * inv / big;
        (big.is_finite() && small > 0.0).then_some((big, small, det))
    }
}

/// Per-vertex incidence: the faces around each vertex and the vertex's corner in each.
pub(super) struct Incidence {
    pub(super) ptr: Vec<usize>,
    pub(super) face: Vec<u32>,
    pub(super) corner: Vec<u8>,
}

impl Incidence {
    pub(super) fn new(n: usize, triangles: &[[u32; 3]]) -> Self {
        let mut ptr = vec![0usize; n + 1];
        for t in triangles {
            for &v in t {
                ptr[v as usize + 1] += 1;
            }
        }
        for v in 0..n {
            ptr[v + 1] += ptr[v];
        }
        let mut fill = ptr.clone();
        let mut face = vec![0u32; ptr[n]];
        let mut corner = vec![0u8; ptr[n]];
        for (f, t) in triangles.iter().enumerate() {
            for (c, &v) in t.iter().enumerate() {
                face[fill[v as usize]] = f as u32;
                corner[fill[v as usize]] = c as u8;
                fill[v as usize] += 1;
            }
        }
        Self { ptr, face, corner }
    }
    pub(super) fn of(&self, v: usize) -> impl Iterator<Item = (usize, usize)> + '_ {
        (self.ptr[v]..self.ptr[v + 1]).map(|k| (self.face[k] as usize, self.corner[k] as usize))
    }
}

/// The per-face values of one vertex position: Σ 2·A2 and Σ (Γ²+γ²)/2·A3 over its positive
/// faces, and their extreme singular values.
#[derive(Debug, Clone, Copy)]
struct Local {
    twice_a2: f64,
    l2_sum: f64,
    big_max: f64,
    small_min: f64,
}

/// Which phase a line search serves.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Linf,
    L2,
}

/// The optimiser's state for one chart.
struct State<'a> {
    chart: StretchChart<'a>,
    frames: Vec<Option<FrameFace>>,
    inc: Incidence,
    movable: Vec<bool>,
    on_boundary: Vec<bool>,
    /// Boundary segments `(a, b, owning triangle)` of the positive-area faces.
    segs: Vec<(u32, u32, usize)>,
    /// Per boundary vertex, its two segments (indices into `segs`).
    vertex_segs: Vec<[u32; 2]>,
    /// The positive-area faces as a chart (same vertex numbering), for `fold_with_boundary`.
    solid: ChartMesh,
    a3_total: f64,
    /// Σ 2·A2 and Σ (Γ²+γ²)/2·A3 over the positive-area faces, maintained per move.
    twice_a2_total: f64,
    l2_total: f64,
    /// Per face `(Γ, γ)` (unscaled), maintained per move; 0 for zero-area faces.
    big: Vec<f64>,
    small: Vec<f64>,
    /// The largest `Γ` and smallest `γ` over the positive-area faces: exact after `reset`, then
    /// only widened by moves (a bound: a move that lowers the maximum leaves it stale-high), so
    /// checks against it are conservative.
    big_bound: f64,
    small_bound: f64,
}

/// Optimises `uv` (one per chart vertex, model units) for Sander's stretch: the global descent,
/// then `passes` passes of each vertex phase (0: the global descent only); see the module doc for
/// the algorithm and its guarantees. Pure and sequential.
pub fn optimize_chart_stretch(
    chart: &StretchChart<'_>,
    uv: &mut [[f64; 2]],
    passes: u32,
) -> ChartStretchOutcome {
    let mut out = ChartStretchOutcome::default();
    let Some(mut st) = State::new(chart, uv) else {
        return out;
    };
    let Some(before) = st.check(uv) else {
        return out;
    };
    out.optimized = true;
    out.before = Some(before);
    let original = uv.to_vec();
    let mut current = before;
    // First the chart-wide scale error, all vertices at once (`global`), with L∞ capped.
    out.global_steps = global::descend(&st, uv, before.1 * (1.0 + LINF_ROUNDING));
    if out.global_steps > 0 {
        match st.check(uv) {
            Some(after) => current = after,
            None => {
                uv.copy_from_slice(&original);
                out.global_steps = 0;
            }
        }
    }
    let mut order: Vec<u32> = Vec::new();
    for phase in [Phase::Linf, Phase::L2] {
        // The cap on the chart's L∞ for the L2 phase: its value after the L∞ phase.
        let linf_cap = current.1;
        for _ in 0..passes {
            let snapshot = uv.to_vec();
            st.reset(uv);
            let linf_now = st.linf(st.twice_a2_total);
            order.clear();
            match phase {
                Phase::Linf => {
                    let mut keyed: Vec<(f64, u32)> = (0..uv.len())
                        .filter(|&v| st.movable[v])
                        .filter_map(|v| {
                            let m = st.local_max(v, st.twice_a2_total);
                            (m - 1.0 >= LINF_VISIT_FRACTION * (linf_now - 1.0))
                                .then_some((m, v as u32))
                        })
                        .collect();
                    keyed.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
                    order.extend(keyed.iter().map(|&(_, v)| v));
                }
                Phase::L2 => order.extend((0..uv.len() as u32).filter(|&v| st.movable[v as usize])),
            }
            let mut moved = 0usize;
            for &v in &order {
                if st.move_vertex(v as usize, uv, phase, linf_cap) {
                    moved += 1;
                }
            }
            if moved == 0 {
                break;
            }
            // L∞ phase: no move raises the chart's L∞; L2 phase: none raises it above its value at
            // the phase's start (a pass may lower it, and the next raise it back to that cap).
            let bound = match phase {
                Phase::Linf => current.1,
                Phase::L2 => linf_cap,
            };
            match st.check(uv) {
                Some(after) if after.1 <= bound * (1.0 + LINF_ROUNDING) => {
                    current = after;
                    out.moves += moved;
                }
                _ => {
                    uv.copy_from_slice(&snapshot);
                    out.passes_undone += 1;
                    break;
                }
            }
        }
    }
    // The L∞ phase may raise L2 and the L2 phase lower it again; keep the result only when
    // neither norm ends higher than it started.
    if !(current.0 <= before.0 && current.1 <= before.1 * (1.0 + LINF_ROUNDING)) {
        uv.copy_from_slice(&original);
        out.moves = 0;
        out.global_steps = 0;
        current = before;
    }
    // The last test (`clearance`'s module doc; the global descent keeps it at each step, the
    // vertex passes do not): a moved map whose border parts came closer than the clearance is
    // not kept.
    if out.moves + out.global_steps > 0
        && clearance::too_close(
            st.chart.triangles,
            &st.segs,
            uv,
            Some(&original),
            clearance::CLEARANCE_RELATIVE * clearance::extent(&original),
        )
    {
        uv.copy_from_slice(&original);
        out.moves = 0;
        out.global_steps = 0;
        current = before;
    }
    out.after = Some(current);
    out
}

impl<'a> State<'a> {
    /// Builds the state; `None` when the chart is not usable (index out of range, no face of
    /// positive model area, a non-manifold boundary among those faces).
    fn new(chart: &StretchChart<'a>, uv: &[[f64; 2]]) -> Option<Self> {
        let n = uv.len();
        if chart.positions_m.len() != n || chart.zero_area.len() != chart.triangles.len() {
            return None;
        }
        if chart.triangles.iter().flatten().any(|&i| i as usize >= n) {
            return None;
        }
        let frames: Vec<Option<FrameFace>> = chart
            .triangles
            .iter()
            .zip(chart.zero_area)
            .map(|(t, &z)| {
                if z || t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                    None
                } else {
                    FrameFace::new(t.map(|i| chart.positions_m[i as usize]))
                }
            })
            .collect();
        let solid_tris: Vec<[u32; 3]> = chart
            .triangles
            .iter()
            .zip(&frames)
            .filter(|(_, f)| f.is_some())
            .map(|(t, _)| *t)
            .collect();
        if solid_tris.is_empty() {
            return None;
        }
        let inc = Incidence::new(n, chart.triangles);
        let mut movable = vec![false; n];
        for t in &solid_tris {
            for &v in t {
                movable[v as usize] = true;
            }
        }
        let solid_face: Vec<bool> = frames.iter().map(Option::is_some).collect();
        let (segs, on_boundary, vertex_segs) = boundary_segments(n, chart.triangles, &solid_face)?;
        let a3_total = frames.iter().flatten().map(|f| f.a3).sum();
        let nf = chart.triangles.len();
        Some(Self {
            chart: *chart,
            frames,
            inc,
            movable,
            on_boundary,
            segs,
            vertex_segs,
            solid: ChartMesh {
                positions_m: chart.positions_m.to_vec(),
                triangles: solid_tris,
            },
            a3_total,
            twice_a2_total: 0.0,
            l2_total: 0.0,
            big: vec![0.0; nf],
            small: vec![0.0; nf],
            big_bound: 0.0,
            small_bound: f64::INFINITY,
        })
    }

    /// Recomputes the maintained sums and extremes from `uv` (start of each pass).
    fn reset(&mut self, uv: &[[f64; 2]]) {
        self.twice_a2_total = 0.0;
        self.l2_total = 0.0;
        self.big_bound = 0.0;
        self.small_bound = f64::INFINITY;
        for (f, t) in self.chart.triangles.iter().enumerate() {
            let Some(frame) = self.frames[f] else {
                continue;
            };
            // `check` ran before: every positive-area face is positive.
            let (b, s, det) = frame.singular_values(t.map(|i| uv[i as usize])).unwrap_or((
                f64::INFINITY,
                0.0,
                0.0,
            ));
            self.big[f] = b;
            self.small[f] = s;
            self.twice_a2_total += det;
            self.l2_total += 0.5 * (b * b + s * s) * frame.a3;
            self.big_bound = self.big_bound.max(b);
            self.small_bound = self.small_bound.min(s);
        }
    }

    /// The scale factor √r for a chart UV area sum `twice_a2` (twice the area).
    fn scale(&self, twice_a2: f64) -> f64 {
        (0.5 * twice_a2 / self.a3_total).sqrt()
    }

    /// A bound on the chart's L∞ from the maintained extremes (exact after `reset`).
    fn linf(&self, twice_a2: f64) -> f64 {
        let s = self.scale(twice_a2);
        (self.big_bound * s).max(1.0 / (self.small_bound * s))
    }

    /// The maximum of `v_f` over the positive-area faces around `v`, at the current position.
    fn local_max(&self, v: usize, twice_a2: f64) -> f64 {
        let s = self.scale(twice_a2);
        self.inc
            .of(v)
            .filter(|&(f, _)| self.frames[f].is_some())
            .map(|(f, _)| (self.big[f] * s).max(1.0 / (self.small[f] * s)))
            .fold(0.0, f64::max)
    }

    /// The fan values with `v` at `p`; `None` when a positive-area face would not be positive or
    /// a zero-area face would become flipped.
    fn eval(&self, uv: &[[f64; 2]], v: usize, p: [f64; 2]) -> Option<Local> {
        let mut l = Local {
            twice_a2: 0.0,
            l2_sum: 0.0,
            big_max: 0.0,
            small_min: f64::INFINITY,
        };
        for (f, c) in self.inc.of(v) {
            let t = self.chart.triangles[f];
            let mut q = t.map(|i| uv[i as usize]);
            q[c] = p;
            match self.frames[f] {
                Some(frame) => {
                    let (b, s, det) = frame.singular_values(q)?;
                    l.twice_a2 += det;
                    l.l2_sum += 0.5 * (b * b + s * s) * frame.a3;
                    l.big_max = l.big_max.max(b);
                    l.small_min = l.small_min.min(s);
                }
                None => {
                    let before = cross2(sub2(uv[t[1] as usize], uv[t[0] as usize]), {
                        sub2(uv[t[2] as usize], uv[t[0] as usize])
                    });
                    let after = cross2(sub2(q[1], q[0]), sub2(q[2], q[0]));
                    if after < before.min(0.0) {
                        return None;
                    }
                }
            }
        }
        Some(l)
    }

    /// Tries one move of `v` (module doc); returns whether it was kept.
    fn move_vertex(&mut self, v: usize, uv: &mut [[f64; 2]], phase: Phase, linf_cap: f64) -> bool {
        let p0 = uv[v];
        let Some(l0) = self.eval(uv, v, p0) else {
            return false;
        };
        let boundary = self.on_boundary[v];
        // Interior moves keep the chart's UV area (exactly, up to rounding): hold it fixed so
        // that the faces elsewhere keep their scaled values bit for bit.
        let total_at = |l: &Local| {
            if boundary {
                self.twice_a2_total - l0.twice_a2 + l.twice_a2
            } else {
                self.twice_a2_total
            }
        };
        // The faces outside the fan of a boundary vertex (whose move changes the chart's scale):
        // bounded by the whole chart's extremes (conservative).
        let (rest_big, rest_small) = if boundary {
            (self.big_bound, self.small_bound)
        } else {
            (0.0, f64::INFINITY)
        };
        let chart_linf = |l: &Local| {
            let s = self.scale(total_at(l));
            let big = if boundary {
                rest_big.max(l.big_max)
            } else {
                l.big_max
            };
            let small = if boundary {
                rest_small.min(l.small_min)
            } else {
                l.small_min
            };
            (big * s).max(1.0 / (small * s))
        };
        let linf_start = self.linf(self.twice_a2_total);
        let local_max = |l: &Local| {
            let s = self.scale(total_at(l));
            (l.big_max * s).max(1.0 / (l.small_min * s))
        };
        // The objective to minimise; `None` when the constraint on the chart's L∞ fails.
        let objective = |l: &Local| -> Option<f64> {
            match phase {
                Phase::Linf => (chart_linf(l) <= linf_start).then(|| local_max(l)),
                Phase::L2 => (chart_linf(l) <= linf_cap)
                    .then(|| total_at(l) * (self.l2_total - l0.l2_sum + l.l2_sum)),
            }
        };
        let Some(phi0) = objective(&l0) else {
            return false;
        };
        // The smooth proxy whose gradient gives the direction.
        let m0 = local_max(&l0);
        let proxy = |p: [f64; 2]| -> Option<f64> {
            match phase {
                Phase::L2 => {
                    let l = self.eval(uv, v, p)?;
                    Some(total_at(&l) * (self.l2_total - l0.l2_sum + l.l2_sum))
                }
                Phase::Linf => {
                    let l = self.eval(uv, v, p)?;
                    let s = self.scale(total_at(&l));
                    let mut sum = 0.0;
                    for (f, c) in self.inc.of(v) {
                        let Some(frame) = self.frames[f] else {
                            continue;
                        };
                        let t = self.chart.triangles[f];
                        let mut q = t.map(|i| uv[i as usize]);
                        q[c] = p;
                        let (b, sm, _) = frame.singular_values(q)?;
                        let x = (b * s).max(1.0 / (sm * s)) / m0;
                        let x2 = x * x;
                        let x4 = x2 * x2;
                        sum += frame.a3 * x4 * x4;
                    }
                    Some(sum)
                }
            }
        };
        // Local UV length scale: mean incident edge length.
        let (mut len, mut cnt) = (0.0, 0usize);
        for (f, c) in self.inc.of(v) {
            let t = self.chart.triangles[f];
            for k in [1, 2] {
                let w = uv[t[(c + k) % 3] as usize];
                len += (sub2(w, p0)[0].powi(2) + sub2(w, p0)[1].powi(2)).sqrt();
                cnt += 1;
            }
        }
        if cnt == 0 || !exceeds(len, 0.0) {
            return false;
        }
        let scale_len = len / cnt as f64;
        let h = 1e-6 * scale_len;
        // In the L2 phase the proxy is the objective, known at `p0`.
        let base = match phase {
            Phase::L2 => phi0,
            Phase::Linf => match proxy(p0) {
                Some(b) => b,
                None => return false,
            },
        };
        let (Some(px), Some(py)) = (proxy([p0[0] + h, p0[1]]), proxy([p0[0], p0[1] + h])) else {
            return false;
        };
        let g = [(px - base) / h, (py - base) / h];
        let gn = (g[0] * g[0] + g[1] * g[1]).sqrt();
        if !(gn > 0.0 && gn.is_finite()) {
            return false;
        }
        let d = [-g[0] / gn, -g[1] / gn];
        // Clip the line to the kernel: the signed area of each face is linear in t.
        let mut t_max = if boundary { scale_len } else { f64::INFINITY };
        for (f, c) in self.inc.of(v) {
            let t = self.chart.triangles[f];
            let u = sub2(uv[t[(c + 1) % 3] as usize], p0);
            let w = sub2(uv[t[(c + 2) % 3] as usize], p0);
            let a0 = cross2(u, w);
            // 2A(t) = a0 − t · d × (w − u)
            let slope = -cross2(d, sub2(w, u));
            let floor = if self.frames[f].is_some() {
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
        let hi = 0.999 * t_max;
        let at = |t: f64| [p0[0] + t * d[0], p0[1] + t * d[1]];
        let value = |t: f64| -> f64 {
            self.eval(uv, v, at(t))
                .and_then(|l| objective(&l))
                .unwrap_or(f64::INFINITY)
        };
        let (best_t, best) = match phase {
            // L∞: the objective is a maximum (not smooth), so a bracketing search.
            Phase::Linf => golden_search(&value, hi, phi0),
            // L2: smooth along the line, so a parabola through the known slope.
            Phase::L2 => parabolic_search(&value, hi, phi0, -gn),
        };
        if !exceeds(phi0, best) || best_t == 0.0 {
            return false;
        }
        let mut t = best_t;
        for retry in 0..=BOUNDARY_RETRIES {
            let p = at(t);
            if retry > 0 {
                let Some(l) = self.eval(uv, v, p) else {
                    return false;
                };
                match objective(&l) {
                    Some(x) if x < phi0 => {}
                    _ => return false,
                }
            }
            if !boundary || self.boundary_ok(uv, v, p) {
                let Some(l) = self.eval(uv, v, p) else {
                    return false;
                };
                self.apply(uv, v, p, &l0, &l, boundary);
                return true;
            }
            t *= 0.5;
        }
        false
    }

    /// Whether moving the boundary vertex `v` to `p` keeps the boundary simple and every
    /// boundary vertex of its fan unfolded ([`boundary_move_ok`]).
    fn boundary_ok(&self, uv: &[[f64; 2]], v: usize, p: [f64; 2]) -> bool {
        boundary_move_ok(
            &BoundaryView {
                segs: &self.segs,
                vertex_segs: &self.vertex_segs,
                on_boundary: &self.on_boundary,
                inc: &self.inc,
                triangles: self.chart.triangles,
                solid: &|f| self.frames[f].is_some(),
            },
            uv,
            v,
            p,
        )
    }

    /// Moves `v` to `p` and updates the maintained values (`l0`, `l`: its fan before, after).
    fn apply(
        &mut self,
        uv: &mut [[f64; 2]],
        v: usize,
        p: [f64; 2],
        l0: &Local,
        l: &Local,
        boundary: bool,
    ) {
        uv[v] = p;
        if boundary {
            self.twice_a2_total += l.twice_a2 - l0.twice_a2;
        }
        self.l2_total += l.l2_sum - l0.l2_sum;
        for k in self.inc.ptr[v]..self.inc.ptr[v + 1] {
            let f = self.inc.face[k] as usize;
            let Some(frame) = self.frames[f] else {
                continue;
            };
            let t = self.chart.triangles[f];
            let (b, s, _) = frame.singular_values(t.map(|i| uv[i as usize])).unwrap_or((
                f64::INFINITY,
                0.0,
                0.0,
            ));
            self.big[f] = b;
            self.small[f] = s;
            self.big_bound = self.big_bound.max(b);
            self.small_bound = self.small_bound.min(s);
        }
    }

    /// The chart's `(L2, L∞)` computed from scratch when the map passes every invariant of the
    /// module doc (positive faces, simple boundary, no fold); `None` otherwise.
    fn check(&self, uv: &[[f64; 2]]) -> Option<(f64, f64)> {
        let (mut twice_a2, mut l2, mut big, mut small) = (0.0, 0.0, 0.0f64, f64::INFINITY);
        for (f, t) in self.chart.triangles.iter().enumerate() {
            let q = t.map(|i| uv[i as usize]);
            if !q.iter().all(|p| p[0].is_finite() && p[1].is_finite()) {
                return None;
            }
            let Some(frame) = self.frames[f] else {
                continue;
            };
            let (b, s, det) = frame.singular_values(q)?;
            twice_a2 += det;
            l2 += 0.5 * (b * b + s * s) * frame.a3;
            big = big.max(b);
            small = small.min(s);
        }
        if crossing_among(&self.segs, uv).is_some()
            || fold_with_boundary(&self.solid, uv, &self.on_boundary).is_some()
        {
            return None;
        }
        let r = 0.5 * twice_a2 / self.a3_total;
        let s = r.sqrt();
        Some((
            (r * l2 / self.a3_total).sqrt(),
            (big * s).max(1.0 / (small * s)),
        ))
    }
}

/// The chart's `(L2, L∞)` in the scaled metric of the module doc, over its faces of positive
/// model area, when every such face is positively oriented; `None` otherwise. For reports and
/// tests.
pub fn chart_stretch(chart: &StretchChart<'_>, uv: &[[f64; 2]]) -> Option<(f64, f64)> {
    let (mut twice_a2, mut l2, mut a3, mut big, mut small) = (0.0, 0.0, 0.0, 0.0f64, f64::INFINITY);
    for (t, &z) in chart.triangles.iter().zip(chart.zero_area) {
        if z {
            continue;
        }
        let Some(frame) = FrameFace::new(t.map(|i| chart.positions_m[i as usize])) else {
            continue;
        };
        let (b, s, det) = frame.singular_values(t.map(|i| uv[i as usize]))?;
        twice_a2 += det;
        l2 += 0.5 * (b * b + s * s) * frame.a3;
        a3 += frame.a3;
        big = big.max(b);
        small = small.min(s);
    }
    if !exceeds(a3, 0.0) {
        return None;
    }
    let r = 0.5 * twice_a2 / a3;
    Some((
        (r * l2 / a3).sqrt(),
        (big * r.sqrt()).max(1.0 / (small * r.sqrt())),
    ))
}

/// Boundary segments `(a, b, owning triangle)` of the faces flagged `solid`, the boundary
/// flag of every vertex, and each boundary vertex's (outgoing, incoming) segment indices;
/// `None` when a directed edge repeats or a vertex has two outgoing or two incoming boundary
/// segments (the solid faces are not a manifold disk there). Shared by the stretch optimiser and
/// ASP (`super::asp`).
#[allow(clippy::type_complexity)]
pub(super) fn boundary_segments(
    n: usize,
    triangles: &[[u32; 3]],
    solid: &[bool],
) -> Option<(Vec<(u32, u32, usize)>, Vec<bool>, Vec<[u32; 2]>)> {
    // Boundary half-edges of the solid faces (reverse absent); each directed edge once, each
    // boundary vertex with one outgoing and one incoming segment.
    let mut sorted: Vec<(u32, u32)> = Vec::with_capacity(3 * triangles.len());
    for (t, _) in triangles.iter().zip(solid).filter(|(_, &s)| s) {
        for s in 0..3 {
            sorted.push((t[s], t[(s + 1) % 3]));
        }
    }
    sorted.sort_unstable();
    if sorted.windows(2).any(|w| w[0] == w[1]) {
        return None;
    }
    let mut segs = Vec::new();
    let mut on_boundary = vec![false; n];
    let mut vertex_segs = vec![[u32::MAX; 2]; n];
    for (k, t) in triangles.iter().enumerate().filter(|(k, _)| solid[*k]) {
        for s in 0..3 {
            let (a, b) = (t[s], t[(s + 1) % 3]);
            if sorted.binary_search(&(b, a)).is_err() {
                let i = segs.len() as u32;
                segs.push((a, b, k));
                *on_boundary.get_mut(a as usize)? = true;
                *on_boundary.get_mut(b as usize)? = true;
                let slot = &mut vertex_segs.get_mut(a as usize)?[0];
                if *slot != u32::MAX {
                    return None;
                }
                *slot = i;
                let slot = &mut vertex_segs.get_mut(b as usize)?[1];
                if *slot != u32::MAX {
                    return None;
                }
                *slot = i;
            }
        }
    }
    Some((segs, on_boundary, vertex_segs))
}

/// What [`boundary_move_ok`] reads: the boundary of the solid faces ([`boundary_segments`]),
/// the incidence, and which faces are solid.
pub(super) struct BoundaryView<'a> {
    pub(super) segs: &'a [(u32, u32, usize)],
    pub(super) vertex_segs: &'a [[u32; 2]],
    pub(super) on_boundary: &'a [bool],
    pub(super) inc: &'a Incidence,
    pub(super) triangles: &'a [[u32; 3]],
    pub(super) solid: &'a dyn Fn(usize) -> bool,
}

/// Whether moving the boundary vertex `v` to `p` keeps the boundary simple (its two segments
/// cross no other) and every boundary vertex of its fan unfolded (UV angle sum below 2π −
/// `FOLD_MARGIN_RAD`). Cost: O(boundary segments + fan).
pub(super) fn boundary_move_ok(
    b: &BoundaryView<'_>,
    uv: &[[f64; 2]],
    v: usize,
    p: [f64; 2],
) -> bool {
    let pos = |i: u32| if i as usize == v { p } else { uv[i as usize] };
    let Some(own) = b.vertex_segs.get(v) else {
        return false;
    };
    for &si in own {
        let Some(&(a, bb, _)) = b.segs.get(si as usize) else {
            return false;
        };
        let (pa, pb) = (pos(a), pos(bb));
        let (lo, hi) = (
            [pa[0].min(pb[0]), pa[1].min(pb[1])],
            [pa[0].max(pb[0]), pa[1].max(pb[1])],
        );
        for &(c, d, _) in b.segs {
            if c == a || c == bb || d == a || d == bb {
                continue;
            }
            let (pc, pd) = (pos(c), pos(d));
            if pc[0].max(pd[0]) < lo[0]
                || pc[0].min(pd[0]) > hi[0]
                || pc[1].max(pd[1]) < lo[1]
                || pc[1].min(pd[1]) > hi[1]
            {
                continue;
            }
            if segments_intersect(pa, pb, pc, pd) {
                return false;
            }
        }
    }
    // Angle sums at the boundary vertices whose angles change: `v` and its fan's corners.
    let mut check = vec![v as u32];
    for (f, _) in b.inc.of(v) {
        if (b.solid)(f) {
            for &w in &b.triangles[f] {
                if b.on_boundary[w as usize] && !check.contains(&w) {
                    check.push(w);
                }
            }
        }
    }
    let limit = std::f64::consts::TAU - FOLD_MARGIN_RAD;
    for &w in &check {
        let mut sum = 0.0;
        for (f, c) in b.inc.of(w as usize) {
            if !(b.solid)(f) {
                continue;
            }
            let t = b.triangles[f];
            let (pw, pa, pb) = (pos(t[c]), pos(t[(c + 1) % 3]), pos(t[(c + 2) % 3]));
            let (e1, e2) = (sub2(pa, pw), sub2(pb, pw));
            sum += cross2(e1, e2).atan2(e1[0] * e2[0] + e1[1] * e2[1]).abs();
        }
        if !exceeds(limit, sum) {
            return false;
        }
    }
    true
}

mod clearance;
mod global;
pub(super) use global::descend_for_bound;
mod search;
use search::{golden_search, parabolic_search, GOLDEN_STEPS, PARABOLA_EVALS};
#[cfg(test)]
pub(super) mod tests;
