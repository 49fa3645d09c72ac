//! URIs of buffers and images: `data:` URIs are decoded here, relative references are looked up
//! in the caller's [`Resources`], everything else is refused.
//!
//! Invariant (architecture): this module never touches the filesystem or the network. A URI
//! with a scheme other than `data:` (`file:`, `http:`, ...), an absolute path, a `\` or a `..`
//! segment is refused with [`ErrorCode::UriForbidden`] before any lookup, so even a caller that
//! fills `Resources` from a directory cannot be steered outside it by the asset.
//!
//! References: glTF 2.0 spec §3.6.1.2 (URIs), RFC 2397 (`data:`), RFC 3986 §2.1 (percent
//! encoding).
use std::collections::BTreeMap;

use super::error::{ErrorCode, GltfError};

/// External files of a `.gltf` (buffers and images), supplied by the caller as named byte
/// blobs, for example from a multipart upload. Names are relative URIs exactly as they appear
/// in the asset (`"scene.bin"`, `"textures/wood.png"`); a percent-decoded form
/// (`"my%20file.bin"` → `"my file.bin"`) is also found.
#[derive(Debug, Clone, Default)]
pub struct Resources {
    blobs: BTreeMap<String, Vec<u8>>,
}

impl Resources {
    /// No resources: enough for `.glb` files and `.gltf` files with `data:` URIs only.
    pub fn new() -> Self {
        Resources::default()
    }

    /// Adds (or replaces) the blob for a relative URI.
    pub fn insert(&mut self, uri: impl Into<String>, bytes: Vec<u8>) {
        self.blobs.insert(uri.into(), bytes);
    }

    /// The blob for `uri`: the exact name first, then its percent-decoded form.
    pub fn get(&self, uri: &str) -> Option<&[u8]> {
        if let Some(bytes) = self.blobs.get(uri) {
            return Some(bytes);
        }
        let decoded = percent_decode(uri)?;
        self.blobs.get(&decoded).map(Vec::as_slice)
    }

    /// Number of blobs.
    pub fn len(&self) -> usize {
        self.blobs.len()
    }

    /// True when no blob was supplied.
    pub fn is_empty(&self) -> bool {
        self.blobs.is_empty()
    }
}

/// The file path a relative URI names: the URI percent-decoded (`"my%20file.bin"` →
/// `"my file.bin"`), or the URI itself when it has no valid escapes. For callers that read
/// [`required_resources`](super::required_resources) from a directory.
pub fn relative_path_of(uri: &str) -> String {
    percent_decode(uri).unwrap_or_else(|| uri.to_string())
}

fn percent_decode(s: &str) -> Option<String> {
    if !s.contains('%') {
        return None;
    }
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes.get(i + 1..i + 3)?;
            let hex = std::str::from_utf8(hex).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// Where a URI's bytes come from.
#[derive(Debug)]
pub(crate) enum Resolved<'a> {
    /// Decoded from a `data:` URI.
    Data(Vec<u8>),
    /// Supplied by the caller.
    Supplied(&'a [u8]),
}

/// Resolves `uri` found at JSON pointer `path`.
pub(crate) fn resolve<'a>(
    uri: &str,
    path: &str,
    resources: &'a Resources,
) -> Result<Resolved<'a>, GltfError> {
    if uri.starts_with("data:") {
        return decode_data_uri(uri, path).map(Resolved::Data);
    }
    check_relative(uri, path)?;
    resources.get(uri).map(Resolved::Supplied).ok_or_else(|| {
        GltfError::new(
            ErrorCode::ResourceMissing,
            path,
            format!("the external file `{uri}` was not supplied"),
            format!("upload `{uri}` together with the .gltf, or send a .glb"),
        )
    })
}

pub(crate) fn check_relative(uri: &str, path: &str) -> Result<(), GltfError> {
    let forbidden = |why: &str| {
        GltfError::new(
            ErrorCode::UriForbidden,
            path,
            format!("URI `{uri}` is refused: {why}"),
            "reference external files by relative paths inside the asset's folder, or embed them",
        )
    };
    // A scheme is letters/digits/+-. before the first ':' (RFC 3986 §3.1); Windows drive
    // letters (`C:`) count too and are refused as absolute paths.
    if let Some(colon) = uri.find(':') {
        let scheme = &uri[..colon];
        if !scheme.is_empty()
            && !scheme.contains('/')
            && scheme
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.'))
        {
            return Err(forbidden(
                "only `data:` URIs and relative references are allowed",
            ));
        }
    }
    if uri.is_empty() {
        return Err(forbidden("it is empty"));
    }
    let decoded = percent_decode(uri).unwrap_or_else(|| uri.to_string());
    if decoded.starts_with('/') || decoded.contains('\\') {
        return Err(forbidden("absolute paths and backslashes are not allowed"));
    }
    if decoded.split('/').any(|segment| segment == "..") {
        return Err(forbidden("`..` segments could escape the asset's folder"));
    }
    Ok(())
}

/// Decodes a base64 `data:` URI with the `data-url` crate (the Fetch standard's data: URL
/// processor): the body is percent-decoded, then forgiving-base64 decoded (ASCII whitespace
/// ignored, `=` padding optional); a `#fragment` is ignored.
///
/// Only base64 data URIs are taken: glTF exporters write binary buffers and images that way,
/// and a percent-encoded (non-base64) one is refused as `data_uri_invalid`, as before.
fn decode_data_uri(uri: &str, path: &str) -> Result<Vec<u8>, GltfError> {
    let invalid = |why: &str| {
        GltfError::new(
            ErrorCode::DataUriInvalid,
            path,
            format!("malformed data: URI: {why}"),
            "write embedded data as `data:<media type>;base64,<base64>`",
        )
    };
    let url = data_url::DataUrl::process(uri).map_err(|e| match e {
        data_url::DataUrlError::NoComma => invalid("no `,` separator"),
        other => invalid(&other.to_string()),
    })?;
    let header = uri["data:".len()..].split(',').next().unwrap_or_default();
    if !declares_base64(header) {
        return Err(invalid("only base64 data URIs are supported"));
    }
    // Cost: decodes into a new buffer of about 3/4 of the payload; bounded by the input size.
    let (bytes, _fragment) = url
        .decode_to_vec()
        .map_err(|e| invalid(&format!("base64 error: {e}")))?;
    Ok(bytes)
}

/// Whether a data URI's header (between `data:` and `,`) ends in `;base64`, by the rule that
/// `data_url::DataUrl` applies and does not expose: ASCII case-insensitive, tabs and line
/// breaks ignored, spaces allowed around `base64`.
fn declares_base64(header: &str) -> bool {
    let kept: Vec<u8> = header
        .bytes()
        .filter(|b| !matches!(b, b'\t' | b'\n' | b'\r'))
        .collect();
    let trimmed = kept.trim_ascii_end();
    let Some(split) = trimmed.len().checked_sub(6) else {
        return false;
    };
    let (before, word) = trimmed.split_at(split);
    word.eq_ignore_ascii_case(b"base64") && before.trim_ascii_end().ends_with(b";")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_uri_decodes() {
        let none = Resources::new();
        let r = resolve(
            "data:application/octet-stream;base64,AAEC",
            "/buffers/0/uri",
            &none,
        )
        .expect("valid");
        match r {
            Resolved::Data(bytes) => assert_eq!(bytes, vec![0, 1, 2]),
            Resolved::Supplied(_) => panic!("expected data"),
        }
        let e = resolve("data:text/plain,hello", "/p", &Resources::new()).expect_err("not base64");
        assert_eq!(e.code, ErrorCode::DataUriInvalid);
        assert_eq!(e.json_path, "/p");
    }

    fn data(uri: &str) -> Result<Vec<u8>, GltfError> {
        match resolve(uri, "/buffers/1/uri", &Resources::new())? {
            Resolved::Data(bytes) => Ok(bytes),
            Resolved::Supplied(_) => panic!("{uri}: expected data"),
        }
    }

    #[test]
    fn base64_data_uris_in_their_written_forms() {
        let hello = b"hello".to_vec();
        for uri in [
            "data:application/octet-stream;base64,aGVsbG8=",
            // Padding is optional; whitespace and line breaks inside the payload are ignored.
            "data:application/octet-stream;base64,aGVsbG8",
            "data:application/octet-stream;base64,aGVs\nbG8=",
            "data:application/octet-stream;base64,aGVs bG8=",
            // Percent-encoded payload bytes (`%3D` is `=`) and header.
            "data:application/octet-stream;base64,aGVsbG8%3D",
            "data:application%2Foctet-stream;base64,aGVsbG8=",
            // `;base64` is case-insensitive, spaces allowed; the media type may be absent.
            "data:image/png;BASE64,aGVsbG8=",
            "data:;base64,aGVsbG8=",
            "data:text/plain; base64 ,aGVsbG8=",
            // Trailing whitespace of the URI, and a fragment, are not payload.
            "data:application/octet-stream;base64,aGVsbG8=  ",
            "data:application/octet-stream;base64,aGVsbG8=#part",
        ] {
            assert_eq!(
                data(uri).unwrap_or_else(|e| panic!("{uri}: {e}")),
                hello,
                "{uri}"
            );
        }
        assert_eq!(
            data("data:application/octet-stream;base64,").unwrap(),
            Vec::<u8>::new()
        );
    }

    #[test]
    fn bad_data_uris_are_data_uri_invalid_at_their_path() {
        for (uri, why) in [
            ("data:application/octet-stream;base64", "no `,`"),
            ("data:", "no `,`"),
            ("data:application/octet-stream;base64,aGVsbG8*", "base64"),
            ("data:application/octet-stream;base64,a", "base64"),
            ("data:application/octet-stream;base64,aG=VsbG8", "base64"),
            ("data:application/octet-stream,hello", "only base64"),
            ("data:application/octet-stream,hello%20world", "only base64"),
            ("data:application/base64,aGVsbG8=", "only base64"),
            ("data:text/plain;charset=base64,aGVsbG8=", "only base64"),
        ] {
            let e = data(uri).expect_err(uri);
            assert_eq!(e.code, ErrorCode::DataUriInvalid, "{uri}");
            assert_eq!(e.json_path, "/buffers/1/uri", "{uri}");
            assert!(e.detail.contains(why), "{uri}: {}", e.detail);
        }
    }

    #[test]
    fn forbidden_uris_are_refused_even_when_supplied() {
        let mut res = Resources::new();
        for uri in [
            "../../etc/passwd",
            "a/../../b.bin",
            "%2e%2e/x.bin",
            "file:///etc/passwd",
            "http://127.0.0.1:1/",
            "https://example.com/a.bin",
            "/etc/passwd",
            "C:/x.bin",
            "a\\b.bin",
            "",
        ] {
            res.insert(uri, vec![1]);
            let e = resolve(uri, "/buffers/0/uri", &res).expect_err(uri);
            assert_eq!(e.code, ErrorCode::UriForbidden, "{uri}");
        }
    }

    #[test]
    fn relative_path_of_percent_decodes() {
        assert_eq!(relative_path_of("tex/my%20wood.png"), "tex/my wood.png");
        assert_eq!(relative_path_of("plain.bin"), "plain.bin");
        assert_eq!(relative_path_of("bad%zz.bin"), "bad%zz.bin");
    }

    #[test]
    fn relative_uris_are_looked_up_exactly_then_percent_decoded() {
        let mut res = Resources::new();
        res.insert("dir/my file.bin", vec![7, 8]);
        assert!(matches!(
            resolve("dir/my%20file.bin", "/x", &res),
            Ok(Resolved::Supplied(b)) if b == [7, 8]
        ));
        let e = resolve("other.bin", "/buffers/2/uri", &res).expect_err("missing");
        assert_eq!(e.code, ErrorCode::ResourceMissing);
        assert_eq!(e.json_path, "/buffers/2/uri");
        assert_eq!(res.len(), 1);
        assert!(!res.is_empty());
    }
}
