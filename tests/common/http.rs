//! Test support for the HTTP tests: the real server on `127.0.0.1:0` with a temp data dir,
//! a scripted fake processor, generated assets, and response validation against
//! `proto/openapi.json`.

use std::ops::ControlFlow;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde_json::{json, Value};
use texatlas::api::{OptionsJson, ProblemCode};
use texatlas::atlas::{Progress, Stage};
use texatlas::jobs::{JobFailure, JobInput, JobOutput, Processor};
use texatlas::service::{self, ServiceConfig};

use super::proto::ProtoRetriever;

/// `max_charts` values that script the fake processor.
pub const PANIC: usize = 900_001;
/// Runs until cancelled (or 60 s).
pub const UNTIL_CANCELLED: usize = 900_002;
/// Sleeps 3 s without a checkpoint (for the time limit).
pub const SLOW: usize = 900_003;

/// A processor scripted by `max_charts` (above); otherwise it walks the four stages in
/// `steps` steps of `step` each and echoes the input as the result.
pub struct Fake {
    pub steps: usize,
    pub step: Duration,
}

impl Fake {
    /// One 1 ms step per stage: for tests about the service, not about progress.
    pub fn instant() -> Arc<dyn Processor> {
        Arc::new(Fake {
            steps: 1,
            step: Duration::from_millis(1),
        })
    }
}

impl Processor for Fake {
    fn process(
        &self,
        input: &JobInput,
        options: &OptionsJson,
        progress: &mut dyn Progress,
    ) -> Result<JobOutput, JobFailure> {
        match options.max_charts {
            Some(PANIC) => panic!("scripted panic"),
            Some(UNTIL_CANCELLED) => {
                let start = Instant::now();
                progress.stage_started(Stage::Segment);
                let mut i = 0;
                while start.elapsed() < Duration::from_secs(60) {
                    i += 1;
                    if progress.advance(Stage::Segment, i % 100, 100).is_break() {
                        return Err(JobFailure::cancelled());
                    }
                    std::thread::sleep(Duration::from_millis(10));
                }
                return Err(JobFailure::internal(
                    ProblemCode::InternalError,
                    "the fake ran 60 s and nobody cancelled it",
                ));
            }
            Some(SLOW) => std::thread::sleep(Duration::from_secs(3)),
            _ => {}
        }
        for stage in Stage::ALL {
            progress.stage_started(stage);
            for i in 0..self.steps {
                if let ControlFlow::Break(()) = progress.advance(stage, i + 1, self.steps) {
                    return Err(JobFailure::cancelled());
                }
                std::thread::sleep(self.step);
            }
            progress.stage_finished(stage);
        }
        Ok(JobOutput {
            glb: input.asset.clone(),
            gltf: br#"{"asset":{"version":"2.0"}}"#.to_vec(),
            report_json: br#"{"fake":true}"#.to_vec(),
            preview_png: b"\x89PNG\r\n\x1a\nfake".to_vec(),
            triangles: 2,
            stage_seconds: [0.01; 4],
        })
    }
}

/// A running server.
pub struct Server {
    pub base: String,
    pub dir: tempfile::TempDir,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    handle: Option<tokio::task::JoinHandle<anyhow::Result<()>>>,
}

impl Server {
    /// Starts `service::serve` with the fake processor and `tweak`ed settings.
    pub async fn start_with(
        processor: Arc<dyn Processor>,
        tweak: impl FnOnce(&mut ServiceConfig),
    ) -> Server {
        let dir = tempfile::tempdir().expect("temp dir");
        let mut config = ServiceConfig {
            data_dir: dir.path().join("data"),
            ..ServiceConfig::default()
        };
        config.jobs.workers = 2;
        config.jobs.sweep_interval = Duration::from_millis(100);
        config.shutdown_grace = Duration::from_secs(5);
        tweak(&mut config);
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
            .await
            .expect("bind");
        let base = format!("http://{}", listener.local_addr().expect("addr"));
        let (tx, rx) = tokio::sync::oneshot::channel::<()>();
        let handle = tokio::spawn(service::serve(listener, config, processor, async move {
            let _ = rx.await;
        }));
        Server {
            base,
            dir,
            stop: Some(tx),
            handle: Some(handle),
        }
    }

    /// The fake processor with quick steps.
    pub async fn start() -> Server {
        Server::start_with(
            Arc::new(Fake {
                steps: 3,
                step: Duration::from_millis(20),
            }),
            |_| {},
        )
        .await
    }

    pub fn url(&self, path: &str) -> String {
        format!("{}{path}", self.base)
    }

    /// Graceful shutdown; the serve future's result.
    pub async fn stop(mut self) -> anyhow::Result<()> {
        if let Some(tx) = self.stop.take() {
            let _ = tx.send(());
        }
        match self.handle.take() {
            Some(h) => h.await.expect("serve task"),
            None => Ok(()),
        }
    }

    pub fn data_dir(&self) -> PathBuf {
        self.dir.path().join("data")
    }
}

/// `GET url`'s body; panics on a transport error (any status is returned).
pub async fn get_bytes(client: &reqwest::Client, url: impl reqwest::IntoUrl) -> Vec<u8> {
    client
        .get(url)
        .send()
        .await
        .expect("GET")
        .bytes()
        .await
        .expect("body")
        .to_vec()
}

/// `GET url`'s body as JSON; panics on a transport error or a body that is not JSON.
pub async fn get_json(client: &reqwest::Client, url: impl reqwest::IntoUrl) -> Value {
    client
        .get(url)
        .send()
        .await
        .expect("GET")
        .json()
        .await
        .expect("JSON body")
}

/// Polls `GET url` until `done(json)` or the deadline; the last body.
pub async fn poll_until(
    client: &reqwest::Client,
    url: &str,
    deadline: Duration,
    done: impl Fn(&Value) -> bool,
) -> Value {
    let start = Instant::now();
    loop {
        let body = get_json(client, url).await;
        if done(&body) {
            return body;
        }
        assert!(
            start.elapsed() < deadline,
            "not done within {deadline:?}: {body:#}"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

pub fn is_terminal(job: &Value) -> bool {
    matches!(
        job["status"].as_str(),
        Some("succeeded" | "failed" | "cancelled")
    )
}

/// Violations of `components/schemas/<name>` of proto/openapi.json by `instance`.
pub fn schema_violations(name: &str, instance: &Value) -> Vec<String> {
    let schema = json!({
        "$ref": format!("https://texatlas.dev/proto/openapi.json#/components/schemas/{name}")
    });
    let validator = jsonschema::options()
        .with_retriever(ProtoRetriever)
        .build(&schema)
        .expect("schema compiles");
    validator
        .iter_errors(instance)
        .map(|e| format!("{e} at {}", e.instance_path()))
        .collect()
}

/// Asserts `instance` is a valid `name` of proto/openapi.json.
pub fn assert_schema(name: &str, instance: &Value) {
    let v = schema_violations(name, instance);
    assert!(v.is_empty(), "{name} violations: {v:#?}\nin {instance:#}");
}

/// Asserts a problem+json response with `status` and `code` (`*`: any); the body.
pub async fn assert_problem(response: reqwest::Response, status: u16, code: &str) -> Value {
    assert_eq!(response.status().as_u16(), status, "status");
    let ct = response
        .headers()
        .get("content-type")
        .and_then(|v| v.to_str().ok())
        .unwrap_or("")
        .to_string();
    assert_eq!(ct, "application/problem+json");
    let body: Value = response.json().await.expect("problem JSON");
    if code != "*" {
        assert_eq!(body["code"], code, "{body:#}");
    }
    assert_eq!(body["status"], status);
    assert!(!body["detail"].as_str().unwrap_or("").is_empty());
    assert!(body["request_id"].is_string());
    assert_schema("Problem", &body);
    body
}

/// A wavy `n × n` grid of quads (2 n² triangles) as a glTF JSON document and its buffer.
pub fn grid_gltf(n: u32) -> (Value, Vec<u8>) {
    let mut bin = Vec::new();
    let mut min = [f32::INFINITY; 3];
    let mut max = [f32::NEG_INFINITY; 3];
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
            let p = [x, y, 0.1 * (6.0 * x).sin() * (4.0 * y).cos()];
            for c in 0..3 {
                min[c] = min[c].min(p[c]);
                max[c] = max[c].max(p[c]);
                bin.extend_from_slice(&p[c].to_le_bytes());
            }
        }
    }
    let positions_len = bin.len();
    let mut count = 0;
    for j in 0..n {
        for i in 0..n {
            let v = |a: u32, b: u32| b * (n + 1) + a;
            for idx in [
                v(i, j),
                v(i + 1, j),
                v(i + 1, j + 1),
                v(i, j),
                v(i + 1, j + 1),
                v(i, j + 1),
            ] {
                bin.extend_from_slice(&idx.to_le_bytes());
                count += 1;
            }
        }
    }
    let doc = json!({
        "asset": {"version": "2.0", "generator": "texatlas http tests"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": (n + 1) * (n + 1), "type": "VEC3",
             "min": min, "max": max},
            {"bufferView": 1, "componentType": 5125, "count": count, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": positions_len},
            {"buffer": 0, "byteOffset": positions_len, "byteLength": bin.len() - positions_len}
        ],
        "buffers": [{"byteLength": bin.len()}]
    });
    (doc, bin)
}

/// The grid as GLB.
pub fn grid_glb(n: u32) -> Vec<u8> {
    let (doc, bin) = grid_gltf(n);
    glb(&doc, &bin)
}

/// A GLB container around `doc` and `bin`.
pub fn glb(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut json = serde_json::to_vec(doc).expect("json");
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// Submits a GLB; the response.
pub async fn submit_glb(
    client: &reqwest::Client,
    server: &Server,
    glb: Vec<u8>,
    query: &str,
) -> reqwest::Response {
    client
        .post(server.url(&format!("/v1/jobs{query}")))
        .header("content-type", "model/gltf-binary")
        .body(glb)
        .send()
        .await
        .expect("POST")
}

/// Submits and returns the 202 body.
pub async fn submit_ok(
    client: &reqwest::Client,
    server: &Server,
    glb: Vec<u8>,
    query: &str,
) -> Value {
    let r = submit_glb(client, server, glb, query).await;
    assert_eq!(r.status().as_u16(), 202, "{:?}", r.text().await);
    let body: Value = r.json().await.expect("job JSON");
    assert_schema("Job", &body);
    body
}
