//! Chart validation: LSCM paper §3.3 ("validate charts").
//!
//! Purpose: after segmentation, flatten every chart with the parameterizer (issue 3,
//! [`parameterize_chart`]) and split the charts whose map is not usable, until every chart is:
//! - **flipped triangle** ([`ChartMap::flipped_faces`] not empty): split in two from the ends of
//!   a diameter of the chart's face graph (LSCM cannot flip in exact arithmetic, §2.6 and A.5, but
//!   HLSCM and rounding can);
//! - **boundary self-intersection in UV** (the overlaps of §3.3 / Figure 6): detected exactly
//!   in the combinatorial sense — every pair of non-adjacent boundary segments that share a cell
//!   of a uniform grid is tested with orientation predicates (collinear overlaps and touching
//!   count as intersections); the chart is re-grown in two from the faces of the two crossing
//!   segments (the paper cuts along the border of the overlapped zone; re-growing is the simpler
//!   alternative issue 4 allows). The orientation signs are computed in `f64`, not with adaptive
//!   exact arithmetic: a crossing within rounding of a touching is reported as a crossing;
//! - **area distortion**: the ratio model area / UV area per face, max over min within the chart,
//!   above [`ValidateOptions::max_area_ratio`]: split by growing two charts from the faces of the
//!   minimum and the maximum, as in the paper.
//!
//! Every part is passed through the disk guarantee again, so the result still satisfies the
//! segmentation contract (every chart a disk, every face in one chart).
//!
//! Invariants: terminates — each split makes one more chart, a single triangle never splits, and
//! the number of splits is bounded by the face count. Deterministic: charts are processed in a
//! fixed order and the parameterizer is deterministic.
//!
//! Small charts are then merged back into a neighbour when the merged chart is still a disk and
//! passes all three tests (one pass, smallest first, two neighbours tried each; see `merge_back`).
//!
//! Charts containing a zero-area face cannot be parameterized by LSCM (its `1/√d_T` weight is
//! infinite); they are returned unsplit with [`ChartDefect::Unparameterizable`] so that the caller
//! sees them rather than losing them.
//!
//! Units: area ratios are plain ratios (model area per UV area, divided by its minimum over the
//! chart); UVs in model units, as the parameterizer returns them.
//!
//! References: B. Lévy, S. Petitjean, N. Ray, J. Maillot, "Least Squares Conformal Maps for
//! Automatic Texture Atlas Generation", SIGGRAPH 2002, §3.3 (area-ratio threshold 2).
use crate::atlas::parameterize::{
    parameterize_chart, ChartMap, ParameterizeError, ParameterizeOptions,
};
use crate::mesh::{FaceId, TriangleMesh};

use super::{
    chart_mesh, disk_check, enforce_disks, finish, grow_two, SegmentError, SegmentStats,
    Segmentation,
};

/// Options of [`validate_charts`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValidateOptions {
    /// Largest allowed ratio between the largest and the smallest per-face area ratio (model area
    /// / UV area) within a chart, or `None` for no area test. Plain ratio `>= 1`. Default
    /// `Some(2.0)` (the paper's threshold).
    pub max_area_ratio: Option<f64>,
    /// How each chart is flattened. Default [`ParameterizeOptions::default`].
    pub parameterize: ParameterizeOptions,
}

impl Default for ValidateOptions {
    fn default() -> Self {
        Self {
            max_area_ratio: Some(2.0),
            parameterize: ParameterizeOptions::default(),
        }
    }
}

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
    /// The parameterizer rejected the chart (e.g. a zero-area face); it is returned unsplit.
    Unparameterizable(ParameterizeError),
}

/// A chart's map and its local → global vertex map (from [`chart_mesh`]).
pub type LocatedMap = (ChartMap, Vec<crate::mesh::VertexId>);

/// The validated charts and their maps.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidatedCharts {
    /// The final charts (each a disk; see [`Segmentation`]).
    pub segmentation: Segmentation,
    /// The map of each chart (same order as `segmentation.charts`), with the local → global
    /// vertex map of [`chart_mesh`]; `None` for a chart that could not be parameterized.
    pub maps: Vec<Option<LocatedMap>>,
    /// Charts returned although not valid: chart index and why.
    pub unresolved: Vec<(usize, ChartDefect)>,
    /// Splits made, by cause: flips, overlaps, area ratio.
    pub splits: [usize; 3],
    /// Small charts merged back into a neighbour after splitting.
    pub merges: usize,
}

/// Parameterizes every chart of `seg` and splits invalid ones until all are valid (module doc).
///
/// Errors: [`SegmentError::InvalidOption`] for an area ratio below 1 or not finite.
/// Cost: one parameterization per chart, plus one per part after each split.
pub fn validate_charts(
    mesh: &TriangleMesh,
    seg: &Segmentation,
    options: &ValidateOptions,
) -> Result<ValidatedCharts, SegmentError> {
    if let Some(r) = options.max_area_ratio {
        if !(r >= 1.0 && r.is_finite()) {
            return Err(SegmentError::InvalidOption {
                option: "max_area_ratio",
                detail: format!("{r} is not a finite ratio >= 1; use e.g. 2.0, or None"),
            });
        }
    }
    let mut stats: SegmentStats = seg.stats;
    let mut pending: Vec<Vec<FaceId>> = seg.charts.iter().rev().cloned().collect();
    let mut done: Vec<(Vec<FaceId>, Option<LocatedMap>)> = Vec::new();
    let mut unresolved_faces: Vec<(FaceId, ChartDefect)> = Vec::new();
    let mut splits = [0usize; 3];
    let mut label = vec![u32::MAX; mesh.num_faces()];
    let mut next_label = 0u32;
    let max_splits = mesh.num_faces();
    while let Some(faces) = pending.pop() {
        let (cm, global) = chart_mesh(mesh, &faces);
        let map = match parameterize_chart(&cm, &options.parameterize) {
            Ok(m) => m,
            Err(e) => {
                unresolved_faces.push((faces[0], ChartDefect::Unparameterizable(e)));
                done.push((faces, None));
                continue;
            }
        };
        let defect = find_defect(&faces, &cm, &map, options);
        let Some(defect) = defect else {
            done.push((faces, Some((map, global))));
            continue;
        };
        if faces.len() < 2 || splits.iter().sum::<usize>() >= max_splits {
            unresolved_faces.push((faces[0], defect));
            done.push((faces, Some((map, global))));
            continue;
        }
        next_label += 1;
        let id = next_label;
        for f in &faces {
            label[f.index()] = id;
        }
        let inside = |f: FaceId| label[f.index()] == id;
        let (a, b, cause) = match &defect {
            ChartDefect::Flipped { .. } => {
                let a = *super::flood(mesh, &faces[..1], &inside)
                    .last()
                    .unwrap_or(&faces[0]);
                let b = *super::flood(mesh, &[a], &inside).last().unwrap_or(&a);
                (a, b, 0)
            }
            ChartDefect::BoundaryOverlap { faces: [a, b] } => (*a, *b, 1),
            ChartDefect::AreaRatio {
                min_face, max_face, ..
            } => (*min_face, *max_face, 2),
            ChartDefect::Unparameterizable(_) => {
                // Not produced by `find_defect`; kept whole if it ever were.
                unresolved_faces.push((faces[0], defect.clone()));
                done.push((faces, Some((map, global))));
                continue;
            }
        };
        let (mut pa, mut pb) = grow_two(mesh, &faces, &inside, a, b);
        if pb.is_empty() {
            // Both seeds in one face (an overlap within one face's edges): split by diameter.
            let a = *super::flood(mesh, &faces[..1], &inside)
                .last()
                .unwrap_or(&faces[0]);
            let b = *super::flood(mesh, &[a], &inside).last().unwrap_or(&a);
            (pa, pb) = grow_two(mesh, &faces, &inside, a, b);
        }
        if pb.is_empty() {
            unresolved_faces.push((faces[0], defect));
            done.push((faces, Some((map, global))));
            continue;
        }
        splits[cause] += 1;
        for part in enforce_disks(mesh, vec![pa, pb], &mut stats)
            .into_iter()
            .rev()
        {
            debug_assert!(disk_check(mesh, &part, &|f| part.binary_search(&f).is_ok()).is_ok());
            pending.push(part);
        }
    }
    let merges = if splits.iter().sum::<usize>() > 0 {
        let unresolved: std::collections::BTreeSet<FaceId> =
            unresolved_faces.iter().map(|(f, _)| *f).collect();
        merge_back(mesh, &mut done, &unresolved, options)
    } else {
        0
    };
    // Order by lowest face like `segment_charts`, keeping maps aligned.
    for (faces, _) in &mut done {
        faces.sort_unstable();
    }
    done.sort_by_key(|(faces, _)| faces[0]);
    let charts: Vec<Vec<FaceId>> = done.iter().map(|(f, _)| f.clone()).collect();
    let segmentation = finish(mesh, charts, stats);
    let unresolved = unresolved_faces
        .into_iter()
        .map(|(f, d)| (segmentation.face_chart[f].index(), d))
        .collect();
    Ok(ValidatedCharts {
        segmentation,
        maps: done.into_iter().map(|(_, m)| m).collect(),
        unresolved,
        splits,
        merges,
    })
}

/// Merges small valid charts back into a neighbour when the merged chart is still a disk and
/// still valid (issue 4: "small charts made by splitting are merged back"). Small means fewer
/// faces than half the mean chart size; smallest first, at most the two neighbours sharing the
/// most edges are tried. Returns the number of merges. Cost: one parameterization per try.
fn merge_back(
    mesh: &TriangleMesh,
    done: &mut Vec<(Vec<FaceId>, Option<LocatedMap>)>,
    unresolved: &std::collections::BTreeSet<FaceId>,
    options: &ValidateOptions,
) -> usize {
    const TRIES: usize = 2;
    let valid: Vec<bool> = done
        .iter()
        .map(|(f, m)| m.is_some() && !unresolved.contains(&f[0]))
        .collect();
    let mut label = vec![u32::MAX; mesh.num_faces()];
    for (i, (faces, _)) in done.iter().enumerate() {
        for f in faces {
            label[f.index()] = i as u32;
        }
    }
    let mean = mesh.num_faces() / done.len().max(1);
    let mut order: Vec<usize> = (0..done.len())
        .filter(|&i| valid[i] && done[i].0.len() * 2 < mean)
        .collect();
    order.sort_by_key(|&i| (done[i].0.len(), done[i].0.iter().min().copied()));
    let mut merges = 0;
    for i in order {
        if done[i].0.is_empty() {
            continue;
        }
        let mut shared: std::collections::BTreeMap<u32, usize> = Default::default();
        for &f in &done[i].0 {
            for g in mesh.face_neighbors(f).into_iter().flatten() {
                let l = label[g.index()];
                if l != i as u32 && l != u32::MAX && valid[l as usize] {
                    *shared.entry(l).or_default() += 1;
                }
            }
        }
        let mut nbrs: Vec<(usize, u32)> = shared.into_iter().map(|(l, n)| (n, l)).collect();
        nbrs.sort_by(|x, y| y.0.cmp(&x.0).then(x.1.cmp(&y.1)));
        for &(_, j) in nbrs.iter().take(TRIES) {
            let j = j as usize;
            let mut union = done[j].0.clone();
            union.extend_from_slice(&done[i].0);
            let (ci, cj) = (i as u32, j as u32);
            let inside = |f: FaceId| {
                let l = label[f.index()];
                l == ci || l == cj
            };
            if disk_check(mesh, &union, &inside).is_err() {
                continue;
            }
            let (cm, global) = chart_mesh(mesh, &union);
            let Ok(map) = parameterize_chart(&cm, &options.parameterize) else {
                continue;
            };
            if find_defect(&union, &cm, &map, options).is_some() {
                continue;
            }
            for f in &done[i].0 {
                label[f.index()] = cj;
            }
            done[j] = (union, Some((map, global)));
            done[i].0.clear();
            merges += 1;
            break;
        }
    }
    done.retain(|(f, _)| !f.is_empty());
    merges
}

/// The first defect of a chart's map, in the order flips, boundary overlap, area ratio.
fn find_defect(
    faces: &[FaceId],
    cm: &crate::atlas::parameterize::ChartMesh,
    map: &ChartMap,
    options: &ValidateOptions,
) -> Option<ChartDefect> {
    if !map.flipped_faces.is_empty() {
        return Some(ChartDefect::Flipped {
            count: map.flipped_faces.len(),
        });
    }
    if let Some([i, j]) = boundary_crossing(cm, &map.uv) {
        return Some(ChartDefect::BoundaryOverlap {
            faces: [faces[i], faces[j]],
        });
    }
    let max_ratio = options.max_area_ratio?;
    let mut lo = (f64::INFINITY, 0usize);
    let mut hi = (0.0f64, 0usize);
    for (k, t) in cm.triangles.iter().enumerate() {
        let p = t.map(|i| cm.positions_m[i as usize]);
        let q = t.map(|i| map.uv[i as usize]);
        let e1 = [0, 1, 2].map(|c| p[1][c] - p[0][c]);
        let e2 = [0, 1, 2].map(|c| p[2][c] - p[0][c]);
        let cr = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let area3 = (cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]).sqrt();
        let area2 =
            (q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[2][0] - q[0][0]) * (q[1][1] - q[0][1]);
        // No flips here (checked above), so area2 > 0.
        let r = area3 / area2;
        if r < lo.0 {
            lo = (r, k);
        }
        if r > hi.0 {
            hi = (r, k);
        }
    }
    let ratio = hi.0 / lo.0;
    (ratio > max_ratio).then(|| ChartDefect::AreaRatio {
        ratio,
        min_face: faces[lo.1],
        max_face: faces[hi.1],
    })
}

fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

fn on_segment(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> bool {
    p[0] >= a[0].min(b[0])
        && p[0] <= a[0].max(b[0])
        && p[1] >= a[1].min(b[1])
        && p[1] <= a[1].max(b[1])
}

/// Segments `ab` and `cd` intersect (touching and collinear overlap included).
fn segments_intersect(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
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
    let n = segs.len();
    if n < 4 {
        return None;
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for &(a, b, _) in &segs {
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
