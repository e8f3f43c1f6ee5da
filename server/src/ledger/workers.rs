//! The ledger's workers: registration with a secret, the identity a secret proves, liveness
//! (heard from, lease polls, losses announced), the list operators see, drain, and forgetting
//! lost workers.
//!
//! A worker's own changes are [`Worker`]'s methods; here they are decided, written to the
//! database first where they are stored, and announced.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::time::Duration;

use spindle_common::protocol::{EventKind, LOST_WORKERS_LISTED_S, WorkerInfo, format_labels};
use tokio::time::Instant;

use super::Ledger;
use super::worker::Worker;
use crate::clock::now_ms;
use crate::db;
use crate::error::Error;
use crate::worker_secret::{self, WORKER_SECRET, WorkerIdentity};

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
        let issued = worker_secret::issue(id)?;
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

    /// The worker whose secret `presented` is: 403 if it is missing, malformed or wrong; 404 if
    /// the worker is not (or no longer) registered, or registered before secrets existed — it
    /// registers again.
    pub fn authenticate(&self, presented: Option<&str>) -> Result<WorkerIdentity, Error> {
        let Some(presented) = presented else {
            return Err(Error::Forbidden(format!(
                "missing worker secret ({WORKER_SECRET})"
            )));
        };
        let Some(worker) = presented
            .split_once('.')
            .and_then(|(id, _)| id.parse::<u64>().ok())
        else {
            return Err(Error::Forbidden(format!(
                "malformed worker secret ({WORKER_SECRET})"
            )));
        };
        self.check_worker(worker)?;
        let Some(expected) = self.workers[&worker].secret_sha256 else {
            return Err(Error::NotFound(format!(
                "worker {worker} registered before worker secrets existed: register again \
                 (POST /v1/workers)"
            )));
        };
        if worker_secret::matches(presented, &expected) {
            Ok(WorkerIdentity(worker))
        } else {
            Err(Error::Forbidden(format!(
                "wrong worker secret for worker {worker} ({WORKER_SECRET})"
            )))
        }
    }

    /// Notes that `worker` was heard from at `now` (unknown ids are ignored).
    pub fn seen(&mut self, worker: u64, now: Instant) {
        let ttl = self.lease_ttl;
        if let Some(w) = self.workers.get_mut(&worker) {
            w.seen(now, ttl, now_ms());
        }
    }

    /// A lease long poll of `worker` begins; it counts as connected until [`Ledger::poll_ended`].
    pub fn poll_started(&mut self, worker: u64, now: Instant) -> Result<(), Error> {
        self.check_worker(worker)?;
        self.seen(worker, now);
        if let Some(w) = self.workers.get_mut(&worker) {
            w.poll_started();
        }
        Ok(())
    }

    /// A lease long poll of `worker` ended (answered, or the client went away).
    pub fn poll_ended(&mut self, worker: u64, now: Instant) {
        self.seen(worker, now);
        if let Some(w) = self.workers.get_mut(&worker) {
            w.poll_ended();
        }
    }

    /// Announces workers not heard from for a lease TTL, once per loss.
    pub fn announce_lost(&mut self, now: Instant) {
        for (&id, w) in self.workers.iter_mut() {
            if w.newly_lost(now) {
                self.events.publish(EventKind::WorkerLost {
                    worker_id: id,
                    worker: w.name.clone(),
                });
            }
        }
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
            .map(|(&id, w)| w.info(id, holding.get(&id).copied(), now, wall))
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
                && w.drain()
            {
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
        self.forget_workers(&[id])?;
        tracing::info!(
            worker = id,
            "lost worker forgotten to make room for a registration"
        );
        Ok(())
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
        self.forget_workers(&gone)?;
        for id in &gone {
            tracing::info!(worker = id, "lost worker forgotten");
        }
        Ok(gone.len())
    }

    /// Deletes workers `ids`, in one commit.
    fn forget_workers(&mut self, ids: &[u64]) -> Result<(), Error> {
        if ids.is_empty() {
            return Ok(());
        }
        let tx = self.db.transaction()?;
        for &id in ids {
            db::delete_worker(&tx, id)?;
        }
        tx.commit()?;
        for id in ids {
            self.workers.remove(id);
        }
        Ok(())
    }
}
