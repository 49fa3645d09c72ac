//! Accessors: layout, bounds checks and reading into packed element bytes.
//!
//! Purpose: turn `accessors[i]` (with its buffer view, byte stride, sparse substitution, or no
//! buffer view at all) into `count` tightly packed elements, each still in its original
//! componentType and layout, so the encoder can copy vertex attributes bit for bit and the
//! decoder can convert positions and indices.
//!
//! Invariants: nothing is allocated before the bytes it reads are known to exist, except for
//! accessors without a buffer view (implicitly zero), whose size is capped by
//! [`DecodeLimits::max_accessor_bytes`]. All offsets are computed in `u64` with checked
//! arithmetic. Sparse indices are checked against `count` before use.
//!
//! Units: bytes; element = one SCALAR/VECn/MATn value. Matrix columns of 1- and 2-byte
//! components are padded to 4 bytes as the spec requires (glTF 2.0 §3.6.2.4, "Data
//! alignment"), and that padding is part of the packed element.
//!
//! References: glTF 2.0 spec §3.6.2 (accessors), §3.6.2.3 (sparse), §3.11 (normalized
//! integers), `KHR_mesh_quantization`.
use serde_json::Value;

use super::error::{ErrorCode, GltfError};
use super::limits::DecodeLimits;

/// A glTF componentType.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ComponentType {
    I8,
    U8,
    I16,
    U16,
    U32,
    F32,
}

impl ComponentType {
    pub(crate) fn from_gl(code: u64) -> Option<Self> {
        Some(match code {
            5120 => ComponentType::I8,
            5121 => ComponentType::U8,
            5122 => ComponentType::I16,
            5123 => ComponentType::U16,
            5125 => ComponentType::U32,
            5126 => ComponentType::F32,
            _ => return None,
        })
    }

    pub(crate) fn gl(self) -> u32 {
        match self {
            ComponentType::I8 => 5120,
            ComponentType::U8 => 5121,
            ComponentType::I16 => 5122,
            ComponentType::U16 => 5123,
            ComponentType::U32 => 5125,
            ComponentType::F32 => 5126,
        }
    }

    pub(crate) fn size(self) -> usize {
        match self {
            ComponentType::I8 | ComponentType::U8 => 1,
            ComponentType::I16 | ComponentType::U16 => 2,
            ComponentType::U32 | ComponentType::F32 => 4,
        }
    }

    /// The raw value of the component at the start of `bytes` (`bytes.len() >= size()`).
    pub(crate) fn raw(self, bytes: &[u8]) -> f64 {
        let b = |i: usize| bytes.get(i).copied().unwrap_or(0);
        match self {
            ComponentType::I8 => f64::from(b(0) as i8),
            ComponentType::U8 => f64::from(b(0)),
            ComponentType::I16 => f64::from(i16::from_le_bytes([b(0), b(1)])),
            ComponentType::U16 => f64::from(u16::from_le_bytes([b(0), b(1)])),
            ComponentType::U32 => f64::from(u32::from_le_bytes([b(0), b(1), b(2), b(3)])),
            ComponentType::F32 => f64::from(f32::from_le_bytes([b(0), b(1), b(2), b(3)])),
        }
    }

    /// The value as a consumer sees it: normalized integers map to \[0,1\] or \[-1,1\] by the
    /// spec's formulas (§3.11), e.g. `max(c / 127, -1)` for signed bytes.
    pub(crate) fn value(self, bytes: &[u8], normalized: bool) -> f64 {
        let raw = self.raw(bytes);
        if !normalized {
            return raw;
        }
        match self {
            ComponentType::I8 => (raw / 127.0).max(-1.0),
            ComponentType::U8 => raw / 255.0,
            ComponentType::I16 => (raw / 32767.0).max(-1.0),
            ComponentType::U16 => raw / 65535.0,
            ComponentType::U32 => raw / 4_294_967_295.0,
            ComponentType::F32 => raw,
        }
    }
}

/// Sparse substitution of an accessor.
#[derive(Debug, Clone)]
pub(crate) struct SparseLayout {
    pub count: u64,
    pub indices_view: usize,
    pub indices_offset: u64,
    pub indices_type: ComponentType,
    pub values_view: usize,
    pub values_offset: u64,
}

/// Everything needed to read one accessor, validated against the document.
#[derive(Debug, Clone)]
pub(crate) struct AccessorLayout {
    pub index: usize,
    pub buffer_view: Option<usize>,
    pub byte_offset: u64,
    pub component_type: ComponentType,
    pub normalized: bool,
    pub count: u64,
    /// `"SCALAR"`, `"VEC3"`, ...
    pub kind: &'static str,
    /// Number of components (rows × columns for matrices).
    pub components: usize,
    /// Packed element size in bytes, including matrix column padding.
    pub element_size: usize,
    pub sparse: Option<SparseLayout>,
}

impl AccessorLayout {
    pub(crate) fn path(&self) -> String {
        format!("/accessors/{}", self.index)
    }

    /// Byte offset of component `c` inside a packed element (matrix columns are padded).
    pub(crate) fn component_offset(&self, c: usize) -> usize {
        let size = self.component_type.size();
        match self.kind {
            "MAT2" | "MAT3" | "MAT4" => {
                let rows = match self.kind {
                    "MAT2" => 2,
                    "MAT3" => 3,
                    _ => 4,
                };
                let column_bytes = (rows * size).div_ceil(4) * 4;
                (c / rows) * column_bytes + (c % rows) * size
            }
            _ => c * size,
        }
    }
}

/// A buffer view, validated against its buffer.
#[derive(Debug, Clone)]
pub(crate) struct ViewLayout {
    pub buffer: usize,
    pub byte_offset: u64,
    pub byte_length: u64,
    pub byte_stride: Option<u64>,
}

/// Reads typed fields of a JSON object with JSON-pointer errors.
pub(crate) fn field_u64(obj: &Value, key: &str, path: &str) -> Result<Option<u64>, GltfError> {
    match obj.get(key) {
        None => Ok(None),
        Some(v) => v.as_u64().map(Some).ok_or_else(|| {
            GltfError::new(
                ErrorCode::Schema,
                format!("{path}/{key}"),
                format!("`{key}` must be a non-negative integer, found {v}"),
                "fix the exporter or the JSON by hand",
            )
        }),
    }
}

pub(crate) fn required_u64(obj: &Value, key: &str, path: &str) -> Result<u64, GltfError> {
    field_u64(obj, key, path)?.ok_or_else(|| {
        GltfError::new(
            ErrorCode::Schema,
            format!("{path}/{key}"),
            format!("required property `{key}` is missing"),
            "fix the exporter or the JSON by hand",
        )
    })
}

pub(crate) fn array<'a>(root: &'a Value, key: &str) -> &'a [Value] {
    root.get(key)
        .and_then(Value::as_array)
        .map(Vec::as_slice)
        .unwrap_or(&[])
}

fn index_error(path: String, what: &str, index: u64, len: usize) -> GltfError {
    GltfError::new(
        ErrorCode::Schema,
        path,
        format!("{what} index {index} is out of range (there are {len})"),
        "fix the reference or add the missing object",
    )
}

/// The document's accessors and buffer views with their bytes, ready to read.
pub(crate) struct Reader<'a> {
    pub views: Vec<ViewLayout>,
    pub accessors: Vec<AccessorLayout>,
    pub buffers: &'a [Vec<u8>],
    pub limits: &'a DecodeLimits,
}

impl<'a> Reader<'a> {
    /// Parses and bounds-checks every buffer view and accessor (no data is read or allocated
    /// beyond the layouts themselves).
    pub(crate) fn new(
        root: &Value,
        buffers: &'a [Vec<u8>],
        limits: &'a DecodeLimits,
    ) -> Result<Self, GltfError> {
        let mut views = Vec::new();
        for (i, v) in array(root, "bufferViews").iter().enumerate() {
            let path = format!("/bufferViews/{i}");
            let buffer = required_u64(v, "buffer", &path)?;
            let byte_offset = field_u64(v, "byteOffset", &path)?.unwrap_or(0);
            let byte_length = required_u64(v, "byteLength", &path)?;
            let byte_stride = field_u64(v, "byteStride", &path)?;
            let data = buffers.get(buffer as usize).ok_or_else(|| {
                index_error(format!("{path}/buffer"), "buffer", buffer, buffers.len())
            })?;
            let end = byte_offset.checked_add(byte_length);
            if end.is_none_or(|end| end > data.len() as u64) {
                return Err(GltfError::new(
                    ErrorCode::BufferOutOfBounds,
                    format!("{path}/byteLength"),
                    format!(
                        "buffer view covers bytes {byte_offset}..{byte_offset}+{byte_length} but buffer \
                         {buffer} has {} bytes",
                        data.len()
                    ),
                    "re-export the asset; the buffer view reaches past its buffer",
                ));
            }
            if let Some(stride) = byte_stride {
                if !(4..=252).contains(&stride) {
                    return Err(GltfError::new(
                        ErrorCode::Schema,
                        format!("{path}/byteStride"),
                        format!("byteStride {stride} is outside 4..=252"),
                        "fix the exporter",
                    ));
                }
            }
            views.push(ViewLayout {
                buffer: buffer as usize,
                byte_offset,
                byte_length,
                byte_stride,
            });
        }
        let mut reader = Reader {
            views,
            accessors: Vec::new(),
            buffers,
            limits,
        };
        for (i, a) in array(root, "accessors").iter().enumerate() {
            let layout = reader.parse_accessor(i, a)?;
            reader.check_bounds(&layout)?;
            reader.accessors.push(layout);
        }
        Ok(reader)
    }

    fn parse_accessor(&self, index: usize, a: &Value) -> Result<AccessorLayout, GltfError> {
        let path = format!("/accessors/{index}");
        let buffer_view = field_u64(a, "bufferView", &path)?;
        if let Some(view) = buffer_view {
            if view as usize >= self.views.len() {
                return Err(index_error(
                    format!("{path}/bufferView"),
                    "bufferView",
                    view,
                    self.views.len(),
                ));
            }
        }
        let byte_offset = field_u64(a, "byteOffset", &path)?.unwrap_or(0);
        let ct_code = required_u64(a, "componentType", &path)?;
        let component_type = ComponentType::from_gl(ct_code).ok_or_else(|| {
            GltfError::new(
                ErrorCode::Schema,
                format!("{path}/componentType"),
                format!("componentType {ct_code} is not a glTF component type"),
                "use 5120, 5121, 5122, 5123, 5125 or 5126",
            )
        })?;
        let normalized = a
            .get("normalized")
            .and_then(Value::as_bool)
            .unwrap_or(false);
        let count = required_u64(a, "count", &path)?;
        let type_str = a.get("type").and_then(Value::as_str).unwrap_or("");
        let (kind, components): (&'static str, usize) = match type_str {
            "SCALAR" => ("SCALAR", 1),
            "VEC2" => ("VEC2", 2),
            "VEC3" => ("VEC3", 3),
            "VEC4" => ("VEC4", 4),
            "MAT2" => ("MAT2", 4),
            "MAT3" => ("MAT3", 9),
            "MAT4" => ("MAT4", 16),
            other => {
                return Err(GltfError::new(
                    ErrorCode::Schema,
                    format!("{path}/type"),
                    format!("accessor type `{other}` is not SCALAR, VECn or MATn"),
                    "fix the exporter",
                ))
            }
        };
        let size = component_type.size();
        let element_size = match kind {
            "MAT2" => 2 * (2 * size).div_ceil(4) * 4,
            "MAT3" => 3 * (3 * size).div_ceil(4) * 4,
            "MAT4" => 16 * size,
            _ => components * size,
        };
        let sparse = match a.get("sparse") {
            None => None,
            Some(s) => {
                let sp = format!("{path}/sparse");
                let sparse_count = required_u64(s, "count", &sp)?;
                let idx = s.get("indices").unwrap_or(&Value::Null);
                let vals = s.get("values").unwrap_or(&Value::Null);
                let ip = format!("{sp}/indices");
                let vp = format!("{sp}/values");
                let indices_view = required_u64(idx, "bufferView", &ip)?;
                let values_view = required_u64(vals, "bufferView", &vp)?;
                for (v, p) in [(indices_view, &ip), (values_view, &vp)] {
                    if v as usize >= self.views.len() {
                        return Err(index_error(
                            format!("{p}/bufferView"),
                            "bufferView",
                            v,
                            self.views.len(),
                        ));
                    }
                }
                let it = required_u64(idx, "componentType", &ip)?;
                let indices_type = match ComponentType::from_gl(it) {
                    Some(t @ (ComponentType::U8 | ComponentType::U16 | ComponentType::U32)) => t,
                    _ => {
                        return Err(GltfError::new(
                            ErrorCode::Schema,
                            format!("{ip}/componentType"),
                            format!("sparse indices componentType {it} must be 5121, 5123 or 5125"),
                            "fix the exporter",
                        ))
                    }
                };
                if sparse_count > count {
                    return Err(GltfError::new(
                        ErrorCode::AccessorOutOfBounds,
                        format!("{sp}/count"),
                        format!("sparse count {sparse_count} exceeds accessor count {count}"),
                        "fix the exporter",
                    ));
                }
                Some(SparseLayout {
                    count: sparse_count,
                    indices_view: indices_view as usize,
                    indices_offset: field_u64(idx, "byteOffset", &ip)?.unwrap_or(0),
                    indices_type,
                    values_view: values_view as usize,
                    values_offset: field_u64(vals, "byteOffset", &vp)?.unwrap_or(0),
                })
            }
        };
        Ok(AccessorLayout {
            index,
            buffer_view: buffer_view.map(|v| v as usize),
            byte_offset,
            component_type,
            normalized,
            count,
            kind,
            components,
            element_size,
            sparse,
        })
    }

    /// Checks that every byte the accessor reads lies inside its buffer view, and that an
    /// accessor without buffer view stays under the allocation cap.
    fn check_bounds(&self, a: &AccessorLayout) -> Result<(), GltfError> {
        let path = a.path();
        let packed_bytes = a.count.checked_mul(a.element_size as u64);
        if packed_bytes.is_none_or(|b| b > self.limits.max_accessor_bytes) {
            return Err(GltfError::new(
                ErrorCode::LimitExceeded,
                format!("{path}/count"),
                format!(
                    "accessor of {} {} elements needs more than the {}-byte limit per accessor",
                    a.count, a.kind, self.limits.max_accessor_bytes
                ),
                "split the mesh or raise DecodeLimits::max_accessor_bytes",
            ));
        }
        if let Some(view_index) = a.buffer_view {
            let view = &self.views[view_index];
            let stride = view.byte_stride.unwrap_or(a.element_size as u64);
            if stride < a.element_size as u64 {
                return Err(GltfError::new(
                    ErrorCode::AccessorOutOfBounds,
                    format!("/bufferViews/{view_index}/byteStride"),
                    format!(
                        "byteStride {stride} is smaller than the {}-byte elements of accessor {}",
                        a.element_size, a.index
                    ),
                    "fix the exporter",
                ));
            }
            let needed = if a.count == 0 {
                Some(a.byte_offset)
            } else {
                (a.count - 1)
                    .checked_mul(stride)
                    .and_then(|x| x.checked_add(a.byte_offset))
                    .and_then(|x| x.checked_add(a.element_size as u64))
            };
            if needed.is_none_or(|n| n > view.byte_length) {
                return Err(GltfError::new(
                    ErrorCode::AccessorOutOfBounds,
                    format!("{path}/count"),
                    format!(
                        "accessor reads {} elements of {} bytes (stride {stride}) from offset {} but \
                         buffer view {view_index} has {} bytes",
                        a.count, a.element_size, a.byte_offset, view.byte_length
                    ),
                    "re-export the asset; the accessor reaches past its buffer view",
                ));
            }
        }
        if let Some(s) = &a.sparse {
            let sp = format!("{path}/sparse");
            for (view_index, offset, size, which) in [
                (
                    s.indices_view,
                    s.indices_offset,
                    s.indices_type.size() as u64,
                    "indices",
                ),
                (
                    s.values_view,
                    s.values_offset,
                    a.element_size as u64,
                    "values",
                ),
            ] {
                let view = &self.views[view_index];
                let needed = s
                    .count
                    .checked_mul(size)
                    .and_then(|x| x.checked_add(offset));
                if needed.is_none_or(|n| n > view.byte_length) {
                    return Err(GltfError::new(
                        ErrorCode::AccessorOutOfBounds,
                        format!("{sp}/{which}"),
                        format!(
                            "sparse {which} need {} elements of {size} bytes from offset {offset} but \
                             buffer view {view_index} has {} bytes",
                            s.count, view.byte_length
                        ),
                        "re-export the asset",
                    ));
                }
            }
        }
        Ok(())
    }

    /// The accessor's layout, or a schema error at `ref_path`.
    pub(crate) fn layout(&self, index: u64, ref_path: &str) -> Result<&AccessorLayout, GltfError> {
        usize::try_from(index)
            .ok()
            .and_then(|i| self.accessors.get(i))
            .ok_or_else(|| {
                index_error(
                    ref_path.to_string(),
                    "accessor",
                    index,
                    self.accessors.len(),
                )
            })
    }

    fn view_bytes(&self, view_index: usize) -> &[u8] {
        let view = &self.views[view_index];
        // Bounds were checked in `new`.
        let start = view.byte_offset as usize;
        let end = start + view.byte_length as usize;
        self.buffers
            .get(view.buffer)
            .and_then(|b| b.get(start..end))
            .unwrap_or(&[])
    }

    /// The sparse indices of `a`, each checked `< count`.
    pub(crate) fn sparse_indices(&self, a: &AccessorLayout) -> Result<Vec<u64>, GltfError> {
        let Some(s) = &a.sparse else {
            return Ok(Vec::new());
        };
        let bytes = self.view_bytes(s.indices_view);
        let size = s.indices_type.size();
        let mut out = Vec::with_capacity(s.count as usize);
        for k in 0..s.count as usize {
            let at = s.indices_offset as usize + k * size;
            let raw = bytes.get(at..at + size).unwrap_or(&[]);
            let index = s.indices_type.raw(raw) as u64;
            if index >= a.count {
                return Err(GltfError::new(
                    ErrorCode::IndexOutOfRange,
                    format!("{}/sparse/indices", a.path()),
                    format!(
                        "sparse index #{k} is {index}, accessor count is {}",
                        a.count
                    ),
                    "fix the exporter",
                ));
            }
            out.push(index);
        }
        Ok(out)
    }

    /// Reads the accessor into `count × element_size` packed bytes, sparse substitution applied.
    /// Cost: one allocation of that size and one pass over the source bytes.
    pub(crate) fn read_packed(&self, a: &AccessorLayout) -> Result<Vec<u8>, GltfError> {
        let es = a.element_size;
        let total = a.count as usize * es; // bounded by max_accessor_bytes in `check_bounds`
        let mut out;
        match a.buffer_view {
            None => out = vec![0u8; total],
            Some(view_index) => {
                let bytes = self.view_bytes(view_index);
                let stride = self.views[view_index].byte_stride.unwrap_or(es as u64) as usize;
                let base = a.byte_offset as usize;
                if stride == es {
                    out = bytes.get(base..base + total).unwrap_or(&[]).to_vec();
                } else {
                    out = Vec::with_capacity(total);
                    for i in 0..a.count as usize {
                        let at = base + i * stride;
                        out.extend_from_slice(bytes.get(at..at + es).unwrap_or(&[]));
                    }
                }
                if out.len() != total {
                    return Err(GltfError::new(
                        ErrorCode::Internal,
                        a.path(),
                        "accessor bytes shorter than checked",
                        "report this bug",
                    ));
                }
            }
        }
        if let Some(s) = &a.sparse {
            let indices = self.sparse_indices(a)?;
            let values = self.view_bytes(s.values_view);
            for (k, &index) in indices.iter().enumerate() {
                let src = s.values_offset as usize + k * es;
                let dst = index as usize * es;
                if let (Some(from), Some(to)) =
                    (values.get(src..src + es), out.get_mut(dst..dst + es))
                {
                    to.copy_from_slice(from);
                }
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn reader<'a>(
        root: &Value,
        buffers: &'a [Vec<u8>],
        limits: &'a DecodeLimits,
    ) -> Result<Reader<'a>, GltfError> {
        Reader::new(root, buffers, limits)
    }

    #[test]
    fn strided_and_sparse_read_matches_hand_layout() {
        // Two interleaved VEC2 u16 values per 8-byte vertex; read the second one (offset 4),
        // then sparse-replace vertex 1 with (9, 9).
        let mut buf = Vec::new();
        for v in 0u16..3 {
            for x in [v, 100 + v, 200 + v, 300 + v] {
                buf.extend_from_slice(&x.to_le_bytes());
            }
        }
        let sparse_at = buf.len();
        buf.extend_from_slice(&1u16.to_le_bytes());
        buf.extend_from_slice(&[0, 0]);
        buf.extend_from_slice(&9u16.to_le_bytes());
        buf.extend_from_slice(&9u16.to_le_bytes());
        let root = json!({
            "bufferViews": [
                {"buffer": 0, "byteLength": 24, "byteStride": 8},
                {"buffer": 0, "byteOffset": sparse_at, "byteLength": 2},
                {"buffer": 0, "byteOffset": sparse_at + 4, "byteLength": 4}
            ],
            "accessors": [{
                "bufferView": 0, "byteOffset": 4, "componentType": 5123, "count": 3, "type": "VEC2",
                "sparse": {"count": 1, "indices": {"bufferView": 1, "componentType": 5123},
                           "values": {"bufferView": 2}}
            }]
        });
        let buffers = vec![buf];
        let limits = DecodeLimits::default();
        let r = reader(&root, &buffers, &limits).expect("valid");
        let packed = r.read_packed(&r.accessors[0]).expect("readable");
        let values: Vec<u16> = packed
            .chunks(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]))
            .collect();
        assert_eq!(values, vec![200, 300, 9, 9, 202, 302]);
    }

    #[test]
    fn accessor_past_view_and_view_past_buffer_are_rejected() {
        let limits = DecodeLimits::default();
        let buffers = vec![vec![0u8; 16]];
        let root = json!({
            "bufferViews": [{"buffer": 0, "byteLength": 16}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 2, "type": "VEC3"}]
        });
        let e = reader(&root, &buffers, &limits).err().expect("24 > 16");
        assert_eq!(
            (e.code, e.json_path.as_str()),
            (ErrorCode::AccessorOutOfBounds, "/accessors/0/count")
        );
        let root = json!({"bufferViews": [{"buffer": 0, "byteOffset": 8, "byteLength": 16}]});
        let e = reader(&root, &buffers, &limits).err().expect("24 > 16");
        assert_eq!(
            (e.code, e.json_path.as_str()),
            (ErrorCode::BufferOutOfBounds, "/bufferViews/0/byteLength")
        );
    }

    #[test]
    fn zero_accessor_is_capped_and_normalized_values_follow_the_spec() {
        let limits = DecodeLimits {
            max_accessor_bytes: 1000,
            ..DecodeLimits::default()
        };
        let root = json!({"accessors": [{"componentType": 5126, "count": 1_000_000_000u64, "type": "VEC3"}]});
        let e = reader(&root, &[], &limits).err().expect("too big");
        assert_eq!(e.code, ErrorCode::LimitExceeded);
        assert_eq!(ComponentType::I8.value(&[0x80], true), -1.0);
        assert_eq!(ComponentType::I8.value(&[127], true), 1.0);
        assert_eq!(ComponentType::U16.value(&[0xff, 0xff], true), 1.0);
        assert_eq!(ComponentType::I16.value(&[0x00, 0x80], false), -32768.0);
    }

    #[test]
    fn matrix_columns_are_padded() {
        let limits = DecodeLimits::default();
        let root = json!({"accessors": [
            {"componentType": 5121, "count": 1, "type": "MAT3"},
            {"componentType": 5122, "count": 1, "type": "MAT2"}
        ]});
        let r = reader(&root, &[], &limits).expect("valid");
        assert_eq!(r.accessors[0].element_size, 12);
        assert_eq!(r.accessors[0].component_offset(4), 5);
        assert_eq!(r.accessors[1].element_size, 8);
    }
}
