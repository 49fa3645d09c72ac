//! `texatlas inspect --json` ↔ `proto/inspect.schema.json`.
use serde::Serialize;

use crate::gltf_io::{MeshSummary, PrimitiveSummary, SourceFormat};
use crate::inspect::{InspectReport, Surface};
use crate::mesh::{ComponentInfo, MeshDefect};

/// `texatlas inspect --json`.
#[derive(Debug, Clone, Serialize)]
pub struct InspectJson {
    /// The file that was inspected, as given on the command line.
    pub file: String,
    /// Its size in bytes.
    pub file_bytes: u64,
    /// `"glb"` or `"gltf"`.
    pub format: &'static str,
    /// Every entry of the document's `meshes`.
    pub meshes: Vec<MeshJson>,
    /// Number of nodes.
    pub nodes: usize,
    /// `extensionsUsed`.
    pub extensions_used: Vec<String>,
    /// `extensionsRequired`.
    pub extensions_required: Vec<String>,
    /// Triangles over all triangle primitives (strips and fans expanded).
    pub triangles: usize,
    /// Vertices of all triangle primitives before welding.
    pub source_vertices: usize,
    /// The welded surface; `null` when none could be built (see `surface_error`).
    pub surface: Option<SurfaceJson>,
    /// Why no surface could be built, e.g. an asset with only points and lines.
    pub surface_error: Option<ProblemJson>,
    /// Wall-clock seconds spent per step.
    pub timings_s: TimingsJson,
}

/// One glTF mesh.
#[derive(Debug, Clone, Serialize)]
pub struct MeshJson {
    /// Index in the document's `meshes`.
    pub index: usize,
    /// The mesh's `name`.
    pub name: Option<String>,
    /// Nodes that instance it.
    pub instances: usize,
    /// Its primitives.
    pub primitives: Vec<PrimitiveJson>,
}

/// One primitive.
#[derive(Debug, Clone, Serialize)]
pub struct PrimitiveJson {
    /// glTF mode: 0 points, 1 lines, 2 line loop, 3 line strip, 4 triangles, 5 strip, 6 fan.
    pub mode: u32,
    /// The POSITION accessor's count.
    pub vertices: u64,
    /// Triangles for modes 4–6, else `null`.
    pub triangles: Option<u64>,
    /// Attribute names in document order.
    pub attributes: Vec<String>,
    /// Number of morph targets.
    pub morph_targets: usize,
    /// Whether it has an `indices` accessor.
    pub indexed: bool,
}

/// The welded surface.
#[derive(Debug, Clone, Serialize)]
pub struct SurfaceJson {
    /// Distinct vertices after welding by position.
    pub welded_vertices: usize,
    /// Vertices of the repaired mesh (welded vertices plus repair copies).
    pub mesh_vertices: usize,
    /// Undirected edges.
    pub edges: usize,
    /// Boundary loops over all components.
    pub boundary_loops: usize,
    /// Every connected component.
    pub components: Vec<ComponentJson>,
    /// Every repaired defect.
    pub defects: Vec<DefectJson>,
}

/// One connected component of the welded surface.
#[derive(Debug, Clone, Serialize)]
pub struct ComponentJson {
    /// The glTF mesh it belongs to.
    pub mesh: Option<u32>,
    /// F.
    pub faces: usize,
    /// V.
    pub vertices: usize,
    /// E.
    pub edges: usize,
    /// b.
    pub boundary_loops: usize,
    /// χ = V − E + F.
    pub euler_characteristic: i64,
    /// g = (2 − χ − b) / 2.
    pub genus: u32,
}

/// One repaired defect.
#[derive(Debug, Clone, Serialize)]
pub struct DefectJson {
    /// Stable snake_case code.
    pub code: &'static str,
    /// What is wrong, the elements it names, and how it was repaired.
    pub detail: String,
    /// The faces it names (indices into the concatenated triangle list, in (mesh, primitive)
    /// order).
    pub faces: Vec<u32>,
}

/// An error in `application/problem+json` spirit: a stable code and a human detail.
#[derive(Debug, Clone, Serialize)]
pub struct ProblemJson {
    /// Stable snake_case code.
    pub code: &'static str,
    /// What is wrong and how to fix it.
    pub detail: String,
}

/// Wall-clock seconds per step of `inspect`.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct TimingsJson {
    /// Reading and decoding the file.
    pub decode_s: f64,
    /// Welding, connectivity and validation.
    pub build_s: f64,
}

impl InspectJson {
    /// The JSON form of `report` for `file` (`file_bytes` long), with the measured timings.
    pub fn new(
        file: String,
        file_bytes: u64,
        report: &InspectReport,
        timings: TimingsJson,
    ) -> Self {
        let (surface, surface_error) = match &report.surface {
            Ok(surface) => (Some(SurfaceJson::from(surface)), None),
            Err(err) => (
                None,
                Some(ProblemJson {
                    code: err.code(),
                    detail: err.to_string(),
                }),
            ),
        };
        InspectJson {
            file,
            file_bytes,
            format: match report.asset.format {
                SourceFormat::Glb => "glb",
                SourceFormat::Gltf => "gltf",
            },
            meshes: report
                .asset
                .meshes
                .iter()
                .enumerate()
                .map(|(index, mesh)| MeshJson::from((index, mesh)))
                .collect(),
            nodes: report.asset.node_count,
            extensions_used: report.asset.extensions_used.clone(),
            extensions_required: report.asset.extensions_required.clone(),
            triangles: report.triangles,
            source_vertices: report.source_vertices,
            surface,
            surface_error,
            timings_s: timings,
        }
    }
}

impl From<(usize, &MeshSummary)> for MeshJson {
    fn from((index, mesh): (usize, &MeshSummary)) -> Self {
        MeshJson {
            index,
            name: mesh.name.clone(),
            instances: mesh.instances,
            primitives: mesh.primitives.iter().map(PrimitiveJson::from).collect(),
        }
    }
}

impl From<&PrimitiveSummary> for PrimitiveJson {
    fn from(p: &PrimitiveSummary) -> Self {
        PrimitiveJson {
            mode: p.mode,
            vertices: p.vertex_count,
            triangles: p.triangle_count,
            attributes: p.attributes.clone(),
            morph_targets: p.morph_targets,
            indexed: p.indexed,
        }
    }
}

impl From<&Surface> for SurfaceJson {
    fn from(s: &Surface) -> Self {
        SurfaceJson {
            welded_vertices: s.welded_vertices,
            mesh_vertices: s.mesh_vertices,
            edges: s.edges,
            boundary_loops: s.boundary_loops,
            components: s.components.iter().map(ComponentJson::from).collect(),
            defects: s.defects.iter().map(DefectJson::from).collect(),
        }
    }
}

impl From<&ComponentInfo> for ComponentJson {
    fn from(c: &ComponentInfo) -> Self {
        ComponentJson {
            mesh: c.weld_group,
            faces: c.num_faces,
            vertices: c.num_vertices,
            edges: c.num_edges,
            boundary_loops: c.num_boundary_loops,
            euler_characteristic: c.euler_characteristic,
            genus: c.genus,
        }
    }
}

impl From<&MeshDefect> for DefectJson {
    fn from(d: &MeshDefect) -> Self {
        DefectJson {
            code: d.code(),
            detail: d.to_string(),
            faces: d.faces().iter().map(|f| f.index() as u32).collect(),
        }
    }
}
