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
//! boxes, after a strict bounding-box test, so each pair is tested once. Rows of cells are
//! counted in parallel (rayon) in fixed batches merged in order, so the result — including
//! where counting stops at the cap — does not depend on the thread count. Reference: Shewchuk,
//! "Adaptive Precision Floating-Point Arithmetic and Fast Robust Geometric Predicates", 1997.
//!
//! Cost: `O(faces + candidate pairs)`; on a packed atlas about 3–6 candidates per face (mostly
//! edge neighbours, rejected by their shared edge after 2–3 predicates).
use rayon::prelude::*;
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

/// [`interiors_intersect`] with a shortcut for two triangles sharing an edge (two equal
/// corners; most candidate pairs of an atlas are edge neighbours): their interiors meet iff
/// their third corners lie strictly on the same side of the shared edge's line (on opposite
/// sides the line separates them; on the same side both contain the points just beside the
/// edge's midpoint). Both orientations are exact and non-zero (each is a permutation of a
/// non-degenerate triangle's corners), so the answer is exactly [`interiors_intersect`]'s,
/// with two predicates instead of up to eighteen. Three equal corners: the same triangle.
pub(super) fn interiors_intersect_pair(a: &Tri, b: &Tri) -> bool {
    // For each corner of `a`, the equal corner of `b` (at most one: `b` has distinct corners).
    let mut in_b = [usize::MAX; 3];
    let mut shared = 0;
    for (i, pa) in a.iter().enumerate() {
        if let Some(k) = b.iter().position(|pb| pb == pa) {
            in_b[i] = k;
            shared += 1;
        }
    }
    match shared {
        3 => true,
        2 => {
            let i = in_b.iter().position(|&k| k == usize::MAX).unwrap_or(0);
            let (p, q) = ((i + 1) % 3, (i + 2) % 3);
            let rb = 3 - in_b[p] - in_b[q];
            let sa = orient(a[p], a[q], a[i]) > 0.0;
            let sb = orient(a[p], a[q], b[rb]) > 0.0;
            sa == sb
        }
        _ => interiors_intersect(a, b),
    }
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

/// Rows of cells per parallel batch; the pair cap is checked between batches (deterministic).
const ROWS_PER_BATCH: u32 = 32;

/// The overlapping pairs found, before they are classified by chart
/// ([`ExactPairs::classify`]): chart ids are not needed to find them, so the search runs
/// while the charts are being computed.
#[derive(Default)]
pub(super) struct ExactPairs {
    /// Every overlapping pair found, `[lower face, higher face]`, in search order.
    pairs: Vec<[u32; 2]>,
    /// Up to [`EXACT_OVERLAP_EXAMPLES`] pairs of each batch merged while fewer were known.
    examples: Vec<[FaceId; 2]>,
    /// Counting stopped at the cap.
    truncated: bool,
}

impl ExactPairs {
    /// The same pairs, examples and truncation as `other`.
    pub(super) fn same_pairs(&self, other: &ExactPairs) -> bool {
        self.pairs == other.pairs
            && self.examples == other.examples
            && self.truncated == other.truncated
    }

    /// The pairs `(a, b)`, `a < b`, whose faces lie in one chart of `chart_of_face`, ascending.
    pub(super) fn same_chart(&self, chart_of_face: &[u32]) -> Vec<(u32, u32)> {
        let mut pairs: Vec<(u32, u32)> = self
            .pairs
            .iter()
            .filter(|p| chart_of_face[p[0] as usize] == chart_of_face[p[1] as usize])
            .map(|p| (p[0], p[1]))
            .collect();
        pairs.sort_unstable();
        pairs
    }

    /// The faces in any pair, ascending, once each.
    pub(super) fn faces(&self) -> Vec<u32> {
        let mut faces: Vec<u32> = self.pairs.iter().flatten().copied().collect();
        faces.sort_unstable();
        faces.dedup();
        faces
    }

    /// The report: counts by same or different chart, examples sorted.
    pub(super) fn classify(self, chart_of_face: &[u32]) -> ExactOverlap {
        let pairs = self.pairs.len() as u64;
        let same = self
            .pairs
            .iter()
            .filter(|p| chart_of_face[p[0] as usize] == chart_of_face[p[1] as usize])
            .count() as u64;
        let mut examples = self.examples;
        examples.sort_unstable();
        examples.truncate(EXACT_OVERLAP_EXAMPLES);
        ExactOverlap {
            pairs,
            pairs_same_chart: same,
            pairs_cross_chart: pairs - same,
            truncated: self.truncated,
            examples,
        }
    }
}

/// Finds the exact overlap pairs over all pages (classify them with [`ExactPairs::classify`]).
pub(super) fn exact_overlap_pairs(
    corner_uvs: &[[[f32; 2]; 3]],
    face_page: &[u32],
    num_pages: u32,
) -> ExactPairs {
    let mut out = ExactPairs::default();
    let mut per_page: Vec<Vec<u32>> = (0..num_pages).map(|_| Vec::new()).collect();
    for (f, &p) in face_page.iter().enumerate() {
        per_page[p as usize].push(f as u32);
    }
    for faces in &per_page {
        if out.truncated {
            break;
        }
        count_page(corner_uvs, faces, &mut out);
    }
    out
}

fn count_page(corner_uvs: &[[[f32; 2]; 3]], faces: &[u32], out: &mut ExactPairs) {
    let mut face = Vec::new();
    let mut tris = Vec::new();
    let mut boxes = Vec::new();
    for &f in faces {
        let uv = &corner_uvs[f as usize];
        if let Some(t) = ccw_triangle(uv) {
            face.push(f);
            tris.push(t);
            let (us, vs) = (
                [uv[0][0], uv[1][0], uv[2][0]],
                [uv[0][1], uv[1][1], uv[2][1]],
            );
            boxes.push([
                us[0].min(us[1]).min(us[2]),
                vs[0].min(vs[1]).min(vs[2]),
                us[0].max(us[1]).max(us[2]),
                vs[0].max(vs[1]).max(vs[2]),
            ]);
        }
    }
    let n = tris.len();
    if n < 2 {
        return;
    }
    let mut dom = [
        f32::INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
    ];
    for b in &boxes {
        dom = [
            dom[0].min(b[0]),
            dom[1].min(b[1]),
            dom[2].max(b[2]),
            dom[3].max(b[3]),
        ];
    }
    let dom = dom.map(f64::from);
    // Cell of a coordinate: monotone in the coordinate, so overlapping boxes share a cell.
    let cell_of = |x: f32, lo: f64, hi: f64, g: u32| -> u32 {
        if hi <= lo {
            return 0;
        }
        let c = ((f64::from(x) - lo) / (hi - lo) * f64::from(g)).floor();
        (c.max(0.0) as u32).min(g - 1)
    };
    let range_of = |b: &[f32; 4], g: u32| -> [u32; 4] {
        [
            cell_of(b[0], dom[0], dom[2], g),
            cell_of(b[1], dom[1], dom[3], g),
            cell_of(b[2], dom[0], dom[2], g),
            cell_of(b[3], dom[1], dom[3], g),
        ]
    };
    // About one cell per face; coarser while boxes would make more than 8 entries per face.
    let mut g = ((n as f64).sqrt().ceil() as u32).clamp(1, 2048);
    loop {
        let entries: u64 = boxes
            .iter()
            .map(|b| {
                let r = range_of(b, g);
                u64::from(r[2] - r[0] + 1) * u64::from(r[3] - r[1] + 1)
            })
            .sum();
        if entries <= 8 * n as u64 + 64 || g == 1 {
            break;
        }
        g = (g / 2).max(1);
    }
    // Cell lists (CSR), cells row-major (y then x), of candidate indices (4 bytes per entry: the
    // lists are scattered once, and the pair loop reads each face's box and lowest cell by
    // index; 24-byte entries with the box inside made the scatter cost more than the reads save).
    let num_cells = (g as usize) * (g as usize);
    let ranges: Vec<[u32; 4]> = boxes.iter().map(|b| range_of(b, g)).collect();
    let mut start = vec![0u32; num_cells + 1];
    for r in &ranges {
        for cy in r[1]..=r[3] {
            for cx in r[0]..=r[2] {
                start[(cy * g + cx) as usize + 1] += 1;
            }
        }
    }
    for i in 0..num_cells {
        start[i + 1] += start[i];
    }
    let mut next = start.clone();
    let mut entries = vec![0u32; start[num_cells] as usize];
    for (i, r) in ranges.iter().enumerate() {
        for cy in r[1]..=r[3] {
            for cx in r[0]..=r[2] {
                let cell = (cy * g + cx) as usize;
                entries[next[cell] as usize] = i as u32;
                next[cell] += 1;
            }
        }
    }
    let lo: Vec<[u16; 2]> = ranges.iter().map(|r| [r[0] as u16, r[1] as u16]).collect();
    drop((next, ranges));

    let count_rows = |rows: std::ops::Range<u32>| -> Vec<[u32; 2]> {
        let mut c = Vec::new();
        for cy in rows {
            for cx in 0..g {
                let cell = (cy * g + cx) as usize;
                let list = &entries[start[cell] as usize..start[cell + 1] as usize];
                for (ia, &ta) in list.iter().enumerate() {
                    let (ta, la) = (ta as usize, lo[ta as usize]);
                    for &tb in &list[ia + 1..] {
                        let tb = tb as usize;
                        // Test each pair once: in the lowest cell both boxes meet.
                        let lb = lo[tb];
                        if u32::from(la[0].max(lb[0])) != cx || u32::from(la[1].max(lb[1])) != cy {
                            continue;
                        }
                        // Strict box overlap is necessary for intersecting interiors.
                        let (a, b) = (&boxes[ta], &boxes[tb]);
                        if !(a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3]) {
                            continue;
                        }
                        if !interiors_intersect_pair(&tris[ta], &tris[tb]) {
                            continue;
                        }
                        let (fa, fb) = (face[ta], face[tb]);
                        c.push([fa.min(fb), fa.max(fb)]);
                    }
                }
            }
        }
        c
    };
    // Parallel over batches of cell rows, merged in row order: deterministic whatever the
    // thread count, and the cap is applied between batches of batches.
    let batches: Vec<u32> = (0..g).step_by(ROWS_PER_BATCH as usize).collect();
    for group in batches.chunks(64) {
        let found: Vec<Vec<[u32; 2]>> = group
            .par_iter()
            .map(|&r0| count_rows(r0..(r0 + ROWS_PER_BATCH).min(g)))
            .collect();
        for c in found {
            if out.examples.len() < EXACT_OVERLAP_EXAMPLES {
                out.examples.extend(
                    c.iter()
                        .take(EXACT_OVERLAP_EXAMPLES)
                        .map(|p| [FaceId(p[0]), FaceId(p[1])]),
                );
            }
            out.pairs.extend(c);
        }
        if out.pairs.len() as u64 >= EXACT_OVERLAP_PAIRS_MAX {
            out.truncated = true;
            return;
        }
    }
}
