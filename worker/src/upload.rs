//! Delivering a rendered tile: upload it, and keep retrying with backoff until the
//! coordinator acknowledges it or says it is no longer wanted.
//!
//! A rendered tile is the expensive thing in a farm, so it is not given up because the
//! coordinator is restarting: transient failures are retried until `stop` (the worker's hard
//! deadline) fires. Uploads are safe to repeat: the coordinator acknowledges an identical
//! result for a finished tile as a duplicate.

use bytes::Bytes;
use spindle_common::protocol::{TileOutcome, TileUpload, pixel_hash};
use spindle_common::provenance::Provenance;
use spindle_common::tile::TilePixels;
use spindle_common::tile_encoding;
use tokio_util::sync::CancellationToken;

use crate::backoff::{Backoff, RetryEnd, retry};
use crate::client::{Client, ErrorKind};
use crate::lease_ref::LeaseRef;

/// How an upload ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Delivery {
    /// The coordinator acknowledged the tile.
    Acknowledged(TileOutcome),
    /// The coordinator does not want it (stale lease, job deleted); the reason is for the log.
    Refused(String),
    /// The coordinator refused the tile itself as invalid (400, 413): the tile must be reported
    /// as failed with the coordinator's message, or it would be leased and refused again forever.
    Invalid(String),
    /// `stop` fired before an acknowledgement; the lease will lapse and the tile be rendered
    /// elsewhere.
    Abandoned,
}

/// A rendered tile and what the worker reports with it.
#[derive(Debug, Clone)]
pub struct RenderedTile {
    pub pixels: TilePixels,
    /// Wall-clock seconds spent in `render_tile`.
    pub seconds: f64,
    /// The job's provenance, from the scene the tile was rendered with.
    pub provenance: Provenance,
}

/// Uploads `rendered` for `lease` until acknowledged.
pub async fn deliver(
    client: &Client,
    policy: Backoff,
    stop: &CancellationToken,
    worker_id: u64,
    lease: LeaseRef,
    rendered: RenderedTile,
) -> Delivery {
    let LeaseRef { job, tile, epoch } = lease;
    let body = TileUpload {
        worker_id,
        epoch,
        hash: pixel_hash(&rendered.pixels),
        pixels: rendered.pixels,
        render_seconds: Some(rendered.seconds),
        provenance: Some(rendered.provenance),
    };
    // Encoding (zstd over tens of kilobytes) is CPU work: off the runtime, once for all tries.
    let encoded = match tokio::task::spawn_blocking(move || tile_encoding::encode(&body)).await {
        Ok(Ok(encoded)) => Bytes::from(encoded),
        Ok(Err(e)) => return Delivery::Invalid(format!("encoding the tile: {e}")),
        Err(e) => return Delivery::Invalid(format!("encoding the tile: {e}")),
    };
    let salt = worker_id ^ (job << 32) ^ u64::from(tile);
    match retry(policy, salt, stop, "uploading a tile", || {
        client.upload(job, tile, epoch, encoded.clone())
    })
    .await
    {
        Ok(ack) => Delivery::Acknowledged(ack.outcome),
        Err(RetryEnd::Stopped) => Delivery::Abandoned,
        Err(RetryEnd::Failed(e)) if e.kind() == ErrorKind::Rejected => {
            tracing::error!(job, tile, error = %e, "the coordinator refused a rendered tile");
            Delivery::Invalid(e.to_string())
        }
        Err(RetryEnd::Failed(e)) => Delivery::Refused(e.to_string()),
    }
}
