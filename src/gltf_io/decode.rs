//! `decode`: bytes (+ caller-supplied resources) → validated [`Asset`] with a [`MeshInput`].
//!
//! Purpose: read `.glb` and `.gltf`, check everything we rely on (container, JSON, schema via
//! `gltf-json`, URIs, buffer/accessor bounds, node hierarchy, index ranges, finite positions),
//! and expand every triangle primitive (lists, strips, fans) into triangles in source corner
//! order.
//!
//! Invariants:
//! - `mesh_input().triangles` holds the triangles of all triangle primitives in (mesh,
//!   primitive) order; [`TrianglePrimitive::faces`] says which belong to which primitive.
//! - Strip triangle `i` is `(v_i, v_{i+1+i%2}, v_{i+2-i%2})` and fan triangle `i` is
//!   `(v_{i+1}, v_{i+2}, v_0)` (glTF 2.0 §3.7.2.1), so winding is preserved.
//! - Positions are mesh-local (`weld_group` = glTF mesh index); primitives of one mesh that share
//!   a POSITION accessor share one vertex block; a mesh used by several nodes appears once.
//! - POINTS/LINES primitives are carried through untouched and produce no triangles.
//!
//! Units: positions in the asset's units (`_m`); quantized positions (`KHR_mesh_quantization`)
//! are dequantized exactly as a renderer would (normalized → spec formula, else raw integer).
//!
//! References: glTF 2.0 spec §3.6-§3.7, §4.4; `KHR_mesh_quantization`.
use std::ops::Range;
use std::panic::{catch_unwind, AssertUnwindSafe};

use serde_json::Value;

use super::accessor::{array, Reader};
use super::error::{ErrorCode, GltfError};
use super::glb;
use super::limits::DecodeLimits;
use super::triangles::{extract_triangles, TrianglePrimitive};
use super::uri::{check_relative, resolve, Resolved, Resources};
use super::validate::{
    check_extensions, check_nodes, check_primitive_references, check_schema, check_version,
    parse_json,
};
use crate::mesh::MeshInput;

/// The container the asset came in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SourceFormat {
    /// Binary `.glb`.
    Glb,
    /// JSON `.gltf`.
    Gltf,
}

/// An image whose bytes came from the caller's [`Resources`]; `encode` embeds it.
#[derive(Debug, Clone)]
pub(crate) struct ExternalImage {
    pub index: usize,
    pub bytes: Vec<u8>,
}

/// A decoded, validated glTF asset.
#[derive(Debug, Clone)]
pub struct Asset {
    /// The document exactly as parsed (key order preserved); `encode` edits a copy.
    pub(crate) json: Value,
    /// Every buffer's bytes, truncated to its `byteLength`.
    pub(crate) buffers: Vec<Vec<u8>>,
    pub(crate) external_images: Vec<ExternalImage>,
    pub(crate) primitives: Vec<TrianglePrimitive>,
    pub(crate) mesh_input: MeshInput,
    pub(crate) format: SourceFormat,
    pub(crate) limits: DecodeLimits,
}

/// A primitive as `texatlas inspect` shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct PrimitiveSummary {
    /// The glTF mode number (0 points … 6 fan).
    pub mode: u32,
    /// Vertices (the POSITION accessor's count; 0 without POSITION).
    pub vertex_count: u64,
    /// Triangles, for modes 4-6.
    pub triangle_count: Option<u64>,
    /// Attribute names in document order.
    pub attributes: Vec<String>,
    /// Number of morph targets.
    pub morph_targets: usize,
    /// Whether the primitive has `indices`.
    pub indexed: bool,
}

/// A mesh as `texatlas inspect` shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshSummary {
    /// The mesh's `name`, if any.
    pub name: Option<String>,
    /// How many nodes instance the mesh.
    pub instances: usize,
    /// Its primitives.
    pub primitives: Vec<PrimitiveSummary>,
}

/// The structure of an asset, for `texatlas inspect`.
#[derive(Debug, Clone, PartialEq)]
pub struct AssetSummary {
    /// `.glb` or `.gltf`.
    pub format: SourceFormat,
    /// Every mesh.
    pub meshes: Vec<MeshSummary>,
    /// Number of nodes.
    pub node_count: usize,
    /// `extensionsUsed`.
    pub extensions_used: Vec<String>,
    /// `extensionsRequired`.
    pub extensions_required: Vec<String>,
}

impl Asset {
    /// The triangle primitives, in (mesh, primitive) order.
    pub fn triangle_primitives(&self) -> &[TrianglePrimitive] {
        &self.primitives
    }

    /// All triangles of all triangle primitives, concatenated in (mesh, primitive) order, in
    /// mesh-local space, `weld_group` = glTF mesh index.
    pub fn mesh_input(&self) -> &MeshInput {
        &self.mesh_input
    }

    /// Which faces of [`Asset::mesh_input`] belong to triangle primitive `primitive` (an index
    /// into [`Asset::triangle_primitives`]); `None` if there is no such primitive.
    pub fn face_range(&self, primitive: usize) -> Option<Range<usize>> {
        self.primitives.get(primitive).map(|p| p.faces.clone())
    }

    /// The container the asset came in.
    pub fn source_format(&self) -> SourceFormat {
        self.format
    }

    /// The document's JSON tree (read-only), e.g. for reports.
    pub fn json(&self) -> &Value {
        &self.json
    }

    /// Meshes, primitives, nodes and extensions, for `texatlas inspect`.
    pub fn summary(&self) -> AssetSummary {
        let root = &self.json;
        let nodes = array(root, "nodes");
        let accessors = array(root, "accessors");
        let count_of = |index: Option<u64>| -> u64 {
            index
                .and_then(|i| accessors.get(i as usize))
                .and_then(|a| a.get("count"))
                .and_then(Value::as_u64)
                .unwrap_or(0)
        };
        let strings = |key: &str| -> Vec<String> {
            array(root, key)
                .iter()
                .filter_map(|v| v.as_str().map(str::to_string))
                .collect()
        };
        let meshes = array(root, "meshes")
            .iter()
            .enumerate()
            .map(|(m, mesh)| {
                let primitives = array(mesh, "primitives")
                    .iter()
                    .map(|p| {
                        let mode = p.get("mode").and_then(Value::as_u64).unwrap_or(4) as u32;
                        let attrs = p.get("attributes").and_then(Value::as_object);
                        let position = attrs
                            .and_then(|a| a.get("POSITION"))
                            .and_then(Value::as_u64);
                        let indices = p.get("indices").and_then(Value::as_u64);
                        let n = if indices.is_some() {
                            count_of(indices)
                        } else {
                            count_of(position)
                        };
                        let triangle_count = match mode {
                            4 => Some(n / 3),
                            5 | 6 => Some(n.saturating_sub(2)),
                            _ => None,
                        };
                        PrimitiveSummary {
                            mode,
                            vertex_count: count_of(position),
                            triangle_count,
                            attributes: attrs
                                .map(|a| a.keys().cloned().collect())
                                .unwrap_or_default(),
                            morph_targets: array(p, "targets").len(),
                            indexed: indices.is_some(),
                        }
                    })
                    .collect();
                MeshSummary {
                    name: mesh.get("name").and_then(Value::as_str).map(str::to_string),
                    instances: nodes
                        .iter()
                        .filter(|n| n.get("mesh").and_then(Value::as_u64) == Some(m as u64))
                        .count(),
                    primitives,
                }
            })
            .collect();
        AssetSummary {
            format: self.format,
            meshes,
            node_count: nodes.len(),
            extensions_used: strings("extensionsUsed"),
            extensions_required: strings("extensionsRequired"),
        }
    }
}

/// Decodes a `.glb` or `.gltf`. External buffers/images are looked up in `resources` (never on
/// disk). Never panics: a panic inside the parser becomes [`ErrorCode::Internal`].
///
/// Cost: one pass over the bytes for the JSON, one copy of each buffer, and the positions and
/// indices of every triangle primitive (about 36 bytes per vertex and 12 per triangle).
pub fn decode(
    bytes: &[u8],
    resources: &Resources,
    limits: &DecodeLimits,
) -> Result<Asset, GltfError> {
    match catch_unwind(AssertUnwindSafe(|| {
        decode_unguarded(bytes, resources, limits)
    })) {
        Ok(result) => result,
        Err(payload) => {
            let message = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_string());
            Err(GltfError::new(
                ErrorCode::Internal,
                "",
                format!("the decoder panicked: {message}"),
                "report this input as a bug; the asset may be valid",
            ))
        }
    }
}

/// The relative URIs (buffers, then images, in document order, without duplicates) that
/// [`decode`] will look up in [`Resources`], so a caller (CLI, upload handler) can supply
/// exactly those. `data:` URIs are skipped; forbidden URIs (`..`, absolute paths, schemes) are
/// an error here already. Only the container and the JSON are parsed.
pub fn required_resources(bytes: &[u8]) -> Result<Vec<String>, GltfError> {
    let result = catch_unwind(AssertUnwindSafe(|| -> Result<Vec<String>, GltfError> {
        let root = parse_json(split_container(bytes)?.json)?;
        let mut uris: Vec<String> = Vec::new();
        for key in ["buffers", "images"] {
            for (i, item) in array(&root, key).iter().enumerate() {
                let Some(uri) = item.get("uri").and_then(Value::as_str) else {
                    continue;
                };
                if uri.starts_with("data:") {
                    continue;
                }
                check_relative(uri, &format!("/{key}/{i}/uri"))?;
                if !uris.iter().any(|u| u == uri) {
                    uris.push(uri.to_string());
                }
            }
        }
        Ok(uris)
    }));
    result.unwrap_or_else(|_| {
        Err(GltfError::new(
            ErrorCode::Internal,
            "",
            "the URI scan panicked",
            "report this input as a bug",
        ))
    })
}

/// The JSON text and BIN chunk of a `.glb`, or the text of a `.gltf`.
struct Container<'a> {
    json: &'a [u8],
    bin: Option<&'a [u8]>,
    format: SourceFormat,
}

fn split_container(bytes: &[u8]) -> Result<Container<'_>, GltfError> {
    if glb::is_glb(bytes) {
        let parts = glb::parse_glb(bytes)?;
        Ok(Container {
            json: parts.json,
            bin: parts.bin,
            format: SourceFormat::Glb,
        })
    } else {
        let text = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
        if text.iter().find(|b| !b.is_ascii_whitespace()) != Some(&b'{') {
            return Err(GltfError::new(
                ErrorCode::NotGltf,
                "",
                "the data is neither a GLB (magic `glTF`) nor a JSON object",
                "send a .glb file or a .gltf JSON file",
            ));
        }
        Ok(Container {
            json: text,
            bin: None,
            format: SourceFormat::Gltf,
        })
    }
}

fn decode_unguarded(
    bytes: &[u8],
    resources: &Resources,
    limits: &DecodeLimits,
) -> Result<Asset, GltfError> {
    let Container {
        json: json_bytes,
        bin,
        format,
    } = split_container(bytes)?;
    let root = parse_json(json_bytes)?;
    check_version(&root)?;
    check_primitive_references(&root)?;
    check_schema(json_bytes)?;
    check_extensions(&root)?;
    check_nodes(&root)?;
    let buffers = load_buffers(&root, bin, resources)?;
    let external_images = load_images(&root, resources)?;
    let reader = Reader::new(&root, &buffers, limits)?;
    for a in &reader.accessors {
        if a.sparse.is_some() {
            reader.sparse_indices(a)?;
        }
    }
    let (primitives, mesh_input) = extract_triangles(&root, &reader, limits)?;
    drop(reader);
    Ok(Asset {
        json: root,
        buffers,
        external_images,
        primitives,
        mesh_input,
        format,
        limits: limits.clone(),
    })
}

fn load_buffers(
    root: &Value,
    bin: Option<&[u8]>,
    resources: &Resources,
) -> Result<Vec<Vec<u8>>, GltfError> {
    let mut out = Vec::new();
    for (i, b) in array(root, "buffers").iter().enumerate() {
        let path = format!("/buffers/{i}");
        let byte_length = super::accessor::required_u64(b, "byteLength", &path)?;
        let uri = b.get("uri").and_then(Value::as_str);
        let resolved;
        let data: &[u8] = match uri {
            Some(uri) => {
                resolved = resolve(uri, &format!("{path}/uri"), resources)?;
                match &resolved {
                    Resolved::Data(bytes) => bytes,
                    Resolved::Supplied(bytes) => bytes,
                }
            }
            None => match (i, bin) {
                (0, Some(bin)) => bin,
                _ => {
                    return Err(GltfError::new(
                        ErrorCode::Schema,
                        path,
                        "buffer has no `uri` and is not the GLB BIN chunk",
                        "give the buffer a uri, or make it buffer 0 of a GLB with a BIN chunk",
                    ))
                }
            },
        };
        let data = usize::try_from(byte_length)
            .ok()
            .and_then(|n| data.get(..n))
            .ok_or_else(|| {
                GltfError::new(
                    ErrorCode::BufferOutOfBounds,
                    format!("{path}/byteLength"),
                    format!(
                        "buffer declares {byte_length} bytes but only {} are present",
                        data.len()
                    ),
                    "re-export the asset; the file is truncated or byteLength is wrong",
                )
            })?;
        out.push(data.to_vec());
    }
    Ok(out)
}

fn load_images(root: &Value, resources: &Resources) -> Result<Vec<ExternalImage>, GltfError> {
    let mut out = Vec::new();
    for (i, image) in array(root, "images").iter().enumerate() {
        if let Some(uri) = image.get("uri").and_then(Value::as_str) {
            match resolve(uri, &format!("/images/{i}/uri"), resources)? {
                // Embedded images stay as they are; resolving checked the data URI.
                Resolved::Data(_) => {}
                Resolved::Supplied(bytes) => out.push(ExternalImage {
                    index: i,
                    bytes: bytes.to_vec(),
                }),
            }
        }
    }
    Ok(out)
}
