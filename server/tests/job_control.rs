//! Operators steer jobs after submission: names and submitters, filtered and paged listing,
//! pause / resume, requeue, priority, delete — and every change survives a restart.

mod support;

use axum::http::{Method, StatusCode};
use serde_json::json;
use spindle_common::protocol::{JobList, JobState};
use support::*;

async fn post(c: &Coordinator, id: u64, action: &str) -> (StatusCode, serde_json::Value) {
    c.client(Method::POST, &format!("/v1/jobs/{id}/{action}"), None)
        .await
}

async fn list(c: &Coordinator, query: &str) -> JobList {
    let (status, v) = c
        .client(Method::GET, &format!("/v1/jobs{query}"), None)
        .await;
    assert_eq!(status, StatusCode::OK, "{v}");
    serde_json::from_value(v).unwrap()
}

#[tokio::test]
async fn jobs_have_names_and_are_listed_by_state_and_name_in_stable_pages() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let mut ids = Vec::new();
    for name in ["box-a", "box-b", "sphere", "box-c", "box-d"] {
        let job = c
            .submit(json!({"scene": scene(8, 8), "name": name, "submitter": "ann"}))
            .await;
        assert_eq!(
            (job.name.as_str(), job.submitter.as_deref()),
            (name, Some("ann"))
        );
        assert!(job.submitted_at_ms > 0);
        ids.push(job.id);
    }
    let unnamed = c.submit(json!({"scene": scene(8, 8)})).await;
    assert_eq!(unnamed.name, format!("job-{}", unnamed.id));
    c.client(Method::POST, &format!("/v1/jobs/{}/cancel", ids[1]), None)
        .await;

    // Pages of 2 of the "box" jobs: every one once, in order, the cursor ending.
    let mut seen = Vec::new();
    let mut query = "?name=box&limit=2".to_string();
    loop {
        let page = list(&c, &query).await;
        assert!(page.jobs.len() <= 2);
        seen.extend(page.jobs.iter().map(|j| j.id));
        // A job submitted between pages comes after the listed ones, never inside a page.
        c.submit(json!({"scene": scene(8, 8), "name": "box-late"}))
            .await;
        match page.next_cursor {
            Some(cursor) => query = format!("?name=box&limit=2&cursor={cursor}"),
            None => break,
        }
        assert!(seen.len() < 50, "the pages do not end");
    }
    let boxes: Vec<u64> = [0, 1, 3, 4].iter().map(|&i| ids[i]).collect();
    assert_eq!(&seen[..4], &boxes[..]);
    assert!(seen.windows(2).all(|w| w[0] < w[1]), "{seen:?}");

    // Newest first (`order=desc`), in pages of 2: every "box" job once, ids falling; one
    // submitted between pages is newer than the first page and so not listed.
    let mut newest = Vec::new();
    let mut query = "?name=box&limit=2&order=desc".to_string();
    loop {
        let page = list(&c, &query).await;
        assert!(page.jobs.len() <= 2);
        newest.extend(page.jobs.iter().map(|j| j.id));
        c.submit(json!({"scene": scene(8, 8), "name": "box-later"}))
            .await;
        match page.next_cursor {
            Some(cursor) => query = format!("?name=box&limit=2&order=desc&cursor={cursor}"),
            None => break,
        }
        assert!(newest.len() < 50, "the pages do not end");
    }
    let mut oldest_first = newest.clone();
    oldest_first.reverse();
    assert_eq!(&oldest_first[..4], &boxes[..]);
    assert!(newest.windows(2).all(|w| w[0] > w[1]), "{newest:?}");
    // Every box job there was when the first page was read, and none after.
    let all = list(&c, "?name=box&limit=1000").await;
    let first_page_top = newest[0];
    let expected: Vec<u64> = all
        .jobs
        .iter()
        .map(|j| j.id)
        .filter(|&id| id <= first_page_top)
        .rev()
        .collect();
    assert_eq!(newest, expected);

    let cancelled = list(&c, "?state=cancelled").await;
    assert_eq!(
        cancelled.jobs.iter().map(|j| j.id).collect::<Vec<_>>(),
        vec![ids[1]]
    );
    for (query, field) in [
        ("?state=sleeping", "state"),
        ("?limit=0", "limit"),
        ("?limit=1001", "limit"),
        ("?cursor=abc", "cursor"),
        ("?order=newest", "order"),
        ("?colour=red", "query"),
    ] {
        let (status, v) = c
            .client(Method::GET, &format!("/v1/jobs{query}"), None)
            .await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "{query}: {v}");
        assert!(
            v["error"].as_str().unwrap().starts_with(field),
            "{query}: {v}"
        );
    }
    let (status, v) = c
        .client(
            Method::POST,
            "/v1/jobs",
            Some(json!({"scene": scene(8, 8), "name": ""})),
        )
        .await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{v}");
    assert!(v["error"].as_str().unwrap().starts_with("name:"), "{v}");
}

#[tokio::test]
async fn a_paused_job_leases_nothing_new_but_keeps_what_was_leased() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(16, 8), "tile_size": 8}))
        .await; // 2 tiles
    let w = c.register("w").await;
    let held = c.lease(w).await.unwrap();
    let (status, v) = post(&c, job.id, "pause").await;
    assert_eq!(status, StatusCode::OK, "{v}");
    assert_eq!(v["state"], "paused");
    assert_eq!(c.lease(w).await, None, "no new lease while paused");
    // The tile in progress is still accepted.
    let (status, v) = c
        .upload(job.id, held.tile_index, &upload_for(&held, w))
        .await;
    assert_eq!(status, StatusCode::OK, "{v}");
    assert_eq!(c.job(job.id).await.tiles_done, 1);

    // Paused survives a restart.
    drop(c);
    let c = Coordinator::open(config(dir.path())).await;
    assert_eq!(c.job(job.id).await.state, JobState::Paused);
    let w = c.register("w2").await;
    assert_eq!(c.lease(w).await, None);
    let (status, v) = post(&c, job.id, "resume").await;
    assert_eq!(status, StatusCode::OK, "{v}");
    assert_eq!(v["state"], "running");
    let next = c.lease(w).await.expect("leased again after resume");
    c.upload(job.id, next.tile_index, &upload_for(&next, w))
        .await;
    assert_eq!(c.wait_finished(job.id).await.state, JobState::Done);
    let (status, _) = post(&c, job.id, "pause").await;
    assert_eq!(status, StatusCode::CONFLICT, "a done job cannot be paused");
}

#[tokio::test]
async fn a_failed_job_is_requeued_with_its_finished_tiles_kept() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(16, 8), "tile_size": 8}))
        .await; // 2 tiles
    let w = c.register("w").await;
    let first = c.lease(w).await.unwrap();
    c.upload(job.id, first.tile_index, &upload_for(&first, w))
        .await;
    let second = c.lease(w).await.unwrap();
    let (status, _) = c
        .worker(
            Method::POST,
            &format!("/v1/leases/{}/{}/fail", job.id, second.tile_index),
            Some(
                json!({"worker_id": w, "epoch": second.epoch, "reason": "boom",
                        "deterministic": true}),
            ),
        )
        .await;
    assert_eq!(status, StatusCode::NO_CONTENT);
    let failed = c.job(job.id).await;
    assert_eq!(failed.state, JobState::Failed);

    let (status, v) = post(&c, job.id, "requeue").await;
    assert_eq!(status, StatusCode::OK, "{v}");
    assert_eq!(v["state"], "queued");
    assert_eq!(v["error"], serde_json::Value::Null);
    assert_eq!(v["tiles_done"], 1, "the finished tile is kept");
    // Requeued state survives a restart; the worker that failed the tile may take it again.
    drop(c);
    let c = Coordinator::open(config(dir.path())).await;
    let info = c.job(job.id).await;
    assert_eq!((info.state, info.tiles_done), (JobState::Queued, 1));
    assert!(info.recent_errors.is_empty());
    let again = c.lease(w).await.expect("the failed tile is leased again");
    assert_eq!(again.tile_index, second.tile_index);
    assert!(again.epoch > second.epoch);
    c.upload(job.id, again.tile_index, &upload_for(&again, w))
        .await;
    assert_eq!(c.wait_finished(job.id).await.state, JobState::Done);
    let (status, v) = post(&c, job.id, "requeue").await;
    assert_eq!(status, StatusCode::CONFLICT, "a done job: {v}");
}

#[tokio::test]
async fn priority_changes_the_lease_order_and_survives_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let low = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let high = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let (status, v) = c
        .client(
            Method::PATCH,
            &format!("/v1/jobs/{}", high.id),
            Some(json!({"priority": 5})),
        )
        .await;
    assert_eq!(status, StatusCode::OK, "{v}");
    assert_eq!(v["priority"], 5);
    let (status, v) = c
        .client(
            Method::PATCH,
            &format!("/v1/jobs/{}", high.id),
            Some(json!({"nice": 1})),
        )
        .await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{v}");
    drop(c);
    let c = Coordinator::open(config(dir.path())).await;
    assert_eq!(c.job(high.id).await.priority, 5);
    let w = c.register("w").await;
    assert_eq!(c.lease(w).await.unwrap().job_id, high.id);
    assert_eq!(c.lease(w).await.unwrap().job_id, low.id);
}

#[tokio::test]
async fn an_unfinished_job_is_deleted_only_with_force() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c.submit(json!({"scene": scene(8, 8)})).await;
    let uri = format!("/v1/jobs/{}", job.id);
    let (status, v) = c.client(Method::DELETE, &uri, None).await;
    assert_eq!(status, StatusCode::CONFLICT, "{v}");
    assert!(v["error"].as_str().unwrap().contains("force=true"), "{v}");
    let (status, _) = c
        .client(Method::DELETE, &format!("{uri}?force=true"), None)
        .await;
    assert_eq!(status, StatusCode::NO_CONTENT);
    let (status, _) = c.client(Method::GET, &uri, None).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
}
