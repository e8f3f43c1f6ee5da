//! The user's `spindle` command: render a scene on this machine, or submit it to a farm and
//! follow it. A thin shell: each subcommand lives in its own module.

mod api;
mod cancel;
mod control;
mod fetch;
mod jobs;
mod local_farm;
mod progress;
mod render;
mod secret;
mod status;
mod submit;
mod workers;

use std::io::IsTerminal;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Debug, Parser)]
#[command(
    name = "spindle",
    version,
    about = "Single scattering in refractive objects, rendered here or on a farm."
)]
struct Cli {
    /// The coordinator's URL (for submit, status, fetch, cancel).
    #[arg(
        long,
        global = true,
        env = "SPINDLE_SERVER",
        default_value = "http://127.0.0.1:7878"
    )]
    server: String,
    /// PEM file of the CA certificates that signed an https coordinator's certificate (a
    /// private CA); without it https trusts the system's roots.
    #[arg(long, global = true, env = "SPINDLE_CA_CERT")]
    ca_cert: Option<std::path::PathBuf>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Render a scene on this machine to an OpenEXR file (and a PNG preview beside it).
    Render(render::RenderArgs),
    /// Send a scene and its meshes to the coordinator; prints the job id.
    Submit(submit::SubmitArgs),
    /// Show one job, or every job.
    Status(status::StatusArgs),
    /// List jobs (filter by state or name), oldest first.
    Jobs(jobs::JobsArgs),
    /// Pause a job: no new tiles are handed out; tiles in progress finish.
    Pause(control::JobArg),
    /// Resume a paused job.
    Resume(control::JobArg),
    /// Put a failed or cancelled job back in the queue (its finished tiles are kept).
    Requeue(control::JobArg),
    /// Change a job's priority (higher runs first).
    Priority(control::PriorityArgs),
    /// Delete a finished job: its tiles, images and records (--force for an unfinished one).
    Delete(control::DeleteArgs),
    /// Download a finished job's image.
    Fetch(fetch::FetchArgs),
    /// Cancel a job.
    Cancel(cancel::CancelArgs),
    /// List the farm's workers (state, lease, labels, tiles, throughput), or drain one.
    Workers(workers::WorkersArgs),
}

fn main() -> ExitCode {
    // Quiet by default: the embedded farm of `render` would otherwise log every tile.
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .init();
    let cli = Cli::parse();
    let runtime = match tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
    {
        Ok(rt) => rt,
        Err(e) => {
            eprintln!("spindle: cannot start the async runtime: {e}");
            return ExitCode::FAILURE;
        }
    };
    match runtime.block_on(run(cli)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("spindle: {e:#}");
            ExitCode::FAILURE
        }
    }
}

async fn run(cli: Cli) -> anyhow::Result<()> {
    let api = || {
        let token = std::env::var("SPINDLE_TOKEN").ok();
        api::Api::with_ca_cert(&cli.server, token, cli.ca_cert.as_deref())
    };
    match &cli.command {
        Command::Render(args) => render::run(args).await,
        Command::Submit(args) => submit::run(&api()?, args).await,
        Command::Status(args) => status::run(&api()?, args).await,
        Command::Fetch(args) => fetch::run(&api()?, args).await,
        Command::Cancel(args) => cancel::run(&api()?, args).await,
        Command::Jobs(args) => jobs::run(&api()?, args).await,
        Command::Pause(args) => control::change(&api()?, args, control::Change::Pause).await,
        Command::Resume(args) => control::change(&api()?, args, control::Change::Resume).await,
        Command::Requeue(args) => control::change(&api()?, args, control::Change::Requeue).await,
        Command::Priority(args) => control::priority(&api()?, args).await,
        Command::Delete(args) => control::delete(&api()?, args).await,
        Command::Workers(args) => workers::run(&api()?, args).await,
    }
}
