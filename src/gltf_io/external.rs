//! Which external files a `.gltf` references, so that a caller holding the files (the CLI
//! reading a directory, the service reading a multipart upload) can supply them as
//! [`Resources`](super::Resources) without understanding glTF.
//!
//! Invariant: lists only references that [`decode`](super::decode) would accept: relative, no
//! scheme, no absolute path, no `\`, no `..` segment. Refused and `data:` URIs are left out; the
//! decoder reports refused ones with their JSON path.
use serde_json::Value;

use super::decode::parse_json;
use super::error::{ErrorCode, GltfError};
use super::glb;
use super::uri::{check_relative, percent_decode};

/// One external file referenced by the document.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExternalReference {
    /// The URI exactly as written in the document: the key to give [`super::Resources::insert`].
    pub uri: String,
    /// The URI percent-decoded: the file's path relative to the `.gltf`'s directory.
    pub relative_path: String,
    /// Where it is referenced, e.g. `/buffers/0/uri`.
    pub json_path: String,
}

/// The external buffers and images of a glTF document (empty for a `.glb` without URIs).
///
/// Cost: parses the JSON once (no buffer is read or decoded).
pub fn external_resources(bytes: &[u8]) -> Result<Vec<ExternalReference>, GltfError> {
    let json_bytes = if glb::is_glb(bytes) {
        glb::parse_glb(bytes)?.json
    } else {
        let text = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
        if text.iter().find(|b| !b.is_ascii_whitespace()) != Some(&b'{') {
            return Err(GltfError::new(
                ErrorCode::NotGltf,
                "",
                "the data is neither a GLB (magic `glTF`) nor a JSON object",
                "send a .glb file or a .gltf JSON file",
            ));
        }
        text
    };
    let root = parse_json(json_bytes)?;
    let mut out = Vec::new();
    for key in ["buffers", "images"] {
        let Some(items) = root.get(key).and_then(Value::as_array) else {
            continue;
        };
        for (i, item) in items.iter().enumerate() {
            let Some(uri) = item.get("uri").and_then(Value::as_str) else {
                continue;
            };
            let json_path = format!("/{key}/{i}/uri");
            if uri.starts_with("data:") || check_relative(uri, &json_path).is_err() {
                continue;
            }
            out.push(ExternalReference {
                uri: uri.to_string(),
                relative_path: percent_decode(uri).unwrap_or_else(|| uri.to_string()),
                json_path,
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_only_acceptable_relative_references() {
        let doc = br#"{"asset":{"version":"2.0"},
            "buffers":[{"uri":"a.bin","byteLength":1},{"uri":"data:application/octet-stream;base64,AA==","byteLength":1},
                       {"uri":"../x.bin","byteLength":1},{"uri":"file:///etc/passwd","byteLength":1},{"byteLength":1}],
            "images":[{"uri":"tex/my%20wood.png"},{"uri":"http://127.0.0.1:1/a.png"},{"bufferView":0}]}"#;
        let refs = external_resources(doc).expect("parses");
        assert_eq!(
            refs,
            vec![
                ExternalReference {
                    uri: "a.bin".into(),
                    relative_path: "a.bin".into(),
                    json_path: "/buffers/0/uri".into()
                },
                ExternalReference {
                    uri: "tex/my%20wood.png".into(),
                    relative_path: "tex/my wood.png".into(),
                    json_path: "/images/0/uri".into()
                },
            ]
        );
    }

    #[test]
    fn garbage_is_an_error_not_a_panic() {
        assert_eq!(
            external_resources(b"\x00\x01").expect_err("garbage").code,
            ErrorCode::NotGltf
        );
        assert!(external_resources(b"glTF\x02\x00\x00\x00\x05\x00\x00\x00").is_err());
    }
}
