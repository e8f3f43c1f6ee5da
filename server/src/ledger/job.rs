//! One job as the ledger holds it, and every change of its state.
//!
//! A job is `queued → running → done`, or `paused`, `cancelled` or `failed` on the way; its
//! tiles ([`Tile`]) move as their leases do. Each change is a method here: it says *how* the
//! job changes, never *whether* it may (that is the ledger's, which checks, writes the change
//! through to the database first, then applies it with these methods and announces it). In
//! particular a job ends in one place, [`Job::end`]: done, cancelled and failed alike lose
//! their per-tile state there.
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
use spindle_common::passes::pass_cap;
use spindle_common::protocol::{
    JobInfo, JobSpec, JobState, Lease, RECENT_TILE_ERRORS, TileError, TileFailure, TileUpload,
};
use spindle_common::provenance::Provenance;
use spindle_common::stats::RenderStats;
use spindle_common::tile::TileRect;
use tokio::time::Instant;

use super::passes::{PassClock, Passes};
use super::rules::{
    DETERMINISTIC_CONFIRMATIONS, JOB_FAILURE_LIMIT, MAX_LEASE_AGE_RENDERS, MAX_LEASE_AGE_TTLS,
    TILE_FAILURE_LIMIT, WORKER_STRIKE_LIMIT,
};
use super::tile::{Tile, TileStatus};
use crate::db::{self, TileRowState};
use crate::error::Error;

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
    /// A job with `film.time_budget_s`: its progressive passes ([`super::passes`]).
    pub passes: Option<Passes>,
}

impl Job {
    /// A queued job of `spec`, none of its tiles leased.
    pub(crate) fn new(id: u64, spec: Arc<JobSpec>, priority: i32, created_ms: i64) -> Job {
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

    /// 409 naming the job's state, for a request the job no longer takes.
    pub fn state_conflict(&self) -> Error {
        Error::Conflict(format!("job {} is {}", self.id, self.state.as_str()))
    }

    /// Checks a tile index (404 naming the job's tile count).
    pub fn check_index(&self, index: u32) -> Result<(), Error> {
        if index < self.tiles_total {
            Ok(())
        } else {
            Err(Error::NotFound(format!(
                "job {} has no tile {index} (it has {})",
                self.id, self.tiles_total
            )))
        }
    }

    // ----- The job's own state -----

    /// The first lease was granted at `at_ms`: the job runs.
    pub(crate) fn start(&mut self, at_ms: i64) {
        self.state = JobState::Running;
        self.started_ms = Some(at_ms);
    }

    /// Paused (its clock as stored, for a budgeted job): no new leases.
    pub(crate) fn pause(&mut self, clock: Option<(PassClock, String)>) {
        self.state = JobState::Paused;
        self.set_clock(clock);
    }

    /// Runnable again, in `state` (running if it had started, else queued).
    pub(crate) fn resume(&mut self, state: JobState, clock: Option<(PassClock, String)>) {
        self.state = state;
        self.set_clock(clock);
    }

    /// The job ends at `at_ms` in `state` (done, cancelled or failed, with `error`): it takes
    /// no more tiles, and its per-tile state is forgotten.
    pub(crate) fn end(&mut self, state: JobState, error: Option<String>, at_ms: i64) {
        debug_assert!(state.is_finished());
        self.state = state;
        self.error = error;
        self.finished_ms = Some(at_ms);
        self.assembling = false;
        self.release_tiles();
    }

    /// Back in the queue after it failed or was cancelled: its tiles as stored (finished ones
    /// kept), a budgeted job from pass 1, its failures forgotten. Writes the passes' restart to
    /// `db` first.
    pub(crate) fn requeue(&mut self, db: &mut Connection) -> anyhow::Result<()> {
        self.restart_passes(db)?;
        self.passes = Passes::of(&self.spec);
        self.restore_tiles(db, None)?;
        self.state = JobState::Queued;
        self.error = None;
        self.started_ms = None;
        self.finished_ms = None;
        self.failed_by.clear();
        self.deterministic_by.clear();
        self.strikes.clear();
        self.failures = 0;
        self.recent_errors.clear();
        Ok(())
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
                    tile.done(stored.render_seconds);
                    self.tiles_done += 1;
                    self.stats.add(&stats);
                }
            }
        }
        Ok(())
    }

    // ----- Leases -----

    /// The epoch tile `index`'s next lease gets.
    pub fn next_epoch(&self, index: u32) -> u64 {
        self.tiles[index as usize].epoch + 1
    }

    /// Leases tile `index` to `worker` at `epoch` from `now`, for `ttl`.
    pub(crate) fn lease(
        &mut self,
        index: u32,
        epoch: u64,
        worker: u64,
        now: Instant,
        ttl: Duration,
    ) -> Lease {
        self.tiles[index as usize].lease(epoch, worker, now, ttl);
        self.leased.insert(index);
        Lease {
            job_id: self.id,
            tile_index: index,
            rect: self.rects[index as usize],
            epoch,
            ttl_ms: ttl.as_millis() as u64,
            pass: self.passes.as_ref().map(|p| p.pass()),
        }
    }

    /// Renews the lease of tile `index` until `now + ttl` (reviving a lapsed one nobody took).
    pub(crate) fn renew(&mut self, index: u32, now: Instant, ttl: Duration) {
        self.tiles[index as usize].renew(now, ttl);
        self.leased.insert(index);
    }

    /// The greatest age of a lease of this job with leases of `ttl`: [`MAX_LEASE_AGE_TTLS`]
    /// TTLs, or [`MAX_LEASE_AGE_RENDERS`] times the slowest render its finished tiles
    /// reported, if longer.
    pub fn max_lease_age(&self, ttl: Duration) -> Duration {
        let floor = ttl * MAX_LEASE_AGE_TTLS;
        let slowest = self
            .tiles
            .iter()
            .filter_map(|t| t.render_seconds)
            .fold(0.0f64, f64::max);
        floor.max(Duration::from_secs_f64(
            (slowest * MAX_LEASE_AGE_RENDERS).min(1e9),
        ))
    }

    /// Leased tiles whose lease was granted at least `max_age` before `now`.
    pub fn overdue(&self, now: Instant, max_age: Duration) -> Vec<u32> {
        self.leased
            .iter()
            .copied()
            .filter(|&i| self.tiles[i as usize].is_overdue(now, max_age))
            .collect()
    }

    /// Takes back the lease of tile `index`, older than its greatest age: the tile is queued
    /// again, its holder's result is no longer taken, and the holder is not given it again.
    /// Returns the holder.
    pub(crate) fn take_back(&mut self, index: u32) -> Option<u64> {
        let holder = self.tiles[index as usize].release();
        self.leased.remove(&index);
        if let Some(holder) = holder {
            self.failed_by.entry(index).or_default().insert(holder);
        }
        holder
    }

    /// Returns the leases lapsed by `now` to the queue (their workers' late results are still
    /// taken until the tiles are leased again); returns their tiles.
    pub(crate) fn lapse_expired(&mut self, now: Instant) -> Vec<u32> {
        let lapsed: Vec<u32> = self
            .leased
            .iter()
            .copied()
            .filter(|&i| self.tiles[i as usize].deadline().is_some_and(|d| d <= now))
            .collect();
        for &index in &lapsed {
            self.leased.remove(&index);
            self.tiles[index as usize].lapse();
        }
        lapsed
    }

    /// When the first of its leases lapses, if any.
    pub fn next_expiry(&self) -> Option<Instant> {
        self.leased
            .iter()
            .filter_map(|&i| self.tiles[i as usize].deadline())
            .min()
    }

    /// The first pending tile (centre-first) that `worker` has not failed.
    pub fn next_tile_for(&self, worker: u64) -> Option<u32> {
        self.tiles
            .iter()
            .enumerate()
            .find(|(i, t)| {
                t.status == TileStatus::Pending
                    && !self
                        .failed_by
                        .get(&(*i as u32))
                        .is_some_and(|w| w.contains(&worker))
            })
            .map(|(i, _)| i as u32)
    }

    /// Has `worker` failed so many of this job's tiles that it is kept off it?
    pub fn keeps_off(&self, worker: u64) -> bool {
        self.strikes
            .get(&worker)
            .is_some_and(|tiles| tiles.len() >= WORKER_STRIKE_LIMIT)
    }

    // ----- Results -----

    /// Records the result of tile `index` (already stored): `upload`, its `noise`, its pixels
    /// still sampling in the pass, and the job's provenance if it is the first. Returns whether
    /// every tile is now in.
    pub(crate) fn tile_done(
        &mut self,
        index: u32,
        upload: &TileUpload,
        noise: &NoiseSums,
        sampling: Option<u32>,
        provenance: Option<Provenance>,
    ) -> bool {
        if let Some(p) = provenance {
            self.provenance = Some(Arc::new(p));
        }
        self.tiles[index as usize].done(upload.render_seconds);
        self.leased.remove(&index);
        self.tiles_done += 1;
        self.stats.add(&upload.pixels.stats);
        self.noise.add(noise);
        if let (Some(passes), Some(sampling)) = (&mut self.passes, sampling) {
            passes.tile_done(index, sampling);
        }
        self.is_complete()
    }

    /// Tile `index`'s stored result turned out damaged (`why`), found at `at_ms`: the tile is
    /// queued again (the caller sets the job's sums from the rows left) and the reason kept.
    pub(crate) fn tile_damaged(&mut self, index: u32, why: &str, at_ms: i64) {
        if self.tiles[index as usize].undo() {
            self.tiles_done -= 1;
        }
        self.remember_error(TileError {
            tile: index,
            worker_id: 0,
            worker: "coordinator".into(),
            at_ms,
            message: format!("{why}; rendering it again"),
        });
    }

    /// Every tile of the pass that ended is in: the next pass begins (its clock as stored),
    /// each tile going on from its result in `results` (`(index, hash)`).
    pub(crate) fn begin_next_pass(
        &mut self,
        clock: Option<(PassClock, String)>,
        results: Vec<(u32, String)>,
    ) {
        self.set_clock(clock);
        if let Some(passes) = &mut self.passes {
            passes.begin_next(self.tiles.len(), results);
        }
        for tile in &mut self.tiles {
            *tile = tile.for_next_pass();
        }
        self.leased.clear();
        self.tiles_done = 0;
        self.stats = Default::default();
        self.noise = Default::default();
        self.assembling = false;
    }

    // ----- Failures -----

    /// What a worker's report that it could not render tile `index` does to the job, by the
    /// rules ([`super::rules`]): `Some(reason)` when it fails the job. `names` writes workers
    /// as people read them.
    pub fn failure_verdict(
        &self,
        index: u32,
        failure: &TileFailure,
        names: impl Fn(&[u64]) -> String,
    ) -> Option<String> {
        let worker = names(&[failure.worker_id]);
        let rect = self.rects[index as usize];
        let mut failed_by = self.failed_by.get(&index).cloned().unwrap_or_default();
        failed_by.insert(failure.worker_id);
        let mut claimed_by = self
            .deterministic_by
            .get(&index)
            .cloned()
            .unwrap_or_default();
        if failure.deterministic {
            claimed_by.insert(failure.worker_id);
        }
        let reason = &failure.reason;
        if claimed_by.len() >= DETERMINISTIC_CONFIRMATIONS {
            Some(format!(
                "tile {index} ({rect}) cannot be rendered: {} workers found so ({}); the \
                 last (worker {worker}): {reason}",
                claimed_by.len(),
                names(&claimed_by.iter().copied().collect::<Vec<_>>()),
            ))
        } else if failed_by.len() >= TILE_FAILURE_LIMIT {
            Some(format!(
                "tile {index} ({rect}) failed on {} different workers; last reason \
                 (worker {worker}): {reason}",
                failed_by.len(),
            ))
        } else if self.failures + 1 >= JOB_FAILURE_LIMIT {
            Some(format!(
                "{JOB_FAILURE_LIMIT} tile failures in this job; the last: tile {index} on \
                 worker {worker}: {reason}"
            ))
        } else {
            None
        }
    }

    /// Records that `failure.worker_id` could not render tile `index` (`error`, as shown):
    /// the tile is queued again, not for that worker. Returns how many of the job's tiles that
    /// worker has failed.
    pub(crate) fn tile_failed(
        &mut self,
        index: u32,
        failure: &TileFailure,
        error: TileError,
    ) -> usize {
        let worker = failure.worker_id;
        self.tiles[index as usize].release();
        self.leased.remove(&index);
        self.failed_by.entry(index).or_default().insert(worker);
        let claims = self.deterministic_by.entry(index).or_default();
        if failure.deterministic {
            claims.insert(worker);
        }
        self.failures += 1;
        self.remember_error(error);
        let strikes = self.strikes.entry(worker).or_default();
        strikes.insert(index);
        strikes.len()
    }

    /// Why no worker among `live` (connected, eligible, in id order) can finish the job, if
    /// none can: every one is kept off it, or a failed tile is pending that each of them failed
    /// or is kept off. `names` writes workers as people read them.
    pub fn stuck_reason(&self, live: &[u64], names: impl Fn(&[u64]) -> String) -> Option<String> {
        if live.iter().all(|&w| self.keeps_off(w)) {
            return Some(format!(
                "every connected worker ({}) failed {WORKER_STRIKE_LIMIT} tiles of this job and \
                 is kept off it; last error: {}",
                names(live),
                self.last_error(None)
            ));
        }
        let mut failed: Vec<_> = self.failed_by.iter().collect();
        failed.sort_unstable_by_key(|(index, _)| **index);
        let (&index, by) = failed.into_iter().find(|(index, by)| {
            self.tiles[**index as usize].status == TileStatus::Pending
                && live.iter().all(|w| by.contains(w) || self.keeps_off(*w))
        })?;
        let by: Vec<u64> = by.iter().copied().collect();
        Some(format!(
            "tile {index} ({}) failed on {} and no other connected worker may take it; last \
             error: {}",
            self.rects[index as usize],
            names(&by),
            self.last_error(Some(index))
        ))
    }

    /// The message of the newest recorded failure (of tile `index`, if given).
    fn last_error(&self, index: Option<u32>) -> String {
        self.recent_errors
            .iter()
            .rev()
            .find(|e| index.is_none_or(|i| e.tile == i))
            .map_or_else(
                || "(not kept)".to_string(),
                |e| format!("{} (worker {})", e.message, e.worker),
            )
    }

    // ----- Passes -----

    /// Restores the job's passes from its stored clock `json` and tile rows; a job whose last
    /// pass ended gets its spec at the reached `spp` back.
    pub(crate) fn restore_passes(
        &mut self,
        json: &str,
        rows: &[db::PassRow],
    ) -> anyhow::Result<()> {
        self.passes = Passes::restore(&self.spec, json, rows)
            .map_err(|e| anyhow::anyhow!("job {}: {e}", self.id))?;
        if self.passes.as_ref().is_some_and(Passes::complete) {
            self.spec = Arc::new(self.spec_at_reached_spp());
        }
        Ok(())
    }

    /// Puts every tile of a budgeted job back in the queue for pass 1 in `db`, and stores pass
    /// 1 as its clock (a job requeued, or stored before its passes were). Runs before the tile
    /// rows are read back.
    pub(crate) fn restart_passes(&self, db: &mut Connection) -> anyhow::Result<()> {
        let Some(json) = Passes::json_of(&self.spec).map_err(|e| anyhow::anyhow!("{e}"))? else {
            return Ok(());
        };
        let tx = db.transaction()?;
        for index in 0..self.tiles_total {
            db::requeue_tile(&tx, self.id, index)?;
        }
        db::set_passes(&tx, self.id, &json)?;
        tx.commit()?;
        Ok(())
    }

    /// Its passes start again from pass 1 (`clock`, as stored; the tile rows in `db` already
    /// queued again): every tile is queued, and `error` says why.
    pub(crate) fn restart_passes_from(
        &mut self,
        clock: (PassClock, String),
        db: &Connection,
        error: TileError,
    ) -> anyhow::Result<()> {
        self.passes = Passes::of(&self.spec);
        self.set_clock(Some(clock));
        self.restore_tiles(db, None)?;
        self.assembling = false;
        self.remember_error(error);
        Ok(())
    }

    /// The job's spec at the current pass's sample cap.
    pub(crate) fn spec_at_reached_spp(&self) -> JobSpec {
        let mut spec = JobSpec::clone(&self.spec);
        if let Some(passes) = &self.passes {
            spec.scene.film.spp = pass_cap(passes.pass(), spec.scene.film.spp);
        }
        spec
    }

    /// The last pass ended and no other follows (its clock as stored): the job's spec is fixed
    /// at the reached `spp`, the image's.
    pub(crate) fn complete_passes(&mut self, clock: Option<(PassClock, String)>) {
        self.spec = Arc::new(self.spec_at_reached_spp());
        self.set_clock(clock);
    }

    /// The pixels of `upload` that would take more samples in another pass, for a budgeted job.
    pub(crate) fn pass_sampling(&self, upload: &TileUpload) -> Option<u32> {
        self.passes.as_ref()?;
        let spp = self.spec.scene.film.spp;
        let progress = upload.pixels.progress.as_ref()?;
        let sampling = progress
            .pixels
            .iter()
            .filter(|p| !p.converged && p.taken < spp)
            .count();
        Some(sampling as u32)
    }

    /// The job's clock, changed by `change`, as stored (`None` for a job without a budget).
    pub(crate) fn clock_with(
        &self,
        change: impl FnOnce(&mut PassClock),
    ) -> Result<Option<(PassClock, String)>, Error> {
        self.passes
            .as_ref()
            .map(|passes| passes.clock_with(change))
            .transpose()
    }

    /// Makes a stored clock (from [`Job::clock_with`]) the job's.
    pub(crate) fn set_clock(&mut self, clock: Option<(PassClock, String)>) {
        if let (Some(passes), Some((clock, _))) = (&mut self.passes, clock) {
            passes.clock = clock;
        }
    }

    /// Checks that an upload is the tile's result of the job's current pass (a budgeted job)
    /// or a one-pass result (any other), naming `pixels.progress` when it is not.
    pub(crate) fn check_pass(&self, upload: &TileUpload) -> Result<(), Error> {
        let progress = &upload.pixels.progress;
        let Some(passes) = &self.passes else {
            return match progress {
                None => Ok(()),
                Some(_) => Err(Error::BadRequest(
                    "pixels.progress: the job has no time budget; its tiles are one pass".into(),
                )),
            };
        };
        let Some(progress) = progress else {
            return Err(Error::BadRequest(format!(
                "pixels.progress: missing; the job renders in passes (pass {})",
                passes.pass()
            )));
        };
        let expected = passes.info(self.spec.scene.film.spp);
        if progress.pass != expected.pass || progress.spp != expected.spp {
            return Err(Error::Conflict(format!(
                "pixels.progress: pass {} at {} spp, but the job is at pass {} ({} spp)",
                progress.pass, progress.spp, expected.pass, expected.spp
            )));
        }
        let pixels = upload.pixels.rect.pixel_count();
        if progress.pixels.len() != pixels {
            return Err(Error::BadRequest(format!(
                "pixels.progress.pixels: expected {pixels} pixel states, got {}",
                progress.pixels.len()
            )));
        }
        Ok(())
    }
}
