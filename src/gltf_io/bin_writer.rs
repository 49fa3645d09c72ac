//! The output BIN buffer of [`encode`](fn@super::encode): [`Output`] appends 4-byte-aligned
//! buffer views and their accessors (UVs, indices, gathered vertex attributes, with min/max
//! bounds) after the ones already in the document.
//!
//! References: glTF 2.0 spec §3.6.2.4 (data alignment), §3.6.2.5 (accessor bounds).
/// The growing BIN buffer and the views/accessors appended to the document.
#[derive(Default)]
pub(super) struct Output {
    pub(super) bin: Vec<u8>,
    pub(super) views: Vec<Value>,
    pub(super) accessors: Vec<Value>,
    /// Views/accessors already in the document (new ones are numbered after them).
    pub(super) view_count: usize,
    pub(super) accessor_count: usize,
}

use serde_json::{json, Map, Value};

use super::accessor::{AccessorLayout, ComponentType};

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

impl Output {
    pub(super) fn align(&mut self) {
        self.bin.resize(self.bin.len().div_ceil(4) * 4, 0);
    }

    pub(super) fn push_view(
        &mut self,
        bytes: &[u8],
        stride: Option<usize>,
        target: Option<u32>,
    ) -> usize {
        self.align();
        let mut view = Map::new();
        view.insert("buffer".into(), json!(0));
        view.insert("byteOffset".into(), json!(self.bin.len()));
        view.insert("byteLength".into(), json!(bytes.len()));
        if let Some(stride) = stride {
            view.insert("byteStride".into(), json!(stride));
        }
        if let Some(target) = target {
            view.insert("target".into(), json!(target));
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(Value::Object(view));
        self.view_count + self.views.len() - 1
    }

    pub(super) fn push_accessor(&mut self, accessor: Map<String, Value>) -> u64 {
        self.accessors.push(Value::Object(accessor));
        (self.accessor_count + self.accessors.len() - 1) as u64
    }

    /// Writes `source.len()` elements of `layout`, element `i` = source element `source[i]`.
    pub(super) fn push_gathered(
        &mut self,
        layout: &AccessorLayout,
        packed: &[u8],
        source: &[u32],
        with_bounds: bool,
        source_json: Option<&Value>,
    ) -> u64 {
        let es = layout.element_size;
        // Vertex attribute elements must start on 4-byte boundaries (spec §3.6.2.4).
        let stride = es.div_ceil(4) * 4;
        let mut data = Vec::with_capacity(source.len() * stride);
        for &s in source {
            let at = s as usize * es;
            data.extend_from_slice(packed.get(at..at + es).unwrap_or(&[]));
            data.resize(data.len().div_ceil(4) * 4, 0);
        }
        let view = self.push_view(&data, (stride != es).then_some(stride), Some(ARRAY_BUFFER));
        let mut accessor = Map::new();
        accessor.insert("bufferView".into(), json!(view));
        accessor.insert("componentType".into(), json!(layout.component_type.gl()));
        if layout.normalized {
            accessor.insert("normalized".into(), json!(true));
        }
        accessor.insert("count".into(), json!(source.len()));
        accessor.insert("type".into(), json!(layout.kind));
        if with_bounds && !source.is_empty() {
            if let Some((min, max)) = bounds(layout, &data, stride, source.len()) {
                accessor.insert("max".into(), Value::Array(max));
                accessor.insert("min".into(), Value::Array(min));
            }
        }
        for key in ["name", "extensions", "extras"] {
            if let Some(value) = source_json.and_then(|a| a.get(key)) {
                accessor.insert(key.into(), value.clone());
            }
        }
        self.push_accessor(accessor)
    }

    pub(super) fn push_uvs(&mut self, uvs: &[[f32; 2]]) -> u64 {
        let mut data = Vec::with_capacity(uvs.len() * 8);
        for uv in uvs {
            data.extend_from_slice(&uv[0].to_le_bytes());
            data.extend_from_slice(&uv[1].to_le_bytes());
        }
        let view = self.push_view(&data, None, Some(ARRAY_BUFFER));
        let mut accessor = Map::new();
        accessor.insert("bufferView".into(), json!(view));
        accessor.insert("componentType".into(), json!(ComponentType::F32.gl()));
        accessor.insert("count".into(), json!(uvs.len()));
        accessor.insert("type".into(), json!("VEC2"));
        self.push_accessor(accessor)
    }

    pub(super) fn push_indices(&mut self, indices: &[u32], vertex_count: usize) -> u64 {
        // 65535 is the primitive-restart value and must not appear in u16 indices.
        let (component, data) = if vertex_count <= 65535 {
            (
                ComponentType::U16,
                indices
                    .iter()
                    .flat_map(|&i| (i as u16).to_le_bytes())
                    .collect::<Vec<u8>>(),
            )
        } else {
            (
                ComponentType::U32,
                indices
                    .iter()
                    .flat_map(|&i| i.to_le_bytes())
                    .collect::<Vec<u8>>(),
            )
        };
        let view = self.push_view(&data, None, Some(ELEMENT_ARRAY_BUFFER));
        let mut accessor = Map::new();
        accessor.insert("bufferView".into(), json!(view));
        accessor.insert("componentType".into(), json!(component.gl()));
        accessor.insert("count".into(), json!(indices.len()));
        accessor.insert("type".into(), json!("SCALAR"));
        self.push_accessor(accessor)
    }
}

/// Per-component raw min and max (spec §3.6.2.5: `normalized` has no effect on them); `None`
/// when a component has no finite value (then no bounds are written).
fn bounds(
    layout: &AccessorLayout,
    data: &[u8],
    stride: usize,
    count: usize,
) -> Option<(Vec<Value>, Vec<Value>)> {
    let size = layout.component_type.size();
    let mut min = vec![f64::INFINITY; layout.components];
    let mut max = vec![f64::NEG_INFINITY; layout.components];
    for i in 0..count {
        for c in 0..layout.components {
            let at = i * stride + layout.component_offset(c);
            let v = layout
                .component_type
                .raw(data.get(at..at + size).unwrap_or(&[]));
            // NaN (possible in non-POSITION float attributes) is skipped, as the validator does.
            if v < min[c] {
                min[c] = v;
            }
            if v > max[c] {
                max[c] = v;
            }
        }
    }
    if !min.iter().chain(&max).all(|v| v.is_finite()) {
        return None;
    }
    let to_json = |v: f64| -> Value {
        if layout.component_type == ComponentType::F32 {
            json!(v)
        } else {
            json!(v as i64)
        }
    };
    Some((
        min.into_iter().map(to_json).collect(),
        max.into_iter().map(to_json).collect(),
    ))
}
