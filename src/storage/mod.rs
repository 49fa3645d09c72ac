//! Persistent state of the service: the job queue ([`JobStore`]) and the bytes of inputs and
//! results ([`BlobStore`]).
//!
//! # Purpose
//! Everything the service must not lose lives behind these two traits, so that a second backend
//! (issue 7: PostgreSQL + an S3-compatible object store) is an addition beside
//! [`sqlite::SqliteJobStore`] and [`fs::FsBlobStore`], not a rewrite of `jobs` or `http`.
//!
//! # Invariants
//! - **SQL lives only here** (`tests/architecture.rs`): `jobs` and `http` see rows as
//!   [`JobRecord`] values and never name a table or a column.
//! - **The traits are synchronous**, and callers in async code run them on the blocking pool
//!   (`tokio::task::spawn_blocking`, see `jobs::JobService`). Why: rusqlite is synchronous, and a
//!   sync trait is object safe without boxing futures; a PostgreSQL backend can use the
//!   synchronous `postgres` client or block on its own runtime handle. Every method is short
//!   (one statement or one small transaction, or one file) so a blocking thread is held briefly.
//! - **The queue is lease based.** A worker [`JobStore::claim`]s the oldest queued job in one
//!   atomic statement, which sets `status = running`, `worker`, `lease_until` and increments
//!   `attempts`. The worker extends the lease with [`JobStore::heartbeat`] while it runs. Every
//!   later write by the worker is fenced by `(id, worker, status = running)`, so a worker whose
//!   lease expired and was re-queued cannot overwrite the new attempt. Expired leases return
//!   to the queue ([`JobStore::requeue_expired`]) until `max_attempts`, then fail.
//! - **Blob keys are validated** ([`BlobKey`]): `/`-separated segments of `[A-Za-z0-9._-]`,
//!   never `.` or `..`, so no key can name a path outside the store.
//! - **Blob writes are atomic**: a reader sees the old bytes, or all of the new ones.
//!
//! # Units
//! Times are milliseconds since the Unix epoch (`_ms`), passed in by the caller so the store
//! itself reads no clock and tests can move time.
//!
//! # The job state machine
//! ```text
//!            claim                 finish(Succeeded)
//!  queued ──────────▶ running ──────────────────────▶ succeeded
//!    ▲  │               │  │     finish(Failed) / attempts exhausted
//!    │  │ cancel        │  └───────────────────────▶ failed
//!    │  ▼               │ cancel requested → finish(Cancelled)
//!    │ cancelled ◀──────┘
//!    └── lease expired (attempts < max) or release (graceful shutdown)
//! ```
//! The terminal states (`succeeded`, `failed`, `cancelled`) never change again; only
//! [`JobStore::delete`] removes them (by a user, or the retention sweeper after `expires_at`).
pub mod fs;
pub mod sqlite;

use std::path::Path;

/// Why a store operation failed. These are infrastructure faults (disk, database), never the
/// user's: the HTTP layer maps them to a 500/503 with only a code and a request id.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// The database failed (I/O, corruption, busy past the timeout).
    #[error("database: {0}")]
    Database(String),
    /// A blob could not be read or written.
    #[error("blob store: {0}")]
    Blob(String),
    /// A blob key is malformed (a bug of the caller: keys are built by `jobs`).
    #[error("invalid blob key `{0}`: use `/`-separated segments of A-Z a-z 0-9 . _ -")]
    InvalidKey(String),
}

/// The status of a job (module doc: the state machine).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum JobStatus {
    /// Accepted, waiting for a worker.
    Queued,
    /// Held by a worker under a lease.
    Running,
    /// Done; the result, report and preview are stored.
    Succeeded,
    /// Done with an error (`error_json`).
    Failed,
    /// Cancelled by its owner before it finished.
    Cancelled,
}

impl JobStatus {
    /// Every status, in state-machine order.
    pub const ALL: [JobStatus; 5] = [
        JobStatus::Queued,
        JobStatus::Running,
        JobStatus::Succeeded,
        JobStatus::Failed,
        JobStatus::Cancelled,
    ];

    /// Stable lower-case name (wire and database).
    pub fn as_str(self) -> &'static str {
        match self {
            JobStatus::Queued => "queued",
            JobStatus::Running => "running",
            JobStatus::Succeeded => "succeeded",
            JobStatus::Failed => "failed",
            JobStatus::Cancelled => "cancelled",
        }
    }

    /// The status named `s` ([`JobStatus::as_str`]).
    pub fn parse(s: &str) -> Option<JobStatus> {
        JobStatus::ALL.into_iter().find(|st| st.as_str() == s)
    }

    /// True for `succeeded`, `failed` and `cancelled`: the status never changes again.
    pub fn is_terminal(self) -> bool {
        matches!(
            self,
            JobStatus::Succeeded | JobStatus::Failed | JobStatus::Cancelled
        )
    }
}

/// One job as stored. The `*_json` fields are opaque text to the store: `jobs` writes and reads
/// them (options, input manifest, result manifest, error).
#[derive(Debug, Clone, PartialEq)]
pub struct JobRecord {
    /// Public id (a UUIDv7 string).
    pub id: String,
    /// Insertion order, strictly increasing: the list order and the pagination cursor.
    pub seq: i64,
    /// Hash of the API key that created the job (`None` when the service runs without keys).
    pub owner: Option<String>,
    /// Where the job is in the state machine.
    pub status: JobStatus,
    /// The wire options as submitted (JSON object).
    pub options_json: String,
    /// Where the input blobs are (JSON written by `jobs`).
    pub input_json: String,
    /// Triangles of the decoded input (metrics, listings).
    pub triangles: u64,
    /// The client's `Idempotency-Key`, if any.
    pub idempotency_key: Option<String>,
    /// SHA-256 (hex) of the request: options and every uploaded part.
    pub body_hash: String,
    /// Claims so far (1 for a job that ran once).
    pub attempts: u32,
    /// The current lease ends here (running jobs only).
    pub lease_until_ms: Option<i64>,
    /// The worker holding the lease (running jobs), or the last one.
    pub worker: Option<String>,
    /// The owner asked for a cancel while the job was running.
    pub cancel_requested: bool,
    /// The stage running now (`segment`, `parameterize`, `pack`, `measure`).
    pub progress_stage: Option<String>,
    /// Fraction of the whole job done, in \[0, 1\].
    pub progress_fraction: Option<f64>,
    /// Accepted at.
    pub created_at_ms: i64,
    /// First claimed at.
    pub started_at_ms: Option<i64>,
    /// Reached a terminal status at.
    pub finished_at_ms: Option<i64>,
    /// The retention sweeper deletes the job and its blobs after this.
    pub expires_at_ms: Option<i64>,
    /// The failure (problem JSON written by `jobs`), for failed jobs.
    pub error_json: Option<String>,
    /// Where the result blobs are (JSON written by `jobs`), for succeeded jobs.
    pub result_json: Option<String>,
}

/// A job to insert.
#[derive(Debug, Clone, PartialEq)]
pub struct NewJob {
    /// [`JobRecord::id`].
    pub id: String,
    /// [`JobRecord::owner`].
    pub owner: Option<String>,
    /// [`JobRecord::options_json`].
    pub options_json: String,
    /// [`JobRecord::input_json`].
    pub input_json: String,
    /// [`JobRecord::triangles`].
    pub triangles: u64,
    /// [`JobRecord::idempotency_key`].
    pub idempotency_key: Option<String>,
    /// [`JobRecord::body_hash`].
    pub body_hash: String,
    /// [`JobRecord::created_at_ms`].
    pub created_at_ms: i64,
}

/// What [`JobStore::create`] did.
#[derive(Debug, Clone, PartialEq)]
pub enum Created {
    /// The job was inserted, queued.
    New(JobRecord),
    /// The same owner already sent this idempotency key with the same body: that job.
    Replayed(JobRecord),
    /// The same owner already sent this idempotency key with another body: that job.
    KeyReused(JobRecord),
    /// `queued + running` had reached the capacity: nothing was inserted.
    QueueFull {
        /// Jobs queued or running.
        depth: u64,
    },
}

/// How a running job ends ([`JobStore::finish`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Finish {
    /// Done; `result_json` says where the blobs are.
    Succeeded {
        /// [`JobRecord::result_json`].
        result_json: String,
    },
    /// Failed with this problem JSON.
    Failed {
        /// [`JobRecord::error_json`].
        error_json: String,
    },
    /// Stopped on the owner's request.
    Cancelled,
}

/// Filters and page of [`JobStore::list`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ListQuery {
    /// Only jobs of this owner (`None`: jobs without an owner, when the service has no keys).
    pub owner: Option<String>,
    /// Only jobs in this status.
    pub status: Option<JobStatus>,
    /// Only jobs older than this [`JobRecord::seq`] (the cursor of the previous page).
    pub before_seq: Option<i64>,
    /// Page size.
    pub limit: u32,
}

/// What [`JobStore::requeue_expired`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Requeued {
    /// Jobs back in the queue.
    pub requeued: u64,
    /// Jobs failed because they had used up their attempts.
    pub failed: u64,
}

/// The persistent job queue (module doc: state machine, leases, fencing).
pub trait JobStore: Send + Sync + 'static {
    /// Inserts a queued job, unless the owner's idempotency key is already taken (→ the existing
    /// job, [`Created::Replayed`] when the body hash matches, else [`Created::KeyReused`]) or
    /// `queued + running ≥ capacity` (→ [`Created::QueueFull`]). One transaction.
    fn create(&self, job: NewJob, capacity: Option<u64>) -> Result<Created, StoreError>;

    /// The job with the owner's idempotency key.
    fn find_idempotent(
        &self,
        owner: Option<&str>,
        key: &str,
    ) -> Result<Option<JobRecord>, StoreError>;

    /// The job `id`, whoever owns it (owner checks are the caller's).
    fn get(&self, id: &str) -> Result<Option<JobRecord>, StoreError>;

    /// Jobs newest first ([`ListQuery`]).
    fn list(&self, query: &ListQuery) -> Result<Vec<JobRecord>, StoreError>;

    /// Claims the oldest queued job for `worker` until `now_ms + lease_ms`, in one atomic
    /// statement (`UPDATE … RETURNING`): two workers never claim the same job.
    fn claim(
        &self,
        worker: &str,
        now_ms: i64,
        lease_ms: i64,
    ) -> Result<Option<JobRecord>, StoreError>;

    /// Extends `worker`'s lease on `id` to `lease_until_ms` and stores the progress. Returns
    /// `None` when the worker no longer holds the job (lease lost), else whether a cancel was
    /// requested.
    fn heartbeat(
        &self,
        id: &str,
        worker: &str,
        lease_until_ms: i64,
        progress: Option<(&str, f64)>,
    ) -> Result<Option<bool>, StoreError>;

    /// Moves `worker`'s running job to its terminal status, to be deleted after
    /// `expires_at_ms`. False (and no change) when the worker no longer holds it.
    fn finish(
        &self,
        id: &str,
        worker: &str,
        finish: &Finish,
        now_ms: i64,
        expires_at_ms: i64,
    ) -> Result<bool, StoreError>;

    /// Cancels: a queued job becomes cancelled at once; a running one gets
    /// `cancel_requested` (its worker stops at the next checkpoint). Returns the job after the
    /// change, or `None` when there is no such job. Terminal jobs are returned unchanged.
    fn cancel(
        &self,
        id: &str,
        now_ms: i64,
        expires_at_ms: i64,
    ) -> Result<Option<JobRecord>, StoreError>;

    /// Deletes a terminal job's row. False when it does not exist or is not terminal.
    fn delete(&self, id: &str) -> Result<bool, StoreError>;

    /// Gives `worker`'s running job back to the queue without counting the attempt (graceful
    /// shutdown). False when the worker no longer holds it.
    fn release(&self, id: &str, worker: &str) -> Result<bool, StoreError>;

    /// Running jobs whose lease ended before `now_ms` go back to the queue, or fail with
    /// `exhausted_error_json` once they have had `max_attempts` claims.
    fn requeue_expired(
        &self,
        now_ms: i64,
        max_attempts: u32,
        exhausted_error_json: &str,
        expires_at_ms: i64,
    ) -> Result<Requeued, StoreError>;

    /// Up to `limit` terminal jobs whose `expires_at` is before `now_ms`.
    fn expired(&self, now_ms: i64, limit: u32) -> Result<Vec<JobRecord>, StoreError>;

    /// Jobs per status, in [`JobStatus::ALL`] order.
    fn counts(&self) -> Result<[u64; 5], StoreError>;

    /// Cheap round trip to the database (`/readyz`).
    fn ping(&self) -> Result<(), StoreError>;

    /// True when [`JobStore::get`] and [`JobStore::list`] never wait on I/O beyond a local
    /// page cache or on another writer, so async callers may run them in place instead of
    /// hopping to the blocking pool (two thread switches, which dominate a status request on a
    /// busy machine). Default `false` (a networked database must say no).
    fn inline_reads(&self) -> bool {
        false
    }
}

/// A validated blob key: `/`-separated segments of `[A-Za-z0-9._-]`, none empty, `.` or `..`,
/// at most 512 bytes.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct BlobKey(String);

impl BlobKey {
    /// Checks `key` ([`BlobKey`]).
    pub fn new(key: impl Into<String>) -> Result<BlobKey, StoreError> {
        let key = key.into();
        let ok = !key.is_empty()
            && key.len() <= 512
            && key.split('/').all(|seg| {
                !seg.is_empty()
                    && seg != "."
                    && seg != ".."
                    && seg
                        .bytes()
                        .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'.' | b'_' | b'-'))
            });
        if ok {
            Ok(BlobKey(key))
        } else {
            Err(StoreError::InvalidKey(key))
        }
    }

    /// The key text.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

/// Bytes by key (inputs, results). Writes are atomic (module doc).
pub trait BlobStore: Send + Sync + 'static {
    /// Stores `bytes` under `key`, replacing what was there.
    fn put(&self, key: &BlobKey, bytes: &[u8]) -> Result<(), StoreError>;

    /// Stores the local file `path` under `key` and removes `path` (moved when possible).
    /// For uploads streamed to a spool file.
    fn put_file(&self, key: &BlobKey, path: &Path) -> Result<(), StoreError>;

    /// The bytes under `key`, `None` when absent. Cost: reads the whole blob into memory.
    fn get(&self, key: &BlobKey) -> Result<Option<Vec<u8>>, StoreError>;

    /// Deletes every blob whose key is `prefix` or starts with `prefix/`.
    fn delete_prefix(&self, prefix: &BlobKey) -> Result<(), StoreError>;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blob_keys_refuse_traversal_and_odd_characters() {
        for good in ["jobs/abc/input", "a", "jobs/0190-ab_c/a1/result.glb"] {
            assert!(BlobKey::new(good).is_ok(), "{good}");
        }
        for bad in [
            "",
            "/etc/passwd",
            "../x",
            "jobs/../../x",
            "jobs/./x",
            "jobs//x",
            "jobs/x/",
            "c:\\x",
            "jobs/a b",
            "jobs/%2e%2e",
            "jobs/\0",
        ] {
            assert!(BlobKey::new(bad).is_err(), "{bad:?} was accepted");
        }
        assert!(BlobKey::new("a".repeat(513)).is_err());
    }

    #[test]
    fn status_names_round_trip() {
        for s in JobStatus::ALL {
            assert_eq!(JobStatus::parse(s.as_str()), Some(s));
        }
        assert_eq!(JobStatus::parse("done"), None);
        assert!(!JobStatus::Running.is_terminal());
        assert!(JobStatus::Cancelled.is_terminal());
    }
}
