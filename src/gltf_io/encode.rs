//! `encode` / `encode_pages`: decoded [`Asset`] + per-corner UVs (+ the texture page of every
//! face) → the same asset with a new `TEXCOORD_k`, one primitive per (source primitive, page).
//!
//! Purpose: write atlas UVs back into the asset and change nothing else. When the packer had to
//! open several pages, give every primitive one output primitive per page it has faces on, so
//! any renderer can bind one texture per page.
//!
//! Invariants:
//! - One UV set for the asset ([`UvTarget`]): every triangle primitive gets the atlas in the same
//!   `TEXCOORD_k` ([`EncodedAsset::uv_set`]). A primitive that lacks a set `j < k` gets
//!   `TEXCOORD_j` as well, pointing at the same accessor as its `TEXCOORD_k` (no data is
//!   copied), so its sets start at 0 and are continuous as glTF requires. Its other sets keep
//!   their data; a renderer reading `TEXCOORD_j` there sees the atlas.
//! - Vertices are split only where needed: a primitive (a part, see below) gets one output
//!   vertex per distinct (source vertex, UV bits) pair among its faces, numbered in order of
//!   first use by its corners, so the output is deterministic. Every vertex attribute (NORMAL,
//!   TANGENT, COLOR_n, JOINTS_n, WEIGHTS_n, existing TEXCOORD_n, custom `_FOO`) and every
//!   morph-target attribute is copied element by element in its original componentType,
//!   normalized flag and layout (quantized stays quantized), sparse substitution applied.
//! - Triangle `i` of a primitive keeps its corners in the same order; strips and fans become
//!   TRIANGLES lists in the decoder's triangle order. Indices are u16 when every index fits
//!   below the primitive-restart value 65535, else u32.
//! - Pages ([`encode_pages`]): the faces of a triangle primitive are grouped by page. The part
//!   on its lowest page is written in place (same mesh, same primitive index); each part on a
//!   higher page is a copy of the source primitive's JSON (material, `mode`, `extras`,
//!   `extensions` including `KHR_materials_variants` mappings, `targets`) with its own
//!   accessors, appended to the end of the same mesh's `primitives` in (primitive, page) order.
//!   Within a part, triangles keep the source face order. So a primitive on one page is
//!   written exactly as [`encode`] writes it (byte-identical output for single-page input),
//!   the (mesh, primitive) index of every single-page primitive never moves, every part of a
//!   mesh has the same number of morph targets, and the mesh's `weights` and `extras` (e.g.
//!   `targetNames`) stay valid untouched. [`EncodedAsset::parts`] lists where each part went.
//! - The JSON tree is the input's, edited only at: the rewritten primitives' `attributes`,
//!   `indices`, `targets`, `mode`; primitives appended for other pages; appended accessors and
//!   buffer views; `bufferViews[*].buffer` / `byteOffset` (rebased into one buffer); `buffers`
//!   (one buffer); external images (now a `bufferView` + `mimeType`). Existing accessors keep
//!   their indices and data, so skins, animations and unknown extensions that reference them
//!   stay valid. The one exception is [`OldVertexData::DropWhenSafe`]: accessors that only the
//!   rewritten primitives used become one-element zero accessors and their bytes leave the
//!   buffer, but only when no other primitive, skin or animation references them and every
//!   extension in the document is known not to reference accessors or buffer views.
//! - Vertex-attribute elements are 4-byte aligned (a padded `byteStride` when an element is not
//!   a multiple of 4 bytes), as the spec requires; `min`/`max` are recomputed for POSITION
//!   (attribute and morph target) and wherever the source accessor had them.
//!
//! What a split cannot keep exact (documented, not detected):
//! - The page is not recorded in the glTF: every part keeps the source `material`, so binding
//!   page `p`'s texture to the parts on page `p` is the caller's job, from
//!   [`EncodedAsset::parts`] (the report).
//! - `extras` and unknown `extensions` of a split primitive are copied verbatim to every part.
//!   Data in them that describes the primitive as a whole (an id, a vertex count, accessor
//!   indices of an unknown extension) then describes the whole source primitive on each part.
//!   Accessors such an extension references keep their data, because an unknown extension
//!   disables [`OldVertexData::DropWhenSafe`].
//! - Anything outside the document that addresses primitives by index sees the lowest-page
//!   part at the old index and the other parts at new ones. (No glTF 2.0 property references a
//!   primitive by index.)
//!
//! Units: UVs as given (normally \[0,1\] on their page), written as float VEC2. A page is an
//! opaque `u32` index (pages need not be dense); every page is its own \[0,1\]² UV space.
//!
//! References: glTF 2.0 spec §3.6.2.4 (data alignment), §3.6.2.5 (accessor bounds: min/max are
//! raw values, `normalized` has no effect), §3.7.2.1 (primitive modes), §3.7.2.2 (morph targets:
//! every primitive of a mesh has the same number), §4.4 (GLB); `KHR_materials_variants`
//! (mappings live on the primitive).
use std::collections::hash_map::Entry;
use std::collections::{BTreeSet, HashMap};
use std::ops::Range;

use base64::Engine as _;
use serde_json::{json, Map, Value};

use super::accessor::{array, Reader};
use super::bin_writer::Output;
use super::decode::Asset;
use super::error::{ErrorCode, GltfError};
use super::glb::write_glb;
use super::old_data::{droppable_accessors, live_views};
use super::triangles::{PrimitiveMode, TrianglePrimitive};

/// Which `TEXCOORD_k` receives the atlas UVs. One `k` for the whole asset: every triangle
/// primitive gets the atlas in the same set, so a material (or a baker) can point at one
/// `TEXCOORD_k` for every primitive.
///
/// A primitive that lacks some set `j < k` gets `TEXCOORD_j` too, pointing at the same atlas
/// accessor as `TEXCOORD_k` (no data copied), because glTF requires the indices of a semantic
/// to start at 0 and be continuous.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum UvTarget {
    /// The lowest `k` that no triangle primitive of the asset uses (`0` when none has UVs). So
    /// no existing set (a lightmap in `TEXCOORD_1`, say) is overwritten on any primitive. The
    /// default.
    #[default]
    FirstFree,
    /// Replace `TEXCOORD_k` on every primitive that has it (its morph-target displacements
    /// are dropped too, since they would move the atlas UVs) and add it on the others. `k`
    /// must be a set some triangle primitive has, or the [`UvTarget::FirstFree`] set: a
    /// larger `k` would fill the sets between with copies of the atlas on every primitive.
    Replace(u32),
}

/// The container to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OutputFormat {
    /// Binary `.glb` with every buffer and external image in the BIN chunk. The default.
    #[default]
    Glb,
    /// JSON `.gltf` with one `data:` (base64) buffer.
    Gltf,
}

/// What happens to the accessors the rewritten primitives used before.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OldVertexData {
    /// Drop their bytes when that is provably safe, else keep them. The default. Safe means:
    /// nothing outside the rewritten primitives references the accessor (other primitives,
    /// skins, animation samplers), and the document uses no extension outside a list known not
    /// to reference accessors or buffer views (an unknown extension might). A dropped accessor
    /// keeps its index but becomes `{componentType, count: 1, type}` with no buffer view
    /// (all zeros, unused), and buffer views nothing references any more lose their bytes.
    #[default]
    DropWhenSafe,
    /// Keep every accessor and every byte as it was (output about the input plus the new data).
    Keep,
}

/// Options of [`encode`] and [`encode_pages`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EncodeOptions {
    /// Where the UVs go. Default: [`UvTarget::FirstFree`].
    pub uv_target: UvTarget,
    /// Output container. Default: [`OutputFormat::Glb`].
    pub format: OutputFormat,
    /// Old vertex data of rewritten primitives. Default: [`OldVertexData::DropWhenSafe`].
    pub old_vertex_data: OldVertexData,
}

/// The encoded asset.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EncodedAsset {
    /// The file.
    pub bytes: Vec<u8>,
    /// The `k` of the one `TEXCOORD_k` that holds the atlas on every triangle primitive (see
    /// [`UvTarget`]).
    pub uv_set: u32,
    /// [`EncodedAsset::uv_set`] once per [`Asset::triangle_primitives`] entry (every entry is
    /// the same; kept for clients that read a set per primitive).
    pub uv_set_per_primitive: Vec<u32>,
    /// Where the faces of every triangle primitive went: one entry per (primitive, page) that
    /// has at least one face, sorted by (primitive, page), which is (mesh, primitive, page)
    /// order. A primitive without triangles is written unchanged and has no part. With
    /// [`encode`] (one page) this is one part per non-empty triangle primitive, on page 0, at
    /// its source indices.
    pub parts: Vec<EncodedPart>,
}

/// One output primitive: the faces of one source triangle primitive that lie on one page.
///
/// Its triangles are the source primitive's faces whose page is [`EncodedPart::page`], in
/// [`Asset::mesh_input`] face order, each with its corners in the source order; so output
/// triangle `i` of the part is the `i`-th such face.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct EncodedPart {
    /// The source primitive: an index into [`Asset::triangle_primitives`].
    pub primitive: usize,
    /// The page of every face of this part, as given to [`encode_pages`] (0 for [`encode`]).
    pub page: u32,
    /// Index into the output's `meshes` (always the source primitive's mesh: meshes are never
    /// added, removed or renumbered).
    pub mesh_index: usize,
    /// Index into that mesh's output `primitives`. The part on the primitive's lowest page
    /// keeps the source index; parts on other pages are appended after the mesh's source
    /// primitives in (primitive, page) order.
    pub primitive_index: usize,
    /// Number of triangles in the part (≥ 1).
    pub faces: usize,
}

impl EncodedAsset {
    /// The distinct pages that hold at least one part, ascending.
    pub fn pages(&self) -> Vec<u32> {
        let mut pages: Vec<u32> = self.parts.iter().map(|p| p.page).collect();
        pages.sort_unstable();
        pages.dedup();
        pages
    }

    /// The parts on `page`, in (mesh, primitive) order: the output primitives a renderer draws
    /// with that page's texture.
    pub fn parts_on_page(&self, page: u32) -> impl Iterator<Item = &EncodedPart> + '_ {
        self.parts.iter().filter(move |p| p.page == page)
    }
}

/// Writes `corner_uvs` (`corner_uvs[f]` = UVs of the 3 corners of `asset.mesh_input()` face `f`,
/// in corner order) into the asset, all on one page. See the module doc for what changes and
/// what does not.
///
/// Same as [`encode_pages`] with every face on page 0, byte for byte.
///
/// Cost: copies every buffer once, reads every attribute of every triangle primitive once and
/// writes it split; memory about 2× the asset plus the split vertex data.
pub fn encode(
    asset: &Asset,
    corner_uvs: &[[[f32; 2]; 3]],
    options: &EncodeOptions,
) -> Result<EncodedAsset, GltfError> {
    // 4 bytes per face, small beside the vertex data `encode_pages` writes.
    let one_page = vec![0u32; asset.mesh_input.triangles.len()];
    encode_pages(asset, corner_uvs, &one_page, options)
}

/// Writes `corner_uvs` into the asset like [`encode`], with face `f` on texture page
/// `face_page[f]` (any `u32`; each page is its own \[0,1\]² UV space).
///
/// A triangle primitive whose faces all lie on one page is written exactly as [`encode`] writes
/// it, whichever page that is. A primitive whose faces lie on several pages is split into one
/// primitive per page, so a renderer can bind one texture per page: the part on its lowest page
/// keeps the source primitive's index, the others are appended to the end of the same mesh's
/// `primitives` in (primitive, page) order. Every part is a copy of the source primitive's JSON
/// (material, mode, extras, extensions such as `KHR_materials_variants` mappings, targets)
/// with its own accessors, holding only the vertices its faces use (split at UV seams as
/// usual, morph targets gathered for the same vertices). [`EncodedAsset::parts`] says where
/// each part went.
///
/// Errors: [`ErrorCode::UvInput`] when `corner_uvs` or `face_page` does not have one entry per
/// face of [`Asset::mesh_input`] or a UV is not finite; [`ErrorCode::UvTarget`] when
/// `options.uv_target` is [`UvTarget::Replace`] with a `k` that no triangle primitive has and
/// that is above the first free set (the error names both ways out).
///
/// Cost: as [`encode`], plus sorting the faces of each multi-page primitive by page
/// (O(n log n) in its faces) and 8 bytes per face for the per-part face lists.
pub fn encode_pages(
    asset: &Asset,
    corner_uvs: &[[[f32; 2]; 3]],
    face_page: &[u32],
    options: &EncodeOptions,
) -> Result<EncodedAsset, GltfError> {
    let faces = asset.mesh_input.triangles.len();
    if corner_uvs.len() != faces {
        return Err(GltfError::new(
            ErrorCode::UvInput,
            "",
            format!(
                "got UVs for {} faces, the asset has {faces}",
                corner_uvs.len()
            ),
            "pass one [[u, v]; 3] per face of Asset::mesh_input(), in face order",
        ));
    }
    if let Some(f) = corner_uvs
        .iter()
        .position(|t| t.iter().flatten().any(|x| !x.is_finite()))
    {
        return Err(GltfError::new(
            ErrorCode::UvInput,
            "",
            format!("face {f} has a non-finite UV {:?}", corner_uvs[f]),
            "the atlas must produce finite UVs",
        ));
    }
    if face_page.len() != faces {
        // Name the primitive of the first face without a page (none when the list is too long).
        let path = asset
            .primitives
            .iter()
            .find(|p| p.faces.contains(&face_page.len()))
            .map(|p| format!("/meshes/{}/primitives/{}", p.mesh_index, p.primitive_index))
            .unwrap_or_default();
        return Err(GltfError::new(
            ErrorCode::UvInput,
            path,
            format!(
                "got pages for {} faces, the asset has {faces}",
                face_page.len()
            ),
            "pass one page index per face of Asset::mesh_input(), in face order \
             (Atlas::face_page), or call encode for a single page",
        ));
    }
    let uv_set = asset_uv_set(&asset.primitives, options.uv_target)?;

    let mut json = asset.json.clone();
    let mut out = Output::default();

    // 1. One buffer, buffer views rebased: either the original buffers back to back, or (when
    //    old vertex data is dropped) only the views something still references.
    let dropped = match options.old_vertex_data {
        OldVertexData::Keep => Vec::new(),
        OldVertexData::DropWhenSafe => droppable_accessors(asset),
    };
    let mut dead_views = Vec::new();
    if dropped.is_empty() {
        let mut bases = Vec::with_capacity(asset.buffers.len());
        for buffer in &asset.buffers {
            out.align();
            bases.push(out.bin.len() as u64);
            out.bin.extend_from_slice(buffer);
        }
        if let Some(views) = json.get_mut("bufferViews").and_then(Value::as_array_mut) {
            for view in views {
                let buffer = view.get("buffer").and_then(Value::as_u64).unwrap_or(0) as usize;
                let offset = view.get("byteOffset").and_then(Value::as_u64).unwrap_or(0);
                let base = bases.get(buffer).copied().unwrap_or(0);
                if let Some(view) = view.as_object_mut() {
                    view.insert("buffer".into(), json!(0));
                    if base + offset != 0 || view.contains_key("byteOffset") {
                        view.insert("byteOffset".into(), json!(base + offset));
                    }
                }
            }
        }
    } else {
        let live = live_views(&asset.json, &dropped);
        let views = json.get_mut("bufferViews").and_then(Value::as_array_mut);
        for (i, view) in views.into_iter().flatten().enumerate() {
            let Some(view) = view.as_object_mut() else {
                continue;
            };
            if !live.get(i).copied().unwrap_or(true) {
                dead_views.push(i);
                continue;
            }
            let buffer = view.get("buffer").and_then(Value::as_u64).unwrap_or(0) as usize;
            let offset = view.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize;
            let length = view.get("byteLength").and_then(Value::as_u64).unwrap_or(0) as usize;
            let bytes = asset
                .buffers
                .get(buffer)
                .and_then(|b| b.get(offset..offset + length))
                .unwrap_or(&[]);
            // Keep the offset's residue mod 4 so every accessor keeps its alignment.
            out.align();
            out.bin.resize(out.bin.len() + offset % 4, 0);
            view.insert("buffer".into(), json!(0));
            view.insert("byteOffset".into(), json!(out.bin.len()));
            out.bin.extend_from_slice(bytes);
        }
        if let Some(accessors) = json.get_mut("accessors").and_then(Value::as_array_mut) {
            for &i in &dropped {
                if let Some(a) = accessors.get_mut(i) {
                    let mut zero = Map::new();
                    for key in ["componentType", "type", "name"] {
                        if let Some(v) = a.get(key) {
                            zero.insert(key.into(), v.clone());
                        }
                    }
                    zero.insert("count".into(), json!(1));
                    *a = Value::Object(zero);
                }
            }
        }
    }
    out.view_count = array(&json, "bufferViews").len();
    out.accessor_count = array(&json, "accessors").len();

    // 2. External images move into the buffer.
    for image in &asset.external_images {
        let view = out.push_view(&image.bytes, None, None);
        let path = format!("/images/{}", image.index);
        let Some(obj) = json.pointer_mut(&path).and_then(Value::as_object_mut) else {
            continue;
        };
        if !obj.contains_key("mimeType") {
            let mime = sniff_image(&image.bytes).ok_or_else(|| {
                GltfError::new(
                    ErrorCode::ImageFormat,
                    format!("{path}/uri"),
                    "the supplied image is not PNG, JPEG, WebP or KTX2 and has no mimeType",
                    "add a mimeType to the image or convert it to PNG/JPEG",
                )
            })?;
            obj.insert("mimeType".into(), json!(mime));
        }
        obj.remove("uri");
        obj.insert("bufferView".into(), json!(view));
    }

    // 3. Rewrite every triangle primitive, one part per page it has faces on.
    let reader = Reader::new(&asset.json, &asset.buffers, &asset.limits)?;
    let mut packed_cache: HashMap<usize, Vec<u8>> = HashMap::new();
    let mut parts = Vec::new();
    // Parts on a primitive's other pages: (part, its JSON), appended to their mesh below.
    let mut appended: Vec<(EncodedPart, Value)> = Vec::new();
    let uv_name = format!("TEXCOORD_{uv_set}");
    for (k, prim) in asset.primitives.iter().enumerate() {
        // A primitive without triangles (a strip of two vertices) has nothing to carry UVs and
        // would need zero-element accessors, which glTF forbids: it stays as it was.
        if prim.faces.is_empty() {
            continue;
        }
        let path = format!(
            "/meshes/{}/primitives/{}",
            prim.mesh_index, prim.primitive_index
        );
        let source_prim = asset.json.pointer(&path).cloned().unwrap_or(Value::Null);
        // The sets below `uv_set` this primitive lacks: they point at the atlas accessor.
        let fillers: Vec<String> = (0..uv_set)
            .filter(|j| !prim.texcoord_sets.contains(j))
            .map(|j| format!("TEXCOORD_{j}"))
            .collect();
        for (part_number, (page, part_faces)) in faces_by_page(prim.faces.clone(), face_page)
            .into_iter()
            .enumerate()
        {
            let split = split_vertices(prim, &part_faces, &asset.mesh_input.triangles, corner_uvs);
            let mut gather = |name: &str,
                              index: u64,
                              ref_path: &str,
                              out: &mut Output|
             -> Result<u64, GltfError> {
                let layout = reader.layout(index, ref_path)?;
                // Accessors shared by several primitives (or parts) are read once.
                let packed: &[u8] = match packed_cache.entry(layout.index) {
                    Entry::Occupied(e) => e.into_mut(),
                    Entry::Vacant(e) => e.insert(reader.read_packed(layout)?),
                };
                let source_json = asset.json.pointer(&format!("/accessors/{}", layout.index));
                let with_bounds =
                    name == "POSITION" || source_json.is_some_and(|a| a.get("min").is_some());
                Ok(out.push_gathered(layout, packed, &split.source, with_bounds, source_json))
            };

            let mut attributes = Map::new();
            let mut wrote_uv = None;
            if let Some(source) = source_prim.get("attributes").and_then(Value::as_object) {
                for (name, value) in source {
                    let index = value.as_u64().unwrap_or(u64::MAX);
                    if *name == uv_name {
                        let atlas = out.push_uvs(&split.uvs);
                        attributes.insert(name.clone(), json!(atlas));
                        wrote_uv = Some(atlas);
                    } else {
                        let new =
                            gather(name, index, &format!("{path}/attributes/{name}"), &mut out)?;
                        attributes.insert(name.clone(), json!(new));
                    }
                }
            }
            let atlas = match wrote_uv {
                Some(atlas) => atlas,
                None => {
                    let atlas = out.push_uvs(&split.uvs);
                    attributes.insert(uv_name.clone(), json!(atlas));
                    atlas
                }
            };
            for name in &fillers {
                attributes.insert(name.clone(), json!(atlas));
            }
            let mut new_targets = Vec::new();
            for (t, target) in array(&source_prim, "targets").iter().enumerate() {
                let mut new_target = Map::new();
                if let Some(target) = target.as_object() {
                    for (name, value) in target {
                        if *name == uv_name {
                            continue;
                        }
                        let index = value.as_u64().unwrap_or(u64::MAX);
                        let new =
                            gather(name, index, &format!("{path}/targets/{t}/{name}"), &mut out)?;
                        new_target.insert(name.clone(), json!(new));
                    }
                }
                new_targets.push(Value::Object(new_target));
            }
            let indices = out.push_indices(&split.indices, split.source.len());

            let mut part = EncodedPart {
                primitive: k,
                page,
                mesh_index: prim.mesh_index,
                primitive_index: prim.primitive_index,
                faces: part_faces.len(),
            };
            let mut copy = Value::Null;
            let obj = if part_number == 0 {
                json.pointer_mut(&path).and_then(Value::as_object_mut)
            } else {
                copy = source_prim.clone();
                copy.as_object_mut()
            };
            let Some(obj) = obj else {
                return Err(GltfError::new(
                    ErrorCode::Internal,
                    path,
                    "primitive vanished",
                    "report this bug",
                ));
            };
            obj.insert("attributes".into(), Value::Object(attributes));
            obj.insert("indices".into(), json!(indices));
            if obj.contains_key("mode") || prim.mode != PrimitiveMode::Triangles {
                obj.insert("mode".into(), json!(4));
            }
            if obj.contains_key("targets") {
                obj.insert("targets".into(), Value::Array(new_targets));
            }
            if part_number == 0 {
                parts.push(part);
            } else {
                // The output index is assigned when the copies are appended, below.
                part.primitive_index = usize::MAX;
                appended.push((part, copy));
            }
        }
    }
    drop(reader);
    // Append the other pages' parts to their meshes in (mesh, primitive, page) order. The
    // decoder lists primitives in (mesh, primitive) order already; the stable sort makes the
    // order independent of that.
    appended.sort_by_key(|(part, _)| (part.mesh_index, part.primitive, part.page));
    for (mut part, copy) in appended {
        let list = json
            .pointer_mut(&format!("/meshes/{}/primitives", part.mesh_index))
            .and_then(Value::as_array_mut);
        let Some(list) = list else {
            return Err(GltfError::new(
                ErrorCode::Internal,
                format!("/meshes/{}/primitives", part.mesh_index),
                "mesh primitives vanished",
                "report this bug",
            ));
        };
        part.primitive_index = list.len();
        list.push(copy);
        parts.push(part);
    }
    parts.sort_by_key(|p| (p.primitive, p.page));

    // 4. Append the new views and accessors, write the one buffer. Views nothing references
    //    any more point at the start of the buffer (their bytes are gone; they stay only so
    //    that no view is renumbered).
    out.align();
    if let Some(views) = json.get_mut("bufferViews").and_then(Value::as_array_mut) {
        let available = out.bin.len().max(4);
        for &i in &dead_views {
            if let Some(view) = views.get_mut(i).and_then(Value::as_object_mut) {
                let length = view.get("byteLength").and_then(Value::as_u64).unwrap_or(4) as usize;
                let length = length.clamp(1, available);
                view.insert("byteOffset".into(), json!(0));
                view.insert("byteLength".into(), json!(length));
                if view
                    .get("byteStride")
                    .and_then(Value::as_u64)
                    .is_some_and(|s| s as usize > length)
                {
                    view.remove("byteStride");
                }
            }
        }
        if out.bin.len() < available && !dead_views.is_empty() {
            out.bin.resize(available, 0);
        }
    }
    append(&mut json, "bufferViews", std::mem::take(&mut out.views));
    append(&mut json, "accessors", std::mem::take(&mut out.accessors));
    out.align();
    let bin = out.bin;
    let first_buffer = array(&asset.json, "buffers")
        .first()
        .and_then(Value::as_object)
        .cloned();
    if bin.is_empty() {
        if let Some(root) = json.as_object_mut() {
            root.remove("buffers");
        }
    } else {
        let mut buffer = Map::new();
        if options.format == OutputFormat::Gltf {
            let encoded = base64::engine::general_purpose::STANDARD.encode(&bin);
            buffer.insert(
                "uri".into(),
                json!(format!("data:application/octet-stream;base64,{encoded}")),
            );
        }
        buffer.insert("byteLength".into(), json!(bin.len()));
        // Keep the first buffer's name, extras and extensions.
        for (key, value) in first_buffer.into_iter().flatten() {
            if key != "uri" && key != "byteLength" {
                buffer.insert(key, value);
            }
        }
        if let Some(root) = json.as_object_mut() {
            root.insert("buffers".into(), json!([Value::Object(buffer)]));
        }
    }
    let json_bytes = serde_json::to_vec(&json).map_err(|e| {
        GltfError::new(
            ErrorCode::Internal,
            "",
            format!("JSON serialisation failed: {e}"),
            "report this bug",
        )
    })?;
    let bytes = match options.format {
        OutputFormat::Glb => write_glb(&json_bytes, &bin)?,
        OutputFormat::Gltf => json_bytes,
    };
    Ok(EncodedAsset {
        bytes,
        uv_set,
        uv_set_per_primitive: vec![uv_set; asset.primitives.len()],
        parts,
    })
}

/// The one `k` of [`UvTarget`] for every primitive of the asset.
fn asset_uv_set(primitives: &[TrianglePrimitive], target: UvTarget) -> Result<u32, GltfError> {
    let in_use: BTreeSet<u32> = primitives
        .iter()
        .flat_map(|p| p.texcoord_sets.iter().copied())
        .collect();
    // At most `in_use.len()` numbers are taken, so one of 0..=len is free.
    let first_free = (0u32..).find(|k| !in_use.contains(k)).unwrap_or(u32::MAX);
    match target {
        UvTarget::FirstFree => Ok(first_free),
        UvTarget::Replace(k) if k <= first_free || in_use.contains(&k) => Ok(k),
        UvTarget::Replace(k) => {
            let (uses, replace) = if in_use.is_empty() {
                (
                    "no triangle primitive has a UV set".to_string(),
                    String::new(),
                )
            } else {
                (
                    format!(
                        "the triangle primitives use sets {in_use:?} and none has \
                         TEXCOORD_{first_free}"
                    ),
                    format!(" or to a set in use ({in_use:?}) to replace it"),
                )
            };
            Err(GltfError::new(
                ErrorCode::UvTarget,
                "/meshes",
                format!(
                    "cannot write TEXCOORD_{k}: {uses}, so every primitive would get \
                     TEXCOORD_{first_free}..TEXCOORD_{} as mere copies of the atlas",
                    k - 1
                ),
                format!(
                    "set the uv_set option (--uv-set) to first_free (TEXCOORD_{first_free} \
                     here){replace}"
                ),
            ))
        }
    }
}

/// The split vertices of one primitive.
struct Split {
    /// Source vertex (local to the primitive) of each output vertex.
    source: Vec<u32>,
    /// UV of each output vertex.
    uvs: Vec<[f32; 2]>,
    /// Three output vertices per face.
    indices: Vec<u32>,
}

/// The faces of `faces` grouped by page: (page, faces in ascending order), pages ascending.
/// `face_page` has been checked to cover every face.
fn faces_by_page(faces: Range<usize>, face_page: &[u32]) -> Vec<(u32, Vec<usize>)> {
    let page_of = |f: usize| face_page.get(f).copied().unwrap_or(0);
    let first = page_of(faces.start);
    if faces.clone().all(|f| page_of(f) == first) {
        return vec![(first, faces.collect())];
    }
    let mut order: Vec<usize> = faces.collect();
    // Stable: faces stay in source order within a page.
    order.sort_by_key(|&f| page_of(f));
    let mut groups: Vec<(u32, Vec<usize>)> = Vec::new();
    for f in order {
        let page = page_of(f);
        match groups.last_mut() {
            Some((p, list)) if *p == page => list.push(f),
            _ => groups.push((page, vec![f])),
        }
    }
    groups
}

/// Splits the vertices of `faces` (faces of `prim`, in output order).
fn split_vertices(
    prim: &TrianglePrimitive,
    faces: &[usize],
    triangles: &[[u32; 3]],
    corner_uvs: &[[[f32; 2]; 3]],
) -> Split {
    // Per source vertex, a chain of the output vertices made from it so far (`head`, then
    // `next`). Chains are as long as the number of distinct UVs at a vertex (a handful), so
    // this is linear in the corners, without hashing, and deterministic.
    const NONE: u32 = u32::MAX;
    let mut head = vec![NONE; prim.vertex_count as usize];
    let mut next: Vec<u32> = Vec::with_capacity(faces.len());
    let mut split = Split {
        source: Vec::with_capacity(faces.len()),
        uvs: Vec::with_capacity(faces.len()),
        indices: Vec::with_capacity(faces.len() * 3),
    };
    for &f in faces {
        let (Some(tri), Some(uvs)) = (triangles.get(f), corner_uvs.get(f)) else {
            continue;
        };
        for c in 0..3 {
            let local = tri[c].saturating_sub(prim.vertex_start);
            // +0.0 and -0.0 are the same UV: adding 0.0 turns -0.0 into +0.0.
            let uv = [uvs[c][0] + 0.0, uvs[c][1] + 0.0];
            let bits = [uv[0].to_bits(), uv[1].to_bits()];
            let Some(slot) = head.get_mut(local as usize) else {
                continue;
            };
            let mut v = *slot;
            while v != NONE {
                let w = split.uvs[v as usize];
                if [w[0].to_bits(), w[1].to_bits()] == bits {
                    break;
                }
                v = next[v as usize];
            }
            if v == NONE {
                v = split.source.len() as u32;
                split.source.push(local);
                split.uvs.push(uv);
                next.push(*slot);
                *slot = v;
            }
            split.indices.push(v);
        }
    }
    split
}

fn append(json: &mut Value, key: &str, items: Vec<Value>) {
    if items.is_empty() {
        return;
    }
    if let Some(root) = json.as_object_mut() {
        match root.get_mut(key).and_then(Value::as_array_mut) {
            Some(existing) => existing.extend(items),
            None => {
                root.insert(key.into(), Value::Array(items));
            }
        }
    }
}

fn sniff_image(bytes: &[u8]) -> Option<&'static str> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some("image/png")
    } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        Some("image/jpeg")
    } else if bytes.len() >= 12 && &bytes[0..4] == b"RIFF" && &bytes[8..12] == b"WEBP" {
        Some("image/webp")
    } else if bytes.starts_with(b"\xABKTX 20\xBB\r\n\x1A\n") {
        Some("image/ktx2")
    } else {
        None
    }
}
