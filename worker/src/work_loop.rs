//! The worker's main loop: register, lease a tile, render it while heartbeats keep the lease
//! alive, deliver it, repeat, until told to stop.
//!
//! Failure handling in one place:
//! - the coordinator unreachable or answering 5xx: wait with backoff and retry, forever (it may
//!   be restarting);
//! - the coordinator no longer knows this worker (404 on the lease route): register again;
//! - a heartbeat answered 409/404 (the lease is lost, or its job cancelled or deleted):
//!   whatever was being done for it is abandoned at once — the scene build or the tile render
//!   is walked away from ([`crate::detached`]; a render stops at its next band of rows) — and
//!   the worker asks for its next lease;
//! - a scene build or a tile render past the worker's time limit (`build_time_limit`,
//!   `tile_time_limit`): given up the same way, and the tile reported as failed, naming the
//!   limit, as a failure another worker might avoid;
//! - a job that cannot be rendered (bad asset, renderer panic, a tile the coordinator refuses as
//!   invalid): the tile is reported through the fail route with the reason, so the coordinator
//!   can apply its failure rules; a failure no other worker could avoid (the scene does not
//!   build, a pixel overflows f32) is reported as deterministic, which fails the job once a
//!   second worker confirms it (or no other worker may take the tile);
//! - the token refused (401/403): the worker stops with an error, since no retry can fix it.
//!
//! Drain: when a lease request answers 410 or a heartbeat answer says `drain`, the operator has
//! asked this worker to leave: the tile in hand is finished and delivered (no deadline), no new
//! lease is asked for, and the worker returns `Ok` (the binary exits 0).
//!
//! Shutdown: once `shutdown` fires, no new lease is asked for. The tile in hand is finished and
//! delivered, for at most `shutdown_grace` more; then the worker gives up on it (the lease
//! lapses and another worker renders it) and returns. Builds and renders run on the worker's
//! own rayon pool from threads of their own ([`crate::detached`]), never on the async runtime,
//! so heartbeats keep flowing; the worker asks for a lease only with a slot of its
//! [`Gate`] in hand, so work it walked away from never piles up.

use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, anyhow};
use spindle_common::protocol::{Heartbeat, Lease, RegisterWorker, TileFailure, TileOutcome};
use spindle_common::tile::TilePixels;
use tokio_util::sync::CancellationToken;

use crate::Config;
use crate::backoff::{Attempts, RetryEnd, retry};
use crate::bands;
use crate::cache::{LoadError, SceneCache};
use crate::client::{Client, ClientError, ErrorKind};
use crate::detached::{self, Ended, Gate, Slot};
use crate::lease_ref::LeaseRef;
use crate::upload::{Delivery, RenderedTile, deliver};

/// Shortest and longest pause between heartbeats.
const HEARTBEAT_MIN: Duration = Duration::from_millis(50);
const HEARTBEAT_MAX: Duration = Duration::from_secs(10);

/// What a worker did before it stopped.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Summary {
    /// Tiles the coordinator stored from this worker.
    pub accepted: u64,
    /// Tiles acknowledged as identical duplicates of an earlier result.
    pub duplicates: u64,
    /// Tiles rendered or started but not delivered (lease lost, job gone, shutdown deadline).
    pub abandoned: u64,
    /// Tiles reported as failed.
    pub failed: u64,
    /// Scenes built (jobs loaded).
    pub scenes_built: u64,
    /// Times the worker registered (more than 1: the coordinator forgot it).
    pub registrations: u64,
    /// The coordinator told the worker to drain, and it stopped for that.
    pub drained: bool,
}

/// One worker's state.
pub struct Worker {
    config: Config,
    client: Client,
    pool: Arc<rayon::ThreadPool>,
    cache: SceneCache,
    /// Bounds the threads building or rendering for this worker, abandoned ones included.
    gate: Gate,
    shutdown: CancellationToken,
    /// Fires when the coordinator says the worker is draining: no new lease after the tile in
    /// hand.
    drain: CancellationToken,
    /// Fires `shutdown_grace` after `shutdown`: the end of the tile in hand.
    hard_stop: CancellationToken,
    worker_id: Option<u64>,
    /// Backoff state of consecutive failed lease requests.
    lease_attempts: Attempts,
    summary: Summary,
}

/// How the work on one lease ended, before delivery.
enum Rendered {
    Pixels(Box<RenderedTile>),
    /// The tile cannot be rendered: report this reason (`deterministic`: no worker could).
    Failed {
        reason: String,
        deterministic: bool,
    },
    /// Nothing to deliver (lease lost, job gone, deadline).
    Abandoned,
}

impl Worker {
    /// Sets up the render pool and the client; no request is made yet.
    pub fn new(config: Config, shutdown: CancellationToken) -> anyhow::Result<Worker> {
        let pool = Arc::new(
            rayon::ThreadPoolBuilder::new()
                .num_threads(config.threads)
                .thread_name(|i| format!("render-{i}"))
                .build()
                .context("starting the render threads")?,
        );
        let client = Client::with_ca_cert(
            &config.coordinator,
            config.token.clone(),
            config.ca_cert.as_deref(),
        )?;
        let cache = SceneCache::new(
            client.clone(),
            pool.clone(),
            config.backoff,
            config.build_time_limit,
        );
        let hard_stop = CancellationToken::new();
        {
            let (shutdown, hard_stop, grace) =
                (shutdown.clone(), hard_stop.clone(), config.shutdown_grace);
            // Dropped with the runtime if the worker returns first; nothing to clean up.
            tokio::spawn(async move {
                shutdown.cancelled().await;
                tokio::time::sleep(grace).await;
                hard_stop.cancel();
            });
        }
        Ok(Worker {
            client,
            pool,
            cache,
            gate: Gate::new(),
            shutdown,
            drain: CancellationToken::new(),
            hard_stop,
            worker_id: None,
            lease_attempts: config.backoff.attempts(u64::from(std::process::id())),
            summary: Summary::default(),
            config,
        })
    }

    /// Leases and renders tiles until `shutdown` fires (then returns `Ok`) or the coordinator
    /// refuses the worker token.
    pub async fn run(mut self) -> anyhow::Result<Summary> {
        tracing::info!(
            coordinator = %self.config.coordinator,
            name = %self.config.name,
            threads = self.config.threads,
            "worker starting"
        );
        while !self.shutdown.is_cancelled() && !self.drain.is_cancelled() {
            let Some(worker_id) = self.registered().await? else {
                break;
            };
            // A lease is asked for only when a thread may work on it.
            let slot = tokio::select! {
                _ = self.shutdown.cancelled() => break,
                slot = self.gate.slot() => slot,
            };
            let wait = self.config.lease_wait;
            let result = tokio::select! {
                _ = self.shutdown.cancelled() => break,
                r = self.client.lease(worker_id, wait) => r,
            };
            match result {
                Ok(Some(lease)) => {
                    self.lease_attempts.reset();
                    self.work(worker_id, lease, &slot).await?;
                }
                Ok(None) => self.lease_attempts.reset(),
                Err(e) => self.lease_failed(e).await?,
            }
        }
        self.summary.scenes_built = self.cache.builds();
        self.summary.drained = self.drain.is_cancelled();
        if self.summary.drained {
            tracing::info!("drained: the coordinator asked this worker to leave");
        }
        tracing::info!(summary = ?self.summary, "worker stopped");
        Ok(self.summary)
    }

    /// The worker id, registering first if needed; `None` if shutdown came first.
    async fn registered(&mut self) -> anyhow::Result<Option<u64>> {
        if let Some(id) = self.worker_id {
            return Ok(Some(id));
        }
        let body = RegisterWorker {
            name: self.config.name.clone(),
            threads: u32::try_from(self.config.threads).unwrap_or(u32::MAX),
            version: self.config.version.clone(),
            labels: self.config.labels.clone(),
        };
        let salt = u64::from(std::process::id());
        match retry(
            self.config.backoff,
            salt,
            &self.shutdown,
            "registering",
            || self.client.register(&body),
        )
        .await
        {
            Ok(reply) => {
                tracing::info!(
                    worker_id = reply.worker_id,
                    "registered with the coordinator"
                );
                self.worker_id = Some(reply.worker_id);
                self.summary.registrations += 1;
                Ok(Some(reply.worker_id))
            }
            Err(RetryEnd::Stopped) => Ok(None),
            Err(RetryEnd::Failed(e)) => Err(fatal(e, "registering with the coordinator")),
        }
    }

    /// Handles a failed lease request: re-register, back off, or give up.
    async fn lease_failed(&mut self, e: ClientError) -> anyhow::Result<()> {
        match e.kind() {
            ErrorKind::NotFound => {
                tracing::warn!(error = %e, "the coordinator does not know this worker; registering again");
                self.worker_id = None;
                Ok(())
            }
            ErrorKind::Unauthorized => Err(fatal(e, "asking for a lease")),
            ErrorKind::Draining => {
                tracing::info!(error = %e, "draining: no more tiles");
                self.drain.cancel();
                Ok(())
            }
            ErrorKind::Transient | ErrorKind::Conflict | ErrorKind::Rejected => {
                // Lease requests carry no data that could be wrong, so anything else is treated
                // as the coordinator being unwell.
                let delay = self.lease_attempts.next_delay();
                tracing::warn!(error = %e, ?delay, "asking for a lease failed; retrying");
                tokio::select! {
                    _ = self.shutdown.cancelled() => {}
                    _ = tokio::time::sleep(delay) => {}
                }
                Ok(())
            }
        }
    }

    /// Renders and delivers one leased tile, with heartbeats running throughout.
    async fn work(&mut self, worker_id: u64, lease: Lease, slot: &Slot) -> anyhow::Result<()> {
        let held = LeaseRef::from(&lease);
        let LeaseRef { job, tile, epoch } = held;
        tracing::debug!(job, tile, epoch, "leased");
        // `stop` fires when the lease is lost or at the hard deadline.
        let stop = self.hard_stop.child_token();
        let heartbeats = tokio::spawn(heartbeat_loop(
            self.client.clone(),
            worker_id,
            held,
            Duration::from_millis(lease.ttl_ms),
            stop.clone(),
            self.drain.clone(),
        ));
        let outcome = match self.render(job, &lease, slot, &stop).await {
            Ok(Rendered::Pixels(tile)) => match self.deliver(worker_id, held, *tile, &stop).await {
                Some(reason) => {
                    self.report_failure(worker_id, held, reason, false, &stop)
                        .await
                }
                None => Ok(()),
            },
            Ok(Rendered::Failed {
                reason,
                deterministic,
            }) => {
                self.report_failure(worker_id, held, reason, deterministic, &stop)
                    .await
            }
            Ok(Rendered::Abandoned) => {
                self.summary.abandoned += 1;
                tracing::info!(job, tile, epoch, "tile abandoned");
                Ok(())
            }
            Err(e) => Err(e),
        };
        heartbeats.abort();
        outcome
    }

    /// Uploads a rendered tile; returns the reason to report it as failed if the coordinator
    /// refused it as invalid.
    async fn deliver(
        &mut self,
        worker_id: u64,
        held: LeaseRef,
        rendered: RenderedTile,
        stop: &CancellationToken,
    ) -> Option<String> {
        let LeaseRef { job, tile, epoch } = held;
        let delivery = deliver(
            &self.client,
            self.config.backoff,
            stop,
            worker_id,
            held,
            rendered,
        )
        .await;
        tracing::info!(job, tile, epoch, outcome = ?delivery, "tile delivered");
        match delivery {
            Delivery::Acknowledged(TileOutcome::Accepted) => self.summary.accepted += 1,
            Delivery::Acknowledged(TileOutcome::Duplicate) => self.summary.duplicates += 1,
            Delivery::Refused(_) | Delivery::Abandoned => self.summary.abandoned += 1,
            Delivery::Invalid(reason) => {
                return Some(format!(
                    "the coordinator refused the rendered tile: {reason}"
                ));
            }
        }
        None
    }

    /// Reports a tile as failed, retrying until the coordinator answers.
    async fn report_failure(
        &mut self,
        worker_id: u64,
        held: LeaseRef,
        reason: String,
        deterministic: bool,
        stop: &CancellationToken,
    ) -> anyhow::Result<()> {
        let LeaseRef { job, tile, epoch } = held;
        self.summary.failed += 1;
        tracing::warn!(job, tile, %reason, deterministic, "tile failed");
        let body = TileFailure {
            worker_id,
            epoch,
            reason,
            deterministic,
        };
        match retry(
            self.config.backoff,
            worker_id,
            stop,
            "reporting a failed tile",
            || self.client.fail(job, tile, &body),
        )
        .await
        {
            Err(RetryEnd::Failed(e)) if e.kind() == ErrorKind::Unauthorized => {
                Err(fatal(e, "reporting a failed tile"))
            }
            _ => Ok(()),
        }
    }

    /// Loads the job's scene (cached) and renders the tile on the render pool, from a thread
    /// holding `slot`, within the tile time limit: in one pass, or the lease's progressive
    /// pass, continuing from the previous pass's result, fetched from the coordinator.
    async fn render(
        &mut self,
        job_id: u64,
        lease: &Lease,
        slot: &Slot,
        stop: &CancellationToken,
    ) -> anyhow::Result<Rendered> {
        let rect = lease.rect;
        let scene = match self.cache.get(job_id, slot, stop).await {
            Ok(scene) => scene,
            Err(LoadError::Broken(reason) | LoadError::OverLimit(reason)) => {
                return Ok(Rendered::Failed {
                    reason,
                    deterministic: false,
                });
            }
            Err(LoadError::Unbuildable(reason)) => {
                return Ok(Rendered::Failed {
                    reason,
                    deterministic: true,
                });
            }
            Err(LoadError::Gone | LoadError::Interrupted) => return Ok(Rendered::Abandoned),
            Err(LoadError::Unauthorized(e)) => return Err(fatal(e, "loading a job")),
        };
        let film = scene.scene.film();
        if rect.width == 0
            || rect.height == 0
            || u64::from(rect.x) + u64::from(rect.width) > u64::from(film.width)
            || u64::from(rect.y) + u64::from(rect.height) > u64::from(film.height)
        {
            return Ok(Rendered::Failed {
                reason: format!(
                    "the leased tile of {rect} is not inside the {} × {} film",
                    film.width, film.height
                ),
                deterministic: false,
            });
        }
        let previous = match lease.pass {
            Some(pass) if pass > 1 => match self.previous_pass(lease, stop).await? {
                Ok(previous) => Some(previous),
                Err(outcome) => return Ok(outcome),
            },
            _ => None,
        };
        let pool = self.pool.clone();
        let built = scene.clone();
        let pass = lease.pass;
        let render = move |interrupt: &detached::Interrupt| {
            let started = std::time::Instant::now();
            let pixels = pool
                .install(|| bands::render(&built.scene, rect, pass, previous.as_ref(), interrupt));
            (pixels, started.elapsed().as_secs_f64())
        };
        let limit = self.config.tile_time_limit;
        let (pixels, seconds) = match detached::run(slot, "tile-render", limit, stop, render).await
        {
            Ended::Done((Some(Ok(pixels)), seconds)) => (pixels, seconds),
            Ended::Done((Some(Err(e)), _)) => {
                return Ok(Rendered::Failed {
                    reason: format!("pass {}: {e}", pass.unwrap_or(1)),
                    deterministic: false,
                });
            }
            Ended::Broke(how) => {
                return Ok(Rendered::Failed {
                    reason: format!("the renderer {how}"),
                    deterministic: false,
                });
            }
            Ended::OverLimit => {
                return Ok(Rendered::Failed {
                    reason: format!(
                        "rendering the tile took longer than this worker's limit of {} s \
                         (--tile-time-limit-s) and was given up",
                        limit.as_secs_f64()
                    ),
                    deterministic: false,
                });
            }
            // Interrupted: the lease was lost (or the deadline passed) while rendering.
            Ended::Done((None, _)) | Ended::Stopped => return Ok(Rendered::Abandoned),
        };
        if let Some(problem) = first_non_finite(&pixels) {
            // A pixel depends only on the scene: every worker would render the same overflow.
            return Ok(Rendered::Failed {
                reason: problem,
                deterministic: true,
            });
        }
        if stop.is_cancelled() {
            // The lease was lost (or the deadline passed) while rendering.
            return Ok(Rendered::Abandoned);
        }
        Ok(Rendered::Pixels(Box::new(RenderedTile {
            pixels,
            seconds,
            provenance: scene.provenance.clone(),
        })))
    }
}

impl Worker {
    /// Fetches the previous pass's result of the leased tile, retrying transient failures;
    /// `Err` is what the lease comes to when it cannot be had (reported as failed with the
    /// coordinator's reason).
    async fn previous_pass(
        &self,
        lease: &Lease,
        stop: &CancellationToken,
    ) -> anyhow::Result<Result<TilePixels, Rendered>> {
        let (job, tile) = (lease.job_id, lease.tile_index);
        let salt = self.worker_id.unwrap_or_default();
        let fetched = retry(
            self.config.backoff,
            salt,
            stop,
            "fetching the previous pass",
            || self.client.previous_pass(job, tile),
        )
        .await;
        Ok(match fetched {
            Ok(previous) => Ok(previous),
            Err(RetryEnd::Stopped) => Err(Rendered::Abandoned),
            Err(RetryEnd::Failed(e)) => match e.kind() {
                ErrorKind::Unauthorized => return Err(fatal(e, "fetching the previous pass")),
                // Lost (the failure report is then refused as stale, harmlessly) or damaged:
                // the failure rules decide.
                _ => Err(Rendered::Failed {
                    reason: format!("fetching the previous pass of tile {tile}: {e}"),
                    deterministic: false,
                }),
            },
        })
    }
}

/// Renews the lease every third of its TTL until `stop` fires; cancels `stop` when the
/// coordinator says the lease is no longer this worker's, and `drain` when it says the worker
/// is draining (the tile in hand is still finished).
async fn heartbeat_loop(
    client: Client,
    worker_id: u64,
    lease: LeaseRef,
    ttl: Duration,
    stop: CancellationToken,
    drain: CancellationToken,
) {
    let LeaseRef { job, tile, epoch } = lease;
    let body = Heartbeat { worker_id, epoch };
    let mut interval = (ttl / 3).clamp(HEARTBEAT_MIN, HEARTBEAT_MAX);
    loop {
        tokio::select! {
            _ = stop.cancelled() => return,
            _ = tokio::time::sleep(interval) => {}
        }
        let result = tokio::select! {
            _ = stop.cancelled() => return,
            r = client.heartbeat(job, tile, &body) => r,
        };
        match result {
            Ok(ack) => {
                if ack.drain && !drain.is_cancelled() {
                    tracing::info!(job, tile, "draining: finishing this tile, then exiting");
                    drain.cancel();
                }
                interval =
                    (Duration::from_millis(ack.ttl_ms) / 3).clamp(HEARTBEAT_MIN, HEARTBEAT_MAX)
            }
            Err(e) if matches!(e.kind(), ErrorKind::Conflict | ErrorKind::NotFound) => {
                tracing::info!(job, tile, epoch, error = %e, "lease lost");
                stop.cancel();
                return;
            }
            // Keep the render going: if the coordinator comes back within its grace period the
            // lease is still good, and if not the upload will be refused.
            Err(e) => tracing::warn!(job, tile, error = %e, "heartbeat failed"),
        }
    }
}

/// Names the first pixel value that is not a finite f32 (the image formats and the tile
/// protocol carry finite values only), if any.
fn first_non_finite(pixels: &TilePixels) -> Option<String> {
    let rect = pixels.rect;
    for (kind, layer) in spindle_common::tile::LAYERS.iter().zip(pixels.layers()) {
        if let Some(i) = layer.iter().position(|v| !v.is_finite()) {
            let name = kind.name;
            let (pixel, channel) = (i / kind.channels, i % kind.channels);
            let x = rect.x as usize + pixel % rect.width as usize;
            let y = rect.y as usize + pixel / rect.width as usize;
            return Some(format!(
                "pixel ({x}, {y}) of layer {name}, channel {channel}, is {}: the scene's \
                 radiance overflows 32-bit floats (check light intensities and radiances)",
                layer[i]
            ));
        }
    }
    if let Some(i) = pixels.aov.iter().position(|v| !v.is_finite()) {
        let per_pixel = pixels.aov_values_per_pixel().max(1);
        let pixel = i / per_pixel;
        let x = rect.x as usize + pixel % rect.width as usize;
        let y = rect.y as usize + pixel / rect.width as usize;
        return Some(format!(
            "pixel ({x}, {y}) of the optional passes (film.passes), value {}, is {}",
            i % per_pixel,
            pixels.aov[i]
        ));
    }
    None
}

/// An error that ends the worker, with what it was doing.
fn fatal(e: ClientError, doing: &str) -> anyhow::Error {
    match e.kind() {
        ErrorKind::Unauthorized => anyhow!(
            "{doing}: the coordinator refused the worker token ({e}); check SPINDLE_WORKER_TOKEN"
        ),
        _ => anyhow!("{doing}: {e}"),
    }
}
