//! A coordinator stopped mid-job and started again on the same data directory resumes every
//! job: finished tiles are kept and counted once, live leases get a grace period to report,
//! and the final image is the same as without the restart.

mod support;

use std::time::Duration;

use axum::http::{Method, StatusCode};
use serde_json::json;
use spindle_common::protocol::JobState;
use support::*;

#[tokio::test]
async fn a_restarted_coordinator_resumes_without_losing_or_doubling_tiles() {
    let dir = tempfile::tempdir().unwrap();
    let body = json!({"scene": scene(32, 16), "tile_size": 8}); // 8 tiles

    // Reference: the same job without a restart.
    let reference_dir = tempfile::tempdir().unwrap();
    let reference = {
        let c = Coordinator::open(config(reference_dir.path())).await;
        let job = c.submit(body.clone()).await;
        let w = c.register("w").await;
        while let Some(lease) = c.lease(w).await {
            c.upload(job.id, lease.tile_index, &upload_for(&lease, w))
                .await;
        }
        assert_eq!(c.wait_finished(job.id).await.state, JobState::Done);
        c.send(
            Method::GET,
            &format!("/v1/jobs/{}/image.exr", job.id),
            Some(CLIENT),
            "",
        )
        .await
        .1
    };

    let (job, worker, held) = {
        let c = Coordinator::open(config(dir.path())).await;
        let job = c.submit(body.clone()).await;
        let w = c.register("w").await;
        let leases = [
            c.lease(w).await.unwrap(),
            c.lease(w).await.unwrap(),
            c.lease(w).await.unwrap(),
        ];
        for lease in &leases[..2] {
            let (status, _) = c
                .upload(job.id, lease.tile_index, &upload_for(lease, w))
                .await;
            assert_eq!(status, StatusCode::OK);
        }
        (job, w, leases[2].clone())
        // The coordinator is dropped here with one tile leased and two done; the worker keeps
        // its secret.
    };

    let mut cfg = config(dir.path());
    cfg.restart_grace = Duration::from_secs(60);
    cfg.max_leases_per_worker = 8; // one worker takes every remaining tile below
    let c = Coordinator::open(cfg).await;
    let info = c.job(job.id).await;
    assert_eq!(info.state, JobState::Running);
    assert_eq!(info.tiles_done, 2, "finished tiles survive");
    assert_eq!(info.stats.samples, 2);

    // The worker registered before the restart is still known; its live lease is still its
    // own during the grace period, so nobody else gets that tile.
    let other = c.register("other").await;
    let mut handed_out = Vec::new();
    while let Some(lease) = c.lease(other).await {
        assert!(
            lease.tile_index > 2,
            "tiles 0 and 1 are done and 2 is leased"
        );
        handed_out.push(lease);
    }
    assert_eq!(handed_out.len(), 5);
    let (status, _) = c
        .worker(
            Method::POST,
            &format!("/v1/leases/{}/{}/heartbeat", job.id, held.tile_index),
            Some(json!({"worker_id": worker, "epoch": held.epoch})),
        )
        .await;
    assert_eq!(
        status,
        StatusCode::OK,
        "the lease from before the restart is renewed"
    );
    let (status, ack) = c
        .upload(job.id, held.tile_index, &upload_for(&held, worker))
        .await;
    assert_eq!(
        (status, ack["outcome"].as_str()),
        (StatusCode::OK, Some("accepted"))
    );
    for lease in &handed_out {
        let (status, _) = c
            .upload(job.id, lease.tile_index, &upload_for(lease, other))
            .await;
        assert_eq!(status, StatusCode::OK);
    }
    let info = c.wait_finished(job.id).await;
    assert_eq!(info.state, JobState::Done, "{:?}", info.error);
    assert_eq!(info.tiles_done, 8);
    assert_eq!(info.stats.samples, 8, "each tile counted once");
    let (_, exr) = c
        .send(
            Method::GET,
            &format!("/v1/jobs/{}/image.exr", job.id),
            Some(CLIENT),
            "",
        )
        .await;
    assert_eq!(
        timeless(&exr),
        timeless(&reference),
        "the same image and header as without the restart"
    );

    // A second restart after completion keeps the finished job and its image.
    drop(c);
    let c = Coordinator::open(config(dir.path())).await;
    assert_eq!(c.job(job.id).await.state, JobState::Done);
    let (status, again) = c
        .send(
            Method::GET,
            &format!("/v1/jobs/{}/image.exr", job.id),
            Some(CLIENT),
            "",
        )
        .await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(again, exr, "the same file");
}

#[tokio::test]
async fn leases_from_before_a_restart_expire_after_the_grace_period() {
    let dir = tempfile::tempdir().unwrap();
    let job = {
        let c = Coordinator::open(config(dir.path())).await;
        let job = c
            .submit(json!({"scene": scene(8, 8), "tile_size": 8}))
            .await;
        let w = c.register("gone").await;
        c.lease(w).await.unwrap();
        job
    };
    let mut cfg = config(dir.path());
    cfg.restart_grace = Duration::from_millis(300);
    let c = Coordinator::open(cfg).await;
    let w = c.register("new").await;
    assert!(c.lease(w).await.is_none(), "held during the grace period");
    tokio::time::sleep(Duration::from_millis(450)).await;
    let lease = c.lease(w).await.expect("re-leased after the grace period");
    assert_eq!(
        (lease.job_id, lease.tile_index, lease.epoch),
        (job.id, 0, 2)
    );
}

/// All tiles recorded but the image not written (killed during assembly): the restarted
/// coordinator assembles it.
#[tokio::test]
async fn an_interrupted_assembly_is_finished_after_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let (job, last, worker) = {
        let c = Coordinator::open(config(dir.path())).await;
        let job = c
            .submit(json!({"scene": scene(16, 8), "tile_size": 8}))
            .await;
        let w = c.register("w").await;
        let first = c.lease(w).await.unwrap();
        let (status, _) = c
            .upload(job.id, first.tile_index, &upload_for(&first, w))
            .await;
        assert_eq!(status, StatusCode::OK);
        (job, c.lease(w).await.unwrap(), w)
    };
    // A kill after the last tile was recorded, before the image was written: its row as the
    // upload route leaves it (a done job's tile rows go with the commit that records it done,
    // so the row is put back by hand).
    let upload = upload_for(&last, worker);
    let db = rusqlite::Connection::open(dir.path().join("spindle.db")).unwrap();
    db.execute(
        "UPDATE tiles SET state = 'done', hash = ?1, stats = ?2, upload = ?3 WHERE tile_index = ?4",
        rusqlite::params![
            upload.hash,
            serde_json::to_string(&upload.pixels.stats).unwrap(),
            spindle_common::tile_encoding::encode(&upload).unwrap(),
            last.tile_index
        ],
    )
    .unwrap();
    drop(db);

    let c = Coordinator::open(config(dir.path())).await;
    let info = c.wait_finished(job.id).await;
    assert_eq!(info.state, JobState::Done, "{:?}", info.error);
    assert_eq!(info.tiles_done, 2);
    let image = dir
        .path()
        .join("jobs")
        .join(job.id.to_string())
        .join("image.exr");
    assert!(image.is_file());
    // The tile rows went with the commit that recorded the job done.
    assert_eq!(
        tile_rows(dir.path(), job.id),
        0,
        "the tiles of a done job are still there"
    );
}

/// Runs the `spindle-server` binary on `data` (on loopback, with tokens and a full backtrace
/// asked for) until it exits or its stderr shows `until`, for at most 30 s; then stops it.
/// Returns its exit status (`None`: still running when stopped) and its stderr.
fn run_binary(data: &std::path::Path, until: &str) -> (Option<std::process::ExitStatus>, String) {
    use std::io::Read;
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_spindle-server"))
        .args(["--listen", "127.0.0.1:0", "--data"])
        .arg(data)
        .env("SPINDLE_TOKEN", CLIENT)
        .env("SPINDLE_WORKER_TOKEN", WORKER)
        .env("RUST_BACKTRACE", "1")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("starting spindle-server");
    let mut stderr = child.stderr.take().unwrap();
    let text = std::sync::Arc::new(std::sync::Mutex::new(String::new()));
    let reader = {
        let text = text.clone();
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(n) = stderr.read(&mut buf) {
                if n == 0 {
                    break;
                }
                text.lock()
                    .unwrap()
                    .push_str(&String::from_utf8_lossy(&buf[..n]));
            }
        })
    };
    let started = std::time::Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break Some(status);
        }
        if text.lock().unwrap().contains(until) || started.elapsed() > Duration::from_secs(30) {
            child.kill().unwrap();
            child.wait().unwrap();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    reader.join().unwrap();
    let text = text.lock().unwrap().clone();
    (status, text)
}

/// A truncated database stops the coordinator at once with a sentence that names the file
/// and says what to do: no panic, no backtrace.
#[test]
fn a_damaged_database_stops_the_coordinator_saying_what_to_do() {
    let dir = tempfile::tempdir().unwrap();
    let database = dir.path().join("spindle.db");
    // A database with every table, its log copied in and removed when the connection closes.
    drop(spindle_server::db::open(&database).unwrap());
    let length = std::fs::metadata(&database).unwrap().len();
    let file = std::fs::OpenOptions::new()
        .write(true)
        .open(&database)
        .unwrap();
    file.set_len(length / 2).unwrap();
    drop(file);

    let (status, stderr) = run_binary(dir.path(), "coordinator state loaded");
    println!(
        "spindle-server on a database cut from {length} to {} bytes: {stderr}",
        length / 2
    );
    let status = status.expect("the coordinator stops by itself");
    assert!(!status.success(), "{stderr}");
    assert!(
        stderr.contains(&format!("the database {} is damaged: ", database.display()))
            && stderr.contains("restore it from a backup or move it away to start empty"),
        "{stderr}"
    );
    assert!(
        !stderr.contains("panicked") && !stderr.contains("backtrace"),
        "{stderr}"
    );
}

/// A database file deleted while its write-ahead log stayed: the coordinator starts empty, with
/// a warning, and the log is kept aside rather than replayed into the new database.
#[test]
fn a_deleted_database_whose_log_is_left_starts_empty_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let database = dir.path().join("spindle.db");
    let db = spindle_server::db::open(&database).unwrap();
    db.execute_batch("CREATE TABLE scratch (a); INSERT INTO scratch VALUES (1);")
        .unwrap();
    let log = dir.path().join("spindle.db-wal");
    assert!(log.is_file(), "the connection keeps its log while open");
    std::fs::remove_file(&database).unwrap();

    let (status, stderr) = run_binary(dir.path(), "coordinator state loaded");
    drop(db);
    println!("spindle-server on a log without its database: {stderr}");
    assert!(status.is_none(), "the coordinator stopped: {stderr}");
    let warning = stderr
        .lines()
        .find(|l| l.contains("WARN"))
        .unwrap_or_else(|| panic!("no warning: {stderr}"));
    assert!(
        warning.contains("the database file is missing but its write-ahead log was there")
            && warning.contains("spindle.db-wal.orphaned"),
        "{warning}"
    );
    assert!(stderr.contains("jobs=0"), "{stderr}");
    assert!(dir.path().join("spindle.db-wal.orphaned").is_file());
}
