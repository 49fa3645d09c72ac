//! [`ApiError`]: the one error type of the HTTP layer, and the only way an error becomes a
//! response: `application/problem+json` (RFC 9457) with a stable `code`, a `detail` saying what
//! to fix, the asset's defects with JSON paths, and the request id.
//!
//! Internal errors show only a code and the request id; their cause travels to the logging
//! middleware in a response extension ([`InternalCause`]) and is logged there.
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};

use crate::api::{ApiProblemJson, AssetDefectJson, ProblemCode};

tokio::task_local! {
    /// The id of the request being handled (set by the logging middleware).
    pub(crate) static REQUEST_ID: String;
}

/// The cause of a 5xx, for the log only.
#[derive(Debug, Clone)]
pub(crate) struct InternalCause(pub String);

/// An error response (module doc). Boxed: handlers return `Result<_, ApiError>` everywhere,
/// and the problem body is a few hundred bytes.
#[derive(Debug)]
pub struct ApiError(Box<Inner>);

#[derive(Debug)]
struct Inner {
    status: StatusCode,
    problem: ApiProblemJson,
    retry_after_s: Option<u64>,
    internal: Option<String>,
    challenge: bool,
}

impl ApiError {
    /// An error with `status`, `code` and `detail`.
    pub fn new(status: StatusCode, code: ProblemCode, detail: impl Into<String>) -> ApiError {
        let title = status.canonical_reason().unwrap_or("Error");
        ApiError(Box::new(Inner {
            status,
            problem: ApiProblemJson::new(status.as_u16(), code, title, detail),
            retry_after_s: None,
            internal: None,
            challenge: false,
        }))
    }

    /// 400: the request is malformed.
    pub fn bad_request(code: ProblemCode, detail: impl Into<String>) -> ApiError {
        ApiError::new(StatusCode::BAD_REQUEST, code, detail)
    }

    /// 404 for a job that does not exist or belongs to another key (indistinguishable).
    pub fn job_not_found(id: &str) -> ApiError {
        ApiError::new(
            StatusCode::NOT_FOUND,
            ProblemCode::JobNotFound,
            format!(
                "there is no job `{id}` for this API key; check the id (GET /v1/jobs lists your \
                 jobs) — finished jobs are deleted after the retention period"
            ),
        )
    }

    /// 422 with the asset's defects.
    pub fn unprocessable(
        code: ProblemCode,
        detail: impl Into<String>,
        defects: Vec<AssetDefectJson>,
    ) -> Self {
        let mut e = ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, code, detail);
        e.0.problem.defects = defects;
        e
    }

    /// 401 with a `WWW-Authenticate: Bearer` challenge.
    pub fn unauthorized(detail: impl Into<String>) -> ApiError {
        let mut e = ApiError::new(StatusCode::UNAUTHORIZED, ProblemCode::Unauthorized, detail);
        e.0.challenge = true;
        e
    }

    /// 503 with `Retry-After`.
    pub fn unavailable(
        code: ProblemCode,
        detail: impl Into<String>,
        retry_after_s: u64,
    ) -> ApiError {
        let mut e = ApiError::new(StatusCode::SERVICE_UNAVAILABLE, code, detail);
        e.0.retry_after_s = Some(retry_after_s.max(1));
        e
    }

    /// 500: a fault of the service. The cause is logged, never shown.
    pub fn internal(cause: impl std::fmt::Display) -> ApiError {
        let mut e = ApiError::new(
            StatusCode::INTERNAL_SERVER_ERROR,
            ProblemCode::InternalError,
            "the service failed to handle this request; retry later, and quote the request_id \
             when reporting it",
        );
        e.0.internal = Some(cause.to_string());
        e
    }

    /// Attaches a cause for the log (not shown to the client).
    pub fn with_cause(mut self, cause: impl std::fmt::Display) -> ApiError {
        self.0.internal = Some(cause.to_string());
        self
    }

    /// The status.
    pub fn status(&self) -> StatusCode {
        self.0.status
    }
}

impl From<crate::storage::StoreError> for ApiError {
    fn from(e: crate::storage::StoreError) -> ApiError {
        ApiError::internal(e)
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let this = *self.0;
        let mut problem = this.problem;
        problem.request_id = REQUEST_ID.try_with(Clone::clone).ok();
        let body = serde_json::to_vec(&problem).unwrap_or_else(|_| b"{}".to_vec());
        let mut response = (this.status, body).into_response();
        let headers = response.headers_mut();
        headers.insert(
            header::CONTENT_TYPE,
            HeaderValue::from_static("application/problem+json"),
        );
        if let Some(s) = this.retry_after_s {
            headers.insert(header::RETRY_AFTER, HeaderValue::from(s));
        }
        if this.challenge {
            headers.insert(
                header::WWW_AUTHENTICATE,
                HeaderValue::from_static("Bearer realm=\"texatlas\""),
            );
        }
        if let Some(cause) = this.internal {
            response.extensions_mut().insert(InternalCause(cause));
        }
        response
    }
}
