//! The merge-back: valid charts are merged into a neighbour while the union is still a disk and
//! passes every test of [`super::defects`] ([`merge_back`]; Lévy et al. 2002 §3.3 leaves small
//! split charts; merging them back undoes over-segmentation).
//!
//! Whether a union is a disk is decided from the two charts' intersection alone ([`union_arc`],
//! linear in the smaller chart). A union whose two maps draw their shared boundary very
//! differently ([`shared_arc_misfit`] above `MERGE_MAX_ARC_MISFIT`) is not flattened: such
//! unions fail the tests anyway. Deterministic: the pass is sequential; the speculative
//! flattening of [`super::schedule`] never changes its result.
use super::defects::find_defect;
use super::degenerate::{flatten_around_degenerate, is_degenerate, Attempt};
use super::schedule::{MergeKey, Speculation, SPECULATION_CHARTS_PER_THREAD};
use super::ParameterizeChartsError;
use super::{
    chart_mesh, conformal_energy, flipped_faces, lscm, ChartMap, LocatedMap, ParameterizeOptions,
    Pin, LATE_MERGE_MAX_FACES, MERGE_CAP_FLOOR_FACES,
};
use crate::atlas::progress::StageProgress;
use crate::atlas::segment::disk_check;
use crate::mesh::{FaceId, TriangleMesh, VertexId};

/// Merges valid charts into a neighbour while the merged chart is still a disk and still valid,
/// in at most [`ParameterizeOptions::merge_passes`] passes. The first pass visits only the small
/// charts (fewer faces than half the mean chart size when validation ends), later passes every
/// chart (the cost of a try is that of flattening the union, so trying every chart is much
/// dearer). Each pass visits the valid charts smallest first (ties by lowest face) and tries the
/// [`MERGE_TRIES`] neighbours sharing the most edges with it (ties by index), keeping the first
/// valid union; a merged chart can take more merges later in the pass. A pair that failed is
/// not tried again until one of its charts has grown. Returns the number of merges. Unions above
/// [`ParameterizeOptions::merge_max_chart_fraction`] of the mesh (and above
/// [`MERGE_CAP_FLOOR_FACES`]) are not tried. Cost: one parameterization of the union per try.
pub(super) fn merge_back(
    mesh: &TriangleMesh,
    done: &mut Vec<(Vec<FaceId>, LocatedMap)>,
    unresolved: &std::collections::BTreeSet<FaceId>,
    options: &ParameterizeOptions,
    progress: &mut StageProgress<'_>,
) -> Result<usize, ParameterizeChartsError> {
    let valid: Vec<bool> = done
        .iter()
        .map(|(f, _)| !unresolved.contains(&f[0]))
        .collect();
    let mut label = vec![u32::MAX; mesh.num_faces()];
    for (i, (faces, _)) in done.iter().enumerate() {
        for f in faces {
            label[f.index()] = i as u32;
        }
    }
    // A chart's version grows with each merge into it: failed pairs are keyed by versions.
    let mut version = vec![0u32; done.len()];
    let mut failed: std::collections::BTreeSet<MergeKey> = Default::default();
    let key = |i: usize, j: usize, version: &[u32]| -> MergeKey {
        let (a, b) = (i.min(j), i.max(j));
        (a as u32, version[a], b as u32, version[b])
    };
    let mut merges = 0;
    let max_union_faces = options.merge_max_chart_fraction.map_or(usize::MAX, |f| {
        ((f * mesh.num_faces() as f64) as usize).max(MERGE_CAP_FLOOR_FACES)
    });
    // Mean size of the charts that have area: charts made only of zero-area faces (2CylinderEngine
    // has 10,419, each an isolated triangle) would otherwise pull the mean down to ~6 faces, and
    // only 1- and 2-face charts would be tried.
    let (area_faces, area_charts) = done
        .iter()
        .filter(|(f, _)| !f.iter().all(|&g| is_degenerate(mesh, g)))
        .fold((0usize, 0usize), |(n, c), (f, _)| (n + f.len(), c + 1));
    let mean = area_faces / area_charts.max(1);
    // The `MERGE_TRIES` valid neighbours of chart `i` sharing the most edges with it (ties by
    // index), from the current labels.
    let neighbours = |i: usize, done: &[(Vec<FaceId>, LocatedMap)], label: &[u32]| {
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
        nbrs.truncate(MERGE_TRIES);
        nbrs.into_iter()
            .map(|(_, j)| j as usize)
            .collect::<Vec<usize>>()
    };
    // What the union of charts `i` and `j` needs: decided without flattening (`Some`: too
    // large or not a disk, `None` map; or the extension of the larger chart's map), or
    // `None`: flatten it (`flatten_around_degenerate`).
    let pre_check = |union: &[FaceId],
                     i: usize,
                     j: usize,
                     label: &[u32],
                     done: &[(Vec<FaceId>, LocatedMap)]|
     -> Option<Option<LocatedMap>> {
        if union.len() > max_union_faces {
            return Some(None);
        }
        let (ci, cj) = (i as u32, j as u32);
        let arc = union_arc(mesh, &done[i].0, &done[j].0, label, ci, cj);
        debug_assert_eq!(
            arc.is_some(),
            disk_check(mesh, union, &|f: FaceId| {
                let l = label[f.index()];
                l == ci || l == cj
            })
            .is_ok(),
            "union_arc disagrees with disk_check"
        );
        let Some(arc) = arc else {
            return Some(None);
        };
        if shared_arc_misfit(&done[i].1, &done[j].1, &arc) > MERGE_MAX_ARC_MISFIT {
            return Some(None);
        }
        let (big, small) = if done[i].0.len() > done[j].0.len() {
            (&done[i], &done[j])
        } else {
            (&done[j], &done[i])
        };
        if small.0.len() * EXTEND_RATIO <= big.0.len() {
            if let Some(map) = extend_into(mesh, union, big, &small.0, options) {
                return Some(Some(map));
            }
        }
        None
    };
    // Both charts' faces are ascending and disjoint: their union, ascending, by one merge.
    let union_of = |i: usize, j: usize, done: &[(Vec<FaceId>, LocatedMap)]| {
        let (a, b) = (&done[i].0, &done[j].0);
        let mut union = Vec::with_capacity(a.len() + b.len());
        let (mut x, mut y) = (0, 0);
        while x < a.len() && y < b.len() {
            if a[x] < b[y] {
                union.push(a[x]);
                x += 1;
            } else {
                union.push(b[y]);
                y += 1;
            }
        }
        union.extend_from_slice(&a[x..]);
        union.extend_from_slice(&b[y..]);
        debug_assert!(union.windows(2).all(|w| w[0] < w[1]));
        union
    };
    let passes = if mesh.num_faces() > LATE_MERGE_MAX_FACES {
        options.merge_passes.min(1)
    } else {
        options.merge_passes
    };
    for pass in 0..passes {
        let merges_before = merges;
        let mut order: Vec<usize> = (0..done.len())
            .filter(|&i| valid[i] && !done[i].0.is_empty())
            .filter(|&i| pass > 0 || done[i].0.len() * 2 < mean)
            .collect();
        order.sort_by_key(|&i| (done[i].0.len(), done[i].0[0]));
        // Speculation (module doc): while this thread runs the pass in `order`, the pool
        // flattens the tries of the next charts, queued from the current state and keyed by
        // both charts' versions; a result is used only under its exact key, so the pass is the
        // sequential one whatever the thread count.
        let spec = Speculation::default();
        let window = SPECULATION_CHARTS_PER_THREAD * rayon::current_num_threads();
        let flatten_ok = |union: &[FaceId]| match flatten_around_degenerate(mesh, union, options) {
            Attempt::Mapped { map, defect: None } => Some(map),
            _ => None,
        };
        let outcome: Result<(), ParameterizeChartsError> = rayon::in_place_scope(|scope| {
            let (spec, flatten_ok) = (&spec, &flatten_ok);
            let mut queued = 0usize;
            for (p, &i) in order.iter().enumerate() {
                // Queue the tries of the charts up to `window` ahead, from the current state.
                while queued < order.len() && queued <= p + window {
                    let q = order[queued];
                    queued += 1;
                    if done[q].0.is_empty() {
                        continue;
                    }
                    let mut chain = Vec::new();
                    for j in neighbours(q, done, &label) {
                        let k = key(q, j, &version);
                        if failed.contains(&k) || spec.has(&k) {
                            continue;
                        }
                        let union = union_of(q, j, done);
                        match pre_check(&union, q, j, &label, done) {
                            None => {
                                spec.queue(k, union);
                                chain.push(k);
                            }
                            Some(r) => spec.decide(k, r),
                        }
                    }
                    if !chain.is_empty() {
                        scope.spawn(move |_| spec.run_chain(&chain, flatten_ok));
                    }
                }
                if done[i].0.is_empty() {
                    continue;
                }
                for j in neighbours(i, done, &label) {
                    let k = key(i, j, &version);
                    if failed.contains(&k) {
                        continue;
                    }
                    let known = done.len() - merges;
                    if progress.advance(known, known).is_break() {
                        spec.clear();
                        return Err(ParameterizeChartsError::Cancelled);
                    }
                    let union = union_of(i, j, done);
                    let result = match spec.take(&k, flatten_ok) {
                        Some(r) => r,
                        None => pre_check(&union, i, j, &label, done)
                            .unwrap_or_else(|| flatten_ok(&union)),
                    };
                    if let Some(map) = result {
                        // The union takes the slot of the larger chart.
                        let (keep, gone) = if done[i].0.len() > done[j].0.len() {
                            (i, j)
                        } else {
                            (j, i)
                        };
                        for f in &done[gone].0 {
                            label[f.index()] = keep as u32;
                        }
                        done[keep] = (union, map);
                        done[gone].0.clear();
                        version[keep] += 1;
                        merges += 1;
                        // Queued tries of either chart are stale now (their keys can no longer
                        // come up); dropping them keeps the pool from flattening them.
                        spec.forget_charts(keep, gone);
                        break;
                    }
                    failed.insert(k);
                }
            }
            spec.clear();
            Ok(())
        });
        outcome?;
        // The first pass tries only the small charts: nothing merged there says nothing about
        // the larger ones, so only a later pass without a merge ends the merging.
        if pass > 0 && merges == merges_before {
            break;
        }
    }
    done.retain(|(f, _)| !f.is_empty());
    Ok(merges)
}

/// Whether the union of the charts `a` and `b` (disks, disjoint, labelled `la` and `lb` in
/// `label`) is a disk, as [`disk_check`] would find, in time linear in the smaller chart instead
/// of the union. Their intersection — the vertices used by faces of both, and the glued edges
/// between a face of each — lies on the boundary of each (a vertex inside `a` has all its faces
/// in `a`), a simple cycle since `a` is a disk, so it is a set of disjoint arcs and points, or
/// the whole cycle. By inclusion–exclusion `χ(a ∪ b) = χ(a) + χ(b) − χ(a ∩ b) = 2 − (V − E)` of
/// the intersection, so the union has χ = 1 exactly when the intersection is a single arc or a
/// single point. A single arc with at least one edge glues two disks along a boundary arc: a disk
/// (one component through the glued edge, one fan per vertex because the mesh's vertices are
/// manifold and the fans of `a` and `b` at an arc vertex are joined across an arc edge, one
/// boundary loop). A single point joins them at a pinch, and no shared edge means the union is
/// not connected through glued edges; neither is a disk, and any other intersection has χ ≠ 1.
/// So: a disk ⟺ at least one shared edge and `V − E = 1`. Debug builds check it against
/// [`disk_check`] on every merge try.
///
/// Returns the vertices of that arc (ascending) when the union is a disk, `None` otherwise.
pub(super) fn union_arc(
    mesh: &TriangleMesh,
    a: &[FaceId],
    b: &[FaceId],
    label: &[u32],
    la: u32,
    lb: u32,
) -> Option<Vec<VertexId>> {
    let (small, own, other) = if a.len() <= b.len() {
        (a, la, lb)
    } else {
        (b, lb, la)
    };
    let mut shared_edges = 0usize;
    // Vertices of the smaller chart's boundary half-edges: only they can be shared.
    let mut candidates: Vec<VertexId> = Vec::new();
    for &f in small {
        for h in mesh.face_halfedges(f) {
            let across = mesh.opposite(h).map(|o| label[o.face().index()]);
            if across == Some(own) {
                continue;
            }
            if across == Some(other) {
                shared_edges += 1;
            }
            candidates.push(mesh.from_vertex(h));
            candidates.push(mesh.to_vertex(h));
        }
    }
    if shared_edges == 0 {
        return None;
    }
    candidates.sort_unstable();
    candidates.dedup();
    candidates.retain(|&v| {
        mesh.outgoing_halfedges(v)
            .any(|g| label[g.face().index()] == other)
    });
    (candidates.len() == shared_edges + 1).then_some(candidates)
}

/// A map of the union `union` (ascending) of the chart `big` and the chart `small` (faces)
/// that keeps `big`'s map and flattens only the vertices of `small` not in `big`: the least
/// squares conformal extension (`lscm::solve_direct_complex` with every shared vertex pinned
/// at its UV in `big`'s map), if the union's map passes every test ([`find_defect`]: no flip,
/// no boundary crossing, no fold, the stretch and area bounds). `None` means "flatten the
/// union" (also when a face of the union has zero area). Like the warm start of split parts
/// (module doc), this is not the union's LSCM map but a valid map by the same tests, and its
/// cost is that of `small`, not of the union. Pure; called in parallel.
pub(super) fn extend_into(
    mesh: &TriangleMesh,
    union: &[FaceId],
    big: &(Vec<FaceId>, LocatedMap),
    small: &[FaceId],
    options: &ParameterizeOptions,
) -> Option<LocatedMap> {
    if union.iter().any(|&f| is_degenerate(mesh, f)) {
        return None;
    }
    let (bmap, bglobal) = &big.1;
    let mut big_uv: Vec<(VertexId, [f64; 2])> = bglobal
        .iter()
        .zip(&bmap.uv)
        .map(|(&v, &p)| (v, p))
        .collect();
    big_uv.sort_unstable_by_key(|e| e.0);
    let uv_in_big = |v: VertexId| {
        big_uv
            .binary_search_by_key(&v, |e| e.0)
            .ok()
            .map(|k| big_uv[k].1)
    };
    // The small chart alone, its shared vertices pinned.
    let (scm, sglobal) = chart_mesh(mesh, small);
    let stopo = scm.validate().ok()?;
    let pins: Vec<Pin> = sglobal
        .iter()
        .enumerate()
        .filter_map(|(l, &v)| {
            uv_in_big(v).map(|uv| Pin {
                vertex: l as u32,
                uv,
            })
        })
        .collect();
    let suv = lscm::solve_direct_complex(&scm, &stopo, &pins).ok()?;
    let mut small_uv: Vec<(VertexId, [f64; 2])> = sglobal.iter().copied().zip(suv).collect();
    small_uv.sort_unstable_by_key(|e| e.0);
    let (cm, global) = chart_mesh(mesh, union);
    let uv: Vec<[f64; 2]> = global
        .iter()
        .map(|&v| {
            uv_in_big(v).or_else(|| {
                small_uv
                    .binary_search_by_key(&v, |e| e.0)
                    .ok()
                    .map(|k| small_uv[k].1)
            })
        })
        .collect::<Option<_>>()?;
    if !uv.iter().all(|p| p[0].is_finite() && p[1].is_finite())
        || !flipped_faces(&cm, &uv).is_empty()
    {
        return None;
    }
    let topology = cm.validate().ok()?;
    let local_of = |p: u32| -> Option<u32> {
        let v = *bglobal.get(p as usize)?;
        global.iter().position(|&g| g == v).map(|l| l as u32)
    };
    let pins = [local_of(bmap.pins[0])?, local_of(bmap.pins[1])?];
    let map = ChartMap {
        conformal_energy: conformal_energy(&cm, &uv),
        uv,
        flipped_faces: Vec::new(),
        method_used: bmap.method_used,
        iterations: 0,
        pins,
        hlscm: None,
    };
    find_defect(union, &cm, &topology.boundary_loop, &map, options)
        .is_none()
        .then_some((map, global))
}

/// How differently the maps of two charts draw the boundary they share: the relative RMS
/// residual `sqrt(Σ |z·(a_k − ā) − (b_k − b̄)|² / Σ |b_k − b̄|²)` of the best similarity `z`
/// (least squares, complex `z`: rotation and scale) taking chart `a`'s UVs of the shared
/// vertices `arc` ([`union_arc`], ascending) onto chart `b`'s, both centred. 0 when they are
/// the same curve up to a similarity (the union of two developable pieces), about 1 when no
/// similarity relates them (e.g. one map draws the shared arc as a C and the other as a
/// reversed C). Returns 0 (no evidence) with fewer than 3 shared vertices or a degenerate
/// spread. Cost: linear in the two charts' vertex counts, no solve.
pub(super) fn shared_arc_misfit(a: &LocatedMap, b: &LocatedMap, arc: &[VertexId]) -> f64 {
    if arc.len() < 3 {
        return 0.0;
    }
    // The UVs of the arc's vertices in one chart's map, in `arc` order.
    let uvs_of = |(map, vertices): &LocatedMap| -> Option<Vec<[f64; 2]>> {
        let mut out = vec![[f64::NAN; 2]; arc.len()];
        for (l, v) in vertices.iter().enumerate() {
            if let Ok(k) = arc.binary_search(v) {
                out[k] = *map.uv.get(l)?;
            }
        }
        out.iter()
            .all(|p| p[0].is_finite() && p[1].is_finite())
            .then_some(out)
    };
    let (Some(pa), Some(pb)) = (uvs_of(a), uvs_of(b)) else {
        return 0.0;
    };
    similarity_misfit(&pa, &pb)
}

/// The relative RMS residual of the best similarity taking the points `pa` onto `pb` (same
/// length), as [`shared_arc_misfit`] defines it; 0 for a degenerate spread.
pub(super) fn similarity_misfit(pa: &[[f64; 2]], pb: &[[f64; 2]]) -> f64 {
    let centre = |p: &[[f64; 2]]| {
        let n = p.len() as f64;
        let s = p.iter().fold([0.0, 0.0], |c, q| [c[0] + q[0], c[1] + q[1]]);
        [s[0] / n, s[1] / n]
    };
    let (ca, cb) = (centre(pa), centre(pb));
    let (mut zr, mut zi, mut aa, mut bb) = (0.0, 0.0, 0.0, 0.0);
    for (p, q) in pa.iter().zip(pb) {
        let (x, y) = ([p[0] - ca[0], p[1] - ca[1]], [q[0] - cb[0], q[1] - cb[1]]);
        // Σ conj(x)·y and the two spreads.
        zr += x[0] * y[0] + x[1] * y[1];
        zi += x[0] * y[1] - x[1] * y[0];
        aa += x[0] * x[0] + x[1] * x[1];
        bb += y[0] * y[0] + y[1] * y[1];
    }
    if !(aa > 0.0 && bb > 0.0 && aa.is_finite() && bb.is_finite()) {
        return 0.0;
    }
    let (zr, zi) = (zr / aa, zi / aa);
    let mut residual = 0.0;
    for (p, q) in pa.iter().zip(pb) {
        let (x, y) = ([p[0] - ca[0], p[1] - ca[1]], [q[0] - cb[0], q[1] - cb[1]]);
        let (u, v) = (zr * x[0] - zi * x[1] - y[0], zi * x[0] + zr * x[1] - y[1]);
        residual += u * u + v * v;
    }
    let misfit = (residual / bb).sqrt();
    if misfit.is_finite() {
        misfit
    } else {
        0.0
    }
}

/// `merge_back` does not flatten a union whose two maps draw their shared boundary this
/// differently ([`shared_arc_misfit`] above it): such a union fails the tests anyway (on the
/// corpus every union above 0.7 failed, and the highest misfit of a success was 0.5). It is a
/// prediction, not a proof: a union above it that would pass is not merged (one more chart,
/// never an invalid map), for less flattening work.
pub(super) const MERGE_MAX_ARC_MISFIT: f64 = 0.7;

/// `merge_back` first tries `extend_into` when the smaller chart has at most 1 / this of the
/// larger one's faces. Off (2^40): the extension saves flattening work but leaves a slightly
/// higher global stretch than the exact union solve, which is kept.
pub(super) const EXTEND_RATIO: usize = 1 << 40;

/// Neighbours tried per chart and pass by `merge_back`. Trade-off: each try is one flattening
/// of the union. With 2, the chart count swung with small changes upstream (armadillo 29–42
/// charts over feature fractions 0.045–0.055 and border smoothing); with 3 it stays at 26–28,
/// for about 5–10% more time in the parameterize stage.
pub(super) const MERGE_TRIES: usize = 3;

#[cfg(test)]
mod misfit_tests {
    use super::{similarity_misfit, MERGE_MAX_ARC_MISFIT};

    /// Points on an arc of the unit circle, from `a0` to `a1` radians.
    fn arc(n: usize, a0: f64, a1: f64) -> Vec<[f64; 2]> {
        (0..n)
            .map(|k| {
                let a = a0 + (a1 - a0) * k as f64 / (n - 1) as f64;
                [a.cos(), a.sin()]
            })
            .collect()
    }

    /// A similarity image of the same points fits exactly; the same arc bent the other way
    /// (a C against a reversed C) does not fit any similarity, and lies above the merge bound.
    #[test]
    fn misfit_is_zero_for_a_similar_arc_and_large_for_a_reversed_bend() {
        let a = arc(40, 0.0, 3.0);
        let (s, c) = (0.7f64.sin(), 0.7f64.cos());
        let b: Vec<[f64; 2]> = a
            .iter()
            .map(|p| {
                let (x, y) = (2.5 * (c * p[0] - s * p[1]), 2.5 * (s * p[0] + c * p[1]));
                [x + 10.0, y - 3.0]
            })
            .collect();
        assert!(similarity_misfit(&a, &b) < 1e-12);
        // The mirror image of the arc, walked in the same order: it bends the other way.
        let mirrored: Vec<[f64; 2]> = a.iter().map(|p| [p[0], -p[1]]).collect();
        let m = similarity_misfit(&a, &mirrored);
        assert!(m > MERGE_MAX_ARC_MISFIT, "misfit {m}");
        assert!(
            m <= 1.0 + 1e-12,
            "the residual never exceeds the spread: {m}"
        );
        // A straight segment against a slightly bent one: small, below the bound.
        let straight: Vec<[f64; 2]> = (0..40).map(|k| [k as f64, 0.0]).collect();
        let bent: Vec<[f64; 2]> = (0..40)
            .map(|k| {
                let x = k as f64;
                [x, 0.002 * (x - 20.0) * (x - 20.0)]
            })
            .collect();
        let m = similarity_misfit(&straight, &bent);
        assert!(m > 0.0 && m < 0.2, "misfit {m}");
        // Degenerate spreads give no evidence.
        assert_eq!(similarity_misfit(&[[1.0, 1.0]; 5], &a[..5]), 0.0);
    }
}
