//! Test support for the `gltf_io` tests: a small glTF/GLB builder (to generate the cases the
//! corpus lacks) and an independent reader that expands every triangle primitive into
//! per-corner attribute bytes. The reader shares no code with `texatlas::gltf_io`, so round-trip
//! checks compare the crate against a second implementation (libigl-style).

use serde_json::{json, Map, Value};

/// Builds a glTF document and its one binary buffer.
pub struct Builder {
    pub json: Value,
    pub bin: Vec<u8>,
}

impl Default for Builder {
    fn default() -> Self {
        Builder::new()
    }
}

impl Builder {
    pub fn new() -> Self {
        Builder {
            json: json!({"asset": {"version": "2.0", "generator": "texatlas tests"}}),
            bin: Vec::new(),
        }
    }

    /// Appends `value` to the root array `key`, returning its index.
    pub fn push(&mut self, key: &str, value: Value) -> usize {
        let root = self.json.as_object_mut().expect("object");
        let array = root
            .entry(key)
            .or_insert_with(|| json!([]))
            .as_array_mut()
            .expect("array");
        array.push(value);
        array.len() - 1
    }

    /// Appends bytes (4-aligned) as a buffer view on buffer 0.
    pub fn view(&mut self, bytes: &[u8], stride: Option<usize>) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
        if let Some(stride) = stride {
            v["byteStride"] = json!(stride);
        }
        self.bin.extend_from_slice(bytes);
        self.push("bufferViews", v)
    }

    /// A tightly packed float accessor of `N` components with min/max.
    pub fn floats<const N: usize>(&mut self, data: &[[f32; N]]) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let view = self.view(&bytes, None);
        let mut min = [f32::INFINITY; N];
        let mut max = [f32::NEG_INFINITY; N];
        for e in data {
            for c in 0..N {
                min[c] = min[c].min(e[c]);
                max[c] = max[c].max(e[c]);
            }
        }
        let kind = ["", "SCALAR", "VEC2", "VEC3", "VEC4"][N];
        let mut a =
            json!({"bufferView": view, "componentType": 5126, "count": data.len(), "type": kind});
        if !data.is_empty() {
            a["min"] = json!(min.to_vec());
            a["max"] = json!(max.to_vec());
        }
        self.push("accessors", a)
    }

    /// A u16 or u32 index accessor.
    pub fn indices(&mut self, data: &[u32]) -> usize {
        let (ct, bytes): (u32, Vec<u8>) = if data.iter().all(|&i| i < 65535) {
            (
                5123,
                data.iter()
                    .flat_map(|&i| (i as u16).to_le_bytes())
                    .collect(),
            )
        } else {
            (5125, data.iter().flat_map(|&i| i.to_le_bytes()).collect())
        };
        let view = self.view(&bytes, None);
        self.push(
            "accessors",
            json!({"bufferView": view, "componentType": ct, "count": data.len(), "type": "SCALAR"}),
        )
    }

    /// The asset as GLB (one buffer: the BIN chunk).
    pub fn glb(&self) -> Vec<u8> {
        let mut json = self.json.clone();
        if !self.bin.is_empty() {
            json["buffers"] = json!([{"byteLength": self.bin.len()}]);
        }
        glb_bytes(&serde_json::to_vec(&json).expect("json"), &self.bin)
    }

    /// The asset as `.gltf` JSON whose buffer is the external file `uri`.
    pub fn gltf_external(&self, uri: &str) -> Vec<u8> {
        let mut json = self.json.clone();
        json["buffers"] = json!([{"uri": uri, "byteLength": self.bin.len()}]);
        serde_json::to_vec_pretty(&json).expect("json")
    }
}

/// Writes a GLB container around a JSON text and a BIN body.
pub fn glb_bytes(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let mut j = json.to_vec();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while b.len() % 4 != 0 {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + if b.is_empty() { 0 } else { 8 + b.len() };
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    if !b.is_empty() {
        out.extend_from_slice(&(b.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&b);
    }
    out
}

/// A parsed file: JSON and buffer bytes (only GLB BIN and base64 data: URIs are supported).
pub struct Doc {
    pub json: Value,
    pub buffers: Vec<Vec<u8>>,
}

pub fn parse(bytes: &[u8]) -> Doc {
    let (json, bin): (Value, Option<Vec<u8>>) = if bytes.starts_with(b"glTF") {
        let u = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4")) as usize;
        let json_len = u(12);
        let json = serde_json::from_slice(&bytes[20..20 + json_len]).expect("json chunk");
        let at = 20 + json_len;
        let bin = (at < bytes.len()).then(|| bytes[at + 8..at + 8 + u(at)].to_vec());
        (json, bin)
    } else {
        (serde_json::from_slice(bytes).expect("json"), None)
    };
    let mut buffers = Vec::new();
    for b in json["buffers"].as_array().cloned().unwrap_or_default() {
        let data = match b["uri"].as_str() {
            None => bin.clone().expect("BIN chunk"),
            Some(uri) => {
                use base64::Engine as _;
                let payload = uri.split_once(";base64,").expect("base64 data uri").1;
                base64::engine::general_purpose::STANDARD
                    .decode(payload)
                    .expect("base64")
            }
        };
        buffers.push(data);
    }
    Doc { json, buffers }
}

fn component_size(ct: u64) -> usize {
    match ct {
        5120 | 5121 => 1,
        5122 | 5123 => 2,
        _ => 4,
    }
}

fn element_size(kind: &str, ct: u64) -> usize {
    let s = component_size(ct);
    let pad = |n: usize| n.div_ceil(4) * 4;
    match kind {
        "SCALAR" => s,
        "VEC2" => 2 * s,
        "VEC3" => 3 * s,
        "VEC4" => 4 * s,
        "MAT2" => 2 * pad(2 * s),
        "MAT3" => 3 * pad(3 * s),
        "MAT4" => 16 * s,
        other => panic!("type {other}"),
    }
}

impl Doc {
    fn view_slice(&self, view: usize) -> (&[u8], Option<usize>) {
        let v = &self.json["bufferViews"][view];
        let buf = &self.buffers[v["buffer"].as_u64().expect("buffer") as usize];
        let off = v["byteOffset"].as_u64().unwrap_or(0) as usize;
        let len = v["byteLength"].as_u64().expect("len") as usize;
        (
            &buf[off..off + len],
            v["byteStride"].as_u64().map(|s| s as usize),
        )
    }

    /// Elements of accessor `i` as raw bytes (sparse applied).
    pub fn elements(&self, i: usize) -> Vec<Vec<u8>> {
        let a = &self.json["accessors"][i];
        let ct = a["componentType"].as_u64().expect("ct");
        let es = element_size(a["type"].as_str().expect("type"), ct);
        let count = a["count"].as_u64().expect("count") as usize;
        let mut out = vec![vec![0u8; es]; count];
        if let Some(view) = a["bufferView"].as_u64() {
            let (bytes, stride) = self.view_slice(view as usize);
            let stride = stride.unwrap_or(es);
            let off = a["byteOffset"].as_u64().unwrap_or(0) as usize;
            for (k, e) in out.iter_mut().enumerate() {
                e.copy_from_slice(&bytes[off + k * stride..off + k * stride + es]);
            }
        }
        if let Some(s) = a.get("sparse") {
            let n = s["count"].as_u64().expect("count") as usize;
            let ict = s["indices"]["componentType"].as_u64().expect("ct");
            let isz = component_size(ict);
            let (ib, _) = self.view_slice(s["indices"]["bufferView"].as_u64().expect("v") as usize);
            let ioff = s["indices"]["byteOffset"].as_u64().unwrap_or(0) as usize;
            let (vb, _) = self.view_slice(s["values"]["bufferView"].as_u64().expect("v") as usize);
            let voff = s["values"]["byteOffset"].as_u64().unwrap_or(0) as usize;
            for k in 0..n {
                let at = ioff + k * isz;
                let mut idx = [0u8; 4];
                idx[..isz].copy_from_slice(&ib[at..at + isz]);
                let index = u32::from_le_bytes(idx) as usize;
                out[index].copy_from_slice(&vb[voff + k * es..voff + (k + 1) * es]);
            }
        }
        out
    }

    /// Float values of accessor `i` (float accessors only).
    pub fn floats(&self, i: usize) -> Vec<Vec<f32>> {
        assert_eq!(self.json["accessors"][i]["componentType"], 5126);
        self.elements(i)
            .into_iter()
            .map(|e| {
                e.chunks(4)
                    .map(|c| f32::from_le_bytes(c.try_into().expect("4")))
                    .collect()
            })
            .collect()
    }

    /// The vertex index of every corner of every triangle of a primitive (mode 4, 5, 6), in the
    /// glTF spec's order.
    pub fn corners(&self, prim: &Value) -> Vec<[usize; 3]> {
        let n_vertices = self.json["accessors"]
            [prim["attributes"]["POSITION"].as_u64().expect("pos") as usize]["count"]
            .as_u64()
            .expect("count") as usize;
        let stream: Vec<usize> = match prim.get("indices").and_then(Value::as_u64) {
            None => (0..n_vertices).collect(),
            Some(i) => self
                .elements(i as usize)
                .into_iter()
                .map(|e| {
                    let mut b = [0u8; 4];
                    b[..e.len()].copy_from_slice(&e);
                    u32::from_le_bytes(b) as usize
                })
                .collect(),
        };
        let n = stream.len();
        match prim.get("mode").and_then(Value::as_u64).unwrap_or(4) {
            4 => stream.chunks(3).map(|c| [c[0], c[1], c[2]]).collect(),
            5 => (0..n.saturating_sub(2))
                .map(|i| [stream[i], stream[i + 1 + i % 2], stream[i + 2 - i % 2]])
                .collect(),
            6 => (0..n.saturating_sub(2))
                .map(|i| [stream[i + 1], stream[i + 2], stream[0]])
                .collect(),
            m => panic!("mode {m}"),
        }
    }

    /// Per-corner element bytes of every attribute (`"NAME"`) and morph-target attribute
    /// (`"target{t}/NAME"`) of a primitive.
    pub fn corner_attributes(&self, prim: &Value) -> Map<String, Value> {
        let corners = self.corners(prim);
        let mut out = Map::new();
        let mut add = |key: String, accessor: usize| {
            let elements = self.elements(accessor);
            let per_corner: Vec<Value> = corners
                .iter()
                .flatten()
                .map(|&v| json!(elements[v].clone()))
                .collect();
            out.insert(key, Value::Array(per_corner));
        };
        for (name, a) in prim["attributes"].as_object().expect("attributes") {
            add(name.clone(), a.as_u64().expect("index") as usize);
        }
        for (t, target) in prim["targets"]
            .as_array()
            .cloned()
            .unwrap_or_default()
            .iter()
            .enumerate()
        {
            for (name, a) in target.as_object().expect("target") {
                add(
                    format!("target{t}/{name}"),
                    a.as_u64().expect("index") as usize,
                );
            }
        }
        out
    }
}

/// A generated asset with what the corpus lacks: interleaving, sparse (with and without a
/// buffer view), quantized and normalized integers, a custom attribute, colours, joints and
/// weights, morph targets, instancing, points/lines, a strip with indices, unknown extensions
/// and extras at every level, a skin and an animation that reference accessors.
pub fn kitchen_sink() -> Builder {
    let mut b = Builder::new();
    let ext = |tag: &str| json!({"EXT_unknown_thing": {"tag": tag, "nested": {"list": [1, 2.5, null, {"deep": true}]}}});
    let extras = |tag: &str| json!({"note": tag, "ids": [7, 8]});

    // Mesh 0: 3x3 grid, 8 triangles, u8 indices.
    let mut interleaved = Vec::new();
    let mut positions = Vec::new();
    for j in 0..3 {
        for i in 0..3 {
            let p = [i as f32, j as f32, 0.1 * (i * j) as f32];
            positions.push(p);
            for x in p.iter().chain(&[0.0f32, 0.0, 1.0]) {
                interleaved.extend_from_slice(&x.to_le_bytes());
            }
        }
    }
    let iv = b.view(&interleaved, Some(24));
    let min = [0.0f32, 0.0, 0.0];
    let max = [2.0f32, 2.0, 0.4];
    let pos = b.push("accessors", json!({"bufferView": iv, "componentType": 5126, "count": 9, "type": "VEC3", "min": min, "max": max, "extras": extras("pos"), "extensions": ext("accessor")}));
    let nrm = b.push("accessors", json!({"bufferView": iv, "byteOffset": 12, "componentType": 5126, "count": 9, "type": "VEC3"}));
    let uv0: Vec<u8> = (0..9u16)
        .flat_map(|v| [v * 7000, 65535 - v * 3000])
        .flat_map(u16::to_le_bytes)
        .collect();
    let uvv = b.view(&uv0, None);
    let tex0 = b.push("accessors", json!({"bufferView": uvv, "componentType": 5123, "normalized": true, "count": 9, "type": "VEC2"}));
    let colors: Vec<u8> = (0..9u8).flat_map(|v| [v * 20, 255 - v, v, 255]).collect();
    let cv = b.view(&colors, None);
    let sparse_idx = b.view(&[2u8, 7], None);
    let sparse_val = b.view(&[1u8, 2, 3, 4, 5, 6, 7, 8], None);
    let color0 = b.push("accessors", json!({"bufferView": cv, "componentType": 5121, "normalized": true, "count": 9, "type": "VEC4",
        "sparse": {"count": 2, "indices": {"bufferView": sparse_idx, "componentType": 5121}, "values": {"bufferView": sparse_val}}}));
    let sparse_idx1 = b.view(
        &[1u16.to_le_bytes(), 4u16.to_le_bytes(), 8u16.to_le_bytes()].concat(),
        None,
    );
    let sparse_val1 = b.view(&[200u8, 100, 50, 1, 2, 3, 9, 9, 9], None);
    let color1 = b.push("accessors", json!({"componentType": 5121, "normalized": true, "count": 9, "type": "VEC3",
        "sparse": {"count": 3, "indices": {"bufferView": sparse_idx1, "componentType": 5123}, "values": {"bufferView": sparse_val1}}}));
    // 2-byte elements at a 4-byte stride, as vertex attributes must be.
    let custom_bytes: Vec<u8> = (0..9u16)
        .flat_map(|v| (1000 + v).to_le_bytes().into_iter().chain([0, 0]))
        .collect();
    let fv = b.view(&custom_bytes, Some(4));
    let custom = b.push(
        "accessors",
        json!({"bufferView": fv, "componentType": 5123, "count": 9, "type": "SCALAR"}),
    );
    let joints: Vec<u8> = (0..9u8).flat_map(|_| [0, 1, 0, 0]).collect();
    let jv = b.view(&joints, None);
    let joints = b.push(
        "accessors",
        json!({"bufferView": jv, "componentType": 5121, "count": 9, "type": "VEC4"}),
    );
    let weights: Vec<[f32; 4]> = (0..9)
        .map(|v| [0.5 + v as f32 * 0.05, 0.5 - v as f32 * 0.05, 0.0, 0.0])
        .collect();
    let weights = b.floats(&weights);
    let t0_idx = b.view(&[0u8, 4, 8, 0], None);
    let t0_val_data: Vec<u8> = [[0.0f32, 0.0, 1.0], [0.0, 0.5, 0.5], [1.0, 0.0, 0.0]]
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let t0_val = b.view(&t0_val_data, None);
    let target0_pos = b.push("accessors", json!({"componentType": 5126, "count": 9, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [1.0, 0.5, 1.0],
        "sparse": {"count": 3, "indices": {"bufferView": t0_idx, "componentType": 5121}, "values": {"bufferView": t0_val}}}));
    let target0_nrm = b.floats(
        &(0..9)
            .map(|v| [0.0f32, 0.01 * v as f32, 0.0])
            .collect::<Vec<_>>(),
    );
    let target1_pos = b.floats(
        &(0..9)
            .map(|v| [0.1 * v as f32, 0.0, 0.0])
            .collect::<Vec<_>>(),
    );
    let idx: Vec<u8> = vec![
        0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4, 3, 4, 7, 3, 7, 6, 4, 5, 8, 4, 8, 7,
    ];
    let iv8 = b.view(&idx, None);
    let indices = b.push(
        "accessors",
        json!({"bufferView": iv8, "componentType": 5121, "count": 24, "type": "SCALAR"}),
    );
    b.push("meshes", json!({
        "name": "sink",
        "weights": [0.5, 0.25],
        "primitives": [{
            "attributes": {"POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": tex0, "COLOR_0": color0, "COLOR_1": color1,
                           "_FOO": custom, "JOINTS_0": joints, "WEIGHTS_0": weights},
            "indices": indices,
            "material": 0,
            "targets": [{"POSITION": target0_pos, "NORMAL": target0_nrm}, {"POSITION": target1_pos}],
            "extensions": ext("primitive"),
            "extras": extras("primitive")
        }],
        "extensions": ext("mesh"),
        "extras": extras("mesh")
    }));

    // Mesh 1: quantized positions (i16 normalized, 6-byte elements at stride 8), a fan.
    let q: Vec<[i16; 3]> = vec![
        [0, 0, 0],
        [32767, 0, 0],
        [20000, 20000, 0],
        [0, 32767, 0],
        [-32767, 100, 5],
    ];
    let qbytes: Vec<u8> = q
        .iter()
        .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes()).chain([0, 0]))
        .collect();
    let qv = b.view(&qbytes, Some(8));
    let qpos = b.push("accessors", json!({"bufferView": qv, "componentType": 5122, "normalized": true, "count": 5, "type": "VEC3",
        "min": [-32767, 0, 0], "max": [32767, 32767, 5]}));
    b.push(
        "meshes",
        json!({"name": "quantized", "primitives": [{"attributes": {"POSITION": qpos}, "mode": 6}]}),
    );

    // Mesh 2: points, lines, and a strip with u32 indices.
    let ppos = b.floats(&[
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.5],
    ]);
    let line_idx = b.indices(&[0, 1, 1, 3]);
    let strip_bytes: Vec<u8> = [0u32, 1, 2, 3]
        .iter()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    let sv = b.view(&strip_bytes, None);
    let strip_idx = b.push(
        "accessors",
        json!({"bufferView": sv, "componentType": 5125, "count": 4, "type": "SCALAR"}),
    );
    b.push("meshes", json!({"name": "mixed", "primitives": [
        {"attributes": {"POSITION": ppos}, "mode": 0},
        {"attributes": {"POSITION": ppos}, "indices": line_idx, "mode": 1, "extras": extras("lines")},
        {"attributes": {"POSITION": ppos}, "indices": strip_idx, "mode": 5}
    ]}));

    // Skin and animation referencing accessors that encode must not renumber.
    let ibm: Vec<[f32; 4]> = vec![
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let ibm_bytes: Vec<u8> = ibm
        .iter()
        .chain(&ibm)
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let ibmv = b.view(&ibm_bytes, None);
    let ibm = b.push(
        "accessors",
        json!({"bufferView": ibmv, "componentType": 5126, "count": 2, "type": "MAT4"}),
    );
    let times = b.floats(&[[0.0f32], [1.0]]);
    let values = b.floats(&[[0.0f32, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    b.push("materials", json!({"name": "m", "pbrMetallicRoughness": {"baseColorFactor": [1, 0.5, 0.25, 1]},
        "extensions": {"KHR_materials_sheen": {"sheenRoughnessFactor": 0.5}, "EXT_unknown_thing": {"a": 1}}, "extras": extras("material")}));
    b.push("nodes", json!({"name": "sink-a", "mesh": 0, "skin": 0, "extensions": ext("node"), "extras": extras("node")}));
    b.push("nodes", json!({"name": "sink-b", "mesh": 0, "skin": 0}));
    b.push(
        "nodes",
        json!({"name": "quantized", "mesh": 1, "scale": [0.001, 0.001, 0.001]}),
    );
    b.push("nodes", json!({"name": "mixed", "mesh": 2, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 5, 0, 0, 1]}));
    b.push("nodes", json!({"name": "joint0", "children": [5]}));
    b.push("nodes", json!({"name": "joint1"}));
    b.push("nodes", json!({"name": "root", "children": [2, 3, 4]}));
    b.push(
        "skins",
        json!({"joints": [4, 5], "inverseBindMatrices": ibm, "extras": extras("skin")}),
    );
    b.push(
        "animations",
        json!({"channels": [{"sampler": 0, "target": {"node": 4, "path": "translation"}}],
        "samplers": [{"input": times, "output": values}]}),
    );
    b.push(
        "scenes",
        json!({"nodes": [0, 1, 6], "extensions": ext("scene")}),
    );
    b.json["scene"] = json!(0);
    b.json["extensionsUsed"] = json!([
        "EXT_unknown_thing",
        "KHR_mesh_quantization",
        "KHR_materials_sheen"
    ]);
    b.json["extensionsRequired"] = json!(["KHR_mesh_quantization"]);
    b.json["extensions"] = ext("root");
    b.json["extras"] = extras("root");
    b
}

/// A GLB with one glTF mesh (one indexed triangle primitive, POSITION only) per part, one node
/// per mesh.
pub fn glb_of_meshes(parts: &[texatlas::mesh::MeshInput]) -> Vec<u8> {
    let mut b = Builder::new();
    let mut nodes = Vec::new();
    for part in parts {
        let pos: Vec<[f32; 3]> = part
            .positions_m
            .iter()
            .map(|p| p.map(|x| x as f32))
            .collect();
        let pa = b.floats(&pos);
        let idx: Vec<u32> = part.triangles.iter().flatten().copied().collect();
        let ia = b.indices(&idx);
        let m = b.push(
            "meshes",
            json!({"primitives": [{"attributes": {"POSITION": pa}, "indices": ia, "mode": 4}]}),
        );
        nodes.push(b.push("nodes", json!({ "mesh": m })));
    }
    b.push("scenes", json!({ "nodes": nodes }));
    b.glb()
}

/// Seam-creating test UVs: a per-vertex UV, shifted by (0.25, 0) on every third face, so some
/// edges are seams and the rest share UVs.
pub fn test_uvs(asset: &texatlas::gltf_io::Asset) -> Vec<[[f32; 2]; 3]> {
    asset
        .mesh_input()
        .triangles
        .iter()
        .enumerate()
        .map(|(f, t)| {
            t.map(|v| {
                let base = [(v as f32 * 0.618_034) % 1.0, (v as f32 * 0.377_1) % 1.0];
                if f % 3 == 0 {
                    [base[0] * 0.5 + 0.25, base[1]]
                } else {
                    base
                }
            })
        })
        .collect()
}

/// Removes every `EXT_unknown_thing` extension object from a tree, so old vertex data can be
/// dropped.
pub fn strip_unknown(value: &mut Value) {
    match value {
        Value::Object(map) => {
            if let Some(Value::Object(exts)) = map.get_mut("extensions") {
                exts.remove("EXT_unknown_thing");
                if exts.is_empty() {
                    map.remove("extensions");
                }
            }
            map.values_mut().for_each(strip_unknown);
        }
        Value::Array(items) => items.iter_mut().for_each(strip_unknown),
        _ => {}
    }
}

/// A GLB of a generated torus (several charts, enough work for rayon to split), no UVs
/// (`mesh::fixtures::torus`).
pub fn torus_glb() -> Vec<u8> {
    glb_of_meshes(&[texatlas::mesh::fixtures::torus(48, 24, 2.0, 0.6)])
}

/// The `n` of every `TEXCOORD_n` attribute of a primitive, ascending.
pub fn texcoord_sets(prim: &Value) -> Vec<u32> {
    let mut sets: Vec<u32> = prim["attributes"]
        .as_object()
        .into_iter()
        .flatten()
        .filter_map(|(name, _)| name.strip_prefix("TEXCOORD_")?.parse().ok())
        .collect();
    sets.sort_unstable();
    sets
}

/// Checks the UV sets of one rewritten primitive (`dst`) against its source (`src`), with the
/// atlas in `TEXCOORD_k`: the output sets are `0..n` without a gap; every attribute name of the
/// source is still there; the only new names are `TEXCOORD_k` and the `TEXCOORD_j` (`j < k`)
/// the source lacked, and each of those points at the very accessor of `TEXCOORD_k` (no copy).
pub fn assert_one_atlas_set(src: &Value, dst: &Value, k: u32, tag: &str) {
    let sets = texcoord_sets(dst);
    assert_eq!(
        sets,
        (0..sets.len() as u32).collect::<Vec<_>>(),
        "{tag}: TEXCOORD sets must start at 0 and be continuous"
    );
    let atlas = &dst["attributes"][format!("TEXCOORD_{k}")];
    assert!(atlas.is_u64(), "{tag}: TEXCOORD_{k} written");
    let before = src["attributes"].as_object().expect("attributes");
    let after = dst["attributes"].as_object().expect("attributes");
    for name in before.keys() {
        assert!(after.contains_key(name), "{tag}: {name} lost");
    }
    for (name, accessor) in after {
        if before.contains_key(name) || *name == format!("TEXCOORD_{k}") {
            continue;
        }
        let j: u32 = name
            .strip_prefix("TEXCOORD_")
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("{tag}: unexpected new attribute {name}"));
        assert!(j < k, "{tag}: new set {name} above the atlas set {k}");
        assert_eq!(
            accessor, atlas,
            "{tag}: gap-filling {name} must share the atlas accessor"
        );
    }
}
