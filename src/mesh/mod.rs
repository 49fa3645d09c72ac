//! The validated triangle mesh.
//!
//! Purpose: turn a triangle soup ([`MeshInput`]: positions + index triples, as decoded from a
//! file) into a [`TriangleMesh`] with welded vertices, half-edge connectivity, typed ids and
//! per-element data, reporting every defect ([`MeshDefect`]) by the elements it concerns.
//! Everything downstream (segmentation, parameterization, packing, the quality report) works on
//! a `TriangleMesh`, and the only way to get one is [`TriangleMesh::build`].
//!
//! # Weld rule
//! Corners are welded by *position only*, never by normal or UV, to recover the real surface
//! topology from a file whose vertices are split at normal and UV seams: two source vertices
//! become one vertex when their coordinates are bit-identical (`-0.0` counts as `0.0`) and their
//! `weld_group` is equal. No distance tolerance in general: nearly coincident vertices stay apart,
//! as an asset may model a crack or a gap that thin on purpose. One exception: the two ends of
//! an edge of a zero-area face (three distinct, collinear vertices) that is at most
//! [`NEAR_WELD_RELATIVE`] (1e-9) of the face's longest edge are one vertex too (same
//! `weld_group`) when that edge is also at most [`NEAR_WELD_RELATIVE`] of the shortest edge
//! of every face of area at either end (the local scale: a needle to one stray vertex far
//! away makes a real edge of the surface short relative to the needle), joined transitively,
//! unless the join would put two corners of a face of area into one vertex (it would collapse
//! the face where the file gives it area, also through a chain of joins). The zero-area
//! face the rule is for is a slit between coincident copies of a vertex whose coordinates differ by rounding (the poles of
//! a UV sphere computed as `sin(π) ≈ 1.2e-16`); without the join the faces around the copies
//! meet only through the slits, their chart flattens each copy apart, and the written atlas
//! splits there into pieces that keep no padding between them. The asset's positions are never
//! changed: only the connectivity the pipeline works on. Every vertex of a joined group, the
//! copies in isolated faces too, sits at the group's position (its lowest source's), and each
//! corner keeps its own ([`TriangleMesh::corner_position`]), by which the report keys corners as
//! the evaluator does.
//!
//! # Repair policy
//! Fatal (a [`MeshBuildError`], nothing built): zero triangles, `weld_group` length mismatch,
//! indices out of range, NaN/infinite coordinates on a vertex used by a triangle, more than
//! [`MAX_TRIANGLES`] triangles.
//!
//! Repaired (a [`MeshDefect`] in [`BuiltMesh::defects`]; **nothing is silently dropped, no face is
//! removed, reordered or flipped**: face `i` is input triangle `i` with its corner order):
//! - **Non-manifold edge** (more than two faces on one edge): the faces are paired greedily in
//!   face order, the lowest remaining face with the lowest remaining face running the other way
//!   along the edge. Each pair stays glued, so e.g. two closed cubes sharing an edge stay two
//!   closed cubes; a face left without a partner (a fin) is cut off, i.e. the edge is a boundary
//!   for it.
//! - **Inconsistent orientation** (two faces running the same way along a shared edge): the edge
//!   is cut, both sides become boundary. Faces are never flipped, because the corner order is the
//!   output's and a flip would change the asset's shading.
//! - **Non-manifold vertex** (several fans of faces — "sheets" — meeting at one welded vertex,
//!   including the fans left over after an edge cut): each sheet gets its own copy of the vertex
//!   (same position, same source vertex), so every vertex has one fan.
//! - **Degenerate triangles**: a zero-area face (three distinct but collinear vertices) stays in
//!   the connectivity, without a normal. A face with a repeated vertex (same source index, or
//!   positions that weld) cannot be in a half-edge structure: it gets three vertex copies of its
//!   own, isolated from its neighbours. Both kinds are reported; later stages give them a valid UV.
//! - **Unreferenced vertices** (positions no triangle uses) are reported and do not become vertices.
//!
//! After repair the mesh is an oriented 2-manifold with boundary: every edge has one or two faces,
//! glued faces run in opposite directions, every vertex has exactly one fan, every face has three
//! distinct vertices ([`TriangleMesh::check_invariants`] checks all of this, and debug builds
//! assert it after every build).
//!
//! # Code map
//! - `input.rs`: [`MeshInput`], the soup.
//! - `ids.rs`: [`VertexId`], [`FaceId`], [`HalfedgeId`], [`CornerId`], [`ComponentId`], and
//!   [`IdVec`] per-element data ([`FaceData`], [`VertexData`], [`CornerData`]).
//! - `build.rs`: validation, weld, gluing, repair ([`TriangleMesh::build`]).
//! - `topology.rs`: the half-edge structure and its navigation, boundary loops, invariants.
//! - `geometry.rs`: positions, areas, normals, corner and dihedral angles, bounding box.
//! - `components.rs`: connected components, Euler characteristic, genus.
//! - `defect.rs`: [`MeshBuildError`], [`MeshDefect`].
//! - `fixtures.rs`: generated test meshes for every category (test data, used across the crate).
//!
//! Units: positions are in the asset's model units (metres by glTF convention, `_m`), areas
//! `_m2`, angles `_rad`.
//!
//! References: half-edge layout after OpenMesh / pmp-library (implicit face-local `next`, as in
//! geometry-central's "halfedge = corner" numbering); feature angles per Lévy et al.,
//! "Least Squares Conformal Maps", SIGGRAPH 2002, §3.1.
mod build;
mod components;
mod defect;
#[cfg(any(test, feature = "test-support"))]
pub mod fixtures;
mod geometry;
mod ids;
mod input;
mod topology;
pub(crate) mod vector;

#[cfg(test)]
mod tests;

pub use build::{BuiltMesh, MAX_TRIANGLES, NEAR_WELD_RELATIVE};
pub use components::{ComponentInfo, Components};
pub use defect::{BadIndex, DegenerateKind, MeshBuildError, MeshDefect, Offenders, MAX_LISTED};
pub use geometry::{triangle_is_zero_area, Aabb, ZERO_AREA_RELATIVE_TOLERANCE};
pub use ids::{
    ComponentId, CornerData, CornerId, ElementId, FaceData, FaceId, HalfedgeData, HalfedgeId,
    IdVec, VertexData, VertexId,
};
pub use input::MeshInput;
pub use topology::{InvariantViolation, OutgoingHalfedges, TriangleMesh};
