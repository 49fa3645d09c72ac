//! Centre-sampled rasterisation of each page: coverage, sampled overlap, padding violations.
//!
//! The raster of the module doc's definitions (the independent evaluator's, extended to `W × H`
//! pages):
//! - texel `(i, j)` of a page covers `[i/W, (i+1)/W] × [j/H, (j+1)/H]` and is sampled only at
//!   its centre;
//! - UVs are snapped to a fixed-point grid of `1/S` texel, `S = 256` (halved while
//!   `max(W, H)·S·(max|uv| + 1) > 2²⁸`, i.e. only for huge coordinates), `X = rint(u·W·S)`,
//!   `Y = rint(v·H·S)` (round half to even, as numpy);
//! - edge functions are exact in `i64`; a sample exactly on an edge belongs to the triangle
//!   that contains the point moved by `(+ε, +ε²)` (a top-left fill rule), so triangles sharing
//!   an edge or a vertex never both cover a sample; zero-area triangles cover nothing, and
//!   triangles whose UV box misses the unit square are not rasterised.
//! - overlap pairs are enumerated only on texels covered twice or more, with the evaluator's
//!   candidate budget ([`SAMPLED_PAIR_CANDIDATES_MAX`]) applied in its order (groups of `k`
//!   faces per texel by increasing `k`, then texel order);
//! - padding: a covered texel of chart `c` violates when some texel of another chart lies within
//!   Chebyshev distance ≤ padding on the same page (texels covered by several charts are neither
//!   tested nor testing). Computed with a separable sliding min/max of chart labels.
//!
//! Units: texels. Cost: `O(covered texels + faces + W·H·padding)` per page; 5 bytes per texel
//! (count, saturated at 255, + label), plus 12 bytes per multiply covered (texel, face) sample.
use rayon::prelude::*;

use super::{SampledOverlap, SAMPLED_PAIR_CANDIDATES_MAX};

/// Rows per band of the parallel coverage pass.
const BAND_ROWS: usize = 32;

/// Fixed-point subdivisions per texel (the evaluator's `S`).
const SUBPIXEL: i64 = 256;
/// Bound on fixed-point magnitudes (the evaluator's `LIM`), keeping edge functions in `i64`.
const FIXED_POINT_LIMIT: f64 = (1u64 << 28) as f64;

pub(super) struct RasterResult {
    pub sampled: SampledOverlap,
    pub padding_violation_texels: u64,
    pub covered_per_page: Vec<u64>,
    /// The face pairs `(a, b)`, `a < b`, of `sampled.pairs_same_chart`, ascending.
    pub same_chart_pairs: Vec<(u32, u32)>,
}

/// A triangle in fixed point, counter-clockwise (positive area).
struct FixedTriangle {
    face: u32,
    x: [i64; 3],
    y: [i64; 3],
}

/// Rows `j0..=j1` whose sample `y = j·S + S/2` lies in the triangle's `[ymin, ymax]`, clipped
/// to the page (`j1 < j0` when none).
fn row_span(t: &FixedTriangle, s: i64, h: i64) -> (i64, i64) {
    let half = s / 2;
    let (ymin, ymax) = (t.y.iter().min().unwrap(), t.y.iter().max().unwrap());
    let j0 = (-((-(ymin - half)).div_euclid(s))).max(0);
    let j1 = (ymax - half).div_euclid(s).min(h - 1);
    (j0, j1)
}

/// Calls `run(j, lo, hi)` for every row `j` whose texel centres `lo..=hi` the triangle covers.
fn for_each_run(t: &FixedTriangle, s: i64, [w, h]: [i64; 2], run: impl FnMut(i64, i64, i64)) {
    for_each_run_in_rows(t, s, [w, h], (0, h - 1), run);
}

/// [`for_each_run`] restricted to the rows `rows.0..=rows.1`.
fn for_each_run_in_rows(
    t: &FixedTriangle,
    s: i64,
    [w, h]: [i64; 2],
    rows: (i64, i64),
    mut run: impl FnMut(i64, i64, i64),
) {
    let half = s / 2;
    let (j0, j1) = row_span(t, s, h);
    let (j0, j1) = (j0.max(rows.0), j1.min(rows.1));
    let edges: [(i64, i64, i64, i64); 3] = std::array::from_fn(|e| {
        let (a, b) = (e, (e + 1) % 3);
        (t.x[a], t.y[a], t.x[b] - t.x[a], t.y[b] - t.y[a])
    });
    for j in j0..=j1 {
        let ys = j * s + half;
        let (mut lo, mut hi) = (0i64, w - 1);
        for &(ax, ay, dx, dy) in &edges {
            // Inside iff E(p) = dx·(py - ay) - dy·(px - ax) >= off, off = 0 on edges that own
            // their samples (top-left rule), 1 otherwise; px = i·S + S/2.
            let owns = dy < 0 || (dy == 0 && dx > 0);
            let c = dx * (ys - ay) + dy * ax - i64::from(!owns);
            if dy > 0 {
                hi = hi.min((c - dy * half).div_euclid(dy * s));
            } else if dy < 0 {
                let m = -dy;
                lo = lo.max(-((c + m * half).div_euclid(m * s)));
            } else if c < 0 {
                hi = -1;
            }
        }
        if hi >= lo {
            run(j, lo, hi);
        }
    }
}

/// Rasterises every page. `size = [W, H]` texels.
pub(super) fn rasterize_pages(
    corner_uvs: &[[[f32; 2]; 3]],
    face_page: &[u32],
    num_pages: u32,
    size: [u32; 2],
    padding_texels: u32,
    chart_of_face: &[u32],
) -> RasterResult {
    let (w, h) = (i64::from(size[0]), i64::from(size[1]));
    let texels = (w * h) as usize;
    let r = w.max(h) as f64;
    let mut faces_of_page: Vec<Vec<u32>> = vec![Vec::new(); num_pages as usize];
    for (f, &p) in face_page.iter().enumerate() {
        faces_of_page[p as usize].push(f as u32);
    }
    let mut out = RasterResult {
        sampled: SampledOverlap::default(),
        padding_violation_texels: 0,
        covered_per_page: Vec::with_capacity(num_pages as usize),
        same_chart_pairs: Vec::new(),
    };
    // (global texel, face) samples on multiply covered texels, all pages.
    let mut multi_samples: Vec<(u64, u32)> = Vec::new();
    // Every band sets its own part of both before using it (pass 1), page after page.
    let mut cov = vec![0u8; texels];
    let mut label = vec![0i32; texels];
    for (page, faces) in faces_of_page.iter().enumerate() {
        // Faces whose UV box meets the unit square, and the fixed-point scale.
        let mut cand_max = 0.0f64;
        let inside: Vec<(u32, f64)> = faces
            .iter()
            .filter_map(|&f| {
                let uv = &corner_uvs[f as usize];
                let c: [f64; 6] = std::array::from_fn(|i| f64::from(uv[i / 2][i % 2]));
                if !c.iter().all(|x| x.is_finite()) {
                    return None;
                }
                let (us, vs) = ([c[0], c[2], c[4]], [c[1], c[3], c[5]]);
                let max = |a: [f64; 3]| a[0].max(a[1]).max(a[2]);
                let min = |a: [f64; 3]| a[0].min(a[1]).min(a[2]);
                if max(us) < 0.0 || max(vs) < 0.0 || min(us) > 1.0 || min(vs) > 1.0 {
                    return None;
                }
                let maxabs = c.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                cand_max = cand_max.max(maxabs);
                Some((f, maxabs))
            })
            .collect();
        let mut s = SUBPIXEL;
        while s > 2 && r * s as f64 * (cand_max + 1.0) > FIXED_POINT_LIMIT {
            s /= 2;
        }
        let (ws, hs) = ((w * s) as f64, (h * s) as f64);
        let mut tris = Vec::with_capacity(inside.len());
        for &(f, maxabs) in &inside {
            if r * s as f64 * (maxabs + 1.0) > FIXED_POINT_LIMIT {
                out.sampled.raster_skipped_triangles += 1;
                continue;
            }
            let uv = &corner_uvs[f as usize];
            let mut x = uv.map(|c| (f64::from(c[0]) * ws).round_ties_even() as i64);
            let mut y = uv.map(|c| (f64::from(c[1]) * hs).round_ties_even() as i64);
            let area2 = (x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0]);
            if area2 == 0 {
                continue;
            }
            if area2 < 0 {
                x.swap(1, 2);
                y.swap(1, 2);
            }
            tris.push(FixedTriangle { face: f, x, y });
        }

        // Pass 1: coverage count and chart label (-1 empty, -2 several charts), in bands of
        // `BAND_ROWS` rows rasterised in parallel. A texel's count and label depend only on the
        // triangles covering it, visited in `tris` order within its band, so the result is the
        // same for any banding and thread count.
        let band_rows = BAND_ROWS as i64;
        let num_bands = ((h + band_rows - 1) / band_rows) as usize;
        let mut tris_of_band: Vec<Vec<u32>> = vec![Vec::new(); num_bands];
        for (ti, t) in tris.iter().enumerate() {
            let (j0, j1) = row_span(t, s, h);
            if j1 >= j0 {
                let bands = (j0 / band_rows) as usize..=(j1 / band_rows) as usize;
                for band_tris in &mut tris_of_band[bands] {
                    band_tris.push(ti as u32);
                }
            }
        }
        let band_texels = BAND_ROWS * w as usize;
        let band_counts: Vec<[u64; 4]> = cov
            .par_chunks_mut(band_texels)
            .zip(label.par_chunks_mut(band_texels))
            .zip(tris_of_band.par_iter())
            .enumerate()
            .map(|(band, ((cov, label), band_tris))| {
                cov.fill(0);
                label.fill(-1);
                let first_row = band as i64 * band_rows;
                let rows = (first_row, first_row + band_rows - 1);
                for &ti in band_tris {
                    let t = &tris[ti as usize];
                    let chart = chart_of_face[t.face as usize] as i32;
                    for_each_run_in_rows(t, s, [w, h], rows, |j, lo, hi| {
                        let row = ((j - first_row) * w) as usize;
                        for i in lo as usize..=hi as usize {
                            let k = row + i;
                            if cov[k] == 0 {
                                label[k] = chart;
                            } else if label[k] != chart {
                                label[k] = -2;
                            }
                            cov[k] = cov[k].saturating_add(1);
                        }
                    });
                }
                // [covered, multiply covered, of which cross-chart, of which same-chart]
                let mut n = [0u64; 4];
                for (&c, &l) in cov.iter().zip(label.iter()) {
                    n[0] += u64::from(c >= 1);
                    if c >= 2 {
                        n[1] += 1;
                        n[2] += u64::from(l == -2);
                        n[3] += u64::from(l != -2);
                    }
                }
                n
            })
            .collect();
        let n = band_counts.iter().fold([0u64; 4], |a, b| {
            [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]]
        });
        let (covered, multi) = (n[0], n[1]);
        out.sampled.texels_cross_chart += n[2];
        out.sampled.texels_same_chart += n[3];
        out.sampled.covered_texels += covered;
        out.sampled.overlapping_texels += multi;
        out.covered_per_page.push(covered);

        // Pass 2, only when something is covered twice: the (texel, face) samples there.
        if multi > 0 {
            let base = page as u64 * texels as u64;
            for t in &tris {
                for_each_run(t, s, [w, h], |j, lo, hi| {
                    let row = (j * w) as usize;
                    for i in lo as usize..=hi as usize {
                        if cov[row + i] >= 2 {
                            multi_samples.push((base + (row + i) as u64, t.face));
                        }
                    }
                });
            }
        }
        out.padding_violation_texels +=
            padding_violations(&label, [w as usize, h as usize], padding_texels as usize);
    }
    let covered = out.sampled.covered_texels;
    out.sampled.fraction = if covered > 0 {
        out.sampled.overlapping_texels as f64 / covered as f64
    } else {
        0.0
    };
    out.same_chart_pairs = sampled_pairs(
        &mut out.sampled,
        multi_samples,
        chart_of_face,
        SAMPLED_PAIR_CANDIDATES_MAX,
    );
    out
}

/// Distinct face pairs sharing a multiply covered texel, with the evaluator's candidate budget;
/// returns the pairs `(a, b)` within one chart, ascending.
fn sampled_pairs(
    out: &mut SampledOverlap,
    mut samples: Vec<(u64, u32)>,
    chart_of_face: &[u32],
    max_candidates: u64,
) -> Vec<(u32, u32)> {
    if samples.is_empty() {
        return Vec::new();
    }
    samples.sort_unstable();
    // Groups (size, start) of equal texel, then by size ascending, texel order kept.
    let mut groups: Vec<(usize, usize)> = Vec::new();
    let mut start = 0;
    for i in 1..=samples.len() {
        if i == samples.len() || samples[i].0 != samples[start].0 {
            groups.push((i - start, start));
            start = i;
        }
    }
    groups.sort_by_key(|&(size, _)| size);
    let nf = chart_of_face.len() as u64;
    let mut keys: Vec<u64> = Vec::new();
    let mut budget = max_candidates;
    let mut g = 0;
    while g < groups.len() {
        let k = groups[g].0;
        let mut end = g;
        while end < groups.len() && groups[end].0 == k {
            end += 1;
        }
        let per_group = (k * (k - 1) / 2) as u64;
        let mut count = (end - g) as u64;
        if count * per_group > budget {
            out.pairs_truncated = true;
            count = budget / per_group.max(1);
        }
        if count > 0 {
            budget -= count * per_group;
            for &(_, s0) in &groups[g..g + count as usize] {
                let faces = &samples[s0..s0 + k];
                for a in 0..k {
                    for b in a + 1..k {
                        keys.push(u64::from(faces[a].1) * nf + u64::from(faces[b].1));
                    }
                }
            }
        }
        g = end;
    }
    keys.sort_unstable();
    keys.dedup();
    out.pairs = keys.len() as u64;
    let same_chart: Vec<(u32, u32)> = keys
        .iter()
        .map(|&key| ((key / nf) as u32, (key % nf) as u32))
        .filter(|&(a, b)| chart_of_face[a as usize] == chart_of_face[b as usize])
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    out.pairs_same_chart = same_chart.len() as u64;
    out.pairs_cross_chart = out.pairs - out.pairs_same_chart;
    same_chart
}

/// Covered single-chart texels with a texel of another chart within Chebyshev distance `p`.
///
/// A texel of chart `me` violates when the window around it holds a chart label `< me` or
/// `> me` (labels `< 0`, empty or several charts, are ignored). Read as `u32`, negative labels
/// are larger than every chart, so the window's smallest label is its `u32` minimum and its
/// largest its `i32` maximum (an empty or several-charts texel is then never below nor above a
/// chart): both are separable sliding extrema, computed branch-free over whole rows (rows
/// first, then columns) in bands of `BAND_ROWS` rows, in parallel, with band-sized buffers.
/// Integer counts per band, so the sum does not depend on the thread count.
pub(super) fn padding_violations(label: &[i32], [w, h]: [usize; 2], p: usize) -> u64 {
    if p == 0 || !label.iter().any(|&l| l >= 0) {
        return 0;
    }
    let num_bands = h.div_ceil(BAND_ROWS);
    (0..num_bands)
        .into_par_iter()
        .map(|band| {
            let (j0, j1) = (band * BAND_ROWS, ((band + 1) * BAND_ROWS).min(h));
            // Rows `r0..r1` are the band's rows and up to `p` more on each side.
            let (r0, r1) = (j0.saturating_sub(p), (j1 + p).min(h));
            let rows = r1 - r0;
            let mut rmin = vec![0u32; rows * w];
            let mut rmax = vec![0i32; rows * w];
            for r in 0..rows {
                let row = &label[(r0 + r) * w..(r0 + r + 1) * w];
                let (mn, mx) = (&mut rmin[r * w..(r + 1) * w], &mut rmax[r * w..(r + 1) * w]);
                for ((a, b), &l) in mn.iter_mut().zip(mx.iter_mut()).zip(row) {
                    *a = l as u32;
                    *b = l;
                }
                for d in 1..=p.min(w - 1) {
                    for ((a, b), &l) in mn[..w - d]
                        .iter_mut()
                        .zip(mx[..w - d].iter_mut())
                        .zip(&row[d..])
                    {
                        *a = (*a).min(l as u32);
                        *b = (*b).max(l);
                    }
                    for ((a, b), &l) in mn[d..]
                        .iter_mut()
                        .zip(mx[d..].iter_mut())
                        .zip(&row[..w - d])
                    {
                        *a = (*a).min(l as u32);
                        *b = (*b).max(l);
                    }
                }
            }
            let mut cmin = vec![0u32; w];
            let mut cmax = vec![0i32; w];
            let mut violations = 0u64;
            for j in j0..j1 {
                let (a0, a1) = (j.saturating_sub(p) - r0, (j + p + 1).min(h) - r0);
                cmin.copy_from_slice(&rmin[a0 * w..(a0 + 1) * w]);
                cmax.copy_from_slice(&rmax[a0 * w..(a0 + 1) * w]);
                for a in a0 + 1..a1 {
                    for ((x, y), (&m, &n)) in cmin.iter_mut().zip(cmax.iter_mut()).zip(
                        rmin[a * w..(a + 1) * w]
                            .iter()
                            .zip(&rmax[a * w..(a + 1) * w]),
                    ) {
                        *x = (*x).min(m);
                        *y = (*y).max(n);
                    }
                }
                let row = &label[j * w..(j + 1) * w];
                let bad: u32 = row
                    .iter()
                    .zip(cmin.iter().zip(&cmax))
                    .map(|(&me, (&mn, &mx))| u32::from(me >= 0 && (mn < me as u32 || mx > me)))
                    .sum();
                violations += u64::from(bad);
            }
            violations
        })
        .sum()
}
