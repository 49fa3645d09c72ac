//! Clearance between the parts of a chart's border: no boundary vertex may come closer than a
//! small fraction of the chart's size to a boundary segment it is not an endpoint of.
//!
//! Why: the optimiser's tests (no flip, no boundary crossing, no fold) hold in `f64`, but the
//! written UVs are `f32` in page coordinates. A move that presses a boundary vertex against
//! another part of the border (the two sides of a crack in a CAD mesh, a bay closing up) can
//! leave a gap below the `f32` spacing, and rounding then makes the faces on both sides overlap
//! (2CylinderEngine: a vertex 1.5e-8 page units inside a face of its own chart). A moved map
//! that brings a vertex closer than the clearance to a segment, and closer than half the
//! distance it had before the move, is not kept (near-contacts the parameterizer's map already
//! had are left as they were).
//!
//! Test: segments are entered in a uniform grid (about one cell per segment, cells at least the
//! clearance wide) by their boxes grown by the clearance; each boundary vertex is tested against
//! the segments of its own cell. Cost: `O(segments + candidates)`. Deterministic.

/// The clearance, as a fraction of the chart's larger UV extent. Trade-off: the `f32` spacing
/// of page coordinates is about 6e-8, so 1e-5 of the chart keeps a margin of a few spacings on
/// charts down to about 1/100 of the page; a larger fraction rejects more moved maps.
pub(super) const CLEARANCE_RELATIVE: f64 = 1e-5;

/// The larger side of the UV box of `uv` (0 when empty).
pub(super) fn extent(uv: &[[f64; 2]]) -> f64 {
    (0..2)
        .map(|k| {
            let (lo, hi) = uv.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |m, p| {
                (m.0.min(p[k]), m.1.max(p[k]))
            });
            hi - lo
        })
        .fold(0.0f64, f64::max)
}

/// Distance from `p` to the segment `a`–`b`.
fn distance_to_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1]];
    let ap = [p[0] - a[0], p[1] - a[1]];
    let len2 = ab[0] * ab[0] + ab[1] * ab[1];
    let t = if len2 > 0.0 {
        ((ap[0] * ab[0] + ap[1] * ab[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let d = [ap[0] - t * ab[0], ap[1] - t * ab[1]];
    (d[0] * d[0] + d[1] * d[1]).sqrt()
}

/// True when some endpoint of the boundary segments `segs` (`(a, b, owning triangle)` of
/// `triangles`) lies closer than `clearance` to a segment it is not a corner of the triangle of
/// in `uv` (or when a UV is not
/// finite), and, when `before` is given, also closer than half its distance in `before` (a
/// near-contact the move made, not one the map already had).
pub(super) fn too_close(
    triangles: &[[u32; 3]],
    segs: &[(u32, u32, usize)],
    uv: &[[f64; 2]],
    before: Option<&[[f64; 2]]>,
    clearance: f64,
) -> bool {
    if segs.len() < 3 {
        return false;
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for &(a, b, _) in segs {
        for v in [a, b] {
            let Some(p) = uv.get(v as usize) else {
                return true;
            };
            if !(p[0].is_finite() && p[1].is_finite()) {
                return true;
            }
            lo = [lo[0].min(p[0]), lo[1].min(p[1])];
            hi = [hi[0].max(p[0]), hi[1].max(p[1])];
        }
    }
    let n = ((segs.len() as f64).sqrt().ceil() as usize).clamp(1, 2048);
    let size = [
        ((hi[0] - lo[0] + 2.0 * clearance) / n as f64).max(clearance),
        ((hi[1] - lo[1] + 2.0 * clearance) / n as f64).max(clearance),
    ];
    let (nx, ny) = (
        (((hi[0] - lo[0] + 2.0 * clearance) / size[0]).ceil() as usize).clamp(1, n),
        (((hi[1] - lo[1] + 2.0 * clearance) / size[1]).ceil() as usize).clamp(1, n),
    );
    let cell = |x: f64, axis: usize, m: usize| {
        (((x - lo[axis] + clearance) / size[axis]).max(0.0) as usize).min(m - 1)
    };
    let mut grid: Vec<Vec<u32>> = vec![Vec::new(); nx * ny];
    for (s, &(a, b, _)) in segs.iter().enumerate() {
        let (pa, pb) = (uv[a as usize], uv[b as usize]);
        let (x0, x1) = (pa[0].min(pb[0]) - clearance, pa[0].max(pb[0]) + clearance);
        let (y0, y1) = (pa[1].min(pb[1]) - clearance, pa[1].max(pb[1]) + clearance);
        for cy in cell(y0, 1, ny)..=cell(y1, 1, ny) {
            for cx in cell(x0, 0, nx)..=cell(x1, 0, nx) {
                grid[cy * nx + cx].push(s as u32);
            }
        }
    }
    // Every boundary vertex is the start of some segment.
    segs.iter().any(|&(v, _, _)| {
        let p = uv[v as usize];
        grid[cell(p[1], 1, ny) * nx + cell(p[0], 0, nx)]
            .iter()
            .any(|&s| {
                let (a, b, t) = segs[s as usize];
                // The segment's own triangle: its height, which the flip test bounds.
                if a == v || b == v || triangles.get(t).is_some_and(|t| t.contains(&v)) {
                    return false;
                }
                let d = distance_to_segment(p, uv[a as usize], uv[b as usize]);
                d < clearance
                    && before.is_none_or(|q| {
                        d < 0.5 * distance_to_segment(q[v as usize], q[a as usize], q[b as usize])
                    })
            })
    })
}

#[cfg(test)]
mod tests {
    use super::too_close;

    #[test]
    fn a_square_has_clearance_and_a_closed_crack_does_not() {
        // A square's border: every vertex is far from the segments it is not on.
        let square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let segs = [(0, 1, 0), (1, 2, 0), (2, 3, 0), (3, 0, 0)];
        assert!(!too_close(&[], &segs, &square, None, 1e-5));
        // A bay closed up: the border runs 0 -> 1 -> 2 -> 3 -> 4 -> 0 with vertex 3 pressed
        // 1e-9 above the segment 0 -> 1 (every other vertex is at least 0.4 from the segments
        // it is not on).
        let crack = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1e-9], [0.0, 1.0]];
        let segs = [(0, 1, 0), (1, 2, 0), (2, 3, 0), (3, 4, 0), (4, 0, 0)];
        assert!(too_close(&[], &segs, &crack, None, 1e-5));
        assert!(!too_close(&[], &segs, &crack, None, 1e-10));
        // Made by the move (the crack was open before): too close; already as close before:
        // not the move's doing.
        let mut open = crack;
        open[3][1] = 0.5;
        assert!(too_close(&[], &segs, &crack, Some(&open), 1e-5));
        assert!(!too_close(&[], &segs, &crack, Some(&crack), 1e-5));
    }
}
