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
use std::collections::HashMap;
use std::ops::Range;
use std::panic::{catch_unwind, AssertUnwindSafe};

use gltf_json::validation::Validate as _;
use serde_json::Value;

use super::accessor::{array, field_u64, ComponentType, Reader};
use super::error::{
    offset_of_line_column, pointer_at_offset, pointer_from_gltf_path, ErrorCode, GltfError,
};
use super::glb;
use super::uri::{check_relative, resolve, Resolved, Resources};
use crate::mesh::MeshInput;

/// Bounds on what one decode may allocate. Defaults keep a decode under about 1 GB.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DecodeLimits {
    /// Largest accessor, in packed bytes (count × element size). Accessors with a buffer view
    /// are also bounded by their real bytes; this cap matters for accessors without one (all
    /// zeros, maybe sparse), whose `count` is backed by nothing. Default: 256 MiB.
    pub max_accessor_bytes: u64,
    /// Most vertices over all triangle primitives (shared POSITION accessors of one mesh count
    /// once). `None` = no limit. Default: `Some(16_777_216)`.
    pub max_vertices: Option<u64>,
    /// Most triangles over all triangle primitives. `None` = no limit. Default:
    /// `Some(16_777_216)`.
    pub max_triangles: Option<u64>,
}

impl Default for DecodeLimits {
    fn default() -> Self {
        DecodeLimits {
            max_accessor_bytes: 256 << 20,
            max_vertices: Some(1 << 24),
            max_triangles: Some(1 << 24),
        }
    }
}

/// How a triangle primitive stores its triangles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrimitiveMode {
    /// Mode 4.
    Triangles,
    /// Mode 5.
    TriangleStrip,
    /// Mode 6.
    TriangleFan,
}

/// The container the asset came in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SourceFormat {
    /// Binary `.glb`.
    Glb,
    /// JSON `.gltf`.
    Gltf,
}

/// One triangle primitive (mode 4, 5 or 6) and where its data sits in the [`MeshInput`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TrianglePrimitive {
    /// Index into the document's `meshes`.
    pub mesh_index: usize,
    /// Index into that mesh's `primitives`.
    pub primitive_index: usize,
    /// The source mode (strips and fans are written back as lists).
    pub mode: PrimitiveMode,
    /// The primitive's faces in `MeshInput::triangles`.
    pub faces: Range<usize>,
    /// First vertex of the primitive's POSITION accessor in `MeshInput::positions_m`.
    pub vertex_start: u32,
    /// Number of vertices (the POSITION accessor's count).
    pub vertex_count: u32,
    /// The `n` of every `TEXCOORD_n` the primitive already has, ascending.
    pub texcoord_sets: Vec<u32>,
    /// Whether the source primitive has an `indices` accessor.
    pub indexed: bool,
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

fn parse_json(json: &[u8]) -> Result<Value, GltfError> {
    let value: Value = serde_json::from_slice(json).map_err(|e| {
        let message = e.to_string();
        if message.contains("recursion limit") {
            GltfError::new(
                ErrorCode::JsonTooDeep,
                "",
                format!("the JSON nests deeper than 128 levels: {message}"),
                "flatten the deeply nested extras/extensions",
            )
        } else {
            GltfError::new(
                ErrorCode::JsonSyntax,
                "",
                format!("invalid JSON: {message}"),
                "fix the JSON syntax",
            )
        }
    })?;
    if !value.is_object() {
        return Err(GltfError::new(
            ErrorCode::JsonSyntax,
            "",
            "the glTF JSON must be an object",
            "send a glTF 2.0 document",
        ));
    }
    Ok(value)
}

fn check_version(root: &Value) -> Result<(), GltfError> {
    let version = root
        .get("asset")
        .and_then(|a| a.get("version"))
        .and_then(Value::as_str);
    match version {
        Some(v) if v.split('.').next() == Some("2") => Ok(()),
        Some(v) => Err(GltfError::new(
            ErrorCode::AssetVersion,
            "/asset/version",
            format!("asset version is `{v}`, only 2.x is supported"),
            "convert the asset to glTF 2.0",
        )),
        None => Err(GltfError::new(
            ErrorCode::Schema,
            "/asset/version",
            "`asset.version` is missing",
            "add \"asset\": {\"version\": \"2.0\"}",
        )),
    }
}

/// Every accessor reference of every primitive must exist. Checked before `gltf-json`'s
/// validation because that indexes `accessors[POSITION]` unchecked and panics otherwise.
fn check_primitive_references(root: &Value) -> Result<(), GltfError> {
    let accessors = array(root, "accessors").len() as u64;
    let check = |value: &Value, path: String| -> Result<(), GltfError> {
        match value.as_u64() {
            Some(i) if i < accessors => Ok(()),
            _ => Err(GltfError::new(
                ErrorCode::Schema,
                path,
                format!("{value} is not an accessor index (there are {accessors})"),
                "point the attribute at an existing accessor",
            )),
        }
    };
    for (m, mesh) in array(root, "meshes").iter().enumerate() {
        for (p, prim) in array(mesh, "primitives").iter().enumerate() {
            let path = format!("/meshes/{m}/primitives/{p}");
            if let Some(attributes) = prim.get("attributes").and_then(Value::as_object) {
                for (name, value) in attributes {
                    check(value, format!("{path}/attributes/{name}"))?;
                }
            }
            if let Some(indices) = prim.get("indices") {
                check(indices, format!("{path}/indices"))?;
            }
            for (t, target) in array(prim, "targets").iter().enumerate() {
                for (name, value) in target.as_object().into_iter().flatten() {
                    check(value, format!("{path}/targets/{t}/{name}"))?;
                }
            }
        }
    }
    Ok(())
}

/// Schema validation by `gltf-json` (typed parse + its `Validate`), reported with JSON pointers.
/// Cost: a second parse of the JSON text into typed structs.
fn check_schema(json: &[u8]) -> Result<(), GltfError> {
    let typed: gltf_json::Root = serde_json::from_slice(json).map_err(|e| {
        let offset = offset_of_line_column(json, e.line(), e.column());
        GltfError::new(
            ErrorCode::Schema,
            pointer_at_offset(json, offset),
            format!("the document does not follow the glTF 2.0 schema: {e}"),
            "fix the property named in the message",
        )
    })?;
    let mut first: Option<(String, gltf_json::validation::Error)> = None;
    let mut total = 0usize;
    typed.validate(&typed, gltf_json::Path::new, &mut |path, error| {
        let path = path().0;
        // gltf-json flags every extension name it was not compiled to understand; unknown
        // extensions are legal and we carry them through, so these reports are not defects.
        // A texture whose image comes only from an extension (KHR_texture_basisu,
        // EXT_texture_webp, ...) has no `source`, which is legal too.
        let extension_list =
            path.starts_with("extensionsRequired[") || path.starts_with("extensionsUsed[");
        let missing = error == gltf_json::validation::Error::Missing;
        let extension_texture =
            missing && path.starts_with("textures[") && path.ends_with(".source");
        // An accessor without buffer view is all zeros (spec §3.6.2.1), which is legal.
        let zero_accessor =
            missing && path.starts_with("accessors[") && path.ends_with(".bufferView");
        // POSITION is optional for the spec; `extract_triangles` names it where we need it.
        let no_position = missing && path.ends_with("attributes[\"POSITION\"]");
        if extension_list || extension_texture || zero_accessor || no_position {
            return;
        }
        total += 1;
        if first.is_none() {
            first = Some((path, error));
        }
    });
    match first {
        None => Ok(()),
        Some((path, error)) => {
            let what = match error {
                gltf_json::validation::Error::IndexOutOfBounds => "index points to no object",
                gltf_json::validation::Error::Invalid => "value is invalid",
                gltf_json::validation::Error::Missing => "required value is missing",
                gltf_json::validation::Error::Oversize => {
                    "size exceeds what this system can address"
                }
                _ => "value is not valid glTF 2.0",
            };
            Err(GltfError::new(
                ErrorCode::Schema,
                pointer_from_gltf_path(&path),
                format!("{what} at `{path}` ({total} schema error(s) in total)"),
                "fix the value at this path; the glTF-Validator lists every error",
            ))
        }
    }
}

/// Mesh compression changes where geometry lives; we cannot decode it (no well-kept pure-Rust
/// Draco/meshopt decoder), so such assets are refused by name rather than unwrapped wrongly.
fn check_extensions(root: &Value) -> Result<(), GltfError> {
    const UNSUPPORTED: [&str; 3] = [
        "KHR_draco_mesh_compression",
        "EXT_meshopt_compression",
        "KHR_meshopt_compression",
    ];
    for key in ["extensionsRequired", "extensionsUsed"] {
        for (i, name) in array(root, key).iter().enumerate() {
            if let Some(name) = name.as_str().filter(|n| UNSUPPORTED.contains(n)) {
                return Err(GltfError::new(
                    ErrorCode::UnsupportedExtension,
                    format!("/{key}/{i}"),
                    format!("the asset uses {name}, which texatlas cannot decode"),
                    format!("re-export the asset without {name} (uncompressed geometry)"),
                ));
            }
        }
    }
    Ok(())
}

/// The nodes must form a forest: every child has one parent and no node is its own ancestor.
/// O(nodes + children): each node is walked up at most once.
fn check_nodes(root: &Value) -> Result<(), GltfError> {
    let nodes = array(root, "nodes");
    let mut parent: Vec<Option<usize>> = vec![None; nodes.len()];
    for (i, node) in nodes.iter().enumerate() {
        for (k, child) in array(node, "children").iter().enumerate() {
            let path = format!("/nodes/{i}/children/{k}");
            let c = child
                .as_u64()
                .map(|c| c as usize)
                .filter(|&c| c < nodes.len())
                .ok_or_else(|| {
                    GltfError::new(
                        ErrorCode::Schema,
                        path.clone(),
                        "child is not a node index",
                        "fix the reference",
                    )
                })?;
            if let Some(p) = parent[c] {
                return Err(GltfError::new(
                    ErrorCode::NodeHierarchy,
                    path,
                    format!("node {c} is a child of both node {p} and node {i}"),
                    "give every node at most one parent",
                ));
            }
            parent[c] = Some(i);
        }
    }
    // 0 = unvisited, 1 = on the current upward walk, 2 = known to reach a root.
    let mut state = vec![0u8; nodes.len()];
    let mut walk = Vec::new();
    for start in 0..nodes.len() {
        let mut v = start;
        walk.clear();
        loop {
            match state[v] {
                2 => break,
                1 => {
                    return Err(GltfError::new(
                        ErrorCode::NodeHierarchy,
                        format!("/nodes/{v}/children"),
                        format!("node {v} is its own ancestor (a cycle in `children`)"),
                        "remove the cycle from the node hierarchy",
                    ))
                }
                _ => {}
            }
            state[v] = 1;
            walk.push(v);
            match parent[v] {
                Some(p) => v = p,
                None => break,
            }
        }
        for &w in &walk {
            state[w] = 2;
        }
    }
    Ok(())
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

fn primitive_error(code: ErrorCode, path: String, detail: String) -> GltfError {
    GltfError::new(
        code,
        path,
        detail,
        "re-export the mesh; the primitive is malformed",
    )
}

fn limit_error(path: String, what: &str, limit: u64) -> GltfError {
    GltfError::new(
        ErrorCode::LimitExceeded,
        path,
        format!("the asset has more than {limit} {what}"),
        format!("decimate or split the asset, or raise the {what} limit"),
    )
}

/// Expands every triangle primitive into `MeshInput` triangles.
fn extract_triangles(
    root: &Value,
    reader: &Reader<'_>,
    limits: &DecodeLimits,
) -> Result<(Vec<TrianglePrimitive>, MeshInput), GltfError> {
    let mut input = MeshInput::default();
    let mut primitives = Vec::new();
    // (mesh, POSITION accessor) → (vertex_start, vertex_count): shared vertex blocks.
    let mut blocks: HashMap<(usize, usize), (u32, u32)> = HashMap::new();
    for (m, mesh) in array(root, "meshes").iter().enumerate() {
        for (p, prim) in array(mesh, "primitives").iter().enumerate() {
            let path = format!("/meshes/{m}/primitives/{p}");
            let mode = match field_u64(prim, "mode", &path)?.unwrap_or(4) {
                0..=3 => continue,
                4 => PrimitiveMode::Triangles,
                5 => PrimitiveMode::TriangleStrip,
                6 => PrimitiveMode::TriangleFan,
                other => {
                    return Err(primitive_error(
                        ErrorCode::Schema,
                        format!("{path}/mode"),
                        format!("mode {other} is not 0..=6"),
                    ))
                }
            };
            let attributes = prim
                .get("attributes")
                .and_then(Value::as_object)
                .ok_or_else(|| {
                    primitive_error(
                        ErrorCode::Schema,
                        format!("{path}/attributes"),
                        "attributes object missing".into(),
                    )
                })?;
            let position_index = attributes
                .get("POSITION")
                .and_then(Value::as_u64)
                .ok_or_else(|| {
                    primitive_error(
                        ErrorCode::PrimitiveInvalid,
                        format!("{path}/attributes"),
                        "triangle primitive has no POSITION attribute".into(),
                    )
                })?;
            let position = reader.layout(position_index, &format!("{path}/attributes/POSITION"))?;
            if position.kind != "VEC3" || position.component_type == ComponentType::U32 {
                return Err(GltfError::new(
                    ErrorCode::AccessorInvalid,
                    format!("{path}/attributes/POSITION"),
                    format!(
                        "POSITION accessor {} is {} of componentType {}; it must be VEC3 float (or \
                         8/16-bit integers with KHR_mesh_quantization)",
                        position.index,
                        position.kind,
                        position.component_type.gl()
                    ),
                    "re-export positions as VEC3 float",
                ));
            }
            let vertex_count = position.count;
            let mut texcoord_sets = Vec::new();
            for (name, value) in attributes {
                let apath = format!("{path}/attributes/{name}");
                let index = value.as_u64().ok_or_else(|| {
                    primitive_error(
                        ErrorCode::Schema,
                        apath.clone(),
                        "attribute is not an accessor index".into(),
                    )
                })?;
                let layout = reader.layout(index, &apath)?;
                if layout.count != vertex_count {
                    return Err(primitive_error(
                        ErrorCode::PrimitiveInvalid,
                        apath,
                        format!(
                            "{name} has {} elements but POSITION has {vertex_count}",
                            layout.count
                        ),
                    ));
                }
                if let Some(set) = name
                    .strip_prefix("TEXCOORD_")
                    .and_then(|s| s.parse::<u32>().ok())
                {
                    texcoord_sets.push(set);
                }
            }
            texcoord_sets.sort_unstable();
            for (t, target) in array(prim, "targets").iter().enumerate() {
                let Some(target) = target.as_object() else {
                    return Err(primitive_error(
                        ErrorCode::Schema,
                        format!("{path}/targets/{t}"),
                        "target is not an object".into(),
                    ));
                };
                for (name, value) in target {
                    let tpath = format!("{path}/targets/{t}/{name}");
                    let index = value.as_u64().ok_or_else(|| {
                        primitive_error(
                            ErrorCode::Schema,
                            tpath.clone(),
                            "target attribute is not an accessor index".into(),
                        )
                    })?;
                    let layout = reader.layout(index, &tpath)?;
                    if layout.count != vertex_count {
                        return Err(primitive_error(
                            ErrorCode::PrimitiveInvalid,
                            tpath,
                            format!("morph target {name} has {} elements but POSITION has {vertex_count}", layout.count),
                        ));
                    }
                }
            }

            // Vertex block: positions, shared by primitives of this mesh with the same accessor.
            let (vertex_start, vertex_count_u32) = match blocks.get(&(m, position.index)) {
                Some(&block) => block,
                None => {
                    let start = input.positions_m.len() as u64;
                    let end = start + vertex_count;
                    if limits.max_vertices.is_some_and(|max| end > max) {
                        return Err(limit_error(
                            format!("{path}/attributes/POSITION"),
                            "vertices",
                            limits.max_vertices.unwrap_or(0),
                        ));
                    }
                    if end > u64::from(u32::MAX) {
                        return Err(limit_error(
                            format!("{path}/attributes/POSITION"),
                            "vertices",
                            u64::from(u32::MAX),
                        ));
                    }
                    let packed = reader.read_packed(position)?;
                    let size = position.component_type.size();
                    let float = position.component_type == ComponentType::F32;
                    input.positions_m.reserve(vertex_count as usize);
                    for (i, element) in packed.chunks_exact(position.element_size).enumerate() {
                        let mut p = [0.0f64; 3];
                        for (c, value) in p.iter_mut().enumerate() {
                            let bytes = &element[c * size..];
                            *value = if float {
                                // Fast path for the common case (no normalization to apply).
                                f64::from(f32::from_le_bytes([
                                    bytes[0], bytes[1], bytes[2], bytes[3],
                                ]))
                            } else {
                                position.component_type.value(bytes, position.normalized)
                            };
                        }
                        if !p.iter().all(|x| x.is_finite()) {
                            return Err(GltfError::new(
                                ErrorCode::NonFinitePosition,
                                position.path(),
                                format!(
                                    "vertex {i} of POSITION accessor {} is {p:?}",
                                    position.index
                                ),
                                "repair or remove the vertex; positions must be finite",
                            ));
                        }
                        input.positions_m.push(p);
                    }
                    input.weld_group.resize(input.positions_m.len(), m as u32);
                    let block = (start as u32, vertex_count as u32);
                    blocks.insert((m, position.index), block);
                    block
                }
            };

            // Corner stream: the indices (checked < vertex count), or 0..count without them.
            let indices_path = format!("{path}/indices");
            let stream: Option<Vec<u32>> = match field_u64(prim, "indices", &path)? {
                Some(index) => {
                    let layout = reader.layout(index, &indices_path)?;
                    if layout.kind != "SCALAR"
                        || layout.normalized
                        || !matches!(
                            layout.component_type,
                            ComponentType::U8 | ComponentType::U16 | ComponentType::U32
                        )
                    {
                        return Err(GltfError::new(
                            ErrorCode::AccessorInvalid,
                            indices_path,
                            format!("indices accessor {} must be SCALAR unsigned byte/short/int, not normalized", layout.index),
                            "re-export the indices",
                        ));
                    }
                    let packed = reader.read_packed(layout)?;
                    let values: Vec<u32> = match layout.component_type {
                        ComponentType::U8 => packed.iter().map(|&b| u32::from(b)).collect(),
                        ComponentType::U16 => packed
                            .chunks_exact(2)
                            .map(|c| u32::from(u16::from_le_bytes([c[0], c[1]])))
                            .collect(),
                        _ => packed
                            .chunks_exact(4)
                            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                            .collect(),
                    };
                    drop(packed);
                    if let Some((k, v)) = values
                        .iter()
                        .enumerate()
                        .find(|(_, &v)| u64::from(v) >= vertex_count)
                    {
                        return Err(GltfError::new(
                            ErrorCode::IndexOutOfRange,
                            indices_path,
                            format!(
                                "index #{k} of accessor {} is {v}, but there are {vertex_count} vertices",
                                layout.index
                            ),
                            "re-export the mesh; indices must be smaller than the vertex count",
                        ));
                    }
                    Some(values)
                }
                None => None,
            };
            let corner_count = stream.as_ref().map_or(vertex_count, |s| s.len() as u64);
            let triangle_count = match mode {
                PrimitiveMode::Triangles => {
                    if corner_count % 3 != 0 {
                        return Err(primitive_error(
                            ErrorCode::PrimitiveInvalid,
                            if stream.is_some() { indices_path } else { format!("{path}/attributes/POSITION") },
                            format!("a TRIANGLES primitive needs a multiple of 3 corners, found {corner_count}"),
                        ));
                    }
                    corner_count / 3
                }
                PrimitiveMode::TriangleStrip | PrimitiveMode::TriangleFan => {
                    corner_count.saturating_sub(2)
                }
            };
            let face_start = input.triangles.len();
            if limits
                .max_triangles
                .is_some_and(|max| face_start as u64 + triangle_count > max)
            {
                return Err(limit_error(
                    path,
                    "triangles",
                    limits.max_triangles.unwrap_or(0),
                ));
            }
            // `k < corner_count` for every call below, so `get` never misses.
            let corner = |k: u64| -> u32 {
                let local = match &stream {
                    None => k as u32,
                    Some(s) => s.get(k as usize).copied().unwrap_or(0),
                };
                vertex_start + local
            };
            input.triangles.reserve(triangle_count as usize);
            for i in 0..triangle_count {
                let t = match mode {
                    PrimitiveMode::Triangles => {
                        [corner(3 * i), corner(3 * i + 1), corner(3 * i + 2)]
                    }
                    PrimitiveMode::TriangleStrip => {
                        let odd = i % 2;
                        [corner(i), corner(i + 1 + odd), corner(i + 2 - odd)]
                    }
                    PrimitiveMode::TriangleFan => [corner(i + 1), corner(i + 2), corner(0)],
                };
                input.triangles.push(t);
            }
            primitives.push(TrianglePrimitive {
                mesh_index: m,
                primitive_index: p,
                mode,
                faces: face_start..input.triangles.len(),
                vertex_start,
                vertex_count: vertex_count_u32,
                texcoord_sets,
                indexed: stream.is_some(),
            });
        }
    }
    Ok((primitives, input))
}
