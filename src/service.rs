//! The composition root of `texatlas serve`: builds the SQLite job store and the file blob store
//! under the data dir, the [`JobService`], the [`WorkerPool`] and the router, and serves on a
//! listener it is handed until a shutdown future resolves, so tests run it on port 0.
//!
//! Data dir layout: `jobs.sqlite` (+ `-wal`, `-shm`), `blobs/` (inputs and results),
//! `spool/` (uploads in flight; emptied at start).
//!
//! Shutdown: stop accepting connections and refuse new jobs (503), let in-flight requests end
//! (event streams close), stop claiming, let running jobs finish within the grace period, then
//! stop them at their next checkpoint and give them back to the queue.
use std::future::Future;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context as _;
use tokio::net::TcpListener;
use tokio::sync::watch;

use crate::http::{self, HttpConfig};
use crate::jobs::{JobService, JobsConfig, Processor, UnwrapProcessor, WorkerPool};
use crate::storage::fs::FsBlobStore;
use crate::storage::sqlite::SqliteJobStore;

/// Everything `serve` needs.
#[derive(Debug, Clone)]
pub struct ServiceConfig {
    /// Where state is kept. Default `./texatlas-data`.
    pub data_dir: PathBuf,
    /// Queue and workers.
    pub jobs: JobsConfig,
    /// The HTTP layer.
    pub http: HttpConfig,
    /// How long running jobs may go on after a shutdown signal. Default 30 s.
    pub shutdown_grace: Duration,
}

impl Default for ServiceConfig {
    fn default() -> Self {
        ServiceConfig {
            data_dir: PathBuf::from("texatlas-data"),
            jobs: JobsConfig::default(),
            http: HttpConfig::default(),
            shutdown_grace: Duration::from_secs(30),
        }
    }
}

/// The production processor for `config` (the triangle limit applies in the worker too).
pub fn default_processor(config: &ServiceConfig) -> Arc<dyn Processor> {
    Arc::new(UnwrapProcessor {
        limits: config.jobs.decode_limits.clone(),
    })
}

/// Serves until `shutdown` resolves, then shuts down gracefully (module doc).
pub async fn serve(
    listener: TcpListener,
    config: ServiceConfig,
    processor: Arc<dyn Processor>,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> anyhow::Result<()> {
    std::fs::create_dir_all(&config.data_dir)
        .with_context(|| format!("creating the data dir {}", config.data_dir.display()))?;
    let store = SqliteJobStore::open(config.data_dir.join("jobs.sqlite"))
        .context("opening the job database")?;
    let blobs =
        FsBlobStore::open(config.data_dir.join("blobs")).context("opening the blob store")?;
    let jobs = JobService::new(
        Arc::new(store),
        Arc::new(blobs),
        config.jobs.clone(),
        config.data_dir.join("spool"),
    )
    .context("preparing the spool dir")?;
    let instance = uuid::Uuid::now_v7().simple().to_string();
    let pool = WorkerPool::start(jobs.clone(), processor, &instance)
        .await
        .context("recovering expired leases")?;
    let (stop_tx, stop_rx) = watch::channel(false);
    let app = http::router(jobs, config.http.clone(), stop_rx);
    let signal_tx = stop_tx.clone();
    let graceful = async move {
        shutdown.await;
        tracing::info!("shutdown: no new connections or jobs");
        let _ = signal_tx.send(true);
    };
    let served = http::serve(listener, app, graceful).await;
    let _ = stop_tx.send(true);
    pool.shutdown(config.shutdown_grace).await;
    tracing::info!("shutdown complete");
    served.context("serving HTTP")
}
