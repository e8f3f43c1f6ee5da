//! The live event stream (`GET /v1/events`, Server-Sent Events) through the router: job state
//! changes, finished tiles and workers as they happen, and resuming with `Last-Event-ID`.

mod support;

use std::time::Duration;

use axum::body::Body;
use axum::http::{Request, StatusCode};
use serde_json::json;
use spindle_common::protocol::{EventKind, JobState};
use support::*;
use tower::ServiceExt;

#[tokio::test]
async fn the_stream_tells_job_states_tiles_and_workers_and_resumes_after_an_id() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let follow = {
        let c = c.share();
        tokio::spawn(async move { read_events(&c, None, 5).await })
    };
    tokio::time::sleep(Duration::from_millis(100)).await; // subscribed
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await; // 1 tile
    let w = c.register("w1").await;
    let lease = c.lease(w).await.unwrap();
    let (status, _) = c.upload(job.id, 0, &upload_for(&lease, w)).await;
    assert_eq!(status, StatusCode::OK);
    let events = follow.await.unwrap();
    let kinds: Vec<&str> = events.iter().map(|(k, _)| k.as_str()).collect();
    assert_eq!(
        kinds,
        [
            "job_state",
            "worker_joined",
            "job_state",
            "tile_done",
            "job_state"
        ],
        "{events:?}"
    );
    let ids: Vec<u64> = events.iter().map(|(_, e)| e.id).collect();
    assert!(ids.windows(2).all(|w| w[1] == w[0] + 1), "{ids:?}");
    let states: Vec<JobState> = events
        .iter()
        .filter_map(|(_, e)| match e.kind {
            EventKind::JobState { state, .. } => Some(state),
            _ => None,
        })
        .collect();
    assert_eq!(
        states,
        [JobState::Queued, JobState::Running, JobState::Done]
    );
    match &events[3].1.kind {
        EventKind::TileDone {
            job: j,
            tile,
            worker_id,
            worker,
            seconds,
            render_seconds,
        } => {
            assert_eq!(
                (*j, *tile, *worker_id, worker.as_str()),
                (job.id, 0, w, "w1")
            );
            assert!(seconds.is_some_and(|s| s >= 0.0));
            assert_eq!(*render_seconds, Some(0.5), "as the worker reported it");
        }
        other => panic!("{other:?}"),
    }

    // A client reconnecting after the second event gets the rest first.
    let resumed = read_events(&c, Some(ids[1]), 3).await;
    assert_eq!(
        resumed.iter().map(|(_, e)| e.id).collect::<Vec<_>>(),
        ids[2..].to_vec()
    );
}

#[tokio::test]
async fn a_bad_last_event_id_is_refused_and_a_lost_worker_is_announced() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.lease_ttl = Duration::from_millis(200);
    let c = Coordinator::open(cfg).await;
    let response = c
        .app
        .clone()
        .oneshot(
            Request::builder()
                .uri("/v1/events")
                .header("authorization", format!("Bearer {CLIENT}"))
                .header("last-event-id", "yesterday")
                .body(Body::empty())
                .unwrap(),
        )
        .await
        .unwrap();
    assert_eq!(response.status(), StatusCode::BAD_REQUEST);

    c.register("quiet").await;
    let events = read_events(&c, Some(0), 2).await;
    assert_eq!(events[0].0, "worker_joined");
    assert_eq!(events[1].0, "worker_lost", "{events:?}");
}
