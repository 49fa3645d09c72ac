//! The convex hull of a chart's UVs and its diameter (its farthest pair of points), which
//! [`super::place`] turns vertical (lscm-2002 §4 step 2).
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

#[cfg(test)]
mod tests {
    use super::*;

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
