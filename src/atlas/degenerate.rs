//! UVs for the charts that are not packed because all their faces are degenerate.
//!
//! A chart made only of faces with zero area or a repeated vertex covers nothing in 3-D, so it
//! must cover nothing in UV: its corners take the UV (and page) of a vertex of a packed chart
//! at the bit-identical position in the same glTF mesh (weld group), or the page origin when
//! there is none (a vertex's position, which is its welded group's when the weld joined
//! near-coincident copies: the face then shares its UV edges with the packed faces around it).
//! Its UV image is then a point or a segment: zero UV area, never a flip, never an overlap.
//! Deterministic (sorted keys, ties to the lowest chart).

use crate::mesh::{TriangleMesh, VertexId};

/// UVs for the corners of degenerate charts (see [`generate`](super::generate)). Each
/// degenerate face follows one packed chart: the lowest chart with a vertex at the position of
/// its first matched corner; its other corners take that chart's vertex at their position when
/// it has one, else the first corner's UV. A face with no match at all collapses to `[0, 0]` on
/// page 0.
pub(super) fn place_degenerate(
    mesh: &TriangleMesh,
    charts: &[Vec<crate::mesh::FaceId>],
    degenerate: &[bool],
    corner_uvs: &mut [[[f32; 2]; 3]],
    face_page: &mut [u32],
    chart_page: &mut [u32],
) {
    if !degenerate.iter().any(|&d| d) {
        return;
    }
    type Key = (u32, [u64; 3]);
    let key = |v: VertexId| -> Key {
        let p = mesh
            .position(v)
            .map(|x| if x == 0.0 { 0 } else { x.to_bits() });
        (mesh.vertex_weld_group(v), p)
    };
    // (position key, chart) → (page, uv), one entry per vertex of each packed chart.
    let mut known: Vec<(Key, u32, u32, [f32; 2])> = Vec::new();
    for (i, faces) in charts.iter().enumerate() {
        if degenerate[i] {
            continue;
        }
        for &f in faces {
            for (k, v) in mesh.face_vertices(f).into_iter().enumerate() {
                known.push((
                    key(v),
                    i as u32,
                    face_page[f.index()],
                    corner_uvs[f.index()][k],
                ));
            }
        }
    }
    known.sort_by_key(|a| (a.0, a.1));
    known.dedup_by(|a, b| (a.0, a.1) == (b.0, b.1));
    // The lowest chart at `k`, or the entry of chart `c` at `k`.
    let first_at = |k: &Key| {
        let j = known.partition_point(|e| e.0 < *k);
        known.get(j).filter(|e| e.0 == *k)
    };
    let in_chart = |k: &Key, c: u32| {
        known
            .binary_search_by(|e| (e.0, e.1).cmp(&(*k, c)))
            .ok()
            .map(|j| &known[j])
    };
    for (i, faces) in charts.iter().enumerate() {
        if !degenerate[i] {
            continue;
        }
        let mut page = None;
        for &f in faces {
            let keys = mesh.face_vertices(f).map(key);
            let Some(&(_, chart, p, uv0)) = keys.iter().find_map(first_at) else {
                corner_uvs[f.index()] = [[0.0; 2]; 3];
                face_page[f.index()] = 0;
                continue;
            };
            corner_uvs[f.index()] = keys.map(|k| in_chart(&k, chart).map_or(uv0, |e| e.3));
            face_page[f.index()] = p;
            page.get_or_insert(p);
        }
        chart_page[i] = page.unwrap_or(0);
    }
}
