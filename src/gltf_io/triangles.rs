//! The triangles of every triangle primitive, for [`decode`](fn@super::decode): lists, strips and
//! fans expanded into `MeshInput` triangles in source corner order, positions dequantized, and
//! every index, count and limit checked.
//!
//! Invariants: strip triangle `i` is `(v_i, v_{i+1+i%2}, v_{i+2-i%2})` and fan triangle `i` is
//! `(v_{i+1}, v_{i+2}, v_0)`, so winding is preserved; primitives of one mesh that share a
//! POSITION accessor share one vertex block (`weld_group` = glTF mesh index).
//!
//! References: glTF 2.0 spec §3.7.2.1 (primitive modes); `KHR_mesh_quantization`.
use std::collections::HashMap;
use std::ops::Range;

use serde_json::Value;

use super::accessor::{array, field_u64, ComponentType, Reader};
use super::error::{ErrorCode, GltfError};
use super::limits::DecodeLimits;
use crate::mesh::MeshInput;

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
pub(super) fn extract_triangles(
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
