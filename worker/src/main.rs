//! `spindle-worker`: a farm worker process. A thin shell over [`spindle_worker::run`]:
//! parse the settings, set up logging and signals, run until SIGTERM or Ctrl-C.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Parser;
use spindle_common::protocol::parse_label;
use spindle_worker::Config;
use tokio_util::sync::CancellationToken;

/// Renders tiles for a spindle coordinator.
#[derive(Debug, Parser)]
#[command(name = "spindle-worker", version, about)]
struct Args {
    /// The coordinator's URL, e.g. https://farm.example:7878 (or http:// on a private network).
    #[arg(long, env = "SPINDLE_COORDINATOR")]
    coordinator: String,
    /// Render threads (default: every core).
    #[arg(long, env = "SPINDLE_WORKER_THREADS")]
    threads: Option<usize>,
    /// The name this worker registers under (default: HOSTNAME-PID).
    #[arg(long, env = "SPINDLE_WORKER_NAME")]
    name: Option<String>,
    /// A `key=value` label jobs can require (`spindle submit --require pool=night`);
    /// repeatable, at most 16; keys and values of letters, digits, `_ - .`, 1 to 63 bytes.
    #[arg(long = "label", value_name = "KEY=VALUE", value_parser = parse_label)]
    labels: Vec<(String, String)>,
    /// PEM file of the CA certificates that signed the coordinator's certificate (a private
    /// CA); without it https trusts the system's roots.
    #[arg(long, env = "SPINDLE_CA_CERT")]
    ca_cert: Option<PathBuf>,
    /// The longest a job's scene may take to build, seconds: past it the build is given up,
    /// the tile reported as failed and the next lease taken.
    #[arg(long, env = "SPINDLE_BUILD_TIME_LIMIT_S", default_value_t = spindle_worker::config::DEFAULT_BUILD_TIME_LIMIT_S)]
    build_time_limit_s: f64,
    /// The longest one tile's render may take, seconds: past it the render is given up, the
    /// tile reported as failed and the next lease taken.
    #[arg(long, env = "SPINDLE_TILE_TIME_LIMIT_S", default_value_t = spindle_worker::config::DEFAULT_TILE_TIME_LIMIT_S)]
    tile_time_limit_s: f64,
    /// Read the worker token from this file instead of SPINDLE_WORKER_TOKEN.
    #[arg(long, env = "SPINDLE_WORKER_TOKEN_FILE")]
    token_file: Option<PathBuf>,
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .init();
    match real_main(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("spindle-worker: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn real_main(args: Args) -> anyhow::Result<()> {
    // The token is read from the environment or a file, never from the command line, where
    // every user of the machine could see it.
    let token = match &args.token_file {
        Some(path) => Some(
            std::fs::read_to_string(path)
                .with_context(|| format!("reading the worker token from {}", path.display()))?,
        ),
        None => std::env::var("SPINDLE_WORKER_TOKEN").ok(),
    };
    let mut config = Config::new(&args.coordinator, token, args.name, args.threads)?
        .with_labels(args.labels)?
        .with_time_limits(args.build_time_limit_s, args.tile_time_limit_s)?;
    // Read the CA file now, so a bad one stops the worker at once with its name.
    drop(spindle_worker::tls::client_builder(
        args.ca_cert.as_deref(),
    )?);
    config.ca_cert = args.ca_cert;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    runtime.block_on(async {
        let shutdown = CancellationToken::new();
        tokio::spawn(stop_on_signal(shutdown.clone()));
        spindle_worker::run(config, shutdown).await.map(drop)
    })
}

/// Cancels `shutdown` at the first SIGTERM or Ctrl-C.
async fn stop_on_signal(shutdown: CancellationToken) {
    let ctrl_c = tokio::signal::ctrl_c();
    #[cfg(unix)]
    {
        let mut term =
            match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
                Ok(s) => s,
                Err(e) => {
                    tracing::error!(error = %e, "cannot listen for SIGTERM");
                    let _ = ctrl_c.await;
                    shutdown.cancel();
                    return;
                }
            };
        tokio::select! {
            _ = ctrl_c => {}
            _ = term.recv() => {}
        }
    }
    #[cfg(not(unix))]
    {
        let _ = ctrl_c.await;
    }
    tracing::info!("stopping: no new leases; finishing the tile in hand");
    shutdown.cancel();
}
