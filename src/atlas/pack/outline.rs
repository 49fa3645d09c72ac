//! The outline of a chart in UV: the boundary chain whose nonzero-winding fill gives the
//! chart's footprint ([`super::raster::fill_chain`]), with the loose triangles that the fill
//! cannot take, and the outline triangles, the only ones whose conservative raster decides the
//! footprint's per-line extents (see [`super::place`]).
//!
//! Units: the chart's UVs (model units); both functions are invariant under similarities.
use crate::mesh::vector::orient2;

/// Whether a triangle is well shaped for the boundary fill: its orientation is stable under
/// the similarity to texels (rotation, uniform scale, rounding), as in
/// [`super::raster::rasterize_centres`]'s thin-triangle test with the largest edge (rotation
/// invariant, at least the box side) and a 100× margin.
fn orientation_sign(p: [[f64; 2]; 3]) -> i32 {
    let [a, b, c] = p;
    let area2 = orient2(a, b, c);
    let l2 = |u: [f64; 2], v: [f64; 2]| (u[0] - v[0]).powi(2) + (u[1] - v[1]).powi(2);
    let span2 = l2(a, b).max(l2(b, c)).max(l2(c, a));
    if !(area2.abs() > 1e-4 * span2 && span2 > 0.0 && area2.is_finite()) {
        0
    } else if area2 > 0.0 {
        1
    } else {
        -1
    }
}

/// The boundary chain of the triangles of the majority orientation that are well shaped, and
/// the others. Deterministic (sorted edges). Cost: O(t log t).
pub fn boundary_chain(uv: &[[f64; 2]], triangles: &[[u32; 3]]) -> (Vec<[u32; 2]>, Vec<u32>) {
    let signs: Vec<i32> = triangles
        .iter()
        .map(|t| orientation_sign(t.map(|i| uv[i as usize])))
        .collect();
    let positive = signs.iter().filter(|&&s| s > 0).count();
    let negative = signs.iter().filter(|&&s| s < 0).count();
    let major = if positive >= negative { 1 } else { -1 };
    let mut loose = Vec::new();
    // (min, max, +1 if directed min→max else -1)
    let mut edges: Vec<(u32, u32, i32)> = Vec::with_capacity(3 * triangles.len());
    for (k, t) in triangles.iter().enumerate() {
        if signs[k] != major {
            loose.push(k as u32);
            continue;
        }
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            if a != b {
                edges.push((a.min(b), a.max(b), if a < b { 1 } else { -1 }));
            }
        }
    }
    edges.sort_unstable();
    let mut chain = Vec::new();
    let mut g = 0;
    while g < edges.len() {
        let (a, b, _) = edges[g];
        let mut net = 0i32;
        while g < edges.len() && edges[g].0 == a && edges[g].1 == b {
            net += edges[g].2;
            g += 1;
        }
        for _ in 0..net.unsigned_abs() {
            chain.push(if net > 0 { [a, b] } else { [b, a] });
        }
    }
    (chain, loose)
}

/// The triangles that can touch the boundary of the chart's UV region `U` (the union of its
/// triangles): every triangle except those whose three edges are each shared with exactly one
/// other triangle lying strictly on the other side of the edge (by a margin far above
/// rounding). Such an edge is interior to `U`, and a vertex whose edges are all interior is
/// too (its fan sweeps a whole number ≥ 1 of turns), so `∂U` lies in the union of the outline
/// triangles.
///
/// Why it is enough: in any column (row) strip, the extreme point of `U` is a point of `∂U`,
/// hence of an outline triangle, whose conservative raster then holds that extreme texel; and
/// the extreme vertices in any direction are outline vertices. So the per-line extents and the
/// bounding box of the outline triangles are those of all the triangles (the interior, which
/// the extents ignore, is all that is skipped). Deterministic (sorted edges, no hash map).
///
/// Cost: O(t log t) for t triangles, once per chart.
pub fn outline_triangles(uv: &[[f64; 2]], triangles: &[[u32; 3]]) -> Vec<u32> {
    let mut edges: Vec<(u32, u32, u32)> = Vec::with_capacity(3 * triangles.len());
    for (k, t) in triangles.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            edges.push((a.min(b), a.max(b), k as u32));
        }
    }
    edges.sort_unstable();
    let mut mark = vec![false; triangles.len()];
    let opposite = |t: u32, a: u32, b: u32| -> Option<u32> {
        let tri = triangles[t as usize];
        let mut rest = tri.iter().filter(|&&v| v != a && v != b);
        match (rest.next(), rest.next()) {
            (Some(&o), None) => Some(o),
            _ => None,
        }
    };
    let mut g = 0;
    while g < edges.len() {
        let (a, b, _) = edges[g];
        let mut end = g + 1;
        while end < edges.len() && edges[end].0 == a && edges[end].1 == b {
            end += 1;
        }
        let interior = end - g == 2
            && a != b
            && match (opposite(edges[g].2, a, b), opposite(edges[g + 1].2, a, b)) {
                (Some(o1), Some(o2)) => {
                    let (pa, pb) = (uv[a as usize], uv[b as usize]);
                    let (q1, q2) = (uv[o1 as usize], uv[o2 as usize]);
                    let m = [pa, pb, q1, q2]
                        .iter()
                        .map(|p| p[0].abs().max(p[1].abs()))
                        .fold(0.0, f64::max);
                    let tol = 1e-12 * m * m;
                    let (s1, s2) = (orient2(pa, pb, q1), orient2(pa, pb, q2));
                    (s1 > tol && s2 < -tol) || (s1 < -tol && s2 > tol)
                }
                _ => false,
            };
        if !interior {
            for e in &edges[g..end] {
                mark[e.2 as usize] = true;
            }
        }
        g = end;
    }
    (0..triangles.len() as u32)
        .filter(|&k| mark[k as usize])
        .collect()
}
