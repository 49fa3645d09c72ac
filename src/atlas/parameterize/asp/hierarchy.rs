//! Hierarchical ASP (asp-2003 §4, "hierarchical optimization" after Hormann): the vertex
//! relaxation of [`super::relax_chart_asp`] run coarse to fine over the HLSCM progressive mesh
//! (`progressive_mesh`, Ray & Lévy 2003), so that area moves across a large chart at the coarse
//! levels in a few sweeps instead of creeping one ring per Gauss–Seidel sweep.
//!
//! Levels: the progressive mesh of the chart (half-edge collapses, boundary kept a simple loop)
//! read at `n, n/r, n/r², …` vertices (`r` = [`LEVEL_RATIO`]) down to about
//! [`COARSEST_VERTICES`]. The coarsest level whose restriction of the start map is valid is
//! relaxed first (the paper starts from one triangle; we start from the LSCM map, the θ = 0 end
//! of the trade-off). Going one level finer, every re-inserted vertex is placed by the affine map
//! that takes its recorded nearest triangle (`Collapse::triangle`) from the start map to the
//! relaxed coarse map, i.e. the coarse correction applied to the start map's local shape. Where
//! that leaves a face of a re-inserted vertex non-positive, the vertex is moved into the kernel
//! of its ring by the paper's ray casting ("cast a ray from the texture coordinate … in random
//! direction and intersect with the ring kernel; … choose the center of the intersection
//! interval"), with [`RAY_DIRECTIONS`] fixed directions (deterministic) from two origins (its
//! position and the centroid of its ring). Each level is then relaxed, which keeps it valid.
//!
//! Fallback: when a level cannot be made valid (no kernel point found, a boundary crossing or a
//! fold after the placement), or when the finest result has a higher energy than the start
//! map's, the chart is relaxed at the finest level only, from the start map. So the result
//! always satisfies [`super::relax_chart_asp`]'s guarantees: valid, energy not above the
//! start's. Charts with zero-area faces, or too small for two levels, use the single level.
//!
//! Cost: the progressive mesh (`O(n log n)`), then about `r/(r−1)` times the finest level's
//! relaxation. Deterministic: the progressive mesh is (its own module doc), the rest is
//! sequential.
use super::{relax_chart_asp, AspOutcome, State};
use crate::atlas::parameterize::chart::ChartMesh;
use crate::atlas::parameterize::progressive_mesh::{
    build_progressive_mesh, ProgressiveMesh, ProgressiveMeshOptions,
};
use crate::atlas::parameterize::stretch::{
    boundary_move_ok, cross2, sub2, BoundaryView, StretchChart,
};

/// Vertex-count ratio between consecutive levels. Trade-off: a larger ratio makes fewer levels
/// (less total work) but each prolongation guesses more vertices at once.
pub const LEVEL_RATIO: usize = 4;
/// The coarsest level has about this many vertices (at least); charts with fewer than
/// `LEVEL_RATIO ×` this are relaxed on one level.
pub const COARSEST_VERTICES: usize = 64;
/// Ray directions tried per origin when placing a re-inserted vertex in its kernel.
const RAY_DIRECTIONS: usize = 16;
/// Rounds of kernel placement after a prolongation (a placement can unblock a neighbour).
const REPAIR_ROUNDS: usize = 3;

/// [`relax_chart_asp`] run coarse to fine (module doc); same contract and guarantees.
pub fn relax_chart_asp_hierarchical(
    chart: &StretchChart<'_>,
    uv: &mut [[f64; 2]],
    theta: f64,
    max_sweeps: usize,
) -> AspOutcome {
    let n = uv.len();
    if chart.zero_area.iter().any(|&z| z)
        || n < LEVEL_RATIO * COARSEST_VERTICES
        || chart.positions_m.len() != n
    {
        return relax_chart_asp(chart, uv, theta, max_sweeps);
    }
    let start = uv.to_vec();
    match hierarchical(chart, &start, theta, max_sweeps) {
        Some((result, out)) => {
            // Keep it only when it beats the start map's energy (scaled like the result).
            let mut single_start = start.clone();
            let reference = relax_chart_asp(chart, &mut single_start, theta, 0);
            if reference.relaxed && out.energy_after <= reference.energy_before {
                uv.copy_from_slice(&result);
                AspOutcome {
                    energy_before: reference.energy_before,
                    ..out
                }
            } else {
                relax_chart_asp(chart, uv, theta, max_sweeps)
            }
        }
        None => relax_chart_asp(chart, uv, theta, max_sweeps),
    }
}

/// The coarse-to-fine relaxation; `None` when a level cannot be made valid or the finest level
/// is not relaxed.
fn hierarchical(
    chart: &StretchChart<'_>,
    start: &[[f64; 2]],
    theta: f64,
    max_sweeps: usize,
) -> Option<(Vec<[f64; 2]>, AspOutcome)> {
    let n = start.len();
    let cm = ChartMesh {
        positions_m: chart.positions_m.to_vec(),
        triangles: chart.triangles.to_vec(),
    };
    cm.validate().ok()?;
    let pm = build_progressive_mesh(
        &cm,
        &[],
        &ProgressiveMeshOptions {
            min_vertices: COARSEST_VERTICES,
            ..ProgressiveMeshOptions::default()
        },
    )
    .ok()?;
    // Collapses applied per level, coarsest first, the finest (0) last.
    let mut applied = vec![0usize];
    let mut target = n / LEVEL_RATIO;
    while target >= COARSEST_VERTICES {
        let a = (n - target).min(pm.collapses.len());
        if a <= *applied.last()? {
            break;
        }
        applied.push(a);
        target /= LEVEL_RATIO;
    }
    applied.reverse();
    if applied.len() < 2 {
        return None;
    }
    let mut cur = start.to_vec();
    let mut inserted = vec![false; n];
    let mut total = AspOutcome::default();
    let mut started = false;
    for (li, &a) in applied.iter().enumerate() {
        let level = pm.level(&cm, a).ok()?;
        let zero = vec![false; level.chart.triangles.len()];
        let lc = StretchChart {
            positions_m: &level.chart.positions_m,
            triangles: &level.chart.triangles,
            zero_area: &zero,
        };
        let mut luv: Vec<[f64; 2]> = level
            .chart_vertex
            .iter()
            .map(|&v| cur[v as usize])
            .collect();
        if started {
            let ins: Vec<bool> = level
                .chart_vertex
                .iter()
                .map(|&v| inserted[v as usize])
                .collect();
            if !repair(&lc, &mut luv, &ins, theta) {
                return None;
            }
        }
        let out = relax_chart_asp(&lc, &mut luv, theta, max_sweeps);
        if !out.relaxed {
            if started || li + 1 == applied.len() {
                return None;
            }
            // The start map restricted to this level is not valid: start one level finer.
            continue;
        }
        started = true;
        total.relaxed = true;
        total.levels += 1;
        total.sweeps += out.sweeps;
        total.moves += out.moves;
        total.sweeps_undone += out.sweeps_undone;
        total.energy_after = out.energy_after;
        for (k, &v) in level.chart_vertex.iter().enumerate() {
            cur[v as usize] = luv[k];
        }
        if let Some(&next) = applied.get(li + 1) {
            inserted.fill(false);
            prolong(&pm, start, &mut cur, a, next, &mut inserted);
        }
    }
    total.relaxed.then_some((cur, total))
}

/// Vertex splits from `coarse` collapses back to `fine`: each re-inserted vertex gets the image
/// of its start-map position under the affine map taking its recorded triangle from the start
/// map (`start`) to the current map (`cur`); the recorded barycentric point when that triangle
/// is degenerate in the start map. Marks the re-inserted vertices in `inserted`.
fn prolong(
    pm: &ProgressiveMesh,
    start: &[[f64; 2]],
    cur: &mut [[f64; 2]],
    coarse: usize,
    fine: usize,
    inserted: &mut [bool],
) {
    let hi = coarse.min(pm.collapses.len());
    let lo = fine.min(hi);
    for c in pm.collapses[lo..hi].iter().rev() {
        let [i, j, k] = c.triangle.map(|v| v as usize);
        let x = c.removed as usize;
        let (p, q, r) = (start[i], start[j], start[k]);
        let (e1, e2) = (sub2(q, p), sub2(r, p));
        let d = cross2(e1, e2);
        let scale = (e1[0] * e1[0] + e1[1] * e1[1]) * (e2[0] * e2[0] + e2[1] * e2[1]);
        let lambda = if d * d > 1e-12 * scale && d.is_finite() {
            let w = sub2(start[x], p);
            let l1 = cross2(w, e2) / d;
            let l2 = cross2(e1, w) / d;
            [1.0 - l1 - l2, l1, l2]
        } else {
            c.barycentric
        };
        let pos = [
            lambda[0] * cur[i][0] + lambda[1] * cur[j][0] + lambda[2] * cur[k][0],
            lambda[0] * cur[i][1] + lambda[1] * cur[j][1] + lambda[2] * cur[k][1],
        ];
        if pos[0].is_finite() && pos[1].is_finite() {
            cur[x] = pos;
        }
        inserted[x] = true;
    }
}

/// Moves the re-inserted vertices (`ins`) that have a non-positive face into the kernel of
/// their ring (module doc); whether the level is then valid (positive faces, simple boundary,
/// no fold).
fn repair(lc: &StretchChart<'_>, luv: &mut [[f64; 2]], ins: &[bool], theta: f64) -> bool {
    let Some(st) = State::new(lc, luv, theta) else {
        return false;
    };
    let positive = |luv: &[[f64; 2]], f: usize| {
        let q = lc.triangles[f].map(|i| luv[i as usize]);
        cross2(sub2(q[1], q[0]), sub2(q[2], q[0])) > 0.0
    };
    for _ in 0..REPAIR_ROUNDS {
        let bad: Vec<usize> = (0..luv.len())
            .filter(|&v| ins[v] && st.inc.of(v).any(|(f, _)| !positive(luv, f)))
            .collect();
        if bad.is_empty() {
            break;
        }
        for v in bad {
            place_in_kernel(&st, luv, v);
        }
    }
    st.valid(luv)
}

/// The paper's ray casting: from `v`'s position, then from its ring's centroid, rays in
/// [`RAY_DIRECTIONS`] fixed directions; the first whose intersection with the kernel (every
/// ring face positive) is non-empty gives the interval's centre (a boundary vertex's unbounded
/// interval is capped at its mean ring edge length, and its move must keep the boundary simple).
fn place_in_kernel(st: &State<'_>, luv: &mut [[f64; 2]], v: usize) -> bool {
    let tris = st.chart.triangles;
    let (mut centroid, mut len, mut cnt) = ([0.0, 0.0], 0.0, 0usize);
    for (f, c) in st.inc.of(v) {
        let t = tris[f];
        for k in [1, 2] {
            let w = luv[t[(c + k) % 3] as usize];
            centroid[0] += w[0];
            centroid[1] += w[1];
            let e = sub2(w, luv[v]);
            len += (e[0] * e[0] + e[1] * e[1]).sqrt();
            cnt += 1;
        }
    }
    if cnt == 0 {
        return false;
    }
    let centroid = [centroid[0] / cnt as f64, centroid[1] / cnt as f64];
    let mean_len = len / cnt as f64;
    let view = BoundaryView {
        segs: &st.segs,
        vertex_segs: &st.vertex_segs,
        on_boundary: &st.on_boundary,
        inc: &st.inc,
        triangles: tris,
        solid: &|f| st.faces[f].is_some(),
    };
    for origin in [luv[v], centroid] {
        for k in 0..RAY_DIRECTIONS {
            let angle = std::f64::consts::TAU * (k as f64 + 0.5) / RAY_DIRECTIONS as f64;
            let d = [angle.cos(), angle.sin()];
            // Each face's doubled area along the ray: a0 + s·t, t ≥ 0.
            let (mut lo, mut hi) = (0.0f64, f64::INFINITY);
            for (f, c) in st.inc.of(v) {
                let t = tris[f];
                let u = sub2(luv[t[(c + 1) % 3] as usize], origin);
                let w = sub2(luv[t[(c + 2) % 3] as usize], origin);
                let a0 = cross2(u, w);
                let s = -cross2(d, sub2(w, u));
                if s > 0.0 {
                    lo = lo.max(-a0 / s);
                } else if s < 0.0 {
                    hi = hi.min(-a0 / s);
                } else if a0 <= 0.0 {
                    hi = -1.0;
                }
            }
            if hi.is_infinite() {
                hi = lo + mean_len;
            }
            if !(lo < hi && hi.is_finite()) {
                continue;
            }
            let t = 0.5 * (lo + hi);
            let p = [origin[0] + t * d[0], origin[1] + t * d[1]];
            let ring_ok = st.inc.of(v).all(|(f, c)| {
                let tri = tris[f];
                let mut q = tri.map(|i| luv[i as usize]);
                q[c] = p;
                cross2(sub2(q[1], q[0]), sub2(q[2], q[0])) > 0.0
            });
            if ring_ok && (!st.on_boundary[v] || boundary_move_ok(&view, luv, v, p)) {
                luv[v] = p;
                return true;
            }
        }
    }
    false
}
