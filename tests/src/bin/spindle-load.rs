//! `spindle-load`: how hard one coordinator can be driven. It starts the real `spindle-server`
//! on loopback, keeps it fed with jobs of 8-px tiles (`--tile`; the cheapest scene: single
//! scattering off, unless `--scatter-spp`),
//! and runs N simulated workers in this process — each with its own connection, doing
//! register, then lease → upload round trips as fast as the coordinator answers, uploading
//! ready-made tiles (rendered once here beforehand, so the workers cost no rendering) — while a
//! client polls a job's status. It prints tile round trips per second, the status latency's
//! p50 and p99, the mean upload body and the coordinator's CPU time per tile (user + system,
//! from `/proc`) over the measured window. `--tiles json` uploads JSON bodies instead of the
//! compact form `spindle-worker` sends, to compare the two.
//!
//! A benchmark that prints figures, not a test: nothing here is asserted about speed. Every
//! upload must still be accepted (a refused one is counted and reported).
//!
//! ```text
//! cargo build --release -p spindle-server -p spindle-tests --bin spindle-server --bin spindle-load
//! target/release/spindle-load --workers 8 --seconds 10
//! ```

use std::collections::HashMap;
use std::path::PathBuf;
use std::process::Command;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use clap::Parser;
use spindle_common::protocol::{
    JobInfo, Lease, LeaseRequest, RegisterWorker, SubmitJob, TileAck, TileOutcome, TileUpload,
    WORKER_SECRET_HEADER, WorkerRegistered, asset_hash, pixel_hash,
};
use spindle_common::tile::{TilePixels, split_centre_first};
use spindle_common::tile_encoding;
use spindle_render::{Scene, render_tile};
use spindle_tests::{Proc, free_port, http_builder, test_scene};

/// Drives a coordinator with simulated workers and prints what it sustains.
#[derive(Debug, Parser)]
#[command(name = "spindle-load")]
struct Args {
    /// Simulated workers, each doing lease → upload round trips back to back.
    #[arg(long, default_value_t = 8)]
    workers: usize,
    /// The measured window, after a one-second warm-up.
    #[arg(long, default_value_t = 10.0)]
    seconds: f64,
    /// The job's film edge in pixels (tiles are 8 px: (edge / 8)² tiles a job).
    #[arg(long, default_value_t = 512)]
    size: u32,
    /// How often the client asks for a job's status, in milliseconds.
    #[arg(long, default_value_t = 10)]
    poll_ms: u64,
    /// The `spindle-server` binary (default: the one beside this program).
    #[arg(long)]
    server_bin: Option<PathBuf>,
    /// Tile edge in pixels.
    #[arg(long, default_value_t = 8)]
    tile: u32,
    /// Samples per pixel of the ready-made tiles, with single scattering on (realistic layers
    /// and upload sizes; the ready-made tiles take longer to render first). Default: 1 sample,
    /// single scattering off.
    #[arg(long)]
    scatter_spp: Option<u32>,
    /// How tiles are uploaded: `compact` (what spindle-worker sends) or `json`.
    #[arg(long, value_enum, default_value_t = TileBody::Compact)]
    tiles: TileBody,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum TileBody {
    Compact,
    Json,
}

const CLIENT_TOKEN: &str = "load-client-token";
const WORKER_TOKEN: &str = "load-worker-token";

fn main() -> Result<()> {
    let args = Args::parse();
    let server_bin = match &args.server_bin {
        Some(path) => path.clone(),
        None => std::env::current_exe()?
            .parent()
            .context("this program's directory")?
            .join("spindle-server"),
    };
    if !server_bin.is_file() {
        bail!(
            "{} is missing: build spindle-server (or pass --server-bin)",
            server_bin.display()
        );
    }
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?
        .block_on(run(args, server_bin))
}

/// Ready-made tile results by rectangle origin, and the job to submit for them.
struct Workload {
    submit: SubmitJob,
    assets: Vec<(String, Vec<u8>)>,
    tiles: HashMap<(u32, u32), TilePixels>,
}

fn workload(size: u32, tile: u32, scatter_spp: Option<u32>) -> Result<Workload> {
    let (mut scene, assets) = test_scene(size, size, scatter_spp.unwrap_or(1));
    let method = if scatter_spp.is_some() {
        "auto"
    } else {
        "none"
    };
    scene["integrator"]["single_scatter"]["method"] = serde_json::json!(method);
    let desc = serde_json::from_value(scene.clone())?;
    let built = Scene::build(&desc, &assets).map_err(|e| anyhow!("the load scene: {e}"))?;
    let tiles = split_centre_first(size, size, tile)
        .into_iter()
        .map(|rect| ((rect.x, rect.y), render_tile(&built, rect)))
        .collect();
    let table = assets
        .iter()
        .map(|(path, bytes)| (path.clone(), asset_hash(bytes)))
        .collect();
    Ok(Workload {
        submit: SubmitJob {
            scene: desc,
            assets: table,
            tile_size: tile,
            priority: 0,
            requires: Default::default(),
            name: Some("load".into()),
            submitter: None,
            crop: None,
            frame: None,
        },
        assets: assets.into_iter().collect(),
        tiles,
    })
}

/// What the simulated workers and the status poller share.
struct Shared {
    http_base: String,
    workload: Workload,
    /// Counting: set after the warm-up, cleared at the end of the window.
    measuring: AtomicBool,
    stop: AtomicBool,
    round_trips: AtomicU64,
    refused: AtomicU64,
    /// Upload body bytes of the counted round trips.
    upload_bytes: AtomicU64,
    tiles: TileBody,
    /// The newest job, for the status poller.
    latest_job: AtomicU64,
}

async fn run(args: Args, server_bin: PathBuf) -> Result<()> {
    eprintln!("rendering the ready-made tiles…");
    let workload = workload(args.size, args.tile, args.scatter_spp)?;
    let dir = tempfile::tempdir()?;
    let port = free_port();
    let mut cmd = Command::new(&server_bin);
    cmd.arg("--listen")
        .arg(format!("127.0.0.1:{port}"))
        .arg("--data")
        .arg(dir.path().join("data"))
        // The poller must not be throttled: it measures latency, not the rate limit.
        .arg("--client-rate-per-s")
        .arg("100000");
    let env = [
        ("SPINDLE_TOKEN", CLIENT_TOKEN),
        ("SPINDLE_WORKER_TOKEN", WORKER_TOKEN),
        ("RUST_LOG", "warn"),
    ];
    let server = Proc::spawn(cmd, &env, dir.path(), "server")?;
    let shared = Arc::new(Shared {
        http_base: format!("http://127.0.0.1:{port}"),
        workload,
        measuring: AtomicBool::new(false),
        stop: AtomicBool::new(false),
        round_trips: AtomicU64::new(0),
        refused: AtomicU64::new(0),
        upload_bytes: AtomicU64::new(0),
        tiles: args.tiles,
        latest_job: AtomicU64::new(0),
    });
    let client = new_client()?;
    wait_ready(&client, &shared.http_base, &server).await?;
    upload_assets(&client, &shared).await?;
    // Two jobs queued at all times, so workers never wait for work.
    let mut jobs = vec![
        submit(&client, &shared).await?,
        submit(&client, &shared).await?,
    ];

    let mut tasks = Vec::new();
    for i in 0..args.workers {
        let shared = shared.clone();
        tasks.push(tokio::spawn(async move { worker(shared, i).await }));
    }
    let poller = {
        let shared = shared.clone();
        let period = Duration::from_millis(args.poll_ms);
        tokio::spawn(async move { poll_status(shared, period).await })
    };

    let warm_up_end = Instant::now() + Duration::from_secs(1);
    let end = warm_up_end + Duration::from_secs_f64(args.seconds);
    let mut started = None;
    let mut cpu_at_start = None;
    while Instant::now() < end {
        if started.is_none() && Instant::now() >= warm_up_end {
            shared.measuring.store(true, Ordering::SeqCst);
            started = Some(Instant::now());
            cpu_at_start = cpu_seconds(server.pid());
        }
        // Keep two unfinished jobs.
        let mut unfinished = Vec::new();
        for id in jobs {
            if !job(&client, &shared.http_base, id)
                .await?
                .state
                .is_finished()
            {
                unfinished.push(id);
            }
        }
        while unfinished.len() < 2 {
            unfinished.push(submit(&client, &shared).await?);
        }
        jobs = unfinished;
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    shared.measuring.store(false, Ordering::SeqCst);
    let window = started.map_or(0.0, |s| s.elapsed().as_secs_f64());
    let server_cpu = cpu_at_start
        .zip(cpu_seconds(server.pid()))
        .map(|(a, b)| b - a);
    shared.stop.store(true, Ordering::SeqCst);
    for task in tasks {
        task.await??;
    }
    let mut latencies = poller.await??;
    drop(server);

    let round_trips = shared.round_trips.load(Ordering::SeqCst);
    latencies.sort_by(f64::total_cmp);
    let quantile = |q: f64| {
        latencies
            .get(((latencies.len() as f64 - 1.0) * q).round() as usize)
            .copied()
            .unwrap_or(f64::NAN)
    };
    let per_tile = |total: f64| total / round_trips.max(1) as f64;
    let cpu = server_cpu.map_or("n/a".to_string(), |c| {
        format!("{:.0} µs", per_tile(c) * 1e6)
    });
    println!(
        "workers {}  tiles {:?}  window {window:.1} s  tile round trips {round_trips}  \
         {:.0} tiles/s  status p50 {:.2} ms  p99 {:.2} ms  ({} polls)  refused {}  \
         upload {:.0} bytes/tile  coordinator CPU {cpu}/tile",
        args.workers,
        args.tiles,
        round_trips as f64 / window,
        quantile(0.5),
        quantile(0.99),
        latencies.len(),
        shared.refused.load(Ordering::SeqCst),
        per_tile(shared.upload_bytes.load(Ordering::SeqCst) as f64),
    );
    Ok(())
}

/// User + system CPU seconds of process `pid` so far (`/proc/<pid>/stat`, fields 14 and 15, in
/// clock ticks of 1/100 s on Linux); `None` where that cannot be read.
fn cpu_seconds(pid: u32) -> Option<f64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // The command name (field 2) is in parentheses and may hold spaces: count after it.
    let after_name = &stat[stat.rfind(')')? + 1..];
    let fields: Vec<&str> = after_name.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i)?.parse::<f64>().ok();
    // After the name: state is field 3, so field n is at index n - 3.
    Some((ticks(14 - 3)? + ticks(15 - 3)?) / 100.0)
}

fn new_client() -> Result<reqwest::Client> {
    Ok(http_builder()
        .no_proxy()
        .timeout(Duration::from_secs(30))
        .build()?)
}

async fn wait_ready(client: &reqwest::Client, base: &str, server: &Proc) -> Result<()> {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let ready = client.get(format!("{base}/readyz")).send().await;
        if matches!(&ready, Ok(r) if r.status().is_success()) {
            return Ok(());
        }
        if Instant::now() > deadline {
            bail!("spindle-server not ready after 30 s:\n{}", server.log());
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

async fn upload_assets(client: &reqwest::Client, shared: &Shared) -> Result<()> {
    for (_, bytes) in &shared.workload.assets {
        let resp = client
            .put(format!(
                "{}/v1/assets/{}",
                shared.http_base,
                asset_hash(bytes)
            ))
            .bearer_auth(CLIENT_TOKEN)
            .body(bytes.clone())
            .send()
            .await?;
        if !resp.status().is_success() {
            bail!("asset upload: {}", resp.status());
        }
    }
    Ok(())
}

async fn submit(client: &reqwest::Client, shared: &Shared) -> Result<u64> {
    let resp = client
        .post(format!("{}/v1/jobs", shared.http_base))
        .bearer_auth(CLIENT_TOKEN)
        .json(&shared.workload.submit)
        .send()
        .await?;
    let status = resp.status();
    if !status.is_success() {
        bail!("submit: {status} {}", resp.text().await?);
    }
    let info: JobInfo = resp.json().await?;
    shared.latest_job.store(info.id, Ordering::SeqCst);
    Ok(info.id)
}

async fn job(client: &reqwest::Client, base: &str, id: u64) -> Result<JobInfo> {
    let resp = client
        .get(format!("{base}/v1/jobs/{id}"))
        .bearer_auth(CLIENT_TOKEN)
        .send()
        .await?;
    if !resp.status().is_success() {
        bail!("job {id}: {}", resp.status());
    }
    Ok(resp.json().await?)
}

/// One simulated worker: its own connection, lease → upload until told to stop.
async fn worker(shared: Arc<Shared>, i: usize) -> Result<()> {
    let client = new_client()?;
    let base = &shared.http_base;
    let registered: WorkerRegistered = client
        .post(format!("{base}/v1/workers"))
        .bearer_auth(WORKER_TOKEN)
        .json(&RegisterWorker {
            name: format!("load-{i}"),
            threads: 1,
            version: env!("CARGO_PKG_VERSION").into(),
            labels: Default::default(),
        })
        .send()
        .await?
        .error_for_status()?
        .json()
        .await?;
    let id = registered.worker_id;
    let secret = registered.worker_secret;
    while !shared.stop.load(Ordering::SeqCst) {
        let resp = client
            .post(format!("{base}/v1/workers/{id}/lease"))
            .bearer_auth(WORKER_TOKEN)
            .header(WORKER_SECRET_HEADER, &secret)
            .json(&LeaseRequest { wait_ms: Some(200) })
            .send()
            .await?;
        if resp.status() == reqwest::StatusCode::NO_CONTENT {
            continue;
        }
        let lease: Lease = resp.error_for_status()?.json().await?;
        let pixels = shared
            .workload
            .tiles
            .get(&(lease.rect.x, lease.rect.y))
            .context("a lease for a tile this load never made")?
            .clone();
        let upload = TileUpload {
            worker_id: id,
            epoch: lease.epoch,
            hash: pixel_hash(&pixels),
            pixels,
            render_seconds: None,
            provenance: None,
        };
        let (content_type, body) = match shared.tiles {
            TileBody::Compact => (tile_encoding::CONTENT_TYPE, tile_encoding::encode(&upload)?),
            TileBody::Json => ("application/json", serde_json::to_vec(&upload)?),
        };
        let bytes = body.len() as u64;
        let resp = client
            .put(format!(
                "{base}/v1/jobs/{}/tiles/{}",
                lease.job_id, lease.tile_index
            ))
            .bearer_auth(WORKER_TOKEN)
            .header(WORKER_SECRET_HEADER, &secret)
            .header(reqwest::header::CONTENT_TYPE, content_type)
            .body(body)
            .send()
            .await?;
        let accepted = resp.status().is_success()
            && resp.json::<TileAck>().await?.outcome == TileOutcome::Accepted;
        if shared.measuring.load(Ordering::SeqCst) {
            let counter = if accepted {
                shared.upload_bytes.fetch_add(bytes, Ordering::SeqCst);
                &shared.round_trips
            } else {
                &shared.refused
            };
            counter.fetch_add(1, Ordering::SeqCst);
        }
    }
    Ok(())
}

/// Asks for the newest job's status every `period`; the latencies (ms) measured in the window.
async fn poll_status(shared: Arc<Shared>, period: Duration) -> Result<Vec<f64>> {
    let client = new_client()?;
    let mut latencies = Vec::new();
    let mut tick = tokio::time::interval(period);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    while !shared.stop.load(Ordering::SeqCst) {
        tick.tick().await;
        let id = shared.latest_job.load(Ordering::SeqCst);
        let start = Instant::now();
        job(&client, &shared.http_base, id).await?;
        if shared.measuring.load(Ordering::SeqCst) {
            latencies.push(start.elapsed().as_secs_f64() * 1e3);
        }
    }
    Ok(latencies)
}
