//! The convex hull of a chart's UVs, its diameter (its farthest pair of points), which
//! [`super::place`] turns vertical (lscm-2002 §4 step 2), and its minimum-area enclosing
//! rectangle, which [`super::place`] turns axis-aligned for nearly rectangular charts.
//!
//! Units: whatever the points are in (the chart's normalized UVs).

use crate::mesh::vector::orient2;

/// Convex hull, counter-clockwise, no collinear points (Andrew's monotone chain). Cost:
/// O(n log n).
pub(super) fn convex_hull(points: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut p: Vec<[f64; 2]> = points.to_vec();
    p.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let mut hull: Vec<[f64; 2]> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &[f64; 2]>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &q in iter {
            while hull.len() >= start + 2
                && orient2(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0
            {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    hull
}

/// The farthest pair of a convex polygon (rotating calipers over antipodal pairs). Cost: O(h).
pub(super) fn diameter(hull: &[[f64; 2]]) -> (usize, usize) {
    let n = hull.len();
    let d2 = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2);
    match n {
        0 | 1 => return (0, 0),
        2 => return (0, 1),
        _ => {}
    }
    let mut best = (0, 1, d2(hull[0], hull[1]));
    let mut j = 1;
    for i in 0..n {
        let ni = (i + 1) % n;
        // Advance j while the triangle (i, ni, j+1) is larger: j+1 is farther from edge i.
        let mut steps = 0;
        while steps < n
            && orient2(hull[i], hull[ni], hull[(j + 1) % n]) > orient2(hull[i], hull[ni], hull[j])
        {
            j = (j + 1) % n;
            steps += 1;
        }
        for (a, b) in [(i, j), (ni, j)] {
            let d = d2(hull[a], hull[b]);
            if d > best.2 {
                best = (a, b, d);
            }
        }
    }
    (best.0, best.1)
}

/// The minimum-area rectangle enclosing a convex polygon: one of its sides lies on a hull edge
/// (H. Freeman, R. Shapira, "Determining the minimum-area encasing rectangle for an arbitrary
/// closed curve", CACM 1975), found by rotating calipers over the edges (G. Toussaint, "Solving
/// geometric problems with the rotating calipers", MELECON 1983).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct MinAreaBox {
    /// Unit direction of the hull edge the box lies on.
    pub dir: [f64; 2],
    /// Extent of the box along `dir`.
    pub along: f64,
    /// Extent of the box across `dir`.
    pub across: f64,
}

/// [`MinAreaBox`] of a counter-clockwise convex polygon without collinear points (as
/// [`convex_hull`] returns); `None` below 3 points. Ties go to the first edge. Cost: O(h).
pub(super) fn min_area_box(hull: &[[f64; 2]]) -> Option<MinAreaBox> {
    let n = hull.len();
    if n < 3 {
        return None;
    }
    let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
    let edge_dir = |i: usize| {
        let (p, q) = (hull[i], hull[(i + 1) % n]);
        let d = [q[0] - p[0], q[1] - p[1]];
        let l = d[0].hypot(d[1]);
        [d[0] / l, d[1] / l]
    };
    // Calipers: the farthest point along the edge (`right`), across it (`top`, the interior
    // is to the left of a counter-clockwise edge) and back along it (`left`); each only moves
    // forwards as the edge turns.
    let argmax = |start: usize, key: &dyn Fn([f64; 2]) -> f64| {
        let mut j = start;
        let mut steps = 0;
        while steps < n && key(hull[(j + 1) % n]) > key(hull[j]) {
            j = (j + 1) % n;
            steps += 1;
        }
        j
    };
    let (mut right, mut top, mut left) = (1 % n, 1 % n, 1 % n);
    let mut best: Option<(f64, MinAreaBox)> = None;
    for i in 0..n {
        let u = edge_dir(i);
        if !(u[0].is_finite() && u[1].is_finite()) {
            continue;
        }
        let v = [-u[1], u[0]];
        let o = hull[i];
        let rel = |p: [f64; 2]| [p[0] - o[0], p[1] - o[1]];
        right = argmax(right, &|p| dot(rel(p), u));
        top = argmax(if i == 0 { right } else { top }, &|p| dot(rel(p), v));
        left = argmax(if i == 0 { top } else { left }, &|p| -dot(rel(p), u));
        let along = dot(rel(hull[right]), u) - dot(rel(hull[left]), u);
        let across = dot(rel(hull[top]), v);
        let area = along * across;
        if best.is_none_or(|b| area < b.0) {
            best = Some((
                area,
                MinAreaBox {
                    dir: u,
                    along,
                    across,
                },
            ));
        }
    }
    best.map(|b| b.1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_area_box_matches_brute_force_over_hull_edges() {
        let mut state = 777u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for case in 0..200 {
            let n = 3 + (next() * 60.0) as usize;
            let (sx, sy) = (0.1 + 3.0 * next(), 0.1 + next());
            let pts: Vec<[f64; 2]> = (0..n).map(|_| [next() * sx, next() * sy]).collect();
            let hull = convex_hull(&pts);
            let Some(b) = min_area_box(&hull) else {
                assert!(hull.len() < 3);
                continue;
            };
            // Brute force: every hull edge direction, every point projected.
            let brute = (0..hull.len())
                .map(|i| {
                    let (p, q) = (hull[i], hull[(i + 1) % hull.len()]);
                    let l = (q[0] - p[0]).hypot(q[1] - p[1]);
                    let u = [(q[0] - p[0]) / l, (q[1] - p[1]) / l];
                    let proj = |d: [f64; 2]| {
                        let vals = pts.iter().map(|a| a[0] * d[0] + a[1] * d[1]);
                        let (lo, hi) =
                            vals.fold((f64::MAX, f64::MIN), |m, x| (m.0.min(x), m.1.max(x)));
                        hi - lo
                    };
                    proj(u) * proj([-u[1], u[0]])
                })
                .fold(f64::MAX, f64::min);
            assert!(
                (b.along * b.across - brute).abs() <= 1e-9 * brute.max(1.0),
                "case {case}: {} vs {brute}",
                b.along * b.across
            );
            // The box holds every point.
            let v = [-b.dir[1], b.dir[0]];
            let span = |d: [f64; 2]| {
                let vals = pts.iter().map(|a| a[0] * d[0] + a[1] * d[1]);
                let (lo, hi) = vals.fold((f64::MAX, f64::MIN), |m, x| (m.0.min(x), m.1.max(x)));
                hi - lo
            };
            assert!((span(b.dir) - b.along).abs() < 1e-9 && (span(v) - b.across).abs() < 1e-9);
        }
        // A rotated rectangle: its own sides.
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        let rect: Vec<[f64; 2]> = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]]
            .iter()
            .map(|p| [c * p[0] - s * p[1], s * p[0] + c * p[1]])
            .collect();
        let b = min_area_box(&convex_hull(&rect)).unwrap();
        assert!((b.along * b.across - 2.0).abs() < 1e-12);
        assert!((b.dir[0].abs() - c).abs() < 1e-12 || (b.dir[0].abs() - s).abs() < 1e-12);
    }

    #[test]
    fn diameter_matches_brute_force() {
        let mut state = 12345u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..50 {
            let pts: Vec<[f64; 2]> = (0..40).map(|_| [next() * 3.0, next()]).collect();
            let hull = convex_hull(&pts);
            let (a, b) = diameter(&hull);
            let d = |p: [f64; 2], q: [f64; 2]| (p[0] - q[0]).hypot(p[1] - q[1]);
            let brute = pts
                .iter()
                .flat_map(|p| pts.iter().map(move |q| (*p, *q)))
                .map(|(p, q)| d(p, q))
                .fold(0.0, f64::max);
            assert!((d(hull[a], hull[b]) - brute).abs() < 1e-12);
        }
    }
}
