//! Worker identity: a worker's requests carry the secret its registration gave it; nobody can
//! touch another worker's leases with the shared worker token alone; registrations are capped;
//! secrets survive a restart.

mod support;

use axum::http::{Method, StatusCode};
use serde_json::{Value, json};
use spindle_common::protocol::JobState;
use support::*;

fn error_of(bytes: &[u8]) -> String {
    serde_json::from_slice::<Value>(bytes).unwrap()["error"]
        .as_str()
        .unwrap()
        .to_string()
}

/// A second worker (or anyone with the worker token) forging `worker_id` of the lease holder:
/// heartbeat, fail and upload are 403 whatever secret it has, and the tile stays leased to its
/// worker, which then delivers it.
#[tokio::test]
async fn another_workers_lease_cannot_be_touched() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let victim = c.register("victim").await;
    let attacker = c.register("attacker").await;
    let lease = c.lease(victim).await.unwrap();
    let tile = lease.tile_index;
    let heartbeat = json!({"worker_id": victim, "epoch": lease.epoch}).to_string();
    let fail = json!({"worker_id": victim, "epoch": lease.epoch, "reason": "forged",
                      "deterministic": true})
    .to_string();
    let upload = serde_json::to_string(&upload_for(&lease, victim)).unwrap();
    let calls = [
        (
            Method::POST,
            format!("/v1/leases/{}/{tile}/heartbeat", job.id),
            heartbeat,
        ),
        (
            Method::POST,
            format!("/v1/leases/{}/{tile}/fail", job.id),
            fail.clone(),
        ),
        (
            Method::PUT,
            format!("/v1/jobs/{}/tiles/{tile}", job.id),
            upload,
        ),
        (
            Method::POST,
            format!("/v1/workers/{victim}/lease"),
            r#"{"wait_ms": 0}"#.to_string(),
        ),
    ];
    let attacker_secret = c.secret(attacker);
    let guessed = format!("{victim}.{}", "0".repeat(64));
    for (method, uri, body) in &calls {
        for secret in [Some(attacker_secret.as_str()), Some(guessed.as_str()), None] {
            let (status, bytes) = c
                .send_as(method.clone(), uri, Some(WORKER), secret, body.clone())
                .await;
            let error = error_of(&bytes);
            // An upload is judged by its path and the caller's own secret before its body
            // (and the forged id in it) is read: the tile is not the caller's lease, 409.
            if *method == Method::PUT && secret == Some(attacker_secret.as_str()) {
                assert_eq!(status, StatusCode::CONFLICT, "{uri}: {error}");
                assert!(error.contains("stale lease"), "{error}");
                continue;
            }
            assert_eq!(status, StatusCode::FORBIDDEN, "{method} {uri} {secret:?}");
            assert!(error.contains("worker secret"), "{error}");
        }
    }
    // Three forged deterministic failures would have failed the job; it is untouched.
    let info = c.job(job.id).await;
    assert_eq!(info.state, JobState::Running);
    assert_eq!(info.tiles_done, 0);
    // The victim still holds its lease and delivers the tile.
    let (status, v) = c.upload(job.id, tile, &upload_for(&lease, victim)).await;
    assert_eq!(
        (status, v["outcome"].as_str()),
        (StatusCode::OK, Some("accepted"))
    );
    assert_eq!(c.wait_finished(job.id).await.state, JobState::Done);
}

/// Every worker route but registration needs a secret, also those that name no worker.
#[tokio::test]
async fn worker_routes_need_a_worker_secret() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let w = c.register("w").await;
    let uri = format!("/v1/jobs/{}/spec", job.id);
    for secret in [None, Some("garbage"), Some("1.abc")] {
        let (status, bytes) = c.send_as(Method::GET, &uri, Some(WORKER), secret, "").await;
        assert_eq!(status, StatusCode::FORBIDDEN, "{secret:?}");
        assert!(error_of(&bytes).contains("worker secret"));
    }
    let (status, _) = c
        .send_as(Method::GET, &uri, Some(WORKER), Some(&c.secret(w)), "")
        .await;
    assert_eq!(status, StatusCode::OK);
    // An unknown worker is told to register (404), not refused.
    let (status, _) = c
        .send_as(
            Method::GET,
            &uri,
            Some(WORKER),
            Some(&format!("99.{}", "0".repeat(64))),
            "",
        )
        .await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    // The document says so.
    let (_, doc) = c.client(Method::GET, "/v1/openapi.json", None).await;
    let spec = &doc["paths"]["/v1/jobs/{id}/spec"]["get"];
    assert!(spec["security"][0]["worker_secret"].is_array(), "{spec}");
    assert!(spec["responses"]["403"].is_object(), "{spec}");
    let register = &doc["paths"]["/v1/workers"]["post"];
    assert!(
        register["security"][0]["worker_secret"].is_null(),
        "{register}"
    );
    assert_eq!(
        doc["components"]["securitySchemes"]["worker_secret"]["name"],
        "Spindle-Worker-Secret"
    );
}

/// At `--max-workers`, a registration is refused (429, Retry-After) while every registered
/// worker is connected, and takes the place of a lost one otherwise.
#[tokio::test]
async fn registrations_are_capped() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.max_workers = 2;
    cfg.lease_ttl = std::time::Duration::from_millis(300);
    let c = Coordinator::open(cfg).await;
    let first = c.register("a").await;
    c.register("b").await;
    let (status, v) = c
        .worker(
            Method::POST,
            "/v1/workers",
            Some(json!({"name": "c", "threads": 1})),
        )
        .await;
    assert_eq!(status, StatusCode::TOO_MANY_REQUESTS, "{v}");
    assert!(
        v["error"].as_str().unwrap().contains("--max-workers"),
        "{v}"
    );
    // Once the first two are lost (a lease TTL without a word), a newcomer takes the place
    // of the one heard from longest ago, and that one must register again.
    tokio::time::sleep(std::time::Duration::from_millis(400)).await;
    c.register("c").await;
    let (status, _) = c
        .worker(
            Method::POST,
            &format!("/v1/workers/{first}/lease"),
            Some(json!({"wait_ms": 0})),
        )
        .await;
    assert_eq!(
        status,
        StatusCode::NOT_FOUND,
        "the forgotten worker re-registers"
    );
}

/// The coordinator keeps the secrets' digests in its database: after a restart a worker goes
/// on with the secret it has, and a wrong one is still refused.
#[tokio::test]
async fn a_worker_secret_survives_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let (w, secret) = {
        let c = Coordinator::open(config(dir.path())).await;
        let w = c.register("w").await;
        (w, c.secret(w))
    };
    let c = Coordinator::open(config(dir.path())).await;
    let uri = format!("/v1/workers/{w}/lease");
    let (status, bytes) = c
        .send_as(
            Method::POST,
            &uri,
            Some(WORKER),
            Some(&secret),
            r#"{"wait_ms": 0}"#,
        )
        .await;
    assert_eq!(
        status,
        StatusCode::NO_CONTENT,
        "{}",
        String::from_utf8_lossy(&bytes)
    );
    let mut wrong = secret.clone();
    let last = if wrong.ends_with('0') { "1" } else { "0" };
    wrong.replace_range(wrong.len() - 1.., last);
    let (status, _) = c
        .send_as(
            Method::POST,
            &uri,
            Some(WORKER),
            Some(&wrong),
            r#"{"wait_ms": 0}"#,
        )
        .await;
    assert_eq!(status, StatusCode::FORBIDDEN);
}
