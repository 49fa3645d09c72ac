//! Warm start of split parts: a part of a split chart first tries the restriction of its
//! parent's map to its faces ([`restrict_map`]); when that passes every test of
//! [`super::defects`], the part keeps it and is not flattened.
//!
//! It is not the part's LSCM map (that is usually a little less stretched), but a valid map by
//! the same tests as a fresh one. Parts with zero-area faces are always flattened. It applies
//! mostly to overlap splits: a part of an over-stretched map is usually still over-stretched.
use super::defects::find_defect;
use super::degenerate::is_degenerate;
use super::{
    chart_mesh, conformal_energy, flipped_faces, ChartMap, LocatedMap, ParameterizeOptions,
};
use crate::mesh::{FaceId, TriangleMesh, VertexId};

/// The parent's map restricted to the part `faces` (ascending) of it, if that is a valid map
/// of the part (module doc, "warm start"): no zero-area face in the part, no flip, and
/// [`find_defect`] finds no defect (boundary overlap, fold, stretch or area bound). `None`
/// means "flatten the part". The restriction is not the part's LSCM map (that is usually a
/// little less stretched), but it passes the same tests as a fresh map. Pure; called in
/// parallel. Cost: O(k log k) for k faces, no solve.
pub(super) fn restrict_map(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    parent: &LocatedMap,
    options: &ParameterizeOptions,
) -> Option<LocatedMap> {
    if faces.iter().any(|&f| is_degenerate(mesh, f)) {
        return None;
    }
    let (map, global, cm) = restriction(mesh, faces, parent)?;
    if !map.flipped_faces.is_empty() {
        return None;
    }
    let topology = cm.validate().ok()?;
    find_defect(faces, &cm, &topology.boundary_loop, &map, options)
        .is_none()
        .then_some((map, global))
}

/// The parent's map restricted to the part `faces` (ascending) of it, with no test of the
/// result: the UV of every vertex of the part is its UV in `parent`, so every face keeps the
/// image it had (its flip or not, its stretch, its place among the parent's faces). The
/// map's `flipped_faces` are recomputed on the part. `None` when a vertex of `faces` is not in
/// `parent` (`faces` is not a part of it). For cuts made in UV space: a part of a valid map
/// overlaps nothing the parent did not. Cost: O(k log k) for k faces, no solve.
pub fn restricted_map(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    parent: &LocatedMap,
) -> Option<LocatedMap> {
    restriction(mesh, faces, parent).map(|(map, global, _)| (map, global))
}

/// [`restricted_map`] and the part's chart mesh.
fn restriction(
    mesh: &TriangleMesh,
    faces: &[FaceId],
    parent: &LocatedMap,
) -> Option<(ChartMap, Vec<VertexId>, super::ChartMesh)> {
    let (pmap, pglobal) = parent;
    let mut by_vertex: Vec<(VertexId, u32)> = pglobal
        .iter()
        .enumerate()
        .map(|(l, &v)| (v, l as u32))
        .collect();
    by_vertex.sort_unstable();
    let parent_local = |v: VertexId| {
        by_vertex
            .binary_search_by_key(&v, |&(g, _)| g)
            .ok()
            .map(|k| by_vertex[k].1)
    };
    let (cm, global) = chart_mesh(mesh, faces);
    let uv: Vec<[f64; 2]> = global
        .iter()
        .map(|&v| parent_local(v).and_then(|l| pmap.uv.get(l as usize).copied()))
        .collect::<Option<_>>()?;
    let local_of = |p: u32| -> Option<u32> {
        let v = *pglobal.get(p as usize)?;
        global.iter().position(|&g| g == v).map(|l| l as u32)
    };
    let pins = match (local_of(pmap.pins[0]), local_of(pmap.pins[1])) {
        (Some(a), Some(b)) => [a, b],
        _ => [0, (global.len() as u32).saturating_sub(1)],
    };
    let map = ChartMap {
        conformal_energy: conformal_energy(&cm, &uv),
        flipped_faces: flipped_faces(&cm, &uv),
        uv,
        method_used: pmap.method_used,
        iterations: 0,
        pins,
        hlscm: None,
    };
    Some((map, global, cm))
}
