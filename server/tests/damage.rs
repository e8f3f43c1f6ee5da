//! A stored tile result found damaged at assembly goes back to the queue, an I/O error at assembly is
//! retried, and a tile upload racing a delete or cancel is answered 404/409, never 500.

mod support;

use std::path::Path;
use std::time::Duration;

use axum::http::{Method, StatusCode};
use serde_json::json;
use spindle_common::protocol::{JobState, TileUpload};
use spindle_common::tile_encoding;
use support::*;

/// Replaces the stored upload of tile `index` of `job` in the coordinator's database, as a
/// damaged disk would, beside the running coordinator.
fn damage_tile(data: &Path, job: u64, index: u32, damage: impl FnOnce(Vec<u8>) -> Vec<u8>) {
    let db = rusqlite::Connection::open(data.join("spindle.db")).unwrap();
    db.busy_timeout(Duration::from_secs(5)).unwrap();
    let stored: Vec<u8> = db
        .query_row(
            "SELECT upload FROM tiles WHERE job_id = ?1 AND tile_index = ?2",
            rusqlite::params![job as i64, index],
            |r| r.get(0),
        )
        .unwrap();
    db.execute(
        "UPDATE tiles SET upload = ?3 WHERE job_id = ?1 AND tile_index = ?2",
        rusqlite::params![job as i64, index, damage(stored)],
    )
    .unwrap();
}

#[tokio::test]
async fn damaged_tiles_are_rendered_again_instead_of_failing_the_job() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    // Three tiles of 8 × 8.
    let job = c
        .submit(json!({"scene": scene(24, 8), "tile_size": 8}))
        .await;
    let w = c.register("w").await;
    let leases: Vec<_> = [
        c.lease(w).await.unwrap(),
        c.lease(w).await.unwrap(),
        c.lease(w).await.unwrap(),
    ]
    .into();
    for lease in &leases[..2] {
        let (status, v) = c
            .upload(job.id, lease.tile_index, &upload_for(lease, w))
            .await;
        assert_eq!(status, StatusCode::OK, "{v}");
    }
    // One result loses its end, the other has one bit of one value changed (only the hash
    // can tell).
    damage_tile(dir.path(), job.id, leases[0].tile_index, |bytes| {
        bytes[..bytes.len() / 2].to_vec()
    });
    damage_tile(dir.path(), job.id, leases[1].tile_index, |bytes| {
        let mut upload: TileUpload = tile_encoding::decode(&bytes, 1 << 24).unwrap();
        upload.pixels.total[0] = f32::from_bits(upload.pixels.total[0].to_bits() ^ 1);
        tile_encoding::encode(&upload).unwrap()
    });

    let last = &leases[2];
    let (status, v) = c
        .upload(job.id, last.tile_index, &upload_for(last, w))
        .await;
    assert_eq!(status, StatusCode::OK, "{v}");

    // Assembly finds both and puts them back in the queue; the job keeps running.
    let mut info = c.job(job.id).await;
    for _ in 0..500 {
        if info.tiles_done == 1 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
        info = c.job(job.id).await;
    }
    assert_eq!(
        (info.state, info.tiles_done),
        (JobState::Running, 1),
        "{info:?}"
    );
    let messages: Vec<&str> = info
        .recent_errors
        .iter()
        .map(|e| e.message.as_str())
        .collect();
    assert_eq!(messages.len(), 2, "{messages:?}");
    let data = dir.path().to_string_lossy().to_string();
    for m in &messages {
        assert!(
            m.contains("rendering it again") && !m.contains(&data),
            "{m}"
        );
    }

    // Rendered again under new epochs, the job completes.
    for _ in 0..2 {
        let again = c.lease(w).await.expect("a damaged tile is leased again");
        assert!(again.epoch >= 2, "{again:?}");
        let (status, v) = c
            .upload(job.id, again.tile_index, &upload_for(&again, w))
            .await;
        assert_eq!(status, StatusCode::OK, "{v}");
    }
    let done = c.wait_finished(job.id).await;
    assert_eq!(done.state, JobState::Done, "{:?}", done.error);
    assert_eq!(done.stats.samples, 3, "each tile counted once");
}

#[tokio::test]
async fn an_io_error_at_assembly_is_retried_until_it_passes() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
        .await;
    let w = c.register("w").await;
    let lease = c.lease(w).await.unwrap();
    // A directory where the image goes: writing it fails (EISDIR) until it is removed.
    let image = dir.path().join(format!("jobs/{}/image.exr", job.id));
    std::fs::create_dir_all(&image).unwrap();
    let (status, v) = c.upload(job.id, 0, &upload_for(&lease, w)).await;
    assert_eq!(status, StatusCode::OK, "{v}");
    tokio::time::sleep(Duration::from_millis(400)).await;
    let info = c.job(job.id).await;
    assert_eq!(
        info.state,
        JobState::Running,
        "not failed for good: {info:?}"
    );
    std::fs::remove_dir(&image).unwrap();
    let done = c.wait_finished(job.id).await;
    assert_eq!(done.state, JobState::Done, "{:?}", done.error);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_upload_racing_a_delete_or_cancel_is_answered_404_or_409() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let w = c.register("w").await;
    let body = json!({"scene": scene(256, 256), "tile_size": 256});
    // How long one upload takes here, to pull the job away at points spread across it.
    let job = c.submit(body.clone()).await;
    let lease = c.lease(w).await.unwrap();
    let started = std::time::Instant::now();
    assert_eq!(
        c.upload(job.id, 0, &upload_for(&lease, w)).await.0,
        StatusCode::OK
    );
    let span = started.elapsed();
    let rounds = 40u32;
    for round in 0..rounds {
        let job = c.submit(body.clone()).await;
        let lease = c.lease(w).await.unwrap();
        let upload = upload_for(&lease, w);
        let uploading = tokio::spawn({
            let c = c.share();
            async move { c.upload(job.id, 0, &upload).await }
        });
        tokio::time::sleep(span * (round / 2) / (rounds / 2)).await;
        let cancel = round % 2 == 1;
        let (status, v) = if cancel {
            c.client(Method::POST, &format!("/v1/jobs/{}/cancel", job.id), None)
                .await
        } else {
            c.client(
                Method::DELETE,
                &format!("/v1/jobs/{}?force=true", job.id),
                None,
            )
            .await
        };
        let (stopped, stop_body) = (status, v);
        let (status, v) = uploading.await.unwrap();
        if cancel && stopped == StatusCode::CONFLICT {
            // The upload won the race and finished the job: cancelling a done job is refused.
            assert_eq!(
                status,
                StatusCode::OK,
                "round {round}: {stop_body}; upload {v}"
            );
            continue;
        }
        assert!(stopped.is_success(), "round {round}: {stopped} {stop_body}");
        let allowed = if cancel {
            [StatusCode::OK, StatusCode::CONFLICT]
        } else {
            [StatusCode::OK, StatusCode::NOT_FOUND]
        };
        assert!(allowed.contains(&status), "round {round}: {status} {v}");
    }
}
