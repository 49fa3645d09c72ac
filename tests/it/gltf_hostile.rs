//! Hostile inputs: every one gives a typed error naming the fault (code + JSON path), never a
//! panic, a hang, or an allocation beyond the limits. `decode` turns a panic into
//! `ErrorCode::Internal`, so "no panic" is asserted as "never Internal".
use crate::common::fixture;
use crate::common::gltf as gltf_common;

use gltf_common::{glb_bytes, Builder};
use serde_json::json;
use texatlas::gltf_io::{
    decode, encode, Asset, DecodeLimits, EncodeOptions, ErrorCode, GltfError, Resources,
};

fn run(bytes: &[u8]) -> Result<Asset, GltfError> {
    decode(bytes, &Resources::new(), &DecodeLimits::default())
}

fn expect_err(bytes: &[u8], code: ErrorCode, path: &str) -> GltfError {
    let err = run(bytes)
        .err()
        .unwrap_or_else(|| panic!("expected {code} at {path}, got Ok"));
    assert_eq!((err.code, err.json_path.as_str()), (code, path), "{err}");
    assert!(!err.fix.is_empty());
    err
}

/// A valid one-triangle asset to corrupt.
fn triangle() -> Builder {
    let mut b = Builder::new();
    let pos = b.floats(&[[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let idx = b.indices(&[0, 1, 2]);
    b.push(
        "meshes",
        json!({"primitives": [{"attributes": {"POSITION": pos}, "indices": idx}]}),
    );
    b.push("nodes", json!({"mesh": 0}));
    b
}

#[test]
fn the_valid_triangle_decodes() {
    let asset = run(&triangle().glb()).expect("valid");
    assert_eq!(asset.mesh_input().triangles, vec![[0, 1, 2]]);
}

#[test]
fn every_prefix_of_a_small_glb_is_an_error_not_a_panic() {
    let glb = fixture("Box.glb");
    for n in 0..glb.len() {
        let err = run(&glb[..n])
            .err()
            .unwrap_or_else(|| panic!("prefix {n} decoded"));
        assert_ne!(err.code, ErrorCode::Internal, "prefix {n}: {err}");
    }
    assert!(run(&glb).is_ok());
}

#[test]
fn random_byte_flips_never_panic() {
    // Seeded xorshift: deterministic, no dependency.
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for name in [
        "Box.glb",
        "AnimatedMorphCube.glb",
        "SimpleSparseAccessor.glb",
        "Mesh_PrimitiveMode_05_fan.glb",
    ] {
        let original = fixture(name);
        let mut ok = 0;
        for _ in 0..1500 {
            let mut bytes = original.clone();
            for _ in 0..1 + next() % 4 {
                let at = (next() % bytes.len() as u64) as usize;
                bytes[at] ^= 1 << (next() % 8);
            }
            match run(&bytes) {
                Ok(asset) => {
                    ok += 1;
                    // What decodes must also encode without panicking.
                    let uvs = vec![[[0.25f32, 0.5]; 3]; asset.mesh_input().triangles.len()];
                    match encode(&asset, &uvs, &EncodeOptions::default()) {
                        // Whatever we write, we can read back.
                        Ok(out) => {
                            assert!(run(&out.bytes).is_ok(), "{name}: output does not decode")
                        }
                        Err(e) => assert_ne!(e.code, ErrorCode::Internal, "{name}: {e}"),
                    }
                }
                Err(e) => assert_ne!(e.code, ErrorCode::Internal, "{name}: {e}"),
            }
        }
        // Flips in float payloads still decode; the loop must exercise both paths.
        assert!(ok > 0 && ok < 1500, "{name}: {ok} of 1500 decoded");
    }
}

#[test]
fn container_faults() {
    let glb = triangle().glb();
    let mut bad = glb.clone();
    bad[0..4].copy_from_slice(b"glTX");
    expect_err(&bad, ErrorCode::NotGltf, "");
    expect_err(b"", ErrorCode::NotGltf, "");
    expect_err(b"\x00\x01garbage", ErrorCode::NotGltf, "");
    // Header length below 12: the input that panics gltf 1.4.1 (kept as a regression test).
    let mut bad = glb.clone();
    bad[8..12].copy_from_slice(&3u32.to_le_bytes());
    expect_err(&bad, ErrorCode::GlbContainer, "");
    // Header length past the end of the file.
    let mut bad = glb.clone();
    bad[8..12].copy_from_slice(&(glb.len() as u32 + 4).to_le_bytes());
    expect_err(&bad, ErrorCode::GlbContainer, "");
    // JSON chunk length past the end.
    let mut bad = glb.clone();
    bad[12..16].copy_from_slice(&0x7FFF_FFF0u32.to_le_bytes());
    let err = expect_err(&bad, ErrorCode::GlbContainer, "");
    assert!(err.detail.contains("past the end"), "{}", err.detail);
    let mut bad = glb.clone();
    bad[4] = 1;
    expect_err(&bad, ErrorCode::GlbVersion, "");
}

#[test]
fn json_faults() {
    expect_err(&glb_bytes(b"{\"asset\": ", &[]), ErrorCode::JsonSyntax, "");
    expect_err(b"[1, 2]", ErrorCode::NotGltf, "");
    expect_err(
        br#"{"asset": {"version": "1.0"}}"#,
        ErrorCode::AssetVersion,
        "/asset/version",
    );
    expect_err(br#"{"meshes": []}"#, ErrorCode::Schema, "/asset/version");
    // Deep nesting inside extras: serde_json's recursion limit, surfaced as its own code.
    let mut deep = String::from(r#"{"asset": {"version": "2.0"}, "extras": "#);
    deep.push_str(&"[".repeat(100_000));
    deep.push_str(&"]".repeat(100_000));
    deep.push('}');
    expect_err(deep.as_bytes(), ErrorCode::JsonTooDeep, "");
    // A reference to a missing object, reported by the schema check with its path.
    let mut b = triangle();
    b.json["nodes"][0]["mesh"] = json!(5);
    expect_err(&b.glb(), ErrorCode::Schema, "/nodes/0/mesh");
}

#[test]
fn accessor_past_its_buffer_and_index_out_of_range() {
    let mut b = triangle();
    b.json["accessors"][0]["count"] = json!(4);
    expect_err(
        &b.glb(),
        ErrorCode::AccessorOutOfBounds,
        "/accessors/0/count",
    );
    let mut b = triangle();
    b.json["bufferViews"][0]["byteLength"] = json!(4096);
    expect_err(
        &b.glb(),
        ErrorCode::BufferOutOfBounds,
        "/bufferViews/0/byteLength",
    );
    let mut b = triangle();
    let idx = b.indices(&[0, 1, 3]);
    b.json["meshes"][0]["primitives"][0]["indices"] = json!(idx);
    let err = expect_err(
        &b.glb(),
        ErrorCode::IndexOutOfRange,
        "/meshes/0/primitives/0/indices",
    );
    assert!(err.detail.contains("is 3"), "{}", err.detail);
    let mut b = triangle();
    let bad_normals = b.floats(&[[0.0f32, 0.0, 1.0]]);
    b.json["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(bad_normals);
    expect_err(
        &b.glb(),
        ErrorCode::PrimitiveInvalid,
        "/meshes/0/primitives/0/attributes/NORMAL",
    );
    // A sparse index past the accessor's count.
    let mut b = triangle();
    let si = b.view(&[7u8, 0, 0, 0], None);
    let sv = b.view(&[0u8; 12], None);
    b.json["accessors"][0]["sparse"] = json!({"count": 1, "indices": {"bufferView": si, "componentType": 5121}, "values": {"bufferView": sv}});
    expect_err(
        &b.glb(),
        ErrorCode::IndexOutOfRange,
        "/accessors/0/sparse/indices",
    );
    // Two indices do not make a triangle list.
    let mut b = triangle();
    let idx = b.indices(&[0, 1]);
    b.json["meshes"][0]["primitives"][0]["indices"] = json!(idx);
    expect_err(
        &b.glb(),
        ErrorCode::PrimitiveInvalid,
        "/meshes/0/primitives/0/indices",
    );
}

#[test]
fn nan_position_is_named() {
    let mut b = Builder::new();
    let pos = b.floats(&[[0.0f32, 0.0, 0.0], [1.0, f32::NAN, 0.0], [0.0, 1.0, 0.0]]);
    // `floats` wrote NaN into min/max; replace them with finite bounds so only the data is bad.
    b.json["accessors"][pos]["min"] = json!([0.0, 0.0, 0.0]);
    b.json["accessors"][pos]["max"] = json!([1.0, 1.0, 0.0]);
    b.push(
        "meshes",
        json!({"primitives": [{"attributes": {"POSITION": pos}}]}),
    );
    let err = expect_err(&b.glb(), ErrorCode::NonFinitePosition, "/accessors/0");
    assert!(err.detail.contains("vertex 1"), "{}", err.detail);
}

#[test]
fn forbidden_and_missing_uris() {
    let b = triangle();
    let mut everything = Resources::new();
    for uri in [
        "../../etc/passwd",
        "file:///etc/passwd",
        "http://127.0.0.1:1/",
        "/etc/passwd",
        "a/../../b.bin",
    ] {
        // Even a caller that would supply these bytes is not asked: the URI is refused first.
        everything.insert(uri, b.bin.clone());
        let err =
            decode(&b.gltf_external(uri), &everything, &DecodeLimits::default()).expect_err(uri);
        assert_eq!(
            (err.code, err.json_path.as_str()),
            (ErrorCode::UriForbidden, "/buffers/0/uri"),
            "{uri}"
        );
        assert!(err.detail.contains(uri), "{}", err.detail);
    }
    for uri in ["../x.bin", "file:///etc/passwd"] {
        let err = texatlas::gltf_io::required_resources(&b.gltf_external(uri)).expect_err(uri);
        assert_eq!(
            (err.code, err.json_path.as_str()),
            (ErrorCode::UriForbidden, "/buffers/0/uri")
        );
    }
    let err = decode(
        &b.gltf_external("scene.bin"),
        &Resources::new(),
        &DecodeLimits::default(),
    )
    .expect_err("missing");
    assert_eq!(
        (err.code, err.json_path.as_str()),
        (ErrorCode::ResourceMissing, "/buffers/0/uri")
    );
    // Images are held to the same rules.
    let mut with_image = triangle();
    with_image.push("images", json!({"uri": "http://127.0.0.1:1/x.png"}));
    expect_err(&with_image.glb(), ErrorCode::UriForbidden, "/images/0/uri");
    let mut with_image = triangle();
    with_image.push("images", json!({"uri": "data:image/png,notbase64"}));
    expect_err(
        &with_image.glb(),
        ErrorCode::DataUriInvalid,
        "/images/0/uri",
    );
}

#[test]
fn huge_declared_sizes_are_rejected_before_allocation() {
    // 4 GiB declared buffer, 100-odd real bytes.
    let mut b = triangle();
    let mut json = b.json.clone();
    json["buffers"] = json!([{"byteLength": 4_294_967_296u64}]);
    let glb = glb_bytes(&serde_json::to_vec(&json).expect("json"), &b.bin);
    expect_err(&glb, ErrorCode::BufferOutOfBounds, "/buffers/0/byteLength");
    // An accessor without buffer view claims 2^40 elements.
    b.push(
        "accessors",
        json!({"componentType": 5126, "count": 1_099_511_627_776u64, "type": "VEC3"}),
    );
    expect_err(&b.glb(), ErrorCode::LimitExceeded, "/accessors/2/count");
    // Triangle and vertex limits.
    let limits = DecodeLimits {
        max_triangles: Some(0),
        ..DecodeLimits::default()
    };
    let err = decode(&triangle().glb(), &Resources::new(), &limits).expect_err("limit");
    assert_eq!(
        (err.code, err.json_path.as_str()),
        (ErrorCode::LimitExceeded, "/meshes/0/primitives/0")
    );
    let limits = DecodeLimits {
        max_vertices: Some(2),
        ..DecodeLimits::default()
    };
    let err = decode(&triangle().glb(), &Resources::new(), &limits).expect_err("limit");
    assert_eq!(err.code, ErrorCode::LimitExceeded);
    // No limit means no limit.
    let limits = DecodeLimits {
        max_vertices: None,
        max_triangles: None,
        ..DecodeLimits::default()
    };
    assert!(decode(&triangle().glb(), &Resources::new(), &limits).is_ok());
}

#[test]
fn node_cycles_and_shared_children_are_rejected() {
    let mut b = triangle();
    b.push("nodes", json!({"children": [2]}));
    b.push("nodes", json!({"children": [1]}));
    let err = expect_err(&b.glb(), ErrorCode::NodeHierarchy, "/nodes/1/children");
    assert!(err.detail.contains("cycle"), "{}", err.detail);
    let mut b = triangle();
    b.json["nodes"][0]["children"] = json!([0]);
    expect_err(&b.glb(), ErrorCode::NodeHierarchy, "/nodes/0/children");
    let mut b = triangle();
    b.push("nodes", json!({"children": [0]}));
    b.push("nodes", json!({"children": [0]}));
    expect_err(&b.glb(), ErrorCode::NodeHierarchy, "/nodes/2/children/0");
    // A long chain is fine (and checked in linear time).
    let mut b = triangle();
    for i in 1..5000 {
        b.push("nodes", json!({"children": [i - 1]}));
    }
    assert!(run(&b.glb()).is_ok());
}

#[test]
fn mesh_compression_is_refused_by_name() {
    for (key, name) in [
        ("extensionsRequired", "KHR_draco_mesh_compression"),
        ("extensionsUsed", "EXT_meshopt_compression"),
    ] {
        let mut b = triangle();
        b.json["extensionsUsed"] = json!([name]);
        if key == "extensionsRequired" {
            b.json["extensionsRequired"] = json!([name]);
        }
        let err = expect_err(
            &b.glb(),
            ErrorCode::UnsupportedExtension,
            &format!("/{key}/0"),
        );
        assert!(err.detail.contains(name) && err.fix.contains(name), "{err}");
    }
    // Unknown extensions, even required ones, are carried, not refused.
    let mut b = triangle();
    b.json["extensionsUsed"] = json!(["EXT_never_heard_of"]);
    b.json["extensionsRequired"] = json!(["EXT_never_heard_of"]);
    assert!(run(&b.glb()).is_ok());
}

#[test]
fn triangle_primitive_without_position_is_named() {
    let mut b = triangle();
    b.json["meshes"][0]["primitives"][0]["attributes"] = json!({"NORMAL": 0});
    expect_err(
        &b.glb(),
        ErrorCode::PrimitiveInvalid,
        "/meshes/0/primitives/0/attributes",
    );
}

#[test]
fn position_index_out_of_range_is_a_schema_error() {
    // Regression: found by `random_byte_flips_never_panic`; gltf-json 1.4.1's validation
    // indexes `accessors[POSITION]` unchecked and panicked on this input.
    let mut b = triangle();
    b.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(2);
    expect_err(
        &b.glb(),
        ErrorCode::Schema,
        "/meshes/0/primitives/0/attributes/POSITION",
    );
    let mut b = triangle();
    b.json["meshes"][0]["primitives"][0]["targets"] = json!([{"POSITION": 99}]);
    expect_err(
        &b.glb(),
        ErrorCode::Schema,
        "/meshes/0/primitives/0/targets/0/POSITION",
    );
}

#[test]
fn points_and_lines_without_position_are_carried() {
    let mut b = triangle();
    b.push(
        "meshes",
        json!({"primitives": [{"attributes": {"_CUSTOM": 0}, "mode": 0}]}),
    );
    let asset = run(&b.glb()).expect("POSITION is optional outside triangle primitives");
    assert_eq!(asset.triangle_primitives().len(), 1);
}

/// Paths of every number in a JSON tree (JSON pointers).
fn number_paths(value: &serde_json::Value, path: String, out: &mut Vec<String>) {
    match value {
        serde_json::Value::Number(_) => out.push(path),
        serde_json::Value::Array(items) => {
            for (i, v) in items.iter().enumerate() {
                number_paths(v, format!("{path}/{i}"), out);
            }
        }
        serde_json::Value::Object(map) => {
            for (k, v) in map {
                number_paths(
                    v,
                    format!("{path}/{}", k.replace('~', "~0").replace('/', "~1")),
                    out,
                );
            }
        }
        _ => {}
    }
}

#[test]
fn structural_mutations_never_panic() {
    // Byte flips mostly break the JSON syntax; this mutates the numbers the decoder trusts
    // least (counts, offsets, strides, indices, component types, modes) in a valid asset with
    // sparse accessors, interleaving, morph targets, instancing and a skin.
    let mut b = Builder::new();
    let mut interleaved = Vec::new();
    for v in 0..4u8 {
        for x in [f32::from(v % 2), f32::from(v / 2), 0.0, 0.0, 0.0, 1.0] {
            interleaved.extend_from_slice(&x.to_le_bytes());
        }
    }
    let iv = b.view(&interleaved, Some(24));
    let pos = b.push("accessors", json!({"bufferView": iv, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}));
    let nrm = b.push("accessors", json!({"bufferView": iv, "byteOffset": 12, "componentType": 5126, "count": 4, "type": "VEC3"}));
    let si = b.view(&[1u8, 3, 0, 0], None);
    let sv = b.view(&[0u8; 24], None);
    let target = b.push("accessors", json!({"componentType": 5126, "count": 4, "type": "VEC3",
        "sparse": {"count": 2, "indices": {"bufferView": si, "componentType": 5121}, "values": {"bufferView": sv}}}));
    let idx = b.indices(&[0, 1, 2, 2, 1, 3]);
    b.push("meshes", json!({"primitives": [
        {"attributes": {"POSITION": pos, "NORMAL": nrm}, "indices": idx, "targets": [{"POSITION": target}]},
        {"attributes": {"POSITION": pos}, "mode": 5},
        {"attributes": {"POSITION": pos}, "indices": idx, "mode": 1}
    ]}));
    b.push("nodes", json!({"mesh": 0, "children": [1]}));
    b.push("nodes", json!({"mesh": 0}));
    let base = b.json.clone();
    let mut paths = Vec::new();
    number_paths(&base, String::new(), &mut paths);
    assert!(paths.len() > 40);
    let values = [
        json!(0),
        json!(1),
        json!(2),
        json!(3),
        json!(4),
        json!(5),
        json!(6),
        json!(7),
        json!(12),
        json!(255),
        json!(5121),
        json!(5123),
        json!(5125),
        json!(5126),
        json!(65535),
        json!(2_147_483_648u64),
        json!(4_294_967_295u64),
        json!(4_294_967_296u64),
        json!(u64::MAX),
        json!(-1),
        json!(1.5),
        json!(-0.0),
        json!(1e300),
    ];
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut decoded = 0;
    for _ in 0..3000 {
        let mut m = Builder {
            json: base.clone(),
            bin: b.bin.clone(),
        };
        for _ in 0..1 + next() % 3 {
            let path = &paths[(next() % paths.len() as u64) as usize];
            let value = values[(next() % values.len() as u64) as usize].clone();
            if let Some(slot) = m.json.pointer_mut(path) {
                *slot = value;
            }
        }
        match run(&m.glb()) {
            Ok(asset) => {
                decoded += 1;
                let uvs = vec![
                    [[0.5f32, 0.5], [0.0, 0.0], [1.0, 0.0]];
                    asset.mesh_input().triangles.len()
                ];
                match encode(&asset, &uvs, &EncodeOptions::default()) {
                    Ok(out) => {
                        let again = run(&out.bytes)
                            .unwrap_or_else(|e| panic!("output does not decode: {e}\n{}", m.json));
                        assert_eq!(
                            again.mesh_input().triangles.len(),
                            asset.mesh_input().triangles.len()
                        );
                    }
                    Err(e) => assert_ne!(e.code, ErrorCode::Internal, "{e}"),
                }
            }
            Err(e) => assert_ne!(e.code, ErrorCode::Internal, "{e}\n{}", m.json),
        }
    }
    assert!(decoded > 100 && decoded < 3000, "{decoded} of 3000 decoded");
}

#[test]
fn schema_type_errors_name_their_json_path() {
    let mut b = triangle();
    b.json["accessors"][1]["count"] = json!("three");
    expect_err(&b.glb(), ErrorCode::Schema, "/accessors/1/count");
    let mut b = triangle();
    b.json["accessors"][0]
        .as_object_mut()
        .expect("object")
        .remove("componentType");
    expect_err(&b.glb(), ErrorCode::Schema, "/accessors/0");
    let mut b = triangle();
    b.json["meshes"][0]["primitives"][0]["mode"] = json!(9);
    expect_err(&b.glb(), ErrorCode::Schema, "/meshes/0/primitives/0/mode");
}
