//! Operators see and steer the workers: the worker list (state, lease in hand, counts,
//! throughput), labels and job requirements, and draining — through the router, in process.

mod support;

use axum::http::{Method, StatusCode};
use serde_json::{Value, json};
use spindle_common::protocol::{JobState, WorkerList, WorkerState};
use support::*;

async fn register_with(c: &Coordinator, name: &str, labels: Value) -> u64 {
    let (status, v) = c
        .worker(
            Method::POST,
            "/v1/workers",
            Some(json!({"name": name, "threads": 3, "version": "9.9.9", "labels": labels})),
        )
        .await;
    assert_eq!(status, StatusCode::OK, "{v}");
    v["worker_id"].as_u64().unwrap()
}

async fn workers(c: &Coordinator) -> WorkerList {
    let (status, v) = c.client(Method::GET, "/v1/workers", None).await;
    assert_eq!(status, StatusCode::OK, "{v}");
    serde_json::from_value(v).unwrap()
}

#[tokio::test]
async fn the_worker_list_shows_state_lease_counts_and_throughput() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let w = register_with(&c, "night-1", json!({"pool": "night"})).await;
    let list = workers(&c).await;
    assert_eq!(list.workers.len(), 1);
    let info = &list.workers[0];
    assert_eq!(
        (
            info.id,
            info.name.as_str(),
            info.version.as_str(),
            info.threads
        ),
        (w, "night-1", "9.9.9", 3)
    );
    assert_eq!(info.labels.get("pool").map(String::as_str), Some("night"));
    assert_eq!(info.state, WorkerState::Idle);
    assert_eq!((info.job, info.tile, info.tiles_done), (None, None, 0));

    let job = c
        .submit(json!({"scene": scene(16, 8), "tile_size": 8}))
        .await; // 2 tiles
    let lease = c.lease(w).await.unwrap();
    let info = &workers(&c).await.workers[0];
    assert_eq!(info.state, WorkerState::Rendering);
    assert_eq!(
        (info.job, info.tile),
        (Some(job.id), Some(lease.tile_index))
    );

    let (status, _) = c
        .upload(job.id, lease.tile_index, &upload_for(&lease, w))
        .await;
    assert_eq!(status, StatusCode::OK);
    let second = c.lease(w).await.unwrap();
    let (status, _) = c
        .worker(
            Method::POST,
            &format!("/v1/leases/{}/{}/fail", job.id, second.tile_index),
            Some(json!({"worker_id": w, "epoch": second.epoch, "reason": "out of memory"})),
        )
        .await;
    assert_eq!(status, StatusCode::NO_CONTENT);
    let info = &workers(&c).await.workers[0];
    assert_eq!(info.state, WorkerState::Idle);
    assert_eq!((info.tiles_done, info.failures), (1, 1));
    // One tile in the 5-minute window: 1/5 tile per minute.
    assert_eq!(info.tiles_per_min, 0.2);
}

#[tokio::test]
async fn a_worker_nobody_hears_from_for_a_lease_ttl_is_lost() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.lease_ttl = std::time::Duration::from_millis(200);
    let c = Coordinator::open(cfg).await;
    register_with(&c, "w", json!({})).await;
    assert_eq!(workers(&c).await.workers[0].state, WorkerState::Idle);
    tokio::time::sleep(std::time::Duration::from_millis(300)).await;
    assert_eq!(workers(&c).await.workers[0].state, WorkerState::Lost);
    let (status, v) = c.client(Method::POST, "/v1/workers/w/drain", None).await;
    assert_eq!(status, StatusCode::CONFLICT, "{v}");
    assert!(v["error"].as_str().unwrap().contains("lost"), "{v}");
}

#[tokio::test]
async fn a_job_with_requirements_goes_only_to_workers_with_those_labels() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let day = register_with(&c, "day", json!({"pool": "day"})).await;
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8, "requires": {"pool": "night"}}))
        .await;
    assert_eq!(job.requires.get("pool").map(String::as_str), Some("night"));
    assert_eq!(c.lease(day).await, None, "the day worker must not get it");
    let info = c.job(job.id).await;
    assert_eq!(info.state, JobState::Queued);
    assert_eq!((info.workers_live, info.workers_eligible), (1, 0));

    let night = register_with(&c, "night", json!({"pool": "night", "gpu": "no"})).await;
    assert_eq!(c.job(job.id).await.workers_eligible, 1);
    let lease = c.lease(night).await.expect("the night worker gets it");
    assert_eq!(lease.job_id, job.id);
}

#[tokio::test]
async fn bad_labels_and_requirements_are_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let (status, v) = c
        .worker(
            Method::POST,
            "/v1/workers",
            Some(json!({"name": "w", "threads": 1, "labels": {"po ol": "x"}})),
        )
        .await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{v}");
    assert!(
        v["error"].as_str().unwrap().starts_with("labels: key"),
        "{v}"
    );
    let (status, v) = c
        .client(
            Method::POST,
            "/v1/jobs",
            Some(json!({"scene": scene(8, 8), "requires": {"pool": ""}})),
        )
        .await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{v}");
    assert!(
        v["error"]
            .as_str()
            .unwrap()
            .starts_with("requires.pool: value"),
        "{v}"
    );
}

#[tokio::test]
async fn a_drained_worker_is_told_in_its_heartbeat_and_leased_nothing_more_even_after_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let (job, w, lease) = {
        let c = Coordinator::open(config(dir.path())).await;
        let w = register_with(&c, "leaving", json!({"pool": "night"})).await;
        let other = register_with(&c, "staying", json!({})).await;
        let job = c
            .submit(json!({"scene": scene(16, 8), "tile_size": 8}))
            .await;
        let lease = c.lease(w).await.unwrap();
        let (status, v) = c
            .client(Method::POST, "/v1/workers/leaving/drain", None)
            .await;
        assert_eq!(status, StatusCode::OK, "{v}");
        let told: WorkerList = serde_json::from_value(v).unwrap();
        assert_eq!(told.workers.len(), 1);
        assert_eq!(
            (told.workers[0].id, told.workers[0].state),
            (w, WorkerState::Draining)
        );
        let (status, _) = c
            .client(Method::POST, &format!("/v1/workers/{other}/drain"), None)
            .await;
        assert_eq!(status, StatusCode::OK, "drain by id");
        let (status, v) = c
            .client(Method::POST, "/v1/workers/nobody/drain", None)
            .await;
        assert_eq!(status, StatusCode::NOT_FOUND, "{v}");
        (job, w, lease)
    };

    // Restarted: the drain is remembered.
    let c = Coordinator::open(config(dir.path())).await;
    let (status, v) = c
        .worker(
            Method::POST,
            &format!("/v1/leases/{}/{}/heartbeat", job.id, lease.tile_index),
            Some(json!({"worker_id": w, "epoch": lease.epoch})),
        )
        .await;
    assert_eq!(status, StatusCode::OK, "{v}");
    assert_eq!(v["drain"], true, "{v}");
    // The tile in hand is still accepted...
    let (status, _) = c
        .upload(job.id, lease.tile_index, &upload_for(&lease, w))
        .await;
    assert_eq!(status, StatusCode::OK);
    // ...but no new lease is given.
    let (status, v) = c
        .worker(
            Method::POST,
            &format!("/v1/workers/{w}/lease"),
            Some(json!({"wait_ms": 0})),
        )
        .await;
    assert_eq!(status, StatusCode::GONE, "{v}");
    assert!(v["error"].as_str().unwrap().contains("draining"), "{v}");
    let listed = workers(&c).await;
    let me = listed.workers.iter().find(|x| x.id == w).unwrap();
    assert_eq!(me.labels.get("pool").map(String::as_str), Some("night"));
    assert_eq!(me.tiles_done, 1);
}
