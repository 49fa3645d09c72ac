//! The tests a chart's map must pass (Lévy et al. 2002 §3.3) and their 2-D predicates.
//!
//! Purpose: `find_defect` returns the first defect of a map, in the order flips, boundary
//! self-intersection or vertex fold, stretch, area ratio; the stage splits the chart by it.
//!
//! Predicates: orientation signs are computed in `f64` with a relative tolerance (`orient`): an
//! orientation within 1e-12 of its operands' scale counts as 0, so a crossing within rounding of
//! a touching or of a collinear overlap counts as a crossing instead of being decided by noise.
//! Boundary crossings are found exactly in the combinatorial sense: every pair of non-adjacent
//! boundary segments sharing a cell of a uniform grid is tested. A map with no flip and a simple
//! boundary can still fold where the UV angles around a vertex wrap past a full turn (≥ 4π
//! inside, ≥ 2π on the boundary, whose two boundary segments share an endpoint and so are never
//! tested against each other): [`vertex_fold`].
//!
//! Units: UVs and positions in model units; angles in radians; stretch is Sander et al. 2001's
//! L2 stretch of the chart scaled to UV area = model area (1 is isometric).
use super::{ChartMap, ParameterizeError, ParameterizeOptions};
use crate::mesh::FaceId;

/// What is wrong with a chart's map (why it is split, or why it is returned as is).
#[derive(Debug, Clone, PartialEq)]
pub enum ChartDefect {
    /// Some faces are flipped in UV.
    Flipped {
        /// Number of flipped faces.
        count: usize,
    },
    /// Two boundary segments cross in UV (faces of the two segments).
    BoundaryOverlap {
        /// The faces owning the two crossing boundary edges.
        faces: [FaceId; 2],
    },
    /// Area distortion above the threshold.
    AreaRatio {
        /// max / min of model area per UV area over the chart's faces.
        ratio: f64,
        /// The face with the smallest ratio.
        min_face: FaceId,
        /// The face with the largest ratio.
        max_face: FaceId,
    },
    /// The chart's Sander L2 stretch, the chart scaled to UV area = model area, is above
    /// [`ParameterizeOptions::max_stretch`], or its L∞ stretch above
    /// [`ParameterizeOptions::max_linf`].
    Stretch {
        /// The chart's L2 stretch (1 is isometric).
        l2: f64,
        /// The chart's L∞ stretch, when it was measured (only against `max_linf`).
        linf: Option<f64>,
        /// The face with the smallest model area per UV area.
        min_face: FaceId,
        /// The face with the largest model area per UV area.
        max_face: FaceId,
    },
    /// The parameterizer rejected the chart (e.g. a zero-area face); it is returned unsplit.
    Unparameterizable(ParameterizeError),
}

/// The first defect of a chart's map, in the order flips, boundary overlap, area ratio.
pub(super) fn find_defect(
    faces: &[FaceId],
    cm: &crate::atlas::parameterize::ChartMesh,
    boundary_loop: &[u32],
    map: &ChartMap,
    options: &ParameterizeOptions,
) -> Option<ChartDefect> {
    if !map.flipped_faces.is_empty() {
        return Some(ChartDefect::Flipped {
            count: map.flipped_faces.len(),
        });
    }
    let segs = loop_segments(cm, boundary_loop);
    let crossing = crossing_among(&segs, &map.uv).or_else(|| {
        let mut on_boundary = vec![false; cm.positions_m.len()];
        for &v in boundary_loop {
            on_boundary[v as usize] = true;
        }
        fold_with_boundary(cm, &map.uv, &on_boundary)
    });
    if let Some([i, j]) = crossing {
        return Some(ChartDefect::BoundaryOverlap {
            faces: [faces[i], faces[j]],
        });
    }
    if options.max_area_ratio.is_none()
        && options.max_stretch.is_none()
        && options.max_linf.is_none()
    {
        return None;
    }
    // Per face: model area, UV area (> 0: no flips here), and Sander's (a + c) / 2.
    let mut per_face: Vec<(f64, usize, f64)> = Vec::with_capacity(cm.triangles.len());
    let (mut sum3, mut sum2, mut sum_l2) = (0.0f64, 0.0f64, 0.0f64);
    let (mut big2, mut small2) = (0.0f64, f64::INFINITY);
    let dot = |x: [f64; 3], y: [f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    for (k, t) in cm.triangles.iter().enumerate() {
        let q = t.map(|i| cm.positions_m[i as usize]);
        let p = t.map(|i| map.uv[i as usize]);
        let e1 = [0, 1, 2].map(|c| q[1][c] - q[0][c]);
        let e2 = [0, 1, 2].map(|c| q[2][c] - q[0][c]);
        let cr = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let area3 = 0.5 * (cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]).sqrt();
        let area2 = 0.5
            * ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1])
                - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]));
        // Sander et al. 2001: the derivatives of the 3-D position along u and v.
        let (u, v) = (p.map(|x| x[0]), p.map(|x| x[1]));
        let su = [0, 1, 2].map(|c| {
            (q[0][c] * (v[1] - v[2]) + q[1][c] * (v[2] - v[0]) + q[2][c] * (v[0] - v[1]))
                / (2.0 * area2)
        });
        let sv = [0, 1, 2].map(|c| {
            (q[0][c] * (u[2] - u[1]) + q[1][c] * (u[0] - u[2]) + q[2][c] * (u[1] - u[0]))
                / (2.0 * area2)
        });
        let (a, b, c) = (dot(su, su), dot(su, sv), dot(sv, sv));
        let l2sq = 0.5 * (a + c);
        // Singular values² of the Jacobian (uv → 3-D), for L∞; faces of zero model area (the
        // parameterizer's test: twice the area ≤ 1e-12 of the longest edge²) have none.
        let e3 = [0, 1, 2].map(|k| e2[k] - e1[k]);
        let longest2 = dot(e1, e1).max(dot(e2, e2)).max(dot(e3, e3));
        if 2.0 * area3 > 1e-12 * longest2 {
            let root = ((a - c) * (a - c) + 4.0 * b * b).sqrt();
            big2 = big2.max(0.5 * (a + c + root));
            small2 = small2.min(0.5 * (a + c - root));
        }
        per_face.push((area3 / area2, k, area3));
        sum3 += area3;
        sum2 += area2;
        sum_l2 += area3 * l2sq;
    }
    // The first and last faces in (ratio, index) order, by one scan: the stretch split and
    // the untrimmed area test need no more (the trimmed test sorts below).
    let by_ratio =
        |a: &(f64, usize, f64), b: &(f64, usize, f64)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
    let (Some(&lo), Some(&hi)) = (
        per_face.iter().min_by(|a, b| by_ratio(a, b)),
        per_face.iter().max_by(|a, b| by_ratio(a, b)),
    ) else {
        return None;
    };
    // The chart scaled to UV area = model area (as the packer does) multiplies a and c by
    // sum2 / sum3.
    let l2 = (sum_l2 * sum2 / (sum3 * sum3)).sqrt();
    let stretch = |linf: Option<f64>| ChartDefect::Stretch {
        l2,
        linf,
        min_face: faces[lo.1],
        max_face: faces[hi.1],
    };
    if options.max_stretch.is_some_and(|bound| l2 > bound) {
        return Some(stretch(None));
    }
    if let Some(bound) = options.max_linf {
        // The same scaling as L2 (a and c times sum2 / sum3); L∞ = max(Γ, 1/γ) over the faces,
        // as `stretch::chart_stretch` measures it.
        let r = sum2 / sum3;
        let linf = (big2 * r).sqrt().max(1.0 / (small2 * r).sqrt());
        if linf > bound {
            return Some(stretch(Some(linf)));
        }
    }
    let max_ratio = options.max_area_ratio?;
    if options.area_ratio_trim == 0.0 && lo.2 > 0.0 && hi.2 > 0.0 {
        // No trim: the quantiles below are the first and last faces.
        let ratio = hi.0 / lo.0;
        return (ratio > max_ratio).then(|| ChartDefect::AreaRatio {
            ratio,
            min_face: faces[lo.1],
            max_face: faces[hi.1],
        });
    }
    per_face.sort_by(by_ratio);
    // Area-weighted quantiles: skip `area_ratio_trim · sum3` of model area at each end.
    let trim = options.area_ratio_trim * sum3;
    let quantile = |iter: &mut dyn Iterator<Item = &(f64, usize, f64)>| {
        let mut acc = 0.0;
        let mut last = None;
        for &e in iter {
            last = Some(e);
            acc += e.2;
            if acc > trim {
                break;
            }
        }
        last
    };
    let (Some(qlo), Some(qhi)) = (
        quantile(&mut per_face.iter()),
        quantile(&mut per_face.iter().rev()),
    ) else {
        return None;
    };
    let ratio = qhi.0 / qlo.0;
    (ratio > max_ratio).then(|| ChartDefect::AreaRatio {
        ratio,
        min_face: faces[qlo.1],
        max_face: faces[qhi.1],
    })
}

/// The orientation of `abc`, rounded to 0 when its magnitude is within a (generous) bound of
/// the `f64` rounding error of the expression (Shewchuk's `ccwerrboundA` ≈ 3.3e-16 of the
/// permanent, taken 1e-12 here), so a crossing within rounding of a touching or of a collinear
/// overlap counts as an intersection instead of being decided by the sign of noise: a folded
/// boundary sliver has almost collinear segments whose signs are noise.
pub(super) fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    let (l, r) = ((b[0] - a[0]) * (c[1] - a[1]), (b[1] - a[1]) * (c[0] - a[0]));
    let o = l - r;
    if o.abs() <= 1e-12 * (l.abs() + r.abs()) {
        0.0
    } else {
        o
    }
}

/// A vertex around which the map is not locally injective although no face is flipped, as two
/// chart-local triangles of its fan: an interior vertex whose UV angles sum to more than 3π
/// (they sum to a multiple of 2π, so ≥ 4π: the fan wraps twice), or a boundary vertex whose
/// angles sum to at least 2π − 1e-9 (its two boundary edges overlap, or its fan wraps past
/// itself: a fold that the boundary crossing test cannot see, because the two boundary segments
/// at the vertex share an endpoint and are skipped). `None` when every vertex is fine. Assumes
/// no flipped face (angles in (0, π)). Cost: O(k log k).
pub fn vertex_fold(
    cm: &crate::atlas::parameterize::ChartMesh,
    uv: &[[f64; 2]],
) -> Option<[usize; 2]> {
    let n = cm.positions_m.len();
    let mut directed: Vec<(u32, u32)> = Vec::with_capacity(3 * cm.triangles.len());
    for t in &cm.triangles {
        for s in 0..3 {
            directed.push((t[s], t[(s + 1) % 3]));
        }
    }
    let mut sorted = directed.clone();
    sorted.sort_unstable();
    let mut boundary = vec![false; n];
    for &(a, b) in &directed {
        if sorted.binary_search(&(b, a)).is_err() {
            if let Some(slot) = boundary.get_mut(a as usize) {
                *slot = true;
            }
        }
    }
    fold_with_boundary(cm, uv, &boundary)
}

/// [`vertex_fold`] with the boundary vertices given (`boundary[v]`, one flag per chart vertex),
/// e.g. from the chart's boundary loop. Cost: O(k).
///
/// The angle sums are first taken with [`approx_angle_rad`] (no `atan2`); a vertex is decided
/// from them when its approximate sum is farther from its threshold than the approximation's
/// worst error over its fan, and otherwise (rare: a boundary vertex whose angles sum to about
/// 2π, or non-finite UVs) from the exact sums of the original loop, taken in the same order, so
/// the answer is exactly that of exact `atan2` sums.
pub(super) fn fold_with_boundary(
    cm: &crate::atlas::parameterize::ChartMesh,
    uv: &[[f64; 2]],
    boundary: &[bool],
) -> Option<[usize; 2]> {
    let n = cm.positions_m.len();
    if boundary.len() != n {
        return None;
    }
    // Per vertex: approximate angle sum, corner count, first and last face of its fan.
    let mut sum = vec![0.0f64; n];
    let mut corners = vec![0u32; n];
    let mut fan: Vec<[usize; 2]> = vec![[usize::MAX, 0]; n];
    for (k, t) in cm.triangles.iter().enumerate() {
        for s in 0..3 {
            let (v, a, b) = (t[s], t[(s + 1) % 3], t[(s + 2) % 3]);
            let (cross, dot) = corner_cross_dot(uv, v, a, b)?;
            let vi = v as usize;
            *sum.get_mut(vi)? += approx_angle_rad(cross, dot);
            *corners.get_mut(vi)? += 1;
            let f = fan.get_mut(vi)?;
            f[0] = f[0].min(k);
            f[1] = f[1].max(k);
        }
    }
    let tau = std::f64::consts::TAU;
    let threshold = |v: usize| {
        if boundary[v] {
            tau - 1e-9
        } else {
            1.5 * tau
        }
    };
    // `folds(v, s)`: whether angle sum `s` at `v` is a fold (boundary: at least the threshold;
    // interior: above it).
    let folds = |v: usize, s: f64| {
        if boundary[v] {
            s >= threshold(v)
        } else {
            s > threshold(v)
        }
    };
    let uncertain: Vec<bool> = (0..n)
        .map(|v| {
            let margin = f64::from(corners[v]) * APPROX_ANGLE_MARGIN_RAD;
            // Also true for a NaN sum.
            let distance = (sum[v] - threshold(v)).abs();
            distance.is_nan() || distance <= margin
        })
        .collect();
    if uncertain.iter().any(|&u| u) {
        // The exact sums of the uncertain vertices, accumulated in the original order.
        let mut exact = vec![0.0f64; n];
        for t in &cm.triangles {
            for s in 0..3 {
                let (v, a, b) = (t[s], t[(s + 1) % 3], t[(s + 2) % 3]);
                if uncertain[v as usize] {
                    let (cross, dot) = corner_cross_dot(uv, v, a, b)?;
                    exact[v as usize] += cross.atan2(dot).abs();
                }
            }
        }
        for v in 0..n {
            if uncertain[v] {
                sum[v] = exact[v];
            }
        }
    }
    (0..n)
        .find(|&v| {
            fan[v][0] != fan[v][1]
                && if uncertain[v] {
                    folds(v, sum[v])
                } else {
                    // Decided by the approximation: the exact sum is on the same side.
                    sum[v] > threshold(v)
                }
        })
        .map(|v| fan[v])
}

/// Cross and dot products of the UV edges from corner `v` to `a` and `b`; `None` when an index
/// is out of range.
pub(super) fn corner_cross_dot(uv: &[[f64; 2]], v: u32, a: u32, b: u32) -> Option<(f64, f64)> {
    let (pv, pa, pb) = (
        uv.get(v as usize)?,
        uv.get(a as usize)?,
        uv.get(b as usize)?,
    );
    let (e1, e2) = (
        [pa[0] - pv[0], pa[1] - pv[1]],
        [pb[0] - pv[0], pb[1] - pv[1]],
    );
    Some((e1[0] * e2[1] - e1[1] * e2[0], e1[0] * e2[0] + e1[1] * e2[1]))
}

/// Bound used by [`fold_with_boundary`] on the error of [`approx_angle_rad`] per corner,
/// radians: more than twice the measured worst error (the test
/// `approx_angle_error_is_within_the_margin` checks it).
pub(super) const APPROX_ANGLE_MARGIN_RAD: f64 = 0.01;

/// `|atan2(cross, dot)|`, the unsigned angle in \[0, π\], without `atan2`: the octant is
/// reduced to `atan(z)` with `z` in \[0, 1\], approximated by `π/4·z + 0.273·z·(1 − z)`
/// (worst error about 0.004 rad). Non-finite inputs give a non-finite result or an arbitrary
/// angle, which the caller treats as uncertain only when it is NaN; [`fold_with_boundary`]
/// therefore checks every sum with a margin and recomputes near-threshold ones exactly.
pub(super) fn approx_angle_rad(cross: f64, dot: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let (a, b) = (cross.abs(), dot.abs());
    let (num, den) = if a <= b { (a, b) } else { (b, a) };
    if den == 0.0 {
        // atan2(±0, ±0): 0 or π by the sign of the zero; leave it to the exact path.
        return f64::NAN;
    }
    let z = num / den;
    let t = FRAC_PI_4 * z + 0.273 * z * (1.0 - z);
    let t = if a <= b { t } else { FRAC_PI_2 - t };
    if dot < 0.0 {
        PI - t
    } else {
        t
    }
}

pub(super) fn on_segment(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> bool {
    p[0] >= a[0].min(b[0])
        && p[0] <= a[0].max(b[0])
        && p[1] >= a[1].min(b[1])
        && p[1] <= a[1].max(b[1])
}

/// Segments `ab` and `cd` intersect (touching and collinear overlap included).
pub(super) fn segments_intersect(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let (o1, o2) = (orient(a, b, c), orient(a, b, d));
    let (o3, o4) = (orient(c, d, a), orient(c, d, b));
    if ((o1 > 0.0 && o2 < 0.0) || (o1 < 0.0 && o2 > 0.0))
        && ((o3 > 0.0 && o4 < 0.0) || (o3 < 0.0 && o4 > 0.0))
    {
        return true;
    }
    (o1 == 0.0 && on_segment(a, b, c))
        || (o2 == 0.0 && on_segment(a, b, d))
        || (o3 == 0.0 && on_segment(c, d, a))
        || (o4 == 0.0 && on_segment(c, d, b))
}

/// Two non-adjacent boundary segments of the chart that intersect in UV, as the chart-local
/// indices of the triangles owning them; `None` if the boundary is simple. Uniform grid of about
/// `n` cells for `n` segments; each segment is entered in every cell its bounding box covers.
pub fn boundary_crossing(
    cm: &crate::atlas::parameterize::ChartMesh,
    uv: &[[f64; 2]],
) -> Option<[usize; 2]> {
    // Boundary half-edges: directed edges whose reverse is not in the chart. Sort to find them.
    let mut directed: Vec<(u32, u32, usize)> = Vec::with_capacity(3 * cm.triangles.len());
    for (k, t) in cm.triangles.iter().enumerate() {
        for s in 0..3 {
            directed.push((t[s], t[(s + 1) % 3], k));
        }
    }
    let mut keys: Vec<(u32, u32)> = directed.iter().map(|&(a, b, _)| (a, b)).collect();
    keys.sort_unstable();
    let segs: Vec<(u32, u32, usize)> = directed
        .into_iter()
        .filter(|&(a, b, _)| keys.binary_search(&(b, a)).is_err())
        .collect();
    crossing_among(&segs, uv)
}

/// The boundary half-edges `(a, b, owning triangle)` of a chart that passed
/// `ChartMesh::validate`, from its boundary loop, in the order of [`boundary_crossing`] (by
/// triangle, then side), without sorting: `a → b` is on the boundary exactly when `b` follows
/// `a` on the loop (a manifold chart uses each directed edge once). Cost: O(k).
pub(super) fn loop_segments(
    cm: &crate::atlas::parameterize::ChartMesh,
    boundary_loop: &[u32],
) -> Vec<(u32, u32, usize)> {
    let mut next = vec![u32::MAX; cm.positions_m.len()];
    for (w, &v) in boundary_loop.iter().enumerate() {
        if let Some(slot) = next.get_mut(v as usize) {
            *slot = boundary_loop[(w + 1) % boundary_loop.len()];
        }
    }
    let mut segs = Vec::with_capacity(boundary_loop.len());
    for (k, t) in cm.triangles.iter().enumerate() {
        for s in 0..3 {
            let (a, b) = (t[s], t[(s + 1) % 3]);
            if next.get(a as usize) == Some(&b) {
                segs.push((a, b, k));
            }
        }
    }
    segs
}

/// Two of the boundary segments `segs` (`(a, b, owning triangle)`) that do not share an
/// endpoint and intersect in UV, as their triangles; see [`boundary_crossing`].
pub(super) fn crossing_among(segs: &[(u32, u32, usize)], uv: &[[f64; 2]]) -> Option<[usize; 2]> {
    let n = segs.len();
    if n < 4 {
        return None;
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for &(a, b, _) in segs {
        for p in [uv.get(a as usize)?, uv.get(b as usize)?] {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    let side = ((n as f64).sqrt().ceil() as usize).clamp(1, 1024);
    let w = [0, 1].map(|k| ((hi[k] - lo[k]) / side as f64).max(f64::MIN_POSITIVE));
    let cell = |p: [f64; 2], k: usize| (((p[k] - lo[k]) / w[k]) as usize).min(side - 1);
    let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); side * side];
    for (i, &(a, b, _)) in segs.iter().enumerate() {
        let (pa, pb) = (uv[a as usize], uv[b as usize]);
        let (x0, x1) = (cell(pa, 0).min(cell(pb, 0)), cell(pa, 0).max(cell(pb, 0)));
        let (y0, y1) = (cell(pa, 1).min(cell(pb, 1)), cell(pa, 1).max(cell(pb, 1)));
        for y in y0..=y1 {
            for x in x0..=x1 {
                buckets[y * side + x].push(i as u32);
            }
        }
    }
    for bucket in &buckets {
        for (x, &i) in bucket.iter().enumerate() {
            for &j in &bucket[x + 1..] {
                let (a, b, fi) = segs[i as usize];
                let (c, d, fj) = segs[j as usize];
                // Segments sharing an endpoint are adjacent along the loop: they touch by design.
                if a == c || a == d || b == c || b == d {
                    continue;
                }
                let (pa, pb, pc, pd) = (
                    uv[a as usize],
                    uv[b as usize],
                    uv[c as usize],
                    uv[d as usize],
                );
                if segments_intersect(pa, pb, pc, pd) {
                    return Some([fi, fj]);
                }
            }
        }
    }
    None
}

#[cfg(test)]
mod approx_angle_tests {
    use super::{approx_angle_rad, APPROX_ANGLE_MARGIN_RAD};

    /// The approximation stays within half the margin of `|atan2|` over the whole circle,
    /// at every scale, and signals the 0/0 corner as NaN.
    #[test]
    fn approx_angle_error_is_within_the_margin() {
        let mut worst = 0.0f64;
        for k in 0..200_000u32 {
            let theta = f64::from(k) / 200_000.0 * std::f64::consts::TAU;
            for scale in [1e-9, 1.0, 3.7e6] {
                let (cross, dot) = (scale * theta.sin(), scale * theta.cos());
                let err = (approx_angle_rad(cross, dot) - cross.atan2(dot).abs()).abs();
                worst = worst.max(err);
            }
        }
        assert!(worst < 0.5 * APPROX_ANGLE_MARGIN_RAD, "worst error {worst}");
        assert!(
            worst > 1e-4,
            "the approximation is coarse by design: {worst}"
        );
        assert!(approx_angle_rad(0.0, 0.0).is_nan());
        assert!(approx_angle_rad(0.0, -0.0).is_nan());
    }
}
