//! The `/v1/jobs` handlers and the operational endpoints. Handlers never log: the middleware
//! logs every request with its id, and the job id is recorded on the request span.
use std::convert::Infallible;
use std::time::Duration;

use axum::extract::{Path, Query, Request, State};
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::{Extension, Json};
use serde::Deserialize;

use super::auth::Owner;
use super::error::ApiError;
use super::upload::{read_upload, UploadLimits};
use super::AppState;
use crate::api::{
    rfc3339_from_ms, ApiProblemJson, JobJson, JobListJson, LinksJson, ProblemCode, ProgressJson,
};
use crate::jobs::{
    Artifact, ArtifactOutcome, DeleteOutcome, JobRecord, JobStatus, SubmitError, Upload,
};

/// The wire form of a stored job.
pub(crate) fn job_json(job: &JobRecord) -> JobJson {
    let base = format!("/v1/jobs/{}", job.id);
    let done = job.status == JobStatus::Succeeded;
    let link = |suffix: &str| done.then(|| format!("{base}/{suffix}"));
    JobJson {
        id: job.id.clone(),
        status: job.status.as_str().to_string(),
        progress: job.progress_fraction.map(|fraction| ProgressJson {
            stage: job.progress_stage.clone(),
            fraction,
        }),
        cancel_requested: job.cancel_requested,
        attempts: job.attempts,
        triangles: job.triangles,
        options: serde_json::from_str(&job.options_json).unwrap_or_default(),
        created_at: rfc3339_from_ms(job.created_at_ms),
        started_at: job.started_at_ms.map(rfc3339_from_ms),
        finished_at: job.finished_at_ms.map(rfc3339_from_ms),
        expires_at: job.expires_at_ms.map(rfc3339_from_ms),
        error: job
            .error_json
            .as_deref()
            .and_then(ApiProblemJson::from_stored),
        links: LinksJson {
            self_: base.clone(),
            events: format!("{base}/events"),
            result: link("result"),
            report: link("report"),
            preview: link("preview.png"),
        },
    }
}

fn record_job_id(id: &str) {
    tracing::Span::current().record("job_id", id);
}

/// Job ids are UUIDs; anything else cannot name a job (and never reaches the store).
fn check_id(id: &str) -> Result<(), ApiError> {
    if id.len() <= 64 && id.bytes().all(|b| b.is_ascii_hexdigit() || b == b'-') {
        Ok(())
    } else {
        Err(ApiError::job_not_found(id))
    }
}

fn idempotency_key(headers: &HeaderMap) -> Result<Option<String>, ApiError> {
    let Some(v) = headers.get("idempotency-key") else {
        return Ok(None);
    };
    let ok = v
        .to_str()
        .ok()
        .map(|s| s.trim().trim_matches('"').to_string())
        .filter(|s| !s.is_empty() && s.len() <= 255);
    ok.map(Some).ok_or_else(|| {
        ApiError::bad_request(
            ProblemCode::InvalidIdempotencyKey,
            "the Idempotency-Key header must be 1 to 255 visible ASCII characters (a UUID is a \
             good choice)",
        )
    })
}

/// `POST /v1/jobs`.
pub(crate) async fn submit(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    req: Request,
) -> Result<Response, ApiError> {
    if state.is_shutting_down() {
        return Err(ApiError::unavailable(
            ProblemCode::ShuttingDown,
            "the service is shutting down; retry in a moment",
            5,
        ));
    }
    let key = idempotency_key(req.headers())?;
    let limits = UploadLimits {
        max_bytes: state.config.max_upload_bytes,
        idle_timeout: state.config.upload_idle_timeout,
    };
    let parsed = read_upload(&state.jobs, req, limits).await?;
    let upload = Upload {
        asset: parsed.asset,
        resources: parsed.resources,
        options: parsed.options,
        idempotency_key: key,
    };
    let submitted = state
        .jobs
        .submit(owner.0, upload)
        .await
        .map_err(|e| match e {
            SubmitError::InvalidOption { option, detail } => ApiError::unprocessable(
                ProblemCode::InvalidOption,
                format!("option `{option}`: {detail}"),
                Vec::new(),
            ),
            SubmitError::InvalidAsset {
                code,
                detail,
                defects,
            } => ApiError::unprocessable(code, detail, defects),
            SubmitError::IdempotencyKeyReused { job_id } => ApiError::unprocessable(
                ProblemCode::IdempotencyKeyReused,
                format!(
                    "this Idempotency-Key was used for job {job_id} with a different body; use a \
                 new key for a new request"
                ),
                Vec::new(),
            ),
            SubmitError::QueueFull { depth, retry_after } => ApiError::unavailable(
                ProblemCode::QueueFull,
                format!("{depth} jobs are queued or running, the capacity; retry after a while"),
                retry_after.as_secs(),
            ),
            SubmitError::Store(e) => ApiError::internal(e),
        })?;
    record_job_id(&submitted.job.id);
    let body = job_json(&submitted.job);
    let mut response = (StatusCode::ACCEPTED, Json(body)).into_response();
    if let Ok(v) = HeaderValue::from_str(&format!("/v1/jobs/{}", submitted.job.id)) {
        response.headers_mut().insert(header::LOCATION, v);
    }
    if submitted.replayed {
        response
            .headers_mut()
            .insert("idempotent-replayed", HeaderValue::from_static("true"));
    }
    Ok(response)
}

/// `GET /v1/jobs/{id}`.
pub(crate) async fn get_job(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
) -> Result<Json<JobJson>, ApiError> {
    check_id(&id)?;
    record_job_id(&id);
    match state.jobs.get(owner.0.as_deref(), &id).await? {
        Some(job) => Ok(Json(job_json(&job))),
        None => Err(ApiError::job_not_found(&id)),
    }
}

/// Query of `GET /v1/jobs`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ListParams {
    status: Option<String>,
    cursor: Option<String>,
    limit: Option<u32>,
}

/// `GET /v1/jobs`.
pub(crate) async fn list_jobs(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    params: Result<Query<ListParams>, axum::extract::rejection::QueryRejection>,
) -> Result<Json<JobListJson>, ApiError> {
    let Query(params) = params.map_err(|e| {
        ApiError::bad_request(
            ProblemCode::InvalidQuery,
            format!(
                "{}; the parameters are status, cursor and limit",
                e.body_text()
            ),
        )
    })?;
    let status = match params.status.as_deref() {
        None => None,
        Some(s) => Some(JobStatus::parse(s).ok_or_else(|| {
            ApiError::bad_request(
                ProblemCode::InvalidStatus,
                format!(
                    "`{s}` is not a status; use queued, running, succeeded, failed or cancelled"
                ),
            )
        })?),
    };
    let limit = params.limit.unwrap_or(20);
    if !(1..=100).contains(&limit) {
        return Err(ApiError::bad_request(
            ProblemCode::InvalidLimit,
            format!("limit {limit} is out of range; use 1 to 100"),
        ));
    }
    let before = match params.cursor.as_deref() {
        None => None,
        Some(c) => Some(
            c.strip_prefix('c')
                .and_then(|n| n.parse::<i64>().ok())
                .filter(|n| *n > 0)
                .ok_or_else(|| {
                    ApiError::bad_request(
                        ProblemCode::InvalidCursor,
                        "the cursor is not one this service gave; pass `next_cursor` of the \
                         previous page unchanged",
                    )
                })?,
        ),
    };
    let mut jobs = state
        .jobs
        .list(owner.0.as_deref(), status, before, limit + 1)
        .await?;
    let more = jobs.len() > limit as usize;
    jobs.truncate(limit as usize);
    let next_cursor = more
        .then(|| jobs.last().map(|j| format!("c{}", j.seq)))
        .flatten();
    Ok(Json(JobListJson {
        jobs: jobs.iter().map(job_json).collect(),
        next_cursor,
    }))
}

/// `DELETE /v1/jobs/{id}`.
pub(crate) async fn delete_job(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
) -> Result<Response, ApiError> {
    check_id(&id)?;
    record_job_id(&id);
    match state.jobs.cancel_or_delete(owner.0.as_deref(), &id).await? {
        DeleteOutcome::NotFound => Err(ApiError::job_not_found(&id)),
        DeleteOutcome::Cancelled(job) => {
            Ok((StatusCode::ACCEPTED, Json(job_json(&job))).into_response())
        }
        DeleteOutcome::Deleted => Ok(StatusCode::NO_CONTENT.into_response()),
    }
}

/// Query of `GET /v1/jobs/{id}/result`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ResultParams {
    format: Option<String>,
}

async fn artifact(
    state: &AppState,
    owner: &Owner,
    id: &str,
    which: Artifact,
) -> Result<Vec<u8>, ApiError> {
    check_id(id)?;
    record_job_id(id);
    match state.jobs.artifact(owner.0.as_deref(), id, which).await? {
        ArtifactOutcome::NotFound => Err(ApiError::job_not_found(id)),
        ArtifactOutcome::NotReady(job) => {
            let detail = match job.status {
                JobStatus::Queued | JobStatus::Running => format!(
                    "job {id} is {}; poll GET /v1/jobs/{id} (or GET /v1/jobs/{id}/events) until \
                     it has succeeded",
                    job.status.as_str()
                ),
                _ => format!(
                    "job {id} is {} and has no result; see its `error` in GET /v1/jobs/{id}",
                    job.status.as_str()
                ),
            };
            Err(ApiError::new(
                StatusCode::CONFLICT,
                ProblemCode::ResultNotReady,
                detail,
            ))
        }
        ArtifactOutcome::Bytes(b) => Ok(b),
    }
}

fn bytes_response(content_type: &'static str, disposition: Option<String>, b: Vec<u8>) -> Response {
    let mut r = b.into_response();
    r.headers_mut()
        .insert(header::CONTENT_TYPE, HeaderValue::from_static(content_type));
    if let Some(d) = disposition.and_then(|d| HeaderValue::from_str(&d).ok()) {
        r.headers_mut().insert(header::CONTENT_DISPOSITION, d);
    }
    r
}

/// `GET /v1/jobs/{id}/result`: GLB, or `.gltf` with `?format=gltf` or
/// `Accept: model/gltf+json`; default: the job's `output_format`.
pub(crate) async fn get_result(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
    headers: HeaderMap,
    params: Result<Query<ResultParams>, axum::extract::rejection::QueryRejection>,
) -> Result<Response, ApiError> {
    let Query(params) = params.map_err(|e| {
        ApiError::bad_request(
            ProblemCode::InvalidQuery,
            format!("{}; the only parameter is format=glb|gltf", e.body_text()),
        )
    })?;
    let accept = headers
        .get(header::ACCEPT)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("");
    let gltf = match params.format.as_deref() {
        Some("gltf") => true,
        Some("glb") => false,
        Some(other) => {
            return Err(ApiError::bad_request(
                ProblemCode::InvalidFormat,
                format!("`{other}` is not a result format; use glb or gltf"),
            ))
        }
        None if accept.contains("model/gltf+json") => true,
        None if accept.contains("model/gltf-binary") => false,
        None => {
            check_id(&id)?;
            let job = state.jobs.get(owner.0.as_deref(), &id).await?;
            job.and_then(|j| serde_json::from_str::<crate::api::OptionsJson>(&j.options_json).ok())
                .and_then(|o| o.output_format)
                == Some(crate::api::OutputFormatJson::Gltf)
        }
    };
    let (which, ct, ext) = if gltf {
        (Artifact::ResultGltf, "model/gltf+json", "gltf")
    } else {
        (Artifact::ResultGlb, "model/gltf-binary", "glb")
    };
    let bytes = artifact(&state, &owner, &id, which).await?;
    Ok(bytes_response(
        ct,
        Some(format!("attachment; filename=\"{id}.{ext}\"")),
        bytes,
    ))
}

/// `GET /v1/jobs/{id}/report`.
pub(crate) async fn get_report(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
) -> Result<Response, ApiError> {
    let bytes = artifact(&state, &owner, &id, Artifact::Report).await?;
    Ok(bytes_response("application/json", None, bytes))
}

/// `GET /v1/jobs/{id}/preview.png`.
pub(crate) async fn get_preview(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
) -> Result<Response, ApiError> {
    let bytes = artifact(&state, &owner, &id, Artifact::Preview).await?;
    Ok(bytes_response("image/png", None, bytes))
}

/// What an event stream last sent.
#[derive(Clone, PartialEq)]
struct Seen {
    status: JobStatus,
    stage: Option<String>,
    fraction: Option<f64>,
}

/// `GET /v1/jobs/{id}/events`: `event: status` on every status change and `event: progress`
/// on progress changes, each with the job as data, in order, ending after the terminal status.
pub(crate) async fn job_events(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
) -> Result<Response, ApiError> {
    check_id(&id)?;
    record_job_id(&id);
    if state.jobs.get(owner.0.as_deref(), &id).await?.is_none() {
        return Err(ApiError::job_not_found(&id));
    }
    struct St {
        state: AppState,
        owner: Option<String>,
        id: String,
        seen: Option<Seen>,
        changes: tokio::sync::watch::Receiver<u64>,
        shutdown: tokio::sync::watch::Receiver<bool>,
        done: bool,
        n: u64,
    }
    let st = St {
        changes: state.jobs.subscribe(),
        shutdown: state.shutdown.clone(),
        state,
        owner: owner.0,
        id,
        seen: None,
        done: false,
        n: 0,
    };
    let stream = futures_util::stream::unfold(st, |mut st| async move {
        if st.done {
            return None;
        }
        loop {
            // Mark the current version seen before reading, so no change is missed.
            st.changes.borrow_and_update();
            let job = match st.state.jobs.get(st.owner.as_deref(), &st.id).await {
                Ok(Some(job)) => job,
                // Deleted meanwhile, or the store failed: the stream ends.
                Ok(None) | Err(_) => return None,
            };
            let now = Seen {
                status: job.status,
                stage: job.progress_stage.clone(),
                fraction: job.progress_fraction,
            };
            if st.seen.as_ref() != Some(&now) {
                let kind = match &st.seen {
                    Some(prev) if prev.status == now.status => "progress",
                    _ => "status",
                };
                st.seen = Some(now);
                st.n += 1;
                st.done = job.status.is_terminal();
                let event = Event::default()
                    .event(kind)
                    .id(st.n.to_string())
                    .json_data(job_json(&job))
                    .unwrap_or_else(|_| Event::default().event(kind));
                return Some((Ok::<Event, Infallible>(event), st));
            }
            if *st.shutdown.borrow() {
                return None;
            }
            tokio::select! {
                _ = st.changes.changed() => {}
                // Changes made by other processes (issue 7) are seen by polling.
                _ = tokio::time::sleep(Duration::from_secs(1)) => {}
                _ = st.shutdown.changed() => {}
            }
        }
    });
    Ok(Sse::new(stream)
        .keep_alive(KeepAlive::new().interval(Duration::from_secs(15)))
        .into_response())
}

/// `GET /healthz`: the process is up.
pub(crate) async fn healthz() -> Json<serde_json::Value> {
    Json(serde_json::json!({ "status": "ok" }))
}

/// `GET /readyz`: the store answers and the service is not shutting down.
pub(crate) async fn readyz(State(state): State<AppState>) -> Result<Response, ApiError> {
    if state.is_shutting_down() {
        return Err(ApiError::unavailable(
            ProblemCode::ShuttingDown,
            "the service is shutting down",
            5,
        ));
    }
    state.jobs.ready().await.map_err(|e| {
        ApiError::unavailable(
            ProblemCode::StoreUnavailable,
            "the job store does not answer",
            5,
        )
        .with_cause(e)
    })?;
    Ok(Json(serde_json::json!({ "status": "ready" })).into_response())
}

/// `GET /metrics`: Prometheus text.
pub(crate) async fn metrics(State(state): State<AppState>) -> Result<Response, ApiError> {
    let counts = state.jobs.counts().await?;
    let text = state.jobs.metrics().render(&counts);
    let mut r = text.into_response();
    r.headers_mut().insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static(crate::jobs::METRICS_CONTENT_TYPE),
    );
    Ok(r)
}

/// The OpenAPI document, served byte for byte as `proto/openapi.json`.
pub const OPENAPI_JSON: &str = include_str!("../../proto/openapi.json");

/// `GET /openapi.json`.
pub(crate) async fn openapi() -> Response {
    let mut r = OPENAPI_JSON.into_response();
    r.headers_mut().insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("application/json"),
    );
    r
}

/// Any other path.
pub(crate) async fn not_found() -> ApiError {
    ApiError::new(
        StatusCode::NOT_FOUND,
        ProblemCode::RouteNotFound,
        "no such endpoint; GET /openapi.json lists them",
    )
}

/// A known path with another method.
pub(crate) async fn method_not_allowed() -> ApiError {
    ApiError::new(
        StatusCode::METHOD_NOT_ALLOWED,
        ProblemCode::MethodNotAllowed,
        "this endpoint does not take that method; GET /openapi.json lists them",
    )
}
