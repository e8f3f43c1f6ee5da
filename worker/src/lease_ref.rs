//! Which lease a message is about: one tile of one job, at one epoch.
//!
//! The coordinator names a lease by job and tile in the URL and by epoch in the body of every
//! heartbeat, upload and failure report; the worker carries the three together so that no call
//! can mix up one lease's job with another's epoch.

use spindle_common::protocol::Lease;

/// The identity of a lease this worker holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LeaseRef {
    pub job: u64,
    /// The tile's index in the job's centre-first order.
    pub tile: u32,
    /// The lease's epoch; a newer lease of the same tile has a higher one.
    pub epoch: u64,
}

impl From<&Lease> for LeaseRef {
    fn from(lease: &Lease) -> LeaseRef {
        LeaseRef {
            job: lease.job_id,
            tile: lease.tile_index,
            epoch: lease.epoch,
        }
    }
}
