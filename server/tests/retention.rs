//! Nothing is kept forever: a finished job holds no per-tile state in memory (nor after a
//! restart), a done job's tile rows go with the commit that records it done, finished jobs are deleted
//! after their retention, assets no job names after a grace period, lost workers after a while;
//! `max_active_jobs` counts live jobs only.

mod support;

use std::time::Duration;

use axum::http::{Method, StatusCode};
use serde_json::json;
use spindle_common::protocol::{JobState, asset_hash};
use spindle_server::Config;
use support::*;

/// 2048 × 2048 px in 8-px tiles: 65,536 tiles, the per-job limit.
fn big_job() -> serde_json::Value {
    json!({"scene": scene(2048, 2048), "tile_size": 8})
}

/// Polls `check` every 20 ms for up to 3 s.
async fn eventually(what: &str, mut check: impl AsyncFnMut() -> bool) {
    for _ in 0..150 {
        if check().await {
            return;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    panic!("not within 3 s: {what}");
}

fn fast_sweep(dir: &std::path::Path) -> Config {
    let mut cfg = config(dir);
    cfg.retention.sweep_interval = Duration::from_millis(20);
    cfg
}

#[tokio::test]
async fn a_finished_job_keeps_no_tile_state_in_memory_nor_after_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let (big, small) = {
        let c = Coordinator::open(config(dir.path())).await;
        let big = c.submit(big_job()).await;
        assert_eq!(big.tiles_total, 65_536);
        assert_eq!(
            c.state.tiles_in_memory(),
            65_536,
            "a live job tracks its tiles"
        );
        let (status, v) = c
            .client(Method::POST, &format!("/v1/jobs/{}/cancel", big.id), None)
            .await;
        assert_eq!(status, StatusCode::OK, "{v}");
        assert_eq!(c.state.tiles_in_memory(), 0, "a cancelled job keeps none");

        let small = c
            .submit(json!({"scene": scene(32, 16), "tile_size": 8}))
            .await;
        assert_eq!(c.state.tiles_in_memory(), 8);
        let w = c.register("w").await;
        while let Some(lease) = c.lease(w).await {
            c.upload(small.id, lease.tile_index, &upload_for(&lease, w))
                .await;
        }
        let done = c.wait_finished(small.id).await;
        assert_eq!(done.state, JobState::Done);
        assert_eq!(c.state.tiles_in_memory(), 0, "a done job keeps none");
        let job_dir = dir.path().join("jobs").join(small.id.to_string());
        assert!(job_dir.join("image.exr").is_file());
        assert_eq!(
            tile_rows(dir.path(), small.id),
            0,
            "a done job's tiles go with the commit that records it done"
        );
        (big, done)
    };

    let c = Coordinator::open(config(dir.path())).await;
    assert_eq!(
        c.state.tiles_in_memory(),
        0,
        "a restart loads no finished job's tiles"
    );
    let reloaded = c.job(small.id).await;
    assert_eq!(
        (reloaded.tiles_done, reloaded.stats, reloaded.state),
        (8, small.stats, JobState::Done),
        "a done job's counts survive its tile rows"
    );
    for image in ["image.exr", "image.png"] {
        let (status, _) = c
            .send(
                Method::GET,
                &format!("/v1/jobs/{}/{image}", small.id),
                Some(CLIENT),
                "",
            )
            .await;
        assert_eq!(status, StatusCode::OK, "{image}");
    }
    // A requeued job is live again and tracks its tiles again.
    let (status, v) = c
        .client(Method::POST, &format!("/v1/jobs/{}/requeue", big.id), None)
        .await;
    assert_eq!(status, StatusCode::OK, "{v}");
    assert_eq!(c.state.tiles_in_memory(), 65_536);
}

#[tokio::test]
async fn finished_jobs_are_deleted_after_their_retention_and_live_ones_kept() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = fast_sweep(dir.path());
    cfg.retention.keep_finished = Some(Duration::from_millis(200));
    let c = Coordinator::open(cfg).await;
    let finished = c
        .submit(json!({"scene": scene(32, 16), "tile_size": 8}))
        .await;
    let live = c
        .submit(json!({"scene": scene(32, 16), "tile_size": 8}))
        .await;
    let (status, _) = c
        .client(
            Method::POST,
            &format!("/v1/jobs/{}/cancel", finished.id),
            None,
        )
        .await;
    assert_eq!(status, StatusCode::OK);
    assert!(dir.path().join("spindle.db").is_file());
    eventually("the cancelled job is deleted", async || {
        c.client(Method::GET, &format!("/v1/jobs/{}", finished.id), None)
            .await
            .0
            == StatusCode::NOT_FOUND
    })
    .await;
    assert_eq!(
        c.job(live.id).await.state,
        JobState::Queued,
        "a live job is kept"
    );
    assert!(
        !dir.path()
            .join("jobs")
            .join(finished.id.to_string())
            .exists()
    );
    drop(c);
    let c = Coordinator::open(config(dir.path())).await;
    let (status, _) = c
        .client(Method::GET, &format!("/v1/jobs/{}", finished.id), None)
        .await;
    assert_eq!(status, StatusCode::NOT_FOUND, "its rows are gone too");
}

#[tokio::test]
async fn unreferenced_assets_go_after_the_grace_period_and_named_ones_stay() {
    let dir = tempfile::tempdir().unwrap();
    let named = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n".to_vec();
    let unnamed = b"v 0 0 0\nv 2 0 0\nv 2 2 0\nf 1 2 3\n".to_vec();
    let (named_hash, unnamed_hash) = (asset_hash(&named), asset_hash(&unnamed));
    let stored = |hash: &str| dir.path().join("assets").join(hash).is_file();
    {
        // Within the grace period an asset no job names yet survives: a client uploads its
        // assets first, then submits.
        let mut cfg = fast_sweep(dir.path());
        cfg.retention.asset_grace = Duration::from_secs(3600);
        let c = Coordinator::open(cfg).await;
        for (hash, bytes) in [(&named_hash, &named), (&unnamed_hash, &unnamed)] {
            let (status, _) = c
                .send(
                    Method::PUT,
                    &format!("/v1/assets/{hash}"),
                    Some(CLIENT),
                    bytes.clone(),
                )
                .await;
            assert_eq!(status, StatusCode::OK);
        }
        tokio::time::sleep(Duration::from_millis(150)).await;
        assert!(stored(&named_hash) && stored(&unnamed_hash));
        let mut s = scene(8, 8);
        s["objects"].as_array_mut().unwrap().push(json!({
            "shape": {"type": "obj", "path": "m.obj"},
            "material": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}
        }));
        c.submit(json!({"scene": s, "assets": {"m.obj": named_hash}}))
            .await;
    }
    let mut cfg = fast_sweep(dir.path());
    cfg.retention.asset_grace = Duration::ZERO;
    let c = Coordinator::open(cfg).await;
    eventually("the unnamed asset is deleted", async || {
        !stored(&unnamed_hash)
    })
    .await;
    assert!(stored(&named_hash), "an asset a job names is kept");
    let (_, v) = c
        .client(
            Method::POST,
            "/v1/assets/missing",
            Some(json!({"hashes": [named_hash, unnamed_hash]})),
        )
        .await;
    assert_eq!(v["missing"], json!([unnamed_hash]));
}

#[tokio::test]
async fn lost_workers_are_forgotten_after_a_while_and_must_register_again() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = fast_sweep(dir.path());
    cfg.lease_ttl = Duration::from_millis(100);
    cfg.retention.keep_lost_workers = Duration::from_millis(100);
    let c = Coordinator::open(cfg).await;
    let w = c.register("w").await;
    let (_, list) = c.client(Method::GET, "/v1/workers", None).await;
    assert_eq!(list["workers"].as_array().unwrap().len(), 1, "{list}");
    eventually("the lost worker is forgotten", async || {
        let (_, list) = c.client(Method::GET, "/v1/workers", None).await;
        list["workers"].as_array().unwrap().is_empty()
    })
    .await;
    let (status, v) = c
        .worker(
            Method::POST,
            &format!("/v1/workers/{w}/lease"),
            Some(json!({"wait_ms": 0})),
        )
        .await;
    assert_eq!(status, StatusCode::NOT_FOUND, "{v}");
    assert!(
        v["error"].as_str().unwrap().contains("not registered"),
        "{v}"
    );
}

#[tokio::test]
async fn max_active_jobs_counts_live_jobs_only() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.limits.max_active_jobs = 1;
    let c = Coordinator::open(cfg).await;
    let body = json!({"scene": scene(32, 16), "tile_size": 8});
    let first = c.submit(body.clone()).await;
    c.client(Method::POST, &format!("/v1/jobs/{}/pause", first.id), None)
        .await;
    let (status, v) = c.client(Method::POST, "/v1/jobs", Some(body.clone())).await;
    assert_eq!(
        status,
        StatusCode::TOO_MANY_REQUESTS,
        "a paused job is live: {v}"
    );
    c.client(Method::POST, &format!("/v1/jobs/{}/cancel", first.id), None)
        .await;
    c.submit(body).await; // the cancelled one does not count
}
