//! Lease rules: expiry and re-lease with a higher epoch, stale epochs refused while the newer
//! lease succeeds, late identical results acknowledged, different ones refused, and the
//! failure rules: three strikes for tiles and workers, deterministic failures, a tile no
//! connected worker may take, a job with too many failures, and the recent errors on show.

mod support;

use std::time::Duration;

use axum::http::{Method, StatusCode};
use serde_json::json;
use spindle_common::protocol::{JobState, TileUpload, pixel_hash};
use spindle_common::tile_encoding;
use support::*;

/// A coordinator whose leases lapse after `ttl`.
async fn with_ttl(dir: &std::path::Path, ttl: Duration) -> Coordinator {
    let mut config = config(dir);
    config.lease_ttl = ttl;
    Coordinator::open(config).await
}

#[tokio::test]
async fn an_expired_lease_is_leased_again_with_a_higher_epoch_and_the_stale_one_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let c = with_ttl(dir.path(), Duration::from_millis(300)).await;
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let (old, new) = (c.register("old").await, c.register("new").await);
    let first = c.lease(old).await.unwrap();
    assert_eq!(first.epoch, 1);
    assert!(c.lease(new).await.is_none(), "the only tile is leased");

    tokio::time::sleep(Duration::from_millis(450)).await;
    let second = c
        .lease(new)
        .await
        .expect("the lapsed tile is handed out again");
    assert_eq!(
        (second.tile_index, second.epoch),
        (first.tile_index, 2),
        "same tile, next epoch"
    );

    // The presumed-dead worker's heartbeat and upload are stale now.
    let (status, err) = c
        .worker(
            Method::POST,
            &format!("/v1/leases/{}/0/heartbeat", job.id),
            Some(json!({"worker_id": old, "epoch": 1})),
        )
        .await;
    assert_eq!(status, StatusCode::CONFLICT, "{err}");
    assert!(
        err["error"].as_str().unwrap().contains("stale lease"),
        "{err}"
    );
    let (status, err) = c.upload(job.id, 0, &upload_for(&first, old)).await;
    assert_eq!(status, StatusCode::CONFLICT, "{err}");
    assert_eq!(c.job(job.id).await.tiles_done, 0);

    // The newer lease's upload succeeds.
    let (status, ack) = c.upload(job.id, 0, &upload_for(&second, new)).await;
    assert_eq!(status, StatusCode::OK, "{ack}");
    assert_eq!(ack["outcome"], "accepted");

    // Now the late identical result is acknowledged as a duplicate, a different one refused.
    let (status, ack) = c.upload(job.id, 0, &upload_for(&first, old)).await;
    assert_eq!(status, StatusCode::OK, "{ack}");
    assert_eq!(ack["outcome"], "duplicate");
    let mut different = upload_for(&first, old);
    different.pixels.total[0] += 1.0;
    different.hash = pixel_hash(&different.pixels);
    let (status, err) = c.upload(job.id, 0, &different).await;
    assert_eq!(status, StatusCode::CONFLICT, "{err}");
    assert!(
        err["error"].as_str().unwrap().contains("determinism fault"),
        "{err}"
    );

    let info = c.wait_finished(job.id).await;
    assert_eq!(info.state, JobState::Done);
    assert_eq!(info.tiles_done, 1);
    assert_eq!(info.stats.samples, 1, "the duplicate was not counted");
}

#[tokio::test]
async fn a_lapsed_lease_nobody_took_can_still_report() {
    let dir = tempfile::tempdir().unwrap();
    let c = with_ttl(dir.path(), Duration::from_millis(200)).await;
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let w = c.register("slow").await;
    let lease = c.lease(w).await.unwrap();
    tokio::time::sleep(Duration::from_millis(300)).await;
    // Nobody else asked: the slow worker's heartbeat revives its lease, and its upload counts.
    let (status, _) = c
        .worker(
            Method::POST,
            &format!("/v1/leases/{}/0/heartbeat", job.id),
            Some(json!({"worker_id": w, "epoch": lease.epoch})),
        )
        .await;
    assert_eq!(status, StatusCode::OK);
    let (status, ack) = c.upload(job.id, 0, &upload_for(&lease, w)).await;
    assert_eq!(status, StatusCode::OK, "{ack}");
    assert_eq!(c.wait_finished(job.id).await.state, JobState::Done);
}

#[tokio::test]
async fn uploads_are_checked_against_the_lease_and_the_tile() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(16, 8), "tile_size": 8}))
        .await;
    let (a, b) = (c.register("a").await, c.register("b").await);
    let lease = c.lease(a).await.unwrap();

    // Another worker, a future epoch, a wrong hash, a wrong rectangle, a short layer.
    let (status, _) = c
        .upload(job.id, lease.tile_index, &upload_for(&lease, b))
        .await;
    assert_eq!(status, StatusCode::CONFLICT);
    let mut future = upload_for(&lease, a);
    future.epoch += 1;
    assert_eq!(
        c.upload(job.id, lease.tile_index, &future).await.0,
        StatusCode::CONFLICT
    );
    let mut bad_hash = upload_for(&lease, a);
    bad_hash.hash = pixel_hash(&fake_tile(lease.rect, 99));
    let (status, err) = c.upload(job.id, lease.tile_index, &bad_hash).await;
    assert_eq!(status, StatusCode::BAD_REQUEST);
    assert!(err["error"].as_str().unwrap().starts_with("hash:"), "{err}");
    let mut moved = upload_for(&lease, a);
    moved.pixels.rect.x += 1;
    moved.hash = pixel_hash(&moved.pixels);
    let (status, err) = c.upload(job.id, lease.tile_index, &moved).await;
    assert_eq!(status, StatusCode::BAD_REQUEST);
    assert!(
        err["error"].as_str().unwrap().starts_with("pixels.rect:"),
        "{err}"
    );
    let mut short = upload_for(&lease, a);
    short.pixels.surface.pop();
    short.hash = pixel_hash(&short.pixels);
    let (status, err) = c.upload(job.id, lease.tile_index, &short).await;
    assert_eq!(status, StatusCode::BAD_REQUEST);
    assert!(
        err["error"]
            .as_str()
            .unwrap()
            .starts_with("pixels.surface:"),
        "{err}"
    );
    let (status, _) = c.upload(job.id, 77, &upload_for(&lease, a)).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    let (status, _) = c.upload(job.id + 1, 0, &upload_for(&lease, a)).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    assert_eq!(c.job(job.id).await.tiles_done, 0, "nothing was recorded");

    // The real one goes through.
    let good: TileUpload = upload_for(&lease, a);
    assert_eq!(
        c.upload(job.id, lease.tile_index, &good).await.0,
        StatusCode::OK
    );
    assert_eq!(c.job(job.id).await.tiles_done, 1);
}

async fn fail(c: &Coordinator, job: u64, tile: u32, worker: u64, epoch: u64) -> StatusCode {
    c.worker(
        Method::POST,
        &format!("/v1/leases/{job}/{tile}/fail"),
        Some(json!({"worker_id": worker, "epoch": epoch, "reason": format!("worker {worker} broke")})),
    )
    .await
    .0
}

#[tokio::test]
async fn a_tile_failing_on_three_workers_fails_its_job() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let workers = [
        c.register("a").await,
        c.register("b").await,
        c.register("c").await,
    ];
    for (n, &w) in workers.iter().enumerate() {
        let lease = c
            .lease(w)
            .await
            .expect("the tile is offered to a worker that has not failed it");
        assert_eq!((lease.tile_index, lease.epoch), (0, n as u64 + 1));
        assert_eq!(
            fail(&c, job.id, 0, w, lease.epoch).await,
            StatusCode::NO_CONTENT
        );
        // The worker that failed the tile is not given it again.
        if n < 2 {
            assert!(c.lease(w).await.is_none());
        }
    }
    let info = c.job(job.id).await;
    assert_eq!(info.state, JobState::Failed);
    let error = info.error.unwrap();
    assert!(
        error.contains("tile 0") && error.contains("failed on 3 different workers"),
        "{error}"
    );
    assert!(
        error.contains(&format!("worker {} broke", workers[2])),
        "{error}"
    );
    let fresh = c.register("d").await;
    assert!(
        c.lease(fresh).await.is_none(),
        "a failed job hands out nothing"
    );
}

#[tokio::test]
async fn a_worker_failing_three_tiles_of_a_job_is_kept_off_it() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    // 4 × 2 tiles of 8 px.
    let job = c
        .submit(json!({"scene": scene(32, 16), "tile_size": 8}))
        .await;
    let bad = c.register("bad").await;
    // Connected from the start: a tile failed by every connected worker would fail the job.
    let good = c.register("good").await;
    for _ in 0..3 {
        let lease = c.lease(bad).await.unwrap();
        assert_eq!(
            fail(&c, job.id, lease.tile_index, bad, lease.epoch).await,
            StatusCode::NO_CONTENT
        );
    }
    assert!(
        c.lease(bad).await.is_none(),
        "three strikes: no more tiles of this job"
    );
    // Other jobs still come to it.
    let other = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    assert_eq!(c.lease(bad).await.unwrap().job_id, other.id);

    // The good worker finishes the first job, including the tiles the bad one failed.
    let mut done = 0;
    while let Some(lease) = c.lease(good).await {
        let (status, _) = c
            .upload(lease.job_id, lease.tile_index, &upload_for(&lease, good))
            .await;
        assert_eq!(status, StatusCode::OK);
        done += 1;
    }
    assert_eq!(
        done, 8,
        "all 8 tiles of the first job (the second's only tile is leased)"
    );
    let info = c.wait_finished(job.id).await;
    assert_eq!(info.state, JobState::Done, "{:?}", info.error);
}

#[tokio::test]
async fn an_unknown_worker_is_told_to_register() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    // A secret naming a worker the coordinator does not know (it forgot it, say).
    let (status, err) = c
        .send_as(
            Method::POST,
            "/v1/workers/99/lease",
            Some(WORKER),
            Some(&format!("99.{}", "0".repeat(64))),
            r#"{"wait_ms": 0}"#,
        )
        .await;
    let err: serde_json::Value = serde_json::from_slice(&err).unwrap();
    assert_eq!(status, StatusCode::NOT_FOUND);
    assert!(
        err["error"].as_str().unwrap().contains("not registered"),
        "{err}"
    );
}

async fn fail_with(
    c: &Coordinator,
    lease: &spindle_common::protocol::Lease,
    worker: u64,
    reason: &str,
    deterministic: bool,
) -> StatusCode {
    let (status, body) = c
        .worker(
            Method::POST,
            &format!("/v1/leases/{}/{}/fail", lease.job_id, lease.tile_index),
            Some(
                json!({"worker_id": worker, "epoch": lease.epoch, "reason": reason,
                        "deterministic": deterministic}),
            ),
        )
        .await;
    assert_eq!(status, StatusCode::NO_CONTENT, "{body}");
    status
}

#[tokio::test]
async fn with_two_workers_a_tile_both_failed_fails_its_job_instead_of_hanging() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let (a, b) = (c.register("alpha").await, c.register("beta").await);
    let lease = c.lease(a).await.unwrap();
    fail_with(&c, &lease, a, "alpha broke", false).await;
    assert_eq!(
        c.job(job.id).await.state,
        JobState::Running,
        "beta may still render the tile"
    );
    let lease = c.lease(b).await.expect("beta gets the tile alpha failed");
    fail_with(&c, &lease, b, "beta broke", false).await;
    let info = c.job(job.id).await;
    assert_eq!(info.state, JobState::Failed);
    let error = info.error.unwrap();
    assert!(
        error.contains("tile 0")
            && error.contains(&format!("alpha ({a}), beta ({b})"))
            && error.contains("no other connected worker may take it; last error")
            && error.contains("beta broke"),
        "{error}"
    );
    // A sentence for people: the tile's rectangle in words, no Rust debug text.
    assert!(
        error.contains("tile 0 (8 × 8 pixels at x 0, y 0)")
            && !error.contains("TileRect {")
            && !error.contains("  "),
        "{error}"
    );
}

#[tokio::test]
async fn a_failed_tile_fails_its_job_once_the_workers_that_could_take_it_are_gone() {
    let dir = tempfile::tempdir().unwrap();
    let c = with_ttl(dir.path(), Duration::from_millis(300)).await;
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let (a, _b) = (c.register("alpha").await, c.register("beta").await);
    let lease = c.lease(a).await.unwrap();
    fail_with(&c, &lease, a, "alpha broke", false).await;
    assert_eq!(c.job(job.id).await.state, JobState::Running);
    // beta never asks for work: after a lease TTL it no longer counts as connected.
    tokio::time::sleep(Duration::from_millis(450)).await;
    assert!(
        c.lease(a).await.is_none(),
        "alpha may not take the tile again"
    );
    let info = c.job(job.id).await;
    assert_eq!(info.state, JobState::Failed, "{info:?}");
    assert!(
        info.error.as_deref().unwrap().contains("alpha broke"),
        "{info:?}"
    );
}

#[tokio::test]
async fn a_deterministic_failure_confirmed_by_a_second_worker_fails_the_job_and_errors_are_shown() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(16, 8), "tile_size": 8}))
        .await;
    let workers = [
        c.register("alpha").await,
        c.register("beta").await,
        c.register("gamma").await,
    ];
    let before = spindle_server::clock::now_ms();
    let lease = c.lease(workers[0]).await.unwrap();
    let reason = "the scene does not build: objects[0].shape: face index 9 out of range";
    fail_with(&c, &lease, workers[0], reason, true).await;
    assert_eq!(
        c.job(job.id).await.state,
        JobState::Running,
        "one worker's claim"
    );
    let second = c.lease(workers[1]).await.unwrap();
    assert_eq!(second.tile_index, lease.tile_index);
    fail_with(&c, &second, workers[1], reason, true).await;
    let info = c.job(job.id).await;
    assert_eq!(info.state, JobState::Failed);
    let error = info.error.unwrap();
    assert!(
        error.contains(reason) && error.contains("alpha") && error.contains("beta"),
        "{error}"
    );
    assert!(
        error.contains(&format!(
            "tile {} (8 × 8 pixels at x {}, y 0) cannot be rendered",
            lease.tile_index, lease.rect.x
        )) && !error.contains("TileRect {"),
        "{error}"
    );
    assert_eq!(info.recent_errors.len(), 2);
    let e = &info.recent_errors[0];
    assert_eq!(
        (e.tile, e.worker_id, e.worker.as_str(), e.message.as_str()),
        (lease.tile_index, workers[0], "alpha", reason)
    );
    assert!(e.at_ms >= before, "{e:?}");
    assert!(
        c.lease(workers[2]).await.is_none(),
        "nothing more is handed out"
    );
}

#[tokio::test]
async fn ten_failures_in_a_job_fail_it_and_only_the_newest_errors_are_kept() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    // 4 × 4 tiles of 8 px.
    let job = c
        .submit(json!({"scene": scene(32, 32), "tile_size": 8}))
        .await;
    let mut workers = Vec::new();
    for n in 0..12 {
        workers.push(c.register(&format!("w{n}")).await);
    }
    // Ten different tiles on ten different workers: no tile reaches three failures.
    let mut leases = Vec::new();
    for &w in workers.iter().take(10) {
        leases.push((w, c.lease(w).await.unwrap()));
    }
    for (n, (w, lease)) in leases.iter().enumerate() {
        assert!(
            !c.job(job.id).await.state.is_finished(),
            "after {n} failures"
        );
        fail_with(&c, lease, *w, &format!("failure {n}"), false).await;
    }
    let info = c.job(job.id).await;
    assert_eq!(info.state, JobState::Failed);
    let error = info.error.unwrap();
    assert!(
        error.starts_with("10 tile failures in this job") && error.contains("failure 9"),
        "{error}"
    );
    let kept: Vec<&str> = info
        .recent_errors
        .iter()
        .map(|e| e.message.as_str())
        .collect();
    assert_eq!(
        kept,
        [
            "failure 5",
            "failure 6",
            "failure 7",
            "failure 8",
            "failure 9"
        ]
    );
}

#[tokio::test]
async fn a_job_says_how_many_workers_are_connected() {
    let dir = tempfile::tempdir().unwrap();
    let c = with_ttl(dir.path(), Duration::from_millis(300)).await;
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    assert_eq!(c.job(job.id).await.workers_live, 0);
    let a = c.register("alpha").await;
    assert_eq!(c.job(job.id).await.workers_live, 1);
    let lease = c.lease(a).await.unwrap();
    tokio::time::sleep(Duration::from_millis(450)).await;
    assert_eq!(
        c.job(job.id).await.workers_live,
        0,
        "silent for a lease TTL: gone"
    );
    let (status, _) = c.upload(job.id, 0, &upload_for(&lease, a)).await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(c.job(job.id).await.workers_live, 1, "heard from again");
}

#[tokio::test]
async fn an_upload_beyond_f32_is_refused_naming_the_value() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let w = c.register("w").await;
    let lease = c.lease(w).await.unwrap();
    // The hash of what a lenient parser would read (+inf), so only the value is wrong.
    let mut read_as = upload_for(&lease, w);
    read_as.pixels.total[4] = f32::INFINITY;
    let mut body = serde_json::to_value(&read_as).unwrap();
    body["hash"] = json!(pixel_hash(&read_as.pixels));
    body["pixels"]["total"][4] = json!(1e39);
    let (status, err) = c
        .worker(
            Method::PUT,
            &format!("/v1/jobs/{}/tiles/0", job.id),
            Some(body),
        )
        .await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{err}");
    let message = err["error"].as_str().unwrap();
    assert!(
        message.starts_with("pixels.total: value 4 is 1e39, beyond the range of 32-bit floats"),
        "{message}"
    );
    assert_eq!(c.job(job.id).await.tiles_done, 0);
    // The preview still renders (it used to answer 500 once +inf was stored).
    let (status, _) = c
        .send(
            Method::GET,
            &format!("/v1/jobs/{}/image.png", job.id),
            Some(CLIENT),
            "",
        )
        .await;
    assert_eq!(status, StatusCode::OK);
}

#[tokio::test]
async fn compact_uploads_are_read_and_bad_ones_refused_with_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(16, 8), "tile_size": 8}))
        .await;
    let w = c.register("w").await;
    let first = c.lease(w).await.unwrap();
    let second = c.lease(w).await.unwrap();
    let compact = tile_encoding::CONTENT_TYPE;

    // Another media type: 415 naming the header; not zstd: 400 naming the body.
    let body = serde_json::to_vec(&upload_for(&first, w)).unwrap();
    let (status, err) = c
        .upload_bytes(job.id, first.tile_index, "text/plain", body)
        .await;
    assert_eq!(status, StatusCode::UNSUPPORTED_MEDIA_TYPE, "{err}");
    assert!(
        err["error"].as_str().unwrap().starts_with("Content-Type:"),
        "{err}"
    );
    let (status, err) = c
        .upload_bytes(job.id, first.tile_index, compact, b"not zstd".to_vec())
        .await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{err}");
    assert!(
        err["error"]
            .as_str()
            .unwrap()
            .starts_with("body: not a zstd frame"),
        "{err}"
    );

    // A value beyond f32 in the compact form: 400 naming the layer and the value.
    let mut wide = serde_json::to_value(upload_for(&first, w)).unwrap();
    wide["pixels"]["total"][2] = json!(1e39);
    let (status, err) = c
        .upload_bytes(
            job.id,
            first.tile_index,
            compact,
            tile_encoding::encode(&wide).unwrap(),
        )
        .await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{err}");
    assert!(
        err["error"]
            .as_str()
            .unwrap()
            .starts_with("pixels.total: value 2 is 1e39"),
        "{err}"
    );

    // Both forms complete their tiles, and the job finishes.
    let encoded = tile_encoding::encode(&upload_for(&first, w)).unwrap();
    let (status, ack) = c
        .upload_bytes(job.id, first.tile_index, compact, encoded)
        .await;
    assert_eq!(
        (status, ack["outcome"].as_str()),
        (StatusCode::OK, Some("accepted"))
    );
    let (status, ack) = c
        .upload(job.id, second.tile_index, &upload_for(&second, w))
        .await;
    assert_eq!(
        (status, ack["outcome"].as_str()),
        (StatusCode::OK, Some("accepted"))
    );
    assert_eq!(c.wait_finished(job.id).await.state, JobState::Done);
}

/// `GET /v1/leases/{job}/{tile}/previous` answers only the tile's leaseholder, and only when
/// there is a previous pass: 404 for a job without a time budget or a tile in its first pass,
/// 409 for another worker, 403 without a worker secret.
#[tokio::test]
async fn the_previous_pass_is_refused_to_all_but_its_leaseholder() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let mut budgeted = scene(8, 8);
    budgeted["film"]["time_budget_s"] = json!(60);
    let budgeted = c.submit(json!({"scene": budgeted, "tile_size": 8})).await;
    let plain = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let holder = c.register("holder").await;
    let other = c.register("other").await;
    let first = c.lease(holder).await.unwrap();
    let second = c.lease(holder).await.unwrap();
    assert_eq!(
        (first.pass, second.pass),
        (Some(1), None),
        "{first:?} {second:?}"
    );
    let previous = |job: u64| format!("/v1/leases/{job}/0/previous");
    let error = |bytes: &[u8]| {
        serde_json::from_slice::<serde_json::Value>(bytes).unwrap()["error"]
            .as_str()
            .unwrap()
            .to_string()
    };

    let ask = |job: u64, worker: u64| {
        let secret = c.secret(worker);
        let uri = previous(job);
        let c = c.share();
        async move {
            c.send_as(Method::GET, &uri, Some(WORKER), Some(&secret), "")
                .await
        }
    };
    let (status, body) = ask(budgeted.id, holder).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    assert!(
        error(&body).contains("has no previous pass"),
        "{}",
        error(&body)
    );
    let (status, body) = ask(plain.id, holder).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    assert!(
        error(&body).contains("has no time budget"),
        "{}",
        error(&body)
    );
    let (status, body) = ask(budgeted.id, other).await;
    assert_eq!(status, StatusCode::CONFLICT);
    assert!(
        error(&body).contains("is not leased to worker"),
        "{}",
        error(&body)
    );
    let (status, body) = c
        .send_as(Method::GET, &previous(budgeted.id), Some(WORKER), None, "")
        .await;
    assert_eq!(status, StatusCode::FORBIDDEN);
    assert!(error(&body).contains("worker secret"), "{}", error(&body));
}

#[tokio::test]
async fn one_workers_deterministic_failure_is_a_claim_that_a_second_worker_confirms() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let (liar, honest, third) = (
        c.register("liar").await,
        c.register("honest").await,
        c.register("third").await,
    );
    // One identity claims the tile cannot be rendered anywhere: the job goes on.
    let lease = c.lease(liar).await.unwrap();
    fail_with(&c, &lease, liar, "forged: the scene does not build", true).await;
    assert_eq!(c.job(job.id).await.state, JobState::Running);
    // Another worker takes the tile (not the claimant) and renders it.
    assert!(
        c.lease(liar).await.is_none(),
        "the claimant is not given it again"
    );
    let lease = c.lease(honest).await.expect("another worker gets the tile");
    let (status, ack) = c.upload(job.id, 0, &upload_for(&lease, honest)).await;
    assert_eq!(status, StatusCode::OK, "{ack}");
    assert_eq!(c.wait_finished(job.id).await.state, JobState::Done);

    // A scene that really fails: two different workers say so, and the job fails then.
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let reason = "the scene does not build: objects[0].shape: face index 9 out of range";
    let lease = c.lease(honest).await.unwrap();
    fail_with(&c, &lease, honest, reason, true).await;
    assert_eq!(c.job(job.id).await.state, JobState::Running);
    let lease = c.lease(third).await.unwrap();
    fail_with(&c, &lease, third, reason, true).await;
    let info = c.job(job.id).await;
    assert_eq!(info.state, JobState::Failed);
    let error = info.error.unwrap();
    assert!(
        error.contains("2 workers found so") && error.contains(reason),
        "{error}"
    );
}

/// docs/promises.md: with one connected worker nobody can confirm its claim or do better, so
/// its report fails the job at once, naming the tile, the worker and its reason, instead of
/// leaving the job waiting for a worker that may never come.
#[tokio::test]
async fn the_only_connected_workers_deterministic_failure_fails_the_job_naming_why() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let alone = c.register("alone").await;
    let lease = c.lease(alone).await.unwrap();
    let reason = "the scene does not build: objects[0].shape: face index 9 out of range";
    fail_with(&c, &lease, alone, reason, true).await;
    let info = c.job(job.id).await;
    assert_eq!(info.state, JobState::Failed, "{info:?}");
    assert_eq!(info.workers_live, 1);
    let error = info.error.unwrap();
    assert_eq!(
        error,
        format!(
            "tile 0 (8 × 8 pixels at x 0, y 0) failed on alone ({alone}) and no other connected \
             worker may take it; last error: {reason} (worker alone)"
        )
    );
    assert!(c.lease(alone).await.is_none(), "nothing more is handed out");
}

#[tokio::test]
async fn a_lease_kept_alive_by_heartbeats_alone_is_taken_back_at_its_greatest_age() {
    let dir = tempfile::tempdir().unwrap();
    let ttl = Duration::from_millis(100);
    let c = with_ttl(dir.path(), ttl).await;
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let (squatter, honest) = (c.register("squatter").await, c.register("honest").await);
    let lease = c.lease(squatter).await.unwrap();
    // Heartbeats every half TTL and nothing else, for up to three times the greatest age.
    let greatest = ttl * spindle_server::ledger::rules::MAX_LEASE_AGE_TTLS;
    let started = std::time::Instant::now();
    let refused = loop {
        let (status, _) = c
            .worker(
                Method::POST,
                &format!("/v1/leases/{}/0/heartbeat", job.id),
                Some(json!({"worker_id": squatter, "epoch": lease.epoch})),
            )
            .await;
        if status != StatusCode::OK {
            break status;
        }
        assert!(c.lease(honest).await.is_none(), "the tile is held");
        assert!(
            started.elapsed() < 3 * greatest,
            "the lease was never taken back"
        );
        tokio::time::sleep(ttl / 2).await;
    };
    assert_eq!(refused, StatusCode::CONFLICT);
    assert!(started.elapsed() >= greatest, "taken back before its age");
    let lease = c
        .lease(honest)
        .await
        .expect("the tile goes to another worker");
    let (status, ack) = c.upload(job.id, 0, &upload_for(&lease, honest)).await;
    assert_eq!(status, StatusCode::OK, "{ack}");
    assert_eq!(c.wait_finished(job.id).await.state, JobState::Done);
}
