//! The numbers of the lease and failure rules, in one place.
//!
//! The rules themselves:
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
//! - A lease lapses, too, once it is older than its greatest age ([`MAX_LEASE_AGE_TTLS`],
//!   [`MAX_LEASE_AGE_RENDERS`]), however often it was renewed: a worker that only sends
//!   heartbeats cannot keep a tile for ever. The tile goes back to the queue, the holder's late
//!   result is no longer taken, and the holder is not given that tile again.
//! - A job fails, with the reason, when [`DETERMINISTIC_CONFIRMATIONS`] different workers
//!   report a tile's failure as deterministic (each says no worker could do better: the scene
//!   does not build, the pixels overflow f32 — one worker's word is only a claim), when a
//!   tile failed on [`TILE_FAILURE_LIMIT`] different workers, when [`JOB_FAILURE_LIMIT`] tile
//!   failures add up in the job, or when no connected worker may take a tile that failed (every
//!   connected worker failed it or is kept off the job). With no worker connected at all, jobs
//!   wait: there is nobody to judge by. So with one connected worker its report of a tile's
//!   failure, deterministic or not, fails the job at once: nobody else may take the tile, to
//!   confirm the claim or to do better (Flamenco's rule: a job no worker is left to complete
//!   fails), where waiting would leave a one-worker farm (`spindle render --workers 1`)
//!   hanging on a scene that does not build.
//! - A worker is connected while it is in a lease poll, and for one lease TTL after any request.
//! - A job with `requires` is leased only to workers whose labels include every requirement;
//!   a draining worker is leased nothing (410) and its heartbeats answer `drain`. Only workers
//!   that may take a job's tiles count when judging whether it is stuck: a job no connected
//!   worker is eligible for waits (its `workers_eligible` is 0), like a job with no worker.
//!
//! [`super::job::Job`] applies them to one job's tiles; [`super::leases`] when leases are
//! granted, renewed and reported on.

/// Worker failures on one tile that fail its job.
pub const TILE_FAILURE_LIMIT: usize = 3;
/// Tiles a worker may fail in one job before it is kept off that job.
pub const WORKER_STRIKE_LIMIT: usize = 3;
/// Tile failures, over all tiles and workers, that fail a job: a job whose tiles keep failing
/// on different workers is broken even if no single tile reached [`TILE_FAILURE_LIMIT`].
pub const JOB_FAILURE_LIMIT: usize = 10;
/// Distinct workers that must report a tile's failure as deterministic ("no worker could do
/// better") before the job fails for it: one worker's word is a claim, which any registered
/// identity could make about anyone's job.
pub const DETERMINISTIC_CONFIRMATIONS: usize = 2;
/// A lease's greatest age, in lease TTLs, however often it is renewed, while the job has no
/// measured tile.
pub const MAX_LEASE_AGE_TTLS: u32 = 20;
/// A lease's greatest age, in multiples of the slowest render time measured on the job's
/// finished tiles, when that is longer.
pub const MAX_LEASE_AGE_RENDERS: f64 = 8.0;
