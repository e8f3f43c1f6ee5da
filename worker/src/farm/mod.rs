//! The farm worker process: registers with a coordinator, leases tiles, renders them with
//! [`crate::render`] and uploads them, until told to stop.
//!
//! This is the only part of the crate that talks to the network. It is a library so the
//! `spindle-worker` binary stays a thin shell and the `spindle render` command can run workers
//! in its own process: both call [`run`].

pub mod backoff;
pub mod cache;
pub mod client;
pub mod config;
pub mod lease;
pub mod upload;

pub use config::{Config, ConfigError};
pub use lease::Summary;
use tokio_util::sync::CancellationToken;

/// Runs one worker until `shutdown` is cancelled (then finishes or abandons the tile in hand
/// and returns what it did), or until the coordinator refuses the worker token (an error).
///
/// Must be called inside a tokio runtime; rendering happens on a rayon pool of
/// `config.threads` threads owned by this worker.
pub async fn run(config: Config, shutdown: CancellationToken) -> anyhow::Result<Summary> {
    lease::Worker::new(config, shutdown)?.run().await
}
