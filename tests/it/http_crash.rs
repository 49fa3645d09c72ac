//! Crash recovery with the real binary: start `texatlas serve`, submit 5 jobs, `kill -9` it
//! while a job runs, restart it on the same data dir: every job ends `succeeded`, none is lost
//! and none is duplicated.
//!
//! The job killed is the first, a grid large enough that it is seen in an early stage (claimed,
//! segment or parameterize) well before it ends: with small jobs only, the kill could land
//! between one job's end and the next claim, and then no job had been killed mid-run.
use crate::common::http as http_common;

use std::io::{BufRead as _, BufReader};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use http_common::*;
use serde_json::Value;

/// Starts the binary; (child, base URL read from its first stdout line).
fn start(data: &std::path::Path) -> (Child, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_texatlas"))
        .args([
            "serve",
            "--bind",
            "127.0.0.1:0",
            "--workers",
            "1",
            "--lease-s",
            "2",
        ])
        .arg("--data-dir")
        .arg(data)
        .env("RUST_LOG", "warn")
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn texatlas serve");
    let mut line = String::new();
    BufReader::new(child.stdout.take().expect("stdout"))
        .read_line(&mut line)
        .expect("read the listening line");
    let base = line
        .trim()
        .strip_prefix("texatlas listening on ")
        .unwrap_or_else(|| panic!("unexpected first line: {line:?}"))
        .to_string();
    (child, base)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn kill_9_while_running_then_restart_finishes_every_job_once() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let (mut child, base) = start(&data);
    let c = reqwest::Client::new();
    let mut ids = Vec::new();
    for n in 0..5 {
        // The first job (80k triangles) is the one killed; the others are small.
        let size = if n == 0 { 200 } else { 48 + n };
        let r = c
            .post(format!("{base}/v1/jobs"))
            .header("content-type", "model/gltf-binary")
            .body(grid_glb(size))
            .send()
            .await
            .unwrap();
        assert_eq!(r.status().as_u16(), 202);
        let job: Value = r.json().await.unwrap();
        ids.push(job["id"].as_str().unwrap().to_string());
    }
    // Wait until the first job is running and still in an early stage, then kill -9.
    let start_wait = Instant::now();
    loop {
        let job: Value = get_json(&c, format!("{base}/v1/jobs/{}", ids[0])).await;
        let early = matches!(
            job["progress"]["stage"].as_str(),
            None | Some("segment") | Some("parameterize")
        );
        if job["status"] == "running" && early {
            break;
        }
        assert!(
            !is_terminal(&job),
            "the first job ended before it was seen running: {job:#}"
        );
        assert!(
            start_wait.elapsed() < Duration::from_secs(60),
            "no job started"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    child.kill().expect("SIGKILL");
    child.wait().unwrap();

    let (mut child, base) = start(&data);
    let deadline = Instant::now() + Duration::from_secs(300);
    let mut attempts = Vec::new();
    for id in &ids {
        let job = loop {
            let job: Value = get_json(&c, format!("{base}/v1/jobs/{id}")).await;
            if is_terminal(&job) {
                break job;
            }
            assert!(Instant::now() < deadline, "job {id} did not end: {job:#}");
            tokio::time::sleep(Duration::from_millis(100)).await;
        };
        assert_eq!(job["status"], "succeeded", "{job:#}");
        attempts.push(job["attempts"].as_u64().unwrap());
        let glb = get_bytes(&c, format!("{base}/v1/jobs/{id}/result")).await;
        assert!(glb.starts_with(b"glTF"));
    }
    // The job killed mid-run ran again.
    assert!(attempts[0] >= 2, "attempts {attempts:?}");
    // Exactly the 5 jobs, each once.
    let list: Value = get_json(&c, format!("{base}/v1/jobs?limit=100")).await;
    let mut listed: Vec<String> = list["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| j["id"].as_str().unwrap().to_string())
        .collect();
    listed.sort();
    let mut expected = ids.clone();
    expected.sort();
    assert_eq!(listed, expected);
    child.kill().ok();
    child.wait().ok();
}
