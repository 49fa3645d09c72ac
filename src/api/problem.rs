//! [`ProblemCode`]: every stable code that an HTTP problem body (`application/problem+json`)
//! or a failed job's `error` can carry ↔ `components/schemas/ProblemCode` of
//! `proto/openapi.json`.
//!
//! Invariants:
//! - the wire name of a code (serde, snake_case) never changes once released: clients match on
//!   it, and failed jobs store it as text (`JobRecord::error_json`);
//! - the document's `enum` lists exactly the variants (tested both ways below);
//! - a domain error turns into its code only through the `From` conversions here, so one domain
//!   error has one code wherever it surfaces (a `422` at submit or a failed job).
use serde::{Deserialize, Serialize};

use crate::atlas::AtlasError;
use crate::gltf_io::{ErrorCode, GltfError};
use crate::mesh::MeshBuildError;

/// A stable, machine-readable problem code (module doc). `Display` and [`ProblemCode::as_str`]
/// give the wire name.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Hash,
    Serialize,
    Deserialize,
    strum::VariantArray,
    strum::IntoStaticStr,
    strum::EnumString,
)]
#[serde(rename_all = "snake_case")]
#[strum(serialize_all = "snake_case")]
pub enum ProblemCode {
    // The request (HTTP).
    /// 401: no `Authorization: Bearer` key, or a key the service does not have.
    Unauthorized,
    /// 404: no job with this id for this API key (also another key's job).
    JobNotFound,
    /// 404: no endpoint at this path.
    RouteNotFound,
    /// 405: the path exists but does not take this method.
    MethodNotAllowed,
    /// 400: the query of `GET /v1/jobs` or `GET …/result` has an unknown or malformed parameter.
    InvalidQuery,
    /// 400: `status=` of `GET /v1/jobs` is not a job status.
    InvalidStatus,
    /// 400: `limit=` of `GET /v1/jobs` is outside 1..=100.
    InvalidLimit,
    /// 400: `cursor=` of `GET /v1/jobs` is not a `next_cursor` this service gave.
    InvalidCursor,
    /// 400: `format=` of `GET …/result` is neither `glb` nor `gltf`.
    InvalidFormat,
    /// 400: the `Idempotency-Key` header is empty, too long or not visible ASCII.
    InvalidIdempotencyKey,
    /// 422: the `Idempotency-Key` was used before with a different body.
    IdempotencyKeyReused,
    /// 400: the options (query string or `options` part) do not parse, or name an unknown
    /// option.
    InvalidOptions,
    /// 422: an option parses but its value is out of range (also a failed job's code).
    InvalidOption,
    /// 400: the upload has no bytes.
    EmptyUpload,
    /// 415: the body is not `model/gltf-binary`, `model/gltf+json` or `multipart/form-data`.
    UnsupportedMediaType,
    /// 400: the multipart body is malformed (boundary, part headers, a part without a name).
    InvalidMultipart,
    /// 400: the multipart body has more parts than the service takes.
    TooManyParts,
    /// 400: the multipart body has no `asset` part.
    MissingAsset,
    /// 413: the upload is larger than `--max-upload-bytes`.
    UploadTooLarge,
    /// 408: no bytes of the upload arrived within `--upload-idle-timeout-s`.
    UploadStalled,
    /// 400: the connection failed while the body was being read.
    UploadInterrupted,
    /// 409: the job has no result (yet, or because it failed or was cancelled).
    ResultNotReady,
    /// 503: as many jobs are queued or running as the queue holds; retry after `Retry-After`.
    QueueFull,
    /// 503: the service is shutting down; retry after `Retry-After`.
    ShuttingDown,
    /// 503: the job store does not answer (`GET /readyz`).
    StoreUnavailable,
    /// 500: a fault of the service while handling the request; the cause is in the log under
    /// the request id.
    InternalError,

    // A job's run.
    /// The job stopped at a checkpoint after a cancel.
    Cancelled,
    /// 500: the job's worker stopped (crash or restart) on every one of `--max-attempts`
    /// claims.
    AttemptsExhausted,
    /// 500: the job's stored input could not be read.
    InputMissing,
    /// 500: the job's stored options could not be read.
    OptionsUnreadable,
    /// 500: the pipeline panicked on this job (the service carries on).
    WorkerPanicked,
    /// 500: the job ran longer than `--job-time-limit-s`.
    TimeLimitExceeded,
    /// 500: the pipeline succeeded but writing the second container failed.
    EncodeFailed,
    /// 500: the pipeline succeeded but its report could not be written.
    ReportFailed,

    // The pipeline ([`AtlasError`]).
    /// 422: a chart could not be flattened (for example all its triangles have zero area).
    UnparameterizableChart,
    /// 422: packing failed (for example one chart is larger than a page at the density asked).
    PackingFailed,

    // The mesh ([`MeshBuildError`]).
    /// 422: the asset has no triangle primitive.
    ZeroTriangles,
    /// 422: the weld groups do not match the positions (a fault of the decoded input).
    WeldGroupLengthMismatch,
    /// 422: the mesh has more vertices or triangles than the mesh index type holds.
    MeshTooLarge,
    /// 422: a vertex index is not smaller than the number of vertices (glTF or mesh).
    IndexOutOfRange,
    /// 422: a vertex coordinate is NaN or infinite.
    NonFiniteCoordinate,

    // The glTF asset ([`ErrorCode`]; see its variants).
    /// 422: the bytes are neither a GLB nor a glTF JSON document.
    NotGltf,
    /// 422: the GLB header or a chunk header is inconsistent with the file.
    GlbContainer,
    /// 422: the GLB version is not 2.
    GlbVersion,
    /// 422: the JSON does not parse.
    JsonSyntax,
    /// 422: the JSON is nested deeper than the parser's limit.
    JsonTooDeep,
    /// 422: the document violates the glTF 2.0 schema.
    Schema,
    /// 422: `asset.version` is not 2.x.
    AssetVersion,
    /// 422: a URI is absolute, escapes with `..`, or uses a scheme other than `data:`.
    UriForbidden,
    /// 422: a relative URI names a resource that was not uploaded with the asset.
    ResourceMissing,
    /// 422: a `data:` URI is malformed or not base64.
    DataUriInvalid,
    /// 422: a buffer is shorter than its `byteLength`, or a buffer view lies outside it.
    BufferOutOfBounds,
    /// 422: an accessor reaches past its buffer view, or its layout is invalid.
    AccessorOutOfBounds,
    /// 422: an accessor's type or component type is not allowed where it is used.
    AccessorInvalid,
    /// 422: a POSITION value is NaN or infinite.
    NonFinitePosition,
    /// 422: a primitive is malformed (no POSITION, attribute counts differ, …).
    PrimitiveInvalid,
    /// 422: the node hierarchy is not a forest.
    NodeHierarchy,
    /// 422: the asset uses an extension whose data cannot be decoded (mesh compression).
    UnsupportedExtension,
    /// 422: a decoder limit (triangles, `--max-triangles`, …) was exceeded.
    LimitExceeded,
    /// 422: the UVs to write do not match the asset, or are not finite.
    UvInput,
    /// 422: the requested UV set cannot be written.
    UvTarget,
    /// 422: an uploaded image has an unrecognised format and no `mimeType`.
    ImageFormat,
    /// 422: a fault or panic inside the glTF decoder or encoder; the input may be fine.
    Internal,
}

impl ProblemCode {
    /// The wire name (`job_not_found`).
    pub fn as_str(self) -> &'static str {
        self.into()
    }

    /// The code named `name`, if this version knows it.
    pub fn parse(name: &str) -> Option<ProblemCode> {
        name.parse().ok()
    }
}

impl std::fmt::Display for ProblemCode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl From<ErrorCode> for ProblemCode {
    fn from(c: ErrorCode) -> ProblemCode {
        match c {
            ErrorCode::NotGltf => ProblemCode::NotGltf,
            ErrorCode::GlbContainer => ProblemCode::GlbContainer,
            ErrorCode::GlbVersion => ProblemCode::GlbVersion,
            ErrorCode::JsonSyntax => ProblemCode::JsonSyntax,
            ErrorCode::JsonTooDeep => ProblemCode::JsonTooDeep,
            ErrorCode::Schema => ProblemCode::Schema,
            ErrorCode::AssetVersion => ProblemCode::AssetVersion,
            ErrorCode::UriForbidden => ProblemCode::UriForbidden,
            ErrorCode::ResourceMissing => ProblemCode::ResourceMissing,
            ErrorCode::DataUriInvalid => ProblemCode::DataUriInvalid,
            ErrorCode::BufferOutOfBounds => ProblemCode::BufferOutOfBounds,
            ErrorCode::AccessorOutOfBounds => ProblemCode::AccessorOutOfBounds,
            ErrorCode::AccessorInvalid => ProblemCode::AccessorInvalid,
            ErrorCode::IndexOutOfRange => ProblemCode::IndexOutOfRange,
            ErrorCode::NonFinitePosition => ProblemCode::NonFinitePosition,
            ErrorCode::PrimitiveInvalid => ProblemCode::PrimitiveInvalid,
            ErrorCode::NodeHierarchy => ProblemCode::NodeHierarchy,
            ErrorCode::UnsupportedExtension => ProblemCode::UnsupportedExtension,
            ErrorCode::LimitExceeded => ProblemCode::LimitExceeded,
            ErrorCode::UvInput => ProblemCode::UvInput,
            ErrorCode::UvTarget => ProblemCode::UvTarget,
            ErrorCode::ImageFormat => ProblemCode::ImageFormat,
            ErrorCode::Internal => ProblemCode::Internal,
        }
    }
}

impl From<&GltfError> for ProblemCode {
    fn from(e: &GltfError) -> ProblemCode {
        e.code.into()
    }
}

impl From<&MeshBuildError> for ProblemCode {
    fn from(e: &MeshBuildError) -> ProblemCode {
        match e {
            MeshBuildError::NoTriangles => ProblemCode::ZeroTriangles,
            MeshBuildError::WeldGroupLengthMismatch { .. } => ProblemCode::WeldGroupLengthMismatch,
            MeshBuildError::TooLarge { .. } => ProblemCode::MeshTooLarge,
            MeshBuildError::IndexOutOfRange { .. } => ProblemCode::IndexOutOfRange,
            MeshBuildError::NonFiniteCoordinate { .. } => ProblemCode::NonFiniteCoordinate,
        }
    }
}

impl From<&AtlasError> for ProblemCode {
    fn from(e: &AtlasError) -> ProblemCode {
        match e {
            AtlasError::InvalidOption { .. } => ProblemCode::InvalidOption,
            AtlasError::Cancelled { .. } => ProblemCode::Cancelled,
            AtlasError::Unparameterizable { .. } => ProblemCode::UnparameterizableChart,
            AtlasError::Pack(_) => ProblemCode::PackingFailed,
        }
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;

    use strum::VariantArray as _;

    use super::*;

    /// `proto/openapi.json`, as the service serves it.
    const OPENAPI: &str = include_str!("../../proto/openapi.json");

    fn document_codes() -> Vec<String> {
        let doc: serde_json::Value = serde_json::from_str(OPENAPI).unwrap();
        let schemas = &doc["components"]["schemas"];
        // The problem body's code (also a failed job's `error.code`) is this shared enum.
        assert_eq!(
            schemas["Problem"]["properties"]["code"]["$ref"], "#/components/schemas/ProblemCode",
            "Problem.code must refer to the shared ProblemCode schema"
        );
        assert_eq!(
            schemas["Job"]["properties"]["error"]["$ref"],
            "#/components/schemas/Problem"
        );
        schemas["ProblemCode"]["enum"]
            .as_array()
            .expect("components/schemas/ProblemCode has an enum")
            .iter()
            .map(|v| v.as_str().expect("codes are strings").to_string())
            .collect()
    }

    #[test]
    fn every_variant_is_in_the_openapi_enum() {
        let documented: BTreeSet<String> = document_codes().into_iter().collect();
        for code in ProblemCode::VARIANTS {
            let wire = serde_json::to_value(code).unwrap();
            let wire = wire.as_str().unwrap();
            assert!(
                documented.contains(wire),
                "{code:?} (`{wire}`) is missing from components/schemas/ProblemCode of proto/openapi.json"
            );
        }
    }

    #[test]
    fn every_openapi_code_is_a_variant() {
        let codes = document_codes();
        let unique: BTreeSet<&String> = codes.iter().collect();
        assert_eq!(unique.len(), codes.len(), "the document lists a code twice");
        for name in &codes {
            let parsed: Result<ProblemCode, _> = serde_json::from_value(name.as_str().into());
            assert!(
                parsed.is_ok(),
                "`{name}` of proto/openapi.json is no ProblemCode variant"
            );
        }
    }

    #[test]
    fn serde_and_as_str_agree_and_names_are_distinct() {
        let mut seen = BTreeSet::new();
        for &code in ProblemCode::VARIANTS {
            assert_eq!(serde_json::to_value(code).unwrap(), code.as_str());
            assert_eq!(ProblemCode::parse(code.as_str()), Some(code));
            assert!(seen.insert(code.as_str()), "{code:?} repeats a name");
            assert!(code
                .as_str()
                .bytes()
                .all(|b| b.is_ascii_lowercase() || b == b'_'));
        }
        assert_eq!(ProblemCode::parse("no_such_code"), None);
    }

    /// The codes as they were strings before the enum (wire contract: these names must stay).
    #[test]
    fn released_names_are_kept() {
        for name in [
            "unauthorized",
            "job_not_found",
            "route_not_found",
            "method_not_allowed",
            "invalid_query",
            "invalid_status",
            "invalid_limit",
            "invalid_cursor",
            "invalid_format",
            "invalid_idempotency_key",
            "idempotency_key_reused",
            "invalid_options",
            "invalid_option",
            "empty_upload",
            "unsupported_media_type",
            "invalid_multipart",
            "too_many_parts",
            "missing_asset",
            "upload_too_large",
            "upload_stalled",
            "upload_interrupted",
            "result_not_ready",
            "queue_full",
            "shutting_down",
            "store_unavailable",
            "internal_error",
            "cancelled",
            "attempts_exhausted",
            "input_missing",
            "options_unreadable",
            "worker_panicked",
            "time_limit_exceeded",
            "encode_failed",
            "report_failed",
            "unparameterizable_chart",
            "packing_failed",
            "zero_triangles",
            "weld_group_length_mismatch",
            "mesh_too_large",
            "index_out_of_range",
            "non_finite_coordinate",
        ] {
            assert!(ProblemCode::parse(name).is_some(), "`{name}` is gone");
        }
        assert_eq!(ProblemCode::VARIANTS.len(), 41 + 22);
    }

    #[test]
    fn domain_codes_keep_their_names() {
        // Every glTF code keeps its name (`ErrorCode::as_str`) as a problem code.
        let all_gltf = [
            ErrorCode::NotGltf,
            ErrorCode::GlbContainer,
            ErrorCode::GlbVersion,
            ErrorCode::JsonSyntax,
            ErrorCode::JsonTooDeep,
            ErrorCode::Schema,
            ErrorCode::AssetVersion,
            ErrorCode::UriForbidden,
            ErrorCode::ResourceMissing,
            ErrorCode::DataUriInvalid,
            ErrorCode::BufferOutOfBounds,
            ErrorCode::AccessorOutOfBounds,
            ErrorCode::AccessorInvalid,
            ErrorCode::IndexOutOfRange,
            ErrorCode::NonFinitePosition,
            ErrorCode::PrimitiveInvalid,
            ErrorCode::NodeHierarchy,
            ErrorCode::UnsupportedExtension,
            ErrorCode::LimitExceeded,
            ErrorCode::UvInput,
            ErrorCode::UvTarget,
            ErrorCode::ImageFormat,
            ErrorCode::Internal,
        ];
        for c in all_gltf {
            assert_eq!(ProblemCode::from(c).as_str(), c.as_str());
        }
        let e = MeshBuildError::NoTriangles;
        assert_eq!(ProblemCode::from(&e).as_str(), e.code());
    }
}
