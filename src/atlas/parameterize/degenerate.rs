//! Zero-area faces (collinear corners or a repeated vertex, `TriangleMesh::face_degeneracy`).
//!
//! LSCM cannot flatten them (their `1/√d_T` weight is infinite), yet every chart gets a map:
//! - a chart is flattened without its zero-area faces ([`flatten_around_degenerate`]), and
//!   every vertex only they use gets a UV from its face's two mapped corners (the point of their
//!   UV segment at the vertex's 3-D position projected on the 3-D segment) or else the UV of a
//!   mapped corner ([`extend_map`]); such a face maps to a (near-)degenerate UV triangle, is never
//!   listed as flipped and takes no part in the overlap and area tests;
//! - when the chart without them is not a disk, it is cut into disks first and each glued group
//!   of zero-area faces joins the first neighbouring part with which it is still a disk
//!   ([`split_off_degenerate`]);
//! - a chart made only of zero-area faces gets the line map ([`line_map`]).
//!
//! Units: UVs in model units. Pure functions, called in parallel.
use super::defects::{find_defect, ChartDefect};
use super::flatten::flatten_chart_with_topology;
use super::stretch::{descend_for_bound, StretchOptimization};
use super::{
    chart_mesh, conformal_energy, ChartMap, LocatedMap, ParameterizeError, ParameterizeMethod,
    ParameterizeOptions,
};
use crate::atlas::progress::{Stage, StageProgress};
use crate::atlas::segment::{disk_check, enforce_disks, SegmentStats};
use crate::mesh::{FaceId, TriangleMesh, VertexId};

/// What flattening one chart gave.
pub(super) enum Attempt {
    /// A map of the whole chart (in [`chart_mesh`] order of its ascending faces) and the first
    /// defect of its non-degenerate part, if any.
    Mapped {
        map: LocatedMap,
        defect: Option<ChartDefect>,
    },
    /// The chart without its zero-area faces is not a disk (a zero-area face inside it, or one
    /// joining two parts): it must be split first (`split_off_degenerate`).
    NotADiskWithoutDegenerate,
    /// The parameterizer failed for another reason (e.g. a failed factorization).
    Failed(ParameterizeError),
}

/// True when `f` has (numerically) zero area or repeats a vertex: LSCM's `1/√d_T` weight is
/// infinite there, so it is left out of the flattening (module doc, "zero-area faces").
pub(super) fn is_degenerate(mesh: &TriangleMesh, f: FaceId) -> bool {
    mesh.face_degeneracy(f).is_some()
}

/// Flattens the chart `faces` (ascending) without its zero-area faces, then gives the vertices
/// only those faces use UVs from the map (`extend_map`). Pure; called in parallel.
pub(super) fn flatten_around_degenerate(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    options: &ParameterizeOptions,
) -> Attempt {
    let mut dropped: Vec<bool> = faces.iter().map(|&f| is_degenerate(mesh, f)).collect();
    // Each retry drops one more face (the parameterizer's own zero-area test may disagree with
    // the mesh's by rounding), so this runs at most `faces.len() + 1` times.
    loop {
        let kept: Vec<FaceId> = faces
            .iter()
            .zip(&dropped)
            .filter(|(_, &d)| !d)
            .map(|(&f, _)| f)
            .collect();
        if kept.is_empty() {
            return Attempt::Mapped {
                map: line_map(mesh, faces),
                defect: None,
            };
        }
        if kept.len() < faces.len()
            && disk_check(mesh, &kept, &|f| kept.binary_search(&f).is_ok()).is_err()
        {
            return Attempt::NotADiskWithoutDegenerate;
        }
        let (cm, global) = chart_mesh(mesh, &kept);
        match flatten_chart_with_topology(
            &cm,
            &options.flatten,
            &mut StageProgress::ignored(Stage::Parameterize),
        ) {
            Ok((map, topology)) => {
                let mut map = map;
                let mut defect = find_defect(&kept, &cm, &topology.boundary_loop, &map, options);
                // The stretch bound holds for the map the stretch optimisation makes: test that
                // one (the descended map is kept even when it still fails, so that the split's
                // parts start from it).
                if matches!(defect, Some(ChartDefect::Stretch { .. }))
                    && options.stretch_optimization != StretchOptimization::None
                {
                    if let Some(uv) = descend_for_bound(&cm, &map.uv) {
                        map.conformal_energy = conformal_energy(&cm, &uv);
                        map.uv = uv;
                        defect = find_defect(&kept, &cm, &topology.boundary_loop, &map, options);
                    }
                }
                let map = if kept.len() == faces.len() {
                    (map, global)
                } else {
                    extend_map(mesh, faces, &dropped, map, &global)
                };
                return Attempt::Mapped { map, defect };
            }
            Err(ParameterizeError::DegenerateTriangle { triangle }) => {
                let f = kept[triangle as usize];
                let i = faces.binary_search(&f).unwrap_or(0);
                if dropped[i] {
                    return Attempt::Failed(ParameterizeError::DegenerateTriangle { triangle });
                }
                dropped[i] = true;
            }
            Err(e) => return Attempt::Failed(e),
        }
    }
}

/// The map of the whole chart `faces` from the map `sub` of its non-dropped faces (local
/// vertices `sub_global`): UVs are copied by global vertex; a vertex used only by dropped faces
/// gets, from a dropped face with two mapped corners `a`, `b`, the UV on the line through theirs
/// at its own 3-D position projected on `ab` (a zero-area face has collinear corners, so its UV
/// triangle is degenerate too), or else the UV of a mapped corner. `flipped_faces` and `pins`
/// are renumbered into the whole chart; dropped faces are never listed as flipped (they have no
/// orientation).
pub(super) fn extend_map(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    dropped: &[bool],
    sub: ChartMap,
    sub_global: &[VertexId],
) -> LocatedMap {
    let (cm, global) = chart_mesh(mesh, faces);
    let mut by_vertex: Vec<(VertexId, u32)> = global
        .iter()
        .enumerate()
        .map(|(l, &v)| (v, l as u32))
        .collect();
    by_vertex.sort_unstable();
    let local_of = |v: VertexId| {
        by_vertex
            .binary_search_by_key(&v, |&(g, _)| g)
            .map(|k| by_vertex[k].1)
            .unwrap_or(0)
    };
    let mut uv: Vec<Option<[f64; 2]>> = vec![None; global.len()];
    for (s, &v) in sub_global.iter().enumerate() {
        uv[local_of(v) as usize] = Some(sub.uv[s]);
    }
    let dropped_tris: Vec<usize> = (0..faces.len()).filter(|&k| dropped[k]).collect();
    place_on_zero_area_faces(&cm, &dropped_tris, &mut uv);
    let uv: Vec<[f64; 2]> = uv.into_iter().map(Option::unwrap_or_default).collect();
    let kept_index: Vec<usize> = (0..faces.len()).filter(|&k| !dropped[k]).collect();
    let flipped_faces = sub
        .flipped_faces
        .iter()
        .map(|&t| kept_index[t as usize] as u32)
        .collect();
    let pins = sub.pins.map(|p| local_of(sub_global[p as usize]));
    (
        ChartMap {
            uv,
            conformal_energy: sub.conformal_energy,
            flipped_faces,
            method_used: sub.method_used,
            iterations: sub.iterations,
            pins,
            hlscm: sub.hlscm,
        },
        global,
    )
}

/// Gives a UV to every vertex of `uv` still `None` from the zero-area faces `dropped_tris` of
/// `cm` (extend_map's rule): from a face with two placed corners `a`, `b`, the point of their UV
/// segment at the vertex's 3-D position projected on `ab`; when no face has two placed corners,
/// the UV of a placed corner. Vertices no zero-area face reaches stay `None`.
pub(super) fn place_on_zero_area_faces(
    cm: &super::ChartMesh,
    dropped_tris: &[usize],
    uv: &mut [Option<[f64; 2]>],
) {
    // Each round maps at least one more vertex (or stops), so at most V rounds; the chart is
    // connected, so every vertex is reached. Interpolation is preferred; one copy is made only
    // when no interpolation is possible.
    loop {
        let mut progress = false;
        for &k in dropped_tris {
            let t = cm.triangles[k];
            let known: Vec<u32> = t
                .iter()
                .copied()
                .filter(|&i| uv[i as usize].is_some())
                .collect();
            if known.len() != 2 {
                continue;
            }
            let Some(&p) = t.iter().find(|&&i| uv[i as usize].is_none()) else {
                continue;
            };
            let (ua, ub) = (
                uv[known[0] as usize].unwrap_or_default(),
                uv[known[1] as usize].unwrap_or_default(),
            );
            let [pa, pb, pp] = [known[0], known[1], p].map(|i| cm.positions_m[i as usize]);
            let ab = [0, 1, 2].map(|c| pb[c] - pa[c]);
            let ap = [0, 1, 2].map(|c| pp[c] - pa[c]);
            let len2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
            let s = if len2 > 0.0 {
                (ab[0] * ap[0] + ab[1] * ap[1] + ab[2] * ap[2]) / len2
            } else {
                0.0
            };
            uv[p as usize] = Some([ua[0] + s * (ub[0] - ua[0]), ua[1] + s * (ub[1] - ua[1])]);
            progress = true;
        }
        if progress {
            continue;
        }
        'copy: for &k in dropped_tris {
            let t = cm.triangles[k];
            if let Some(&a) = t.iter().find(|&&i| uv[i as usize].is_some()) {
                if let Some(&p) = t.iter().find(|&&i| uv[i as usize].is_none()) {
                    uv[p as usize] = uv[a as usize];
                    progress = true;
                    break 'copy;
                }
            }
        }
        if !progress {
            break;
        }
    }
}

/// The map of a chart whose faces all have zero area (or, as a last resort, of a chart the
/// parameterizer rejected and that cannot be split): every vertex is projected on the line
/// through the chart's first vertex and its farthest vertex, `u` = signed distance in model
/// units along it, `v = 0`. Every UV triangle is degenerate, as the 3-D faces are; no face is
/// listed as flipped. `method_used` is `Direct`, `iterations` 0, `conformal_energy` 0.
pub(super) fn line_map(mesh: &TriangleMesh, faces: &[FaceId]) -> LocatedMap {
    let (cm, global) = chart_mesh(mesh, faces);
    let o = cm.positions_m[0];
    let d = |p: [f64; 3]| [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
    let mut far = (0usize, 0.0f64);
    for (i, &p) in cm.positions_m.iter().enumerate() {
        let v = d(p);
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if n > far.1 {
            far = (i, n);
        }
    }
    let dir = if far.1 > 0.0 {
        d(cm.positions_m[far.0]).map(|c| c / far.1)
    } else {
        [1.0, 0.0, 0.0]
    };
    let uv = cm
        .positions_m
        .iter()
        .map(|&p| {
            let v = d(p);
            [v[0] * dir[0] + v[1] * dir[1] + v[2] * dir[2], 0.0]
        })
        .collect();
    (
        ChartMap {
            uv,
            conformal_energy: 0.0,
            flipped_faces: Vec::new(),
            method_used: ParameterizeMethod::Direct,
            iterations: 0,
            pins: [0, far.0 as u32],
            hlscm: None,
        },
        global,
    )
}

/// Splits a chart whose non-degenerate faces do not form a disk: those faces are cut into disks
/// (the disk guarantee), the zero-area faces into glued disk components of their own, and each
/// such component joins the first neighbouring part (ascending label) with which it is still a
/// disk. Every part's non-degenerate faces are then a disk (or empty), so each part flattens.
pub(super) fn split_off_degenerate(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    stats: &mut SegmentStats,
) -> Vec<Vec<FaceId>> {
    let (bad, good): (Vec<FaceId>, Vec<FaceId>) =
        faces.iter().partition(|&&f| is_degenerate(mesh, f));
    let mut parts = enforce_disks(mesh, vec![good], stats);
    // The part holding each face of the chart (`faces` is ascending), `u32::MAX` for none yet.
    let mut part_of = vec![u32::MAX; faces.len()];
    let slot = |f: FaceId| faces.binary_search(&f).ok();
    for (i, p) in parts.iter().enumerate() {
        for &f in p {
            if let Some(k) = slot(f) {
                part_of[k] = i as u32;
            }
        }
    }
    let good_parts = parts.len() as u32;
    for d in enforce_disks(mesh, vec![bad], stats) {
        let mut nbrs: Vec<u32> = d
            .iter()
            .flat_map(|&f| mesh.face_neighbors(f))
            .flatten()
            .filter_map(slot)
            .map(|k| part_of[k])
            .filter(|&l| l < good_parts)
            .collect();
        nbrs.sort_unstable();
        nbrs.dedup();
        let mut joined = false;
        for l in nbrs {
            let i = l as usize;
            let mut union = parts[i].clone();
            union.extend_from_slice(&d);
            union.sort_unstable();
            let inside = |f: FaceId| union.binary_search(&f).is_ok();
            if disk_check(mesh, &union, &inside).is_ok() {
                for &f in &d {
                    if let Some(k) = slot(f) {
                        part_of[k] = l;
                    }
                }
                parts[i] = union;
                joined = true;
                break;
            }
        }
        if !joined {
            parts.push(d);
        }
    }
    parts
}
