//! Progressive passes of a job with `film.time_budget_s`: the farm's time budget.
//!
//! Such a job is rendered as successive sets of its tiles. Pass `k` of every tile takes each
//! pixel to `min(16 k, film.spp)` samples, continuing from the running sums its pass-`k − 1`
//! result carried ([`spindle_common::passes::TileProgress`], stored with the tile as any result
//! is; a worker fetches it through `GET /v1/leases/{job}/{tile}/previous`). Pass `k + 1` starts
//! only when every tile has finished pass `k`, and only if the budget allows it by the rule of
//! `spindle render --workers 0`: the time since the job started (its first lease) plus the
//! time the last pass took is within the budget. Otherwise — or when every pixel has `spp`
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
//! The hashes of the previous pass's results live in memory only (the tile table keeps one
//! result per tile): a coordinator that restarts, or a job requeued after it failed or was
//! cancelled, renders a budgeted job again from pass 1 ([`Ledger::restart_passes`]), keeping the
//! job's start, so its budget still counts from then.

use std::sync::Arc;

use spindle_common::passes::pass_cap;
use spindle_common::protocol::{JobSpec, PassInfo, TileUpload};

use crate::db;
use crate::error::Error;
use crate::jobs::{Job, Ledger, Tile, TileStatus, now_ms};

/// Where a budgeted job's passes stand.
#[derive(Debug, Clone, PartialEq)]
pub struct Passes {
    /// `film.time_budget_s`, counted from the job's start.
    budget_s: f64,
    /// The pass being rendered (from 1).
    pub pass: u32,
    /// When the current pass began (wall-clock ms); `None` until the job's first lease.
    started_ms: Option<i64>,
    /// Each tile's result of the previous pass (its hash), from which its current pass goes
    /// on; all `None` in pass 1.
    previous: Vec<Option<String>>,
    /// Per tile done in this pass: its pixels that would take more samples in another pass.
    sampling: Vec<u32>,
    /// The last pass ended and no other follows: the job may be assembled.
    pub complete: bool,
}

impl Passes {
    /// The passes of a job whose scene has a time budget, at pass 1.
    pub fn of(spec: &JobSpec) -> Option<Passes> {
        let budget_s = spec.scene.film.time_budget_s?;
        let tiles = spec.tiles().len();
        Some(Passes {
            budget_s,
            pass: 1,
            started_ms: None,
            previous: vec![None; tiles],
            sampling: vec![0; tiles],
            complete: false,
        })
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
            pass: self.pass,
            spp: pass_cap(self.pass, spp),
            budget_s: self.budget_s,
        }
    }
}

impl Job {
    /// Notes the job's start for the clock of its first pass.
    pub(crate) fn passes_started(&mut self, at_ms: i64) {
        if let Some(p) = &mut self.passes
            && p.started_ms.is_none()
        {
            p.started_ms = Some(at_ms);
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
                passes.pass
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

    /// Notes a recorded upload's pixels still sampling (after [`Job::check_pass`]).
    pub(crate) fn pass_tile_done(&mut self, index: u32, upload: &TileUpload) {
        let spp = self.spec.scene.film.spp;
        if let (Some(passes), Some(progress)) = (&mut self.passes, &upload.pixels.progress) {
            let sampling = progress
                .pixels
                .iter()
                .filter(|p| !p.converged && p.taken < spp)
                .count();
            passes.sampling[index as usize] = sampling as u32;
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
}

impl Ledger {
    /// Called when every tile of job `id` is in: starts the next pass if the budget allows it
    /// and a pixel would take more samples, else fixes the job's spec at the reached `spp`.
    /// A job without a budget is complete.
    pub(crate) fn end_of_pass(&mut self, id: u64) -> Result<PassEnd, Error> {
        let now = now_ms();
        let job = self.job(id)?;
        let Some(passes) = &job.passes else {
            return Ok(PassEnd::Complete);
        };
        let spp = job.spec.scene.film.spp;
        let cap = pass_cap(passes.pass, spp);
        let sampling: u64 = passes.sampling.iter().map(|&n| u64::from(n)).sum();
        let job_start = job.started_ms.unwrap_or(now);
        let pass_start = passes.started_ms.unwrap_or(job_start);
        let seconds = |from: i64| (now - from).max(0) as f64 / 1000.0;
        let next_would_end = seconds(job_start) + seconds(pass_start);
        let go_on = cap < spp && sampling > 0 && next_would_end <= passes.budget_s;
        tracing::info!(
            job = id,
            pass = passes.pass,
            spp = cap,
            pixels_sampling = sampling,
            elapsed_s = seconds(job_start),
            budget_s = passes.budget_s,
            go_on,
            "pass complete"
        );
        if !go_on {
            // The image is the one-pass render at the reached cap: say so where it is assembled.
            let mut spec = JobSpec::clone(&job.spec);
            spec.scene.film.spp = cap;
            let job = self.job_mut(id)?;
            job.spec = Arc::new(spec);
            job.passes.as_mut().expect("checked above").complete = true;
            return Ok(PassEnd::Complete);
        }
        let results = db::done_tiles(&self.db, id)?;
        let tx = self.db.transaction()?;
        for (index, _) in &results {
            db::next_pass_tile(&tx, id, *index)?;
        }
        tx.commit()?;
        let job = self.job_mut(id)?;
        let passes = job.passes.as_mut().expect("checked above");
        passes.pass += 1;
        passes.started_ms = Some(now);
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
        self.job_changed(id);
        Ok(PassEnd::NextPass)
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
                passes.pass
            ))
        })
    }

    /// Puts every tile of budgeted job `id` back in the queue for pass 1 (its tile rows are
    /// being rebuilt from the database, which keeps no previous pass); the job's start stays.
    /// Runs before the rows are read back.
    pub(crate) fn restart_passes(db: &mut rusqlite::Connection, job: &Job) -> anyhow::Result<()> {
        if job.passes.is_none() {
            return Ok(());
        }
        let tx = db.transaction()?;
        for index in 0..job.tiles_total {
            db::requeue_tile(&tx, job.id, index)?;
        }
        tx.commit()?;
        Ok(())
    }
}
