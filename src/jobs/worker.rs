//! [`WorkerPool`]: the workers, their heartbeats, the sweeper, and graceful shutdown.
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use tokio::sync::watch;
use tokio::task::JoinHandle;
use tracing::Instrument as _;

use super::metrics::Metrics;
use super::now_ms;
use super::processor::{JobFailure, JobOutput, Processor};
use super::progress::{Bridge, SharedSnapshot};
use super::service::{blocking, job_prefix, JobService, ResultManifest};
use crate::api::{OptionsJson, ProblemCode};
use crate::storage::{BlobKey, Finish, JobRecord, JobStatus, StoreError};

/// The workers and the sweeper of one process.
pub struct WorkerPool {
    /// `true`: workers claim no more jobs, the sweeper stops.
    stop: watch::Sender<bool>,
    /// `true`: running jobs are stopped at their next checkpoint and given back to the queue.
    abort: watch::Sender<bool>,
    /// One per worker.
    workers: Vec<JoinHandle<()>>,
    /// The sweeper.
    sweeper: JoinHandle<()>,
}

impl std::fmt::Debug for WorkerPool {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WorkerPool")
            .field("workers", &self.workers.len())
            .finish_non_exhaustive()
    }
}

/// The body of a failed job whose attempts ran out (its worker kept dying).
fn exhausted_error() -> String {
    let failure = JobFailure::internal(
        ProblemCode::AttemptsExhausted,
        "the job's worker stopped (crash or restart) on every attempt; the job was not retried \
         again. Submit it again; if it keeps failing, report the asset",
    );
    serde_json::to_string(&failure.problem()).unwrap_or_default()
}

impl WorkerPool {
    /// Returns expired leases to the queue (crash recovery), then starts
    /// [`super::JobsConfig::workers`] workers and the sweeper. `instance` names this process
    /// in the `worker` column (`{instance}-{n}`) and must be unique per process start.
    pub async fn start(
        service: Arc<JobService>,
        processor: Arc<dyn Processor>,
        instance: &str,
    ) -> Result<WorkerPool, StoreError> {
        sweep_leases(&service).await?;
        let (stop, _) = watch::channel(false);
        let (abort, _) = watch::channel(false);
        let workers = (0..service.config.workers.max(1))
            .map(|n| {
                let worker = Worker {
                    service: service.clone(),
                    processor: processor.clone(),
                    id: format!("{instance}-{n}"),
                    stop: stop.subscribe(),
                    abort: abort.subscribe(),
                };
                tokio::spawn(worker.run())
            })
            .collect();
        let sweeper = tokio::spawn(sweeper(service, stop.subscribe()));
        Ok(WorkerPool {
            stop,
            abort,
            workers,
            sweeper,
        })
    }

    /// Stops claiming; lets running jobs finish for up to `grace`, then stops them at their next
    /// checkpoint and gives them back to the queue (not counted as an attempt).
    pub async fn shutdown(self, grace: Duration) {
        let _ = self.stop.send(true);
        let mut all = futures_util::future::join_all(self.workers);
        if tokio::time::timeout(grace, &mut all).await.is_err() {
            tracing::info!(
                grace_s = grace.as_secs_f64(),
                "grace period over: re-queueing running jobs"
            );
            let _ = self.abort.send(true);
            // A processor that never reaches a checkpoint is abandoned; its lease expires.
            let _ = tokio::time::timeout(Duration::from_secs(10), all).await;
        }
        let _ = self.sweeper.await;
    }
}

/// Resolves once the flag is `true` (or its sender is gone).
async fn until_true(rx: &mut watch::Receiver<bool>) {
    let _ = rx.wait_for(|v| *v).await;
}

/// Expired leases back to the queue, or failed after `max_attempts`.
async fn sweep_leases(service: &Arc<JobService>) -> Result<(), StoreError> {
    let store = service.store.clone();
    let max = service.config.max_attempts;
    let expires = now_ms().saturating_add(service.config.retention.as_millis() as i64);
    let r =
        blocking(move || store.requeue_expired(now_ms(), max, &exhausted_error(), expires)).await?;
    if r.requeued > 0 || r.failed > 0 {
        tracing::warn!(
            requeued = r.requeued,
            failed = r.failed,
            "expired leases recovered"
        );
        for _ in 0..r.failed {
            service.metrics.job_finished(JobStatus::Failed, None);
        }
        service.work.notify_one();
        service.changed();
    }
    Ok(())
}

/// Deletes up to 100 expired jobs and their blobs.
async fn sweep_retention(service: &Arc<JobService>) -> Result<(), StoreError> {
    let (store, blobs) = (service.store.clone(), service.blobs.clone());
    let n = blocking(move || {
        let expired = store.expired(now_ms(), 100)?;
        for job in &expired {
            // Blobs first: a crash in between leaves a row that the next sweep deletes,
            // never files that no row names.
            blobs.delete_prefix(&job_prefix(&job.id)?)?;
            store.delete(&job.id)?;
        }
        Ok(expired.len())
    })
    .await?;
    if n > 0 {
        tracing::info!(deleted = n, "expired jobs swept");
        service.changed();
    }
    Ok(())
}

async fn sweeper(service: Arc<JobService>, mut stop: watch::Receiver<bool>) {
    loop {
        tokio::select! {
            _ = tokio::time::sleep(service.config.sweep_interval) => {}
            _ = until_true(&mut stop) => return,
        }
        if let Err(e) = sweep_leases(&service).await {
            tracing::error!(error = %e, "lease sweep failed");
        }
        if let Err(e) = sweep_retention(&service).await {
            tracing::error!(error = %e, "retention sweep failed");
        }
    }
}

struct Worker {
    service: Arc<JobService>,
    processor: Arc<dyn Processor>,
    id: String,
    stop: watch::Receiver<bool>,
    abort: watch::Receiver<bool>,
}

/// How an attempt ended.
enum Outcome {
    /// The processor returned.
    Done(Result<JobOutput, JobFailure>),
    /// Over the time limit.
    TimedOut(Duration),
    /// Shutdown after the grace period.
    Aborted,
}

impl Worker {
    async fn run(mut self) {
        loop {
            if *self.stop.borrow() {
                return;
            }
            let store = self.service.store.clone();
            let (id, lease_ms) = (
                self.id.clone(),
                self.service.config.lease.as_millis() as i64,
            );
            match blocking(move || store.claim(&id, now_ms(), lease_ms)).await {
                Ok(Some(job)) => {
                    // Another job may be waiting for another idle worker.
                    self.service.work.notify_one();
                    self.run_job(job).await;
                }
                Ok(None) => {
                    let mut stop = self.stop.clone();
                    tokio::select! {
                        _ = self.service.work.notified() => {}
                        _ = tokio::time::sleep(Duration::from_secs(1)) => {}
                        _ = until_true(&mut stop) => {}
                    }
                }
                Err(e) => {
                    tracing::error!(error = %e, worker = %self.id, "claim failed");
                    tokio::time::sleep(Duration::from_secs(1)).await;
                }
            }
        }
    }

    async fn run_job(&mut self, job: JobRecord) {
        let span = tracing::info_span!("job", job_id = %job.id, attempt = job.attempts);
        self.run_job_in_span(job).instrument(span).await;
    }

    async fn run_job_in_span(&mut self, job: JobRecord) {
        let svc = self.service.clone();
        tracing::info!(triangles = job.triangles, worker = %self.id, "job started");
        let started = Instant::now();
        let cancel = Arc::new(AtomicBool::new(job.cancel_requested));
        svc.running
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .insert(job.id.clone(), cancel.clone());
        svc.changed();
        let snapshot = SharedSnapshot::default();
        let lost = Arc::new(AtomicBool::new(false));
        let heartbeat = tokio::spawn(
            heartbeat(
                svc.clone(),
                job.id.clone(),
                self.id.clone(),
                snapshot.clone(),
                cancel.clone(),
                lost.clone(),
            )
            .in_current_span(),
        );

        let outcome = self.execute(&job, cancel.clone(), snapshot).await;
        heartbeat.abort();
        let _ = heartbeat.await;
        let elapsed = started.elapsed().as_secs_f64();
        let end = if lost.load(Ordering::Relaxed) {
            tracing::warn!("lease lost while running; another attempt owns the job");
            None
        } else {
            match self
                .conclude(&job, outcome, cancel.load(Ordering::Relaxed))
                .await
            {
                Ok(end) => end,
                Err(e) => {
                    tracing::error!(error = %e, "recording the job's end failed; its lease will expire and it will be retried");
                    None
                }
            }
        };
        if let Some(status) = end {
            svc.metrics.job_finished(status, Some(elapsed));
            tracing::info!(status = status.as_str(), seconds = elapsed, "job ended");
        }
        svc.running
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .remove(&job.id);
        svc.changed();
    }

    async fn execute(
        &mut self,
        job: &JobRecord,
        cancel: Arc<AtomicBool>,
        snapshot: SharedSnapshot,
    ) -> Outcome {
        let (svc, processor, job2) = (self.service.clone(), self.processor.clone(), job.clone());
        let flag = cancel.clone();
        let span = tracing::Span::current();
        let mut task = tokio::task::spawn_blocking(move || {
            let _entered = span.enter();
            let input = svc
                .load_input(&job2)
                .map_err(|e| JobFailure::internal(ProblemCode::InputMissing, e))?;
            let options: OptionsJson = serde_json::from_str(&job2.options_json)
                .map_err(|e| JobFailure::internal(ProblemCode::OptionsUnreadable, e.to_string()))?;
            let mut bridge = Bridge {
                cancel: flag,
                snapshot,
            };
            match catch_unwind(AssertUnwindSafe(|| {
                processor.process(&input, &options, &mut bridge)
            })) {
                Ok(result) => result,
                Err(payload) => {
                    let message = payload
                        .downcast_ref::<&str>()
                        .map(|s| s.to_string())
                        .or_else(|| payload.downcast_ref::<String>().cloned())
                        .unwrap_or_else(|| "unknown panic".to_string());
                    Err(JobFailure::internal(
                        ProblemCode::WorkerPanicked,
                        format!("the pipeline panicked: {message}"),
                    ))
                }
            }
        });
        let limit = self.service.config.job_time_limit;
        let time_limit = async {
            match limit {
                Some(d) => tokio::time::sleep(d).await,
                None => std::future::pending().await,
            }
        };
        let mut abort = self.abort.clone();
        tokio::select! {
            r = &mut task => Outcome::Done(r.unwrap_or_else(|e| {
                Err(JobFailure::internal(ProblemCode::WorkerPanicked, format!("the job's task failed: {e}")))
            })),
            _ = time_limit => {
                // The thread stops at its next checkpoint; the worker moves on now.
                cancel.store(true, Ordering::Relaxed);
                Outcome::TimedOut(limit.unwrap_or_default())
            }
            _ = until_true(&mut abort) => {
                cancel.store(true, Ordering::Relaxed);
                let _ = tokio::time::timeout(Duration::from_secs(10), &mut task).await;
                Outcome::Aborted
            }
        }
    }

    /// Records the end of an attempt; the terminal status reached, if any.
    async fn conclude(
        &self,
        job: &JobRecord,
        outcome: Outcome,
        cancel_requested: bool,
    ) -> Result<Option<JobStatus>, StoreError> {
        let svc = &self.service;
        let (store, blobs) = (svc.store.clone(), svc.blobs.clone());
        let (id, worker) = (job.id.clone(), self.id.clone());
        let expires = now_ms().saturating_add(svc.config.retention.as_millis() as i64);
        let failed = |f: JobFailure| Finish::Failed {
            error_json: serde_json::to_string(&f.problem()).unwrap_or_default(),
        };
        let finish = match outcome {
            Outcome::Aborted => {
                let released = blocking(move || store.release(&id, &worker)).await?;
                if released {
                    tracing::info!("job given back to the queue for the next start");
                }
                return Ok(None);
            }
            Outcome::TimedOut(limit) => failed(JobFailure::internal(
                ProblemCode::TimeLimitExceeded,
                format!(
                    "the job ran longer than the per-job limit of {} s; split the asset or ask \
                     the operator to raise --job-time-limit",
                    limit.as_secs()
                ),
            )),
            Outcome::Done(Err(f)) if f.code == ProblemCode::Cancelled && cancel_requested => {
                Finish::Cancelled
            }
            Outcome::Done(Err(f)) => failed(f),
            Outcome::Done(Ok(out)) => {
                let metrics: Arc<Metrics> = svc.metrics.clone();
                let attempt = job.attempts;
                let (id2, worker2) = (id.clone(), worker.clone());
                let (triangles, stages) = (out.triangles, out.stage_seconds);
                let stored = blocking(move || {
                    let prefix = format!("jobs/{id2}/a{attempt}");
                    let put = |name: &str, bytes: &[u8]| -> Result<String, StoreError> {
                        let k = BlobKey::new(format!("{prefix}/{name}"))?;
                        blobs.put(&k, bytes)?;
                        Ok(k.as_str().to_string())
                    };
                    let manifest = ResultManifest {
                        glb: put("result.glb", &out.glb)?,
                        gltf: put("result.gltf", &out.gltf)?,
                        report: put("report.json", &out.report_json)?,
                        preview: put("preview.png", &out.preview_png)?,
                    };
                    let result_json = serde_json::to_string(&manifest)
                        .map_err(|e| StoreError::Database(e.to_string()))?;
                    let done = store.finish(
                        &id2,
                        &worker2,
                        &Finish::Succeeded { result_json },
                        now_ms(),
                        expires,
                    )?;
                    if !done {
                        // Lease lost meanwhile: this attempt's blobs belong to no one.
                        blobs.delete_prefix(&BlobKey::new(prefix)?)?;
                    }
                    Ok(done)
                })
                .await?;
                if stored {
                    metrics.job_succeeded(triangles, &stages);
                    return Ok(Some(JobStatus::Succeeded));
                }
                return Ok(None);
            }
        };
        let status = match finish {
            Finish::Cancelled => JobStatus::Cancelled,
            _ => JobStatus::Failed,
        };
        let done = blocking(move || store.finish(&id, &worker, &finish, now_ms(), expires)).await?;
        Ok(done.then_some(status))
    }
}

/// Flushes progress (at most every `progress_interval`) and renews the lease (every third of
/// it); learns of cancels requested through the store and of a lost lease.
async fn heartbeat(
    svc: Arc<JobService>,
    id: String,
    worker: String,
    snapshot: SharedSnapshot,
    cancel: Arc<AtomicBool>,
    lost: Arc<AtomicBool>,
) {
    let lease = svc.config.lease;
    let mut tick = tokio::time::interval(svc.config.progress_interval);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut written_version = 0u64;
    let mut renewed = Instant::now();
    loop {
        tick.tick().await;
        let snap = *snapshot.lock().unwrap_or_else(|p| p.into_inner());
        let progress_due = snap.version != written_version && snap.stage.is_some();
        if !progress_due && renewed.elapsed() < lease / 3 {
            continue;
        }
        let store = svc.store.clone();
        let (id2, worker2) = (id.clone(), worker.clone());
        let until = now_ms().saturating_add(lease.as_millis() as i64);
        let result = blocking(move || {
            let progress = snap.stage.map(|s| (s.name(), snap.fraction));
            store.heartbeat(&id2, &worker2, until, progress)
        })
        .await;
        match result {
            Ok(Some(cancel_requested)) => {
                renewed = Instant::now();
                if cancel_requested {
                    cancel.store(true, Ordering::Relaxed);
                }
                if progress_due {
                    written_version = snap.version;
                    svc.changed();
                }
            }
            Ok(None) => {
                lost.store(true, Ordering::Relaxed);
                cancel.store(true, Ordering::Relaxed);
                return;
            }
            Err(e) => tracing::warn!(error = %e, "heartbeat failed"),
        }
    }
}
