//! `POST /v1/jobs` bodies → spool files, with bounded memory: chunks go to disk as they arrive,
//! and the total over all parts is held to the upload limit (413 past it, also up front from
//! `Content-Length`), and a body whose next bytes take longer than the idle timeout is
//! dropped (408), so a stalled client holds no spool file for ever (a client that trickles a
//! byte now and then, within the timeout each time, is not bounded in time yet).
//!
//! The three forms (proto/openapi.json):
//! - `model/gltf-binary` or `model/gltf+json`: the asset is the body, options are query
//!   parameters (`?padding_texels=4&resolution=2048x1024`);
//! - `multipart/form-data`: an `asset` part (`.glb` or `.gltf`), further file parts named by
//!   the URI the `.gltf` uses for them (`scene.bin`), and an optional `options` JSON part.
use std::collections::BTreeMap;

use axum::body::Body;
use axum::extract::{FromRequest, Multipart, Request};
use axum::http::{header, HeaderMap};
use futures_util::StreamExt as _;
use tokio::io::AsyncWriteExt as _;

use super::error::ApiError;
use crate::api::{OptionsJson, ProblemCode};
use crate::jobs::{JobService, SpooledPart};

/// Largest `options` part or query string, bytes.
const MAX_OPTIONS_BYTES: usize = 64 * 1024;
/// Most parts of a multipart upload.
const MAX_PARTS: usize = 256;

/// The bounds of one upload.
#[derive(Debug, Clone, Copy)]
pub(crate) struct UploadLimits {
    /// Largest upload over all parts, bytes.
    pub max_bytes: u64,
    /// Longest wait for the next bytes of the body.
    pub idle_timeout: std::time::Duration,
}

/// `fut` (the next bytes of the body, or what needs them), or `408 upload_stalled` when it
/// takes longer than the idle timeout.
async fn within<T>(
    limits: UploadLimits,
    fut: impl std::future::Future<Output = T>,
) -> Result<T, ApiError> {
    tokio::time::timeout(limits.idle_timeout, fut)
        .await
        .map_err(|_| {
            ApiError::new(
                axum::http::StatusCode::REQUEST_TIMEOUT,
                ProblemCode::UploadStalled,
                format!(
                    "no bytes of the upload arrived for {:.1} s, so it was dropped; check the \
                     connection and send it again",
                    limits.idle_timeout.as_secs_f64()
                ),
            )
        })
}

/// What a request body turned into.
pub(crate) struct Parsed {
    pub asset: SpooledPart,
    pub resources: Vec<SpooledPart>,
    pub options: OptionsJson,
}

fn too_large(limit: u64) -> ApiError {
    ApiError::new(
        axum::http::StatusCode::PAYLOAD_TOO_LARGE,
        ProblemCode::UploadTooLarge,
        format!(
            "the upload is larger than this service's limit of {limit} bytes; simplify or split \
             the asset, or ask the operator to raise --max-upload-bytes"
        ),
    )
}

/// Streams chunks into a new spool file, counting against `budget`.
async fn spool<S, E>(
    jobs: &JobService,
    mut chunks: S,
    name: String,
    budget: &mut u64,
    limits: UploadLimits,
) -> Result<SpooledPart, ApiError>
where
    S: futures_util::Stream<Item = Result<bytes_like::Bytes, E>> + Unpin,
    E: std::fmt::Display,
{
    let path = jobs.spool_path();
    let mut file = tokio::fs::File::create(&path)
        .await
        .map_err(|e| ApiError::internal(format!("creating {}: {e}", path.display())))?;
    // From here the part owns the file and removes it on any early return.
    let mut part = SpooledPart::new(path, name, 0);
    while let Some(chunk) = within(limits, chunks.next()).await? {
        let chunk = chunk.map_err(|e| {
            ApiError::bad_request(
                ProblemCode::UploadInterrupted,
                format!("the request body could not be read ({e}); send it again"),
            )
        })?;
        let n = chunk.len() as u64;
        if n > *budget {
            return Err(too_large(limits.max_bytes));
        }
        *budget -= n;
        part.size += n;
        file.write_all(&chunk)
            .await
            .map_err(|e| ApiError::internal(format!("writing the spool file: {e}")))?;
    }
    file.flush()
        .await
        .map_err(|e| ApiError::internal(format!("writing the spool file: {e}")))?;
    Ok(part)
}

/// The bytes crate as axum re-exports it.
mod bytes_like {
    pub use axum::body::Bytes;
}

/// The options from a query string: every parameter is an option of
/// proto/options.schema.json. Values are read as JSON when they parse (`4`, `true`,
/// `[2048,1024]`), else as strings (`auto`); `resolution` also takes `2048x1024`.
pub(crate) fn options_from_query(query: Option<&str>) -> Result<OptionsJson, ApiError> {
    let Some(query) = query.filter(|q| !q.is_empty()) else {
        return Ok(OptionsJson::default());
    };
    if query.len() > MAX_OPTIONS_BYTES {
        return Err(ApiError::bad_request(
            ProblemCode::InvalidOptions,
            "the query string is too long",
        ));
    }
    let pairs: Vec<(String, String)> = serde_urlencoded_pairs(query)
        .map_err(|d| ApiError::bad_request(ProblemCode::InvalidOptions, d))?;
    let mut map = serde_json::Map::new();
    for (k, v) in pairs {
        if map.contains_key(&k) {
            return Err(ApiError::bad_request(
                ProblemCode::InvalidOptions,
                format!("the option `{k}` is given twice; give it once"),
            ));
        }
        let value = if k == "resolution" && v.contains(['x', 'X']) {
            let (w, h) = v.split_once(['x', 'X']).unwrap_or(("", ""));
            match (w.trim().parse::<u32>(), h.trim().parse::<u32>()) {
                (Ok(w), Ok(h)) => serde_json::json!([w, h]),
                _ => serde_json::Value::String(v),
            }
        } else {
            serde_json::from_str(&v).unwrap_or(serde_json::Value::String(v))
        };
        map.insert(k, value);
    }
    parse_options(serde_json::Value::Object(map))
}

/// Splits `a=1&b=x%20y` into decoded pairs.
fn serde_urlencoded_pairs(query: &str) -> Result<Vec<(String, String)>, String> {
    let decode = |s: &str| -> Result<String, String> {
        let bytes = s.as_bytes();
        let mut out = Vec::with_capacity(bytes.len());
        let mut i = 0;
        while i < bytes.len() {
            match bytes[i] {
                b'+' => out.push(b' '),
                b'%' => {
                    let hex = bytes
                        .get(i + 1..i + 3)
                        .and_then(|h| std::str::from_utf8(h).ok())
                        .and_then(|h| u8::from_str_radix(h, 16).ok())
                        .ok_or_else(|| format!("bad percent escape in the query near `{s}`"))?;
                    out.push(hex);
                    i += 2;
                }
                b => out.push(b),
            }
            i += 1;
        }
        String::from_utf8(out).map_err(|_| "the query string is not UTF-8".to_string())
    };
    query
        .split('&')
        .filter(|p| !p.is_empty())
        .map(|p| {
            let (k, v) = p.split_once('=').unwrap_or((p, ""));
            Ok((decode(k)?, decode(v)?))
        })
        .collect()
}

fn parse_options(value: serde_json::Value) -> Result<OptionsJson, ApiError> {
    serde_json::from_value(value).map_err(|e| {
        ApiError::bad_request(
            ProblemCode::InvalidOptions,
            format!(
                "the options do not match proto/options.schema.json: {e}; see GET \
                 /openapi.json for the names and types"
            ),
        )
    })
}

fn media_type(headers: &HeaderMap) -> String {
    headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .map(|v| {
            v.split(';')
                .next()
                .unwrap_or("")
                .trim()
                .to_ascii_lowercase()
        })
        .unwrap_or_default()
}

/// Reads a `POST /v1/jobs` body (module doc).
pub(crate) async fn read_upload(
    jobs: &JobService,
    req: Request,
    limits: UploadLimits,
) -> Result<Parsed, ApiError> {
    let limit = limits.max_bytes;
    let declared = req
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<u64>().ok());
    if declared.is_some_and(|n| n > limit) {
        return Err(too_large(limit));
    }
    let mut budget = limit;
    match media_type(req.headers()).as_str() {
        "model/gltf-binary" | "model/gltf+json" => {
            let options = options_from_query(req.uri().query())?;
            let body: Body = req.into_body();
            let asset = spool(
                jobs,
                body.into_data_stream(),
                "asset".into(),
                &mut budget,
                limits,
            )
            .await?;
            if asset.size == 0 {
                return Err(ApiError::bad_request(
                    ProblemCode::EmptyUpload,
                    "the request body is empty; send the asset's bytes",
                ));
            }
            Ok(Parsed {
                asset,
                resources: Vec::new(),
                options,
            })
        }
        "multipart/form-data" => read_multipart(jobs, req, &mut budget, limits).await,
        other => Err(ApiError::new(
            axum::http::StatusCode::UNSUPPORTED_MEDIA_TYPE,
            ProblemCode::UnsupportedMediaType,
            format!(
                "`{}` is not an accepted Content-Type; send a GLB as `model/gltf-binary`, a \
                 .gltf with embedded buffers as `model/gltf+json`, or `multipart/form-data` \
                 with an `asset` part (and its .bin/images as further parts)",
                if other.is_empty() { "(none)" } else { other }
            ),
        )),
    }
}

async fn read_multipart(
    jobs: &JobService,
    req: Request,
    budget: &mut u64,
    limits: UploadLimits,
) -> Result<Parsed, ApiError> {
    let limit = limits.max_bytes;
    let query_options = req.uri().query().filter(|q| !q.is_empty()).is_some();
    let mut options = options_from_query(req.uri().query())?;
    let mut multipart = Multipart::from_request(req, &()).await.map_err(|e| {
        ApiError::bad_request(
            ProblemCode::InvalidMultipart,
            format!("the multipart body cannot be read: {e}"),
        )
    })?;
    let bad = |e: axum::extract::multipart::MultipartError| {
        if e.status() == axum::http::StatusCode::PAYLOAD_TOO_LARGE {
            too_large(limit)
        } else {
            ApiError::bad_request(
                ProblemCode::InvalidMultipart,
                format!("the multipart body cannot be read: {e}"),
            )
        }
    };
    let mut asset: Option<SpooledPart> = None;
    let mut resources: BTreeMap<String, SpooledPart> = BTreeMap::new();
    let mut saw_options = false;
    let mut parts = 0usize;
    while let Some(mut field) = within(limits, multipart.next_field()).await?.map_err(bad)? {
        parts += 1;
        if parts > MAX_PARTS {
            return Err(ApiError::bad_request(
                ProblemCode::TooManyParts,
                format!("a multipart upload has at most {MAX_PARTS} parts"),
            ));
        }
        let name = field.name().unwrap_or("").to_string();
        let file_name = field.file_name().map(str::to_string);
        if name == "options" {
            if saw_options || query_options {
                return Err(ApiError::bad_request(
                    ProblemCode::InvalidOptions,
                    "options are given twice; send one `options` part or query parameters",
                ));
            }
            saw_options = true;
            let mut text = Vec::new();
            while let Some(chunk) = within(limits, field.chunk()).await?.map_err(bad)? {
                if text.len() + chunk.len() > MAX_OPTIONS_BYTES {
                    return Err(ApiError::bad_request(
                        ProblemCode::InvalidOptions,
                        format!("the `options` part is larger than {MAX_OPTIONS_BYTES} bytes"),
                    ));
                }
                text.extend_from_slice(&chunk);
            }
            let value: serde_json::Value = serde_json::from_slice(&text).map_err(|e| {
                ApiError::bad_request(
                    ProblemCode::InvalidOptions,
                    format!("the `options` part is not JSON: {e}"),
                )
            })?;
            options = parse_options(value)?;
            continue;
        }
        let stream = futures_util::stream::poll_fn(|cx| {
            use futures_util::Stream as _;
            std::pin::Pin::new(&mut field).poll_next(cx)
        });
        if name == "asset" {
            if asset.is_some() {
                return Err(ApiError::bad_request(
                    ProblemCode::InvalidMultipart,
                    "more than one `asset` part; send exactly one",
                ));
            }
            let part = spool(jobs, stream, "asset".into(), budget, limits).await?;
            asset = Some(part);
        } else {
            // A resource: named by its file name (the URI in the .gltf), else the field name.
            let uri = file_name.filter(|f| !f.is_empty()).unwrap_or(name);
            if uri.is_empty() {
                return Err(ApiError::bad_request(
                    ProblemCode::InvalidMultipart,
                    "a part has neither a name nor a file name; name resource parts by the URI \
                     the .gltf uses for them",
                ));
            }
            let part = spool(jobs, stream, uri.clone(), budget, limits).await?;
            resources.insert(uri, part);
        }
    }
    let Some(asset) = asset else {
        return Err(ApiError::bad_request(
            ProblemCode::MissingAsset,
            "the multipart body has no `asset` part; send the .glb or .gltf as a part named \
             `asset`",
        ));
    };
    Ok(Parsed {
        asset,
        resources: resources.into_values().collect(),
        options,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn query_options_parse_numbers_names_and_resolutions() {
        let o = options_from_query(Some("padding_texels=4&solver=direct&resolution=2048x1024"))
            .unwrap();
        assert_eq!(o.padding_texels, Some(4));
        assert_eq!(o.solver, Some(crate::api::SolverJson::Direct));
        assert_eq!(
            o.resolution,
            Some(crate::api::ResolutionJson::Rect([2048, 1024]))
        );
        assert_eq!(options_from_query(None).unwrap(), OptionsJson::default());
        let e = options_from_query(Some("padding=4")).unwrap_err();
        assert_eq!(e.status(), axum::http::StatusCode::BAD_REQUEST);
        assert!(options_from_query(Some("padding_texels=1&padding_texels=2")).is_err());
        assert!(options_from_query(Some("padding_texels=%zz")).is_err());
    }
}
