//! Exact UV overlaps: pairs of faces on the same page whose open UV triangles intersect.
//!
//! Test: two triangles with non-empty interiors have intersecting interiors iff no edge line of
//! either separates them, i.e. iff for every edge `(p, q)` of one (made counter-clockwise), some
//! vertex of the other lies strictly left of it (separating axis theorem for convex polygons:
//! two convex sets with disjoint interiors have a weakly separating line, and for polygons one
//! through an edge). Orientation signs come from Shewchuk's adaptive exact `orient2d` (the
//! `robust` crate) on the `f32` UVs widened to `f64` (exact), so the answer is exact: two faces
//! sharing an edge on opposite sides, or only a vertex, do not overlap; a face folded over its
//! neighbour, or two stacked charts, do. Faces of exactly zero UV area (or non-finite UVs) have
//! no interior and are left out.
//!
//! Acceleration: per page, a uniform grid of about one cell per face over the faces' UV box;
//! each face is entered in the cells its bounding box meets (the grid is coarsened while that
//! exceeds 8 entries per face), and a pair is tested only in the lowest cell common to both
//! boxes, after a strict bounding-box test, so each pair is tested once. Reference: Shewchuk,
//! "Adaptive Precision Floating-Point Arithmetic and Fast Robust Geometric Predicates", 1997.
//!
//! Cost: `O(faces + candidate pairs)`; on a packed atlas about 3–6 candidates per face (mostly
//! edge neighbours, rejected by their shared edge after 2–3 predicates).
use robust::{orient2d, Coord};

use super::{ExactOverlap, EXACT_OVERLAP_EXAMPLES, EXACT_OVERLAP_PAIRS_MAX};
use crate::mesh::FaceId;

type Tri = [[f64; 2]; 3];

fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    orient2d(
        Coord { x: a[0], y: a[1] },
        Coord { x: b[0], y: b[1] },
        Coord { x: c[0], y: c[1] },
    )
}

/// Some edge line of `a` (counter-clockwise) has all of `b` on or right of it.
fn separated_by_edge_of(a: &Tri, b: &Tri) -> bool {
    (0..3).any(|e| {
        let (p, q) = (a[e], a[(e + 1) % 3]);
        b.iter().all(|&r| orient(p, q, r) <= 0.0)
    })
}

/// Whether the open interiors of two counter-clockwise, non-degenerate triangles intersect.
pub(super) fn interiors_intersect(a: &Tri, b: &Tri) -> bool {
    !separated_by_edge_of(a, b) && !separated_by_edge_of(b, a)
}

/// A face's triangle made counter-clockwise, or `None` when it has no interior.
pub(super) fn ccw_triangle(uv: &[[f32; 2]; 3]) -> Option<Tri> {
    if !uv.iter().flatten().all(|x| x.is_finite()) {
        return None;
    }
    let mut t: Tri = uv.map(|c| [f64::from(c[0]), f64::from(c[1])]);
    let o = orient(t[0], t[1], t[2]);
    if o == 0.0 {
        return None;
    }
    if o < 0.0 {
        t.swap(1, 2);
    }
    Some(t)
}

struct Candidate {
    face: u32,
    tri: Tri,
    /// `[u_min, v_min, u_max, v_max]`.
    bbox: [f64; 4],
    /// Cell range `[cx0, cy0, cx1, cy1]`, inclusive.
    cells: [u32; 4],
}

/// Counts exact overlap pairs over all pages.
pub(super) fn exact_overlaps(
    corner_uvs: &[[[f32; 2]; 3]],
    face_page: &[u32],
    num_pages: u32,
    chart_of_face: &[u32],
) -> ExactOverlap {
    let mut out = ExactOverlap::default();
    let mut per_page: Vec<Vec<Candidate>> = (0..num_pages).map(|_| Vec::new()).collect();
    for (f, uv) in corner_uvs.iter().enumerate() {
        if let Some(tri) = ccw_triangle(uv) {
            let us = [tri[0][0], tri[1][0], tri[2][0]];
            let vs = [tri[0][1], tri[1][1], tri[2][1]];
            let bbox = [
                us[0].min(us[1]).min(us[2]),
                vs[0].min(vs[1]).min(vs[2]),
                us[0].max(us[1]).max(us[2]),
                vs[0].max(vs[1]).max(vs[2]),
            ];
            per_page[face_page[f] as usize].push(Candidate {
                face: f as u32,
                tri,
                bbox,
                cells: [0; 4],
            });
        }
    }
    for cands in &mut per_page {
        if out.truncated {
            break;
        }
        count_page(cands, chart_of_face, &mut out);
    }
    out.examples.sort_unstable();
    out
}

fn count_page(cands: &mut [Candidate], chart_of_face: &[u32], out: &mut ExactOverlap) {
    let n = cands.len();
    if n < 2 {
        return;
    }
    let mut dom = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for c in cands.iter() {
        dom = [
            dom[0].min(c.bbox[0]),
            dom[1].min(c.bbox[1]),
            dom[2].max(c.bbox[2]),
            dom[3].max(c.bbox[3]),
        ];
    }
    // Cell of a coordinate: monotone in the coordinate, so overlapping boxes share a cell.
    let cell_of = |x: f64, lo: f64, hi: f64, g: u32| -> u32 {
        if hi <= lo {
            return 0;
        }
        let c = ((x - lo) / (hi - lo) * f64::from(g)).floor();
        (c.max(0.0) as u32).min(g - 1)
    };
    let mut g = ((n as f64).sqrt().ceil() as u32).clamp(1, 2048);
    loop {
        let mut entries = 0u64;
        for c in cands.iter_mut() {
            c.cells = [
                cell_of(c.bbox[0], dom[0], dom[2], g),
                cell_of(c.bbox[1], dom[1], dom[3], g),
                cell_of(c.bbox[2], dom[0], dom[2], g),
                cell_of(c.bbox[3], dom[1], dom[3], g),
            ];
            entries +=
                u64::from(c.cells[2] - c.cells[0] + 1) * u64::from(c.cells[3] - c.cells[1] + 1);
        }
        if entries <= 8 * n as u64 + 64 || g == 1 {
            break;
        }
        g = (g / 2).max(1);
    }
    // Cell lists (CSR), cells row-major (y then x).
    let num_cells = (g as usize) * (g as usize);
    let mut start = vec![0u32; num_cells + 1];
    for c in cands.iter() {
        for cy in c.cells[1]..=c.cells[3] {
            for cx in c.cells[0]..=c.cells[2] {
                start[(cy * g + cx) as usize + 1] += 1;
            }
        }
    }
    for i in 0..num_cells {
        start[i + 1] += start[i];
    }
    let mut next = start.clone();
    let mut members = vec![0u32; start[num_cells] as usize];
    for (i, c) in cands.iter().enumerate() {
        for cy in c.cells[1]..=c.cells[3] {
            for cx in c.cells[0]..=c.cells[2] {
                let cell = (cy * g + cx) as usize;
                members[next[cell] as usize] = i as u32;
                next[cell] += 1;
            }
        }
    }
    for cy in 0..g {
        for cx in 0..g {
            let cell = (cy * g + cx) as usize;
            let list = &members[start[cell] as usize..start[cell + 1] as usize];
            for (ia, &a) in list.iter().enumerate() {
                let ca = &cands[a as usize];
                for &b in &list[ia + 1..] {
                    let cb = &cands[b as usize];
                    // Strict box overlap is necessary for intersecting interiors.
                    if !(ca.bbox[0] < cb.bbox[2]
                        && cb.bbox[0] < ca.bbox[2]
                        && ca.bbox[1] < cb.bbox[3]
                        && cb.bbox[1] < ca.bbox[3])
                    {
                        continue;
                    }
                    // Test each pair once: in the lowest cell both boxes meet.
                    if ca.cells[0].max(cb.cells[0]) != cx || ca.cells[1].max(cb.cells[1]) != cy {
                        continue;
                    }
                    if !interiors_intersect(&ca.tri, &cb.tri) {
                        continue;
                    }
                    out.pairs += 1;
                    if chart_of_face[ca.face as usize] == chart_of_face[cb.face as usize] {
                        out.pairs_same_chart += 1;
                    } else {
                        out.pairs_cross_chart += 1;
                    }
                    if out.examples.len() < EXACT_OVERLAP_EXAMPLES {
                        let (lo, hi) = (ca.face.min(cb.face), ca.face.max(cb.face));
                        out.examples.push([FaceId(lo), FaceId(hi)]);
                    }
                    if out.pairs >= EXACT_OVERLAP_PAIRS_MAX {
                        out.truncated = true;
                        return;
                    }
                }
            }
        }
    }
}
