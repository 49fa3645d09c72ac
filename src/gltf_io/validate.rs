//! The document checks of [`decode`](fn@super::decode), in the order it runs them: the JSON
//! parses (and is not nested too deep), `asset.version` is 2.x, every accessor reference of a
//! primitive exists, the document passes `gltf-json`'s schema validation, it uses no mesh
//! compression we cannot decode, and its nodes form a forest.
//!
//! Invariant: each check names the JSON pointer at fault; none panics (`gltf-json` is only
//! called once the references it indexes unchecked are known to exist).
//!
//! References: glTF 2.0 spec §3.5 (asset), §5 (schema); RFC 6901 (JSON pointers).
use gltf_json::validation::Validate as _;
use serde_json::Value;

use super::accessor::array;
use super::error::{
    offset_of_line_column, pointer_at_offset, pointer_from_gltf_path, ErrorCode, GltfError,
};

pub(super) fn parse_json(json: &[u8]) -> Result<Value, GltfError> {
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

pub(super) fn check_version(root: &Value) -> Result<(), GltfError> {
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
pub(super) fn check_primitive_references(root: &Value) -> Result<(), GltfError> {
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
pub(super) fn check_schema(json: &[u8]) -> Result<(), GltfError> {
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
pub(super) fn check_extensions(root: &Value) -> Result<(), GltfError> {
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
pub(super) fn check_nodes(root: &Value) -> Result<(), GltfError> {
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
