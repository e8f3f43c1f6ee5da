//! Allowances per caller: a worker may hold only so many leases, a client address may send
//! only so many requests a second, and every 429 and 503 says when to come back
//! (`Retry-After`).

mod support;

use std::net::SocketAddr;

use axum::body::Body;
use axum::extract::ConnectInfo;
use axum::http::{Method, Request, StatusCode, header};
use serde_json::json;
use support::{CLIENT, Coordinator, WORKER, config, scene};
use tower::ServiceExt;

/// Sends a request from `peer` (as the real server records it); the status and Retry-After.
async fn send_from(
    c: &Coordinator,
    peer: Option<SocketAddr>,
    method: Method,
    uri: &str,
    token: &str,
    body: &str,
) -> (StatusCode, Option<u64>) {
    let mut request = Request::builder()
        .method(method)
        .uri(uri)
        .header("authorization", format!("Bearer {token}"))
        .body(Body::from(body.to_string()))
        .unwrap();
    if token == WORKER {
        let last = c.secrets.lock().unwrap().1.expect("a worker registered");
        let secret = c.secret(last).parse().unwrap();
        request
            .headers_mut()
            .insert("spindle-worker-secret", secret);
    }
    if let Some(peer) = peer {
        request.extensions_mut().insert(ConnectInfo(peer));
    }
    let response = c.app.clone().oneshot(request).await.unwrap();
    let retry_after = response
        .headers()
        .get(header::RETRY_AFTER)
        .map(|v| v.to_str().unwrap().parse::<u64>().expect("whole seconds"));
    (response.status(), retry_after)
}

#[tokio::test]
async fn a_worker_holds_at_most_its_lease_allowance() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.max_leases_per_worker = 2;
    let c = Coordinator::open(cfg).await;
    c.submit(json!({"scene": scene(16, 16), "tile_size": 4}))
        .await; // 16 tiles
    let greedy = c.register("greedy").await;
    let uri = format!("/v1/workers/{greedy}/lease");
    for _ in 0..2 {
        let (status, _) = send_from(&c, None, Method::POST, &uri, WORKER, "").await;
        assert_eq!(status, StatusCode::OK);
    }
    let (status, retry_after) = send_from(&c, None, Method::POST, &uri, WORKER, "").await;
    assert_eq!(status, StatusCode::TOO_MANY_REQUESTS);
    assert_eq!(retry_after, Some(1));
    // Another worker still gets work.
    let other = c.register("other").await;
    assert!(c.lease(other).await.is_some());
}

#[tokio::test]
async fn a_client_address_is_rate_limited_with_retry_after() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.client_rate_per_s = std::num::NonZeroU32::new(1).unwrap(); // bursts of 2
    let c = Coordinator::open(cfg).await;
    let noisy: SocketAddr = "192.0.2.1:4000".parse().unwrap();
    let quiet: SocketAddr = "192.0.2.2:4000".parse().unwrap();
    for _ in 0..2 {
        let (status, _) = send_from(&c, Some(noisy), Method::GET, "/v1/jobs", CLIENT, "").await;
        assert_eq!(status, StatusCode::OK);
    }
    let (status, retry_after) =
        send_from(&c, Some(noisy), Method::GET, "/v1/jobs", CLIENT, "").await;
    assert_eq!(status, StatusCode::TOO_MANY_REQUESTS);
    assert_eq!(retry_after, Some(1));
    let (status, _) = send_from(&c, Some(quiet), Method::GET, "/v1/jobs", CLIENT, "").await;
    assert_eq!(status, StatusCode::OK, "another address is not affected");
    // Worker and public routes are not counted against the client rate.
    let (status, _) = send_from(&c, Some(noisy), Method::GET, "/healthz", CLIENT, "").await;
    assert_eq!(status, StatusCode::OK);
}

#[tokio::test]
async fn the_job_limit_and_shutdown_answer_with_retry_after() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.limits.max_active_jobs = 1;
    let c = Coordinator::open(cfg).await;
    c.submit(json!({"scene": scene(8, 8)})).await;
    let body = json!({"scene": scene(8, 8)}).to_string();
    let (status, retry_after) = send_from(&c, None, Method::POST, "/v1/jobs", CLIENT, &body).await;
    assert_eq!(status, StatusCode::TOO_MANY_REQUESTS);
    assert_eq!(retry_after, Some(10));
    c.state.begin_shutdown();
    let (status, retry_after) = send_from(&c, None, Method::GET, "/readyz", CLIENT, "").await;
    assert_eq!(status, StatusCode::SERVICE_UNAVAILABLE);
    assert_eq!(retry_after, Some(5));
}
