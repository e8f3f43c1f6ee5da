//! The spindle coordinator: jobs, content-addressed assets, tiles leased to workers, and the
//! final image assembled from their results.
//!
//! [`app`] builds the router for a [`AppState`] (tests drive it with `tower::ServiceExt`);
//! [`run`] serves it on a listener until a shutdown future resolves. The `spindle-server`
//! binary and the `spindle render` local farm are thin shells over these two. The coordinator
//! never links the renderer: it moves tiles, it does not make them.
#![forbid(unsafe_code)]

pub mod admission;
pub mod api;
pub mod assemble;
pub mod assets;
pub mod auth;
pub mod checkpoint;
pub mod clock;
pub mod config;
pub mod dashboard;
pub mod db;
pub mod error;
pub mod events;
pub mod extract;
pub mod ledger;
pub mod limits;
pub mod logging;
pub mod metrics;
pub mod peers;
pub mod retention;
pub mod send_bound;
pub mod serve;
pub mod throttle;
pub mod tile_store;
pub mod tls;
pub mod worker_secret;

use std::future::Future;
use std::sync::{Arc, Mutex, MutexGuard};

use anyhow::Context;
use axum::Router;
use tokio::sync::Notify;
use tokio_util::sync::CancellationToken;

pub use config::{Args, Config, Retention, Timeouts};
pub use limits::Limits;

use assets::AssetStore;
use ledger::Ledger;
use tile_store::TileStore;

/// Everything a request handler can reach; cheap to clone.
#[derive(Clone)]
pub struct AppState {
    inner: Arc<Shared>,
}

struct Shared {
    config: Config,
    ledger: Mutex<Ledger>,
    /// The ledger's event log, reachable without its lock.
    events: Arc<events::Events>,
    assets: AssetStore,
    tiles: TileStore,
    client_rate: throttle::ClientRate,
    /// Woken when tiles may have become available (a job submitted, a tile failed).
    work: Notify,
    /// Tile uploads being decoded at once: each holds up to its tile's bound in memory
    /// ([`spindle_common::protocol::TileUpload::max_packed_bytes`]), so their number is
    /// capped, at twice the cores (decoding is CPU work; more would only wait for a core).
    decodes: Arc<tokio::sync::Semaphore>,
    shutdown: CancellationToken,
}

impl AppState {
    /// Opens (or creates) the data directory and the database, resumes every job found there,
    /// and finishes any assembly a previous process did not. Needs a Tokio runtime.
    pub async fn open(config: Config) -> anyhow::Result<AppState> {
        // Counters count from the start, not from the first scrape.
        metrics::handle();
        let data = config.data_dir.clone();
        let max_upload = config.limits.max_tile_upload_bytes;
        let lease_ttl = config.lease_ttl;
        let grace = config.restart_grace;
        let (ledger, assets, tiles) = tokio::task::spawn_blocking(move || {
            std::fs::create_dir_all(&data)
                .with_context(|| format!("creating the data directory {}", data.display()))?;
            let database = data.join("spindle.db");
            db::set_aside_orphaned_log(&database)?;
            let damaged = |e| db::explain_damage(e, &database);
            let db = db::open(&database)
                .with_context(|| format!("opening {}", database.display()))
                .map_err(damaged)?;
            let ledger =
                Ledger::load(db, lease_ttl, grace, tokio::time::Instant::now()).map_err(damaged)?;
            let assets = AssetStore::open(data.join("assets"))?;
            let tiles =
                TileStore::open(data.join("jobs"), &database, max_upload).map_err(damaged)?;
            anyhow::Ok((ledger, assets, tiles))
        })
        .await??;
        let jobs = ledger.jobs.len();
        let events = ledger.events.clone();
        let client_rate = throttle::ClientRate::new(config.client_rate_per_s);
        let state = AppState {
            inner: Arc::new(Shared {
                config,
                ledger: Mutex::new(ledger),
                events,
                assets,
                tiles,
                client_rate,
                work: Notify::new(),
                decodes: Arc::new(tokio::sync::Semaphore::new(
                    2 * std::thread::available_parallelism().map_or(1, |n| n.get()),
                )),
                shutdown: CancellationToken::new(),
            }),
        };
        tracing::info!(jobs, data = %state.config().data_dir.display(), "coordinator state loaded");
        state.assemble_complete_jobs();
        state.spawn_loss_watch();
        retention::spawn(state.clone());
        checkpoint::spawn(state.clone(), &state.config().data_dir.join("spindle.db"))?;
        Ok(state)
    }

    /// Announces lost workers as they go quiet: checks every half lease TTL until shutdown.
    fn spawn_loss_watch(&self) {
        let state = self.clone();
        let period = (self.config().lease_ttl / 2).max(std::time::Duration::from_millis(20));
        tokio::spawn(async move {
            let mut tick = tokio::time::interval(period);
            loop {
                tokio::select! {
                    _ = tick.tick() => state.ledger().announce_lost(tokio::time::Instant::now()),
                    _ = state.shutdown_signal() => return,
                }
            }
        });
    }

    /// Per-tile entries the ledger holds in memory, over every job (finished jobs hold none).
    pub fn tiles_in_memory(&self) -> usize {
        self.ledger().tiles_in_memory()
    }

    pub(crate) fn events(&self) -> &events::Events {
        &self.inner.events
    }

    /// Cancelled when the coordinator begins to shut down.
    pub(crate) fn shutdown_token(&self) -> CancellationToken {
        self.inner.shutdown.clone()
    }

    /// The configuration the coordinator runs with.
    pub fn config(&self) -> &Config {
        &self.inner.config
    }

    /// The ledger of jobs, tiles and workers, locked. Never held across an `.await`.
    pub(crate) fn ledger(&self) -> MutexGuard<'_, Ledger> {
        // Every change is written to the database before memory, and nothing on the request
        // path panics; should a panic still poison the lock, the ledger is as consistent as the
        // last completed change, so carry on.
        self.inner.ledger.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Runs `f` on the locked ledger on a blocking thread, for ledger calls that write to
    /// SQLite: a commit, and a wait for the lock while another commit holds it, must not stall
    /// the async runtime's threads, which serve every other request meanwhile. The call runs to
    /// its end even if the request is dropped meanwhile, as a commit must, inside the caller's
    /// span.
    pub(crate) async fn with_ledger<T, F>(&self, f: F) -> Result<T, error::Error>
    where
        T: Send + 'static,
        F: FnOnce(&mut Ledger) -> Result<T, error::Error> + Send + 'static,
    {
        self.off_runtime(move |state| f(&mut state.ledger())).await
    }

    /// Runs `f` on a blocking thread (CPU work, or taking the ledger and committing), in the
    /// caller's tracing span.
    pub(crate) async fn off_runtime<T, F>(&self, f: F) -> Result<T, error::Error>
    where
        T: Send + 'static,
        F: FnOnce(&AppState) -> Result<T, error::Error> + Send + 'static,
    {
        let state = self.clone();
        // Lines the ledger logs go where the caller's go, in the request's span (its id).
        let span = tracing::Span::current();
        let dispatch = tracing::dispatcher::get_default(|d| d.clone());
        tokio::task::spawn_blocking(move || {
            tracing::dispatcher::with_default(&dispatch, || span.in_scope(|| f(&state)))
        })
        .await
        .map_err(anyhow::Error::from)?
    }

    pub(crate) fn assets(&self) -> &AssetStore {
        &self.inner.assets
    }

    pub(crate) fn client_rate(&self) -> &throttle::ClientRate {
        &self.inner.client_rate
    }

    pub(crate) fn tile_store(&self) -> &TileStore {
        &self.inner.tiles
    }

    /// A turn to decode a tile upload (see `Shared::decodes`); waits while all are taken.
    pub(crate) async fn decode_turn(&self) -> tokio::sync::OwnedSemaphorePermit {
        self.inner
            .decodes
            .clone()
            .acquire_owned()
            .await
            .expect("the decode semaphore is never closed")
    }

    pub(crate) fn work_available(&self) {
        self.inner.work.notify_waiters();
    }

    pub(crate) fn work_notified(&self) -> tokio::sync::futures::Notified<'_> {
        self.inner.work.notified()
    }

    /// Ends long polls and makes `/readyz` answer 503; the server then drains.
    pub fn begin_shutdown(&self) {
        self.inner.shutdown.cancel();
    }

    pub(crate) fn is_shutting_down(&self) -> bool {
        self.inner.shutdown.is_cancelled()
    }

    pub(crate) fn shutdown_signal(&self) -> tokio_util::sync::WaitForCancellationFuture<'_> {
        self.inner.shutdown.cancelled()
    }

    pub(crate) async fn remove_job_files(&self, id: u64) -> Result<(), error::Error> {
        let store = self.tile_store().clone();
        tokio::task::spawn_blocking(move || store.remove_job(id))
            .await
            .map_err(anyhow::Error::from)??;
        Ok(())
    }

    /// Starts writing the final image of every job whose tiles are all in.
    pub(crate) fn assemble_complete_jobs(&self) {
        let ids = self.ledger().take_jobs_to_assemble();
        for id in ids {
            let state = self.clone();
            tokio::spawn(async move { state.assemble(id).await });
        }
    }

    async fn assemble(&self, id: u64) {
        assemble::finish(self.clone(), id).await
    }
}

/// The coordinator's router.
pub fn app(state: AppState) -> Router {
    api::router(state)
}

/// Serves the coordinator on `listener` until `shutdown` resolves, then drains in-flight
/// requests (long polls end at once). Refuses a non-loopback listener without both tokens.
pub async fn run(
    config: Config,
    listener: tokio::net::TcpListener,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> anyhow::Result<()> {
    run_with_dashboard(config, listener, None, shutdown).await
}

/// [`run`], and with `dashboard`, also serves the web dashboard ([`dashboard`]) and the same
/// API on that listener, under the same rules (tokens, TLS, limits). Both stop together.
pub async fn run_with_dashboard(
    config: Config,
    listener: tokio::net::TcpListener,
    dashboard: Option<tokio::net::TcpListener>,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> anyhow::Result<()> {
    let addr = listener.local_addr()?;
    config.check_listen_address(addr)?;
    if let Some(dashboard) = &dashboard {
        config
            .check_listen_address(dashboard.local_addr()?)
            .context("--dashboard-listen")?;
    }
    let state = AppState::open(config).await?;
    let router = app(state.clone());
    tracing::info!(%addr, "spindle-server listening");
    let stop = CancellationToken::new();
    let draining = state.clone();
    let stopping = stop.clone();
    tokio::spawn(async move {
        shutdown.await;
        draining.begin_shutdown();
        stopping.cancel();
    });
    let api = serve::serve(
        state.config(),
        listener,
        router.clone(),
        stop.clone().cancelled_owned(),
    );
    let Some(dashboard) = dashboard else {
        return api.await;
    };
    tracing::info!(addr = %dashboard.local_addr()?, "dashboard listening");
    let pages = serve::serve(
        state.config(),
        dashboard,
        dashboard::router(router),
        stop.clone().cancelled_owned(),
    );
    // Either listener failing stops both.
    let result = tokio::try_join!(
        async {
            let r = api.await;
            stop.cancel();
            r
        },
        async {
            let r = pages.await;
            stop.cancel();
            r
        }
    );
    result.map(|_| ())
}
