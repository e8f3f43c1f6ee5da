//! The user's `spindle` command: render a scene on this machine, or submit it to a farm and
//! follow it. A thin shell: each subcommand lives in its own module.

mod api;
mod cancel;
mod control;
mod fetch;
mod frames;
mod interrupt;
mod jobs;
mod local_farm;
mod meter;
mod progress;
mod render;
mod scene_input;
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
    #[command(subcommand)]
    command: Command,
}

/// How to reach a coordinator: the options of every command that talks to one.
#[derive(Debug, clap::Args)]
struct FarmArgs {
    /// The coordinator: `https://HOST:PORT`, `http://HOST:PORT`, or `HOST:PORT` (http on a
    /// loopback address, https elsewhere).
    #[arg(long, env = "SPINDLE_SERVER", default_value = "http://127.0.0.1:7878")]
    server: String,
    /// PEM file of the CA certificates that signed an https coordinator's certificate (a
    /// private CA); without it https trusts the system's roots.
    #[arg(long, env = "SPINDLE_CA_CERT")]
    ca_cert: Option<std::path::PathBuf>,
    /// Read the client token from this file instead of SPINDLE_TOKEN.
    #[arg(long, env = "SPINDLE_TOKEN_FILE")]
    token_file: Option<std::path::PathBuf>,
}

impl FarmArgs {
    /// A client of the coordinator. The token comes from `--token-file` or `SPINDLE_TOKEN`,
    /// never from the command line, where every user of the machine could see it.
    fn api(&self) -> anyhow::Result<api::Api> {
        use anyhow::Context;
        let token = match &self.token_file {
            Some(path) => Some(std::fs::read_to_string(path).with_context(|| {
                format!("--token-file {}: cannot read the token", path.display())
            })?),
            None => std::env::var("SPINDLE_TOKEN").ok(),
        };
        api::Api::with_ca_cert(&self.server, token, self.ca_cert.as_deref())
    }
}

/// A command that talks to a coordinator: its own options and how to reach the coordinator.
#[derive(Debug, clap::Args)]
struct OnFarm<A: clap::Args> {
    #[command(flatten)]
    args: A,
    #[command(flatten)]
    farm: FarmArgs,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Render a scene on this machine to an OpenEXR file (and a PNG preview beside it).
    Render(render::RenderArgs),
    /// Send a scene and its meshes to the coordinator; prints the job id.
    Submit(OnFarm<submit::SubmitArgs>),
    /// Show one job, or every job.
    Status(OnFarm<status::StatusArgs>),
    /// List jobs (filter by state or name), newest first, with progress and ETA.
    Jobs(OnFarm<jobs::JobsArgs>),
    /// Pause a job: no new tiles are handed out; tiles in progress finish.
    Pause(OnFarm<control::JobArg>),
    /// Resume a paused job.
    Resume(OnFarm<control::JobArg>),
    /// Put a failed or cancelled job back in the queue (its finished tiles are kept).
    Requeue(OnFarm<control::JobArg>),
    /// Change a job's priority (higher runs first).
    Priority(OnFarm<control::PriorityArgs>),
    /// Delete a finished job: its tiles, images and records (--force for an unfinished one).
    Delete(OnFarm<control::DeleteArgs>),
    /// Download a finished job's image.
    Fetch(OnFarm<fetch::FetchArgs>),
    /// Cancel a job.
    Cancel(OnFarm<cancel::CancelArgs>),
    /// List the farm's workers (state, lease, labels, tiles, throughput), or drain one.
    Workers(OnFarm<workers::WorkersArgs>),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // Warnings and errors only (the embedded farm of `render` would otherwise log every tile);
    // errors only with `render --quiet`. RUST_LOG, when set, decides instead.
    let quiet = matches!(&cli.command, Command::Render(args) if args.quiet);
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
                tracing_subscriber::EnvFilter::new(if quiet { "error" } else { "warn" })
            }),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .init();
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
            if let Some(interrupted) = e.downcast_ref::<interrupt::Interrupted>() {
                // Not through the runtime's drop, which would wait for the tiles still
                // rendering on its blocking threads.
                std::process::exit(i32::from(interrupted.signal.exit_code()));
            }
            ExitCode::FAILURE
        }
    }
}

async fn run(cli: Cli) -> anyhow::Result<()> {
    use control::Change;
    match &cli.command {
        Command::Render(args) => render::run(args).await,
        Command::Submit(c) => submit::run(&c.farm.api()?, &c.args).await,
        Command::Status(c) => status::run(&c.farm.api()?, &c.args).await,
        Command::Fetch(c) => fetch::run(&c.farm.api()?, &c.args).await,
        Command::Cancel(c) => cancel::run(&c.farm.api()?, &c.args).await,
        Command::Jobs(c) => jobs::run(&c.farm.api()?, &c.args).await,
        Command::Pause(c) => control::change(&c.farm.api()?, &c.args, Change::Pause).await,
        Command::Resume(c) => control::change(&c.farm.api()?, &c.args, Change::Resume).await,
        Command::Requeue(c) => control::change(&c.farm.api()?, &c.args, Change::Requeue).await,
        Command::Priority(c) => control::priority(&c.farm.api()?, &c.args).await,
        Command::Delete(c) => control::delete(&c.farm.api()?, &c.args).await,
        Command::Workers(c) => workers::run(&c.farm.api()?, &c.args).await,
    }
}
