//! Which of the old vertex data of the rewritten primitives [`encode`](fn@super::encode) may drop
//! ([`OldVertexData::DropIfUnreferenced`](super::OldVertexData)): an accessor goes only when
//! nothing but a rewritten primitive references it and no extension that might reference it by
//! index is present; a buffer view stays while anything still uses it.
//!
//! Invariant: when in doubt, keep: an unknown extension anywhere in the document disables
//! dropping.
use serde_json::Value;

use super::accessor::array;
use super::decode::Asset;

/// Extensions known to reference no accessor and no buffer view; any other extension object
/// in the document (an unknown one might reference them by index) disables dropping.
const ACCESSOR_FREE_EXTENSIONS: [&str; 10] = [
    "KHR_materials_",
    "KHR_texture_transform",
    "KHR_lights_punctual",
    "KHR_mesh_quantization",
    "KHR_texture_basisu",
    "EXT_texture_webp",
    "EXT_texture_avif",
    "KHR_xmp_json_ld",
    "KHR_animation_pointer",
    "KHR_materials_variants",
];

fn extension_is_accessor_free(name: &str) -> bool {
    // Entries ending in `_` are prefixes (the KHR_materials_* family).
    ACCESSOR_FREE_EXTENSIONS.iter().any(|known| {
        if known.ends_with('_') {
            name.starts_with(known)
        } else {
            name == *known
        }
    })
}

/// True if every `extensions` object anywhere in the tree only names accessor-free extensions.
fn only_accessor_free_extensions(value: &Value) -> bool {
    match value {
        Value::Object(map) => map.iter().all(|(key, v)| {
            let names_ok = key != "extensions"
                || v.as_object()
                    .is_some_and(|exts| exts.keys().all(|n| extension_is_accessor_free(n)));
            names_ok && only_accessor_free_extensions(v)
        }),
        Value::Array(items) => items.iter().all(only_accessor_free_extensions),
        _ => true,
    }
}

/// Accessors that only the rewritten (triangle) primitives reference, when dropping is safe;
/// empty otherwise. Sorted ascending.
pub(super) fn droppable_accessors(asset: &Asset) -> Vec<usize> {
    let root = &asset.json;
    if !only_accessor_free_extensions(root) {
        return Vec::new();
    }
    let n = array(root, "accessors").len();
    let mut used_by_rewritten = vec![false; n];
    let mut used_elsewhere = vec![false; n];
    let mark = |flags: &mut Vec<bool>, v: Option<&Value>| {
        if let Some(i) = v.and_then(Value::as_u64) {
            if let Some(f) = flags.get_mut(i as usize) {
                *f = true;
            }
        }
    };
    let rewritten: Vec<(usize, usize)> = asset
        .primitives
        .iter()
        .filter(|p| !p.faces.is_empty())
        .map(|p| (p.mesh_index, p.primitive_index))
        .collect();
    for (m, mesh) in array(root, "meshes").iter().enumerate() {
        for (p, prim) in array(mesh, "primitives").iter().enumerate() {
            let flags = if rewritten.contains(&(m, p)) {
                &mut used_by_rewritten
            } else {
                &mut used_elsewhere
            };
            for v in prim
                .get("attributes")
                .and_then(Value::as_object)
                .into_iter()
                .flat_map(|m| m.values())
            {
                mark(flags, Some(v));
            }
            mark(flags, prim.get("indices"));
            for target in array(prim, "targets") {
                for v in target.as_object().into_iter().flat_map(|m| m.values()) {
                    mark(flags, Some(v));
                }
            }
        }
    }
    for skin in array(root, "skins") {
        mark(&mut used_elsewhere, skin.get("inverseBindMatrices"));
    }
    for animation in array(root, "animations") {
        for sampler in array(animation, "samplers") {
            mark(&mut used_elsewhere, sampler.get("input"));
            mark(&mut used_elsewhere, sampler.get("output"));
        }
    }
    (0..n)
        .filter(|&i| used_by_rewritten[i] && !used_elsewhere[i])
        .collect()
}

/// Which original buffer views are still referenced once `dropped` accessors are gone.
pub(super) fn live_views(root: &Value, dropped: &[usize]) -> Vec<bool> {
    let mut live = vec![false; array(root, "bufferViews").len()];
    let mut mark = |v: Option<&Value>| {
        if let Some(i) = v.and_then(Value::as_u64) {
            if let Some(f) = live.get_mut(i as usize) {
                *f = true;
            }
        }
    };
    for (i, a) in array(root, "accessors").iter().enumerate() {
        if dropped.binary_search(&i).is_ok() {
            continue;
        }
        mark(a.get("bufferView"));
        if let Some(sparse) = a.get("sparse") {
            mark(sparse.get("indices").and_then(|x| x.get("bufferView")));
            mark(sparse.get("values").and_then(|x| x.get("bufferView")));
        }
    }
    for image in array(root, "images") {
        mark(image.get("bufferView"));
    }
    live
}
