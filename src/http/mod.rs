//! The HTTP API: the only module that knows axum.
//!
//! # Purpose
//! [`router`] builds the whole API (proto/openapi.json) over a [`JobService`]; tests call it
//! with a real listener, `service.rs` serves it.
//!
//! # Invariants
//! - Every error is an [`ApiError`] → `application/problem+json` with a stable `code`.
//! - Handlers never log. Every request gets an id: the client's `x-request-id` when it is 1 to
//!   64 of `[A-Za-z0-9._-]`, else a new UUIDv7 (tower-http `SetRequestId`, after
//!   `drop_unusable_request_id`); it is echoed in the response's `x-request-id`
//!   (`PropagateRequestId`) and in every problem body. tower-http's `TraceLayer` runs the request
//!   in a `request` span (`request_id`, `method`, `route`, and `job_id` once a handler knows it)
//!   and logs one line per response with its status and latency (`ms`), at `error` with the
//!   logged cause of a 500. The `request_context` middleware records the latency metric.
//! - Memory per request is bounded: uploads stream to spool files (`upload.rs`), results are
//!   read whole from the blob store (bounded by what an upload may produce).
//! - A request refused before its body was read gets its answer, not a TCP reset: the
//!   `drain` middleware reads and drops the rest of the body first, within fixed bounds.
//! - No SQL here (`tests/architecture.rs`): the store is reached through `jobs` only.
mod auth;
mod drain;
mod error;
mod handlers;
mod upload;

use std::sync::Arc;
use std::time::{Duration, Instant};

use axum::extract::{DefaultBodyLimit, MatchedPath, Request, State};
use axum::http::{HeaderName, HeaderValue, Method};
use axum::middleware::{self, Next};
use axum::response::Response;
use axum::routing::get;
use axum::Router;
use tokio::sync::watch;
use tower_http::cors::{AllowOrigin, CorsLayer};
use tower_http::request_id::{
    MakeRequestId, PropagateRequestIdLayer, RequestId, SetRequestIdLayer,
};
use tower_http::trace::TraceLayer;

pub use auth::Owner;
pub use error::ApiError;
pub use handlers::OPENAPI_JSON;

use crate::jobs::JobService;

/// Settings of the HTTP layer.
#[derive(Debug, Clone)]
pub struct HttpConfig {
    /// Accepted bearer keys; empty: no authentication (fine on localhost).
    pub api_keys: Vec<String>,
    /// Largest upload over all parts, bytes. Default 256 MiB.
    pub max_upload_bytes: u64,
    /// Longest wait for the next bytes of an upload's body; past it the upload is refused
    /// (`408 upload_stalled`) and its spool files removed. Default 60 s.
    pub upload_idle_timeout: std::time::Duration,
    /// Origins allowed by CORS (`*` for any); empty: no CORS headers.
    pub cors_origins: Vec<String>,
}

impl Default for HttpConfig {
    fn default() -> Self {
        HttpConfig {
            api_keys: Vec::new(),
            max_upload_bytes: 256 << 20,
            upload_idle_timeout: std::time::Duration::from_secs(60),
            cors_origins: Vec::new(),
        }
    }
}

/// What every handler sees.
#[derive(Clone)]
pub struct AppState {
    pub(crate) jobs: Arc<JobService>,
    pub(crate) config: Arc<HttpConfig>,
    pub(crate) keys: Arc<auth::Keys>,
    /// `true` once shutdown began: event streams end, submissions get 503.
    pub(crate) shutdown: watch::Receiver<bool>,
}

impl AppState {
    fn is_shutting_down(&self) -> bool {
        *self.shutdown.borrow()
    }
}

/// The API over `jobs`. `shutdown` turning `true` ends event streams and refuses new jobs.
pub fn router(
    jobs: Arc<JobService>,
    config: HttpConfig,
    shutdown: watch::Receiver<bool>,
) -> Router {
    let state = AppState {
        keys: Arc::new(auth::Keys::new(&config.api_keys)),
        config: Arc::new(config),
        jobs,
        shutdown,
    };
    let v1 = Router::new()
        .route("/v1/jobs", get(handlers::list_jobs).post(handlers::submit))
        .route(
            "/v1/jobs/{id}",
            get(handlers::get_job).delete(handlers::delete_job),
        )
        .route("/v1/jobs/{id}/events", get(handlers::job_events))
        .route("/v1/jobs/{id}/result", get(handlers::get_result))
        .route("/v1/jobs/{id}/report", get(handlers::get_report))
        .route("/v1/jobs/{id}/preview.png", get(handlers::get_preview))
        .route_layer(middleware::from_fn_with_state(
            state.clone(),
            auth::require_key,
        ));
    let mut app = Router::new()
        .merge(v1)
        .route("/healthz", get(handlers::healthz))
        .route("/readyz", get(handlers::readyz))
        .route("/metrics", get(handlers::metrics))
        .route("/openapi.json", get(handlers::openapi))
        .fallback(handlers::not_found)
        .method_not_allowed_fallback(handlers::method_not_allowed)
        // Uploads are bounded by our own streaming limit, not by a buffered-body limit.
        .layer(DefaultBodyLimit::disable())
        // A refused upload's unread bytes are drained so the refusal reaches the client.
        .layer(middleware::from_fn(drain::drain_unread_bodies))
        .layer(middleware::from_fn_with_state(
            state.clone(),
            request_context,
        ))
        .layer(
            TraceLayer::new_for_http()
                .make_span_with(request_span)
                .on_request(())
                .on_response(log_response)
                .on_failure(()),
        )
        .layer(PropagateRequestIdLayer::x_request_id())
        .layer(SetRequestIdLayer::x_request_id(NewRequestId))
        .layer(middleware::map_request(drop_unusable_request_id))
        .with_state(state.clone());
    if let Some(cors) = cors_layer(&state.config.cors_origins) {
        app = app.layer(cors);
    }
    app
}

/// Serves `app` on `listener` until `shutdown` resolves; then stops accepting and waits for
/// in-flight requests (event streams end on the router's shutdown flag).
pub async fn serve(
    listener: tokio::net::TcpListener,
    app: Router,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    axum::serve(listener, app)
        .with_graceful_shutdown(shutdown)
        .await
}

fn cors_layer(origins: &[String]) -> Option<CorsLayer> {
    if origins.is_empty() {
        return None;
    }
    let allow = if origins.iter().any(|o| o == "*") {
        AllowOrigin::any()
    } else {
        AllowOrigin::list(
            origins
                .iter()
                .filter_map(|o| HeaderValue::from_str(o.trim()).ok()),
        )
    };
    Some(
        CorsLayer::new()
            .allow_origin(allow)
            .allow_methods([Method::GET, Method::POST, Method::DELETE])
            .allow_headers([
                axum::http::header::AUTHORIZATION,
                axum::http::header::CONTENT_TYPE,
                HeaderName::from_static("idempotency-key"),
            ])
            .expose_headers([
                axum::http::header::LOCATION,
                axum::http::header::RETRY_AFTER,
                HeaderName::from_static("x-request-id"),
            ]),
    )
}

/// Removes a client's `x-request-id` unless it is 1 to 64 of `[A-Za-z0-9._-]`, so that
/// `SetRequestId` (which keeps any id a request brings) gives such a request a new one: an id
/// goes into logs and headers, so it must be short and plain.
async fn drop_unusable_request_id(mut req: Request) -> Request {
    let usable = req
        .headers()
        .get("x-request-id")
        .map(|v| {
            let b = v.as_bytes();
            !b.is_empty()
                && b.len() <= 64
                && b.iter()
                    .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'.' | b'_' | b'-'))
        })
        .unwrap_or(true);
    if !usable {
        req.headers_mut().remove("x-request-id");
    }
    req
}

/// A new request id: a UUIDv7 (time-ordered, so ids sort like the log).
#[derive(Debug, Clone, Copy)]
struct NewRequestId;

impl MakeRequestId for NewRequestId {
    fn make_request_id<B>(&mut self, _: &axum::http::Request<B>) -> Option<RequestId> {
        HeaderValue::from_str(&uuid::Uuid::now_v7().to_string())
            .ok()
            .map(RequestId::new)
    }
}

/// The request's id (set by `SetRequestId`), `""` if it has none.
fn id_of(req: &Request) -> &str {
    req.extensions()
        .get::<RequestId>()
        .and_then(|id| id.header_value().to_str().ok())
        .unwrap_or("")
}

/// The matched route template (bounded cardinality), `unmatched` for the fallback.
fn route_of(req: &Request) -> &str {
    req.extensions()
        .get::<MatchedPath>()
        .map(MatchedPath::as_str)
        .unwrap_or("unmatched")
}

/// The `request` span of `TraceLayer` (module doc).
fn request_span(req: &Request) -> tracing::Span {
    tracing::info_span!(
        "request",
        request_id = %id_of(req),
        method = %req.method(),
        route = %route_of(req),
        job_id = tracing::field::Empty,
    )
}

/// The one log line per request of `TraceLayer`, inside the request span.
fn log_response(response: &Response, latency: Duration, _span: &tracing::Span) {
    let status = response.status();
    let ms = latency.as_secs_f64() * 1000.0;
    match response.extensions().get::<error::InternalCause>() {
        Some(cause) => {
            tracing::error!(status = status.as_u16(), ms, cause = %cause.0, "request failed")
        }
        None if status.is_server_error() => {
            tracing::warn!(status = status.as_u16(), ms, "request")
        }
        None => tracing::info!(status = status.as_u16(), ms, "request"),
    }
}

/// Middleware: makes the request id known to [`ApiError`]'s problem bodies and records the
/// latency metric by method, route and status.
async fn request_context(State(state): State<AppState>, req: Request, next: Next) -> Response {
    let started = Instant::now();
    let id = id_of(&req).to_string();
    let method = req.method().clone();
    let route = route_of(&req).to_string();
    let response = error::REQUEST_ID.scope(id, next.run(req)).await;
    state.jobs.metrics().observe_http(
        method.as_str(),
        &route,
        response.status().as_u16(),
        started.elapsed().as_secs_f64(),
    );
    response
}

#[cfg(test)]
mod tests {
    use super::*;

    async fn kept(id: &str) -> Option<String> {
        let req = Request::builder()
            .header("x-request-id", id)
            .body(axum::body::Body::empty())
            .unwrap();
        drop_unusable_request_id(req)
            .await
            .headers()
            .get("x-request-id")
            .map(|v| v.to_str().unwrap().to_string())
    }

    #[tokio::test]
    async fn only_short_plain_client_request_ids_are_kept() {
        for id in ["abc-123", "A.b_C-9", &"x".repeat(64)] {
            assert_eq!(kept(id).await.as_deref(), Some(id), "{id}");
        }
        for id in ["", "with space", "semi;colon", "a/b", &"x".repeat(65)] {
            assert_eq!(kept(id).await, None, "{id:?}");
        }
        let none = Request::builder().body(axum::body::Body::empty()).unwrap();
        assert!(drop_unusable_request_id(none).await.headers().is_empty());
    }
}
