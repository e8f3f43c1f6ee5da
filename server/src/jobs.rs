//! The coordinator's ledger: every job and worker in memory, written through to the database;
//! submission, progress, cancellation, deletion.
//!
//! [`Ledger`] mirrors the database ([`crate::db`]) and owns the connection, so one lock orders
//! every change: each change is written to the database first and applied in memory only once
//! the write succeeded. A restarted coordinator rebuilds the ledger from the database with
//! [`Ledger::load`]. Leasing, heartbeats, uploads and failures are in [`crate::lease`].
//!
//! Memory per job is bounded: only a live (queued, running, paused) job keeps per-tile state,
//! a [`Tile`] of a few words and a rectangle per tile (result hashes stay in the database). A
//! finished job keeps its counts and statistics only ([`Job::release_tiles`]), and a restart
//! loads per-tile state for live jobs alone.

use std::collections::{BTreeMap, BTreeSet, HashMap, VecDeque};
use std::sync::Arc;
use std::time::Duration;

use rusqlite::Connection;
use spindle_common::noise::NoiseSums;
use spindle_common::protocol::{
    EventKind, JobInfo, JobSpec, JobState, LOST_WORKERS_LISTED_S, RECENT_TILE_ERRORS, SubmitJob,
    THROUGHPUT_WINDOW_S, TileError, WorkerInfo, WorkerState, format_labels,
};
use spindle_common::provenance::Provenance;
use spindle_common::stats::RenderStats;
use spindle_common::tile::TileRect;
use tokio::time::Instant;

use crate::db::{self, JobRow, TileRowState};
use crate::error::Error;
use crate::events::Events;
use crate::passes::Passes;

/// Worker failures on one tile that fail its job.
pub const TILE_FAILURE_LIMIT: usize = 3;
/// Tiles a worker may fail in one job before it is kept off that job.
pub const WORKER_STRIKE_LIMIT: usize = 3;
/// Tile failures, over all tiles and workers, that fail a job: a job whose tiles keep failing
/// on different workers is broken even if no single tile reached [`TILE_FAILURE_LIMIT`].
pub const JOB_FAILURE_LIMIT: usize = 10;
/// Distinct workers that must report a tile's failure as deterministic ("no worker could do
/// better") before the job fails for it: one worker's word is a claim, which any registered
/// identity could make about anyone's job.
pub const DETERMINISTIC_CONFIRMATIONS: usize = 2;
/// A lease's greatest age, in lease TTLs, however often it is renewed, while the job has no
/// measured tile ([`Ledger::max_lease_age`]).
pub const MAX_LEASE_AGE_TTLS: u32 = 20;
/// A lease's greatest age, in multiples of the slowest render time measured on the job's
/// finished tiles, when that is longer.
pub const MAX_LEASE_AGE_RENDERS: f64 = 8.0;

/// Every job and worker the coordinator knows, with the database they are stored in.
pub struct Ledger {
    pub(crate) db: Connection,
    pub(crate) jobs: BTreeMap<u64, Job>,
    pub(crate) workers: HashMap<u64, Worker>,
    pub(crate) lease_ttl: Duration,
    /// Idempotency key → (job, hash of the request that created it).
    keys: HashMap<String, (u64, String)>,
    /// Where every job state change, finished tile and worker change is announced.
    pub(crate) events: Arc<Events>,
}

/// One registered worker, as far as the coordinator can tell.
pub struct Worker {
    pub name: String,
    pub threads: u32,
    pub version: String,
    pub labels: BTreeMap<String, String>,
    /// Told to drain: it gets no more leases (410) and its heartbeats answer `drain`.
    pub draining: bool,
    /// Wall-clock time it was last heard from, in ms since the Unix epoch.
    pub last_seen_ms: i64,
    /// Tiles accepted from it, and tile failures it reported, ever.
    pub tiles_done: u64,
    pub failures: u64,
    /// When its tiles were accepted within the last [`THROUGHPUT_WINDOW_S`] (ms since the
    /// Unix epoch, oldest first; trimmed as tiles arrive, at most [`MAX_RECENT_TILES`]).
    pub recent_tiles: VecDeque<i64>,
    /// The worker counts as connected until then, unless it is in a lease poll: renewed by
    /// every request it makes, by one lease TTL.
    pub seen_until: Instant,
    /// Lease long polls of this worker in progress.
    pub polls: u32,
    /// Its loss was announced (reset when it is heard from again).
    pub announced_lost: bool,
    /// The SHA-256 of its secret (see [`crate::worker_secret`]); `None` for a worker
    /// registered before secrets existed, which must register again.
    pub secret_sha256: Option<[u8; 32]>,
}

/// Bound on [`Worker::recent_tiles`]: beyond it the throughput saturates rather than memory
/// growing with a fast worker.
pub const MAX_RECENT_TILES: usize = 100_000;

impl Worker {
    /// Is the worker connected at `now`?
    pub fn is_live(&self, now: Instant) -> bool {
        self.polls > 0 || self.seen_until > now
    }

    /// May the worker take tiles of a job requiring `requires` at `now`: connected, not
    /// draining, and labelled with every requirement.
    pub fn eligible(&self, requires: &BTreeMap<String, String>, now: Instant) -> bool {
        self.is_live(now) && !self.draining && self.has_labels(requires)
    }

    /// Does the worker carry every label of `requires`?
    pub fn has_labels(&self, requires: &BTreeMap<String, String>) -> bool {
        requires.iter().all(|(k, v)| self.labels.get(k) == Some(v))
    }

    /// Notes a tile accepted at `at_ms`.
    pub(crate) fn tile_accepted(&mut self, at_ms: i64) {
        self.tiles_done += 1;
        if self.recent_tiles.len() == MAX_RECENT_TILES {
            self.recent_tiles.pop_front();
        }
        self.recent_tiles.push_back(at_ms);
        let since = at_ms - THROUGHPUT_WINDOW_S as i64 * 1000;
        while self.recent_tiles.front().is_some_and(|&t| t < since) {
            self.recent_tiles.pop_front();
        }
    }

    /// Tiles accepted within the last [`THROUGHPUT_WINDOW_S`] before `now_ms`, per minute.
    pub fn tiles_per_min(&self, now_ms: i64) -> f64 {
        let since = now_ms - THROUGHPUT_WINDOW_S as i64 * 1000;
        let n = self.recent_tiles.iter().filter(|&&t| t >= since).count();
        n as f64 / (THROUGHPUT_WINDOW_S as f64 / 60.0)
    }
}

/// One job.
pub struct Job {
    pub id: u64,
    /// As submitted; '' for none (shown as `job-<id>`).
    pub name: String,
    pub submitter: Option<String>,
    pub spec: Arc<JobSpec>,
    pub priority: i32,
    /// Worker labels a worker must carry to be leased this job's tiles.
    pub requires: BTreeMap<String, String>,
    pub state: JobState,
    pub error: Option<String>,
    pub created_ms: i64,
    pub started_ms: Option<i64>,
    pub finished_ms: Option<i64>,
    /// Tiles in the job.
    pub tiles_total: u32,
    /// Tile rectangles in centre-first order; a tile's index is its position here. Empty once
    /// the job is finished.
    pub rects: Vec<TileRect>,
    /// Per-tile state, as long as the job is live (empty once it is finished).
    pub tiles: Vec<Tile>,
    /// Indices of tiles in [`TileStatus::Leased`].
    pub leased: BTreeSet<u32>,
    pub tiles_done: u32,
    /// Sum of the finished tiles' statistics.
    pub stats: RenderStats,
    /// Sum of the finished tiles' noise sums ([`JobInfo::relative_error`]).
    pub noise: NoiseSums,
    /// Tile → workers that failed it.
    pub failed_by: HashMap<u32, BTreeSet<u64>>,
    /// Tile → workers that reported it cannot be rendered anywhere (a deterministic failure,
    /// [`DETERMINISTIC_CONFIRMATIONS`] of which fail the job). Since this process started.
    pub deterministic_by: HashMap<u32, BTreeSet<u64>>,
    /// Worker → tiles of this job it failed.
    pub strikes: HashMap<u64, BTreeSet<u32>>,
    /// Tile failures recorded for this job, in total.
    pub failures: usize,
    /// The newest tile failures, oldest first, at most [`RECENT_TILE_ERRORS`].
    pub recent_errors: VecDeque<TileError>,
    /// Every tile is in and the final image is being written.
    pub assembling: bool,
    /// The SHA-256 of the final EXR as written (hex), once the job is done; `None` for a job
    /// done before digests were recorded.
    pub image_sha256: Option<String>,
    /// What the job's scene builds to, from the first tile that reported it.
    pub provenance: Option<Arc<Provenance>>,
    /// A job with `film.time_budget_s`: its progressive passes ([`crate::passes`]).
    pub passes: Option<Passes>,
}

/// One tile of a job.
#[derive(Debug, Clone, PartialEq)]
pub struct Tile {
    /// The epoch of the latest lease (0: never leased).
    pub epoch: u64,
    /// The worker of the latest lease, while that lease may still report.
    pub worker: Option<u64>,
    pub status: TileStatus,
    /// When the latest lease was granted by this process.
    pub leased_at: Option<Instant>,
    /// A done tile's render seconds as its worker reported them.
    pub render_seconds: Option<f64>,
}

/// Where a tile is. A done tile's result hash is in the database ([`db::done_hash`]).
#[derive(Debug, Clone, PartialEq)]
pub enum TileStatus {
    Pending,
    Leased { deadline: Instant },
    Done,
}

impl Tile {
    pub(crate) const PENDING: Tile = Tile {
        epoch: 0,
        worker: None,
        status: TileStatus::Pending,
        leased_at: None,
        render_seconds: None,
    };
}

/// Milliseconds since the Unix epoch, for the times kept in the database.
pub fn now_ms() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_millis() as i64)
        .unwrap_or(0)
}

impl Job {
    fn new(id: u64, spec: Arc<JobSpec>, priority: i32, created_ms: i64) -> Job {
        let rects = spec.tiles();
        let tiles = vec![Tile::PENDING; rects.len()];
        Job {
            passes: Passes::of(&spec),
            tiles_total: rects.len() as u32,
            id,
            name: String::new(),
            submitter: None,
            spec,
            priority,
            requires: BTreeMap::new(),
            state: JobState::Queued,
            error: None,
            created_ms,
            started_ms: None,
            finished_ms: None,
            rects,
            tiles,
            leased: BTreeSet::new(),
            tiles_done: 0,
            stats: RenderStats::default(),
            noise: NoiseSums::default(),
            failed_by: HashMap::new(),
            deterministic_by: HashMap::new(),
            strikes: HashMap::new(),
            failures: 0,
            recent_errors: VecDeque::new(),
            assembling: false,
            image_sha256: None,
            provenance: None,
        }
    }

    /// Is the job still taking tiles: heartbeats, uploads and failures of its leases (paused
    /// jobs too)?
    pub fn is_active(&self) -> bool {
        !self.state.is_finished() && !self.assembling
    }

    /// Does the job hand out new leases (active and not paused)?
    pub fn is_leasing(&self) -> bool {
        self.is_active() && self.state != JobState::Paused
    }

    /// The name clients see.
    pub fn display_name(&self) -> String {
        if self.name.is_empty() {
            format!("job-{}", self.id)
        } else {
            self.name.clone()
        }
    }

    /// Is every tile in?
    pub fn is_complete(&self) -> bool {
        self.tiles_done == self.tiles_total
    }

    /// The job as clients see it, at wall-clock time `now_ms`, with `workers_live` workers
    /// connected, `workers_eligible` of which may take its tiles.
    pub fn info(&self, now_ms: i64, workers_live: u32, workers_eligible: u32) -> JobInfo {
        let elapsed_ms = match self.started_ms {
            Some(start) => (self.finished_ms.unwrap_or(now_ms) - start).max(0),
            None => 0,
        };
        let elapsed_s = elapsed_ms as f64 / 1000.0;
        let total = self.tiles_total;
        let eta_s = (self.tiles_done > 0 && !self.state.is_finished())
            .then(|| elapsed_s / self.tiles_done as f64 * (total - self.tiles_done) as f64);
        JobInfo {
            id: self.id,
            name: self.display_name(),
            submitter: self.submitter.clone(),
            submitted_at_ms: self.created_ms,
            state: self.state,
            priority: self.priority,
            width: self.spec.scene.film.width,
            height: self.spec.scene.film.height,
            tile_size: self.spec.tile_size,
            tiles_done: self.tiles_done,
            tiles_total: total,
            elapsed_s,
            eta_s,
            error: self.error.clone(),
            recent_errors: self.recent_errors.iter().cloned().collect(),
            workers_live,
            requires: self.requires.clone(),
            workers_eligible,
            stats: self.stats,
            provenance: self.provenance.as_deref().cloned(),
            relative_error: self.noise.relative_error(self.spec.scene.film.spp),
            crop: self.spec.crop,
            passes: self
                .passes
                .as_ref()
                .map(|p| p.info(self.spec.scene.film.spp)),
        }
    }

    /// Keeps `error` among the newest few.
    pub(crate) fn remember_error(&mut self, error: TileError) {
        if self.recent_errors.len() == RECENT_TILE_ERRORS {
            self.recent_errors.pop_front();
        }
        self.recent_errors.push_back(error);
    }

    /// Forgets the per-tile state of a job that has finished: its leases, tiles, rectangles
    /// and failure bookkeeping. Its counts, statistics and recent errors stay.
    pub(crate) fn release_tiles(&mut self) {
        self.leased = BTreeSet::new();
        self.tiles = Vec::new();
        self.rects = Vec::new();
        self.failed_by = HashMap::new();
        self.deterministic_by = HashMap::new();
        self.strikes = HashMap::new();
        if let Some(passes) = &mut self.passes {
            passes.release();
        }
    }

    /// Rebuilds the per-tile state of a live job from its stored tile rows. Tiles recorded as
    /// leased keep their lease until `lease_deadline` (after a restart), or are pending (`None`).
    pub(crate) fn restore_tiles(
        &mut self,
        db: &Connection,
        lease_deadline: Option<Instant>,
    ) -> anyhow::Result<()> {
        self.rects = self.spec.tiles();
        self.tiles = vec![Tile::PENDING; self.rects.len()];
        self.leased = BTreeSet::new();
        self.tiles_done = 0;
        self.stats = RenderStats::default();
        self.noise = db::tile_noise_totals(db, self.id)?;
        for (index, stored) in db::load_tiles(db, self.id)? {
            let Some(tile) = self.tiles.get_mut(index as usize) else {
                anyhow::bail!("job {}: stored tile {index} out of range", self.id);
            };
            tile.epoch = stored.epoch;
            match (stored.state, lease_deadline) {
                (TileRowState::Pending, _) | (TileRowState::Leased, None) => {}
                (TileRowState::Leased, Some(deadline)) => {
                    tile.worker = stored.worker_id;
                    tile.status = TileStatus::Leased { deadline };
                    self.leased.insert(index);
                }
                (TileRowState::Done { stats, .. }, _) => {
                    tile.worker = stored.worker_id;
                    tile.render_seconds = stored.render_seconds;
                    tile.status = TileStatus::Done;
                    self.tiles_done += 1;
                    self.stats.add(&stats);
                }
            }
        }
        Ok(())
    }
}

/// Which jobs `GET /v1/jobs` lists.
#[derive(Debug, Clone)]
pub struct JobFilter {
    pub state: Option<JobState>,
    /// Jobs whose name contains this.
    pub name: Option<String>,
    /// Jobs with a larger id only (the cursor).
    pub after: Option<u64>,
    pub limit: usize,
}

/// An admitted submission, ready to be stored.
pub struct NewJob {
    pub spec: JobSpec,
    pub priority: i32,
    pub requires: BTreeMap<String, String>,
    pub name: Option<String>,
    pub submitter: Option<String>,
    pub idempotency_key: Option<String>,
    /// blake3 of the canonical request, to tell a retry from a different request with the
    /// same key.
    pub request_hash: String,
}

impl NewJob {
    /// The job `submit` asks for; a retry with the same `idempotency_key` must hash the same.
    pub fn new(submit: SubmitJob, idempotency_key: Option<String>) -> Result<NewJob, Error> {
        let canonical = serde_json::to_vec(&submit).map_err(anyhow::Error::from)?;
        Ok(NewJob {
            request_hash: blake3::hash(&canonical).to_hex().to_string(),
            spec: JobSpec {
                scene: submit.scene,
                assets: submit.assets,
                tile_size: submit.tile_size,
                crop: submit.crop,
            },
            priority: submit.priority,
            requires: submit.requires,
            name: submit.name,
            submitter: submit.submitter,
            idempotency_key,
        })
    }
}

impl Ledger {
    /// Rebuilds the ledger from the database. Leases that were live when the previous process
    /// stopped get `grace` from `now` to be renewed before they expire.
    pub fn load(
        mut db: Connection,
        lease_ttl: Duration,
        grace: Duration,
        now: Instant,
    ) -> anyhow::Result<Ledger> {
        let mut jobs = BTreeMap::new();
        let mut keys = HashMap::new();
        for row in db::load_jobs(&db)? {
            let spec: JobSpec = serde_json::from_str(&row.spec_json)
                .map_err(|e| anyhow::anyhow!("job {}: stored spec: {e}", row.id))?;
            let mut job = Job::new(row.id, Arc::new(spec), row.priority, row.created_ms);
            job.name = row.name;
            job.submitter = row.submitter;
            job.requires = serde_json::from_str(&row.requires_json)
                .map_err(|e| anyhow::anyhow!("job {}: stored requirements: {e}", row.id))?;
            job.state = row.state;
            job.error = row.error;
            job.started_ms = row.started_ms;
            job.finished_ms = row.finished_ms;
            job.image_sha256 = row.image_sha256;
            if let Some(json) = &row.provenance_json {
                let provenance = serde_json::from_str(json)
                    .map_err(|e| anyhow::anyhow!("job {}: stored provenance: {e}", row.id))?;
                job.provenance = Some(Arc::new(provenance));
            }
            if job.state.is_finished() {
                if let Some(json) = &row.passes_json {
                    job.restore_passes(json, &[])?;
                }
                job.release_tiles();
                let (done, stats) = match row.totals {
                    Some(totals) => totals,
                    None => db::tile_totals(&db, row.id)?,
                };
                job.tiles_done = done;
                job.stats = stats;
                job.noise = match db::job_noise(&db, row.id)? {
                    Some(noise) => noise,
                    None => db::tile_noise_totals(&db, row.id)?,
                };
                if job.state == JobState::Done && row.totals.is_none() {
                    // Done before totals were recorded: its tile rows are not needed.
                    let tx = db.transaction()?;
                    db::set_job_noise(&tx, row.id, &job.noise)?;
                    db::settle_done_job(&tx, row.id, done, &stats, None)?;
                    tx.commit()?;
                }
            } else {
                match &row.passes_json {
                    Some(json) => {
                        let rows = db::pass_rows(&db, row.id)?;
                        job.restore_passes(json, &rows)?;
                    }
                    // Stored before its passes were: rendered again from pass 1.
                    None => Ledger::restart_passes(&mut db, &job)?,
                }
                job.restore_tiles(&db, Some(now + grace))?;
            }
            let live = !job.state.is_finished();
            for failure in db::load_failures(&db, row.id)? {
                job.failures += 1;
                job.remember_error(TileError {
                    tile: failure.tile_index,
                    worker_id: failure.worker_id,
                    worker: failure.worker_name.clone(),
                    at_ms: failure.at_ms,
                    message: failure.reason.clone(),
                });
                if live {
                    job.failed_by
                        .entry(failure.tile_index)
                        .or_default()
                        .insert(failure.worker_id);
                    job.strikes
                        .entry(failure.worker_id)
                        .or_default()
                        .insert(failure.tile_index);
                }
            }
            if let Some(key) = row.idempotency_key {
                keys.insert(key, (row.id, row.request_hash));
            }
            jobs.insert(row.id, job);
        }
        // Workers known before a restart get the same grace as their leases to come back.
        let wall = now_ms();
        let mut workers = HashMap::new();
        for row in db::load_workers(&db)? {
            let labels = serde_json::from_str(&row.labels_json)
                .map_err(|e| anyhow::anyhow!("worker {}: stored labels: {e}", row.id))?;
            let worker = Worker {
                name: row.name,
                threads: row.threads,
                version: row.version,
                labels,
                draining: row.draining,
                // Not known across a restart; the restart is when it was last accounted for.
                last_seen_ms: wall.max(row.registered_ms),
                tiles_done: row.tiles_done,
                failures: row.failures,
                recent_tiles: VecDeque::new(),
                seen_until: now + grace,
                polls: 0,
                announced_lost: false,
                secret_sha256: row.secret_sha256,
            };
            workers.insert(row.id, worker);
        }
        Ok(Ledger {
            db,
            jobs,
            workers,
            lease_ttl,
            keys,
            events: Arc::new(Events::default()),
        })
    }

    /// The job with this id.
    pub fn job(&self, id: u64) -> Result<&Job, Error> {
        self.jobs
            .get(&id)
            .ok_or_else(|| Error::NotFound(format!("job {id} does not exist")))
    }

    pub(crate) fn job_mut(&mut self, id: u64) -> Result<&mut Job, Error> {
        self.jobs
            .get_mut(&id)
            .ok_or_else(|| Error::NotFound(format!("job {id} does not exist")))
    }

    /// Stores a new job, or returns the one an earlier request with the same idempotency key
    /// created (`false`: nothing new was stored).
    pub fn submit(&mut self, new: NewJob, max_active: usize) -> Result<(JobInfo, bool), Error> {
        let now = now_ms();
        if let Some(key) = &new.idempotency_key
            && let Some((id, hash)) = self.keys.get(key)
        {
            if *hash != new.request_hash {
                return Err(Error::Conflict(format!(
                    "Idempotency-Key {key:?} was already used for a different request (job {id})"
                )));
            }
            return Ok((self.info(*id)?, false));
        }
        let active = self
            .jobs
            .values()
            .filter(|j| !j.state.is_finished())
            .count();
        if active >= max_active {
            return Err(Error::TooMany(format!(
                "{active} jobs are queued or running, the limit is {max_active}; \
                 wait for one to finish or cancel one"
            )));
        }
        let row = JobRow {
            id: 0,
            spec_json: serde_json::to_string(&new.spec).map_err(anyhow::Error::from)?,
            priority: new.priority,
            state: JobState::Queued,
            error: None,
            idempotency_key: new.idempotency_key.clone(),
            request_hash: new.request_hash.clone(),
            requires_json: serde_json::to_string(&new.requires).map_err(anyhow::Error::from)?,
            name: new.name.clone().unwrap_or_default(),
            submitter: new.submitter.clone(),
            created_ms: now,
            started_ms: None,
            finished_ms: None,
            totals: None,
            image_sha256: None,
            provenance_json: None,
            passes_json: Passes::json_of(&new.spec)?,
        };
        let id = db::insert_job(&self.db, &row)?;
        let mut job = Job::new(id, Arc::new(new.spec), new.priority, now);
        job.requires = new.requires;
        job.name = new.name.unwrap_or_default();
        job.submitter = new.submitter;
        self.jobs.insert(id, job);
        let info = self.info(id)?;
        if let Some(key) = new.idempotency_key {
            self.keys.insert(key, (id, new.request_hash));
        }
        self.job_changed(id);
        tracing::info!(
            job = id,
            tiles = info.tiles_total,
            priority = info.priority,
            "job submitted"
        );
        Ok((info, true))
    }

    /// A job as clients see it now.
    pub fn info(&self, id: u64) -> Result<JobInfo, Error> {
        let now = Instant::now();
        let job = self.job(id)?;
        Ok(job.info(
            now_ms(),
            self.workers_live(now),
            self.workers_eligible(&job.requires, now),
        ))
    }

    /// Announces job `id`'s current state.
    pub(crate) fn job_changed(&self, id: u64) {
        if let Some(job) = self.jobs.get(&id) {
            self.events.publish(EventKind::JobState {
                job: id,
                state: job.state,
                error: job.error.clone(),
            });
        }
    }

    /// Announces workers not heard from for a lease TTL, once per loss.
    pub fn announce_lost(&mut self, now: Instant) {
        for (&id, w) in self.workers.iter_mut() {
            if w.is_live(now) {
                w.announced_lost = false;
            } else if !w.announced_lost {
                w.announced_lost = true;
                self.events.publish(EventKind::WorkerLost {
                    worker_id: id,
                    worker: w.name.clone(),
                });
            }
        }
    }

    /// A page of the jobs `filter` selects, oldest first, and the cursor of the next page.
    pub fn list(&self, filter: &JobFilter) -> (Vec<JobInfo>, Option<String>) {
        let now = Instant::now();
        let wall = now_ms();
        let live = self.workers_live(now);
        let start = filter.after.map_or(0, |a| a.saturating_add(1));
        let mut selected = self.jobs.range(start..).map(|(_, j)| j).filter(|j| {
            filter.state.is_none_or(|s| j.state == s)
                && filter
                    .name
                    .as_ref()
                    .is_none_or(|n| j.display_name().contains(n.as_str()))
        });
        let page: Vec<JobInfo> = selected
            .by_ref()
            .take(filter.limit)
            .map(|j| j.info(wall, live, self.workers_eligible(&j.requires, now)))
            .collect();
        let next = match (page.last(), selected.next()) {
            (Some(last), Some(_)) => Some(last.id.to_string()),
            _ => None,
        };
        (page, next)
    }

    /// Pauses a queued or running job: no new leases; leased tiles finish and are kept.
    pub fn pause(&mut self, id: u64) -> Result<JobInfo, Error> {
        let job = self.job(id)?;
        match job.state {
            JobState::Paused => return self.info(id),
            JobState::Queued | JobState::Running => {}
            finished => {
                return Err(Error::Conflict(format!(
                    "job {id} is {}; only a queued or running job can be paused",
                    finished.as_str()
                )));
            }
        }
        let (started, error) = (job.started_ms, job.error.clone());
        // A budgeted job's clock stops (`passes::PassClock`).
        let clock = job.clock_with(|c| c.pause(now_ms()))?;
        let tx = self.db.transaction()?;
        db::set_job_state(&tx, id, JobState::Paused, error.as_deref(), started, None)?;
        if let Some((_, json)) = &clock {
            db::set_passes(&tx, id, json)?;
        }
        tx.commit()?;
        let job = self.job_mut(id)?;
        job.state = JobState::Paused;
        job.set_clock(clock);
        self.job_changed(id);
        tracing::info!(job = id, "job paused");
        self.info(id)
    }

    /// Resumes a paused job (running if it had started, else queued); a job that is not
    /// paused and not finished is left as it is.
    pub fn resume(&mut self, id: u64) -> Result<JobInfo, Error> {
        let job = self.job(id)?;
        match job.state {
            JobState::Paused => {}
            JobState::Queued | JobState::Running => return self.info(id),
            finished => {
                return Err(Error::Conflict(format!(
                    "job {id} is {}; only a paused job can be resumed (requeue a failed or \
                     cancelled one)",
                    finished.as_str()
                )));
            }
        }
        let started = job.started_ms;
        let state = if started.is_some() {
            JobState::Running
        } else {
            JobState::Queued
        };
        let clock = job.clock_with(|c| c.resume(now_ms(), started))?;
        let tx = self.db.transaction()?;
        db::set_job_state(&tx, id, state, None, started, None)?;
        if let Some((_, json)) = &clock {
            db::set_passes(&tx, id, json)?;
        }
        tx.commit()?;
        let job = self.job_mut(id)?;
        job.state = state;
        job.set_clock(clock);
        self.job_changed(id);
        tracing::info!(job = id, "job resumed");
        self.info(id)
    }

    /// Puts a failed or cancelled job back in the queue: its unfinished tiles are pending again
    /// and its failures forgotten (finished tiles are kept). A done job is a conflict.
    pub fn requeue(&mut self, id: u64, max_active: usize) -> Result<JobInfo, Error> {
        let job = self.job(id)?;
        if !matches!(job.state, JobState::Failed | JobState::Cancelled) {
            return Err(Error::Conflict(format!(
                "job {id} is {}; only a failed or cancelled job can be requeued",
                job.state.as_str()
            )));
        }
        let active = self
            .jobs
            .values()
            .filter(|j| !j.state.is_finished())
            .count();
        if active >= max_active {
            return Err(Error::TooMany(format!(
                "{active} jobs are queued or running, the limit is {max_active}"
            )));
        }
        let tx = self.db.transaction()?;
        db::requeue_job(&tx, id)?;
        db::set_job_state(&tx, id, JobState::Queued, None, None, None)?;
        tx.commit()?;
        let job = self
            .jobs
            .get_mut(&id)
            .ok_or_else(|| Error::NotFound(format!("job {id} does not exist")))?;
        Ledger::restart_passes(&mut self.db, job)?;
        job.passes = Passes::of(&job.spec);
        job.restore_tiles(&self.db, None)?;
        job.state = JobState::Queued;
        job.error = None;
        job.started_ms = None;
        job.finished_ms = None;
        job.failed_by.clear();
        job.deterministic_by.clear();
        job.strikes.clear();
        job.failures = 0;
        job.recent_errors.clear();
        self.job_changed(id);
        tracing::info!(job = id, "job requeued");
        self.info(id)
    }

    /// Changes a job's priority.
    pub fn set_priority(&mut self, id: u64, priority: i32) -> Result<JobInfo, Error> {
        self.job(id)?;
        db::set_job_priority(&self.db, id, priority)?;
        self.job_mut(id)?.priority = priority;
        tracing::info!(job = id, priority, "job priority changed");
        self.info(id)
    }

    /// How many workers may take tiles of a job requiring `requires` at `now`.
    pub fn workers_eligible(&self, requires: &BTreeMap<String, String>, now: Instant) -> u32 {
        let n = self
            .workers
            .values()
            .filter(|w| w.eligible(requires, now))
            .count();
        u32::try_from(n).unwrap_or(u32::MAX)
    }

    /// Every connected worker and the lost ones heard from within [`LOST_WORKERS_LISTED_S`],
    /// by id.
    pub fn worker_list(&self) -> Vec<WorkerInfo> {
        let now = Instant::now();
        let wall = now_ms();
        // The lowest leased (job, tile) of each worker.
        let mut holding: HashMap<u64, (u64, u32)> = HashMap::new();
        for job in self.jobs.values() {
            for &index in &job.leased {
                if let Some(w) = job.tiles[index as usize].worker {
                    holding.entry(w).or_insert((job.id, index));
                }
            }
        }
        let mut list: Vec<WorkerInfo> = self
            .workers
            .iter()
            .filter(|(_, w)| {
                w.is_live(now) || wall - w.last_seen_ms <= LOST_WORKERS_LISTED_S as i64 * 1000
            })
            .map(|(&id, w)| {
                let lease = holding.get(&id).copied();
                let state = if !w.is_live(now) {
                    WorkerState::Lost
                } else if w.draining {
                    WorkerState::Draining
                } else if lease.is_some() {
                    WorkerState::Rendering
                } else {
                    WorkerState::Idle
                };
                WorkerInfo {
                    id,
                    name: w.name.clone(),
                    version: w.version.clone(),
                    threads: w.threads,
                    labels: w.labels.clone(),
                    state,
                    job: lease.map(|l| l.0),
                    tile: lease.map(|l| l.1),
                    last_seen_ms: w.last_seen_ms,
                    tiles_done: w.tiles_done,
                    failures: w.failures,
                    tiles_per_min: w.tiles_per_min(wall),
                }
            })
            .collect();
        list.sort_by_key(|w| w.id);
        list
    }

    /// Tells the connected workers named `name_or_id` (an id, or a name) to drain: they get no
    /// more leases and exit after the tile in hand. Returns them as listed after the change.
    pub fn drain(&mut self, name_or_id: &str) -> Result<Vec<WorkerInfo>, Error> {
        let now = Instant::now();
        let by_id = name_or_id
            .parse::<u64>()
            .ok()
            .filter(|id| self.workers.contains_key(id));
        let matching: Vec<u64> = match by_id {
            Some(id) => vec![id],
            None => self
                .workers
                .iter()
                .filter(|(_, w)| w.name == name_or_id)
                .map(|(&id, _)| id)
                .collect(),
        };
        if matching.is_empty() {
            return Err(Error::NotFound(format!(
                "no worker has the id or name {name_or_id:?}"
            )));
        }
        let live: Vec<u64> = matching
            .into_iter()
            .filter(|id| self.workers[id].is_live(now))
            .collect();
        if live.is_empty() {
            return Err(Error::Conflict(format!(
                "worker {name_or_id:?} is lost (not heard from within the lease TTL); \
                 there is nothing to drain"
            )));
        }
        let tx = self.db.transaction()?;
        for &id in &live {
            db::set_worker_draining(&tx, id)?;
        }
        tx.commit()?;
        for id in &live {
            if let Some(w) = self.workers.get_mut(id)
                && !w.draining
            {
                w.draining = true;
                tracing::info!(worker = id, name = %w.name, "worker draining");
                self.events.publish(EventKind::WorkerDraining {
                    worker_id: *id,
                    worker: w.name.clone(),
                });
            }
        }
        Ok(self
            .worker_list()
            .into_iter()
            .filter(|w| live.contains(&w.id))
            .collect())
    }

    /// How many workers are connected at `now`.
    pub fn workers_live(&self, now: Instant) -> u32 {
        let live = self.workers.values().filter(|w| w.is_live(now)).count();
        u32::try_from(live).unwrap_or(u32::MAX)
    }

    /// Cancels a job that has not finished; cancelling a cancelled job changes nothing.
    pub fn cancel(&mut self, id: u64) -> Result<JobInfo, Error> {
        let job = self.job(id)?;
        match job.state {
            JobState::Cancelled => return self.info(id),
            JobState::Done | JobState::Failed => {
                return Err(Error::Conflict(format!(
                    "job {id} is already {}",
                    job.state.as_str()
                )));
            }
            JobState::Queued | JobState::Running | JobState::Paused => {}
        }
        let now = now_ms();
        let started = job.started_ms;
        db::set_job_state(&self.db, id, JobState::Cancelled, None, started, Some(now))?;
        let job = self.job_mut(id)?;
        job.state = JobState::Cancelled;
        job.finished_ms = Some(now);
        job.release_tiles();
        self.job_changed(id);
        tracing::info!(job = id, "job cancelled");
        self.info(id)
    }

    /// Forgets a job (its files are removed by the caller). An unfinished job is a conflict
    /// unless `force`.
    pub fn delete(&mut self, id: u64, force: bool) -> Result<(), Error> {
        let job = self.job(id)?;
        if !job.state.is_finished() && !force {
            return Err(Error::Conflict(format!(
                "job {id} is {}; cancel it first, or delete it with ?force=true",
                job.state.as_str()
            )));
        }
        db::delete_job(&self.db, id)?;
        self.jobs.remove(&id);
        self.keys.retain(|_, (job, _)| *job != id);
        tracing::info!(job = id, "job deleted");
        Ok(())
    }

    /// Ends a job that cannot finish: `failed` with `error`, its leases dropped.
    pub(crate) fn fail_job(&mut self, id: u64, error: String) -> Result<(), Error> {
        let job = self.job(id)?;
        let (started, now) = (job.started_ms, now_ms());
        db::set_job_state(
            &self.db,
            id,
            JobState::Failed,
            Some(&error),
            started,
            Some(now),
        )?;
        let job = self.job_mut(id)?;
        tracing::error!(job = id, %error, "job failed");
        job.state = JobState::Failed;
        job.error = Some(error);
        job.finished_ms = Some(now);
        job.release_tiles();
        self.job_changed(id);
        Ok(())
    }

    /// Checks that the database answers.
    pub fn check_database(&self) -> Result<(), Error> {
        self.db.query_row("SELECT 1", [], |_| Ok(()))?;
        Ok(())
    }

    /// Registers a worker (its labels already checked) and returns its id and secret. At
    /// `max_workers` registered workers, the lost worker heard from longest ago is forgotten to
    /// make room; with none lost, 429 until one is (a lease TTL at most).
    pub fn register_worker(
        &mut self,
        name: &str,
        threads: u32,
        version: &str,
        labels: BTreeMap<String, String>,
        max_workers: usize,
    ) -> Result<(u64, String), Error> {
        if self.workers.len() >= max_workers {
            self.forget_longest_lost(Instant::now())?;
        }
        if self.workers.len() >= max_workers {
            return Err(Error::RateLimited {
                message: format!(
                    "{} workers are registered and connected, the most this coordinator takes \
                     (--max-workers); try again when one is lost",
                    self.workers.len()
                ),
                retry_after: self.lease_ttl.max(Duration::from_secs(1)),
            });
        }
        let now = now_ms();
        let labels_json = serde_json::to_string(&labels).map_err(anyhow::Error::from)?;
        let tx = self.db.transaction()?;
        let id = db::insert_worker(&tx, name, threads, version, &labels_json, now)?;
        let issued = crate::worker_secret::issue(id)?;
        db::set_worker_secret(&tx, id, &issued.sha256)?;
        tx.commit()?;
        tracing::info!(
            worker = id,
            name,
            threads,
            version,
            labels = %format_labels(&labels),
            "worker registered"
        );
        let worker = Worker {
            name: name.to_string(),
            threads,
            version: version.to_string(),
            labels,
            draining: false,
            last_seen_ms: now,
            tiles_done: 0,
            failures: 0,
            recent_tiles: VecDeque::new(),
            seen_until: Instant::now() + self.lease_ttl,
            polls: 0,
            announced_lost: false,
            secret_sha256: Some(issued.sha256),
        };
        self.workers.insert(id, worker);
        self.events.publish(EventKind::WorkerJoined {
            worker_id: id,
            worker: name.to_string(),
        });
        Ok((id, issued.secret))
    }

    /// Forgets the lost worker (not connected) heard from longest ago, if any.
    fn forget_longest_lost(&mut self, now: Instant) -> Result<(), Error> {
        let Some(id) = self
            .workers
            .iter()
            .filter(|(_, w)| !w.is_live(now))
            .min_by_key(|(id, w)| (w.last_seen_ms, **id))
            .map(|(&id, _)| id)
        else {
            return Ok(());
        };
        db::delete_worker(&self.db, id)?;
        self.workers.remove(&id);
        tracing::info!(
            worker = id,
            "lost worker forgotten to make room for a registration"
        );
        Ok(())
    }

    /// The finished tiles of a job as `(index, hash)`, in index order (none once the job is
    /// done: its image holds them).
    pub fn done_tiles(&self, id: u64) -> Result<Vec<(u32, String)>, Error> {
        self.job(id)?;
        Ok(db::done_tiles(&self.db, id)?)
    }

    /// The latest result of each tile of a job as `(index, hash)`, in index order: a finished
    /// tile's, or for a budgeted job's tile whose current pass is not in, its previous pass's
    /// (none once the job is done).
    pub fn latest_results(&self, id: u64) -> Result<Vec<(u32, String)>, Error> {
        self.job(id)?;
        Ok(db::latest_results(&self.db, id)?)
    }

    /// Jobs whose tiles are all in but whose image is not written yet (after a restart, or
    /// when the last tile arrives); marks them as assembling.
    pub fn take_jobs_to_assemble(&mut self) -> Vec<u64> {
        let mut ids = Vec::new();
        for job in self.jobs.values_mut() {
            // A budgeted job's tiles are all in at the end of every pass: its assembly begins
            // by ending the pass, which may queue the next (`Ledger::end_of_pass`).
            if job.is_complete() && !job.state.is_finished() && !job.assembling {
                job.assembling = true;
                ids.push(job.id);
            }
        }
        ids
    }

    /// Records the end of assembly: the image, whose SHA-256 is `image_sha256` (hex), is
    /// written and the job is done (unless it was cancelled meanwhile).
    pub fn finish_assembly(&mut self, id: u64, image_sha256: &str) -> Result<(), Error> {
        let Ok(job) = self.job(id) else {
            return Ok(()); // Deleted meanwhile.
        };
        if job.state.is_finished() {
            return Ok(());
        }
        let now = now_ms();
        let (started, done, stats, noise) = (job.started_ms, job.tiles_done, job.stats, job.noise);
        let tx = self.db.transaction()?;
        db::set_job_state(&tx, id, JobState::Done, None, started, Some(now))?;
        db::set_job_noise(&tx, id, &noise)?;
        db::settle_done_job(&tx, id, done, &stats, Some(image_sha256))?;
        tx.commit()?;
        let job = self.job_mut(id)?;
        job.image_sha256 = Some(image_sha256.to_string());
        job.state = JobState::Done;
        job.error = None;
        job.finished_ms = Some(now);
        job.assembling = false;
        job.release_tiles();
        self.job_changed(id);
        tracing::info!(job = id, state = "done", "job finished");
        Ok(())
    }

    /// Puts finished tiles whose stored result turned out damaged (`(index, why)`) back in the
    /// queue, to be rendered again; the job's statistics drop theirs. A budgeted job past its
    /// first pass starts its passes again ([`Ledger::restart_passes_after_damage`]).
    pub fn requeue_damaged(&mut self, id: u64, damaged: &[(u32, String)]) -> Result<(), Error> {
        // Past pass 1 of a budgeted job a tile continues an earlier pass the row no longer keeps.
        if let Some((index, why)) = damaged.first()
            && self.job(id)?.passes.as_ref().is_some_and(|p| p.pass() > 1)
        {
            return self.restart_passes_after_damage(id, *index, why);
        }
        let tx = self.db.transaction()?;
        for (index, _) in damaged {
            db::requeue_tile(&tx, id, *index)?;
        }
        tx.commit()?;
        let (_, stats) = db::tile_totals(&self.db, id)?;
        let noise = db::tile_noise_totals(&self.db, id)?;
        let at_ms = now_ms();
        let job = self.job_mut(id)?;
        for (index, why) in damaged {
            let tile = &mut job.tiles[*index as usize];
            if tile.status == TileStatus::Done {
                tile.status = TileStatus::Pending;
                tile.worker = None;
                tile.render_seconds = None;
                job.tiles_done -= 1;
            }
            tracing::error!(job = id, tile = index, %why, "stored tile damaged; rendering it again");
            job.remember_error(TileError {
                tile: *index,
                worker_id: 0,
                worker: "coordinator".into(),
                at_ms,
                message: format!("{why}; rendering it again"),
            });
        }
        job.stats = stats;
        job.noise = noise;
        job.assembling = false;
        Ok(())
    }
}

impl Ledger {
    /// Per-tile entries held in memory, over every job (0 for a finished job).
    pub fn tiles_in_memory(&self) -> usize {
        self.jobs
            .values()
            .map(|j| j.tiles.len().max(j.rects.len()))
            .sum()
    }

    /// Deletes the finished jobs that finished at least `keep` before `wall_ms` (ms since the
    /// Unix epoch) and returns their ids (their files are removed by the caller).
    pub fn delete_expired_jobs(&mut self, keep: Duration, wall_ms: i64) -> Result<Vec<u64>, Error> {
        let keep_ms = i64::try_from(keep.as_millis()).unwrap_or(i64::MAX);
        let expired: Vec<u64> = self
            .jobs
            .values()
            .filter(|j| {
                j.state.is_finished()
                    && j.finished_ms
                        .is_none_or(|at| at.saturating_add(keep_ms) <= wall_ms)
            })
            .map(|j| j.id)
            .collect();
        if expired.is_empty() {
            return Ok(expired);
        }
        let tx = self.db.transaction()?;
        for &id in &expired {
            db::delete_job(&tx, id)?;
        }
        tx.commit()?;
        for id in &expired {
            self.jobs.remove(id);
            tracing::info!(job = id, "finished job deleted (retention)");
        }
        self.keys.retain(|_, (job, _)| self.jobs.contains_key(job));
        Ok(expired)
    }

    /// The assets some job still names (a job's assets are kept as long as the job).
    pub fn referenced_assets(&self) -> std::collections::HashSet<String> {
        self.jobs
            .values()
            .flat_map(|j| j.spec.assets.values().cloned())
            .collect()
    }

    /// Forgets workers lost for at least `keep` (not heard from since `wall_ms − keep`);
    /// returns how many. A forgotten worker that comes back is told to register again (404).
    pub fn forget_lost_workers(
        &mut self,
        keep: Duration,
        now: Instant,
        wall_ms: i64,
    ) -> Result<usize, Error> {
        let keep_ms = i64::try_from(keep.as_millis()).unwrap_or(i64::MAX);
        let gone: Vec<u64> = self
            .workers
            .iter()
            .filter(|(_, w)| !w.is_live(now) && w.last_seen_ms.saturating_add(keep_ms) <= wall_ms)
            .map(|(&id, _)| id)
            .collect();
        if gone.is_empty() {
            return Ok(0);
        }
        let tx = self.db.transaction()?;
        for &id in &gone {
            db::delete_worker(&tx, id)?;
        }
        tx.commit()?;
        for id in &gone {
            self.workers.remove(id);
            tracing::info!(worker = id, "lost worker forgotten");
        }
        Ok(gone.len())
    }
}
