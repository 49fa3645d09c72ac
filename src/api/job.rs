//! The wire types of the HTTP service ↔ `components/schemas` of `proto/openapi.json`:
//! a job ([`JobJson`]), a page of jobs ([`JobListJson`]), a problem ([`ApiProblemJson`], RFC 9457
//! `application/problem+json`) with its defects ([`AssetDefectJson`]).
//!
//! Times on the wire are RFC 3339 UTC strings with milliseconds (`2025-01-31T12:00:00.123Z`).
use serde::{Deserialize, Serialize};

use super::ProblemCode;
use crate::gltf_io::GltfError;

/// One job, as `GET /v1/jobs/{id}` returns it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JobJson {
    /// The job id.
    pub id: String,
    /// `queued`, `running`, `succeeded`, `failed` or `cancelled`.
    pub status: String,
    /// Where a running job is (also kept after it ends, for the record).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub progress: Option<ProgressJson>,
    /// A cancel was requested while the job was running; it stops at the next checkpoint.
    pub cancel_requested: bool,
    /// Claims by a worker so far (more than 1 after a crash or restart).
    pub attempts: u32,
    /// Triangles of the input.
    pub triangles: u64,
    /// The options as submitted (proto/options.schema.json).
    pub options: serde_json::Value,
    /// Accepted at (RFC 3339).
    pub created_at: String,
    /// First started at.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub started_at: Option<String>,
    /// Reached a terminal status at.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub finished_at: Option<String>,
    /// Deleted with its results after this.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub expires_at: Option<String>,
    /// Why a failed job failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<ApiProblemJson>,
    /// Related resources.
    pub links: LinksJson,
}

/// Progress of a running job.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProgressJson {
    /// The stage running: `segment`, `parameterize`, `pack` or `measure` (absent before the
    /// first stage starts).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stage: Option<String>,
    /// Fraction of the whole job done, in \[0, 1\].
    pub fraction: f64,
}

/// Links of a job; the result links appear once it has succeeded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinksJson {
    /// This job.
    #[serde(rename = "self")]
    pub self_: String,
    /// Its Server-Sent Events.
    pub events: String,
    /// The asset with the atlas UVs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub result: Option<String>,
    /// The report (proto/report.schema.json).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub report: Option<String>,
    /// The UV layout as PNG.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preview: Option<String>,
}

/// A page of jobs, newest first.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JobListJson {
    /// The jobs.
    pub jobs: Vec<JobJson>,
    /// Pass as `cursor` to get the next (older) page; absent on the last page.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub next_cursor: Option<String>,
}

/// An `application/problem+json` body (RFC 9457) with texatlas's stable `code`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ApiProblemJson {
    /// A URI naming the problem type: `urn:texatlas:problem:<code>`.
    #[serde(rename = "type")]
    pub type_: String,
    /// Short summary of the problem type.
    pub title: String,
    /// The HTTP status (for a job's error: the status it would have as a response).
    pub status: u16,
    /// Stable snake_case code, for programs.
    pub code: ProblemCode,
    /// What is wrong and how to fix it, for people.
    pub detail: String,
    /// Every defect found in the asset, each with its JSON path.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub defects: Vec<AssetDefectJson>,
    /// The request that failed (every response carries it as `x-request-id`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub request_id: Option<String>,
}

impl ApiProblemJson {
    /// A problem with `code`, no defects and no request id.
    pub fn new(
        status: u16,
        code: ProblemCode,
        title: &str,
        detail: impl Into<String>,
    ) -> ApiProblemJson {
        ApiProblemJson {
            type_: format!("urn:texatlas:problem:{code}"),
            title: title.to_string(),
            status,
            code,
            detail: detail.into(),
            defects: Vec::new(),
            request_id: None,
        }
    }

    /// A problem body stored as text (a failed job's `error_json`) read back; `None` when the
    /// text is not a problem body. A code that this version does not know (the row was
    /// written by another version) must not lose the job's error: it reads as
    /// `internal_error`, and `detail` starts with the stored code.
    pub fn from_stored(text: &str) -> Option<ApiProblemJson> {
        let mut value: serde_json::Value = serde_json::from_str(text).ok()?;
        let stored = value.get("code")?.as_str()?.to_string();
        if ProblemCode::parse(&stored).is_none() {
            let detail = value.get("detail").and_then(|d| d.as_str()).unwrap_or("");
            let detail = format!("(stored code `{stored}`, unknown to this version) {detail}");
            let object = value.as_object_mut()?;
            object.insert("detail".into(), detail.into());
            object.insert("code".into(), ProblemCode::InternalError.as_str().into());
            object.insert(
                "type".into(),
                format!("urn:texatlas:problem:{}", ProblemCode::InternalError).into(),
            );
        }
        serde_json::from_value(value).ok()
    }
}

/// One defect of an asset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AssetDefectJson {
    /// Stable snake_case code.
    pub code: String,
    /// RFC 6901 JSON pointer into the glTF document (`""`: the container or the whole file).
    pub json_path: String,
    /// What is wrong.
    pub detail: String,
    /// How to fix it.
    pub fix: String,
}

impl From<&GltfError> for AssetDefectJson {
    fn from(e: &GltfError) -> AssetDefectJson {
        AssetDefectJson {
            code: e.code.as_str().to_string(),
            json_path: e.json_path.clone(),
            detail: e.detail.clone(),
            fix: e.fix.clone(),
        }
    }
}

/// RFC 3339 UTC with milliseconds for `ms` since the Unix epoch (proleptic Gregorian calendar;
/// H. Hinnant's `civil_from_days`).
pub fn rfc3339_from_ms(ms: i64) -> String {
    let secs = ms.div_euclid(1000);
    let millis = ms.rem_euclid(1000);
    let days = secs.div_euclid(86_400);
    let sod = secs.rem_euclid(86_400);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}.{millis:03}Z",
        sod / 3600,
        sod % 3600 / 60,
        sod % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rfc3339_known_instants() {
        assert_eq!(rfc3339_from_ms(0), "1970-01-01T00:00:00.000Z");
        assert_eq!(rfc3339_from_ms(951_782_400_123), "2000-02-29T00:00:00.123Z");
        assert_eq!(
            rfc3339_from_ms(1_735_689_599_999),
            "2024-12-31T23:59:59.999Z"
        );
        assert_eq!(rfc3339_from_ms(-1), "1969-12-31T23:59:59.999Z");
    }

    #[test]
    fn problem_type_names_the_code() {
        let p = ApiProblemJson::new(404, ProblemCode::JobNotFound, "Not found", "no such job");
        let v = serde_json::to_value(&p).unwrap();
        assert_eq!(v["type"], "urn:texatlas:problem:job_not_found");
        assert_eq!(v["code"], "job_not_found");
        assert!(v.get("defects").is_none());
    }

    /// The text stored for a failed job before codes were an enum (as `JobFailure::problem`
    /// wrote it) reads back, and is written again byte for byte.
    #[test]
    fn stored_problems_read_back_unchanged() {
        let stored = r#"{"type":"urn:texatlas:problem:time_limit_exceeded","title":"Internal error","status":500,"code":"time_limit_exceeded","detail":"the job ran longer than the per-job limit of 1 s"}"#;
        let p = ApiProblemJson::from_stored(stored).unwrap();
        assert_eq!(p.code, ProblemCode::TimeLimitExceeded);
        assert_eq!(serde_json::to_string(&p).unwrap(), stored);
    }

    #[test]
    fn an_unknown_stored_code_reads_as_internal_error_and_keeps_its_name() {
        let stored = r#"{"type":"urn:texatlas:problem:gpu_melted","title":"Internal error","status":500,"code":"gpu_melted","detail":"it got hot"}"#;
        let p = ApiProblemJson::from_stored(stored).unwrap();
        assert_eq!(p.code, ProblemCode::InternalError);
        assert_eq!(p.type_, "urn:texatlas:problem:internal_error");
        assert_eq!(p.status, 500);
        assert!(p.detail.contains("`gpu_melted`"), "{}", p.detail);
        assert!(p.detail.ends_with("it got hot"), "{}", p.detail);
        assert_eq!(ApiProblemJson::from_stored("not json"), None);
        assert_eq!(ApiProblemJson::from_stored(r#"{"code":"x"}"#), None);
    }
}
