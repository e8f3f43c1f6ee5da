//! Handing tiles to workers: leases with a time to live, renewed by heartbeats, and an epoch
//! per tile so a worker presumed dead cannot overwrite a newer attempt.
//!
//! Rules, in one place:
//! - Jobs are served by priority (higher first), then submission order; a job's tiles in
//!   centre-first order (tile index order).
//! - A lease lapses `lease_ttl` after it was granted or last renewed; the tile goes back to the
//!   queue and its next lease has a higher epoch.
//! - An upload is stored only from the tile's latest lease (worker and epoch), even if that
//!   lease has lapsed, as long as nobody has been given the tile since. Once a tile is done, an
//!   upload with the same pixel hash is acknowledged as a duplicate and one with a different
//!   hash is refused (409) and logged as a determinism fault.
//! - A worker that fails a tile is not given that tile again; a worker that failed
//!   [`WORKER_STRIKE_LIMIT`] tiles of a job is given no more of that job's tiles.
//! - A lease lapses, too, once it is older than [`Ledger::max_lease_age`], however often it was
//!   renewed: a worker that only sends heartbeats cannot keep a tile for ever. The tile goes
//!   back to the queue, the holder's late result is no longer taken, and the holder is not
//!   given that tile again.
//! - A job fails, with the reason, when [`DETERMINISTIC_CONFIRMATIONS`] different workers
//!   report a tile's failure as deterministic (each says no worker could do better: the scene
//!   does not build, the pixels overflow f32 — one worker's word is only a claim), when a
//!   tile failed on [`TILE_FAILURE_LIMIT`] different workers, when [`JOB_FAILURE_LIMIT`] tile
//!   failures add up in the job, or when no connected worker may take a tile that failed (every
//!   connected worker failed it or is kept off the job). With no worker connected at all, jobs
//!   wait: there is nobody to judge by.
//! - A worker is connected while it is in a lease poll, and for one lease TTL after any request.
//! - A job with `requires` is leased only to workers whose labels include every requirement;
//!   a draining worker is leased nothing (410) and its heartbeats answer `drain`. Only workers
//!   that may take a job's tiles count when judging whether it is stuck: a job no connected
//!   worker is eligible for waits (its `workers_eligible` is 0), like a job with no worker.

use spindle_common::noise::NoiseSums;
use spindle_common::protocol::{
    EventKind, Heartbeat, HeartbeatAck, JobState, Lease, TileFailure, TileOutcome, TileUpload,
};
use tokio::time::Instant;

use crate::db;
use crate::error::Error;
use crate::jobs::{
    DETERMINISTIC_CONFIRMATIONS, JOB_FAILURE_LIMIT, Job, Ledger, MAX_LEASE_AGE_RENDERS,
    MAX_LEASE_AGE_TTLS, TILE_FAILURE_LIMIT, TileStatus, WORKER_STRIKE_LIMIT, now_ms,
};
use spindle_common::protocol::TileError;
use spindle_common::tile::TileRect;

/// What to do with an upload that passed the checks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UploadPlan {
    /// The tile is already done with this result: acknowledge, store nothing.
    Duplicate,
    /// A new result: [`Ledger::record_upload`] records it.
    Store,
}

impl Ledger {
    /// Checks a worker id.
    pub fn check_worker(&self, worker: u64) -> Result<(), Error> {
        if self.workers.contains_key(&worker) {
            Ok(())
        } else {
            Err(Error::NotFound(format!(
                "worker {worker} is not registered (POST /v1/workers)"
            )))
        }
    }

    /// Notes that `worker` was heard from at `now` (unknown ids are ignored).
    pub fn seen(&mut self, worker: u64, now: Instant) {
        let ttl = self.lease_ttl;
        if let Some(w) = self.workers.get_mut(&worker) {
            w.seen_until = w.seen_until.max(now + ttl);
            w.last_seen_ms = now_ms();
        }
    }

    /// A lease long poll of `worker` begins; it counts as connected until [`Ledger::poll_ended`].
    pub fn poll_started(&mut self, worker: u64, now: Instant) -> Result<(), Error> {
        self.check_worker(worker)?;
        self.seen(worker, now);
        if let Some(w) = self.workers.get_mut(&worker) {
            w.polls += 1;
        }
        Ok(())
    }

    /// A lease long poll of `worker` ended (answered, or the client went away).
    pub fn poll_ended(&mut self, worker: u64, now: Instant) {
        self.seen(worker, now);
        if let Some(w) = self.workers.get_mut(&worker) {
            w.polls = w.polls.saturating_sub(1);
        }
    }

    /// Fails every active job that no connected worker can finish: a failed tile that every
    /// connected worker has failed or is kept off, or every connected worker kept off the job.
    /// With no worker connected, nothing is decided.
    pub fn fail_stuck_jobs(&mut self, now: Instant) -> Result<(), Error> {
        let mut stuck = Vec::new();
        for job in self.jobs.values() {
            if !job.is_leasing() || job.failed_by.is_empty() {
                continue;
            }
            let mut live: Vec<u64> = self
                .workers
                .iter()
                .filter(|(_, w)| w.eligible(&job.requires, now))
                .map(|(&id, _)| id)
                .collect();
            if live.is_empty() {
                continue;
            }
            live.sort_unstable();
            let kept_off = |w: &u64| {
                job.strikes
                    .get(w)
                    .is_some_and(|tiles| tiles.len() >= WORKER_STRIKE_LIMIT)
            };
            if live.iter().all(kept_off) {
                stuck.push((
                    job.id,
                    format!(
                        "every connected worker ({}) failed {WORKER_STRIKE_LIMIT} tiles of this \
                         job and is kept off it; last error: {}",
                        self.worker_names(&live),
                        last_error(job, None)
                    ),
                ));
                continue;
            }
            let mut failed: Vec<_> = job.failed_by.iter().collect();
            failed.sort_unstable_by_key(|(index, _)| **index);
            let blocked = failed.into_iter().find(|(index, by)| {
                job.tiles[**index as usize].status == TileStatus::Pending
                    && live.iter().all(|w| by.contains(w) || kept_off(w))
            });
            if let Some((&index, by)) = blocked {
                let by: Vec<u64> = by.iter().copied().collect();
                stuck.push((
                    job.id,
                    format!(
                        "tile {index} ({}) failed on {} and no other connected worker may \
                         take it; last error: {}",
                        job.rects[index as usize],
                        self.worker_names(&by),
                        last_error(job, Some(index))
                    ),
                ));
            }
        }
        for (id, error) in stuck {
            self.fail_job(id, error)?;
        }
        Ok(())
    }

    /// `name (id)` of each worker, comma-separated.
    fn worker_names(&self, ids: &[u64]) -> String {
        ids.iter()
            .map(|id| match self.workers.get(id) {
                Some(w) => format!("{} ({id})", w.name),
                None => format!("worker {id}"),
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The greatest age of a lease of `job`: [`MAX_LEASE_AGE_TTLS`] lease TTLs, or
    /// [`MAX_LEASE_AGE_RENDERS`] times the slowest render its finished tiles reported, if longer.
    pub fn max_lease_age(&self, job: &Job) -> std::time::Duration {
        let floor = self.lease_ttl * MAX_LEASE_AGE_TTLS;
        let slowest = job
            .tiles
            .iter()
            .filter_map(|t| t.render_seconds)
            .fold(0.0f64, f64::max);
        floor.max(std::time::Duration::from_secs_f64(
            (slowest * MAX_LEASE_AGE_RENDERS).min(1e9),
        ))
    }

    /// Returns lapsed leases to the queue, and takes back those past their greatest age.
    pub fn expire_leases(&mut self, now: Instant) {
        let ids: Vec<u64> = self.jobs.keys().copied().collect();
        for id in ids {
            let max_age = self.max_lease_age(&self.jobs[&id]);
            let job = self.jobs.get_mut(&id).expect("listed above");
            let overdue: Vec<u32> = job
                .leased
                .iter()
                .copied()
                .filter(|&i| {
                    job.tiles[i as usize]
                        .leased_at
                        .is_some_and(|at| now.saturating_duration_since(at) >= max_age)
                })
                .collect();
            for index in overdue {
                take_back_overdue(job, index, max_age);
            }
        }
        for job in self.jobs.values_mut() {
            let lapsed: Vec<u32> = job
                .leased
                .iter()
                .copied()
                .filter(|&i| {
                    matches!(job.tiles[i as usize].status,
                             TileStatus::Leased { deadline } if deadline <= now)
                })
                .collect();
            for index in lapsed {
                job.leased.remove(&index);
                // The worker is kept: its late result is still welcome until the tile is
                // leased again.
                job.tiles[index as usize].status = TileStatus::Pending;
                crate::metrics::lease_expired();
                tracing::info!(
                    job = job.id,
                    tile = index,
                    "lease expired; tile back in the queue"
                );
            }
        }
    }

    /// When the next live lease lapses, if any.
    pub fn next_expiry(&self) -> Option<Instant> {
        self.jobs
            .values()
            .flat_map(|job| {
                job.leased
                    .iter()
                    .filter_map(|&i| match job.tiles[i as usize].status {
                        TileStatus::Leased { deadline } => Some(deadline),
                        _ => None,
                    })
            })
            .min()
    }

    /// Leases the next tile for `worker`, if any job has one it may take.
    pub fn try_lease(&mut self, worker: u64, now: Instant) -> Result<Option<Lease>, Error> {
        self.check_worker(worker)?;
        self.seen(worker, now);
        if self.workers[&worker].draining {
            return Err(Error::Gone(format!(
                "worker {worker} is draining: take no more tiles and exit"
            )));
        }
        self.expire_leases(now);
        self.fail_stuck_jobs(now)?;
        let mut order: Vec<(i32, u64)> = self
            .jobs
            .values()
            .filter(|j| j.is_leasing())
            .map(|j| (j.priority, j.id))
            .collect();
        order.sort_by_key(|&(priority, id)| (std::cmp::Reverse(priority), id));
        for (_, id) in order {
            let job = &self.jobs[&id];
            if !self.workers[&worker].has_labels(&job.requires) {
                continue;
            }
            if job
                .strikes
                .get(&worker)
                .is_some_and(|tiles| tiles.len() >= WORKER_STRIKE_LIMIT)
            {
                continue;
            }
            let Some(index) = next_tile_for(job, worker) else {
                continue;
            };
            return self.grant(id, index, worker, now).map(Some);
        }
        Ok(None)
    }

    fn grant(&mut self, id: u64, index: u32, worker: u64, now: Instant) -> Result<Lease, Error> {
        let ttl = self.lease_ttl;
        let job = &self.jobs[&id];
        let epoch = job.tiles[index as usize].epoch + 1;
        let start = (job.state == JobState::Queued).then(now_ms);
        let tx = self.db.transaction()?;
        db::record_lease(&tx, id, index, epoch, worker)?;
        if let Some(start) = start {
            db::set_job_state(&tx, id, JobState::Running, None, Some(start), None)?;
        }
        tx.commit()?;

        let job = self.jobs.get_mut(&id).expect("job looked up above");
        if let Some(start) = start {
            job.state = JobState::Running;
            job.started_ms = Some(start);
        }
        let tile = &mut job.tiles[index as usize];
        tile.epoch = epoch;
        tile.worker = Some(worker);
        tile.leased_at = Some(now);
        tile.status = TileStatus::Leased {
            deadline: now + ttl,
        };
        job.leased.insert(index);
        tracing::debug!(job = id, tile = index, epoch, worker, "tile leased");
        let lease = Lease {
            job_id: id,
            tile_index: index,
            rect: job.rects[index as usize],
            epoch,
            ttl_ms: ttl.as_millis() as u64,
            pass: job.passes.as_ref().map(|p| p.pass()),
        };
        if start.is_some() {
            self.job_changed(id);
        }
        Ok(lease)
    }

    /// Renews a lease; 409 when it is no longer the worker's.
    pub fn heartbeat(
        &mut self,
        id: u64,
        index: u32,
        hb: &Heartbeat,
        now: Instant,
    ) -> Result<HeartbeatAck, Error> {
        let ttl = self.lease_ttl;
        self.seen(hb.worker_id, now);
        let drain = self.workers.get(&hb.worker_id).is_some_and(|w| w.draining);
        let job = self.job_mut(id)?;
        check_index(job, index)?;
        if !job.is_active() {
            return Err(Error::Conflict(format!(
                "job {id} is {}; stop rendering tile {index}",
                job.state.as_str()
            )));
        }
        let max_age = self.max_lease_age(self.job(id)?);
        let job = self.job_mut(id)?;
        let tile = &job.tiles[index as usize];
        let yours = tile.epoch == hb.epoch && tile.worker == Some(hb.worker_id);
        if yours
            && tile
                .leased_at
                .is_some_and(|at| now.saturating_duration_since(at) >= max_age)
        {
            take_back_overdue(job, index, max_age);
            return Err(Error::Conflict(format!(
                "tile {index} of job {id}: the lease is older than its greatest age ({} s); \
                 the tile goes to another worker",
                max_age.as_secs()
            )));
        }
        let tile = &mut job.tiles[index as usize];
        match tile.status {
            TileStatus::Leased { .. } | TileStatus::Pending if yours => {
                // A lapsed lease nobody else took is revived: the work is not wasted.
                tile.status = TileStatus::Leased {
                    deadline: now + ttl,
                };
                job.leased.insert(index);
                Ok(HeartbeatAck {
                    ttl_ms: ttl.as_millis() as u64,
                    drain,
                })
            }
            TileStatus::Done => Err(Error::Conflict(format!(
                "tile {index} of job {id} is already done"
            ))),
            _ => Err(Error::Conflict(format!(
                "stale lease: tile {index} of job {id} is at epoch {}, not {} of worker {}",
                tile.epoch, hb.epoch, hb.worker_id
            ))),
        }
    }

    /// Decides whether `worker` may upload tile `index` of job `id` at all, from the request's
    /// path and headers alone, before its body is read: the job exists and takes tiles, and
    /// the tile is done (a late duplicate, judged once read) or its latest lease is `worker`'s
    /// (at `epoch`, when the upload names it). Returns the tile's rectangle, which bounds the
    /// body. So an upload for no job, or for another worker's tile, costs nothing to refuse.
    pub fn admit_upload(
        &self,
        id: u64,
        index: u32,
        worker: u64,
        epoch: Option<u64>,
    ) -> Result<TileRect, Error> {
        let job = self.job(id)?;
        check_index(job, index)?;
        if job.state.is_finished() {
            return Err(Error::Conflict(format!(
                "job {id} is {}",
                job.state.as_str()
            )));
        }
        let tile = &job.tiles[index as usize];
        if tile.status != TileStatus::Done {
            if !job.is_active() {
                return Err(Error::Conflict(format!(
                    "job {id} is {}",
                    job.state.as_str()
                )));
            }
            if tile.worker != Some(worker) || epoch.is_some_and(|e| e != tile.epoch) {
                return Err(Error::Conflict(format!(
                    "stale lease: tile {index} of job {id} is at epoch {} of worker {}, not \
                     leased to worker {worker}{}",
                    tile.epoch,
                    tile.worker.map_or("none".to_string(), |w| w.to_string()),
                    epoch.map_or(String::new(), |e| format!(" at epoch {e}")),
                )));
            }
        }
        Ok(job.rects[index as usize])
    }

    /// Checks an upload against the job and the tile's lease. `upload.hash` must already be
    /// checked against the pixels.
    pub fn check_upload(
        &self,
        id: u64,
        index: u32,
        upload: &TileUpload,
    ) -> Result<UploadPlan, Error> {
        let job = self.job(id)?;
        check_index(job, index)?;
        if job.state.is_finished() {
            // Its per-tile state is gone; nothing can change it any more.
            return Err(Error::Conflict(format!(
                "job {id} is {}",
                job.state.as_str()
            )));
        }
        let expected = job.rects[index as usize];
        if upload.pixels.rect != expected {
            return Err(Error::BadRequest(format!(
                "pixels.rect: {} is not the rectangle of tile {index}, {expected}",
                upload.pixels.rect
            )));
        }
        for (kind, layer) in spindle_common::tile::LAYERS
            .iter()
            .zip(upload.pixels.layers())
        {
            let samples = expected.pixel_count() * kind.channels;
            if layer.len() != samples {
                return Err(Error::BadRequest(format!(
                    "pixels.{}: expected {samples} values ({} per pixel), got {}",
                    kind.name,
                    kind.channels,
                    layer.len()
                )));
            }
        }
        let tile = &job.tiles[index as usize];
        if tile.status == TileStatus::Done {
            let hash = db::done_hash(&self.db, id, index)?.unwrap_or_default();
            if hash == upload.hash {
                return Ok(UploadPlan::Duplicate);
            }
            crate::metrics::determinism_fault();
            tracing::error!(
                job = id,
                tile = index,
                worker = upload.worker_id,
                epoch = upload.epoch,
                recorded = %hash,
                uploaded = %upload.hash,
                "determinism fault: a second result for a finished tile differs from the first"
            );
            return Err(Error::Conflict(format!(
                "tile {index} of job {id} is already done with a different result \
                 (determinism fault, logged)"
            )));
        }
        if !job.is_active() {
            return Err(Error::Conflict(format!(
                "job {id} is {}",
                job.state.as_str()
            )));
        }
        if tile.epoch != upload.epoch || tile.worker != Some(upload.worker_id) {
            return Err(Error::Conflict(format!(
                "stale lease: tile {index} of job {id} is at epoch {}, not {} of worker {}",
                tile.epoch, upload.epoch, upload.worker_id
            )));
        }
        job.check_pass(upload)?;
        Ok(UploadPlan::Store)
    }

    /// Records a tile and its pixels (`stored`: `upload.pixels` in the compact tile form) in
    /// one commit. Returns the outcome and whether the job now has every tile (of the pass,
    /// for a budgeted job: [`crate::assemble::finish`] then ends the pass).
    pub fn record_upload(
        &mut self,
        id: u64,
        index: u32,
        upload: &TileUpload,
        stored: &[u8],
    ) -> Result<(TileOutcome, bool), Error> {
        self.seen(upload.worker_id, Instant::now());
        if self.check_upload(id, index, upload)? == UploadPlan::Duplicate {
            return Ok((TileOutcome::Duplicate, false));
        }
        // The first provenance a job receives is kept (the upload handler checked it).
        let provenance = match (&self.job(id)?.provenance, &upload.provenance) {
            (None, Some(p)) => Some(p.clone()),
            _ => None,
        };
        let noise = NoiseSums::of_tile(&upload.pixels);
        let sampling = self.job(id)?.pass_sampling(upload);
        let tx = self.db.transaction()?;
        db::record_done(&tx, id, index, upload, &noise, stored, sampling)?;
        if let Some(p) = &provenance {
            db::set_provenance(
                &tx,
                id,
                &serde_json::to_string(p).map_err(anyhow::Error::from)?,
            )?;
        }
        tx.commit()?;
        let worker = match self.workers.get_mut(&upload.worker_id) {
            Some(w) => {
                w.tile_accepted(now_ms());
                w.name.clone()
            }
            None => String::new(),
        };
        let job = self.job_mut(id)?;
        if let Some(p) = provenance {
            job.provenance = Some(std::sync::Arc::new(p));
        }
        job.tiles[index as usize].status = TileStatus::Done;
        job.tiles[index as usize].render_seconds = upload.render_seconds;
        job.leased.remove(&index);
        job.tiles_done += 1;
        job.stats.add(&upload.pixels.stats);
        job.noise.add(&noise);
        job.pass_tile_done(index, sampling);
        let seconds = job.tiles[index as usize]
            .leased_at
            .map(|at| at.elapsed().as_secs_f64());
        let complete = job.is_complete();
        self.events.publish(EventKind::TileDone {
            job: id,
            tile: index,
            worker_id: upload.worker_id,
            worker,
            seconds,
            render_seconds: upload.render_seconds,
        });
        tracing::debug!(
            job = id,
            tile = index,
            worker = upload.worker_id,
            "tile done"
        );
        Ok((TileOutcome::Accepted, complete))
    }

    /// Records that a worker could not render its tile; may fail the job (see the rules above).
    pub fn fail_tile(
        &mut self,
        id: u64,
        index: u32,
        failure: &TileFailure,
        now: Instant,
    ) -> Result<(), Error> {
        self.seen(failure.worker_id, now);
        let job = self.job(id)?;
        check_index(job, index)?;
        if !job.is_active() {
            return Err(Error::Conflict(format!(
                "job {id} is {}",
                job.state.as_str()
            )));
        }
        let tile = &job.tiles[index as usize];
        if tile.status == TileStatus::Done {
            return Err(Error::Conflict(format!(
                "tile {index} of job {id} is already done"
            )));
        }
        if tile.epoch != failure.epoch || tile.worker != Some(failure.worker_id) {
            return Err(Error::Conflict(format!(
                "stale lease: tile {index} of job {id} is at epoch {}, not {} of worker {}",
                tile.epoch, failure.epoch, failure.worker_id
            )));
        }
        let worker = self.worker_names(&[failure.worker_id]);
        let rect = job.rects[index as usize];
        let mut failed_by = job.failed_by.get(&index).cloned().unwrap_or_default();
        failed_by.insert(failure.worker_id);
        let mut claimed_by = job
            .deterministic_by
            .get(&index)
            .cloned()
            .unwrap_or_default();
        if failure.deterministic {
            claimed_by.insert(failure.worker_id);
        }
        let reason = &failure.reason;
        let job_error = if claimed_by.len() >= DETERMINISTIC_CONFIRMATIONS {
            Some(format!(
                "tile {index} ({rect}) cannot be rendered: {} workers found so ({}); the \
                 last (worker {worker}): {reason}",
                claimed_by.len(),
                self.worker_names(&claimed_by.iter().copied().collect::<Vec<_>>()),
            ))
        } else if failed_by.len() >= TILE_FAILURE_LIMIT {
            Some(format!(
                "tile {index} ({rect}) failed on {} different workers; last reason \
                 (worker {worker}): {reason}",
                failed_by.len(),
            ))
        } else if job.failures + 1 >= JOB_FAILURE_LIMIT {
            Some(format!(
                "{JOB_FAILURE_LIMIT} tile failures in this job; the last: tile {index} on \
                 worker {worker}: {reason}"
            ))
        } else {
            None
        };
        let started = job.started_ms;
        let at_ms = now_ms();

        let tx = self.db.transaction()?;
        db::record_failure(
            &tx,
            id,
            index,
            failure.epoch,
            failure.worker_id,
            reason,
            at_ms,
        )?;
        if let Some(error) = &job_error {
            db::set_job_state(&tx, id, JobState::Failed, Some(error), started, Some(at_ms))?;
        }
        tx.commit()?;

        let name = match self.workers.get_mut(&failure.worker_id) {
            Some(w) => {
                w.failures += 1;
                w.name.clone()
            }
            None => String::new(),
        };
        let job = self.job_mut(id)?;
        let tile = &mut job.tiles[index as usize];
        tile.status = TileStatus::Pending;
        tile.worker = None;
        job.leased.remove(&index);
        job.failed_by.insert(index, failed_by);
        job.deterministic_by.insert(index, claimed_by);
        job.failures += 1;
        job.remember_error(TileError {
            tile: index,
            worker_id: failure.worker_id,
            worker: name,
            at_ms,
            message: reason.clone(),
        });
        let strikes = job.strikes.entry(failure.worker_id).or_default();
        strikes.insert(index);
        tracing::warn!(
            job = id,
            tile = index,
            worker = failure.worker_id,
            reason = %failure.reason,
            deterministic = failure.deterministic,
            "tile failed"
        );
        if strikes.len() == WORKER_STRIKE_LIMIT {
            tracing::warn!(
                job = id,
                worker = failure.worker_id,
                "worker kept off the job after {WORKER_STRIKE_LIMIT} failed tiles"
            );
        }
        if let Some(error) = job_error {
            tracing::error!(job = id, %error, "job failed");
            job.state = JobState::Failed;
            job.error = Some(error);
            job.finished_ms = Some(at_ms);
            job.release_tiles();
            self.job_changed(id);
            return Ok(());
        }
        self.fail_stuck_jobs(now)
    }
}

/// Takes a lease older than `max_age` back: the tile is queued again, its holder's result is no
/// longer taken, and the holder is not given it again.
fn take_back_overdue(job: &mut Job, index: u32, max_age: std::time::Duration) {
    let tile = &mut job.tiles[index as usize];
    let holder = tile.worker.take();
    tile.status = TileStatus::Pending;
    job.leased.remove(&index);
    if let Some(holder) = holder {
        job.failed_by.entry(index).or_default().insert(holder);
    }
    crate::metrics::lease_expired();
    tracing::warn!(
        job = job.id,
        tile = index,
        worker = holder,
        max_age_s = max_age.as_secs(),
        "lease older than its greatest age taken back; tile back in the queue"
    );
}

/// The message of the newest recorded failure (of tile `index`, if given).
fn last_error(job: &Job, index: Option<u32>) -> String {
    job.recent_errors
        .iter()
        .rev()
        .find(|e| index.is_none_or(|i| e.tile == i))
        .map_or_else(
            || "(not kept)".to_string(),
            |e| format!("{} (worker {})", e.message, e.worker),
        )
}

/// The first pending tile of `job` (centre-first) that `worker` has not failed.
fn next_tile_for(job: &Job, worker: u64) -> Option<u32> {
    job.tiles
        .iter()
        .enumerate()
        .find(|(i, t)| {
            t.status == TileStatus::Pending
                && !job
                    .failed_by
                    .get(&(*i as u32))
                    .is_some_and(|w| w.contains(&worker))
        })
        .map(|(i, _)| i as u32)
}

fn check_index(job: &Job, index: u32) -> Result<(), Error> {
    if index < job.tiles_total {
        Ok(())
    } else {
        Err(Error::NotFound(format!(
            "job {} has no tile {index} (it has {})",
            job.id, job.tiles_total
        )))
    }
}
