//! Test support for the `gltf_io` tests: a small glTF/GLB builder (to generate the cases the
//! corpus lacks) and an independent reader that expands every triangle primitive into
//! per-corner attribute bytes. The reader shares no code with `texatlas::gltf_io`, so round-trip
//! checks compare the crate against a second implementation (libigl-style).
#![allow(dead_code)]

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
