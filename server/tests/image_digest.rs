//! The final EXR carries the SHA-256 recorded when it was written (`Repr-Digest`, `ETag`), and
//! bytes changed on disk afterwards are never served as the image.

mod support;

use axum::body::Body;
use axum::http::{HeaderMap, Method, Request, StatusCode};
use base64::Engine;
use http_body_util::BodyExt;
use serde_json::json;
use sha2::Digest;
use spindle_common::protocol::JobState;
use support::*;
use tower::ServiceExt;

async fn get(c: &Coordinator, uri: &str) -> (StatusCode, HeaderMap, Vec<u8>) {
    let request = Request::builder()
        .method(Method::GET)
        .uri(uri)
        .header("authorization", format!("Bearer {CLIENT}"))
        .body(Body::empty())
        .unwrap();
    let response = c.app.clone().oneshot(request).await.unwrap();
    let (status, headers) = (response.status(), response.headers().clone());
    let bytes = response.into_body().collect().await.unwrap().to_bytes();
    (status, headers, bytes.to_vec())
}

#[tokio::test]
async fn the_image_carries_its_digest_and_a_changed_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let job = {
        let c = Coordinator::open(config(dir.path())).await;
        let job = c
            .submit(json!({"scene": scene(32, 16), "tile_size": 8}))
            .await;
        let w = c.register("w").await;
        while let Some(lease) = c.lease(w).await {
            c.upload(job.id, lease.tile_index, &upload_for(&lease, w))
                .await;
        }
        assert_eq!(c.wait_finished(job.id).await.state, JobState::Done);
        job
    };
    // Across a restart too: the digest is stored with the job.
    let c = Coordinator::open(config(dir.path())).await;
    let uri = format!("/v1/jobs/{}/image.exr", job.id);
    let (status, headers, bytes) = get(&c, &uri).await;
    assert_eq!(status, StatusCode::OK);
    let sha256 = sha2::Sha256::digest(&bytes);
    let b64 = base64::engine::general_purpose::STANDARD.encode(sha256);
    assert_eq!(headers["repr-digest"], format!("sha-256=:{b64}:").as_str());
    let hex: String = sha256.iter().map(|b| format!("{b:02x}")).collect();
    assert_eq!(headers["etag"], format!("\"{hex}\"").as_str());

    // One byte changed on disk: neither the image nor its preview is served.
    let path = dir
        .path()
        .join("jobs")
        .join(job.id.to_string())
        .join("image.exr");
    let mut damaged = std::fs::read(&path).unwrap();
    let middle = damaged.len() / 2;
    damaged[middle] ^= 0x01;
    std::fs::write(&path, &damaged).unwrap();
    for uri in [uri.clone(), format!("/v1/jobs/{}/image.png", job.id)] {
        let (status, _, body) = get(&c, &uri).await;
        assert_eq!(status, StatusCode::INTERNAL_SERVER_ERROR, "{uri}");
        let body = String::from_utf8(body).unwrap();
        assert!(
            body.contains(&format!("the image of job {} is damaged", job.id)),
            "{uri}: {body}"
        );
        assert!(
            !body.contains(&*dir.path().to_string_lossy()),
            "no path: {body}"
        );
    }
}
