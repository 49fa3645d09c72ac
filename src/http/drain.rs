//! Refused uploads still get their answer, and the connection it came on is either reusable or
//! says it is not: a middleware that reads and drops what is left of a request body the handler
//! did not read, before the response goes out.
//!
//! # Why
//! A handler that refuses an upload early (413 from `Content-Length`, 415, 401, a bad option
//! in the query) answers without reading the body. hyper then closes the connection, since the
//! unread bytes make it unusable, but it says so (`Connection: close`) only when it noticed the
//! dropped body before writing the response head, which is a race. When it lost the race, a
//! client that pools connections sends its next request on a connection the server is closing
//! and gets "incomplete message" (CI saw exactly this once: the multipart 413 of
//! `tests/it/http_service.rs`, right after another refused upload; here, without this middleware,
//! the stress test `refusals_before_the_body_is_read_arrive_intact` failed in 1 of 6 runs, and
//! in 0 of 8 with the client's pool turned off). Closing with unread bytes in
//! the socket also makes the kernel answer with a TCP reset, which can overtake the response.
//! Draining the rest of the body, as nginx's lingering close does, leaves the connection clean
//! and reusable; when the body is not drained to its end, the response says
//! `Connection: close` itself.
//!
//! # Bounds
//! Draining is bounded, so a refused client cannot hold the server: at most
//! [`DRAIN_MAX_BYTES`] and [`DRAIN_MAX_TIME`]; a body declared longer than that is not drained
//! at all, nor is the body of a stalled upload (`408`: draining it would only wait). Clients
//! that send big bodies should send `Expect: 100-continue`: they then see the refusal before
//! sending anything, as a body that was never asked for is not drained either.
use std::pin::Pin;
use std::sync::{Arc, Mutex, PoisonError};
use std::task::{Context, Poll};
use std::time::Duration;

use axum::body::{Body, BodyDataStream, Bytes};
use axum::extract::Request;
use axum::http::{header, HeaderValue};
use axum::middleware::Next;
use axum::response::Response;
use futures_util::{Stream, StreamExt as _};

/// Most bytes of a refused body read and dropped.
const DRAIN_MAX_BYTES: u64 = 32 << 20;
/// Longest time spent draining a refused body.
const DRAIN_MAX_TIME: Duration = Duration::from_secs(5);

/// The request body, shared between the handler (through [`TailBody`]) and the middleware.
struct Tail {
    stream: Option<BodyDataStream>,
    /// The handler polled the body at least once (so hyper sent `100 Continue` if asked).
    polled: bool,
    /// The body ended (or failed): nothing is left to drain.
    ended: bool,
    /// Bytes the handler read.
    read_bytes: u64,
}

/// The handler's view of the body.
struct TailBody(Arc<Mutex<Tail>>);

impl Stream for TailBody {
    type Item = Result<Bytes, axum::Error>;

    fn poll_next(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Self::Item>> {
        let mut tail = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        tail.polled = true;
        let Some(stream) = tail.stream.as_mut() else {
            return Poll::Ready(None);
        };
        let next = stream.poll_next_unpin(cx);
        match &next {
            Poll::Ready(Some(Ok(chunk))) => tail.read_bytes += chunk.len() as u64,
            Poll::Ready(None | Some(Err(_))) => tail.ended = true,
            Poll::Pending => {}
        }
        next
    }
}

/// Middleware: runs the request; if its body was not read to the end, drains what is left
/// within the bounds of the module doc, then returns the response.
pub(crate) async fn drain_unread_bodies(req: Request, next: Next) -> Response {
    let headers = req.headers();
    let declared = headers
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.trim().parse::<u64>().ok());
    let chunked = headers.contains_key(header::TRANSFER_ENCODING);
    if declared.unwrap_or(0) == 0 && !chunked {
        return next.run(req).await;
    }
    let expects_continue = headers
        .get(header::EXPECT)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.trim().eq_ignore_ascii_case("100-continue"));
    let (parts, body) = req.into_parts();
    let tail = Arc::new(Mutex::new(Tail {
        stream: Some(body.into_data_stream()),
        polled: false,
        ended: false,
        read_bytes: 0,
    }));
    let req = Request::from_parts(parts, Body::from_stream(TailBody(tail.clone())));
    let mut response = next.run(req).await;
    // A stalled upload (408) would only stall the drain too.
    let stalled = response.status() == axum::http::StatusCode::REQUEST_TIMEOUT;
    let (stream, left, asked) = {
        let mut t = tail.lock().unwrap_or_else(PoisonError::into_inner);
        if t.ended {
            return response;
        }
        let left = declared.map(|n| n.saturating_sub(t.read_bytes));
        // With `Expect: 100-continue` and the body never polled, the client was never asked
        // for it and sends nothing: there is nothing to drain.
        (t.stream.take(), left, !expects_continue || t.polled)
    };
    let drained_to_end = match stream {
        None => false,
        Some(_) if stalled || !asked || left.is_some_and(|n| n > DRAIN_MAX_BYTES) => false,
        Some(mut stream) => {
            let drain = async {
                let mut drained = 0u64;
                loop {
                    match stream.next().await {
                        None => return true,
                        Some(Err(_)) => return false,
                        Some(Ok(chunk)) => {
                            drained += chunk.len() as u64;
                            if drained > DRAIN_MAX_BYTES {
                                return false;
                            }
                        }
                    }
                }
            };
            tokio::time::timeout(DRAIN_MAX_TIME, drain)
                .await
                .unwrap_or(false)
        }
    };
    if !drained_to_end {
        // hyper closes the connection; say so, so that no client reuses it.
        response
            .headers_mut()
            .insert(header::CONNECTION, HeaderValue::from_static("close"));
    }
    response
}
