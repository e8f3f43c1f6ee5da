//! The farm worker process: registers with a coordinator, leases tiles, renders them with
//! [`spindle_render`] and uploads them, until told to stop.
//!
//! It is a library so the
//! `spindle-worker` binary stays a thin shell and the `spindle render` command can run workers
//! in its own process: both call [`run`].

#![forbid(unsafe_code)]

pub mod backoff;
pub mod bands;
pub mod cache;
pub mod client;
pub mod config;
pub mod detached;
pub mod lease_ref;
pub mod tls;
pub mod upload;
pub mod work_loop;

pub use config::{Config, ConfigError};
use tokio_util::sync::CancellationToken;
pub use work_loop::Summary;

/// Runs one worker until `shutdown` is cancelled (then finishes or abandons the tile in hand
/// and returns what it did), or until the coordinator refuses the worker token (an error).
///
/// Must be called inside a tokio runtime; rendering happens on a rayon pool of
/// `config.threads` threads owned by this worker.
pub async fn run(config: Config, shutdown: CancellationToken) -> anyhow::Result<Summary> {
    work_loop::Worker::new(config, shutdown)?.run().await
}
