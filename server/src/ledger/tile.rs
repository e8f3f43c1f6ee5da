//! One tile of a live job as the ledger holds it: its latest lease and where it is.
//!
//! A tile moves `Pending → Leased → Done`, and back to `Pending` when its lease lapses, is
//! taken back, fails, or its stored result turns out damaged; every move is a method here, so
//! the lease rules ([`super::leases`]) say *when* a tile moves and this type says *how*. The
//! epoch only grows: each lease gets the next one, so a result from an older lease is known
//! stale. A done tile's result hash is in the database (`db::done_hash`), not here.

use std::time::Duration;

use tokio::time::Instant;

/// One tile of a job.
#[derive(Debug, Clone, PartialEq)]
pub struct Tile {
    /// The epoch of the latest lease (0: never leased).
    pub epoch: u64,
    /// The worker of the latest lease, while that lease may still report.
    pub worker: Option<u64>,
    pub status: TileStatus,
    /// When the latest lease was granted by this process.
    pub leased_at: Option<Instant>,
    /// A done tile's render seconds as its worker reported them.
    pub render_seconds: Option<f64>,
}

/// Where a tile is.
#[derive(Debug, Clone, PartialEq)]
pub enum TileStatus {
    Pending,
    Leased { deadline: Instant },
    Done,
}

impl Tile {
    /// A tile never leased.
    pub(crate) const PENDING: Tile = Tile {
        epoch: 0,
        worker: None,
        status: TileStatus::Pending,
        leased_at: None,
        render_seconds: None,
    };

    /// The same tile queued for another pass: pending, never leased in it, its epoch kept.
    pub(crate) fn for_next_pass(&self) -> Tile {
        Tile {
            epoch: self.epoch,
            ..Tile::PENDING
        }
    }

    /// Leased to `worker` at `epoch` from `now`, for `ttl`.
    pub(crate) fn lease(&mut self, epoch: u64, worker: u64, now: Instant, ttl: Duration) {
        self.epoch = epoch;
        self.worker = Some(worker);
        self.leased_at = Some(now);
        self.status = TileStatus::Leased {
            deadline: now + ttl,
        };
    }

    /// Is the latest lease `worker`'s, at `epoch`?
    pub fn is_held_by(&self, worker: u64, epoch: u64) -> bool {
        self.epoch == epoch && self.worker == Some(worker)
    }

    /// The lease is renewed (or revived, if it lapsed and nobody took the tile) until `now +
    /// ttl`.
    pub(crate) fn renew(&mut self, now: Instant, ttl: Duration) {
        self.status = TileStatus::Leased {
            deadline: now + ttl,
        };
    }

    /// When the lease in force lapses, if the tile is leased.
    pub fn deadline(&self) -> Option<Instant> {
        match self.status {
            TileStatus::Leased { deadline } => Some(deadline),
            _ => None,
        }
    }

    /// Has the latest lease been held for `max_age` at `now`?
    pub fn is_overdue(&self, now: Instant, max_age: Duration) -> bool {
        self.leased_at
            .is_some_and(|at| now.saturating_duration_since(at) >= max_age)
    }

    /// The lease lapsed: the tile is queued again, and its worker's late result is still
    /// taken until the tile is leased again.
    pub(crate) fn lapse(&mut self) {
        self.status = TileStatus::Pending;
    }

    /// The lease ends without a result (failed, or taken back at its greatest age): the tile is
    /// queued again and nothing more is taken from that lease. Returns its worker.
    pub(crate) fn release(&mut self) -> Option<u64> {
        self.status = TileStatus::Pending;
        self.worker.take()
    }

    /// The result is in, rendered in `render_seconds` as its worker says.
    pub(crate) fn done(&mut self, render_seconds: Option<f64>) {
        self.status = TileStatus::Done;
        self.render_seconds = render_seconds;
    }

    /// A done tile whose stored result turned out damaged is queued again; returns whether it
    /// was done.
    pub(crate) fn undo(&mut self) -> bool {
        if self.status != TileStatus::Done {
            return false;
        }
        self.status = TileStatus::Pending;
        self.worker = None;
        self.render_seconds = None;
        true
    }
}
