//! Process metrics for `GET /metrics`, kept in a `prometheus-client` registry and written in
//! the Prometheus text exposition format (version 0.0.4, [`CONTENT_TYPE`]).
//!
//! Series: `texatlas_jobs{state}` and `texatlas_queue_depth` (gauges read from the store at
//! scrape time), `texatlas_stage_duration_seconds{stage}`, `texatlas_job_duration_seconds`,
//! `texatlas_jobs_finished_total{outcome}`, `texatlas_triangles_processed_total`,
//! `texatlas_http_request_duration_seconds{method,route,status}`.
//!
//! Invariant: label values have bounded cardinality: `route` is the matched route template
//! (`/v1/jobs/{id}`, or `unmatched`), never the raw path.
use prometheus_client::encoding::{prometheus_text, EncodeLabelSet};
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::Histogram;
use prometheus_client::registry::Registry;

use crate::atlas::Stage;
use crate::storage::JobStatus;

/// The `Content-Type` of [`Metrics::render`]'s text.
pub const CONTENT_TYPE: &str = prometheus_text::CONTENT_TYPE;

/// Upper bounds of the HTTP latency buckets, seconds.
const HTTP_BUCKETS_S: &[f64] = &[
    0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 10.0,
];
/// Upper bounds of the stage and job duration buckets, seconds.
const WORK_BUCKETS_S: &[f64] = &[
    0.01, 0.05, 0.1, 0.5, 1.0, 5.0, 10.0, 30.0, 60.0, 300.0, 1800.0,
];

#[derive(Debug, Clone, PartialEq, Eq, Hash, EncodeLabelSet)]
struct StateLabel {
    state: &'static str,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash, EncodeLabelSet)]
struct OutcomeLabel {
    outcome: &'static str,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash, EncodeLabelSet)]
struct StageLabel {
    stage: &'static str,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash, EncodeLabelSet)]
struct HttpLabels {
    method: String,
    route: String,
    status: u16,
}

type HistogramFamily<L> = Family<L, Histogram, fn() -> Histogram>;

fn http_histogram() -> Histogram {
    Histogram::new(HTTP_BUCKETS_S.iter().copied())
}

fn work_histogram() -> Histogram {
    Histogram::new(WORK_BUCKETS_S.iter().copied())
}

/// The metrics of one process. The metric handles share their values with the registry.
#[derive(Debug)]
pub struct Metrics {
    registry: Registry,
    jobs: Family<StateLabel, Gauge>,
    queue_depth: Gauge,
    finished: Family<OutcomeLabel, Counter>,
    triangles: Counter,
    stage: HistogramFamily<StageLabel>,
    job: Histogram,
    http: HistogramFamily<HttpLabels>,
}

impl Default for Metrics {
    fn default() -> Self {
        let m = Metrics {
            registry: Registry::default(),
            jobs: Family::default(),
            queue_depth: Gauge::default(),
            finished: Family::default(),
            triangles: Counter::default(),
            stage: Family::new_with_constructor(work_histogram),
            job: work_histogram(),
            http: Family::new_with_constructor(http_histogram),
        };
        // Series that exist from the start (0 until something happens), as a dashboard expects.
        for s in [
            JobStatus::Succeeded,
            JobStatus::Failed,
            JobStatus::Cancelled,
        ] {
            drop(m.finished.get_or_create(&OutcomeLabel {
                outcome: s.as_str(),
            }));
        }
        for stage in Stage::ALL {
            drop(m.stage.get_or_create(&StageLabel {
                stage: stage.name(),
            }));
        }
        let mut m = m;
        // The help texts get a final `.` from the encoder.
        let r = &mut m.registry;
        r.register(
            "texatlas_jobs",
            "Jobs in the store by state",
            m.jobs.clone(),
        );
        r.register(
            "texatlas_queue_depth",
            "Jobs waiting for a worker",
            m.queue_depth.clone(),
        );
        r.register(
            "texatlas_jobs_finished",
            "Jobs that reached a terminal state in this process",
            m.finished.clone(),
        );
        r.register(
            "texatlas_triangles_processed",
            "Triangles of succeeded jobs",
            m.triangles.clone(),
        );
        r.register(
            "texatlas_stage_duration_seconds",
            "Wall-clock time per pipeline stage",
            m.stage.clone(),
        );
        r.register(
            "texatlas_job_duration_seconds",
            "Wall-clock time of a job's last attempt",
            m.job.clone(),
        );
        r.register(
            "texatlas_http_request_duration_seconds",
            "HTTP latency by route and status",
            m.http.clone(),
        );
        m
    }
}

impl Metrics {
    /// One HTTP request: `route` is the matched route template (bounded cardinality).
    pub fn observe_http(&self, method: &str, route: &str, status: u16, seconds: f64) {
        self.http
            .get_or_create(&HttpLabels {
                method: method.to_string(),
                route: route.to_string(),
                status,
            })
            .observe(seconds);
    }

    /// A job reached a terminal state (`outcome` = its status name).
    pub(crate) fn job_finished(&self, outcome: JobStatus, seconds: Option<f64>) {
        self.finished
            .get_or_create(&OutcomeLabel {
                outcome: outcome.as_str(),
            })
            .inc();
        if let Some(s) = seconds {
            self.job.observe(s);
        }
    }

    /// A job succeeded with these stage durations and triangles.
    pub(crate) fn job_succeeded(&self, triangles: u64, stage_seconds: &[f64; 4]) {
        self.triangles.inc_by(triangles);
        for (stage, s) in Stage::ALL.iter().zip(stage_seconds) {
            self.stage
                .get_or_create(&StageLabel {
                    stage: stage.name(),
                })
                .observe(*s);
        }
    }

    /// The exposition text ([`CONTENT_TYPE`]); `counts` are the jobs per status
    /// ([`JobStatus::ALL`] order).
    pub fn render(&self, counts: &[u64; 5]) -> String {
        let gauge = |n: u64| i64::try_from(n).unwrap_or(i64::MAX);
        for (s, n) in JobStatus::ALL.iter().zip(counts) {
            self.jobs
                .get_or_create(&StateLabel { state: s.as_str() })
                .set(gauge(*n));
        }
        self.queue_depth.set(gauge(counts[0]));
        let mut out = String::new();
        // Writing into a String cannot fail.
        let _ = prometheus_text::encode(&mut out, &self.registry);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_counts_histograms_and_labels() {
        let m = Metrics::default();
        m.observe_http("GET", "/v1/jobs/{id}", 200, 0.002);
        m.observe_http("GET", "/v1/jobs/{id}", 200, 0.02);
        m.job_succeeded(12, &[0.1, 0.2, 0.3, 0.4]);
        m.job_finished(JobStatus::Succeeded, Some(1.0));
        let text = m.render(&[3, 1, 2, 0, 0]);
        for line in [
            "texatlas_jobs{state=\"queued\"} 3",
            "texatlas_jobs{state=\"cancelled\"} 0",
            "texatlas_queue_depth 3",
            "texatlas_triangles_processed_total 12",
            "texatlas_jobs_finished_total{outcome=\"succeeded\"} 1",
            "texatlas_jobs_finished_total{outcome=\"failed\"} 0",
            "texatlas_stage_duration_seconds_count{stage=\"pack\"} 1",
            "texatlas_stage_duration_seconds_bucket{stage=\"pack\",le=\"0.5\"} 1",
            "texatlas_stage_duration_seconds_bucket{stage=\"pack\",le=\"0.1\"} 0",
            "texatlas_http_request_duration_seconds_bucket{method=\"GET\",route=\"/v1/jobs/{id}\",status=\"200\",le=\"0.0005\"} 0",
            "texatlas_http_request_duration_seconds_bucket{method=\"GET\",route=\"/v1/jobs/{id}\",status=\"200\",le=\"0.0025\"} 1",
            "texatlas_http_request_duration_seconds_bucket{method=\"GET\",route=\"/v1/jobs/{id}\",status=\"200\",le=\"+Inf\"} 2",
            "texatlas_http_request_duration_seconds_count{method=\"GET\",route=\"/v1/jobs/{id}\",status=\"200\"} 2",
            "texatlas_job_duration_seconds_count 1",
            "texatlas_job_duration_seconds_bucket{le=\"1800\"} 1",
            // Names, types and help as before the registry (the exposition is the contract).
            "# HELP texatlas_jobs Jobs in the store by state.",
            "# TYPE texatlas_jobs gauge",
            "# TYPE texatlas_queue_depth gauge",
            "# HELP texatlas_jobs_finished_total Jobs that reached a terminal state in this process.",
            "# TYPE texatlas_jobs_finished_total counter",
            "# TYPE texatlas_triangles_processed_total counter",
            "# HELP texatlas_stage_duration_seconds Wall-clock time per pipeline stage.",
            "# TYPE texatlas_stage_duration_seconds histogram",
            "# TYPE texatlas_job_duration_seconds histogram",
            "# HELP texatlas_http_request_duration_seconds HTTP latency by route and status.",
            "# TYPE texatlas_http_request_duration_seconds histogram",
        ] {
            assert!(text.lines().any(|l| l == line), "missing `{line}` in\n{text}");
        }
        // The sum is the sum of the observations.
        let sum = text
            .lines()
            .find_map(|l| l.strip_prefix("texatlas_http_request_duration_seconds_sum{method=\"GET\",route=\"/v1/jobs/{id}\",status=\"200\"} "))
            .expect("http sum");
        assert!((sum.parse::<f64>().unwrap() - 0.022).abs() < 1e-12, "{sum}");
    }

    #[test]
    fn label_values_are_escaped() {
        let m = Metrics::default();
        m.observe_http("GET", "a\"b\\c", 404, 0.1);
        let text = m.render(&[0; 5]);
        assert!(text.contains(r#"route="a\"b\\c",status="404""#), "{text}");
    }
}
