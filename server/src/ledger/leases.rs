//! Handing tiles to workers: leases with a time to live, renewed by heartbeats, and an epoch
//! per tile so a worker presumed dead cannot overwrite a newer attempt; the uploads and
//! failures that end them.
//!
//! The rules, and their numbers, are in [`super::rules`]; a tile's and a job's changes are
//! [`Tile`](super::tile::Tile)'s and [`Job`]'s methods. Here they are applied in order: the
//! checks, one commit, the change in memory, the announcement.

use spindle_common::noise::NoiseSums;
use spindle_common::protocol::{
    EventKind, Heartbeat, HeartbeatAck, JobState, Lease, TileError, TileFailure, TileOutcome,
    TileUpload,
};
use spindle_common::tile::TileRect;
use tokio::time::Instant;

use super::Ledger;
use super::job::Job;
use super::jobs::store_failed;
use super::rules::WORKER_STRIKE_LIMIT;
use super::tile::TileStatus;
use crate::clock::now_ms;
use crate::db;
use crate::error::Error;

/// What to do with an upload that passed the checks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UploadPlan {
    /// The tile is already done with this result: acknowledge, store nothing.
    Duplicate,
    /// A new result: [`Ledger::record_upload`] records it.
    Store,
}

impl Ledger {
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
            if let Some(reason) = job.stuck_reason(&live, |ids| self.worker_names(ids)) {
                stuck.push((job.id, reason));
            }
        }
        for (id, error) in stuck {
            self.fail_job(id, error)?;
        }
        Ok(())
    }

    /// Returns lapsed leases to the queue, and takes back those past their greatest age.
    pub fn expire_leases(&mut self, now: Instant) {
        let ttl = self.lease_ttl;
        for job in self.jobs.values_mut() {
            let max_age = job.max_lease_age(ttl);
            for index in job.overdue(now, max_age) {
                take_back_overdue(job, index, max_age);
            }
            for index in job.lapse_expired(now) {
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
        self.jobs.values().filter_map(Job::next_expiry).min()
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
            if !self.workers[&worker].has_labels(&job.requires) || job.keeps_off(worker) {
                continue;
            }
            let Some(index) = job.next_tile_for(worker) else {
                continue;
            };
            return self.grant(id, index, worker, now).map(Some);
        }
        Ok(None)
    }

    fn grant(&mut self, id: u64, index: u32, worker: u64, now: Instant) -> Result<Lease, Error> {
        let ttl = self.lease_ttl;
        let job = &self.jobs[&id];
        let epoch = job.next_epoch(index);
        let start = (job.state == JobState::Queued).then(now_ms);
        let tx = self.db.transaction()?;
        db::record_lease(&tx, id, index, epoch, worker)?;
        if let Some(start) = start {
            db::set_job_state(&tx, id, JobState::Running, None, Some(start), None)?;
        }
        tx.commit()?;

        let job = self.jobs.get_mut(&id).expect("job looked up above");
        if let Some(start) = start {
            job.start(start);
        }
        let lease = job.lease(index, epoch, worker, now, ttl);
        tracing::debug!(job = id, tile = index, epoch, worker, "tile leased");
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
        job.check_index(index)?;
        if !job.is_active() {
            return Err(Error::Conflict(format!(
                "job {id} is {}; stop rendering tile {index}",
                job.state.as_str()
            )));
        }
        let max_age = job.max_lease_age(ttl);
        let tile = &job.tiles[index as usize];
        let yours = tile.is_held_by(hb.worker_id, hb.epoch);
        if yours && tile.is_overdue(now, max_age) {
            take_back_overdue(job, index, max_age);
            return Err(Error::Conflict(format!(
                "tile {index} of job {id}: the lease is older than its greatest age ({} s); \
                 the tile goes to another worker",
                max_age.as_secs()
            )));
        }
        match tile.status {
            TileStatus::Leased { .. } | TileStatus::Pending if yours => {
                // A lapsed lease nobody else took is revived: the work is not wasted.
                job.renew(index, now, ttl);
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
        job.check_index(index)?;
        if job.state.is_finished() {
            return Err(job.state_conflict());
        }
        let tile = &job.tiles[index as usize];
        if tile.status != TileStatus::Done {
            if !job.is_active() {
                return Err(job.state_conflict());
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
        job.check_index(index)?;
        if job.state.is_finished() {
            // Its per-tile state is gone; nothing can change it any more.
            return Err(job.state_conflict());
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
        let passes = spindle_common::aov::AovSet::of(&job.spec.scene.film.passes);
        let samples = expected.pixel_count() * passes.values_per_pixel();
        if upload.pixels.aov.len() != samples {
            return Err(Error::BadRequest(format!(
                "pixels.aov: expected {samples} values ({} per pixel for the job's film.passes), \
                 got {}",
                passes.values_per_pixel(),
                upload.pixels.aov.len()
            )));
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
            return Err(job.state_conflict());
        }
        if !tile.is_held_by(upload.worker_id, upload.epoch) {
            return Err(stale(id, index, tile.epoch, upload.epoch, upload.worker_id));
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
        let complete = job.tile_done(index, upload, &noise, sampling, provenance);
        let seconds = job.tiles[index as usize]
            .leased_at
            .map(|at| at.elapsed().as_secs_f64());
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

    /// Records that a worker could not render its tile; may fail the job (see the rules,
    /// [`super::rules`]).
    pub fn fail_tile(
        &mut self,
        id: u64,
        index: u32,
        failure: &TileFailure,
        now: Instant,
    ) -> Result<(), Error> {
        self.seen(failure.worker_id, now);
        let job = self.job(id)?;
        job.check_index(index)?;
        if !job.is_active() {
            return Err(job.state_conflict());
        }
        let tile = &job.tiles[index as usize];
        if tile.status == TileStatus::Done {
            return Err(Error::Conflict(format!(
                "tile {index} of job {id} is already done"
            )));
        }
        if !tile.is_held_by(failure.worker_id, failure.epoch) {
            return Err(stale(
                id,
                index,
                tile.epoch,
                failure.epoch,
                failure.worker_id,
            ));
        }
        let job_error = job.failure_verdict(index, failure, |ids| self.worker_names(ids));
        let at_ms = now_ms();

        let tx = self.db.transaction()?;
        db::record_failure(
            &tx,
            id,
            index,
            failure.epoch,
            failure.worker_id,
            &failure.reason,
            at_ms,
        )?;
        if let Some(error) = &job_error {
            store_failed(&tx, &self.jobs[&id], error, at_ms)?;
        }
        tx.commit()?;

        let name = match self.workers.get_mut(&failure.worker_id) {
            Some(w) => {
                w.tile_failed();
                w.name.clone()
            }
            None => String::new(),
        };
        let error = TileError {
            tile: index,
            worker_id: failure.worker_id,
            worker: name,
            at_ms,
            message: failure.reason.clone(),
        };
        let strikes = self.job_mut(id)?.tile_failed(index, failure, error);
        tracing::warn!(
            job = id,
            tile = index,
            worker = failure.worker_id,
            reason = %failure.reason,
            deterministic = failure.deterministic,
            "tile failed"
        );
        if strikes == WORKER_STRIKE_LIMIT {
            tracing::warn!(
                job = id,
                worker = failure.worker_id,
                "worker kept off the job after {WORKER_STRIKE_LIMIT} failed tiles"
            );
        }
        match job_error {
            Some(error) => self.job_failed(id, error, at_ms),
            None => self.fail_stuck_jobs(now),
        }
    }
}

/// Takes a lease older than `max_age` back ([`Job::take_back`]), counted and logged.
fn take_back_overdue(job: &mut Job, index: u32, max_age: std::time::Duration) {
    let holder = job.take_back(index);
    crate::metrics::lease_expired();
    tracing::warn!(
        job = job.id,
        tile = index,
        worker = holder,
        max_age_s = max_age.as_secs(),
        "lease older than its greatest age taken back; tile back in the queue"
    );
}

/// 409 for a report from a lease that is no longer the tile's latest.
fn stale(id: u64, index: u32, epoch: u64, reported: u64, worker: u64) -> Error {
    Error::Conflict(format!(
        "stale lease: tile {index} of job {id} is at epoch {epoch}, not {reported} of worker \
         {worker}"
    ))
}
