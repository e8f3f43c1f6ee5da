//! The coordinator's ledger: every job, tile and worker in memory, written through to the
//! database.
//!
//! [`Ledger`] mirrors the database ([`crate::db`]) and owns the connection, so one lock orders
//! every change: each change is written to the database first and applied in memory only once
//! the write succeeded. A restarted coordinator rebuilds the ledger from the database with
//! [`Ledger::load`].
//!
//! The folder keeps the state and its changes apart from the orchestration:
//! - the state, which knows nothing of the ledger: [`job::Job`], [`tile::Tile`],
//!   [`worker::Worker`] and a budgeted job's [`passes::Passes`], each with the methods that
//!   change it, and [`rules`], the numbers of the lease and failure rules;
//! - the ledger, which decides, writes to the database and announces ([`crate::events`]):
//!   this module (the type, loading, lookups), [`jobs`] (submission, control, assembly,
//!   retention), [`leases`] (leases, uploads, failures), [`pass_end`] (the ends of passes)
//!   and [`workers`] (registration, identity, liveness, drain).
//!
//! Nothing outside the folder changes a job, tile or worker.

pub mod job;
pub mod jobs;
pub mod leases;
pub mod pass_end;
pub mod passes;
pub mod rules;
pub mod tile;
pub mod worker;
pub mod workers;

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::sync::Arc;
use std::time::Duration;

use rusqlite::Connection;
use spindle_common::protocol::{EventKind, JobInfo, JobSpec, JobState, TileError};
use tokio::time::Instant;

use crate::clock::now_ms;
use crate::db;
use crate::error::Error;
use crate::events::Events;
use job::Job;
use worker::Worker;

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
                    None => job.restart_passes(&mut db)?,
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

    /// How many workers are connected at `now`.
    pub fn workers_live(&self, now: Instant) -> u32 {
        let live = self.workers.values().filter(|w| w.is_live(now)).count();
        u32::try_from(live).unwrap_or(u32::MAX)
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

    /// `name (id)` of each worker, comma-separated.
    pub(crate) fn worker_names(&self, ids: &[u64]) -> String {
        ids.iter()
            .map(|id| match self.workers.get(id) {
                Some(w) => format!("{} ({id})", w.name),
                None => format!("worker {id}"),
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Per-tile entries held in memory, over every job (0 for a finished job).
    pub fn tiles_in_memory(&self) -> usize {
        self.jobs
            .values()
            .map(|j| j.tiles.len().max(j.rects.len()))
            .sum()
    }

    /// Checks that the database answers.
    pub fn check_database(&self) -> Result<(), Error> {
        self.db.query_row("SELECT 1", [], |_| Ok(()))?;
        Ok(())
    }
}
