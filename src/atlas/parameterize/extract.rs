//! A chart of a mesh (a set of faces) as the chart-local indexed mesh the parameterizer
//! flattens ([`chart_mesh`]), with the map from local to global vertex ids.
use super::ChartMesh;
use crate::mesh::{FaceId, TriangleMesh, VertexId};

/// The chart `faces` as a chart-local indexed mesh for the parameterizer, and the map from local
/// to global vertex ids. Local vertices are numbered in order of first use along `faces`;
/// triangles keep `faces` order and corner order (orientation is preserved).
pub fn chart_mesh(mesh: &TriangleMesh, faces: &[FaceId]) -> (ChartMesh, Vec<VertexId>) {
    // A chart with at least 1/16 of the mesh's vertex count in faces: number its vertices in
    // one pass through a per-mesh array (zeroed lazily by the allocator, so its cost is about
    // the chart's, not the mesh's). The same numbering as the sort below.
    if faces.len().saturating_mul(16) >= mesh.num_vertices() {
        // `1 + local index`, 0 for not yet numbered.
        let mut local_plus_one = vec![0u32; mesh.num_vertices()];
        let mut global: Vec<VertexId> = Vec::new();
        let triangles = faces
            .iter()
            .map(|&f| {
                mesh.face_vertices(f).map(|v| {
                    let slot = &mut local_plus_one[v.index()];
                    if *slot == 0 {
                        global.push(v);
                        *slot = global.len() as u32;
                    }
                    *slot - 1
                })
            })
            .collect();
        let positions_m = global.iter().map(|&v| mesh.position(v)).collect();
        return (
            ChartMesh {
                positions_m,
                triangles,
            },
            global,
        );
    }
    // Local numbering by first use without a tree or a per-mesh array: sort the corners by
    // vertex (then corner), so each vertex's first corner is the first of its run; number the
    // vertices in the order of those first corners. O(k log k).
    let mut corners: Vec<(VertexId, u32)> = Vec::with_capacity(3 * faces.len());
    for (k, &f) in faces.iter().enumerate() {
        for (c, v) in mesh.face_vertices(f).into_iter().enumerate() {
            corners.push((v, (3 * k + c) as u32));
        }
    }
    corners.sort_unstable();
    // (first corner, vertex) per distinct vertex, then by first corner.
    let mut firsts: Vec<(u32, VertexId)> = Vec::new();
    for (i, &(v, c)) in corners.iter().enumerate() {
        if i == 0 || corners[i - 1].0 != v {
            firsts.push((c, v));
        }
    }
    firsts.sort_unstable();
    let global: Vec<VertexId> = firsts.iter().map(|&(_, v)| v).collect();
    let mut local_of_first: Vec<(VertexId, u32)> = firsts
        .iter()
        .enumerate()
        .map(|(l, &(_, v))| (v, l as u32))
        .collect();
    local_of_first.sort_unstable();
    let mut corner_local = vec![0u32; 3 * faces.len()];
    let mut run = 0usize;
    for (i, &(v, c)) in corners.iter().enumerate() {
        if i > 0 && corners[i - 1].0 != v {
            run += 1;
        }
        corner_local[c as usize] = local_of_first[run].1;
    }
    let triangles = (0..faces.len())
        .map(|k| [0, 1, 2].map(|c| corner_local[3 * k + c]))
        .collect();
    let positions_m = global.iter().map(|&v| mesh.position(v)).collect();
    (
        ChartMesh {
            positions_m,
            triangles,
        },
        global,
    )
}
