//! The HTTP service over a real socket (server on 127.0.0.1:0, temp data dir, reqwest), with a
//! scripted fake processor so the queue, events, cancel, errors and auth are tested without the
//! pipeline's cost; `real_pipeline_*` tests run the production processor on fixtures.
use crate::common::fixture;
use crate::common::http as http_common;

use std::sync::Arc;
use std::time::Duration;

use http_common::*;
use serde_json::{json, Value};
use texatlas::jobs::UnwrapProcessor;

const DEADLINE: Duration = Duration::from_secs(60);

fn client() -> reqwest::Client {
    reqwest::Client::new()
}

async fn wait_done(c: &reqwest::Client, s: &Server, id: &str) -> Value {
    let job = poll_until(c, &s.url(&format!("/v1/jobs/{id}")), DEADLINE, is_terminal).await;
    assert_schema("Job", &job);
    job
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn upload_poll_download_with_the_fake_processor() {
    let s = Server::start().await;
    let c = client();
    let glb = fixture("Box.glb");
    let r = submit_glb(&c, &s, glb.clone(), "?padding_texels=4").await;
    assert_eq!(r.status().as_u16(), 202);
    let location = r.headers()["location"].to_str().unwrap().to_string();
    let job: Value = r.json().await.unwrap();
    assert_schema("Job", &job);
    assert_eq!(
        location,
        format!("/v1/jobs/{}", job["id"].as_str().unwrap())
    );
    assert_eq!(job["status"], "queued");
    assert_eq!(job["options"], json!({"padding_texels": 4}));
    assert_eq!(job["triangles"], 12);
    // Not ready yet is a 409 (the fake takes ~240 ms) unless it was very fast.
    let early = c
        .get(s.url(&format!("{location}/result")))
        .send()
        .await
        .unwrap();
    if early.status().as_u16() != 200 {
        assert_problem(early, 409, "result_not_ready").await;
    }
    let done = wait_done(&c, &s, job["id"].as_str().unwrap()).await;
    assert_eq!(done["status"], "succeeded");
    assert_eq!(done["attempts"], 1);
    assert_eq!(done["progress"]["fraction"], 1.0);
    assert!(done["finished_at"].is_string() && done["expires_at"].is_string());
    let result = c
        .get(s.url(&format!("{location}/result")))
        .send()
        .await
        .unwrap();
    assert_eq!(result.status().as_u16(), 200);
    assert_eq!(result.headers()["content-type"], "model/gltf-binary");
    assert_eq!(
        result.bytes().await.unwrap().to_vec(),
        glb,
        "the fake echoes the input"
    );
    let gltf = c
        .get(s.url(&format!("{location}/result?format=gltf")))
        .send()
        .await
        .unwrap();
    assert_eq!(gltf.headers()["content-type"], "model/gltf+json");
    let report = c
        .get(s.url(&format!("{location}/report")))
        .send()
        .await
        .unwrap();
    assert_eq!(report.json::<Value>().await.unwrap(), json!({"fake": true}));
    let png = c
        .get(s.url(&format!("{location}/preview.png")))
        .send()
        .await
        .unwrap();
    assert_eq!(png.headers()["content-type"], "image/png");
    assert!(png.bytes().await.unwrap().starts_with(b"\x89PNG"));
    // Metrics saw it.
    let metrics = c
        .get(s.url("/metrics"))
        .send()
        .await
        .unwrap()
        .text()
        .await
        .unwrap();
    assert!(
        metrics.contains("texatlas_jobs{state=\"succeeded\"} 1"),
        "{metrics}"
    );
    assert!(metrics.contains("texatlas_triangles_processed_total 2"));
    assert!(metrics.contains("texatlas_http_request_duration_seconds_count{method=\"POST\",route=\"/v1/jobs\",status=\"202\"} 1"));
    // Delete a finished job: 204, then 404.
    let del = c.delete(s.url(&location)).send().await.unwrap();
    assert_eq!(del.status().as_u16(), 204);
    let gone = c.get(s.url(&location)).send().await.unwrap();
    assert_problem(gone, 404, "job_not_found").await;
    assert!(!s
        .data_dir()
        .join("blobs/jobs")
        .join(done["id"].as_str().unwrap())
        .exists());
    s.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn multipart_gltf_with_separate_bin_and_options_part() {
    let s = Server::start().await;
    let c = client();
    let (mut doc, bin) = grid_gltf(4);
    doc["buffers"][0]["uri"] = json!("grid data.bin");
    let gltf = serde_json::to_vec(&doc).unwrap();
    let form = reqwest::multipart::Form::new()
        .part(
            "asset",
            reqwest::multipart::Part::bytes(gltf.clone()).file_name("grid.gltf"),
        )
        .part(
            "bin",
            reqwest::multipart::Part::bytes(bin.clone()).file_name("grid data.bin"),
        )
        .text("options", r#"{"rotations": 4}"#);
    let r = c
        .post(s.url("/v1/jobs"))
        .multipart(form)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status().as_u16(), 202, "{:?}", r.text().await);
    let job: Value = r.json().await.unwrap();
    assert_eq!(job["options"], json!({"rotations": 4}));
    assert_eq!(job["triangles"], 32);
    let done = wait_done(&c, &s, job["id"].as_str().unwrap()).await;
    assert_eq!(done["status"], "succeeded");
    // The worker got the .gltf itself (the fake echoes it) — resolved with the stored .bin.
    let result = c
        .get(s.url(&format!(
            "/v1/jobs/{}/result?format=glb",
            job["id"].as_str().unwrap()
        )))
        .send()
        .await
        .unwrap();
    assert_eq!(result.bytes().await.unwrap().to_vec(), gltf);

    // Without the .bin part the decoder names the missing buffer.
    let form = reqwest::multipart::Form::new().part(
        "asset",
        reqwest::multipart::Part::bytes(gltf).file_name("grid.gltf"),
    );
    let r = c
        .post(s.url("/v1/jobs"))
        .multipart(form)
        .send()
        .await
        .unwrap();
    let p = assert_problem(r, 422, "resource_missing").await;
    assert_eq!(p["defects"][0]["json_path"], "/buffers/0/uri");
    // No asset part.
    let form = reqwest::multipart::Form::new().text("options", "{}");
    let r = c
        .post(s.url("/v1/jobs"))
        .multipart(form)
        .send()
        .await
        .unwrap();
    assert_problem(r, 400, "missing_asset").await;
    s.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn idempotency_key_replays_the_same_job() {
    let s = Server::start().await;
    let c = client();
    let send = |key: &'static str, body: Vec<u8>| {
        c.post(s.url("/v1/jobs"))
            .header("content-type", "model/gltf-binary")
            .header("idempotency-key", key)
            .body(body)
            .send()
    };
    let first = send("k-1", fixture("Box.glb")).await.unwrap();
    assert_eq!(first.status().as_u16(), 202);
    assert!(first.headers().get("idempotent-replayed").is_none());
    let first: Value = first.json().await.unwrap();
    let again = send("k-1", fixture("Box.glb")).await.unwrap();
    assert_eq!(again.status().as_u16(), 202);
    assert_eq!(again.headers()["idempotent-replayed"], "true");
    let again: Value = again.json().await.unwrap();
    assert_eq!(again["id"], first["id"]);
    // Same key, another body.
    let other = send("k-1", grid_glb(3)).await.unwrap();
    assert_problem(other, 422, "idempotency_key_reused").await;
    // Exactly one job exists.
    let list: Value = get_json(&c, s.url("/v1/jobs")).await;
    assert_eq!(list["jobs"].as_array().unwrap().len(), 1);
    s.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn list_is_newest_first_with_cursor_pages_and_status_filter() {
    let s = Server::start().await;
    let c = client();
    let mut ids = Vec::new();
    for n in 1..=7 {
        let job = submit_ok(&c, &s, grid_glb(n), "").await;
        ids.push(job["id"].as_str().unwrap().to_string());
    }
    let mut seen = Vec::new();
    let mut url = s.url("/v1/jobs?limit=3");
    loop {
        let page: Value = get_json(&c, &url).await;
        assert_schema("JobList", &page);
        for j in page["jobs"].as_array().unwrap() {
            seen.push(j["id"].as_str().unwrap().to_string());
        }
        match page["next_cursor"].as_str() {
            Some(cursor) => url = s.url(&format!("/v1/jobs?limit=3&cursor={cursor}")),
            None => break,
        }
    }
    let newest_first: Vec<String> = ids.iter().rev().cloned().collect();
    assert_eq!(seen, newest_first);
    for id in &ids {
        wait_done(&c, &s, id).await;
    }
    let ok: Value = get_json(&c, s.url("/v1/jobs?status=succeeded&limit=100")).await;
    assert_eq!(ok["jobs"].as_array().unwrap().len(), 7);
    let queued: Value = get_json(&c, s.url("/v1/jobs?status=queued")).await;
    assert_eq!(queued["jobs"], json!([]));
    for bad in [
        "?status=done",
        "?cursor=xyz",
        "?limit=0",
        "?limit=101",
        "?sort=asc",
    ] {
        let r = c
            .get(s.url(&format!("/v1/jobs{bad}")))
            .send()
            .await
            .unwrap();
        assert_eq!(r.status().as_u16(), 400, "{bad}");
    }
    s.stop().await.unwrap();
}

/// Parses an SSE body into (event, data JSON) pairs.
fn sse_events(text: &str) -> Vec<(String, Value)> {
    let mut out = Vec::new();
    for block in text.split("\n\n") {
        let mut event = String::new();
        let mut data = String::new();
        for line in block.lines() {
            if let Some(e) = line.strip_prefix("event:") {
                event = e.trim().to_string();
            } else if let Some(d) = line.strip_prefix("data:") {
                data.push_str(d.trim_start());
            }
        }
        if !event.is_empty() {
            out.push((
                event,
                serde_json::from_str(&data).expect("event data is JSON"),
            ));
        }
    }
    out
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn events_arrive_in_order_and_end_with_the_job() {
    let s = Server::start_with(
        Arc::new(Fake {
            steps: 5,
            step: Duration::from_millis(60),
        }),
        |_| {},
    )
    .await;
    let c = client();
    let job = submit_ok(&c, &s, fixture("Box.glb"), "").await;
    let id = job["id"].as_str().unwrap();
    let r = c
        .get(s.url(&format!("/v1/jobs/{id}/events")))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status().as_u16(), 200);
    assert!(r.headers()["content-type"]
        .to_str()
        .unwrap()
        .starts_with("text/event-stream"));
    // The stream ends by itself after the terminal status (bounded by the deadline).
    let text = tokio::time::timeout(DEADLINE, r.text())
        .await
        .unwrap()
        .unwrap();
    let events = sse_events(&text);
    assert!(events.len() >= 3, "{text}");
    let rank = |s: &str| {
        ["queued", "running", "succeeded"]
            .iter()
            .position(|x| *x == s)
            .unwrap()
    };
    let mut last_rank = 0;
    let mut last_fraction = 0.0;
    for (i, (kind, data)) in events.iter().enumerate() {
        assert_schema("Job", data);
        let status = data["status"].as_str().unwrap();
        let r = rank(status);
        assert!(r >= last_rank, "status went back at event {i}: {text}");
        if kind == "status" {
            assert!(
                i == 0 || r > last_rank,
                "a status event without a change: {text}"
            );
        } else {
            assert_eq!(kind, "progress");
            assert_eq!(r, last_rank);
        }
        let f = data["progress"]["fraction"].as_f64().unwrap_or(0.0);
        assert!(f >= last_fraction, "fraction went back: {text}");
        last_rank = r;
        last_fraction = f;
    }
    assert_eq!(events.last().unwrap().1["status"], "succeeded");
    assert!(
        events.iter().any(|(k, _)| k == "progress"),
        "no progress event: {text}"
    );
    // Unknown job: 404 before any stream.
    let r = c
        .get(s.url("/v1/jobs/0190aaaa-0000-7000-8000-000000000000/events"))
        .send()
        .await
        .unwrap();
    assert_problem(r, 404, "job_not_found").await;
    s.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cancel_while_running_and_while_queued() {
    let s = Server::start_with(Fake::instant(), |c| c.jobs.workers = 1).await;
    let c = client();
    let q = format!("?max_charts={UNTIL_CANCELLED}");
    let running = submit_ok(&c, &s, fixture("Box.glb"), &q).await;
    let queued = submit_ok(&c, &s, fixture("Box.glb"), &q).await;
    let run_url = s.url(&format!("/v1/jobs/{}", running["id"].as_str().unwrap()));
    poll_until(&c, &run_url, DEADLINE, |j| j["status"] == "running").await;
    // The second waits: one worker. Cancelling it is immediate.
    let r = c
        .delete(s.url(&format!("/v1/jobs/{}", queued["id"].as_str().unwrap())))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status().as_u16(), 202);
    let q2: Value = r.json().await.unwrap();
    assert_eq!(q2["status"], "cancelled");
    // The running one stops at its next checkpoint.
    let r = c.delete(&run_url).send().await.unwrap();
    assert_eq!(r.status().as_u16(), 202);
    let j: Value = r.json().await.unwrap();
    assert_schema("Job", &j);
    assert_eq!(j["cancel_requested"], true);
    let done = poll_until(&c, &run_url, DEADLINE, is_terminal).await;
    assert_eq!(done["status"], "cancelled", "{done:#}");
    let r = c.get(format!("{run_url}/result")).send().await.unwrap();
    assert_problem(r, 409, "result_not_ready").await;
    s.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn panics_and_time_limits_fail_the_job_and_the_server_lives_on() {
    // A panic, under the default time limit: the panic hook runs before the job's thread
    // unwinds, and with RUST_BACKTRACE set it symbolizes a backtrace of this test binary. Under
    // a 0.8 s limit, one CI run on a loaded machine reported this job as time_limit_exceeded
    // (most likely that symbolization outlasting the limit; not measured).
    let s = Server::start_with(Fake::instant(), |_| {}).await;
    let c = client();
    let boom = submit_ok(&c, &s, fixture("Box.glb"), &format!("?max_charts={PANIC}")).await;
    let boom = wait_done(&c, &s, boom["id"].as_str().unwrap()).await;
    assert_eq!(boom["status"], "failed");
    assert_eq!(boom["error"]["code"], "worker_panicked");
    assert_eq!(boom["error"]["status"], 500);
    let fine = submit_ok(&c, &s, fixture("Box.glb"), "").await;
    let fine = wait_done(&c, &s, fine["id"].as_str().unwrap()).await;
    assert_eq!(fine["status"], "succeeded");
    s.stop().await.unwrap();
    // A job that sleeps 3 s under a 0.8 s limit.
    let s = Server::start_with(Fake::instant(), |c| {
        c.jobs.job_time_limit = Some(Duration::from_millis(800))
    })
    .await;
    let slow = submit_ok(&c, &s, fixture("Box.glb"), &format!("?max_charts={SLOW}")).await;
    let slow = wait_done(&c, &s, slow["id"].as_str().unwrap()).await;
    assert_eq!(slow["status"], "failed");
    assert_eq!(slow["error"]["code"], "time_limit_exceeded");
    let fine = submit_ok(&c, &s, fixture("Box.glb"), "").await;
    let fine = wait_done(&c, &s, fine["id"].as_str().unwrap()).await;
    assert_eq!(fine["status"], "succeeded");
    s.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_requests_are_problems_with_the_right_status() {
    let s = Server::start_with(Fake::instant(), |c| c.http.max_upload_bytes = 4096).await;
    let c = client();
    // 413: declared and streamed (chunked, no Content-Length).
    let r = submit_glb(&c, &s, vec![0u8; 5000], "").await;
    assert_problem(r, 413, "upload_too_large").await;
    let chunks: Vec<Result<Vec<u8>, std::io::Error>> =
        (0..10).map(|_| Ok(vec![b'x'; 1000])).collect();
    let r = c
        .post(s.url("/v1/jobs"))
        .header("content-type", "model/gltf-binary")
        .body(reqwest::Body::wrap_stream(futures_util::stream::iter(
            chunks,
        )))
        .send()
        .await
        .unwrap();
    assert_problem(r, 413, "upload_too_large").await;
    let big = reqwest::multipart::Form::new()
        .part(
            "asset",
            reqwest::multipart::Part::bytes(vec![1u8; 3000]).file_name("a.glb"),
        )
        .part(
            "x.bin",
            reqwest::multipart::Part::bytes(vec![1u8; 3000]).file_name("x.bin"),
        );
    let r = c
        .post(s.url("/v1/jobs"))
        .multipart(big)
        .send()
        .await
        .unwrap();
    assert_problem(r, 413, "upload_too_large").await;
    // 415.
    let r = c
        .post(s.url("/v1/jobs"))
        .header("content-type", "text/plain")
        .body("hello")
        .send()
        .await
        .unwrap();
    assert_problem(r, 415, "unsupported_media_type").await;
    let r = c
        .post(s.url("/v1/jobs"))
        .body("hello")
        .send()
        .await
        .unwrap();
    assert_problem(r, 415, "unsupported_media_type").await;
    // 422: a truncated GLB, a GLB whose length field is below 12 (the gltf crate pitfall).
    let mut glb = fixture("Box.glb");
    glb.truncate(glb.len().min(2000) / 2);
    let r = submit_glb(&c, &s, glb, "").await;
    let p = assert_problem(r, 422, "*").await;
    assert!(p["defects"].as_array().is_some_and(|d| !d.is_empty()));
    let mut tiny = b"glTF".to_vec();
    tiny.extend_from_slice(&2u32.to_le_bytes());
    tiny.extend_from_slice(&4u32.to_le_bytes());
    let r = submit_glb(&c, &s, tiny, "").await;
    assert_eq!(r.status().as_u16(), 422);
    // 422: an option out of range; 400: an unknown option.
    let r = submit_glb(&c, &s, fixture("Box.glb"), "?rotations=0").await;
    assert_problem(r, 422, "invalid_option").await;
    let r = submit_glb(&c, &s, fixture("Box.glb"), "?rotation=4").await;
    assert_problem(r, 400, "invalid_options").await;
    // 400: empty body, bad idempotency key.
    let r = submit_glb(&c, &s, Vec::new(), "").await;
    assert_problem(r, 400, "empty_upload").await;
    // 404 / 405 / unknown ids.
    let r = c.get(s.url("/v1/nope")).send().await.unwrap();
    assert_problem(r, 404, "route_not_found").await;
    let r = c.put(s.url("/v1/jobs")).send().await.unwrap();
    assert_problem(r, 405, "method_not_allowed").await;
    let r = c.get(s.url("/v1/jobs/..%2F..%2Fetc")).send().await.unwrap();
    assert_problem(r, 404, "job_not_found").await;
    // Nothing was queued by any of these.
    let list: Value = get_json(&c, s.url("/v1/jobs")).await;
    assert_eq!(list["jobs"], json!([]));
    // Spool files of refused uploads are gone.
    let spool: Vec<_> = std::fs::read_dir(s.data_dir().join("spool"))
        .unwrap()
        .collect();
    assert!(spool.is_empty(), "{spool:?}");
    s.stop().await.unwrap();
}

/// A refusal sent before the body was read must reach the client intact, and the next request
/// on a pooled connection must not fail (CI once saw `IncompleteMessage` on the multipart 413
/// above; src/http/drain.rs says why). Without the drain this test, as it is now, failed in 1
/// of 6 runs here; the 4 kB bodies are under the limit, refused for their type or options.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn refusals_before_the_body_is_read_arrive_intact() {
    let s = Server::start_with(Fake::instant(), |c| c.http.max_upload_bytes = 4096).await;
    let c = client();
    let body = vec![7u8; 256 << 10];
    for round in 0..100 {
        let size = [5000, 6000, 8192, 65536, 256 << 10][round % 5];
        let r = submit_glb(&c, &s, body[..size].to_vec(), "").await;
        assert_problem(r, 413, "upload_too_large").await;
        let form = reqwest::multipart::Form::new().part(
            "asset",
            reqwest::multipart::Part::bytes(body[..size].to_vec()).file_name("a.glb"),
        );
        let r = c
            .post(s.url("/v1/jobs"))
            .multipart(form)
            .send()
            .await
            .unwrap_or_else(|e| panic!("round {round}, multipart: {e:?}"));
        assert_problem(r, 413, "upload_too_large").await;
        for (query, content_type, status, code) in [
            ("", "text/plain", 415, "unsupported_media_type"),
            ("?rotation=4", "model/gltf-binary", 400, "invalid_options"),
        ] {
            let r = c
                .post(s.url(&format!("/v1/jobs{query}")))
                .header("content-type", content_type)
                .body(body[..4000].to_vec())
                .send()
                .await
                .unwrap_or_else(|e| panic!("round {round}, {content_type}{query}: {e:?}"));
            assert_problem(r, status, code).await;
        }
    }
    // A client that asks first (`Expect: 100-continue`) for a body far past the limit gets the
    // 413 without being asked for the body, and without the server waiting for it.
    use tokio::io::{AsyncReadExt as _, AsyncWriteExt as _};
    let addr = s.url("").trim_start_matches("http://").to_string();
    let mut tcp = tokio::net::TcpStream::connect(&addr).await.unwrap();
    tcp.write_all(
        b"POST /v1/jobs HTTP/1.1\r\nhost: x\r\ncontent-type: model/gltf-binary\r\n\
          content-length: 10000000000\r\nexpect: 100-continue\r\n\r\n",
    )
    .await
    .unwrap();
    let mut answer = Vec::new();
    let read = tokio::time::timeout(Duration::from_secs(10), async {
        let mut buf = [0u8; 4096];
        while !answer.windows(4).any(|w| w == b"\r\n\r\n") {
            let n = tcp.read(&mut buf).await.unwrap();
            if n == 0 {
                break;
            }
            answer.extend_from_slice(&buf[..n]);
        }
    })
    .await;
    assert!(read.is_ok(), "no answer within 10 s");
    let answer = String::from_utf8_lossy(&answer);
    assert!(answer.starts_with("HTTP/1.1 413"), "{answer}");
    assert!(
        answer.to_ascii_lowercase().contains("connection: close"),
        "the connection cannot be reused and the answer must say so: {answer}"
    );
    s.stop().await.unwrap();
}

/// An upload whose bytes stop coming is dropped after the idle timeout with a 408, and leaves
/// no spool file; the server answers the next upload as usual.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stalled_upload_gets_408_and_leaves_nothing() {
    let s = Server::start_with(Fake::instant(), |c| {
        c.http.upload_idle_timeout = Duration::from_millis(300)
    })
    .await;
    let c = client();
    // Raw and multipart: a first chunk, then nothing (the sender stays alive, so the body
    // neither ends nor fails).
    for multipart in [false, true] {
        let (tx, rx) = tokio::sync::mpsc::channel::<Result<Vec<u8>, std::io::Error>>(1);
        let first = if multipart {
            b"--b\r\ncontent-disposition: form-data; name=\"asset\"; filename=\"a.glb\"\r\n\r\nglTF"
                .to_vec()
        } else {
            b"glTF\x02\x00\x00\x00".to_vec()
        };
        tx.send(Ok(first)).await.unwrap();
        let body = reqwest::Body::wrap_stream(futures_util::stream::unfold(rx, |mut rx| async {
            rx.recv().await.map(|item| (item, rx))
        }));
        let content_type = if multipart {
            "multipart/form-data; boundary=b"
        } else {
            "model/gltf-binary"
        };
        let started = std::time::Instant::now();
        let send = c
            .post(s.url("/v1/jobs"))
            .header("content-type", content_type)
            .body(body)
            .send();
        let r = tokio::time::timeout(Duration::from_secs(10), send)
            .await
            .expect("no answer within 10 s to a stalled upload")
            .unwrap();
        let waited = started.elapsed();
        let p = assert_problem(r, 408, "upload_stalled").await;
        assert!(p["detail"].as_str().unwrap().contains("0.3 s"), "{p}");
        assert!(
            waited >= Duration::from_millis(300) && waited < Duration::from_secs(5),
            "answered after {waited:?}"
        );
        drop(tx);
    }
    let spool: Vec<_> = std::fs::read_dir(s.data_dir().join("spool"))
        .unwrap()
        .collect();
    assert!(spool.is_empty(), "{spool:?}");
    let list: Value = get_json(&c, s.url("/v1/jobs")).await;
    assert_eq!(list["jobs"], json!([]));
    submit_ok(&c, &s, fixture("Box.glb"), "").await;
    s.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hostile_buffer_uris_are_refused_without_opening_anything() {
    let s = Server::start().await;
    let c = client();
    for uri in [
        "../../etc/passwd",
        "file:///etc/passwd",
        "http://127.0.0.1:1/",
        "/etc/passwd",
        "..\\..\\etc\\passwd",
    ] {
        let (mut doc, _bin) = grid_gltf(2);
        doc["buffers"][0]["uri"] = json!(uri);
        let body = serde_json::to_vec(&doc).unwrap();
        let r = c
            .post(s.url("/v1/jobs"))
            .header("content-type", "model/gltf+json")
            .body(body.clone())
            .send()
            .await
            .unwrap();
        let p = assert_problem(r, 422, "uri_forbidden").await;
        assert_eq!(p["defects"][0]["json_path"], "/buffers/0/uri", "{uri}");
        // Also as multipart, with a part that claims that name: still refused.
        let form = reqwest::multipart::Form::new()
            .part(
                "asset",
                reqwest::multipart::Part::bytes(body).file_name("a.gltf"),
            )
            .part(
                "evil",
                reqwest::multipart::Part::bytes(vec![0u8; 64]).file_name(uri.to_string()),
            );
        let r = c
            .post(s.url("/v1/jobs"))
            .multipart(form)
            .send()
            .await
            .unwrap();
        assert_eq!(r.status().as_u16(), 422, "{uri}");
    }
    // A truncated GLB in multipart form too.
    let form = reqwest::multipart::Form::new().part(
        "asset",
        reqwest::multipart::Part::bytes(fixture("Box.glb")[..100].to_vec()).file_name("a.glb"),
    );
    let r = c
        .post(s.url("/v1/jobs"))
        .multipart(form)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status().as_u16(), 422);
    s.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn api_keys_isolate_owners() {
    let s = Server::start_with(Fake::instant(), |c| {
        c.http.api_keys = vec!["key-alpha".into(), "key-beta".into()]
    })
    .await;
    let c = client();
    let r = submit_glb(&c, &s, fixture("Box.glb"), "").await;
    let p = assert_problem(r, 401, "unauthorized").await;
    assert!(p["detail"].as_str().unwrap().contains("Bearer"));
    let r = c
        .get(s.url("/v1/jobs"))
        .bearer_auth("key-gamma")
        .send()
        .await
        .unwrap();
    assert_eq!(r.headers()["www-authenticate"], "Bearer realm=\"texatlas\"");
    assert_problem(r, 401, "unauthorized").await;
    let r = c
        .post(s.url("/v1/jobs"))
        .bearer_auth("key-alpha")
        .header("content-type", "model/gltf-binary")
        .body(fixture("Box.glb"))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status().as_u16(), 202);
    let job: Value = r.json().await.unwrap();
    let url = s.url(&format!("/v1/jobs/{}", job["id"].as_str().unwrap()));
    let alpha = c.get(&url).bearer_auth("key-alpha").send().await.unwrap();
    assert_eq!(alpha.status().as_u16(), 200);
    for path in ["", "/result", "/report", "/preview.png", "/events"] {
        let r = c
            .get(format!("{url}{path}"))
            .bearer_auth("key-beta")
            .send()
            .await
            .unwrap();
        assert_problem(r, 404, "job_not_found").await;
    }
    let r = c.delete(&url).bearer_auth("key-beta").send().await.unwrap();
    assert_problem(r, 404, "job_not_found").await;
    let list: Value = c
        .get(s.url("/v1/jobs"))
        .bearer_auth("key-beta")
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(list["jobs"], json!([]));
    let list: Value = c
        .get(s.url("/v1/jobs"))
        .bearer_auth("key-alpha")
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(list["jobs"].as_array().unwrap().len(), 1);
    // Operational endpoints stay open.
    assert_eq!(
        c.get(s.url("/healthz"))
            .send()
            .await
            .unwrap()
            .status()
            .as_u16(),
        200
    );
    s.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_full_queue_answers_503_with_retry_after() {
    let s = Server::start_with(Fake::instant(), |c| {
        c.jobs.workers = 1;
        c.jobs.queue_capacity = Some(2);
    })
    .await;
    let c = client();
    let q = format!("?max_charts={UNTIL_CANCELLED}");
    let a = submit_ok(&c, &s, fixture("Box.glb"), &q).await;
    let b = submit_ok(&c, &s, fixture("Box.glb"), &q).await;
    let r = submit_glb(&c, &s, fixture("Box.glb"), "").await;
    assert_eq!(r.headers()["retry-after"], "5");
    assert_problem(r, 503, "queue_full").await;
    for j in [a, b] {
        let url = s.url(&format!("/v1/jobs/{}", j["id"].as_str().unwrap()));
        c.delete(&url).send().await.unwrap();
        poll_until(&c, &url, DEADLINE, is_terminal).await;
    }
    submit_ok(&c, &s, fixture("Box.glb"), "").await;
    s.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn operational_endpoints_and_the_openapi_contract() {
    let s = Server::start().await;
    let c = client();
    let served = c.get(s.url("/openapi.json")).send().await.unwrap();
    assert_eq!(served.headers()["content-type"], "application/json");
    let served = served.text().await.unwrap();
    let file = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("proto/openapi.json"),
    )
    .unwrap();
    assert_eq!(served, file, "the served document is proto/openapi.json");
    let doc: Value = serde_json::from_str(&file).unwrap();
    // Every route the router serves is in the document, and the reverse.
    let mut paths: Vec<&str> = doc["paths"]
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    paths.sort();
    assert_eq!(
        paths,
        [
            "/healthz",
            "/metrics",
            "/openapi.json",
            "/readyz",
            "/v1/jobs",
            "/v1/jobs/{id}",
            "/v1/jobs/{id}/events",
            "/v1/jobs/{id}/preview.png",
            "/v1/jobs/{id}/report",
            "/v1/jobs/{id}/result",
        ]
    );
    let health: Value = get_json(&c, s.url("/healthz")).await;
    assert_schema("Status", &health);
    let ready = c.get(s.url("/readyz")).send().await.unwrap();
    assert_eq!(ready.status().as_u16(), 200);
    let r = c.get(s.url("/metrics")).send().await.unwrap();
    assert!(r.headers()["content-type"]
        .to_str()
        .unwrap()
        .starts_with("text/plain"));
    let text = r.text().await.unwrap();
    for name in [
        "texatlas_jobs{state=\"queued\"}",
        "texatlas_queue_depth",
        "texatlas_stage_duration_seconds_count{stage=\"segment\"}",
        "texatlas_triangles_processed_total",
        "texatlas_http_request_duration_seconds_bucket",
    ] {
        assert!(text.contains(name), "{name} missing from\n{text}");
    }
    // Request ids: ours is echoed, else one is made.
    let r = c
        .get(s.url("/healthz"))
        .header("x-request-id", "abc-123")
        .send()
        .await
        .unwrap();
    assert_eq!(r.headers()["x-request-id"], "abc-123");
    let r = c.get(s.url("/healthz")).send().await.unwrap();
    assert_eq!(r.headers()["x-request-id"].len(), 36);
    s.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cors_when_configured() {
    let s = Server::start_with(Fake::instant(), |c| {
        c.http.cors_origins = vec!["https://dash.example".into()]
    })
    .await;
    let c = client();
    let r = c
        .get(s.url("/v1/jobs"))
        .header("origin", "https://dash.example")
        .send()
        .await
        .unwrap();
    assert_eq!(
        r.headers()["access-control-allow-origin"],
        "https://dash.example"
    );
    let r = c
        .get(s.url("/v1/jobs"))
        .header("origin", "https://evil.example")
        .send()
        .await
        .unwrap();
    assert!(r.headers().get("access-control-allow-origin").is_none());
    s.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn graceful_shutdown_requeues_running_jobs_and_a_restart_finishes_them() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let d1 = data.clone();
    let s = Server::start_with(Fake::instant(), move |c| {
        c.data_dir = d1;
        c.jobs.workers = 1;
        c.shutdown_grace = Duration::from_millis(200);
    })
    .await;
    let c = client();
    let job = submit_ok(
        &c,
        &s,
        fixture("Box.glb"),
        &format!("?max_charts={UNTIL_CANCELLED}"),
    )
    .await;
    let id = job["id"].as_str().unwrap().to_string();
    poll_until(&c, &s.url(&format!("/v1/jobs/{id}")), DEADLINE, |j| {
        j["status"] == "running"
    })
    .await;
    s.stop().await.unwrap();
    // Same data dir, a processor that finishes: the job was given back, not lost or failed.
    let s = Server::start_with(Fake::instant(), move |c| c.data_dir = data).await;
    // The restarted job has UNTIL_CANCELLED options; cancel it and check it was back in play.
    let url = s.url(&format!("/v1/jobs/{id}"));
    let j = poll_until(&c, &url, DEADLINE, |j| j["status"] == "running").await;
    assert_eq!(
        j["attempts"], 1,
        "a graceful release does not count as an attempt"
    );
    c.delete(&url).send().await.unwrap();
    let j = poll_until(&c, &url, DEADLINE, is_terminal).await;
    assert_eq!(j["status"], "cancelled");
    s.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn real_pipeline_unwraps_fixtures_end_to_end() {
    let s = Server::start_with(Arc::new(UnwrapProcessor::default()), |_| {}).await;
    let c = client();
    let mut jobs = Vec::new();
    for (name, glb) in [
        ("Box.glb", fixture("Box.glb")),
        ("SimpleSkin.glb", fixture("SimpleSkin.glb")),
        ("grid", grid_glb(24)),
    ] {
        jobs.push((name, submit_ok(&c, &s, glb, "").await));
    }
    for (name, job) in jobs {
        let id = job["id"].as_str().unwrap();
        let done = wait_done(&c, &s, id).await;
        assert_eq!(done["status"], "succeeded", "{name}: {done:#}");
        let glb = get_bytes(&c, s.url(&format!("/v1/jobs/{id}/result"))).await;
        // The result decodes again and keeps every triangle.
        let asset = texatlas::gltf_io::decode(
            &glb,
            &texatlas::gltf_io::Resources::new(),
            &texatlas::gltf_io::DecodeLimits::default(),
        )
        .unwrap_or_else(|e| panic!("{name}: result does not decode: {e}"));
        assert_eq!(
            asset.mesh_input().triangles.len() as u64,
            done["triangles"].as_u64().unwrap(),
            "{name}"
        );
        let gltf = c
            .get(s.url(&format!("/v1/jobs/{id}/result")))
            .header("accept", "model/gltf+json")
            .send()
            .await
            .unwrap();
        assert_eq!(gltf.headers()["content-type"], "model/gltf+json");
        let gltf = gltf.bytes().await.unwrap();
        texatlas::gltf_io::decode(
            &gltf,
            &texatlas::gltf_io::Resources::new(),
            &texatlas::gltf_io::DecodeLimits::default(),
        )
        .unwrap_or_else(|e| panic!("{name}: .gltf result does not decode: {e}"));
        let report: Value = get_json(&c, s.url(&format!("/v1/jobs/{id}/report"))).await;
        assert_schema("Report", &report);
        assert_eq!(report["quality"]["flipped"], 0, "{name}");
        let png = get_bytes(&c, s.url(&format!("/v1/jobs/{id}/preview.png"))).await;
        assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"), "{name}");
    }
    s.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn finished_jobs_expire_and_the_sweeper_deletes_them_with_their_files() {
    // The job takes about 1 s (four 250 ms stages), so it cannot have finished and been swept
    // (every 100 ms) before the check that its input is stored; with the instant fake a loaded
    // machine could deschedule the test for the ~4 ms the job took.
    let slow = Arc::new(Fake {
        steps: 1,
        step: Duration::from_millis(250),
    });
    let s = Server::start_with(slow, |c| c.jobs.retention = Duration::ZERO).await;
    let c = client();
    let job = submit_ok(&c, &s, fixture("Box.glb"), "").await;
    let id = job["id"].as_str().unwrap();
    let blobs = s.data_dir().join("blobs/jobs").join(id);
    assert!(
        blobs.exists(),
        "the input is stored before the job is accepted"
    );
    let url = s.url(&format!("/v1/jobs/{id}"));
    let start = std::time::Instant::now();
    loop {
        let r = c.get(&url).send().await.unwrap();
        if r.status().as_u16() == 404 {
            break;
        }
        assert!(start.elapsed() < DEADLINE, "never swept");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    assert!(!blobs.exists(), "the sweeper deletes the job's files");
    s.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_triangle_limit_refuses_big_assets() {
    let s = Server::start_with(Fake::instant(), |c| {
        c.jobs.decode_limits.max_triangles = Some(10)
    })
    .await;
    let c = client();
    let r = submit_glb(&c, &s, fixture("Box.glb"), "").await;
    assert_problem(r, 422, "limit_exceeded").await;
    submit_ok(&c, &s, grid_glb(2), "").await;
    s.stop().await.unwrap();
}
