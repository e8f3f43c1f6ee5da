//! `GET /metrics` after a known sequence of worker requests: the Prometheus text parses and
//! every counter and gauge says what happened. (The only test in this binary: the `metrics`
//! recorder is process-wide, so the counters start at zero here.)

mod support;

use std::time::Duration;

use axum::http::{Method, StatusCode};
use serde_json::json;
use spindle_common::protocol::{JobState, pixel_hash};
use support::*;

/// The samples of a Prometheus text exposition: `name{labels}` → value.
fn samples(text: &str) -> Vec<(String, f64)> {
    text.lines()
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| {
            let (name, value) = l
                .rsplit_once(' ')
                .unwrap_or_else(|| panic!("bad line {l:?}"));
            let value = value
                .parse()
                .unwrap_or_else(|_| panic!("bad value in {l:?}"));
            (name.to_string(), value)
        })
        .collect()
}

fn value(samples: &[(String, f64)], name: &str) -> f64 {
    samples
        .iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no sample {name} in {samples:?}"))
        .1
}

#[tokio::test]
async fn metrics_count_what_happened() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = config(dir.path());
    config.lease_ttl = Duration::from_millis(1000);
    config.restart_grace = config.lease_ttl;
    let c = Coordinator::open(config).await;
    let job = c
        .submit(json!({"scene": scene(16, 16), "tile_size": 8}))
        .await;
    assert_eq!(job.tiles_total, 4);
    let w = c.register("w").await;

    // A lease that lapses, then the same tile leased again and delivered.
    let first = c.lease(w).await.unwrap();
    tokio::time::sleep(Duration::from_millis(1100)).await;
    let second = c.lease(w).await.unwrap();
    assert_eq!(second.tile_index, first.tile_index);
    let upload = upload_for(&second, w);
    let mut bytes = serde_json::to_string(&upload).unwrap().len();
    assert_eq!(
        c.upload(job.id, second.tile_index, &upload).await.0,
        StatusCode::OK
    );
    // A second, different result for the finished tile: a determinism fault.
    let mut other = upload.clone();
    other.pixels.total[0] += 1.0;
    other.hash = pixel_hash(&other.pixels);
    bytes += serde_json::to_string(&other).unwrap().len();
    assert_eq!(
        c.upload(job.id, second.tile_index, &other).await.0,
        StatusCode::CONFLICT
    );
    // A tile leased and reported failed, while a second worker is connected (so the job is
    // not failed for want of a worker that may take it).
    c.register("w2").await;
    let third = c.lease(w).await.unwrap();
    let (status, body) = c
        .worker(
            Method::POST,
            &format!("/v1/leases/{}/{}/fail", job.id, third.tile_index),
            Some(json!({"worker_id": w, "epoch": third.epoch, "reason": "broke"})),
        )
        .await;
    assert_eq!(status, StatusCode::NO_CONTENT, "{body}");
    // And one in hand.
    c.lease(w).await.unwrap();
    // A second job, paused before any lease: its 4 tiles wait for no worker.
    let paused = c
        .submit(json!({"scene": scene(16, 16), "tile_size": 8}))
        .await;
    let (status, body) = c
        .send(
            Method::POST,
            &format!("/v1/jobs/{}/pause", paused.id),
            Some(CLIENT),
            "",
        )
        .await;
    assert_eq!(status, StatusCode::OK, "{body:?}");

    let (status, text) = c.send(Method::GET, "/metrics", None, "").await;
    assert_eq!(status, StatusCode::OK);
    let text = String::from_utf8(text.to_vec()).unwrap();
    let s = samples(&text);
    assert_eq!(value(&s, "spindle_leases_total"), 4.0, "{text}");
    assert_eq!(value(&s, "spindle_lease_expiries_total"), 1.0, "{text}");
    assert_eq!(value(&s, "spindle_tiles_done_total"), 1.0, "{text}");
    assert_eq!(value(&s, "spindle_tiles_failed_total"), 1.0, "{text}");
    assert_eq!(value(&s, "spindle_determinism_faults_total"), 1.0, "{text}");
    assert_eq!(
        value(&s, "spindle_upload_bytes_total"),
        bytes as f64,
        "{text}"
    );
    assert_eq!(value(&s, "spindle_tile_seconds_count"), 1.0, "{text}");
    assert!(value(&s, "spindle_data_disk_free_bytes") > 0.0, "{text}");
    assert_eq!(value(&s, "spindle_workers_live"), 2.0, "{text}");
    // `w` holds a lease, `w2` holds none.
    for (state, n) in [
        ("rendering", 1.0),
        ("idle", 1.0),
        ("draining", 0.0),
        ("lost", 0.0),
    ] {
        let name = format!("spindle_workers{{state=\"{state}\"}}");
        assert_eq!(value(&s, &name), n, "{text}");
    }

    // The job is still running: of its 4 tiles, 1 is done, 1 leased and 2 wait (the failed
    // one back in the queue); the paused job's 4 tiles are not counted as waiting.
    assert_eq!(c.job(job.id).await.state, JobState::Running);
    assert_eq!(value(&s, "spindle_tiles_queued"), 2.0, "{text}");
    assert_eq!(value(&s, "spindle_tiles_leased"), 1.0, "{text}");
    assert_eq!(value(&s, "spindle_jobs{state=\"running\"}"), 1.0, "{text}");
    assert_eq!(value(&s, "spindle_jobs{state=\"queued\"}"), 0.0, "{text}");
    assert_eq!(value(&s, "spindle_jobs{state=\"paused\"}"), 1.0, "{text}");

    // No token needed, and a client job's name or scene is nowhere in it.
    assert!(!text.contains("icosphere"));
}
