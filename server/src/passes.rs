//! Progressive passes of a job with `film.time_budget_s`: the farm's time budget.
//!
//! Such a job is rendered as successive sets of its tiles. Pass `k` of every tile takes each
//! pixel to `min(16 k, film.spp)` samples, continuing from the running sums its pass-`k − 1`
//! result carried ([`spindle_common::passes::TileProgress`], stored with the tile as any result
//! is; a worker fetches it through `GET /v1/leases/{job}/{tile}/previous`). Pass `k + 1` starts
//! only when every tile has finished pass `k`, and only if the budget allows it by the rule of
//! `spindle render --workers 0`: the runnable time since the job started (its first lease)
//! plus the last pass's runnable time is within the budget. Otherwise — or when every pixel has `spp`
//! samples or met `film.target_error` — the job is complete, and its image, assembled from the
//! last pass every tile completed, is bit for bit the one-pass render at `spp` = the reached
//! cap: the job's spec says so from then on (the EXR's `spindle.spp`), and
//! [`JobInfo::passes`] reports it.
//!
//! Why whole passes with a barrier, rather than tiles running ahead: every tile of the image
//! then ends at the same sample count, so the image is one spp's render (what `--workers 0
//! --no-time-budget --spp N` reproduces), and each tile needs one stored result per pass, which
//! the tile store's one row per tile holds; the cost is the pass's tail, where workers wait for
//! its last tiles.
//!
//! What a restart keeps: the job's pass, when it began and the time the job spent paused
//! ([`PassClock`], the job row's `passes`, written in the commit of every change), each tile's
//! result its current pass continues from (a tile row not done keeps the previous pass's
//! result: [`db::next_pass_tile`]) and, per tile done in the current pass, its pixels still
//! sampling. A restarted coordinator resumes the pass it was in; only a job stored before this
//! was recorded, or one requeued after it failed or was cancelled, is rendered again from pass
//! 1 ([`Ledger::restart_passes`]). So is a job past pass 1 one of whose stored results turns
//! out damaged (read for the next pass or at assembly): a tile's pass continues the tile's
//! previous pass, whose result its row no longer keeps, so the tile cannot be rendered again
//! alone ([`Ledger::restart_passes_after_damage`]; the reason goes to the job's recent errors).
//!
//! The budget is wall time while the job is runnable: the intervals it spent paused are
//! subtracted from both the time since its start and the last pass's time (a coordinator that
//! is down is not a pause: that time counts).
//!
//! Ending a pass writes to the database; it runs where assembly does ([`crate::assemble`]),
//! after the upload of the pass's last tile was recorded, and an error is retried with the
//! assembly's backoff (each failure logged) until it passes or [`PASS_END_ATTEMPTS`] failed:
//! then the job fails, with the reason in its `error` and its `job_state` event.

use std::sync::Arc;

use serde::{Deserialize, Serialize};
use spindle_common::passes::pass_cap;
use spindle_common::protocol::{JobSpec, PassInfo, TileError, TileUpload};

use crate::db;
use crate::error::{Error, is_disk_full};
use crate::jobs::{Job, Ledger, Tile, TileStatus, now_ms};

/// Attempts at ending a pass (the first and its retries) before the job fails.
pub const PASS_END_ATTEMPTS: u32 = 6;

/// The part of a budgeted job's passes that is stored with the job (`jobs.passes`, JSON).
/// Times are wall-clock ms since the Unix epoch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PassClock {
    /// The pass being rendered (from 1).
    pub pass: u32,
    /// When the current pass began; `None` in pass 1, which begins with the job.
    pub started_ms: Option<i64>,
    /// Time spent paused since the job started, in pauses that ended.
    pub paused_ms: i64,
    /// Of that, the time within the current pass.
    pub pass_paused_ms: i64,
    /// When the pause in progress began (the job is paused).
    pub paused_since_ms: Option<i64>,
    /// The last pass ended and no other follows: the job's spec is at the reached `spp`.
    pub complete: bool,
}

impl PassClock {
    /// Time from `from` to `now` that is not part of the pause in progress.
    fn open_pause_ms(&self, from: i64, now: i64) -> i64 {
        self.paused_since_ms
            .map_or(0, |since| (now - since.max(from)).max(0))
    }

    /// The job's runnable seconds since its start `job_start`, and its current pass's, at `now`.
    pub fn runnable_s(&self, job_start: i64, now: i64) -> (f64, f64) {
        let pass_start = self.started_ms.unwrap_or(job_start);
        let job = (now - job_start - self.paused_ms - self.open_pause_ms(job_start, now)).max(0);
        let pass =
            (now - pass_start - self.pass_paused_ms - self.open_pause_ms(pass_start, now)).max(0);
        (job as f64 / 1000.0, pass as f64 / 1000.0)
    }

    /// A pause begins at `at`.
    pub fn pause(&mut self, at: i64) {
        self.paused_since_ms.get_or_insert(at);
    }

    /// The pause in progress ends at `at`; it counts from the job's start (`None`: the job
    /// has not started, and nothing counts).
    pub fn resume(&mut self, at: i64, job_start: Option<i64>) {
        let (Some(since), Some(job_start)) = (self.paused_since_ms.take(), job_start) else {
            return;
        };
        let pass_start = self.started_ms.unwrap_or(job_start);
        self.paused_ms += (at - since.max(job_start)).max(0);
        self.pass_paused_ms += (at - since.max(pass_start)).max(0);
    }

    fn to_json(&self) -> Result<String, Error> {
        Ok(serde_json::to_string(self).map_err(anyhow::Error::from)?)
    }
}

/// Where a budgeted job's passes stand.
#[derive(Debug, Clone, PartialEq)]
pub struct Passes {
    /// `film.time_budget_s`, counted from the job's start.
    budget_s: f64,
    /// What is stored with the job.
    pub clock: PassClock,
    /// Each tile's result of the previous pass (its hash), from which its current pass goes
    /// on; all `None` in pass 1.
    previous: Vec<Option<String>>,
    /// Per tile done in this pass: its pixels that would take more samples in another pass.
    sampling: Vec<u32>,
}

impl Passes {
    /// The passes of a job whose scene has a time budget, at pass 1.
    pub fn of(spec: &JobSpec) -> Option<Passes> {
        let budget_s = spec.scene.film.time_budget_s?;
        let tiles = spec.tiles().len();
        Some(Passes {
            budget_s,
            clock: PassClock {
                pass: 1,
                started_ms: None,
                paused_ms: 0,
                pass_paused_ms: 0,
                paused_since_ms: None,
                complete: false,
            },
            previous: vec![None; tiles],
            sampling: vec![0; tiles],
        })
    }

    /// The pass being rendered (from 1).
    pub fn pass(&self) -> u32 {
        self.clock.pass
    }

    /// Has the last pass ended, with no other to follow?
    pub fn complete(&self) -> bool {
        self.clock.complete
    }

    /// The stored form of a new job's passes (pass 1).
    pub fn json_of(spec: &JobSpec) -> Result<Option<String>, Error> {
        Passes::of(spec).map(|p| p.clock.to_json()).transpose()
    }

    /// The passes of job `id` as stored: its clock (`json`, the job row's `passes`) and its
    /// tile rows ([`db::pass_rows`]); `None` when the job has no budget.
    pub(crate) fn restore(
        spec: &JobSpec,
        json: &str,
        rows: &[db::PassRow],
    ) -> anyhow::Result<Option<Passes>> {
        let Some(mut passes) = Passes::of(spec) else {
            return Ok(None);
        };
        passes.clock = serde_json::from_str(json)
            .map_err(|e| anyhow::anyhow!("stored passes {json:?}: {e}"))?;
        for (index, previous, sampling) in rows {
            let i = *index as usize;
            anyhow::ensure!(
                i < passes.previous.len(),
                "stored tile {index} out of range"
            );
            if passes.clock.pass > 1 {
                passes.previous[i] = previous.clone();
            }
            passes.sampling[i] = sampling.unwrap_or(0);
        }
        Ok(Some(passes))
    }

    /// The result tile `index`'s current pass continues from.
    pub fn previous(&self, index: u32) -> Option<&str> {
        self.previous.get(index as usize)?.as_deref()
    }

    /// Forgets the per-tile state of a finished job (its pass stays, for [`Passes::info`]).
    pub(crate) fn release(&mut self) {
        self.previous = Vec::new();
        self.sampling = Vec::new();
    }

    /// The pass and its sample cap, as clients see them.
    pub fn info(&self, spp: u32) -> PassInfo {
        PassInfo {
            pass: self.clock.pass,
            spp: pass_cap(self.clock.pass, spp),
            budget_s: self.budget_s,
        }
    }
}

impl Job {
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

    /// The job's spec at the current pass's sample cap.
    fn spec_at_reached_spp(&self) -> JobSpec {
        let mut spec = JobSpec::clone(&self.spec);
        if let Some(passes) = &self.passes {
            spec.scene.film.spp = pass_cap(passes.pass(), spec.scene.film.spp);
        }
        spec
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
        let Some(passes) = &self.passes else {
            return Ok(None);
        };
        let mut clock = passes.clock.clone();
        change(&mut clock);
        let json = clock.to_json()?;
        Ok(Some((clock, json)))
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

    /// Notes a recorded tile's pixels still sampling ([`Job::pass_sampling`]).
    pub(crate) fn pass_tile_done(&mut self, index: u32, sampling: Option<u32>) {
        if let (Some(passes), Some(sampling)) = (&mut self.passes, sampling) {
            passes.sampling[index as usize] = sampling;
        }
    }
}

/// What the end of a pass led to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PassEnd {
    /// The job is complete: assemble it.
    Complete,
    /// The next pass's tiles are queued.
    NextPass,
    /// The job ended (cancelled, failed) or has tiles to render again: nothing to do.
    Ended,
}

impl Ledger {
    /// Called when every tile of job `id` is in: starts the next pass if the budget allows it
    /// and a pixel would take more samples, else fixes the job's spec at the reached `spp`.
    /// A job without a budget is complete. Each outcome is one commit; on an error nothing
    /// changed, and the call may be made again.
    pub(crate) fn end_of_pass(&mut self, id: u64) -> Result<PassEnd, Error> {
        let now = now_ms();
        let job = self.job(id)?;
        if job.state.is_finished() || !job.is_complete() {
            return Ok(PassEnd::Ended);
        }
        let Some(passes) = &job.passes else {
            return Ok(PassEnd::Complete);
        };
        if passes.complete() {
            return Ok(PassEnd::Complete);
        }
        let spp = job.spec.scene.film.spp;
        let cap = pass_cap(passes.pass(), spp);
        let sampling: u64 = passes.sampling.iter().map(|&n| u64::from(n)).sum();
        let job_start = job.started_ms.unwrap_or(now);
        let (elapsed_s, pass_s) = passes.clock.runnable_s(job_start, now);
        let go_on = cap < spp && sampling > 0 && elapsed_s + pass_s <= passes.budget_s;
        tracing::info!(
            job = id,
            pass = passes.pass(),
            spp = cap,
            pixels_sampling = sampling,
            elapsed_s,
            pass_s,
            budget_s = passes.budget_s,
            go_on,
            "pass complete"
        );
        if !go_on {
            let clock = job.clock_with(|c| c.complete = true)?;
            if let Some((_, json)) = &clock {
                db::set_passes(&self.db, id, json)?;
            }
            // The image is the one-pass render at the reached cap: say so where it is assembled.
            let spec = job.spec_at_reached_spp();
            let job = self.job_mut(id)?;
            job.spec = Arc::new(spec);
            job.set_clock(clock);
            return Ok(PassEnd::Complete);
        }
        let clock = job.clock_with(|c| {
            c.pass += 1;
            c.started_ms = Some(now);
            c.pass_paused_ms = 0;
        })?;
        let results = db::done_tiles(&self.db, id)?;
        let tx = self.db.transaction()?;
        for (index, _) in &results {
            db::next_pass_tile(&tx, id, *index)?;
        }
        if let Some((_, json)) = &clock {
            db::set_passes(&tx, id, json)?;
        }
        tx.commit()?;
        let job = self.job_mut(id)?;
        job.set_clock(clock);
        let passes = job.passes.as_mut().expect("checked above");
        passes.previous = vec![None; job.tiles.len()];
        for (index, hash) in results {
            passes.previous[index as usize] = Some(hash);
        }
        passes.sampling.fill(0);
        for tile in &mut job.tiles {
            *tile = Tile {
                epoch: tile.epoch,
                ..Tile::PENDING
            };
        }
        job.leased.clear();
        job.tiles_done = 0;
        job.stats = Default::default();
        job.noise = Default::default();
        job.assembling = false;
        self.job_changed(id);
        Ok(PassEnd::NextPass)
    }

    /// Fails job `id`, whose current pass could not be ended after [`PASS_END_ATTEMPTS`]
    /// attempts, the last with `error`.
    pub(crate) fn fail_pass_end(&mut self, id: u64, error: &Error) -> Result<(), Error> {
        let job = self.job(id)?;
        if job.state.is_finished() {
            return Ok(());
        }
        let pass = job.passes.as_ref().map_or(1, Passes::pass);
        // The cause is logged by the caller; clients are told what it means, no path or SQL.
        let cause = match error {
            Error::Internal(cause) if is_disk_full(cause) => "the coordinator's disk is full",
            Error::Internal(_) => "the coordinator's database refused the write (see its log)",
            other => return self.fail_job(id, format!("pass {pass} could not be ended: {other}")),
        };
        self.fail_job(
            id,
            format!("pass {pass} could not be ended after {PASS_END_ATTEMPTS} attempts: {cause}"),
        )
    }

    /// The hash of the previous pass's result of tile `index` of job `id`, for `worker`, which
    /// must hold the tile's current lease (409 otherwise); 404 when the tile is in pass 1 or
    /// the job has no passes.
    pub fn previous_result(&self, id: u64, index: u32, worker: u64) -> Result<String, Error> {
        let job = self.job(id)?;
        let Some(passes) = &job.passes else {
            return Err(Error::NotFound(format!(
                "job {id} has no time budget: its tiles have no previous pass"
            )));
        };
        let tile = job.tiles.get(index as usize).ok_or_else(|| {
            Error::NotFound(format!(
                "job {id} has no tile {index} (it has {})",
                job.tiles_total
            ))
        })?;
        if !job.is_active() || tile.worker != Some(worker) || tile.status == TileStatus::Done {
            return Err(Error::Conflict(format!(
                "tile {index} of job {id} is not leased to worker {worker}"
            )));
        }
        passes.previous(index).map(str::to_string).ok_or_else(|| {
            Error::NotFound(format!(
                "tile {index} of job {id} is in pass {}: it has no previous pass",
                passes.pass()
            ))
        })
    }

    /// Starts budgeted job `id`'s passes again from pass 1 because tile `index`'s stored result
    /// was damaged (`why`): the pass it belongs to continued from an earlier pass's result that
    /// the tile row no longer keeps, so that tile cannot be rendered again alone. Every tile goes
    /// back to the queue (leases held are stale from here); the budget keeps counting from the
    /// job's start, with pass 1 timed from now; the reason is kept in the job's recent errors.
    pub fn restart_passes_after_damage(
        &mut self,
        id: u64,
        index: u32,
        why: &str,
    ) -> Result<(), Error> {
        let at_ms = now_ms();
        let job = self.job(id)?;
        let Some(clock) = job.clock_with(|clock| {
            *clock = PassClock {
                pass: 1,
                started_ms: Some(at_ms),
                pass_paused_ms: 0,
                complete: false,
                ..clock.clone()
            };
        })?
        else {
            return Err(Error::Conflict(format!("job {id} has no time budget")));
        };
        let tiles = job.tiles_total;
        let tx = self.db.transaction()?;
        for tile in 0..tiles {
            db::requeue_tile(&tx, id, tile)?;
        }
        db::set_passes(&tx, id, &clock.1)?;
        tx.commit()?;
        let job = self
            .jobs
            .get_mut(&id)
            .ok_or_else(|| Error::NotFound(format!("job {id} does not exist")))?;
        job.passes = Passes::of(&job.spec);
        job.set_clock(Some(clock));
        job.restore_tiles(&self.db, None)?;
        job.assembling = false;
        let message = format!(
            "{why}; a pass of one tile of a budgeted job cannot be rendered again alone: the \
             job's passes start again from pass 1"
        );
        tracing::error!(job = id, tile = index, %why, "stored tile damaged; passes restart from pass 1");
        job.remember_error(TileError {
            tile: index,
            worker_id: 0,
            worker: "coordinator".into(),
            at_ms,
            message,
        });
        self.job_changed(id);
        Ok(())
    }

    /// Puts every tile of budgeted job `id` back in the queue for pass 1, and stores pass 1
    /// as its clock (a job requeued, or stored before its passes were). Runs before the tile
    /// rows are read back.
    pub(crate) fn restart_passes(db: &mut rusqlite::Connection, job: &Job) -> anyhow::Result<()> {
        let Some(json) = Passes::json_of(&job.spec).map_err(|e| anyhow::anyhow!("{e}"))? else {
            return Ok(());
        };
        let tx = db.transaction()?;
        for index in 0..job.tiles_total {
            db::requeue_tile(&tx, job.id, index)?;
        }
        db::set_passes(&tx, job.id, &json)?;
        tx.commit()?;
        Ok(())
    }
}
