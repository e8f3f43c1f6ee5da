//! The ledger's jobs: submission (idempotent), the filtered and paged list, pause, resume,
//! requeue, priority, cancel, delete, failure, assembly and retention.
//!
//! A job's own changes are [`Job`]'s methods; here each is decided, written to the database
//! first, applied, and announced. A job fails in one place, [`Ledger::job_failed`], after
//! [`store_failed`] was committed: by [`Ledger::fail_job`] here, or with the tile failure that
//! failed it ([`super::leases`]). Leasing, heartbeats, uploads and failures are in
//! [`super::leases`].

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;

use rusqlite::Connection;
use spindle_common::protocol::{JobInfo, JobOrder, JobSpec, JobState, SubmitJob};
use tokio::time::Instant;

use super::Ledger;
use super::job::Job;
use super::passes::Passes;
use crate::clock::now_ms;
use crate::db::{self, JobRow};
use crate::error::Error;

/// Which jobs `GET /v1/jobs` lists.
#[derive(Debug, Clone)]
pub struct JobFilter {
    pub state: Option<JobState>,
    /// Jobs whose name contains this.
    pub name: Option<String>,
    /// The cursor: jobs after this id in `order` only (larger ids ascending, smaller
    /// descending).
    pub after: Option<u64>,
    pub limit: usize,
    pub order: JobOrder,
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
                frame: submit.frame,
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
        self.check_room(max_active, "; wait for one to finish or cancel one")?;
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

    /// A page of the jobs `filter` selects, oldest first, and the cursor of the next page.
    pub fn list(&self, filter: &JobFilter) -> (Vec<JobInfo>, Option<String>) {
        let now = Instant::now();
        let wall = now_ms();
        let live = self.workers_live(now);
        let ids: Box<dyn Iterator<Item = &Job>> = match filter.order {
            JobOrder::Asc => {
                let start = filter.after.map_or(0, |a| a.saturating_add(1));
                Box::new(self.jobs.range(start..).map(|(_, j)| j))
            }
            JobOrder::Desc => match filter.after {
                None => Box::new(self.jobs.values().rev()),
                Some(before) => Box::new(self.jobs.range(..before).rev().map(|(_, j)| j)),
            },
        };
        let mut selected = ids.filter(|j| {
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
        self.job_mut(id)?.pause(clock);
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
        self.job_mut(id)?.resume(state, clock);
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
        self.check_room(max_active, "")?;
        let tx = self.db.transaction()?;
        db::requeue_job(&tx, id)?;
        db::set_job_state(&tx, id, JobState::Queued, None, None, None)?;
        tx.commit()?;
        let job = self
            .jobs
            .get_mut(&id)
            .ok_or_else(|| Error::NotFound(format!("job {id} does not exist")))?;
        job.requeue(&mut self.db)?;
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
        self.job_mut(id)?.end(JobState::Cancelled, None, now);
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
        let at_ms = now_ms();
        store_failed(&self.db, self.job(id)?, &error, at_ms)?;
        self.job_failed(id, error, at_ms)
    }

    /// The one way a job fails, once [`store_failed`] has been committed (alone, or with the
    /// change that failed it): `failed` with `error` since `at_ms`, its leases dropped, and
    /// announced.
    pub(crate) fn job_failed(&mut self, id: u64, error: String, at_ms: i64) -> Result<(), Error> {
        tracing::error!(job = id, %error, "job failed");
        self.job_mut(id)?.end(JobState::Failed, Some(error), at_ms);
        self.job_changed(id);
        Ok(())
    }

    /// Refuses another live job (429) when `max_active` are queued, running or paused;
    /// `advice` ends the message.
    fn check_room(&self, max_active: usize, advice: &str) -> Result<(), Error> {
        let active = self
            .jobs
            .values()
            .filter(|j| !j.state.is_finished())
            .count();
        if active >= max_active {
            return Err(Error::TooMany(format!(
                "{active} jobs are queued or running, the limit is {max_active}{advice}"
            )));
        }
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
        job.end(JobState::Done, None, now);
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
            tracing::error!(job = id, tile = index, %why, "stored tile damaged; rendering it again");
            job.tile_damaged(*index, why, at_ms);
        }
        job.stats = stats;
        job.noise = noise;
        job.assembling = false;
        Ok(())
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
}

/// Writes job `job`'s failure with `error` at `at_ms` to `db` (a transaction's, with what
/// else it commits); [`Ledger::job_failed`] then applies it.
pub(crate) fn store_failed(
    db: &Connection,
    job: &Job,
    error: &str,
    at_ms: i64,
) -> Result<(), Error> {
    db::set_job_state(
        db,
        job.id,
        JobState::Failed,
        Some(error),
        job.started_ms,
        Some(at_ms),
    )?;
    Ok(())
}
