//! A job from submission to its final EXR, with fake tiles of constant colour: tiles are
//! leased centre-first, progress is counted, the image holds each tile's colour where the tile
//! lies, statistics add up, and the file's bytes do not depend on arrival order or worker.

mod support;

use axum::http::{Method, StatusCode};
use serde_json::json;
use spindle_common::image::Image;
use spindle_common::protocol::{JobState, Lease};
use spindle_common::tile::{LAYERS, split_centre_first};
use support::*;

const W: u32 = 40;
const H: u32 = 24;
const TILE: u32 = 16;

/// Leases every tile of the only job, alternating between two workers.
async fn lease_all(c: &Coordinator, workers: [u64; 2]) -> Vec<(Lease, u64)> {
    let mut leases = Vec::new();
    for i in 0.. {
        let worker = workers[i % 2];
        match c.lease(worker).await {
            Some(lease) => leases.push((lease, worker)),
            None => break,
        }
    }
    leases
}

#[tokio::test]
async fn a_job_goes_from_submission_to_a_correct_exr() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(W, H), "tile_size": TILE, "priority": 1}))
        .await;
    let rects = split_centre_first(W, H, TILE);
    assert_eq!(job.state, JobState::Queued);
    assert_eq!((job.tiles_done, job.tiles_total), (0, rects.len() as u32));
    assert_eq!((job.width, job.height, job.tile_size), (W, H, TILE));

    let (a, b) = (c.register("a").await, c.register("b").await);
    let leases = lease_all(&c, [a, b]).await;
    // Every tile is handed out once, in centre-first (index) order, with its rectangle.
    assert_eq!(leases.len(), rects.len());
    for (i, (lease, _)) in leases.iter().enumerate() {
        assert_eq!(lease.job_id, job.id);
        assert_eq!(lease.tile_index, i as u32);
        assert_eq!(lease.rect, rects[i]);
        assert_eq!(lease.epoch, 1);
    }
    assert_eq!(c.job(job.id).await.state, JobState::Running);

    // A heartbeat renews a lease that is the worker's own.
    let (lease, worker) = &leases[0];
    let (status, ack) = c
        .worker(
            Method::POST,
            &format!("/v1/leases/{}/{}/heartbeat", job.id, lease.tile_index),
            Some(json!({"worker_id": worker, "epoch": lease.epoch})),
        )
        .await;
    assert_eq!(status, StatusCode::OK, "{ack}");
    assert_eq!(ack["ttl_ms"], 30_000);

    // The image is not there before the job is done; the preview is, at the film's size.
    let (status, err) = c
        .client(Method::GET, &format!("/v1/jobs/{}/image.exr", job.id), None)
        .await;
    assert_eq!(status, StatusCode::CONFLICT, "{err}");
    let (status, png) = c
        .send(
            Method::GET,
            &format!("/v1/jobs/{}/image.png", job.id),
            Some(CLIENT),
            "",
        )
        .await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(&png[1..4], b"PNG");
    assert_eq!(u32::from_be_bytes(png[16..20].try_into().unwrap()), W);
    assert_eq!(u32::from_be_bytes(png[20..24].try_into().unwrap()), H);

    // Upload in reverse order; progress counts each tile once.
    for (n, (lease, worker)) in leases.iter().rev().enumerate() {
        let (status, ack) = c
            .upload(job.id, lease.tile_index, &upload_for(lease, *worker))
            .await;
        assert_eq!(status, StatusCode::OK, "{ack}");
        assert_eq!(ack["outcome"], "accepted");
        if n + 1 < leases.len() {
            let info = c.job(job.id).await;
            assert_eq!(info.tiles_done, n as u32 + 1);
            assert!(info.eta_s.is_some());
        }
    }
    let info = c.wait_finished(job.id).await;
    assert_eq!(info.state, JobState::Done, "{:?}", info.error);
    assert_eq!(info.tiles_done, info.tiles_total);
    assert_eq!(
        info.stats.camera_rays,
        (W * H) as u64,
        "one ray per pixel, counted once"
    );
    assert_eq!(info.stats.samples, rects.len() as u64);

    let (status, exr) = c
        .send(
            Method::GET,
            &format!("/v1/jobs/{}/image.exr", job.id),
            Some(CLIENT),
            "",
        )
        .await;
    assert_eq!(status, StatusCode::OK);
    let image = Image::from_exr_bytes(&exr).unwrap();
    assert_eq!((image.width, image.height), (W, H));
    for (index, rect) in rects.iter().enumerate() {
        for row in rect.y..rect.y + rect.height {
            for col in rect.x..rect.x + rect.width {
                for (layer, values) in image.layers().iter().enumerate() {
                    let channels = LAYERS[layer].channels;
                    for channel in 0..channels {
                        let v = values[(row * W + col) as usize * channels + channel];
                        assert_eq!(
                            v,
                            tile_colour(index as u32, layer, channel),
                            "{} at ({col}, {row})",
                            LAYERS[layer].name
                        );
                    }
                }
            }
        }
    }
    assert_eq!(
        image.attributes["spindle.stats.camera_rays"],
        (W * H).to_string()
    );
    assert_eq!(image.attributes["spindle.spp"], "2");

    // Nothing is left to lease; the job list shows the job.
    assert!(c.lease(a).await.is_none());
    let (status, list) = c.client(Method::GET, "/v1/jobs", None).await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(list["jobs"].as_array().unwrap().len(), 1);

    // Delete removes it and its files.
    let (status, _) = c
        .client(Method::DELETE, &format!("/v1/jobs/{}", job.id), None)
        .await;
    assert_eq!(status, StatusCode::NO_CONTENT);
    let (status, _) = c
        .client(Method::GET, &format!("/v1/jobs/{}", job.id), None)
        .await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    assert!(!dir.path().join("jobs").join(job.id.to_string()).exists());
}

/// The same tiles arriving in different orders from different workers give the same image and
/// header (all but `renderTime`, which differs from run to run).
#[tokio::test]
async fn the_image_does_not_depend_on_arrival_order_or_worker() {
    let mut files = Vec::new();
    for order in 0..3 {
        let dir = tempfile::tempdir().unwrap();
        let c = Coordinator::open(config(dir.path())).await;
        let job = c
            .submit(json!({"scene": scene(W, H), "tile_size": TILE}))
            .await;
        let workers = [c.register("a").await, c.register("b").await];
        let mut leases = lease_all(&c, workers).await;
        match order {
            0 => {}
            1 => leases.reverse(),
            _ => leases.sort_by_key(|(l, _)| (l.tile_index % 2, std::cmp::Reverse(l.tile_index))),
        }
        for (lease, worker) in &leases {
            let (status, ack) = c
                .upload(job.id, lease.tile_index, &upload_for(lease, *worker))
                .await;
            assert_eq!(status, StatusCode::OK, "{ack}");
        }
        assert_eq!(c.wait_finished(job.id).await.state, JobState::Done);
        let (_, exr) = c
            .send(
                Method::GET,
                &format!("/v1/jobs/{}/image.exr", job.id),
                Some(CLIENT),
                "",
            )
            .await;
        assert!(exr.len() > 1000);
        files.push(timeless(&exr));
    }
    assert_eq!(files[0], files[1]);
    assert_eq!(files[0], files[2]);
}

/// A job's relative error is unknown (absent) at 1 spp, where the `stderr` layer holds no
/// estimate, however its tiles' layers read; at 2 spp the same tiles give one.
#[tokio::test]
async fn relative_error_is_unknown_at_one_sample_per_pixel() {
    for (spp, known) in [(1, false), (2, true)] {
        let dir = tempfile::tempdir().unwrap();
        let c = Coordinator::open(config(dir.path())).await;
        let mut scene = scene(W, H);
        scene["film"]["spp"] = json!(spp);
        let job = c.submit(json!({"scene": scene, "tile_size": TILE})).await;
        let workers = [c.register("a").await, c.register("b").await];
        for (lease, worker) in lease_all(&c, workers).await {
            let (status, ack) = c
                .upload(job.id, lease.tile_index, &upload_for(&lease, worker))
                .await;
            assert_eq!(status, StatusCode::OK, "{ack}");
        }
        let done = c.wait_finished(job.id).await;
        assert_eq!(done.state, JobState::Done);
        assert_eq!(done.relative_error.is_some(), known, "{spp} spp: {done:?}");
    }
}

/// Higher priority first, then submission order.
#[tokio::test]
async fn jobs_are_served_by_priority_then_submission_order() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let low = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let high = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8, "priority": 5}))
        .await;
    let low2 = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let w = c.register("w").await;
    let order: Vec<u64> = [
        c.lease(w).await.unwrap(),
        c.lease(w).await.unwrap(),
        c.lease(w).await.unwrap(),
    ]
    .iter()
    .map(|l| l.job_id)
    .collect();
    assert_eq!(order, [high.id, low.id, low2.id]);
    assert!(c.lease(w).await.is_none());
}

/// A long poll waits for work and answers as soon as a job is submitted.
#[tokio::test]
async fn a_long_poll_is_answered_when_a_job_arrives() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let w = c.register("w").await;
    let poll = {
        let app = c.app.clone();
        let secret = c.secret(w);
        tokio::spawn(async move {
            use tower::ServiceExt;
            let request = axum::http::Request::post(format!("/v1/workers/{w}/lease"))
                .header("authorization", format!("Bearer {WORKER}"))
                .header("spindle-worker-secret", secret)
                .body(axum::body::Body::from(r#"{"wait_ms": 20000}"#))
                .unwrap();
            app.oneshot(request).await.unwrap().status()
        })
    };
    tokio::time::sleep(std::time::Duration::from_millis(100)).await;
    assert!(!poll.is_finished(), "the poll waits while there is no work");
    c.submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let status = tokio::time::timeout(std::time::Duration::from_secs(10), poll)
        .await
        .expect("answered long before its 20 s wait")
        .unwrap();
    assert_eq!(status, StatusCode::OK);
}

/// Cancelling stops leasing and refuses the cancelled job's uploads.
#[tokio::test]
async fn cancel_stops_the_job() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(32, 32), "tile_size": 16}))
        .await;
    let w = c.register("w").await;
    let lease = c.lease(w).await.unwrap();
    let (status, info) = c
        .client(Method::POST, &format!("/v1/jobs/{}/cancel", job.id), None)
        .await;
    assert_eq!(status, StatusCode::OK, "{info}");
    assert_eq!(info["state"], "cancelled");
    assert!(c.lease(w).await.is_none());
    let (status, err) = c
        .upload(job.id, lease.tile_index, &upload_for(&lease, w))
        .await;
    assert_eq!(status, StatusCode::CONFLICT, "{err}");
    assert_eq!(c.job(job.id).await.tiles_done, 0);
}
