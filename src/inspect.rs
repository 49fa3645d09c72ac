//! The `texatlas inspect` report: what an asset holds and what is wrong with it, before any
//! atlas work.
//!
//! Purpose: let a user (or a pipeline, with `--json`) see the meshes, primitives and triangles of
//! an asset, the surface topology recovered by welding (vertices, boundary loops, Euler
//! characteristic and genus per connected component) and every mesh defect with the elements
//! it names.
//!
//! Invariants: plain data, built only from [`gltf_io::Asset`] and [`mesh::TriangleMesh`]; the
//! JSON form lives in [`crate::api`]. Topology is per welded component, in mesh-local space:
//! a glTF mesh instanced by several nodes is counted once.
//!
//! Units: counts; timings in seconds (`_s`), measured by the caller.
use crate::gltf_io::{self, AssetSummary};
use crate::mesh::{self, ComponentInfo, MeshBuildError, MeshDefect, TriangleMesh};

/// What `texatlas inspect` prints.
#[derive(Debug, Clone)]
pub struct InspectReport {
    /// Meshes, primitives, nodes and extensions, as the document declares them.
    pub asset: AssetSummary,
    /// Triangles over all triangle primitives (strips and fans expanded).
    pub triangles: usize,
    /// Vertices of all triangle primitives before welding.
    pub source_vertices: usize,
    /// The welded surface, or why none could be built (e.g. an asset with only points and lines).
    pub surface: Result<Surface, MeshBuildError>,
}

/// The welded, repaired surface of all triangle primitives.
#[derive(Debug, Clone)]
pub struct Surface {
    /// Distinct vertices after welding by position (the surface's real vertex count).
    pub welded_vertices: usize,
    /// Vertices of the repaired mesh: welded vertices plus the copies made by splitting
    /// non-manifold vertices and isolating repeated-vertex triangles. Components count these.
    pub mesh_vertices: usize,
    /// Undirected edges.
    pub edges: usize,
    /// Boundary loops over all components.
    pub boundary_loops: usize,
    /// Every connected component with its topology; `weld_group` is the glTF mesh index.
    pub components: Vec<ComponentInfo>,
    /// Every repaired defect, each naming its elements.
    pub defects: Vec<MeshDefect>,
}

/// Builds the report: welds and validates the asset's triangles.
///
/// Cost: one [`TriangleMesh::build`] over all triangles (about 0.1 µs–1 µs per triangle).
pub fn inspect(asset: &gltf_io::Asset) -> InspectReport {
    let input = asset.mesh_input();
    let surface = TriangleMesh::build(input).map(|built| {
        let mesh::BuiltMesh {
            mesh,
            defects,
            num_welded_vertices,
        } = built;
        let components = mesh.components().components;
        Surface {
            welded_vertices: num_welded_vertices,
            mesh_vertices: mesh.num_vertices(),
            edges: mesh.num_edges(),
            boundary_loops: components.iter().map(|c| c.num_boundary_loops).sum(),
            components,
            defects,
        }
    });
    InspectReport {
        asset: asset.summary(),
        triangles: input.triangles.len(),
        source_vertices: input.positions_m.len(),
        surface,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gltf_io::{decode, DecodeLimits, Resources};

    #[test]
    fn box_fixture_is_one_closed_genus_zero_component() {
        let bytes = std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/fixtures/Box.glb"
        ))
        .expect("fixture");
        let asset = decode(&bytes, &Resources::new(), &DecodeLimits::default()).expect("decode");
        let report = inspect(&asset);
        assert_eq!(report.triangles, 12);
        assert_eq!(
            report.source_vertices, 24,
            "Box splits its 8 corners per face normal"
        );
        let surface = report.surface.expect("surface");
        assert_eq!(
            surface.welded_vertices, 8,
            "welding by position recovers the 8 corners"
        );
        assert_eq!(surface.mesh_vertices, 8, "nothing to repair");
        assert_eq!(surface.edges, 18);
        assert_eq!(surface.boundary_loops, 0);
        assert_eq!(surface.components.len(), 1);
        assert_eq!(surface.components[0].euler_characteristic, 2);
        assert_eq!(surface.components[0].genus, 0);
        assert!(surface.defects.is_empty(), "{:?}", surface.defects);
    }
}
