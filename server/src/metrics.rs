//! `GET /metrics`: the coordinator's state in the Prometheus text format, for dashboards and
//! for scaling workers on [`TILES_QUEUED`] (KEDA or an HPA, see `deploy/kubernetes`).
//!
//! Gauges (queue, leases, jobs by state, workers, free disk) are computed at scrape time from
//! the ledger, so they cannot drift from it. Events that leave no trace in the ledger (leases
//! granted, tiles stored and failed, lease expiries, determinism faults, upload bytes, the time
//! from a lease to its tile's upload) are counted where they happen, through the functions
//! below, with the `metrics` facade and its Prometheus exporter. The facade is process-wide:
//! the first [`handle`] installs the recorder, and every coordinator in the process (tests run
//! several) shares its counters. Nothing here names a job, worker or scene: aggregates only,
//! so the route needs no token.

use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};
use std::time::Instant;

use axum::extract::State;
use axum::http::header;
use axum::response::IntoResponse;
use metrics_exporter_prometheus::{Matcher, PrometheusBuilder, PrometheusHandle};
use spindle_common::protocol::{JobState, Lease, TileOutcome, WorkerState};

use crate::AppState;
use crate::ledger::tile::TileStatus;

/// Pending tiles of runnable (queued or running) jobs: the work waiting for a worker.
pub const TILES_QUEUED: &str = "spindle_tiles_queued";
/// Tiles leased to a worker right now.
pub const TILES_LEASED: &str = "spindle_tiles_leased";
/// Leases granted.
pub const LEASES: &str = "spindle_leases_total";
/// Tile uploads accepted (a tile finished).
pub const TILES_DONE: &str = "spindle_tiles_done_total";
/// Tile failures reported by workers and recorded.
pub const TILES_FAILED: &str = "spindle_tiles_failed_total";
/// Jobs by state (label `state`).
pub const JOBS: &str = "spindle_jobs";
/// Workers connected now.
pub const WORKERS_LIVE: &str = "spindle_workers_live";
/// Workers by state (label `state`: idle, rendering, draining, lost), as `GET /v1/workers`
/// lists them.
pub const WORKERS: &str = "spindle_workers";
/// Leases that lapsed without an upload (their tiles went back to the queue).
pub const LEASE_EXPIRIES: &str = "spindle_lease_expiries_total";
/// Uploads for a finished tile whose pixels differ from the stored ones.
pub const DETERMINISM_FAULTS: &str = "spindle_determinism_faults_total";
/// Seconds from a lease to the accepted upload of its tile (render, heartbeats, transfer).
pub const TILE_SECONDS: &str = "spindle_tile_seconds";
/// Bytes of tile upload bodies received.
pub const UPLOAD_BYTES: &str = "spindle_upload_bytes_total";
/// Bytes free for the coordinator on the data directory's filesystem.
pub const DISK_FREE: &str = "spindle_data_disk_free_bytes";

/// Buckets of [`TILE_SECONDS`]: a 32-pixel tile takes from milliseconds to many minutes.
const TILE_SECONDS_BUCKETS: [f64; 12] = [
    0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0, 30.0, 60.0, 300.0, 1800.0,
];

/// Lease start times kept for [`TILE_SECONDS`] at most; past it, older ones are dropped (a
/// lease that lapsed never reports).
const MAX_TRACKED_LEASES: usize = 65_536;

/// The process's Prometheus recorder, installed on first use.
pub fn handle() -> &'static PrometheusHandle {
    static HANDLE: OnceLock<PrometheusHandle> = OnceLock::new();
    HANDLE.get_or_init(|| {
        let recorder = PrometheusBuilder::new()
            .set_buckets_for_metric(Matcher::Full(TILE_SECONDS.into()), &TILE_SECONDS_BUCKETS)
            .expect("a non-empty bucket list")
            .build_recorder();
        let handle = recorder.handle();
        if metrics::set_global_recorder(recorder).is_err() {
            tracing::warn!("another metrics recorder is installed; /metrics shows gauges only");
        }
        describe();
        handle
    })
}

fn describe() {
    use metrics::{describe_counter, describe_gauge, describe_histogram};
    describe_gauge!(
        TILES_QUEUED,
        "Pending tiles of queued or running jobs (not paused ones)."
    );
    describe_gauge!(TILES_LEASED, "Tiles leased to a worker now.");
    describe_counter!(LEASES, "Leases granted.");
    describe_counter!(TILES_DONE, "Tile uploads accepted.");
    describe_counter!(TILES_FAILED, "Tile failures recorded.");
    describe_gauge!(JOBS, "Jobs by state.");
    describe_gauge!(WORKERS_LIVE, "Workers connected now.");
    describe_gauge!(WORKERS, "Workers by state, as GET /v1/workers lists them.");
    describe_counter!(LEASE_EXPIRIES, "Leases that lapsed without an upload.");
    describe_counter!(
        DETERMINISM_FAULTS,
        "Second results of a finished tile that differ."
    );
    describe_histogram!(
        TILE_SECONDS,
        metrics::Unit::Seconds,
        "From a lease to the accepted upload of its tile."
    );
    describe_counter!(
        UPLOAD_BYTES,
        metrics::Unit::Bytes,
        "Tile upload bytes received."
    );
    describe_gauge!(
        DISK_FREE,
        metrics::Unit::Bytes,
        "Free bytes on the data directory's filesystem."
    );
}

/// Lease start times by (job, tile, epoch).
type LeaseStarts = Mutex<HashMap<(u64, u32, u64), Instant>>;

fn lease_starts() -> &'static LeaseStarts {
    static STARTS: OnceLock<LeaseStarts> = OnceLock::new();
    STARTS.get_or_init(Default::default)
}

/// A lease was granted.
pub fn lease_granted(lease: &Lease) {
    metrics::counter!(LEASES).increment(1);
    let mut starts = lease_starts().lock().unwrap_or_else(|p| p.into_inner());
    if starts.len() >= MAX_TRACKED_LEASES {
        let now = Instant::now();
        let oldest_kept = std::time::Duration::from_secs(3600);
        starts.retain(|_, &mut t| now.duration_since(t) < oldest_kept);
        if starts.len() >= MAX_TRACKED_LEASES {
            starts.clear();
        }
    }
    starts.insert(
        (lease.job_id, lease.tile_index, lease.epoch),
        Instant::now(),
    );
}

/// A tile upload of `bytes` arrived.
pub fn upload_received(bytes: usize) {
    metrics::counter!(UPLOAD_BYTES).increment(bytes as u64);
}

/// An upload for tile `tile` of job `job`, leased at `epoch`, was stored with `outcome`.
pub fn tile_stored(job: u64, tile: u32, epoch: u64, outcome: TileOutcome) {
    if outcome != TileOutcome::Accepted {
        return;
    }
    metrics::counter!(TILES_DONE).increment(1);
    let started = lease_starts()
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .remove(&(job, tile, epoch));
    if let Some(started) = started {
        metrics::histogram!(TILE_SECONDS).record(started.elapsed().as_secs_f64());
    }
}

/// A worker's tile failure was recorded.
pub fn tile_failed() {
    metrics::counter!(TILES_FAILED).increment(1);
}

/// A lease lapsed.
pub fn lease_expired() {
    metrics::counter!(LEASE_EXPIRIES).increment(1);
}

/// A second, different result for a finished tile arrived.
pub fn determinism_fault() {
    metrics::counter!(DETERMINISM_FAULTS).increment(1);
}

/// The gauges, read from the ledger in one pass under its lock.
#[derive(Debug, PartialEq)]
struct Gauges {
    tiles_queued: u64,
    tiles_leased: u64,
    jobs: [(JobState, u64); 6],
    workers_live: u32,
    workers: [(WorkerState, u64); 4],
}

fn gauges(state: &AppState) -> Gauges {
    let ledger = state.ledger();
    let mut g = Gauges {
        jobs: [
            JobState::Queued,
            JobState::Running,
            JobState::Done,
            JobState::Failed,
            JobState::Cancelled,
            JobState::Paused,
        ]
        .map(|s| (s, 0)),
        tiles_queued: 0,
        tiles_leased: 0,
        workers_live: 0,
        workers: [
            WorkerState::Idle,
            WorkerState::Rendering,
            WorkerState::Draining,
            WorkerState::Lost,
        ]
        .map(|s| (s, 0)),
    };
    for job in ledger.jobs.values() {
        if let Some((_, n)) = g.jobs.iter_mut().find(|(s, _)| *s == job.state) {
            *n += 1;
        }
        if !job.is_active() {
            continue;
        }
        g.tiles_leased += job.leased.len() as u64;
        // The autoscaling signal: a paused job's tiles wait for no worker.
        if job.is_leasing() {
            g.tiles_queued += job
                .tiles
                .iter()
                .filter(|t| t.status == TileStatus::Pending)
                .count() as u64;
        }
    }
    g.workers_live = ledger.workers_live(tokio::time::Instant::now());
    for worker in ledger.worker_list() {
        if let Some((_, n)) = g.workers.iter_mut().find(|(s, _)| *s == worker.state) {
            *n += 1;
        }
    }
    g
}

/// Free bytes for an unprivileged writer on the filesystem of `dir`.
fn disk_free(dir: &std::path::Path) -> Option<u64> {
    let stat = rustix::fs::statvfs(dir).ok()?;
    Some(stat.f_bavail.saturating_mul(stat.f_frsize))
}

/// The coordinator's metrics in the Prometheus text format (no token: aggregates only).
#[utoipa::path(get, path = "/metrics", responses(
    (status = 200, content_type = "text/plain; version=0.0.4", body = String)))]
pub(crate) async fn metrics(State(state): State<AppState>) -> impl IntoResponse {
    let handle = handle();
    let g = gauges(&state);
    metrics::gauge!(TILES_QUEUED).set(g.tiles_queued as f64);
    metrics::gauge!(TILES_LEASED).set(g.tiles_leased as f64);
    for (s, n) in g.jobs {
        metrics::gauge!(JOBS, "state" => s.as_str()).set(n as f64);
    }
    metrics::gauge!(WORKERS_LIVE).set(f64::from(g.workers_live));
    for (s, n) in g.workers {
        metrics::gauge!(WORKERS, "state" => s.as_str()).set(n as f64);
    }
    let dir = state.config().data_dir.clone();
    if let Ok(Some(free)) = tokio::task::spawn_blocking(move || disk_free(&dir)).await {
        metrics::gauge!(DISK_FREE).set(free as f64);
    }
    handle.run_upkeep();
    (
        [(header::CONTENT_TYPE, "text/plain; version=0.0.4")],
        handle.render(),
    )
}
