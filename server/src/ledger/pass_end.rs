//! The ledger's side of a budgeted job's passes ([`super::passes`]): ending a pass (the next
//! one queued, or the job complete at the reached `spp`), failing a job whose pass cannot be
//! ended, a tile's previous result for the worker continuing it, and starting the passes
//! again when a stored result is damaged.
//!
//! Ending a pass writes to the database; it runs where assembly does ([`crate::assemble`]),
//! after the upload of the pass's last tile was recorded, and an error is retried with the
//! assembly's backoff until it passes or [`PASS_END_ATTEMPTS`] failed: then the job fails.

use spindle_common::passes::pass_cap;
use spindle_common::protocol::TileError;

use super::Ledger;
use super::passes::{PassClock, Passes};

use super::tile::TileStatus;
use crate::clock::now_ms;
use crate::db;
use crate::error::{Error, is_disk_full};

/// Attempts at ending a pass (the first and its retries) before the job fails.
pub const PASS_END_ATTEMPTS: u32 = 6;

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
        let sampling = passes.pixels_sampling();
        let job_start = job.started_ms.unwrap_or(now);
        let (elapsed_s, pass_s) = passes.clock.runnable_s(job_start, now);
        let go_on = cap < spp && sampling > 0 && elapsed_s + pass_s <= passes.budget_s();
        tracing::info!(
            job = id,
            pass = passes.pass(),
            spp = cap,
            pixels_sampling = sampling,
            elapsed_s,
            pass_s,
            budget_s = passes.budget_s(),
            go_on,
            "pass complete"
        );
        if !go_on {
            let clock = job.clock_with(|c| c.complete = true)?;
            if let Some((_, json)) = &clock {
                db::set_passes(&self.db, id, json)?;
            }
            // The image is the one-pass render at the reached cap: say so where it is assembled.
            self.job_mut(id)?.complete_passes(clock);
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
        self.job_mut(id)?.begin_next_pass(clock, results);
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
        let message = format!(
            "{why}; a pass of one tile of a budgeted job cannot be rendered again alone: the \
             job's passes start again from pass 1"
        );
        tracing::error!(job = id, tile = index, %why, "stored tile damaged; passes restart from pass 1");
        let error = TileError {
            tile: index,
            worker_id: 0,
            worker: "coordinator".into(),
            at_ms,
            message,
        };
        let job = self
            .jobs
            .get_mut(&id)
            .ok_or_else(|| Error::NotFound(format!("job {id} does not exist")))?;
        job.restart_passes_from(clock, &self.db, error)?;
        self.job_changed(id);
        Ok(())
    }
}
