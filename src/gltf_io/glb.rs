//! The GLB container (glTF 2.0 spec §4.4): a 12-byte header, a JSON chunk, an optional BIN chunk.
//!
//! Purpose: split a GLB into its JSON text and BIN bytes *before* any JSON parser sees it, and
//! write a GLB back. We parse the container ourselves because `gltf` 1.4.1 panics on a header
//! whose `length` is below 12 (see GUIDE.md, "Known pitfalls").
//!
//! Invariants checked on read: magic `glTF`, version 2, `12 <= length <= data.len()`, every
//! chunk header and chunk body inside `length`, chunk lengths multiples of 4, first chunk JSON,
//! at most one BIN chunk and it comes second. Unknown chunk types after the first are skipped as
//! the spec requires. Nothing is allocated from a declared size: the returned slices borrow the
//! input.
//!
//! Units: bytes, little-endian `u32` fields.
use super::error::{ErrorCode, GltfError};

/// `glTF` in ASCII, little-endian.
pub(crate) const MAGIC: u32 = 0x4654_6C67;
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// The two chunks of a GLB, borrowed from the input.
#[derive(Debug)]
pub(crate) struct GlbParts<'a> {
    pub json: &'a [u8],
    pub bin: Option<&'a [u8]>,
}

fn read_u32(data: &[u8], at: usize) -> Option<u32> {
    let bytes = data.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]))
}

fn container_error(detail: String) -> GltfError {
    GltfError::new(
        ErrorCode::GlbContainer,
        "",
        detail,
        "the file is truncated or corrupted; re-export it as GLB 2.0",
    )
}

/// True when `data` starts with the GLB magic.
pub(crate) fn is_glb(data: &[u8]) -> bool {
    read_u32(data, 0) == Some(MAGIC)
}

/// Splits a GLB into its chunks. `data` must start with the magic (see [`is_glb`]).
pub(crate) fn parse_glb(data: &[u8]) -> Result<GlbParts<'_>, GltfError> {
    let header_error = || {
        container_error(format!(
            "GLB header needs 12 bytes, file has {}",
            data.len()
        ))
    };
    if read_u32(data, 0).ok_or_else(header_error)? != MAGIC {
        return Err(GltfError::new(
            ErrorCode::NotGltf,
            "",
            "the first 4 bytes are not the GLB magic `glTF`",
            "send a .glb or a .gltf JSON file",
        ));
    }
    let version = read_u32(data, 4).ok_or_else(header_error)?;
    let declared = read_u32(data, 8).ok_or_else(header_error)?;
    if version != 2 {
        return Err(GltfError::new(
            ErrorCode::GlbVersion,
            "",
            format!("GLB version is {version}, only 2 is supported"),
            "convert the asset to glTF 2.0",
        ));
    }
    let length = declared as usize;
    if length < 12 || length > data.len() {
        return Err(container_error(format!(
            "GLB header length is {declared} but the file has {} bytes (must be 12..=file size)",
            data.len()
        )));
    }
    let data = &data[..length];
    let mut offset = 12usize;
    let mut json = None;
    let mut bin = None;
    let mut index = 0usize;
    while offset < length {
        let (Some(chunk_len), Some(chunk_type)) =
            (read_u32(data, offset), read_u32(data, offset + 4))
        else {
            return Err(container_error(format!(
                "chunk {index} header at byte {offset} runs past the end ({length} bytes)"
            )));
        };
        let start = offset + 8;
        let end = start
            .checked_add(chunk_len as usize)
            .filter(|&end| end <= length)
            .ok_or_else(|| {
                container_error(format!(
                    "chunk {index} at byte {offset} declares {chunk_len} bytes, past the end of the \
                     {length}-byte file"
                ))
            })?;
        if chunk_len % 4 != 0 {
            return Err(container_error(format!(
                "chunk {index} length {chunk_len} is not a multiple of 4"
            )));
        }
        let body = &data[start..end];
        match (index, chunk_type) {
            (0, CHUNK_JSON) => json = Some(body),
            (0, other) => {
                return Err(container_error(format!(
                    "the first chunk has type 0x{other:08x}, expected JSON (0x{CHUNK_JSON:08x})"
                )))
            }
            (1, CHUNK_BIN) => bin = Some(body),
            (_, CHUNK_JSON) | (_, CHUNK_BIN) => {
                return Err(container_error(format!(
                    "chunk {index} repeats a JSON or BIN chunk (BIN may only be chunk 1)"
                )))
            }
            // Unknown chunk types must be ignored (spec §4.4.3.1).
            _ => {}
        }
        offset = end;
        index += 1;
    }
    let json = json.ok_or_else(|| container_error("the GLB has no JSON chunk".to_string()))?;
    Ok(GlbParts { json, bin })
}

/// Writes a GLB: the JSON padded with spaces and the BIN (if not empty) padded with zeros to 4
/// bytes. Fails only if the result would exceed the 4 GiB the 32-bit length field can address.
pub(crate) fn write_glb(json: &[u8], bin: &[u8]) -> Result<Vec<u8>, GltfError> {
    let json_padded = json.len().div_ceil(4) * 4;
    let bin_padded = bin.len().div_ceil(4) * 4;
    let total = 12 + 8 + json_padded + if bin.is_empty() { 0 } else { 8 + bin_padded };
    let too_big = || {
        GltfError::new(
            ErrorCode::LimitExceeded,
            "",
            format!("the output GLB would be {total} bytes, above the 4 GiB GLB limit"),
            "request `.gltf` output or split the asset",
        )
    };
    let total_u32 = u32::try_from(total).map_err(|_| too_big())?;
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(&MAGIC.to_le_bytes());
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total_u32.to_le_bytes());
    out.extend_from_slice(&(json_padded as u32).to_le_bytes());
    out.extend_from_slice(&CHUNK_JSON.to_le_bytes());
    out.extend_from_slice(json);
    out.resize(20 + json_padded, b' ');
    if !bin.is_empty() {
        out.extend_from_slice(&(bin_padded as u32).to_le_bytes());
        out.extend_from_slice(&CHUNK_BIN.to_le_bytes());
        out.extend_from_slice(bin);
        out.resize(total, 0);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn write_then_parse_round_trips_and_pads() {
        let glb = write_glb(b"{\"a\":1}", &[1, 2, 3, 4, 5]).expect("small");
        assert_eq!(glb.len() % 4, 0);
        assert_eq!(read_u32(&glb, 8), Some(glb.len() as u32));
        let parts = parse_glb(&glb).expect("valid");
        assert_eq!(parts.json, b"{\"a\":1} ");
        assert_eq!(parts.bin, Some(&[1u8, 2, 3, 4, 5, 0, 0, 0][..]));
    }

    #[test]
    fn header_length_below_12_is_a_container_error_not_a_panic() {
        // The input that makes gltf 1.4.1 panic: a header whose length field is 0.
        let mut glb = write_glb(b"{}", &[]).expect("small");
        glb[8..12].copy_from_slice(&0u32.to_le_bytes());
        let err = parse_glb(&glb).expect_err("length 0");
        assert_eq!(err.code, ErrorCode::GlbContainer);
    }

    #[test]
    fn chunk_length_past_end_is_rejected() {
        let mut glb = write_glb(b"{}", &[9; 8]).expect("small");
        // BIN chunk length field sits right after the padded JSON chunk.
        let bin_header = 12 + 8 + 4;
        glb[bin_header..bin_header + 4].copy_from_slice(&1000u32.to_le_bytes());
        let err = parse_glb(&glb).expect_err("past end");
        assert_eq!(err.code, ErrorCode::GlbContainer);
        assert!(err.detail.contains("1000"), "{}", err.detail);
    }

    #[test]
    fn wrong_version_and_first_chunk_type() {
        let mut glb = write_glb(b"{}", &[]).expect("small");
        glb[4] = 1;
        assert_eq!(parse_glb(&glb).expect_err("v1").code, ErrorCode::GlbVersion);
        let mut glb = write_glb(b"{}", &[]).expect("small");
        glb[16] = b'X';
        assert_eq!(
            parse_glb(&glb).expect_err("type").code,
            ErrorCode::GlbContainer
        );
    }
}
