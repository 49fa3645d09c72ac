//! The only module that knows glTF: lossless decode and encode of glTF 2.0 assets.
//!
//! # Purpose
//! [`decode`] reads a `.glb`, or a `.gltf` whose buffers and images are `data:` URIs or blobs
//! the caller supplies in [`Resources`], validates it, and extracts the triangles of every
//! triangle primitive (lists, strips, fans) as one [`MeshInput`]. [`encode`] takes per-corner
//! UVs for those triangles and writes the same asset back with a new float `TEXCOORD_k`,
//! splitting vertices only where the UVs differ. [`encode_pages`] also takes the texture page of
//! every face and splits a primitive whose faces lie on several pages into one primitive per
//! page (same material and every other property), reporting where each part went in
//! [`EncodedAsset::parts`]; for single-page input it writes exactly what [`encode`] writes.
//!
//! # Invariants
//! - No filesystem or network access, ever: external files come from [`Resources`]; URIs with
//!   a scheme other than `data:`, absolute paths and `..` segments are refused.
//! - No panic on any input: the GLB container is parsed by hand before any JSON parser sees it,
//!   every index and byte range is checked, and [`decode`] runs under `catch_unwind` as a last
//!   line of defence (a panic becomes [`ErrorCode::Internal`]).
//! - No allocation from a declared size before checking it against real bytes; accessors with
//!   no buffer view (implicit zeros) and totals are capped by [`DecodeLimits`].
//! - Every error carries the JSON pointer at fault ([`GltfError::json_path`]).
//! - The output is the input's JSON tree (`serde_json::Value` with preserved key order) with
//!   only these edits: the attributes/indices/targets/mode of triangle primitives point to new
//!   accessors; primitives for a split primitive's other pages are appended to its mesh; new
//!   accessors and buffer views are appended; buffers are merged into one (the
//!   GLB BIN chunk, or one `data:` buffer for `.gltf`) and buffer views rebased; external images
//!   are embedded through a buffer view. Existing accessors are never renumbered, so
//!   animations, skins and unknown extensions that reference them stay valid. The rewritten
//!   primitives' old accessors lose their bytes only when that is provably safe (nothing else
//!   references them and no extension that might is present, see [`OldVertexData`]); otherwise
//!   they are kept as they were.
//! - Meshes are unwrapped once, in mesh-local space: node transforms are not applied and a
//!   mesh instanced by several nodes appears once.
//! - Multi-page output never renumbers meshes or moves a single-page primitive: the part on a
//!   primitive's lowest page keeps its (mesh, primitive) index, parts on other pages are
//!   appended to the same mesh in (primitive, page) order (see `encode.rs` for what a copy
//!   cannot keep exact).
//!
//! # Units
//! Positions are in the asset's units (metres by glTF convention); UVs are in \[0,1\] texture
//! space with glTF's convention (origin top-left, v down) — we write what we are given.
//!
//! # References
//! glTF 2.0 specification (Khronos, 2021): §3.6 buffers/accessors, §3.7.2 primitive modes and
//! strip/fan triangle order, §4.4 GLB; `KHR_mesh_quantization`.
mod accessor;
mod bin_writer;
mod decode;
mod encode;
mod error;
mod glb;
mod limits;
mod old_data;
mod triangles;
mod uri;
mod validate;

pub use decode::{
    decode, required_resources, Asset, AssetSummary, MeshSummary, PrimitiveSummary, SourceFormat,
};
pub use encode::{
    encode, encode_pages, EncodeOptions, EncodedAsset, EncodedPart, OldVertexData, OutputFormat,
    UvTarget,
};
pub use error::{ErrorCode, GltfError};
pub use limits::DecodeLimits;
pub use triangles::{PrimitiveMode, TrianglePrimitive};
pub use uri::{relative_path_of, Resources};

#[doc(no_inline)]
pub use crate::mesh::MeshInput;
