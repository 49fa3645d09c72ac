//! Process metrics in the Prometheus text exposition format (version 0.0.4), kept by hand:
//! a few counters and fixed-bucket histograms behind one mutex, so no exporter crate (and its
//! TLS stack) is needed.
//!
//! Series: `texatlas_jobs{state}` and `texatlas_queue_depth` (gauges read from the store at
//! scrape time), `texatlas_stage_duration_seconds{stage}`, `texatlas_job_duration_seconds`,
//! `texatlas_jobs_finished_total{outcome}`, `texatlas_triangles_processed_total`,
//! `texatlas_http_request_duration_seconds{method,route,status}`.
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::sync::Mutex;

use crate::atlas::Stage;
use crate::storage::JobStatus;

/// Upper bounds of the HTTP latency buckets, seconds.
const HTTP_BUCKETS_S: &[f64] = &[
    0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 10.0,
];
/// Upper bounds of the stage and job duration buckets, seconds.
const WORK_BUCKETS_S: &[f64] = &[
    0.01, 0.05, 0.1, 0.5, 1.0, 5.0, 10.0, 30.0, 60.0, 300.0, 1800.0,
];

#[derive(Debug, Clone, Default)]
struct Histogram {
    counts: Vec<u64>,
    sum: f64,
    count: u64,
}

impl Histogram {
    fn observe(&mut self, buckets: &[f64], v: f64) {
        if self.counts.is_empty() {
            self.counts = vec![0; buckets.len()];
        }
        for (i, b) in buckets.iter().enumerate() {
            if v <= *b {
                self.counts[i] += 1;
            }
        }
        self.sum += v;
        self.count += 1;
    }

    fn render(&self, out: &mut String, name: &str, labels: &str, buckets: &[f64]) {
        let sep = if labels.is_empty() { "" } else { "," };
        for (i, b) in buckets.iter().enumerate() {
            let c = self.counts.get(i).copied().unwrap_or(0);
            let _ = writeln!(out, "{name}_bucket{{{labels}{sep}le=\"{b}\"}} {c}");
        }
        let _ = writeln!(
            out,
            "{name}_bucket{{{labels}{sep}le=\"+Inf\"}} {}",
            self.count
        );
        let braces = if labels.is_empty() {
            String::new()
        } else {
            format!("{{{labels}}}")
        };
        let _ = writeln!(out, "{name}_sum{braces} {}", self.sum);
        let _ = writeln!(out, "{name}_count{braces} {}", self.count);
    }
}

#[derive(Debug, Default)]
struct Inner {
    stage: BTreeMap<&'static str, Histogram>,
    job: Histogram,
    finished: BTreeMap<&'static str, u64>,
    triangles: u64,
    http: BTreeMap<(String, String, u16), Histogram>,
}

/// The metrics of one process.
#[derive(Debug, Default)]
pub struct Metrics {
    inner: Mutex<Inner>,
}

fn escape(v: &str) -> String {
    v.replace('\\', "\\\\")
        .replace('"', "\\\"")
        .replace('\n', "\\n")
}

impl Metrics {
    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// One HTTP request: `route` is the matched route template (bounded cardinality).
    pub fn observe_http(&self, method: &str, route: &str, status: u16, seconds: f64) {
        self.lock()
            .http
            .entry((method.to_string(), route.to_string(), status))
            .or_default()
            .observe(HTTP_BUCKETS_S, seconds);
    }

    /// A job reached a terminal state (`outcome` = its status name).
    pub(crate) fn job_finished(&self, outcome: JobStatus, seconds: Option<f64>) {
        let mut m = self.lock();
        *m.finished.entry(outcome.as_str()).or_default() += 1;
        if let Some(s) = seconds {
            m.job.observe(WORK_BUCKETS_S, s);
        }
    }

    /// A job succeeded with these stage durations and triangles.
    pub(crate) fn job_succeeded(&self, triangles: u64, stage_seconds: &[f64; 4]) {
        let mut m = self.lock();
        m.triangles += triangles;
        for (stage, s) in Stage::ALL.iter().zip(stage_seconds) {
            m.stage
                .entry(stage.name())
                .or_default()
                .observe(WORK_BUCKETS_S, *s);
        }
    }

    /// The exposition text; `counts` are the jobs per status ([`JobStatus::ALL`] order).
    pub fn render(&self, counts: &[u64; 5]) -> String {
        let m = self.lock();
        let mut out = String::new();
        out.push_str(
            "# HELP texatlas_jobs Jobs in the store by state.\n# TYPE texatlas_jobs gauge\n",
        );
        for (s, n) in JobStatus::ALL.iter().zip(counts) {
            let _ = writeln!(out, "texatlas_jobs{{state=\"{}\"}} {n}", s.as_str());
        }
        out.push_str("# HELP texatlas_queue_depth Jobs waiting for a worker.\n# TYPE texatlas_queue_depth gauge\n");
        let _ = writeln!(out, "texatlas_queue_depth {}", counts[0]);
        out.push_str("# HELP texatlas_jobs_finished_total Jobs that reached a terminal state in this process.\n# TYPE texatlas_jobs_finished_total counter\n");
        for s in [
            JobStatus::Succeeded,
            JobStatus::Failed,
            JobStatus::Cancelled,
        ] {
            let n = m.finished.get(s.as_str()).copied().unwrap_or(0);
            let _ = writeln!(
                out,
                "texatlas_jobs_finished_total{{outcome=\"{}\"}} {n}",
                s.as_str()
            );
        }
        out.push_str("# HELP texatlas_triangles_processed_total Triangles of succeeded jobs.\n# TYPE texatlas_triangles_processed_total counter\n");
        let _ = writeln!(out, "texatlas_triangles_processed_total {}", m.triangles);
        out.push_str("# HELP texatlas_stage_duration_seconds Wall-clock time per pipeline stage.\n# TYPE texatlas_stage_duration_seconds histogram\n");
        for stage in Stage::ALL {
            let h = m.stage.get(stage.name()).cloned().unwrap_or_default();
            let labels = format!("stage=\"{}\"", stage.name());
            h.render(
                &mut out,
                "texatlas_stage_duration_seconds",
                &labels,
                WORK_BUCKETS_S,
            );
        }
        out.push_str("# HELP texatlas_job_duration_seconds Wall-clock time of a job's last attempt.\n# TYPE texatlas_job_duration_seconds histogram\n");
        m.job.render(
            &mut out,
            "texatlas_job_duration_seconds",
            "",
            WORK_BUCKETS_S,
        );
        out.push_str("# HELP texatlas_http_request_duration_seconds HTTP latency by route and status.\n# TYPE texatlas_http_request_duration_seconds histogram\n");
        for ((method, route, status), h) in &m.http {
            let labels = format!(
                "method=\"{}\",route=\"{}\",status=\"{status}\"",
                escape(method),
                escape(route)
            );
            h.render(
                &mut out,
                "texatlas_http_request_duration_seconds",
                &labels,
                HTTP_BUCKETS_S,
            );
        }
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
            "texatlas_queue_depth 3",
            "texatlas_triangles_processed_total 12",
            "texatlas_jobs_finished_total{outcome=\"succeeded\"} 1",
            "texatlas_stage_duration_seconds_count{stage=\"pack\"} 1",
            "texatlas_http_request_duration_seconds_bucket{method=\"GET\",route=\"/v1/jobs/{id}\",status=\"200\",le=\"0.0025\"} 1",
            "texatlas_http_request_duration_seconds_bucket{method=\"GET\",route=\"/v1/jobs/{id}\",status=\"200\",le=\"+Inf\"} 2",
            "texatlas_job_duration_seconds_count 1",
        ] {
            assert!(text.lines().any(|l| l == line), "missing `{line}` in\n{text}");
        }
    }
}
