//! `spindle render --workers N` (N ≥ 1): an embedded local farm. The coordinator runs in this
//! process on 127.0.0.1 with a temporary data directory and random tokens; N workers run in
//! this process too, as tasks of `spindle_worker::run`, each with its own rayon pool of
//! `--threads` threads (default cores/N). The scene goes through exactly the path a remote farm uses (assets by
//! hash, job submission, leases, tile uploads, assembly), so what works here works on many
//! machines.
//!
//! In-process workers rather than child processes: no binary to locate, nothing left running
//! if the command is interrupted, and one Ctrl-C stops everything.
//!
//! On SIGINT or SIGTERM ([`crate::interrupt`]) the finished tiles are read from the farm's own
//! database ([`so_far`], the coordinator's `assemble::frame` over its tile store) and handed
//! back ([`Outcome::Stopped`]); on SIGHUP the same image goes to the caller's `snapshot` and the
//! render goes on. The data directory is removed however the command ends.

use std::path::Path;
use std::time::Duration;

use anyhow::{Context, Result, anyhow};
use spindle_common::image::Image;
use spindle_common::protocol::{JobInfo, JobSpec};
use spindle_common::stats::RenderStats;
use spindle_worker as worker;
use tokio_util::sync::CancellationToken;

use crate::api::{Api, ImageFile};
use crate::interrupt::{Signals, Stop};
use crate::meter::Show;
use crate::progress::{Wait, require_done, wait_for};
use crate::secret::random_hex;

/// What the farm produced.
pub struct FarmResult {
    pub job: JobInfo,
    /// The coordinator's final EXR.
    pub exr: Vec<u8>,
    /// Tiles each worker delivered, in worker order.
    pub tiles_per_worker: Vec<u64>,
    /// Render threads of each worker.
    pub threads_per_worker: usize,
}

/// How a local render ended.
pub enum Outcome {
    /// Every tile in.
    Done(FarmResult),
    /// A signal stopped it: the tiles that were in.
    Stopped(Stop, SoFar),
}

/// A job's image as far as its tiles are in: the others transparent black (alpha 0).
pub struct SoFar {
    pub image: Image,
    /// The summed statistics of the tiles in.
    pub stats: RenderStats,
    pub tiles_done: usize,
    pub tiles_total: usize,
}

/// The farm to start.
#[derive(Debug, Clone, Copy)]
pub struct LocalFarm {
    /// Workers (at least 1).
    pub workers: usize,
    /// Render threads of each worker (`None`: the cores shared among the workers).
    pub threads: Option<usize>,
    /// Where the job's progress goes.
    pub show: Show,
}

/// The default number of workers: one per two cores, at least two.
pub fn default_workers() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    (cores / 2).max(2)
}

/// Starts the coordinator and the farm's workers, submits the job through `submit`, waits
/// showing its progress, downloads the final EXR, and stops everything. A SIGINT or SIGTERM
/// ends the wait with the tiles that are in; each SIGHUP hands them to `snapshot`.
pub async fn render<F, Fut>(
    farm: LocalFarm,
    signals: &Signals,
    snapshot: &mut dyn FnMut(SoFar),
    submit: F,
) -> Result<Outcome>
where
    F: FnOnce(Api) -> Fut,
    Fut: Future<Output = Result<JobInfo>>,
{
    let wait = Wait {
        show: farm.show,
        local: true,
        ..Wait::default()
    };
    let data = tempfile::Builder::new()
        .prefix("spindle-farm-")
        .tempdir()
        .context("creating the local farm's data directory")?;
    signals.remove_on_quit(Some(data.path().to_path_buf()));
    let outcome = render_waiting(farm, wait, data.path(), Some((signals, snapshot)), submit).await;
    signals.remove_on_quit(None);
    // Whichever way it ended: the coordinator has stopped or been given up on.
    data.close()
        .context("removing the local farm's data directory")?;
    outcome
}

/// [`render`] in the data directory `data`, waiting for the job as `wait` says.
async fn render_waiting<F, Fut>(
    farm: LocalFarm,
    wait: Wait,
    data: &Path,
    signals: Option<(&Signals, &mut dyn FnMut(SoFar))>,
    submit: F,
) -> Result<Outcome>
where
    F: FnOnce(Api) -> Fut,
    Fut: Future<Output = Result<JobInfo>>,
{
    let client_token = random_hex()?;
    let worker_token = random_hex()?;
    let mut config = spindle_server::Config::new(data);
    config.client_token = Some(client_token.clone());
    config.worker_token = Some(worker_token.clone());
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
        .await
        .context("binding the local coordinator to 127.0.0.1")?;
    let base = format!("http://{}", listener.local_addr()?);
    let shutdown = CancellationToken::new();
    // Stops everything when this function returns, whichever way.
    let _stop_all = shutdown.clone().drop_guard();
    let mut server = tokio::spawn(spindle_server::run(
        config,
        listener,
        shutdown.clone().cancelled_owned(),
    ));

    let workers = farm.workers;
    let threads = farm.threads.unwrap_or_else(|| {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        (cores / workers).max(1)
    });
    let mut tasks = Vec::with_capacity(workers);
    for i in 0..workers {
        let config = worker::Config::new(
            &base,
            Some(worker_token.clone()),
            Some(format!("local-{i}")),
            Some(threads),
        )?;
        tasks.push(tokio::spawn(worker::run(config, shutdown.clone())));
    }

    let api = Api::new(&base, Some(client_token))?;
    let job = submit(api.clone()).await?;
    let info = match signals {
        None => wait_for(&api, job.id, wait).await?,
        Some((signals, snapshot)) => {
            let waiting = wait_for(&api, job.id, wait);
            tokio::pin!(waiting);
            let mut asked = signals.watch();
            let mut hangups = asked.borrow_and_update().hangups;
            loop {
                if let Some(stop) = asked.borrow().stop {
                    let so_far = so_far(data, job.id).await?;
                    shutdown.cancel();
                    // The coordinator closes its database before the directory goes; the
                    // workers' tiles in progress are abandoned.
                    let _ = tokio::time::timeout(Duration::from_secs(10), &mut server).await;
                    return Ok(Outcome::Stopped(stop, so_far));
                }
                tokio::select! {
                    info = &mut waiting => break info?,
                    _ = asked.changed() => {
                        let now = *asked.borrow_and_update();
                        if now.stop.is_none() && now.hangups > hangups {
                            hangups = now.hangups;
                            snapshot(so_far(data, job.id).await?);
                        }
                    }
                }
            }
        }
    };
    require_done(&info)?;
    let exr = api.image(job.id, ImageFile::Exr).await?;

    shutdown.cancel();
    let mut tiles_per_worker = Vec::with_capacity(workers);
    for task in tasks {
        let summary = tokio::time::timeout(Duration::from_secs(60), task)
            .await
            .map_err(|_| anyhow!("a local worker did not stop"))?
            .context("a local worker panicked")??;
        tiles_per_worker.push(summary.accepted);
    }
    tokio::time::timeout(Duration::from_secs(60), server)
        .await
        .map_err(|_| anyhow!("the local coordinator did not stop"))?
        .context("the local coordinator panicked")??;
    Ok(Outcome::Done(FarmResult {
        job: info,
        exr,
        tiles_per_worker,
        threads_per_worker: threads,
    }))
}

/// The image of job `job`'s tiles that are in, read from the farm's database in `data` (a
/// reader beside the running coordinator's ledger, or after it stopped).
async fn so_far(data: &Path, job: u64) -> Result<SoFar> {
    let data = data.to_path_buf();
    tokio::task::spawn_blocking(move || {
        use spindle_server::{assemble, db, tile_store::TileStore};
        let database = data.join("spindle.db");
        let conn = db::open(&database).context("opening the local farm's database")?;
        let row = db::load_jobs(&conn)?
            .into_iter()
            .find(|r| r.id == job)
            .ok_or_else(|| anyhow!("the local farm has no job {job}"))?;
        let spec: JobSpec = serde_json::from_str(&row.spec_json).context("the job's spec")?;
        let tiles = db::done_tiles(&conn, job)?;
        let (_, stats) = db::tile_totals(&conn, job)?;
        let limits = spindle_server::Limits::default();
        let store = TileStore::open(data.join("jobs"), &database, limits.max_tile_upload_bytes)?;
        let (image, damaged) = assemble::frame(&store, job, &spec, &tiles)?;
        Ok(SoFar {
            image,
            stats,
            tiles_done: tiles.len() - damaged.len(),
            tiles_total: spec.tiles().len(),
        })
    })
    .await
    .context("reading the tiles that are in")?
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Without the event stream this wait would poll once an hour and never see the job end:
    /// it ends within the test's minute only because the job's end arrives as an event.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn the_wait_follows_the_event_stream_not_polls() {
        let scene =
            std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/tiny.json"));
        let hour = Duration::from_secs(3600);
        let wait = Wait {
            poll: hour,
            quiet: hour,
            unreachable_for: hour,
            show: Show::Nothing,
            local: true,
        };
        let farm = LocalFarm {
            workers: 1,
            threads: None,
            show: Show::Nothing,
        };
        let data = tempfile::tempdir().unwrap();
        let outcome = tokio::time::timeout(
            Duration::from_secs(60),
            render_waiting(farm, wait, data.path(), None, |api| async move {
                crate::submit::submit_scene_file(
                    &api,
                    scene,
                    None,
                    None,
                    crate::submit::Check::AlreadyBuilt,
                    &crate::submit::JobOptions {
                        tile_size: 16,
                        ..Default::default()
                    },
                )
                .await
            }),
        )
        .await
        .expect("the job's end was not seen within a minute")
        .unwrap();
        let Outcome::Done(result) = outcome else {
            panic!("stopped without a signal")
        };
        assert_eq!(result.job.tiles_done, result.job.tiles_total);
        assert!(result.job.tiles_total > 1);
    }
}
