//! [`JobService`]: the operations the HTTP layer calls (module doc of `jobs`).
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use tokio::sync::{watch, Notify};

use super::metrics::Metrics;
use super::now_ms;
use super::processor::JobInput;
use crate::api::{AssetDefectJson, OptionsJson, ProblemCode};
use crate::atlas::AtlasError;
use crate::gltf_io::{self, DecodeLimits, Resources};
use crate::storage::{
    BlobKey, BlobStore, Created, JobRecord, JobStatus, JobStore, ListQuery, NewJob, StoreError,
};

/// Settings of the queue and the workers.
#[derive(Debug, Clone)]
pub struct JobsConfig {
    /// Workers (jobs run at once). Default: the CPU count.
    pub workers: usize,
    /// How long a claim holds a job without a heartbeat; a crashed worker's jobs return to the
    /// queue this long after its last heartbeat. Default 15 s.
    pub lease: Duration,
    /// Least time between two progress writes of one job. Default 200 ms (≤ 5 Hz).
    pub progress_interval: Duration,
    /// Wall-clock limit of one attempt; `None`: no limit. Default 10 min.
    pub job_time_limit: Option<Duration>,
    /// Most jobs queued or running; past it submissions get 503 + `Retry-After`. `None`: no
    /// limit. Default 1000.
    pub queue_capacity: Option<u64>,
    /// Finished jobs and their blobs are deleted this long after they end. Default 24 h.
    pub retention: Duration,
    /// Claims of one job before a crashing job is failed instead of re-queued. Default 3.
    pub max_attempts: u32,
    /// How often the sweeper looks for expired leases and results. Default 1 s.
    pub sweep_interval: Duration,
    /// Decoder limits (triangle limit) applied at submission and in the worker.
    pub decode_limits: DecodeLimits,
}

impl Default for JobsConfig {
    fn default() -> Self {
        JobsConfig {
            workers: std::thread::available_parallelism().map_or(1, |n| n.get()),
            lease: Duration::from_secs(15),
            progress_interval: Duration::from_millis(200),
            job_time_limit: Some(Duration::from_secs(600)),
            queue_capacity: Some(1000),
            retention: Duration::from_secs(24 * 3600),
            max_attempts: 3,
            sweep_interval: Duration::from_secs(1),
            decode_limits: DecodeLimits::default(),
        }
    }
}

/// One uploaded part, streamed to a file in the service's spool directory (the `spool_dir` of
/// `JobService::new`). The file is removed when the part is dropped unless it was moved into
/// the blob store.
#[derive(Debug)]
pub struct SpooledPart {
    /// The spool file.
    path: PathBuf,
    /// The part's name: for resources, the URI the `.gltf` uses (`scene.bin`).
    pub name: String,
    /// Bytes.
    pub size: u64,
}

impl SpooledPart {
    /// A part whose bytes are in `path` (which this part now owns).
    pub fn new(path: PathBuf, name: impl Into<String>, size: u64) -> SpooledPart {
        SpooledPart {
            path,
            name: name.into(),
            size,
        }
    }

    /// The spool file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for SpooledPart {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

/// A submission.
#[derive(Debug)]
pub struct Upload {
    /// The asset (`.glb` or `.gltf`).
    pub asset: SpooledPart,
    /// Further parts: the `.gltf`'s buffers and images, named by URI.
    pub resources: Vec<SpooledPart>,
    /// The options.
    pub options: OptionsJson,
    /// The client's `Idempotency-Key`.
    pub idempotency_key: Option<String>,
}

/// Why a submission was refused.
#[derive(Debug, thiserror::Error)]
pub enum SubmitError {
    /// An option is out of range.
    #[error("option `{option}`: {detail}")]
    InvalidOption {
        /// The option, as on the wire.
        option: String,
        /// What is wrong and what to use.
        detail: String,
    },
    /// The asset cannot be decoded or has no triangles.
    #[error("{code}: {detail}")]
    InvalidAsset {
        /// Stable code (the first defect's).
        code: ProblemCode,
        /// What is wrong.
        detail: String,
        /// Every defect, with JSON paths.
        defects: Vec<AssetDefectJson>,
    },
    /// The idempotency key was used before with another body.
    #[error("idempotency key already used for job {job_id} with another request body")]
    IdempotencyKeyReused {
        /// The job created with that key.
        job_id: String,
    },
    /// The queue is full.
    #[error("{depth} jobs are queued or running, the capacity")]
    QueueFull {
        /// Jobs queued or running.
        depth: u64,
        /// Suggested wait before retrying.
        retry_after: Duration,
    },
    /// The store failed.
    #[error(transparent)]
    Store(#[from] StoreError),
}

/// A submission that was accepted.
#[derive(Debug, Clone)]
pub struct Submitted {
    /// The job.
    pub job: JobRecord,
    /// The same idempotency key and body had been submitted before: this is that job.
    pub replayed: bool,
}

/// What `DELETE` did.
#[derive(Debug, Clone)]
pub enum DeleteOutcome {
    /// No such job (for this owner).
    NotFound,
    /// The job was queued and is now cancelled, or was running and will stop at its next
    /// checkpoint (`cancel_requested`), or had already ended and is deleted.
    Cancelled(Box<JobRecord>),
    /// The job had ended; it and its blobs are deleted.
    Deleted,
}

/// A stored output of a succeeded job.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Artifact {
    /// The asset as GLB.
    ResultGlb,
    /// The asset as `.gltf`.
    ResultGltf,
    /// The report JSON.
    Report,
    /// The UV layout PNG.
    Preview,
}

/// What fetching an artifact found.
#[derive(Debug)]
pub enum ArtifactOutcome {
    /// No such job (for this owner), or its results were already swept.
    NotFound,
    /// The job has not succeeded (yet, or ever).
    NotReady(Box<JobRecord>),
    /// The bytes.
    Bytes(Vec<u8>),
}

/// Where the input blobs of a job are (`input_json`).
#[derive(Debug, Serialize, Deserialize)]
pub(crate) struct InputManifest {
    pub asset: String,
    pub resources: Vec<(String, String)>,
}

/// Where the result blobs of a job are (`result_json`).
#[derive(Debug, Serialize, Deserialize)]
pub(crate) struct ResultManifest {
    pub glb: String,
    pub gltf: String,
    pub report: String,
    pub preview: String,
}

/// The operations on jobs (module doc of `jobs`).
pub struct JobService {
    pub(crate) store: Arc<dyn JobStore>,
    pub(crate) blobs: Arc<dyn BlobStore>,
    pub(crate) config: JobsConfig,
    pub(crate) metrics: Arc<Metrics>,
    /// Where uploads are streamed (same filesystem as the blobs, so storing is a rename).
    spool_dir: PathBuf,
    /// Bumped on every job change made by this process: wakes event streams.
    pub(crate) changes: watch::Sender<u64>,
    /// Wakes idle workers when a job is queued.
    pub(crate) work: Notify,
    /// Cancel flags of the jobs running in this process.
    pub(crate) running: Mutex<HashMap<String, Arc<AtomicBool>>>,
    /// Submissions decoded at once: each holds its upload and decoded asset in memory (up to
    /// the upload limit plus the decoder's limits), so this bounds the memory of submissions.
    decode_permits: tokio::sync::Semaphore,
}

impl std::fmt::Debug for JobService {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JobService")
            .field("config", &self.config)
            .field("spool_dir", &self.spool_dir)
            .finish_non_exhaustive()
    }
}

/// Runs a store call on the blocking pool.
pub(crate) async fn blocking<T: Send + 'static>(
    f: impl FnOnce() -> Result<T, StoreError> + Send + 'static,
) -> Result<T, StoreError> {
    tokio::task::spawn_blocking(f)
        .await
        .unwrap_or_else(|e| Err(StoreError::Database(format!("store task failed: {e}"))))
}

fn key(s: String) -> Result<BlobKey, StoreError> {
    BlobKey::new(s)
}

/// The blob prefix of everything a job stores.
pub(crate) fn job_prefix(id: &str) -> Result<BlobKey, StoreError> {
    key(format!("jobs/{id}"))
}

impl JobService {
    /// A service over these stores; uploads are spooled in `spool_dir` (created, emptied).
    pub fn new(
        store: Arc<dyn JobStore>,
        blobs: Arc<dyn BlobStore>,
        config: JobsConfig,
        spool_dir: PathBuf,
    ) -> Result<Arc<JobService>, StoreError> {
        let _ = std::fs::remove_dir_all(&spool_dir);
        std::fs::create_dir_all(&spool_dir)
            .map_err(|e| StoreError::Blob(format!("creating {}: {e}", spool_dir.display())))?;
        Ok(Arc::new(JobService {
            store,
            blobs,
            config,
            metrics: Arc::new(Metrics::default()),
            spool_dir,
            changes: watch::channel(0).0,
            work: Notify::new(),
            running: Mutex::new(HashMap::new()),
            decode_permits: tokio::sync::Semaphore::new(2),
        }))
    }

    /// The settings.
    pub fn config(&self) -> &JobsConfig {
        &self.config
    }

    /// The process metrics (HTTP latency is recorded here too).
    pub fn metrics(&self) -> &Arc<Metrics> {
        &self.metrics
    }

    /// A fresh spool file path for one uploaded part.
    pub fn spool_path(&self) -> PathBuf {
        self.spool_dir
            .join(uuid::Uuid::now_v7().simple().to_string())
    }

    /// Wakes whenever this process changed a job (submit, progress, end, cancel).
    pub fn subscribe(&self) -> watch::Receiver<u64> {
        self.changes.subscribe()
    }

    pub(crate) fn changed(&self) {
        self.changes.send_modify(|v| *v = v.wrapping_add(1));
    }

    /// Validates, decodes and queues an upload (module doc of `jobs`).
    pub async fn submit(
        self: &Arc<Self>,
        owner: Option<String>,
        upload: Upload,
    ) -> Result<Submitted, SubmitError> {
        let settings_check = upload.options.to_settings();
        if let Err(AtlasError::InvalidOption { option, detail }) = settings_check {
            return Err(SubmitError::InvalidOption {
                option: option.to_string(),
                detail,
            });
        }
        let _permit = self.decode_permits.acquire().await.map_err(|_| {
            SubmitError::Store(StoreError::Database("the service is stopping".into()))
        })?;
        let this = self.clone();
        tokio::task::spawn_blocking(move || this.submit_blocking(owner, upload))
            .await
            .unwrap_or_else(|e| {
                Err(SubmitError::Store(StoreError::Database(format!(
                    "submit task failed: {e}"
                ))))
            })
    }

    fn submit_blocking(
        &self,
        owner: Option<String>,
        upload: Upload,
    ) -> Result<Submitted, SubmitError> {
        let read = |p: &SpooledPart| {
            std::fs::read(p.path())
                .map_err(|e| StoreError::Blob(format!("reading the spooled upload: {e}")))
        };
        let asset_bytes = read(&upload.asset)?;
        let options_text = serde_json::to_string(&upload.options)
            .map_err(|e| StoreError::Database(format!("options: {e}")))?;
        // The body hash: options and every part, length-prefixed, in a fixed order.
        let mut hasher = Sha256::new();
        hasher.update(b"texatlas-submit-v1\0");
        hasher.update((options_text.len() as u64).to_le_bytes());
        hasher.update(options_text.as_bytes());
        hasher.update((asset_bytes.len() as u64).to_le_bytes());
        hasher.update(&asset_bytes);
        let mut sorted: Vec<&SpooledPart> = upload.resources.iter().collect();
        sorted.sort_by(|a, b| a.name.cmp(&b.name));
        let mut resources = Resources::new();
        for part in sorted {
            let bytes = read(part)?;
            hasher.update((part.name.len() as u64).to_le_bytes());
            hasher.update(part.name.as_bytes());
            hasher.update((bytes.len() as u64).to_le_bytes());
            hasher.update(&bytes);
            resources.insert(part.name.clone(), bytes);
        }
        let body_hash: String = hasher
            .finalize()
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        if let Some(k) = &upload.idempotency_key {
            if let Some(existing) = self.store.find_idempotent(owner.as_deref(), k)? {
                return replay_or_reused(existing, &body_hash);
            }
        }
        // Decode now, so a bad asset is a 422 at once; the worker decodes again from the blobs.
        let invalid = |e: &gltf_io::GltfError| SubmitError::InvalidAsset {
            code: ProblemCode::from(e),
            detail: e.to_string(),
            defects: vec![AssetDefectJson::from(e)],
        };
        let required = gltf_io::required_resources(&asset_bytes).map_err(|e| invalid(&e))?;
        let asset = gltf_io::decode(&asset_bytes, &resources, &self.config.decode_limits)
            .map_err(|e| invalid(&e))?;
        let triangles = asset.mesh_input().triangles.len() as u64;
        if triangles == 0 {
            return Err(SubmitError::InvalidAsset {
                code: ProblemCode::ZeroTriangles,
                detail: "the asset has no triangle primitive; give at least one mesh with \
                         triangles (points and lines cannot be unwrapped)"
                    .into(),
                defects: Vec::new(),
            });
        }
        drop(asset);
        drop(asset_bytes);
        let id = uuid::Uuid::now_v7().to_string();
        let prefix = format!("jobs/{id}/input");
        let asset_key = key(format!("{prefix}/asset"))?;
        let mut manifest = InputManifest {
            asset: asset_key.as_str().to_string(),
            resources: Vec::new(),
        };
        let mut store_inputs = || -> Result<(), StoreError> {
            self.blobs.put_file(&asset_key, upload.asset.path())?;
            // Only what the asset references; the rest of the upload is ignored.
            for (i, uri) in required.iter().enumerate() {
                if let Some(part) = upload.resources.iter().find(|p| &p.name == uri) {
                    let k = key(format!("{prefix}/r{i}"))?;
                    self.blobs.put_file(&k, part.path())?;
                    manifest
                        .resources
                        .push((uri.clone(), k.as_str().to_string()));
                }
            }
            Ok(())
        };
        let cleanup = || {
            if let Ok(p) = job_prefix(&id) {
                let _ = self.blobs.delete_prefix(&p);
            }
        };
        if let Err(e) = store_inputs() {
            cleanup();
            return Err(e.into());
        }
        let input_json = serde_json::to_string(&manifest)
            .map_err(|e| StoreError::Database(format!("input manifest: {e}")))?;
        let created = self.store.create(
            NewJob {
                id: id.clone(),
                owner,
                options_json: options_text,
                input_json,
                triangles,
                idempotency_key: upload.idempotency_key.clone(),
                body_hash: body_hash.clone(),
                created_at_ms: now_ms(),
            },
            self.config.queue_capacity,
        );
        match created {
            Ok(Created::New(job)) => {
                self.work.notify_one();
                self.changed();
                Ok(Submitted {
                    job,
                    replayed: false,
                })
            }
            Ok(Created::Replayed(job)) => {
                cleanup();
                Ok(Submitted {
                    job,
                    replayed: true,
                })
            }
            Ok(Created::KeyReused(job)) => {
                cleanup();
                Err(SubmitError::IdempotencyKeyReused { job_id: job.id })
            }
            Ok(Created::QueueFull { depth }) => {
                cleanup();
                Err(SubmitError::QueueFull {
                    depth,
                    retry_after: self.retry_after(),
                })
            }
            Err(e) => {
                cleanup();
                Err(e.into())
            }
        }
    }

    /// A client's wait before retrying a full queue: about one job's share of the lease.
    fn retry_after(&self) -> Duration {
        Duration::from_secs(5)
    }

    /// The job `id` if `owner` may see it.
    pub async fn get(
        &self,
        owner: Option<&str>,
        id: &str,
    ) -> Result<Option<JobRecord>, StoreError> {
        let job = if self.store.inline_reads() {
            self.store.get(id)?
        } else {
            let store = self.store.clone();
            let id_owned = id.to_string();
            blocking(move || store.get(&id_owned)).await?
        };
        Ok(job.filter(|j| j.owner.as_deref() == owner))
    }

    /// A page of `owner`'s jobs, newest first.
    pub async fn list(
        &self,
        owner: Option<&str>,
        status: Option<JobStatus>,
        before_seq: Option<i64>,
        limit: u32,
    ) -> Result<Vec<JobRecord>, StoreError> {
        let q = ListQuery {
            owner: owner.map(str::to_string),
            status,
            before_seq,
            limit,
        };
        if self.store.inline_reads() {
            return self.store.list(&q);
        }
        let store = self.store.clone();
        blocking(move || store.list(&q)).await
    }

    /// `DELETE`: cancels a queued or running job, deletes a finished one and its blobs.
    pub async fn cancel_or_delete(
        &self,
        owner: Option<&str>,
        id: &str,
    ) -> Result<DeleteOutcome, StoreError> {
        let Some(job) = self.get(owner, id).await? else {
            return Ok(DeleteOutcome::NotFound);
        };
        if job.status.is_terminal() {
            let (store, blobs) = (self.store.clone(), self.blobs.clone());
            let id = job.id.clone();
            blocking(move || {
                // Blobs first: a crash in between leaves a terminal row (swept later), never
                // files that no row names.
                blobs.delete_prefix(&job_prefix(&id)?)?;
                store.delete(&id).map(|_| ())
            })
            .await?;
            self.changed();
            return Ok(DeleteOutcome::Deleted);
        }
        let store = self.store.clone();
        let id_owned = job.id.clone();
        let expires = now_ms().saturating_add(self.config.retention.as_millis() as i64);
        let after = blocking(move || store.cancel(&id_owned, now_ms(), expires)).await?;
        if let Some(flag) = self
            .running
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .get(&job.id)
        {
            flag.store(true, Ordering::Relaxed);
        }
        self.changed();
        match after {
            Some(j) => {
                if j.status == JobStatus::Cancelled && job.status == JobStatus::Queued {
                    self.metrics.job_finished(JobStatus::Cancelled, None);
                    let blobs = self.blobs.clone();
                    let id = j.id.clone();
                    // The input of a job that will never run.
                    let _ =
                        blocking(move || blobs.delete_prefix(&key(format!("jobs/{id}/input"))?))
                            .await;
                }
                Ok(DeleteOutcome::Cancelled(Box::new(j)))
            }
            None => Ok(DeleteOutcome::NotFound),
        }
    }

    /// The bytes of a succeeded job's artifact.
    pub async fn artifact(
        &self,
        owner: Option<&str>,
        id: &str,
        which: Artifact,
    ) -> Result<ArtifactOutcome, StoreError> {
        let Some(job) = self.get(owner, id).await? else {
            return Ok(ArtifactOutcome::NotFound);
        };
        let Some(manifest) = job
            .result_json
            .as_deref()
            .filter(|_| job.status == JobStatus::Succeeded)
            .and_then(|t| serde_json::from_str::<ResultManifest>(t).ok())
        else {
            return Ok(ArtifactOutcome::NotReady(Box::new(job)));
        };
        let k = key(match which {
            Artifact::ResultGlb => manifest.glb,
            Artifact::ResultGltf => manifest.gltf,
            Artifact::Report => manifest.report,
            Artifact::Preview => manifest.preview,
        })?;
        let blobs = self.blobs.clone();
        match blocking(move || blobs.get(&k)).await? {
            Some(bytes) => Ok(ArtifactOutcome::Bytes(bytes)),
            None => Ok(ArtifactOutcome::NotFound),
        }
    }

    /// Jobs per status ([`JobStatus::ALL`] order).
    pub async fn counts(&self) -> Result<[u64; 5], StoreError> {
        let store = self.store.clone();
        blocking(move || store.counts()).await
    }

    /// The store answers (`/readyz`).
    pub async fn ready(&self) -> Result<(), StoreError> {
        let store = self.store.clone();
        blocking(move || store.ping()).await
    }

    /// Loads a claimed job's input from the blobs.
    pub(crate) fn load_input(&self, job: &JobRecord) -> Result<JobInput, String> {
        let manifest: InputManifest = serde_json::from_str(&job.input_json)
            .map_err(|e| format!("the job's input manifest is unreadable: {e}"))?;
        let get = |k: &str| -> Result<Vec<u8>, String> {
            let k = BlobKey::new(k).map_err(|e| e.to_string())?;
            self.blobs
                .get(&k)
                .map_err(|e| e.to_string())?
                .ok_or_else(|| format!("the input blob {} is missing", k.as_str()))
        };
        let asset = get(&manifest.asset)?;
        let mut resources = Resources::new();
        for (uri, k) in &manifest.resources {
            resources.insert(uri.clone(), get(k)?);
        }
        Ok(JobInput { asset, resources })
    }
}

fn replay_or_reused(existing: JobRecord, body_hash: &str) -> Result<Submitted, SubmitError> {
    if existing.body_hash == body_hash {
        Ok(Submitted {
            job: existing,
            replayed: true,
        })
    } else {
        Err(SubmitError::IdempotencyKeyReused {
            job_id: existing.id,
        })
    }
}
