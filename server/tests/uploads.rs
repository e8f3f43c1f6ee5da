//! A tile upload is judged by its path and headers before its body is read, and its body is
//! read and inflated only up to what the tile's rectangle can hold: a few hundred bytes that
//! inflate to megabytes cost nothing for a job that does not exist or a lease that is not the
//! worker's, and are refused at the tile's bound (413) for one that is.

mod support;

use axum::body::Body;
use axum::http::{Method, Request, StatusCode};
use http_body_util::BodyExt;
use serde_json::{Value, json};
use spindle_common::protocol::{LEASE_EPOCH_HEADER, TileOutcome, TileUpload};
use spindle_common::tile_encoding;
use support::*;
use tower::ServiceExt;

/// `PUT` of a compact tile body as worker `worker`, with the lease epoch header if given.
async fn put_tile(
    c: &Coordinator,
    worker: u64,
    job: u64,
    tile: u32,
    epoch: Option<u64>,
    body: Vec<u8>,
) -> (StatusCode, Value) {
    let mut request = Request::builder()
        .method(Method::PUT)
        .uri(format!("/v1/jobs/{job}/tiles/{tile}"))
        .header("authorization", format!("Bearer {WORKER}"))
        .header("spindle-worker-secret", c.secret(worker))
        .header("content-type", tile_encoding::CONTENT_TYPE);
    if let Some(epoch) = epoch {
        request = request.header(LEASE_EPOCH_HEADER, epoch);
    }
    let response = c
        .app
        .clone()
        .oneshot(request.body(Body::from(body)).unwrap())
        .await
        .unwrap();
    let status = response.status();
    let bytes = response.into_body().collect().await.unwrap().to_bytes();
    (
        status,
        serde_json::from_slice(&bytes).unwrap_or(Value::Null),
    )
}

/// A zstd body of a few hundred bytes that inflates to a 15 MiB MessagePack string.
fn inflating_body() -> Vec<u8> {
    let body = tile_encoding::encode(&"a".repeat(15 << 20)).unwrap();
    assert!(body.len() < 2048, "{} bytes", body.len());
    body
}

#[tokio::test]
async fn an_inflating_upload_is_refused_before_it_is_read_or_at_the_tiles_bound() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(32, 32), "tile_size": 32}))
        .await;
    let (holder, other) = (c.register("holder").await, c.register("other").await);
    let lease = c.lease(holder).await.unwrap();
    let bomb = inflating_body();

    // No such job: 404 from the path alone (before: 400 "pixels: missing field rect").
    let (status, err) = put_tile(&c, holder, 999, 0, None, bomb.clone()).await;
    assert_eq!(status, StatusCode::NOT_FOUND, "{err}");
    // Another worker's lease: 409 before the body.
    let (status, err) = put_tile(&c, other, job.id, 0, None, bomb.clone()).await;
    assert_eq!(status, StatusCode::CONFLICT, "{err}");
    assert!(
        err["error"].as_str().unwrap().contains("stale lease"),
        "{err}"
    );
    // The holder naming another epoch: 409 before the body.
    let (status, err) = put_tile(&c, holder, job.id, 0, Some(lease.epoch + 1), bomb.clone()).await;
    assert_eq!(status, StatusCode::CONFLICT, "{err}");
    // The holder: the body inflates past what a 32 × 32 tile can hold, and is refused there.
    let (status, err) = put_tile(&c, holder, job.id, 0, Some(lease.epoch), bomb).await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{err}");
    let bound = TileUpload::max_packed_bytes(lease.rect);
    assert!(bound < 1 << 20, "{bound}");
    let message = err["error"].as_str().unwrap();
    assert!(
        message.contains(&format!("at most {bound} bytes when decompressed")),
        "{message}"
    );

    // The lease is intact: the honest tile is accepted after all that.
    let honest = tile_encoding::encode(&upload_for(&lease, holder)).unwrap();
    let (status, ack) = put_tile(&c, holder, job.id, 0, Some(lease.epoch), honest).await;
    assert_eq!(status, StatusCode::OK, "{ack}");
    assert_eq!(
        serde_json::from_value::<TileOutcome>(ack["outcome"].clone()).unwrap(),
        TileOutcome::Accepted
    );
}

#[tokio::test]
async fn a_body_larger_than_the_tile_can_hold_is_not_read() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let holder = c.register("holder").await;
    let lease = c.lease(holder).await.unwrap();
    // 2 MiB of stored (incompressible-looking) data for an 8 × 8 tile: under the route's
    // 16 MiB, over the tile's bound.
    let bound = TileUpload::max_packed_bytes(lease.rect);
    let body = vec![0x5a; 2 << 20];
    assert!(body.len() > bound);
    let (status, err) = put_tile(&c, holder, job.id, 0, Some(lease.epoch), body).await;
    assert_eq!(status, StatusCode::PAYLOAD_TOO_LARGE, "{err}");
    assert!(
        err["error"]
            .as_str()
            .unwrap()
            .contains(&format!("larger than {bound} bytes")),
        "{err}"
    );
}
