//! The raw input to mesh building: a triangle soup as it comes out of a file.

/// A triangle soup, before welding and validation.
///
/// Invariant expected by `TriangleMesh::build` (checked there, never assumed):
/// `weld_group.len() == positions_m.len()` and every index in `triangles` is `< positions_m.len()`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeshInput {
    /// Vertex positions in model units. One entry per source vertex (before welding).
    pub positions_m: Vec<[f64; 3]>,
    /// Triangles as indices into `positions_m`, in the source's corner order. Face `i` of the
    /// built mesh is triangle `i` here: the order is never changed, so results map back 1:1.
    pub triangles: Vec<[u32; 3]>,
    /// Welding scope per source vertex: two vertices are welded only if their groups are equal
    /// AND their positions are bit-identical (after `-0.0 == 0.0`), or they end an edge of a
    /// zero-area face at most `NEAR_WELD_RELATIVE` of its longest and of the faces of area
    /// around them, and joining them collapses no face of area (the weld rule of
    /// [`crate::mesh`]). `gltf_io` uses the glTF
    /// mesh index, because different meshes live in different local spaces.
    pub weld_group: Vec<u32>,
}

impl MeshInput {
    /// A soup whose vertices all share weld group 0 (one mesh, one local space).
    pub fn single_group(positions_m: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>) -> Self {
        let weld_group = vec![0; positions_m.len()];
        Self {
            positions_m,
            triangles,
            weld_group,
        }
    }
}
