//! A job with a time budget (`film.time_budget_s`) through the coordinator alone, with fake
//! tiles that carry their pass: what a restart keeps of its passes, how the end of a pass
//! meets a database that refuses the write, what a pause does to the budget, and what the
//! preview shows between two passes.

mod support;

use std::time::Duration;

use axum::http::{Method, StatusCode};
use serde_json::json;
use spindle_common::image::preview_pixel;
use spindle_common::protocol::{EventKind, JobInfo, JobState, PassInfo};
use support::*;

/// `film.spp` of the jobs here: passes of 16, 32, 48 and 64 samples.
const SPP: u32 = 64;

/// A `width` × 8 job of 8-pixel tiles with a budget of `budget_s` seconds.
fn budgeted(width: u32, budget_s: f64) -> serde_json::Value {
    let mut scene = scene(width, 8);
    scene["film"]["spp"] = json!(SPP);
    scene["film"]["time_budget_s"] = json!(budget_s);
    json!({"scene": scene, "tile_size": 8})
}

/// The coordinator's configuration: one worker may hold every tile of the jobs here.
fn cfg(dir: &std::path::Path) -> spindle_server::Config {
    let mut cfg = config(dir);
    cfg.max_leases_per_worker = 8;
    cfg
}

/// Waits (up to 10 s) until `ready(job)`.
async fn wait_until(c: &Coordinator, id: u64, ready: impl Fn(&JobInfo) -> bool) -> JobInfo {
    for _ in 0..1000 {
        let info = c.job(id).await;
        if ready(&info) {
            return info;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    panic!(
        "job {id}: not as expected within 10 s: {:?}",
        c.job(id).await
    );
}

/// Waits until job `id` renders pass `pass` (or has finished).
async fn wait_pass(c: &Coordinator, id: u64, pass: u32) -> JobInfo {
    wait_until(c, id, |j| {
        j.state.is_finished() || j.passes.is_some_and(|p| p.pass == pass)
    })
    .await
}

/// Leases every pending tile of the job to `worker` (the only job here).
async fn lease_all(c: &Coordinator, worker: u64) -> Vec<spindle_common::protocol::Lease> {
    let mut leases = Vec::new();
    while let Some(lease) = c.lease(worker).await {
        leases.push(lease);
    }
    leases
}

/// Uploads each lease's fake tile, requiring it accepted.
async fn upload_all(
    c: &Coordinator,
    job: u64,
    worker: u64,
    leases: &[spindle_common::protocol::Lease],
) {
    for lease in leases {
        let (status, ack) = c
            .upload(job, lease.tile_index, &pass_upload_for(lease, worker, SPP))
            .await;
        assert_eq!(
            (status, ack["outcome"].as_str()),
            (StatusCode::OK, Some("accepted")),
            "{ack}"
        );
    }
}

fn pass_of(info: &JobInfo) -> Option<PassInfo> {
    info.passes
}

/// Killed mid pass 2 (two of four tiles in, two leased), the coordinator resumes pass 2: the
/// done tiles count, the leases from before are still good for pass-2 results, and the job goes
/// on to pass 3 — it does not start over from pass 1.
#[tokio::test]
async fn a_restarted_coordinator_resumes_the_pass_it_was_in() {
    let dir = tempfile::tempdir().unwrap();
    let (job, held) = {
        let c = Coordinator::open(cfg(dir.path())).await;
        let job = c.submit(budgeted(32, 3600.0)).await;
        let w = c.register("w").await;
        upload_all(&c, job.id, w, &lease_all(&c, w).await).await;
        wait_pass(&c, job.id, 2).await;
        let leases = lease_all(&c, w).await;
        assert_eq!(leases.len(), 4);
        assert!(leases.iter().all(|l| l.pass == Some(2)), "{leases:?}");
        upload_all(&c, job.id, w, &leases[..2]).await;
        (job, (leases[2..].to_vec(), w))
    };
    let c = Coordinator::open(cfg(dir.path())).await;
    let info = c.job(job.id).await;
    assert_eq!(info.state, JobState::Running);
    assert_eq!(
        pass_of(&info).map(|p| (p.pass, p.spp)),
        Some((2, 32)),
        "the pass survives the restart"
    );
    assert_eq!(info.tiles_done, 2, "the tiles done in pass 2 stay done");
    // Nothing else to render in pass 2; the leases from before the restart are still good,
    // and so are their pass-2 results.
    let (held, w) = held;
    assert!(
        c.lease(w).await.is_none(),
        "pass 2's other tiles are done or leased"
    );
    upload_all(&c, job.id, w, &held).await;
    let info = wait_pass(&c, job.id, 3).await;
    assert_eq!(pass_of(&info).map(|p| p.pass), Some(3), "{info:?}");
    // The rest of the job, across another restart between passes.
    upload_all(&c, job.id, w, &lease_all(&c, w).await).await;
    wait_pass(&c, job.id, 4).await;
    drop(c);
    let c = Coordinator::open(cfg(dir.path())).await;
    assert_eq!(pass_of(&c.job(job.id).await).map(|p| p.pass), Some(4));
    upload_all(&c, job.id, w, &lease_all(&c, w).await).await;
    let done = c.wait_finished(job.id).await;
    assert_eq!(done.state, JobState::Done, "{:?}", done.error);
    assert_eq!(pass_of(&done).map(|p| (p.pass, p.spp)), Some((4, 64)));
    drop(c);
    // A finished job's passes are what it reached, after a restart too.
    let c = Coordinator::open(cfg(dir.path())).await;
    assert_eq!(
        pass_of(&c.job(job.id).await).map(|p| (p.pass, p.spp)),
        Some((4, 64))
    );
}

/// The coordinator's database under `data`, opened beside the running coordinator.
fn ledger_db(data: &std::path::Path) -> rusqlite::Connection {
    let db = rusqlite::Connection::open(data.join("spindle.db")).unwrap();
    db.busy_timeout(Duration::from_secs(5)).unwrap();
    db
}

/// Damages the stored result of tile `index` of `job`, as a failing disk would.
fn damage_stored_result(data: &std::path::Path, job: u64, index: u32) {
    let damaged = ledger_db(data)
        .execute(
            "UPDATE tiles SET upload = X'00' WHERE job_id = ?1 AND tile_index = ?2",
            rusqlite::params![job as i64, index],
        )
        .unwrap();
    assert_eq!(damaged, 1);
}

/// Renders `passes` of the only job here (leases all its tiles in each, each carrying that pass),
/// waiting for each next pass; after the last pass (4) the job must end Done at 64 spp.
async fn render_passes(
    c: &Coordinator,
    job: u64,
    worker: u64,
    passes: std::ops::RangeInclusive<u32>,
) {
    let tiles = c.job(job).await.tiles_total;
    for pass in passes {
        let leases = lease_all(c, worker).await;
        assert_eq!(leases.len() as u32, tiles, "pass {pass}");
        assert!(
            leases.iter().all(|l| l.pass == Some(pass)),
            "pass {pass}: {leases:?}"
        );
        upload_all(c, job, worker, &leases).await;
        if pass < SPP / 16 {
            wait_pass(c, job, pass + 1).await;
        } else {
            let done = c.wait_finished(job).await;
            assert_eq!(done.state, JobState::Done, "{:?}", done.error);
            assert_eq!(pass_of(&done).map(|p| (p.pass, p.spp)), Some((4, SPP)));
        }
    }
}

/// Installs a fault in the database under `data`: putting a done tile back in the queue (what
/// ending a pass does) fails.
fn refuse_next_passes(data: &std::path::Path) {
    ledger_db(data)
        .execute_batch(
            "CREATE TRIGGER refuse_next_pass BEFORE UPDATE OF state ON tiles
         WHEN OLD.state = 'done' AND NEW.state = 'pending'
         BEGIN SELECT RAISE(ABORT, 'injected fault: no next pass'); END;",
        )
        .unwrap();
}

fn allow_next_passes(data: &std::path::Path) {
    ledger_db(data)
        .execute_batch("DROP TRIGGER refuse_next_pass;")
        .unwrap();
}

/// The database refuses to end pass 1 for a while: the last tile of the pass is still
/// accepted, the job waits in pass 1 while the end is retried, and once the database takes the
/// write again the job goes on to pass 2 and to its end.
#[tokio::test]
async fn a_failed_end_of_pass_is_retried_until_it_passes() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(cfg(dir.path())).await;
    let job = c.submit(budgeted(16, 3600.0)).await;
    let w = c.register("w").await;
    refuse_next_passes(dir.path());
    upload_all(&c, job.id, w, &lease_all(&c, w).await).await;
    // Two attempts at least (the second after 250 ms).
    tokio::time::sleep(Duration::from_millis(600)).await;
    let info = c.job(job.id).await;
    assert_eq!(info.state, JobState::Running, "{info:?}");
    assert_eq!(pass_of(&info).map(|p| p.pass), Some(1));
    assert_eq!(info.tiles_done, 2);
    assert!(
        c.lease(w).await.is_none(),
        "nothing to lease until the pass ends"
    );
    allow_next_passes(dir.path());
    let info = wait_pass(&c, job.id, 2).await;
    assert_eq!(info.state, JobState::Running, "{info:?}");
    assert_eq!(info.tiles_done, 0, "pass 2 has begun");
    render_passes(&c, job.id, w, 2..=4).await;
}

/// The database keeps refusing: after the attempts the job fails, with the reason in its
/// `error` and in the `job_state` event that announces it — it does not stay `running`.
#[tokio::test]
async fn an_end_of_pass_that_keeps_failing_fails_the_job_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(cfg(dir.path())).await;
    let job = c.submit(budgeted(16, 3600.0)).await;
    let w = c.register("w").await;
    refuse_next_passes(dir.path());
    upload_all(&c, job.id, w, &lease_all(&c, w).await).await;
    // Six attempts, 0.25 + 0.5 + 1 + 2 + 4 s apart.
    let mut failed = None;
    for _ in 0..200 {
        let info = c.job(job.id).await;
        if info.state.is_finished() {
            failed = Some(info);
            break;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let failed = failed.expect("the job ends within 20 s");
    assert_eq!(failed.state, JobState::Failed);
    let error = failed.error.expect("a failed job says why");
    assert!(
        error.contains("pass 1 could not be ended after 6 attempts")
            && error.contains("database refused the write"),
        "{error}"
    );
    assert!(
        !error.contains("injected"),
        "no SQL text reaches a client: {error}"
    );
    // Submitted, worker joined, running, two tiles done, failed.
    let events = read_events(&c, Some(0), 6).await;
    match &events[5].1.kind {
        EventKind::JobState {
            job: j,
            state: JobState::Failed,
            error: Some(e),
        } => assert_eq!((*j, e), (job.id, &error)),
        other => panic!("{other:?} in {events:?}"),
    }
}

/// A job failed while it was being assembled (its pass could not be ended) is requeued like
/// any failed job: its tiles are leased again and it renders to its end, rather than staying
/// queued with nothing handed out.
#[tokio::test]
async fn a_job_failed_at_the_end_of_a_pass_is_leased_again_once_requeued() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(cfg(dir.path())).await;
    let job = c.submit(budgeted(16, 3600.0)).await;
    let w = c.register("w").await;
    refuse_next_passes(dir.path());
    upload_all(&c, job.id, w, &lease_all(&c, w).await).await;
    let failed = c.wait_finished(job.id).await;
    assert_eq!(
        failed.state,
        JobState::Failed,
        "the pass end failed for good"
    );
    allow_next_passes(dir.path());
    control(&c, job.id, "requeue").await;
    assert_eq!(c.job(job.id).await.state, JobState::Queued);
    assert!(
        c.lease(w).await.is_some(),
        "the requeued job hands out its tiles"
    );
}

/// Pauses or resumes job `id` (`action`: "pause" or "resume").
async fn control(c: &Coordinator, id: u64, action: &str) {
    let (status, info) = c
        .client(Method::POST, &format!("/v1/jobs/{id}/{action}"), None)
        .await;
    assert_eq!(status, StatusCode::OK, "{action}: {info}");
}

/// The budget counts the time a job can run: paused for longer than its whole budget, the job
/// still runs its next pass; and so it does when the coordinator restarts during the pause.
#[tokio::test]
async fn time_spent_paused_is_not_spent_from_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let budget_s = 1.5;
    let pause = Duration::from_secs_f64(budget_s + 0.5);
    let (job, w, leases) = {
        let c = Coordinator::open(cfg(dir.path())).await;
        let job = c.submit(budgeted(16, budget_s)).await;
        let w = c.register("w").await;
        upload_all(&c, job.id, w, &lease_all(&c, w).await).await;
        assert_eq!(
            pass_of(&wait_pass(&c, job.id, 2).await).map(|p| p.pass),
            Some(2)
        );
        // Paused mid pass 2 for longer than the budget; its tiles come in during the pause,
        // so the pass ends while the job is paused.
        let leases = lease_all(&c, w).await;
        control(&c, job.id, "pause").await;
        tokio::time::sleep(pause).await;
        upload_all(&c, job.id, w, &leases).await;
        let info = wait_until(&c, job.id, |j| {
            j.state.is_finished() || j.passes.is_some_and(|p| p.pass == 3)
        })
        .await;
        assert_eq!(
            (info.state, pass_of(&info).map(|p| p.pass)),
            (JobState::Paused, Some(3)),
            "{pause:?} paused of a {budget_s} s budget still leaves time for pass 3: {info:?}"
        );
        control(&c, job.id, "resume").await;
        // Paused again mid pass 3, and the coordinator stopped during the pause.
        let leases = lease_all(&c, w).await;
        control(&c, job.id, "pause").await;
        (job, w, leases)
    };
    tokio::time::sleep(pause).await;
    let mut config = cfg(dir.path());
    config.restart_grace = Duration::from_secs(60);
    let c = Coordinator::open(config).await;
    assert_eq!(c.job(job.id).await.state, JobState::Paused);
    control(&c, job.id, "resume").await;
    upload_all(&c, job.id, w, &leases).await;
    let info = wait_pass(&c, job.id, 4).await;
    assert_eq!(
        pass_of(&info).map(|p| p.pass),
        Some(4),
        "the pause is kept across the restart: {info:?}"
    );
    upload_all(&c, job.id, w, &lease_all(&c, w).await).await;
    let done = c.wait_finished(job.id).await;
    assert_eq!(done.state, JobState::Done, "{:?}", done.error);
    assert_eq!(pass_of(&done).map(|p| (p.pass, p.spp)), Some((4, 64)));
}

/// Just after a pass ends, the preview shows every tile's previous-pass result (each fake tile
/// is one colour: its pixels are that colour through the preview's tone map), not black.
#[tokio::test]
async fn the_preview_keeps_the_previous_pass_until_the_next_is_in() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(cfg(dir.path())).await;
    let job = c.submit(budgeted(16, 3600.0)).await;
    let w = c.register("w").await;
    let leases = lease_all(&c, w).await;
    upload_all(&c, job.id, w, &leases).await;
    let info = wait_pass(&c, job.id, 2).await;
    assert_eq!(
        (info.tiles_done, pass_of(&info).map(|p| p.pass)),
        (0, Some(2))
    );
    // Pass 2 of tile 0 is in, tile 1's is not.
    let pass2 = lease_all(&c, w).await;
    let first = pass2.iter().find(|l| l.tile_index == 0).unwrap().clone();
    upload_all(&c, job.id, w, &[first]).await;

    let (status, png) = c
        .send(
            Method::GET,
            &format!("/v1/jobs/{}/image.png", job.id),
            Some(CLIENT),
            "",
        )
        .await;
    assert_eq!(status, StatusCode::OK);
    let decoder = png::Decoder::new(std::io::Cursor::new(png.to_vec()));
    let mut reader = decoder.read_info().unwrap();
    let mut rgb = vec![0; reader.output_buffer_size().unwrap()];
    let frame = reader.next_frame(&mut rgb).unwrap();
    assert_eq!((frame.width, frame.height), (16, 8));
    for lease in &leases {
        let r = lease.rect;
        for y in r.y..r.y + r.height {
            for x in r.x..r.x + r.width {
                for ch in 0..3 {
                    let at = ((y * 16 + x) * 3) as usize + ch;
                    let expected = preview_pixel(tile_colour(lease.tile_index, 0, ch));
                    assert_eq!(
                        rgb[at], expected,
                        "pixel ({x}, {y}) channel {ch} of tile {}",
                        lease.tile_index
                    );
                }
            }
        }
    }
}

/// Tile 0's pass-1 result, stored and found damaged while pass 2 asks for it: the pass cannot
/// go on from it and the row keeps nothing earlier, so the job's passes start again from pass
/// 1 (said to the worker and in the job's recent errors; the pass-2 leases are stale), and the
/// job still completes all its passes. Before, the worker reported the tile failed, and the
/// failure rules failed the job once the tile had failed on enough workers.
#[tokio::test]
async fn a_damaged_result_a_later_pass_needs_restarts_the_passes() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(cfg(dir.path())).await;
    let job = c.submit(budgeted(32, 3600.0)).await;
    let w = c.register("w").await;
    upload_all(&c, job.id, w, &lease_all(&c, w).await).await;
    wait_pass(&c, job.id, 2).await;
    damage_stored_result(dir.path(), job.id, 0);
    let leases = lease_all(&c, w).await;
    assert!(leases.iter().all(|l| l.pass == Some(2)), "{leases:?}");
    let (status, body) = c
        .send_as(
            Method::GET,
            &format!("/v1/leases/{}/0/previous", job.id),
            Some(WORKER),
            Some(&c.secret(w)),
            "",
        )
        .await;
    let said = serde_json::from_slice::<serde_json::Value>(&body).unwrap()["error"].to_string();
    assert_eq!(status, StatusCode::CONFLICT, "{said}");
    assert!(said.contains("start again from pass 1"), "{said}");
    let info = c.job(job.id).await;
    assert_eq!(info.state, JobState::Running);
    assert_eq!(pass_of(&info).map(|p| p.pass), Some(1), "{info:?}");
    assert_eq!(info.tiles_done, 0);
    assert!(
        info.recent_errors
            .iter()
            .any(|e| e.tile == 0 && e.message.contains("start again from pass 1")),
        "{:?}",
        info.recent_errors
    );
    // The pass-2 leases are stale: their results are refused.
    let (status, _) = c
        .upload(job.id, 1, &pass_upload_for(&leases[1], w, SPP))
        .await;
    assert_eq!(status, StatusCode::CONFLICT);
    render_passes(&c, job.id, w, 1..=4).await;
}

/// The same found at assembly: tile 0's last-pass result damaged before the job's image is
/// made. Rendering pass 4 of that tile again would need its pass-3 result, which the row no
/// longer keeps, so the passes start again from pass 1 and the job completes them.
#[tokio::test]
async fn a_damaged_result_at_assembly_restarts_the_passes() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(cfg(dir.path())).await;
    let job = c.submit(budgeted(32, 3600.0)).await;
    let w = c.register("w").await;
    render_passes(&c, job.id, w, 1..=3).await;
    let leases = lease_all(&c, w).await;
    assert!(leases.iter().all(|l| l.pass == Some(4)), "{leases:?}");
    upload_all(&c, job.id, w, &leases[..3]).await;
    damage_stored_result(dir.path(), job.id, leases[0].tile_index);
    upload_all(&c, job.id, w, &leases[3..]).await;
    let info = wait_pass(&c, job.id, 1).await;
    assert_eq!(info.state, JobState::Running, "{:?}", info.error);
    assert!(
        info.recent_errors
            .iter()
            .any(|e| e.message.contains("start again from pass 1")),
        "{:?}",
        info.recent_errors
    );
    render_passes(&c, job.id, w, 1..=4).await;
}
