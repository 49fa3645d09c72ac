//! `texatlas serve`: the HTTP service (texatlas::service), configured by flags, each with a
//! `TEXATLAS_*` environment twin. Prints `texatlas listening on http://ADDR` on stdout once the
//! socket is bound (the real port with `--bind 127.0.0.1:0`), then logs to stderr (JSON with
//! `TEXATLAS_LOG_FORMAT=json`, level from `RUST_LOG`, default `info`).
use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context as _;
use texatlas::gltf_io::DecodeLimits;
use texatlas::http::HttpConfig;
use texatlas::jobs::JobsConfig;
use texatlas::service::{self, ServiceConfig};

#[derive(Debug, clap::Args)]
pub struct ServeArgs {
    /// Address to listen on (port 0: any free port, printed on stdout).
    #[arg(long, env = "TEXATLAS_BIND", default_value = "127.0.0.1:8080")]
    pub bind: String,
    /// Where the job database and blobs are kept.
    #[arg(long, env = "TEXATLAS_DATA_DIR", default_value = "texatlas-data")]
    pub data_dir: PathBuf,
    /// Jobs run at once. Default: the CPU count.
    #[arg(long, env = "TEXATLAS_WORKERS")]
    pub workers: Option<usize>,
    /// Comma-separated API keys; when set, every /v1 call needs `Authorization: Bearer <key>`.
    #[arg(
        long,
        env = "TEXATLAS_API_KEYS",
        value_delimiter = ',',
        hide_env_values = true
    )]
    pub api_keys: Vec<String>,
    /// Largest upload (all parts together), bytes.
    #[arg(long, env = "TEXATLAS_MAX_UPLOAD_BYTES", default_value_t = 256 << 20)]
    pub max_upload_bytes: u64,
    /// Longest wait for the next bytes of an upload, seconds; a stalled upload gets 408.
    #[arg(long, env = "TEXATLAS_UPLOAD_IDLE_TIMEOUT_S", default_value_t = 60, value_parser = clap::value_parser!(u64).range(1..))]
    pub upload_idle_timeout_s: u64,
    /// Most triangles per asset.
    #[arg(long, env = "TEXATLAS_MAX_TRIANGLES", default_value_t = 1 << 24)]
    pub max_triangles: u64,
    /// Wall-clock limit of one job attempt, seconds (0 is refused; omit the flag for the
    /// default of 600).
    #[arg(long, env = "TEXATLAS_JOB_TIME_LIMIT_S", default_value_t = 600, value_parser = clap::value_parser!(u64).range(1..))]
    pub job_time_limit_s: u64,
    /// Most jobs queued or running; past it submissions get 503 with Retry-After.
    #[arg(long, env = "TEXATLAS_QUEUE_CAPACITY", default_value_t = 1000, value_parser = clap::value_parser!(u64).range(1..))]
    pub queue_capacity: u64,
    /// Finished jobs and their results are deleted this many seconds after they end.
    #[arg(long, env = "TEXATLAS_RETENTION_S", default_value_t = 86_400)]
    pub retention_s: u64,
    /// Lease of a running job, seconds: a crashed server's jobs are re-queued this long after
    /// its last heartbeat.
    #[arg(long, env = "TEXATLAS_LEASE_S", default_value_t = 15, value_parser = clap::value_parser!(u64).range(1..))]
    pub lease_s: u64,
    /// Claims of one job before it is failed instead of re-queued after crashes.
    #[arg(long, env = "TEXATLAS_MAX_ATTEMPTS", default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    pub max_attempts: u32,
    /// Seconds running jobs may go on after SIGTERM/SIGINT before they are re-queued.
    #[arg(long, env = "TEXATLAS_SHUTDOWN_GRACE_S", default_value_t = 30)]
    pub shutdown_grace_s: u64,
    /// Comma-separated origins allowed by CORS (`*` for any). Default: none.
    #[arg(long, env = "TEXATLAS_CORS_ORIGINS", value_delimiter = ',')]
    pub cors_origins: Vec<String>,
}

impl ServeArgs {
    fn config(&self) -> ServiceConfig {
        let defaults = JobsConfig::default();
        ServiceConfig {
            data_dir: self.data_dir.clone(),
            jobs: JobsConfig {
                workers: self.workers.unwrap_or(defaults.workers).max(1),
                lease: Duration::from_secs(self.lease_s),
                job_time_limit: Some(Duration::from_secs(self.job_time_limit_s)),
                queue_capacity: Some(self.queue_capacity),
                retention: Duration::from_secs(self.retention_s),
                max_attempts: self.max_attempts,
                decode_limits: DecodeLimits {
                    max_triangles: Some(self.max_triangles),
                    ..DecodeLimits::default()
                },
                ..defaults
            },
            http: HttpConfig {
                api_keys: self.api_keys.clone(),
                max_upload_bytes: self.max_upload_bytes,
                upload_idle_timeout: Duration::from_secs(self.upload_idle_timeout_s),
                cors_origins: self.cors_origins.clone(),
            },
            shutdown_grace: Duration::from_secs(self.shutdown_grace_s),
        }
    }
}

fn init_tracing() {
    use tracing_subscriber::EnvFilter;
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("info"));
    let json = std::env::var("TEXATLAS_LOG_FORMAT").is_ok_and(|v| v.eq_ignore_ascii_case("json"));
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_writer(std::io::stderr);
    if json {
        builder
            .json()
            .with_current_span(true)
            .with_span_list(true)
            .init();
    } else {
        builder.init();
    }
}

/// SIGTERM or SIGINT.
async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {}
        _ = term => {}
    }
}

pub fn run(args: &ServeArgs) -> anyhow::Result<ExitCode> {
    init_tracing();
    let config = args.config();
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    runtime.block_on(async {
        let listener = tokio::net::TcpListener::bind(&args.bind)
            .await
            .with_context(|| format!("binding {}", args.bind))?;
        let addr = listener.local_addr().context("reading the bound address")?;
        let mut out = std::io::stdout();
        writeln!(out, "texatlas listening on http://{addr}")?;
        out.flush()?;
        tracing::info!(%addr, data_dir = %config.data_dir.display(), workers = config.jobs.workers, "serving");
        let processor = service::default_processor(&config);
        service::serve(listener, config, processor, shutdown_signal()).await
    })?;
    Ok(ExitCode::SUCCESS)
}
