//! The one error type of `gltf_io`: a stable code, the JSON path at fault, and how to fix it.
//!
//! Invariant: every error that comes from the asset's content names the place in the document
//! (an RFC 6901 JSON pointer such as `/accessors/3/bufferView`) or, for container faults, the
//! GLB byte range in `detail` with an empty or `""` path. Codes are stable snake_case strings
//! (see [`ErrorCode::as_str`]) so the HTTP layer can put them in `application/problem+json`.
use std::fmt;

/// What went wrong, as a stable machine-readable code.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ErrorCode {
    /// The bytes are neither a GLB (magic `glTF`) nor a JSON document.
    NotGltf,
    /// The GLB header, its `length` field, or a chunk header/length is inconsistent with the file.
    GlbContainer,
    /// The GLB version is not 2.
    GlbVersion,
    /// The JSON text does not parse (syntax, encoding, or not an object).
    JsonSyntax,
    /// The JSON is nested deeper than the parser's limit (128 levels).
    JsonTooDeep,
    /// The document violates the glTF 2.0 schema (a required property is missing, a value is
    /// invalid, or an index points to no object).
    Schema,
    /// `asset.version` is not a 2.x version.
    AssetVersion,
    /// A URI uses a scheme other than `data:`, is absolute, or escapes with `..`.
    UriForbidden,
    /// A relative URI names a resource that the caller did not supply.
    ResourceMissing,
    /// A `data:` URI is malformed or not base64.
    DataUriInvalid,
    /// A buffer holds fewer bytes than its `byteLength`, or a buffer view lies outside its buffer.
    BufferOutOfBounds,
    /// An accessor (or its sparse part) reaches past its buffer view, or its layout is invalid.
    AccessorOutOfBounds,
    /// An accessor's type/componentType is not allowed where it is used.
    AccessorInvalid,
    /// A vertex index is not smaller than the number of vertices.
    IndexOutOfRange,
    /// A POSITION value is NaN or infinite.
    NonFinitePosition,
    /// A primitive is malformed (no POSITION, attribute counts differ, index count does not fit
    /// the mode).
    PrimitiveInvalid,
    /// The node hierarchy is not a forest (a cycle, or a node with two parents).
    NodeHierarchy,
    /// The asset uses an extension whose data we cannot decode (mesh compression).
    UnsupportedExtension,
    /// A size limit from [`super::DecodeLimits`] was exceeded.
    LimitExceeded,
    /// `encode` was given UVs that do not match the decoded asset, or non-finite UVs.
    UvInput,
    /// The requested UV set cannot be written: no primitive has it and it is above the first
    /// free set, so the sets between would be mere copies of the atlas.
    UvTarget,
    /// An image supplied by the caller has an unrecognised format and no `mimeType`.
    ImageFormat,
    /// A bug or an unexpected panic inside the decoder; the input may be fine.
    Internal,
}

impl ErrorCode {
    /// The stable snake_case name of the code.
    pub fn as_str(self) -> &'static str {
        match self {
            ErrorCode::NotGltf => "not_gltf",
            ErrorCode::GlbContainer => "glb_container",
            ErrorCode::GlbVersion => "glb_version",
            ErrorCode::JsonSyntax => "json_syntax",
            ErrorCode::JsonTooDeep => "json_too_deep",
            ErrorCode::Schema => "schema",
            ErrorCode::AssetVersion => "asset_version",
            ErrorCode::UriForbidden => "uri_forbidden",
            ErrorCode::ResourceMissing => "resource_missing",
            ErrorCode::DataUriInvalid => "data_uri_invalid",
            ErrorCode::BufferOutOfBounds => "buffer_out_of_bounds",
            ErrorCode::AccessorOutOfBounds => "accessor_out_of_bounds",
            ErrorCode::AccessorInvalid => "accessor_invalid",
            ErrorCode::IndexOutOfRange => "index_out_of_range",
            ErrorCode::NonFinitePosition => "non_finite_position",
            ErrorCode::PrimitiveInvalid => "primitive_invalid",
            ErrorCode::NodeHierarchy => "node_hierarchy",
            ErrorCode::UnsupportedExtension => "unsupported_extension",
            ErrorCode::LimitExceeded => "limit_exceeded",
            ErrorCode::UvInput => "uv_input",
            ErrorCode::UvTarget => "uv_target",
            ErrorCode::ImageFormat => "image_format",
            ErrorCode::Internal => "internal",
        }
    }
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A decode or encode failure.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{code} at {json_path_display}: {detail} (fix: {fix})", json_path_display = display_path(.json_path))]
pub struct GltfError {
    /// The stable code.
    pub code: ErrorCode,
    /// RFC 6901 JSON pointer to the offending value, e.g. `/accessors/3/bufferView`. Empty for
    /// faults of the GLB container or of the whole document.
    pub json_path: String,
    /// What is wrong, with the numbers involved.
    pub detail: String,
    /// How to fix it.
    pub fix: String,
}

fn display_path(path: &str) -> &str {
    if path.is_empty() {
        "<document>"
    } else {
        path
    }
}

impl GltfError {
    /// Builds an error.
    pub fn new(
        code: ErrorCode,
        json_path: impl Into<String>,
        detail: impl Into<String>,
        fix: impl Into<String>,
    ) -> Self {
        GltfError {
            code,
            json_path: json_path.into(),
            detail: detail.into(),
            fix: fix.into(),
        }
    }
}

/// Converts a `gltf-json` path (`meshes[0].primitives[1].attributes["POSITION"]`) into a JSON
/// pointer (`/meshes/0/primitives/1/attributes/POSITION`). Anything after ` = ` (a value note
/// the crate appends) is dropped.
pub(crate) fn pointer_from_gltf_path(path: &str) -> String {
    let path = path.split(" = ").next().unwrap_or("");
    let mut out = String::with_capacity(path.len() + 8);
    let mut chars = path.chars().peekable();
    let mut at_segment_start = true;
    while let Some(c) = chars.next() {
        match c {
            '.' => at_segment_start = true,
            '[' => {
                out.push('/');
                let quoted = chars.peek() == Some(&'"');
                if quoted {
                    chars.next();
                }
                for d in chars.by_ref() {
                    if (quoted && d == '"') || (!quoted && d == ']') {
                        break;
                    }
                    push_escaped(&mut out, d);
                }
                if quoted {
                    // Skip the closing bracket after the quote.
                    if chars.peek() == Some(&']') {
                        chars.next();
                    }
                }
                at_segment_start = false;
            }
            _ => {
                if at_segment_start {
                    out.push('/');
                    at_segment_start = false;
                }
                push_escaped(&mut out, c);
            }
        }
    }
    out
}

/// The JSON pointer of the innermost value open at byte `offset` of `json`: used to name the
/// place of a serde error, which only knows its line and column. A small scanner over the text
/// (strings and escapes, objects with their current key, arrays with their current index); for
/// an error reported just after a value it names that value, for an error at a closing brace
/// (e.g. "missing field") it names the object.
pub(crate) fn pointer_at_offset(json: &[u8], offset: usize) -> String {
    enum Frame {
        Object {
            key: Option<String>,
            expecting_key: bool,
        },
        Array {
            index: usize,
        },
    }
    let mut stack: Vec<Frame> = Vec::new();
    let mut i = 0;
    let end = offset.min(json.len());
    while i < end {
        match json[i] {
            b'"' => {
                let start = i + 1;
                i += 1;
                while i < json.len() && json[i] != b'"' {
                    i += if json[i] == b'\\' { 2 } else { 1 };
                }
                let text =
                    String::from_utf8_lossy(json.get(start..i.min(json.len())).unwrap_or(&[]));
                if let Some(Frame::Object { key, expecting_key }) = stack.last_mut() {
                    if *expecting_key {
                        *key = Some(text.into_owned());
                        *expecting_key = false;
                    }
                }
            }
            b'{' => stack.push(Frame::Object {
                key: None,
                expecting_key: true,
            }),
            b'[' => stack.push(Frame::Array { index: 0 }),
            b'}' | b']' => {
                stack.pop();
            }
            b',' => match stack.last_mut() {
                Some(Frame::Array { index }) => *index += 1,
                Some(Frame::Object { key, expecting_key }) => {
                    *key = None;
                    *expecting_key = true;
                }
                None => {}
            },
            _ => {}
        }
        i += 1;
    }
    let mut out = String::new();
    for frame in &stack {
        match frame {
            Frame::Object { key: Some(key), .. } => {
                out.push('/');
                key.chars().for_each(|c| push_escaped(&mut out, c));
            }
            Frame::Object { key: None, .. } => break,
            Frame::Array { index } => out.push_str(&format!("/{index}")),
        }
    }
    out
}

/// Byte offset of a 1-based (line, column) position as serde_json reports it.
pub(crate) fn offset_of_line_column(json: &[u8], line: usize, column: usize) -> usize {
    let mut line_start = 0;
    if line > 1 {
        let mut seen = 1;
        for (i, &b) in json.iter().enumerate() {
            if b == b'\n' {
                seen += 1;
                if seen == line {
                    line_start = i + 1;
                    break;
                }
            }
        }
    }
    (line_start + column).min(json.len())
}

fn push_escaped(out: &mut String, c: char) {
    match c {
        '~' => out.push_str("~0"),
        '/' => out.push_str("~1"),
        _ => out.push(c),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gltf_paths_become_json_pointers() {
        assert_eq!(
            pointer_from_gltf_path("meshes[0].primitives[12].attributes[\"POSITION\"]"),
            "/meshes/0/primitives/12/attributes/POSITION"
        );
        assert_eq!(
            pointer_from_gltf_path("accessors[3].bufferView"),
            "/accessors/3/bufferView"
        );
        assert_eq!(
            pointer_from_gltf_path("asset.version = \"3.0\""),
            "/asset/version"
        );
        assert_eq!(pointer_from_gltf_path("x[\"a/b~c\"]"), "/x/a~1b~0c");
        assert_eq!(pointer_from_gltf_path(""), "");
    }

    #[test]
    fn offsets_map_to_the_open_value() {
        let json = br#"{"accessors": [{"count": 3}, {"count": "x", "type": "VEC3"}], "asset": {}}"#;
        let at = |needle: &str| {
            let text = std::str::from_utf8(json).expect("utf8");
            text.find(needle).expect("needle") + needle.len()
        };
        assert_eq!(pointer_at_offset(json, at("\"x\"")), "/accessors/1/count");
        assert_eq!(
            pointer_at_offset(json, at("{\"count\": 3}")),
            "/accessors/0"
        );
        assert_eq!(pointer_at_offset(json, at("\"asset\": {")), "/asset");
        assert_eq!(pointer_at_offset(json, json.len()), "");
        let two_lines = b"{\n \"a\": 1}";
        assert_eq!(offset_of_line_column(two_lines, 2, 7), 9);
        assert_eq!(pointer_at_offset(two_lines, 9), "/a");
    }

    #[test]
    fn display_names_code_path_and_fix() {
        let e = GltfError::new(ErrorCode::Schema, "/nodes/1", "bad", "repair it");
        assert_eq!(e.to_string(), "schema at /nodes/1: bad (fix: repair it)");
        let e = GltfError::new(ErrorCode::NotGltf, "", "x", "y");
        assert!(e.to_string().contains("<document>"));
    }
}
