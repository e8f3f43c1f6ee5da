//! One registered worker as far as the coordinator can tell: who it is, whether it is
//! connected, and what it has done.
//!
//! A worker is connected while it is in a lease poll, and for one lease TTL after any request
//! ([`Worker::is_live`]); the ledger decides with that whether a job is stuck and whom to
//! announce as lost. Its changes (heard from, a poll begun or ended, a tile accepted or
//! failed, told to drain) are methods here; the ledger writes the stored ones through to the
//! database first.

use std::collections::{BTreeMap, VecDeque};
use std::time::Duration;

use spindle_common::protocol::{THROUGHPUT_WINDOW_S, WorkerInfo, WorkerState};
use tokio::time::Instant;

/// One registered worker.
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

    /// The worker was heard from at `now` (wall clock `wall_ms`): connected for `ttl` more.
    pub(crate) fn seen(&mut self, now: Instant, ttl: Duration, wall_ms: i64) {
        self.seen_until = self.seen_until.max(now + ttl);
        self.last_seen_ms = wall_ms;
    }

    /// A lease poll begins: connected until it ends.
    pub(crate) fn poll_started(&mut self) {
        self.polls += 1;
    }

    /// A lease poll ended.
    pub(crate) fn poll_ended(&mut self) {
        self.polls = self.polls.saturating_sub(1);
    }

    /// Told to drain; `false` if it already was.
    pub(crate) fn drain(&mut self) -> bool {
        !std::mem::replace(&mut self.draining, true)
    }

    /// Is the worker newly lost at `now` (connected before, its loss not yet announced)? Once
    /// it is connected again, its next loss is new again.
    pub(crate) fn newly_lost(&mut self, now: Instant) -> bool {
        if self.is_live(now) {
            self.announced_lost = false;
            false
        } else {
            !std::mem::replace(&mut self.announced_lost, true)
        }
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

    /// Notes a tile failure it reported.
    pub(crate) fn tile_failed(&mut self) {
        self.failures += 1;
    }

    /// Tiles accepted within the last [`THROUGHPUT_WINDOW_S`] before `now_ms`, per minute.
    pub fn tiles_per_min(&self, now_ms: i64) -> f64 {
        let since = now_ms - THROUGHPUT_WINDOW_S as i64 * 1000;
        let n = self.recent_tiles.iter().filter(|&&t| t >= since).count();
        n as f64 / (THROUGHPUT_WINDOW_S as f64 / 60.0)
    }

    /// The worker `id` as `GET /v1/workers` lists it at `now` (wall clock `wall_ms`), holding
    /// `lease` (job, tile) if any.
    pub fn info(
        &self,
        id: u64,
        lease: Option<(u64, u32)>,
        now: Instant,
        wall_ms: i64,
    ) -> WorkerInfo {
        let state = if !self.is_live(now) {
            WorkerState::Lost
        } else if self.draining {
            WorkerState::Draining
        } else if lease.is_some() {
            WorkerState::Rendering
        } else {
            WorkerState::Idle
        };
        WorkerInfo {
            id,
            name: self.name.clone(),
            version: self.version.clone(),
            threads: self.threads,
            labels: self.labels.clone(),
            state,
            job: lease.map(|l| l.0),
            tile: lease.map(|l| l.1),
            last_seen_ms: self.last_seen_ms,
            tiles_done: self.tiles_done,
            failures: self.failures,
            tiles_per_min: self.tiles_per_min(wall_ms),
        }
    }
}
