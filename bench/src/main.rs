//! `spindle-bench`: the measurements users choose accuracy and hardware from (issue 5).
//!
//! One module per study: [`accuracy`] (speed against accuracy, and the equal-quality time
//! ratio), [`scaling`] (time per ray against triangle count), [`pruning`] (what each pruning
//! stage culls and what it saves), [`memory`] (peak resident memory of a renderer process
//! against triangle count), [`throughput`] (throughput of the local farm and the coordinator's
//! overhead per tile), [`lights`] (the noise of area lights against point lights), [`multiple`]
//! (multiple scattering's settings, and against a phase-sampling path tracer). Every figure is printed with its setup and kept in the output folder
//! as CSV and PNG plots (`summary.txt` holds the printed record).
//!
//! Timing ([`runner`]): renders run on a private single-thread rayon pool, and each figure is
//! the fastest of a few repeats, because the machine is shared and noisy: compare ratios
//! measured in the same run, never absolute times across runs. Nothing here asserts a speed.

mod accuracy;
mod lights;
mod memory;
mod metric;
mod multiple;
mod plot;
mod pruning;
mod report;
mod runner;
mod scaling;
mod scenes;
mod throughput;

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Result;
use clap::{Parser, Subcommand};

use report::Report;
use runner::Runner;

/// Arguments of `spindle-bench`.
#[derive(Debug, Parser)]
#[command(
    name = "spindle-bench",
    version,
    about = "Measure spindle's speed against accuracy, scaling, pruning, memory and farm \
             throughput; write CSV tables and PNG plots.",
    args_conflicts_with_subcommands = true
)]
struct Cli {
    #[command(flatten)]
    args: BenchArgs,
    #[command(subcommand)]
    internal: Option<Internal>,
}

/// Subcommands the studies run as child processes of this binary.
#[derive(Debug, Subcommand)]
enum Internal {
    /// (For the memory study.) Render a scene in process and print the peak resident memory.
    #[command(hide = true)]
    MemoryProbe {
        /// The scene file (JSON).
        scene: PathBuf,
    },
}

/// What to measure and where to write it.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Folder for the CSV tables, PNG plots and `summary.txt`.
    #[arg(long, default_value = "bench-out")]
    pub out: PathBuf,
    /// A smaller run (a few minutes) with fewer settings, smaller meshes and images.
    #[arg(long)]
    pub quick: bool,
    /// Folder of the shared test meshes (bunnies, Nefertiti); skipped with a reason if absent.
    #[arg(long, default_value = "../shared/meshes")]
    pub meshes: PathBuf,
    /// Studies to run, comma-separated (default: all).
    #[arg(long, value_delimiter = ',', value_enum)]
    pub only: Vec<Study>,
}

/// The studies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Study {
    Accuracy,
    Scaling,
    Pruning,
    Memory,
    Throughput,
    Lights,
    Multiple,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.internal {
        Some(Internal::MemoryProbe { scene }) => memory::probe(scene),
        None => run(&cli.args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("spindle-bench: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Runs the chosen studies and writes their figures into `args.out`.
fn run(args: &BenchArgs) -> Result<()> {
    let started = Instant::now();
    let mut report = Report::new(&args.out)?;
    let runner = Runner::new(if args.quick { 1 } else { 2 })?;
    let wants = |s: Study| args.only.is_empty() || args.only.contains(&s);
    report.line(format!(
        "spindle-bench{}: output in {}, meshes from {}",
        if args.quick { " --quick" } else { "" },
        args.out.display(),
        args.meshes.display()
    ));
    report.line(format!(
        "timing: one render thread, best of {} repeat(s); {} logical CPUs on this machine",
        runner.repeats,
        std::thread::available_parallelism().map_or(1, |n| n.get())
    ));
    if cfg!(debug_assertions) {
        report.line(
            "warning: this is a debug build; time with `cargo run --release -p spindle-bench`",
        );
    }
    if wants(Study::Accuracy) {
        accuracy::run(&mut report, &runner, args)?;
    }
    if wants(Study::Scaling) {
        scaling::run(&mut report, &runner, args)?;
    }
    if wants(Study::Pruning) {
        pruning::run(&mut report, &runner, args)?;
    }
    if wants(Study::Memory) {
        memory::run(&mut report, args)?;
    }
    if wants(Study::Throughput) {
        throughput::run(&mut report, args)?;
    }
    if wants(Study::Lights) {
        lights::run(&mut report, args)?;
    }
    if wants(Study::Multiple) {
        multiple::run(&mut report, args)?;
    }
    report.line(format!(
        "bench finished in {:.1} s",
        started.elapsed().as_secs_f64()
    ));
    report.finish()
}
