//! Round trips through `gltf_io`: decode → deterministic seam-creating corner UVs → encode →
//! check with an independent reader (`gltf_common`) that every corner keeps its position and
//! every attribute / morph-target value, that the UV set lands where expected, that vertices
//! are split only where the UVs differ, and that everything outside the rewritten primitives is
//! unchanged.
use crate::common::fixture;
use crate::common::gltf as gltf_common;

use std::collections::BTreeSet;

use gltf_common::{kitchen_sink, parse, strip_unknown, test_uvs, Builder, Doc};
use serde_json::{json, Value};
use texatlas::gltf_io::{
    decode, encode, required_resources, Asset, DecodeLimits, EncodeOptions, ErrorCode,
    OldVertexData, OutputFormat, PrimitiveMode, Resources, SourceFormat, UvTarget,
};

/// Top-level keys `encode` may change; everything else must be JSON-equal.
const REWRITTEN: [&str; 5] = ["meshes", "accessors", "bufferViews", "buffers", "images"];

/// Checks one encoded output against its input with the independent reader.
fn check_round_trip(
    input: &Doc,
    asset: &Asset,
    uvs: &[[[f32; 2]; 3]],
    output: &[u8],
    uv_sets: &[u32],
    replaced: bool,
) {
    let out = parse(output);
    // 0. One atlas set for the whole asset.
    assert_eq!(uv_sets.len(), asset.triangle_primitives().len());
    assert!(
        uv_sets.iter().all(|&k| k == uv_sets[0]),
        "one UV set for every primitive: {uv_sets:?}"
    );
    // 1. Untouched top-level properties.
    for (key, value) in input.json.as_object().expect("object") {
        if !REWRITTEN.contains(&key.as_str()) {
            assert_eq!(out.json.get(key), Some(value), "top-level `{key}` changed");
        }
    }
    // 2. Existing accessors keep their index, JSON and data, except old vertex data that was
    //    dropped: then the accessor is a one-element zero accessor that nothing references.
    let in_accessors = input.json["accessors"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    let referenced = referenced_accessors(&out.json);
    for (i, a) in in_accessors.iter().enumerate() {
        let o = &out.json["accessors"][i];
        if o == a {
            assert_eq!(
                input.elements(i),
                out.elements(i),
                "accessor {i} data changed"
            );
        } else {
            assert!(
                !referenced.contains(&i),
                "accessor {i} changed but is still referenced"
            );
            assert_eq!(
                (o["count"].as_u64(), o.get("bufferView")),
                (Some(1), None),
                "accessor {i}: {o}"
            );
            assert_eq!(
                (&o["componentType"], &o["type"]),
                (&a["componentType"], &a["type"])
            );
        }
    }
    // 3. Images keep every property (external ones may have gained bufferView/mimeType).
    for (i, image) in input.json["images"]
        .as_array()
        .cloned()
        .unwrap_or_default()
        .iter()
        .enumerate()
    {
        for (key, value) in image.as_object().expect("image") {
            if key != "uri" || value.as_str().is_some_and(|u| u.starts_with("data:")) {
                assert_eq!(
                    &out.json["images"][i][key], value,
                    "images/{i}/{key} changed"
                );
            }
        }
    }
    // 4. Meshes: triangle primitives carry every corner value; the rest is unchanged.
    let mut tri_index = 0;
    for (m, mesh) in input.json["meshes"]
        .as_array()
        .cloned()
        .unwrap_or_default()
        .iter()
        .enumerate()
    {
        let out_mesh = &out.json["meshes"][m];
        for (key, value) in mesh.as_object().expect("mesh") {
            if key != "primitives" {
                assert_eq!(&out_mesh[key], value, "meshes/{m}/{key} changed");
            }
        }
        for (p, prim) in mesh["primitives"]
            .as_array()
            .expect("primitives")
            .iter()
            .enumerate()
        {
            let out_prim = &out_mesh["primitives"][p];
            let mode = prim.get("mode").and_then(Value::as_u64).unwrap_or(4);
            if mode < 4 {
                assert_eq!(out_prim, prim, "points/lines primitive {m}/{p} changed");
                continue;
            }
            if asset.face_range(tri_index).is_some_and(|f| f.is_empty()) {
                assert_eq!(
                    out_prim, prim,
                    "primitive {m}/{p} without triangles changed"
                );
                tri_index += 1;
                continue;
            }
            for (key, value) in prim.as_object().expect("prim") {
                if !["attributes", "indices", "targets", "mode"].contains(&key.as_str()) {
                    assert_eq!(
                        &out_prim[key], value,
                        "meshes/{m}/primitives/{p}/{key} changed"
                    );
                }
            }
            assert_eq!(
                out_prim.get("mode").and_then(Value::as_u64).unwrap_or(4),
                4,
                "not a list"
            );
            let k = uv_sets[tri_index];
            let uv_name = format!("TEXCOORD_{k}");
            // Continuous sets; the sets below k the source lacked share the atlas accessor.
            gltf_common::assert_one_atlas_set(prim, out_prim, k, &format!("{m}/{p}"));
            let before = input.corner_attributes(prim);
            let after = out.corner_attributes(out_prim);
            for (key, values) in &before {
                let is_replaced_uv = key == &uv_name || key.ends_with(&format!("/{uv_name}"));
                if replaced && is_replaced_uv {
                    continue;
                }
                assert!(!is_replaced_uv, "FirstFree wrote over existing {key}");
                assert_eq!(
                    after.get(key),
                    Some(values),
                    "corner values of {key} differ in {m}/{p}"
                );
            }
            // The UV set holds exactly the given UVs, corner by corner.
            let faces = asset.face_range(tri_index).expect("primitive");
            let expected: Vec<[f32; 2]> = uvs[faces.clone()]
                .iter()
                .flatten()
                .map(|uv| [uv[0] + 0.0, uv[1] + 0.0])
                .collect();
            let uv_accessor = out_prim["attributes"][&uv_name]
                .as_u64()
                .expect("UV set written") as usize;
            let written = out.floats(uv_accessor);
            let corners = out.corners(out_prim);
            let got: Vec<[f32; 2]> = corners
                .iter()
                .flatten()
                .map(|&v| [written[v][0], written[v][1]])
                .collect();
            assert_eq!(got, expected, "UVs of {m}/{p}");
            // Split only where needed: one vertex per distinct (source vertex, UV).
            let t = asset.mesh_input();
            let distinct: BTreeSet<(u32, u32, u32)> = t.triangles[faces.clone()]
                .iter()
                .zip(&uvs[faces])
                .flat_map(|(tri, uv)| {
                    (0..3).map(move |c| {
                        (
                            tri[c],
                            (uv[c][0] + 0.0).to_bits(),
                            (uv[c][1] + 0.0).to_bits(),
                        )
                    })
                })
                .collect();
            assert_eq!(
                written.len(),
                distinct.len(),
                "vertex count of {m}/{p} is not minimal"
            );
            tri_index += 1;
        }
    }
    assert_eq!(tri_index, asset.triangle_primitives().len());
}

/// Every accessor index the document references from primitives, skins and animations.
fn referenced_accessors(json: &Value) -> BTreeSet<usize> {
    let mut out = BTreeSet::new();
    let mut add = |v: &Value| {
        if let Some(i) = v.as_u64() {
            out.insert(i as usize);
        }
    };
    for mesh in json["meshes"].as_array().into_iter().flatten() {
        for prim in mesh["primitives"].as_array().into_iter().flatten() {
            prim["attributes"]
                .as_object()
                .into_iter()
                .flatten()
                .for_each(|(_, v)| add(v));
            add(&prim["indices"]);
            for t in prim["targets"].as_array().into_iter().flatten() {
                t.as_object()
                    .into_iter()
                    .flatten()
                    .for_each(|(_, v)| add(v));
            }
        }
    }
    for skin in json["skins"].as_array().into_iter().flatten() {
        add(&skin["inverseBindMatrices"]);
    }
    for anim in json["animations"].as_array().into_iter().flatten() {
        for sampler in anim["samplers"].as_array().into_iter().flatten() {
            add(&sampler["input"]);
            add(&sampler["output"]);
        }
    }
    out
}

/// decode → UVs → encode → independent check → decode again (same triangles, same positions).
fn round_trip(
    bytes: &[u8],
    resources: &Resources,
    options: EncodeOptions,
) -> (Asset, Vec<u8>, Vec<u32>) {
    let asset = decode(bytes, resources, &DecodeLimits::default()).expect("decodes");
    let uvs = test_uvs(&asset);
    let encoded = encode(&asset, &uvs, &options).expect("encodes");
    let input = match asset.source_format() {
        SourceFormat::Glb => parse(bytes),
        SourceFormat::Gltf => {
            // Resolve the external buffer for the reference reader.
            let mut doc = parse(&glb_of(bytes, resources));
            doc.json["buffers"] = json!([{"byteLength": doc.buffers[0].len()}]);
            doc
        }
    };
    let replaced = matches!(options.uv_target, UvTarget::Replace(_));
    assert!(encoded
        .uv_set_per_primitive
        .iter()
        .all(|&k| k == encoded.uv_set));
    check_round_trip(
        &input,
        &asset,
        &uvs,
        &encoded.bytes,
        &encoded.uv_set_per_primitive,
        replaced,
    );
    let again = decode(&encoded.bytes, &Resources::new(), &DecodeLimits::default())
        .expect("output decodes");
    let (a, b) = (asset.mesh_input(), again.mesh_input());
    assert_eq!(a.triangles.len(), b.triangles.len());
    for (ta, tb) in a.triangles.iter().zip(&b.triangles) {
        for c in 0..3 {
            assert_eq!(a.positions_m[ta[c] as usize], b.positions_m[tb[c] as usize]);
        }
    }
    (asset, encoded.bytes, encoded.uv_set_per_primitive)
}

/// Wraps a `.gltf` with one external buffer into a GLB for the reference reader.
fn glb_of(gltf: &[u8], resources: &Resources) -> Vec<u8> {
    let mut json: Value = serde_json::from_slice(gltf).expect("json");
    let uri = json["buffers"][0]["uri"].as_str().expect("uri").to_string();
    let bin = resources.get(&uri).expect("supplied").to_vec();
    json["buffers"][0]
        .as_object_mut()
        .expect("obj")
        .remove("uri");
    gltf_common::glb_bytes(&serde_json::to_vec(&json).expect("json"), &bin)
}

#[test]
fn corpus_fixtures_round_trip() {
    for name in [
        "Box.glb",
        "BoxInterleaved.glb",
        "SimpleSkin.glb",
        "AnimatedMorphCube.glb",
        "SimpleSparseAccessor.glb",
        "Mesh_PrimitiveMode_04_strip.glb",
        "Mesh_PrimitiveMode_05_fan.glb",
    ] {
        let (asset, out, sets) =
            round_trip(&fixture(name), &Resources::new(), EncodeOptions::default());
        assert!(!asset.triangle_primitives().is_empty(), "{name}");
        assert!(
            sets.iter().all(|&k| k == 0),
            "{name}: {sets:?} (none has UVs)"
        );
        let doc = parse(&out);
        assert_eq!(
            doc.json["buffers"].as_array().map(Vec::len),
            Some(1),
            "{name}: one buffer"
        );
    }
}

#[test]
fn skins_animations_morph_targets_survive() {
    let (_, out, _) = round_trip(
        &fixture("SimpleSkin.glb"),
        &Resources::new(),
        EncodeOptions::default(),
    );
    let doc = parse(&out);
    assert_eq!(doc.json["skins"].as_array().map(Vec::len), Some(1));
    assert_eq!(doc.json["animations"].as_array().map(Vec::len), Some(1));
    let prim = &doc.json["meshes"][0]["primitives"][0]["attributes"];
    assert!(prim.get("JOINTS_0").is_some() && prim.get("WEIGHTS_0").is_some());

    let (_, out, _) = round_trip(
        &fixture("AnimatedMorphCube.glb"),
        &Resources::new(),
        EncodeOptions::default(),
    );
    let doc = parse(&out);
    assert_eq!(
        doc.json["meshes"][0]["primitives"][0]["targets"]
            .as_array()
            .map(Vec::len),
        Some(2)
    );
    assert!(doc.json["animations"]
        .as_array()
        .is_some_and(|a| !a.is_empty()));
}

#[test]
fn strip_and_fan_expand_in_spec_order() {
    for (name, mode) in [
        (
            "Mesh_PrimitiveMode_04_strip.glb",
            PrimitiveMode::TriangleStrip,
        ),
        ("Mesh_PrimitiveMode_05_fan.glb", PrimitiveMode::TriangleFan),
    ] {
        let asset =
            decode(&fixture(name), &Resources::new(), &DecodeLimits::default()).expect("decodes");
        let prim = &asset.triangle_primitives()[0];
        assert_eq!(prim.mode, mode);
        assert!(!prim.indexed);
        let expected: Vec<[u32; 3]> = match mode {
            PrimitiveMode::TriangleStrip => vec![[0, 1, 2], [1, 3, 2]],
            _ => vec![[1, 2, 0], [2, 3, 0]],
        };
        assert_eq!(asset.mesh_input().triangles, expected, "{name}");
    }
}

#[test]
fn kitchen_sink_round_trips_glb_and_gltf() {
    let b = kitchen_sink();
    let glb = b.glb();
    let asset = decode(&glb, &Resources::new(), &DecodeLimits::default()).expect("decodes");
    // Three triangle primitives: grid (8), fan (3), strip (2); points and lines skipped.
    let prims = asset.triangle_primitives();
    assert_eq!(prims.len(), 3);
    assert_eq!(
        prims
            .iter()
            .map(|p| (p.mesh_index, p.primitive_index, p.faces.len()))
            .collect::<Vec<_>>(),
        vec![(0, 0, 8), (1, 0, 3), (2, 2, 2)]
    );
    assert_eq!(prims[0].texcoord_sets, vec![0]);
    // Instanced mesh 0 appears once; weld groups are mesh indices; positions are mesh-local.
    let input = asset.mesh_input();
    assert_eq!(input.positions_m.len(), 9 + 5 + 4);
    assert_eq!(input.weld_group.iter().filter(|&&g| g == 0).count(), 9);
    assert_eq!(
        input.positions_m[9 + 1],
        [1.0, 0.0, 0.0],
        "i16 normalized 32767 is 1.0"
    );
    assert_eq!(input.positions_m[9 + 4][0], -1.0);
    assert_eq!(
        input.triangles[8],
        [10, 11, 9],
        "fan (v1, v2, v0), offset by 9 grid vertices"
    );
    assert_eq!(
        input.triangles[12],
        [15, 17, 16],
        "second strip triangle flips winding"
    );

    for format in [OutputFormat::Glb, OutputFormat::Gltf] {
        let (_, out, sets) = round_trip(
            &glb,
            &Resources::new(),
            EncodeOptions {
                format,
                ..EncodeOptions::default()
            },
        );
        // The grid has TEXCOORD_0, the fan and the strip none: all get the atlas in TEXCOORD_1,
        // and the fan and the strip get TEXCOORD_0 pointing at the same accessor.
        assert_eq!(sets, vec![1, 1, 1], "first set no primitive has");
        let doc = parse(&out);
        let fan = &doc.json["meshes"][1]["primitives"][0]["attributes"];
        assert!(fan["TEXCOORD_1"].is_u64());
        assert_eq!(
            fan["TEXCOORD_0"], fan["TEXCOORD_1"],
            "filler shares the atlas"
        );
        assert_eq!(out.starts_with(b"glTF"), format == OutputFormat::Glb);
        // Quantized stays quantized; custom attribute keeps its type.
        let grid = &doc.json["meshes"][0]["primitives"][0]["attributes"];
        let tex0 = &doc.json["accessors"][grid["TEXCOORD_0"].as_u64().expect("tex0") as usize];
        assert_eq!(
            (tex0["componentType"].as_u64(), tex0["normalized"].as_bool()),
            (Some(5123), Some(true))
        );
        let foo = &doc.json["accessors"][grid["_FOO"].as_u64().expect("foo") as usize];
        assert_eq!(foo["componentType"], 5123);
        let qpos = doc.json["meshes"][1]["primitives"][0]["attributes"]["POSITION"]
            .as_u64()
            .expect("pos") as usize;
        assert_eq!(doc.json["accessors"][qpos]["componentType"], 5122);
        assert!(doc.json["accessors"][qpos]["min"].is_array());
        // Unknown extensions and extras survive at every level.
        let text = serde_json::to_string(&doc.json).expect("json");
        for tag in ["root", "node", "mesh", "primitive", "accessor", "scene"] {
            assert!(
                text.contains(&format!("\"tag\":\"{tag}\"")),
                "extension on {tag} lost"
            );
        }
        for tag in [
            "root",
            "node",
            "mesh",
            "primitive",
            "material",
            "skin",
            "lines",
            "pos",
        ] {
            assert!(
                text.contains(&format!("\"note\":\"{tag}\"")),
                "extras on {tag} lost"
            );
        }
    }
}

#[test]
fn vertex_attribute_elements_are_four_byte_aligned_in_the_output() {
    let (_, out, _) = round_trip(
        &kitchen_sink().glb(),
        &Resources::new(),
        EncodeOptions::default(),
    );
    let doc = parse(&out);
    let prim = &doc.json["meshes"][0]["primitives"][0];
    for (name, a) in prim["attributes"].as_object().expect("attributes") {
        let accessor = &doc.json["accessors"][a.as_u64().expect("index") as usize];
        let view =
            &doc.json["bufferViews"][accessor["bufferView"].as_u64().expect("view") as usize];
        let offset =
            view["byteOffset"].as_u64().unwrap_or(0) + accessor["byteOffset"].as_u64().unwrap_or(0);
        assert_eq!(offset % 4, 0, "{name} offset");
        if let Some(stride) = view["byteStride"].as_u64() {
            assert_eq!(stride % 4, 0, "{name} stride");
        }
    }
    // COLOR_1 is u8 VEC3 (3 bytes): it needs a padded stride of 4.
    let c1 = &doc.json["accessors"][prim["attributes"]["COLOR_1"].as_u64().expect("c1") as usize];
    assert_eq!(
        doc.json["bufferViews"][c1["bufferView"].as_u64().expect("v") as usize]["byteStride"],
        4
    );
}

#[test]
fn replace_target_overwrites_a_chosen_set() {
    let glb = kitchen_sink().glb();
    let (_, out, sets) = round_trip(
        &glb,
        &Resources::new(),
        EncodeOptions {
            uv_target: UvTarget::Replace(0),
            ..EncodeOptions::default()
        },
    );
    assert_eq!(sets, vec![0, 0, 0]);
    let doc = parse(&out);
    let tex0 = doc.json["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"]
        .as_u64()
        .expect("tex0") as usize;
    assert_eq!(
        doc.json["accessors"][tex0]["componentType"], 5126,
        "replaced by float UVs"
    );
    assert!(doc.json["meshes"][0]["primitives"][0]["attributes"]
        .get("TEXCOORD_1")
        .is_none());

    // The first free set (1, which no primitive has) on every primitive: the fan and the
    // strip, without UVs, get TEXCOORD_0 too, sharing the atlas accessor (checked by
    // `round_trip`); the grid keeps its TEXCOORD_0.
    let (_, out, sets) = round_trip(
        &glb,
        &Resources::new(),
        EncodeOptions {
            uv_target: UvTarget::Replace(1),
            ..EncodeOptions::default()
        },
    );
    assert_eq!(sets, vec![1, 1, 1]);
    let doc = parse(&out);
    let strip = &doc.json["meshes"][2]["primitives"][2]["attributes"];
    assert_eq!(strip["TEXCOORD_0"], strip["TEXCOORD_1"]);

    // Set 3: no primitive has it and set 1 is free, so sets 1 and 2 would be mere copies.
    let asset = decode(&glb, &Resources::new(), &DecodeLimits::default()).expect("decodes");
    let err = encode(
        &asset,
        &test_uvs(&asset),
        &EncodeOptions {
            uv_target: UvTarget::Replace(3),
            ..EncodeOptions::default()
        },
    )
    .expect_err("gap");
    assert_eq!(err.code, ErrorCode::UvTarget);
    assert_eq!(err.json_path, "/meshes");
    assert!(err.detail.contains("TEXCOORD_3"), "{}", err.detail);
    assert!(
        err.fix.contains("first_free (TEXCOORD_1 here)") && err.fix.contains("{0}"),
        "the hint names both ways out: {}",
        err.fix
    );
}

#[test]
fn continuous_uvs_split_nothing_and_seams_split_only_their_vertices() {
    let b = kitchen_sink();
    let asset = decode(&b.glb(), &Resources::new(), &DecodeLimits::default()).expect("decodes");
    let per_vertex: Vec<[[f32; 2]; 3]> = asset
        .mesh_input()
        .triangles
        .iter()
        .map(|t| t.map(|v| [v as f32 / 32.0, 0.5]))
        .collect();
    let out = encode(&asset, &per_vertex, &EncodeOptions::default()).expect("encodes");
    let doc = parse(&out.bytes);
    let count = |doc: &Doc| {
        let a = doc.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
            .as_u64()
            .expect("pos") as usize;
        doc.json["accessors"][a]["count"].as_u64()
    };
    assert_eq!(count(&doc), Some(9), "no seam → no split");
    // Cut the grid along its middle column: faces 0..4 (left half) get u + 0.5 on vertices 1, 4, 7.
    let mut seamed = per_vertex.clone();
    for (f, t) in asset.mesh_input().triangles.iter().enumerate().take(8) {
        if [0, 1, 4, 5].contains(&f) {
            for c in 0..3 {
                if [1, 4, 7].contains(&t[c]) {
                    seamed[f][c][0] += 0.5;
                }
            }
        }
    }
    let out = encode(&asset, &seamed, &EncodeOptions::default()).expect("encodes");
    assert_eq!(
        count(&parse(&out.bytes)),
        Some(12),
        "three seam vertices split once each"
    );
}

#[test]
fn many_vertices_use_u32_indices() {
    let mut b = Builder::new();
    let n = 70_000usize;
    let pos: Vec<[f32; 3]> = (0..n)
        .map(|i| [(i / 2) as f32, (i % 2) as f32, 0.0])
        .collect();
    let pos = b.floats(&pos);
    b.push(
        "meshes",
        json!({"primitives": [{"attributes": {"POSITION": pos}, "mode": 5}]}),
    );
    b.push("nodes", json!({"mesh": 0}));
    let asset = decode(&b.glb(), &Resources::new(), &DecodeLimits::default()).expect("decodes");
    assert_eq!(asset.mesh_input().triangles.len(), n - 2);
    let uvs: Vec<[[f32; 2]; 3]> = asset
        .mesh_input()
        .triangles
        .iter()
        .map(|t| t.map(|v| [v as f32 / n as f32, 0.0]))
        .collect();
    let out = encode(&asset, &uvs, &EncodeOptions::default()).expect("encodes");
    let doc = parse(&out.bytes);
    let idx = doc.json["meshes"][0]["primitives"][0]["indices"]
        .as_u64()
        .expect("indices") as usize;
    assert_eq!(doc.json["accessors"][idx]["componentType"], 5125);
    assert_eq!(doc.json["meshes"][0]["primitives"][0]["mode"], 4);
    // And a small mesh uses u16.
    let (_, out, _) = round_trip(
        &fixture("Box.glb"),
        &Resources::new(),
        EncodeOptions::default(),
    );
    let doc = parse(&out);
    let idx = doc.json["meshes"][0]["primitives"][0]["indices"]
        .as_u64()
        .expect("indices") as usize;
    assert_eq!(doc.json["accessors"][idx]["componentType"], 5123);
}

#[test]
fn external_buffer_and_image_from_resources_are_embedded() {
    let mut b = kitchen_sink();
    b.push(
        "images",
        json!({"uri": "tex/wood%20grain.png", "name": "wood"}),
    );
    b.push("textures", json!({"source": 0}));
    b.json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] =
        json!({"index": 0, "texCoord": 0});
    let gltf = b.gltf_external("scene.bin");
    let png = b"\x89PNG\r\n\x1a\nfake-image-bytes".to_vec();
    let mut resources = Resources::new();
    resources.insert("scene.bin", b.bin.clone());
    resources.insert("tex/wood grain.png", png.clone());

    // Without resources: a typed error naming the URI.
    let err = decode(&gltf, &Resources::new(), &DecodeLimits::default()).expect_err("missing");
    assert_eq!(
        (err.code, err.json_path.as_str()),
        (ErrorCode::ResourceMissing, "/buffers/0/uri")
    );

    // The caller can ask which files to supply, before decoding.
    assert_eq!(
        required_resources(&gltf).expect("scan"),
        vec!["scene.bin".to_string(), "tex/wood%20grain.png".to_string()]
    );
    assert!(
        required_resources(&b.glb()).expect("scan").len() == 1,
        "only the image"
    );

    let (asset, out, _) = round_trip(&gltf, &resources, EncodeOptions::default());
    assert_eq!(asset.source_format(), SourceFormat::Gltf);
    assert!(
        required_resources(&out).expect("scan").is_empty(),
        "everything embedded"
    );
    let doc = parse(&out);
    let image = &doc.json["images"][0];
    assert!(image.get("uri").is_none());
    assert_eq!(image["mimeType"], "image/png");
    assert_eq!(image["name"], "wood");
    let view = &doc.json["bufferViews"][image["bufferView"].as_u64().expect("view") as usize];
    let start = view["byteOffset"].as_u64().expect("offset") as usize;
    assert_eq!(&doc.buffers[0][start..start + png.len()], &png[..]);
    assert_eq!(
        doc.json["materials"], b.json["materials"],
        "texCoord references untouched"
    );
}

#[test]
fn summary_lists_meshes_primitives_and_extensions() {
    let asset = decode(
        &kitchen_sink().glb(),
        &Resources::new(),
        &DecodeLimits::default(),
    )
    .expect("decodes");
    let s = asset.summary();
    assert_eq!(s.format, SourceFormat::Glb);
    assert_eq!(s.node_count, 7);
    assert_eq!(s.meshes.len(), 3);
    assert_eq!(s.meshes[0].name.as_deref(), Some("sink"));
    assert_eq!(s.meshes[0].instances, 2);
    assert_eq!(s.meshes[0].primitives[0].triangle_count, Some(8));
    assert_eq!(s.meshes[0].primitives[0].morph_targets, 2);
    assert!(s.meshes[0].primitives[0]
        .attributes
        .contains(&"_FOO".to_string()));
    assert_eq!(
        s.meshes[2]
            .primitives
            .iter()
            .map(|p| p.mode)
            .collect::<Vec<_>>(),
        vec![0, 1, 5]
    );
    assert_eq!(s.meshes[2].primitives[1].triangle_count, None);
    assert_eq!(
        s.extensions_required,
        vec!["KHR_mesh_quantization".to_string()]
    );
    assert_eq!(asset.face_range(1), Some(8..11));
    assert_eq!(asset.face_range(3), None);
}

#[test]
fn encode_rejects_mismatched_or_non_finite_uvs() {
    let asset = decode(
        &fixture("Box.glb"),
        &Resources::new(),
        &DecodeLimits::default(),
    )
    .expect("decodes");
    let mut uvs = test_uvs(&asset);
    uvs.pop();
    assert_eq!(
        encode(&asset, &uvs, &EncodeOptions::default())
            .expect_err("short")
            .code,
        ErrorCode::UvInput
    );
    let mut uvs = test_uvs(&asset);
    uvs[3][1][0] = f32::NAN;
    let err = encode(&asset, &uvs, &EncodeOptions::default()).expect_err("nan");
    assert_eq!(err.code, ErrorCode::UvInput);
    assert!(err.detail.contains("face 3"), "{}", err.detail);
}

#[test]
fn encoding_is_deterministic() {
    let asset = decode(
        &kitchen_sink().glb(),
        &Resources::new(),
        &DecodeLimits::default(),
    )
    .expect("decodes");
    let uvs = test_uvs(&asset);
    let a = encode(&asset, &uvs, &EncodeOptions::default()).expect("encodes");
    let b = encode(&asset, &uvs, &EncodeOptions::default()).expect("encodes");
    assert_eq!(a, b);
}

#[test]
fn old_vertex_data_is_dropped_only_when_safe() {
    let sizes = |bytes: &[u8]| {
        let asset = decode(bytes, &Resources::new(), &DecodeLimits::default()).expect("decodes");
        let uvs = test_uvs(&asset);
        let keep = EncodeOptions {
            old_vertex_data: OldVertexData::Keep,
            ..EncodeOptions::default()
        };
        let kept = encode(&asset, &uvs, &keep).expect("encodes").bytes;
        let dropped = encode(&asset, &uvs, &EncodeOptions::default())
            .expect("encodes")
            .bytes;
        (kept, dropped)
    };
    // Box: no extensions, nothing else references the mesh accessors → dropped, file smaller.
    let (kept, dropped) = sizes(&fixture("Box.glb"));
    assert!(
        dropped.len() < kept.len(),
        "{} !< {}",
        dropped.len(),
        kept.len()
    );
    let doc = parse(&dropped);
    assert_eq!(
        doc.json["accessors"][0]["count"], 1,
        "old accessor reduced to a zero accessor"
    );
    let (_, out, _) = round_trip(
        &fixture("Box.glb"),
        &Resources::new(),
        EncodeOptions::default(),
    );
    assert_eq!(parse(&out).json["accessors"][0]["count"], 1);
    // SimpleSkin: skin and animation accessors stay intact (checked by `round_trip`).
    let (kept, dropped) = sizes(&fixture("SimpleSkin.glb"));
    assert!(dropped.len() < kept.len());
    round_trip(
        &fixture("SimpleSkin.glb"),
        &Resources::new(),
        EncodeOptions::default(),
    );
    // An unknown extension might reference accessors: nothing is dropped.
    let (kept, dropped) = sizes(&kitchen_sink().glb());
    assert_eq!(kept, dropped);
}

#[test]
fn kitchen_sink_without_unknown_extensions_drops_old_data_and_still_round_trips() {
    let mut b = kitchen_sink();
    strip_unknown(&mut b.json);
    b.json["extensionsUsed"] = json!(["KHR_mesh_quantization", "KHR_materials_sheen"]);
    let glb = b.glb();
    for format in [OutputFormat::Glb, OutputFormat::Gltf] {
        let (_, out, _) = round_trip(
            &glb,
            &Resources::new(),
            EncodeOptions {
                format,
                ..EncodeOptions::default()
            },
        );
        let doc = parse(&out);
        // The skin's inverse bind matrices and the animation's accessors keep their data.
        let ibm = doc.json["skins"][0]["inverseBindMatrices"]
            .as_u64()
            .expect("ibm") as usize;
        assert_eq!(doc.json["accessors"][ibm]["count"], 2);
        // Mesh 2's points/lines share POSITION with the rewritten strip: it must survive.
        let shared = b.json["meshes"][2]["primitives"][0]["attributes"]["POSITION"]
            .as_u64()
            .expect("pos") as usize;
        assert_eq!(doc.json["accessors"][shared], b.json["accessors"][shared]);
        // The grid's own accessors were dropped.
        let grid_pos = b.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
            .as_u64()
            .expect("pos") as usize;
        assert_eq!(doc.json["accessors"][grid_pos]["count"], 1);
    }
}

#[test]
fn a_primitive_without_triangles_is_left_alone() {
    let mut b = Builder::new();
    let pos = b.floats(&[[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0]]);
    let tri = b.floats(&[[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    b.push(
        "meshes",
        json!({"primitives": [
            {"attributes": {"POSITION": pos}, "mode": 5},
            {"attributes": {"POSITION": tri}}
        ]}),
    );
    b.push("nodes", json!({"mesh": 0}));
    let glb = b.glb();
    let (asset, out, _) = round_trip(&glb, &Resources::new(), EncodeOptions::default());
    assert_eq!(asset.triangle_primitives()[0].faces, 0..0);
    let doc = parse(&out);
    assert_eq!(
        doc.json["meshes"][0]["primitives"][0],
        b.json["meshes"][0]["primitives"][0]
    );
    assert_eq!(
        doc.json["accessors"][pos], b.json["accessors"][pos],
        "still referenced, not dropped"
    );
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    /// A random primitive: vertex count, mode, optional index stream, normals or not.
    fn primitive() -> impl Strategy<Value = (usize, u64, Option<Vec<u32>>, bool)> {
        (
            3usize..24,
            prop_oneof![Just(4u64), Just(5), Just(6)],
            any::<bool>(),
            any::<bool>(),
        )
            .prop_flat_map(|(n, mode, indexed, normals)| {
                // A non-indexed list needs a multiple of 3 vertices.
                let n = if mode == 4 && !indexed { n / 3 * 3 } else { n };
                // Lists: a multiple of 3 indices (truncated from up to 60); strips/fans: 3..30.
                let stream = prop::collection::vec(0..n as u32, 3..60).prop_map(move |mut v| {
                    if mode == 4 {
                        v.truncate(v.len() / 3 * 3);
                    } else {
                        v.truncate(30);
                    }
                    v
                });
                let indices = if indexed {
                    stream.prop_map(Some).boxed()
                } else {
                    Just(None).boxed()
                };
                (Just(n), Just(mode), indices, Just(normals))
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

        /// Any small mesh (lists, strips, fans; indexed or not) and any per-corner UVs drawn
        /// from a small palette (so some corners share UVs and some split): the triangle count
        /// and every per-corner value survive, vertices are split minimally.
        #[test]
        fn any_mesh_and_uvs_round_trip(
            prims in prop::collection::vec(primitive(), 1..3),
            palette in prop::collection::vec((0u8..4, 0u8..4), 256),
        ) {
            let mut b = Builder::new();
            let mut gltf_prims = Vec::new();
            for (p, (n, mode, indices, normals)) in prims.iter().enumerate() {
                let pos: Vec<[f32; 3]> = (0..*n).map(|i| [i as f32, (i * i % 7) as f32, p as f32]).collect();
                let pos = b.floats(&pos);
                let mut attributes = json!({"POSITION": pos});
                if *normals {
                    let nrm: Vec<[f32; 3]> = (0..*n).map(|i| [0.0, (i % 2) as f32, 1.0 - (i % 2) as f32]).collect();
                    attributes["NORMAL"] = json!(b.floats(&nrm));
                }
                let mut prim = json!({"attributes": attributes, "mode": mode});
                if let Some(indices) = indices {
                    prim["indices"] = json!(b.indices(indices));
                }
                gltf_prims.push(prim);
            }
            b.push("meshes", json!({"primitives": gltf_prims}));
            b.push("nodes", json!({"mesh": 0}));
            let glb = b.glb();
            let input = parse(&glb);
            let asset = decode(&glb, &Resources::new(), &DecodeLimits::default()).expect("decodes");
            // Triangles match the independent expansion, primitive by primitive.
            for (k, prim) in asset.triangle_primitives().iter().enumerate() {
                let corners = input.corners(&input.json["meshes"][0]["primitives"][k]);
                let ours: Vec<[usize; 3]> = asset.mesh_input().triangles[prim.faces.clone()]
                    .iter()
                    .map(|t| t.map(|v| (v - prim.vertex_start) as usize))
                    .collect();
                prop_assert_eq!(ours, corners);
            }
            let uvs: Vec<[[f32; 2]; 3]> = (0..asset.mesh_input().triangles.len())
                .map(|f| {
                    let uv = |c: usize| {
                        let (u, v) = palette[(3 * f + c) % palette.len()];
                        [f32::from(u) * 0.25, f32::from(v) * 0.25]
                    };
                    [uv(0), uv(1), uv(2)]
                })
                .collect();
            let encoded = encode(&asset, &uvs, &EncodeOptions::default()).expect("encodes");
            check_round_trip(&input, &asset, &uvs, &encoded.bytes, &encoded.uv_set_per_primitive, false);
        }

        /// One UV set for the whole asset, over random UV-set layouts per primitive (none,
        /// TEXCOORD_0, TEXCOORD_0 + TEXCOORD_1, ... up to 3 sets), with first_free and with an
        /// explicit `Replace(1)`: every primitive gets the atlas in the same TEXCOORD_k (k = the
        /// most sets any primitive has, for first_free), its sets stay continuous, the sets
        /// below k it lacked share the atlas accessor, and every other attribute (existing sets
        /// included) comes back byte for byte per corner (`check_round_trip`). `Replace(1)` is
        /// refused, naming the way out, only when no primitive has any UV set.
        #[test]
        fn one_uv_set_for_any_set_layout(
            layouts in prop::collection::vec((3usize..12, 0u32..4, any::<bool>()), 1..5),
            replace in any::<bool>(),
        ) {
            let mut b = Builder::new();
            let mut meshes: Vec<Vec<Value>> = vec![Vec::new(), Vec::new()];
            for (p, (n, sets, own_mesh)) in layouts.iter().enumerate() {
                let n = n / 3 * 3;
                let pos: Vec<[f32; 3]> = (0..n).map(|i| [i as f32, (i * i % 5) as f32, p as f32]).collect();
                let mut attributes = json!({"POSITION": b.floats(&pos)});
                for j in 0..*sets {
                    let uv: Vec<[f32; 2]> = (0..n).map(|i| [i as f32 * 0.1 + j as f32, p as f32]).collect();
                    attributes[format!("TEXCOORD_{j}")] = json!(b.floats(&uv));
                }
                meshes[usize::from(*own_mesh)].push(json!({"attributes": attributes}));
            }
            for prims in meshes.into_iter().filter(|m| !m.is_empty()) {
                let mesh = b.push("meshes", json!({"primitives": prims}));
                b.push("nodes", json!({"mesh": mesh}));
            }
            let glb = b.glb();
            let input = parse(&glb);
            let asset = decode(&glb, &Resources::new(), &DecodeLimits::default()).expect("decodes");
            let uvs = test_uvs(&asset);
            let most_sets = layouts.iter().map(|l| l.1).max().unwrap_or(0);
            let options = EncodeOptions {
                uv_target: if replace { UvTarget::Replace(1) } else { UvTarget::FirstFree },
                ..EncodeOptions::default()
            };
            let result = encode(&asset, &uvs, &options);
            if replace && most_sets == 0 {
                let err = result.expect_err("set 1 with no set in use leaves TEXCOORD_0 a copy");
                prop_assert_eq!(err.code, ErrorCode::UvTarget);
                prop_assert!(err.fix.contains("first_free (TEXCOORD_0 here)"), "{}", err.fix);
                return Ok(());
            }
            let encoded = result.expect("encodes");
            let k = if replace { 1 } else { most_sets };
            prop_assert_eq!(encoded.uv_set, k);
            prop_assert_eq!(&encoded.uv_set_per_primitive, &vec![k; layouts.len()]);
            check_round_trip(&input, &asset, &uvs, &encoded.bytes, &encoded.uv_set_per_primitive, replace);
            // Decoding the output again: every primitive has at least k + 1 sets.
            let again = decode(&encoded.bytes, &Resources::new(), &DecodeLimits::default()).expect("output decodes");
            for prim in again.triangle_primitives() {
                prop_assert!(prim.texcoord_sets.len() as u32 > k);
            }
        }
    }
}
