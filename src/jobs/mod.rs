//! Jobs: submitting, running and reading unwrap jobs on top of `storage` — the first async
//! module of the crate.
//!
//! # Purpose
//! - [`JobService`]: what the HTTP layer calls. Submit (validate and decode the upload on the
//!   blocking pool, store the input blobs, insert the queued job), read, list, cancel or delete,
//!   fetch results, watch for changes. Owner checks happen here: a job of another owner is
//!   reported as absent.
//! - [`WorkerPool`]: N workers, each claiming one job at a time from the
//!   [`JobStore`](crate::storage::JobStore) and running the [`Processor`] on tokio's blocking
//!   pool, plus one sweeper (expired leases back to the queue, expired results deleted).
//! - [`Processor`]: the work of one job. Production: [`UnwrapProcessor`]
//!   (`gltf_io::decode` → `unwrap::unwrap_asset` → encode both containers + report + preview);
//!   tests inject fakes so the queue can be tested without the pipeline's cost.
//!
//! # Invariants
//! - An accepted job is never lost: the job row is inserted after its input blobs are stored,
//!   and a job leaves `running` only through a fenced store write (finish, release, or lease
//!   expiry → back to the queue until `max_attempts`).
//! - A slow job never blocks the API: processing runs under `spawn_blocking`, store calls are
//!   short and also run on the blocking pool.
//! - A panic in a processor, or a job over its time limit, fails that job with an internal
//!   code (`worker_panicked`, `time_limit_exceeded`); the worker carries on.
//! - Progress reaches the store at most [`JobsConfig::progress_interval`] apart (≤ 5 Hz by
//!   default): the pipeline thread only writes a mutex-guarded snapshot, a heartbeat task
//!   flushes it with the lease renewal.
//! - Cancellation is cooperative: the progress bridge returns `Break` once the job's cancel
//!   flag is set (by a local `DELETE`, or seen in the store by the heartbeat).
//!
//! # Units
//! Durations are `std::time::Duration`; store times are ms since the Unix epoch.
mod metrics;
mod processor;
mod progress;
mod service;
mod worker;

pub use metrics::{Metrics, CONTENT_TYPE as METRICS_CONTENT_TYPE};
pub use processor::{JobFailure, JobInput, JobOutput, Processor, UnwrapProcessor};
pub use service::{
    Artifact, ArtifactOutcome, DeleteOutcome, JobService, JobsConfig, SpooledPart, SubmitError,
    Submitted, Upload,
};
pub use worker::WorkerPool;

pub use crate::storage::{JobRecord, JobStatus};

/// Milliseconds since the Unix epoch, now.
pub(crate) fn now_ms() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_millis().min(i64::MAX as u128) as i64)
        .unwrap_or(0)
}
