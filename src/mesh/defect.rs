//! What can be wrong with a triangle soup: fatal build errors and repaired defects.
//!
//! Purpose: every problem names its elements (face ids, vertex ids, source-vertex indices) and
//! says how to fix it, so that `texatlas inspect`, the HTTP error body and the quality report can
//! point at the exact triangle.
//!
//! Invariants:
//! - [`MeshBuildError`] is returned only for inputs that cannot become a mesh at all. Its element
//!   lists are capped at [`MAX_LISTED`] entries plus a total count, so a hostile input cannot turn
//!   into a huge error.
//! - [`MeshDefect`]s are warnings about problems the build repaired (see the repair policy in
//!   [`crate::mesh`]). Their total size is bounded by the input size.
//! - `code()` strings are stable API (snake_case); they appear in HTTP bodies and reports.
//!
//! Units: none (ids and indices only).
use std::fmt;

use super::ids::{FaceId, VertexId};

/// At most this many offending elements are listed in one [`MeshBuildError`].
pub const MAX_LISTED: usize = 16;

/// A capped list of offending elements plus the total number found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Offenders<T> {
    /// The first offenders in input order, at most [`MAX_LISTED`].
    pub first: Vec<T>,
    /// How many offenders there are in total (`>= first.len()`).
    pub total: usize,
}

impl<T> Offenders<T> {
    pub(crate) fn new() -> Self {
        Self {
            first: Vec::new(),
            total: 0,
        }
    }
    pub(crate) fn push(&mut self, item: T) {
        if self.first.len() < MAX_LISTED {
            self.first.push(item);
        }
        self.total += 1;
    }
    /// True when nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.total == 0
    }
}

impl<T: fmt::Display> fmt::Display for Offenders<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, item) in self.first.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            write!(f, "{item}")?;
        }
        if self.total > self.first.len() {
            write!(f, " and {} more", self.total - self.first.len())?;
        }
        Ok(())
    }
}

/// A triangle index that points past the end of the position list.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BadIndex {
    /// The triangle (input order) holding the index.
    pub face: FaceId,
    /// The corner slot (0, 1, 2) within that triangle.
    pub slot: u8,
    /// The out-of-range index value.
    pub index: u32,
}

impl fmt::Display for BadIndex {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} corner {} = {}", self.face, self.slot, self.index)
    }
}

/// An input that cannot become a mesh. Nothing is built; the message says how to fix the input.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MeshBuildError {
    /// There is no triangle at all.
    #[error("the mesh has zero triangles; give at least one triangle (points and lines cannot be unwrapped)")]
    NoTriangles,
    /// `weld_group` does not have one entry per position.
    #[error(
        "{positions} positions but {weld_groups} weld-group entries; give exactly one weld group per position"
    )]
    WeldGroupLengthMismatch {
        /// `positions_m.len()`.
        positions: usize,
        /// `weld_group.len()`.
        weld_groups: usize,
    },
    /// The mesh is too large for 32-bit ids (3 x triangles half-edges, or positions, exceed `u32`).
    #[error(
        "{triangles} triangles / {positions} positions exceed the 32-bit id range (at most {max_triangles} triangles); split the asset into smaller meshes"
    )]
    TooLarge {
        /// Number of input triangles.
        triangles: usize,
        /// Number of input positions.
        positions: usize,
        /// The largest supported triangle count.
        max_triangles: usize,
    },
    /// Triangle indices point past the end of the position list.
    #[error(
        "{} triangle indices are out of range (there are {num_positions} positions): {offenders}; fix the index buffer so every index is below the position count",
        offenders.total
    )]
    IndexOutOfRange {
        /// The offending indices.
        offenders: Offenders<BadIndex>,
        /// `positions_m.len()`.
        num_positions: usize,
    },
    /// Positions used by triangles are NaN or infinite.
    #[error(
        "{} vertices used by triangles have non-finite coordinates (NaN or infinity), source vertices {source_vertices}; fix or remove them in the modelling tool",
        source_vertices.total
    )]
    NonFiniteCoordinate {
        /// Source-vertex indices (into `positions_m`) with a NaN or infinite coordinate.
        source_vertices: Offenders<u32>,
    },
}

impl MeshBuildError {
    /// A stable snake_case code for this error.
    pub fn code(&self) -> &'static str {
        match self {
            MeshBuildError::NoTriangles => "zero_triangles",
            MeshBuildError::WeldGroupLengthMismatch { .. } => "weld_group_length_mismatch",
            MeshBuildError::TooLarge { .. } => "mesh_too_large",
            MeshBuildError::IndexOutOfRange { .. } => "index_out_of_range",
            MeshBuildError::NonFiniteCoordinate { .. } => "non_finite_coordinate",
        }
    }
}

/// Why a triangle is degenerate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DegenerateKind {
    /// Three distinct vertices, but (numerically) collinear: zero area. The face stays glued to
    /// its neighbours; it has no normal.
    ZeroArea,
    /// Two or three corners weld to the same vertex. Such a face cannot be part of a half-edge
    /// structure: it gets three vertex copies of its own and is isolated.
    RepeatedVertex,
}

impl DegenerateKind {
    /// A stable snake_case name.
    pub fn as_str(self) -> &'static str {
        match self {
            DegenerateKind::ZeroArea => "zero_area",
            DegenerateKind::RepeatedVertex => "repeated_vertex",
        }
    }
}

/// A problem found and repaired while building a mesh. Each variant names its elements.
///
/// Vertex ids are ids of the built mesh; `source_vertices` are indices into
/// [`crate::mesh::MeshInput::positions_m`] (for a welded vertex: the lowest source index welded
/// into it), so a caller can point back into the original vertex buffer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MeshDefect {
    /// A triangle with zero area or a repeated vertex. Kept (faces are never dropped); later
    /// stages give it a valid UV.
    DegenerateTriangle {
        /// The triangle.
        face: FaceId,
        /// Zero area or repeated vertex.
        kind: DegenerateKind,
    },
    /// An edge shared by more than two triangles. Repair: the faces are paired greedily in face
    /// order (the lowest remaining face with the lowest remaining face running the other way
    /// along the edge); each pair stays glued, forming separate sheets that meet at the edge
    /// (their end points are then split as non-manifold vertices). Faces without a partner are
    /// cut off: the edge becomes a boundary for them.
    NonManifoldEdge {
        /// Every face on the edge, ascending.
        faces: Vec<FaceId>,
        /// The consistently oriented pairs that stay glued, each ascending, in pairing order
        /// (empty when all faces run the same way).
        glued: Vec<[FaceId; 2]>,
        /// The edge's end points as source-vertex indices.
        source_vertices: [u32; 2],
    },
    /// Two triangles share an edge but run along it in the same direction (one of them is
    /// flipped relative to the other). Repair: the edge is cut (faces are never flipped, because
    /// the corner order is the output's).
    InconsistentOrientation {
        /// The two faces, ascending.
        faces: [FaceId; 2],
        /// The edge's end points as source-vertex indices.
        source_vertices: [u32; 2],
    },
    /// Several fans of triangles ("sheets") meet at one welded vertex only, e.g. two cones tip to
    /// tip, or what is left of a non-manifold edge after it was cut. Repair: each sheet gets its
    /// own copy of the vertex.
    NonManifoldVertex {
        /// The source vertex (lowest source index of the welded vertex).
        source_vertex: u32,
        /// The vertex copies in the built mesh, one per sheet, ascending.
        vertices: Vec<VertexId>,
    },
    /// Positions that no triangle uses. They do not become vertices of the mesh.
    UnreferencedVertices {
        /// The unused source-vertex indices (capped list + total).
        source_vertices: Offenders<u32>,
    },
}

impl MeshDefect {
    /// A stable snake_case code for this defect.
    pub fn code(&self) -> &'static str {
        match self {
            MeshDefect::DegenerateTriangle {
                kind: DegenerateKind::ZeroArea,
                ..
            } => "degenerate_triangle_zero_area",
            MeshDefect::DegenerateTriangle {
                kind: DegenerateKind::RepeatedVertex,
                ..
            } => "degenerate_triangle_repeated_vertex",
            MeshDefect::NonManifoldEdge { .. } => "non_manifold_edge",
            MeshDefect::InconsistentOrientation { .. } => "inconsistent_orientation",
            MeshDefect::NonManifoldVertex { .. } => "non_manifold_vertex",
            MeshDefect::UnreferencedVertices { .. } => "unreferenced_vertices",
        }
    }

    /// The faces this defect names (empty for vertex-only defects).
    pub fn faces(&self) -> Vec<FaceId> {
        match self {
            MeshDefect::DegenerateTriangle { face, .. } => vec![*face],
            MeshDefect::NonManifoldEdge { faces, .. } => faces.clone(),
            MeshDefect::InconsistentOrientation { faces, .. } => faces.to_vec(),
            MeshDefect::NonManifoldVertex { .. } | MeshDefect::UnreferencedVertices { .. } => {
                Vec::new()
            }
        }
    }
}

fn list<T: fmt::Display>(items: &[T]) -> String {
    items
        .iter()
        .map(|i| i.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

impl fmt::Display for MeshDefect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MeshDefect::DegenerateTriangle {
                face,
                kind: DegenerateKind::ZeroArea,
            } => write!(
                f,
                "triangle {face} has zero area (its corners are collinear); it is kept and gets a valid UV, \
                 remove it or move a corner in the modelling tool to get rid of this warning"
            ),
            MeshDefect::DegenerateTriangle {
                face,
                kind: DegenerateKind::RepeatedVertex,
            } => write!(
                f,
                "triangle {face} uses the same vertex position twice; it is kept as an isolated triangle, \
                 remove it (e.g. merge-by-distance cleanup) in the modelling tool"
            ),
            MeshDefect::NonManifoldEdge {
                faces,
                glued,
                source_vertices: [a, b],
            } => {
                write!(
                    f,
                    "edge between source vertices {a} and {b} is shared by {} triangles ({}); ",
                    faces.len(),
                    list(faces)
                )?;
                if glued.is_empty() {
                    write!(f, "no two of them run in opposite directions, all are cut apart")?;
                } else {
                    let pairs: Vec<String> = glued.iter().map(|[x, y]| format!("{x}+{y}")).collect();
                    write!(f, "pairs {} stay joined as separate sheets", pairs.join(", "))?;
                    if 2 * glued.len() < faces.len() {
                        write!(f, ", the others are cut off")?;
                    }
                }
                write!(f, "; make every edge border at most two triangles")
            }
            MeshDefect::InconsistentOrientation {
                faces: [x, y],
                source_vertices: [a, b],
            } => write!(
                f,
                "triangles {x} and {y} share the edge between source vertices {a} and {b} but face opposite ways; \
                 the edge is cut into a seam, recalculate normals / make orientation consistent in the modelling tool"
            ),
            MeshDefect::NonManifoldVertex {
                source_vertex,
                vertices,
            } => write!(
                f,
                "{} separate sheets of triangles meet only at source vertex {source_vertex}; it is split into \
                 vertices {}, split or merge the sheets in the modelling tool",
                vertices.len(),
                list(vertices)
            ),
            MeshDefect::UnreferencedVertices { source_vertices } => write!(
                f,
                "{} vertices are used by no triangle (source vertices {source_vertices}); they are ignored, \
                 remove loose vertices in the modelling tool",
                source_vertices.total
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offenders_cap_the_list_but_count_everything() {
        let mut o = Offenders::new();
        for i in 0..100u32 {
            o.push(i);
        }
        assert_eq!(o.first.len(), MAX_LISTED);
        assert_eq!(o.total, 100);
        assert!(o.to_string().ends_with(" and 84 more"));
        assert!(!o.is_empty());
    }

    #[test]
    fn codes_are_stable_snake_case() {
        let d = MeshDefect::NonManifoldVertex {
            source_vertex: 4,
            vertices: vec![VertexId(4), VertexId(9)],
        };
        assert_eq!(d.code(), "non_manifold_vertex");
        assert!(d.faces().is_empty());
        let text = d.to_string();
        assert!(text.contains("source vertex 4"), "{text}");
        assert!(text.contains("v4, v9"), "{text}");
        assert_eq!(MeshBuildError::NoTriangles.code(), "zero_triangles");
        assert!(MeshBuildError::NoTriangles
            .to_string()
            .contains("at least one triangle"));
        assert_eq!(DegenerateKind::ZeroArea.as_str(), "zero_area");
    }
}
