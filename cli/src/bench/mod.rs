//! `spindle bench`: the measurements users choose accuracy and hardware from (issue 5).
//!
//! One module per study: [`accuracy`] (speed against accuracy, and the equal-quality time
//! ratio), [`scaling`] (time per ray against triangle count), [`pruning`] (what each pruning
//! stage culls and what it saves), [`memory`] (peak resident memory of a renderer process
//! against triangle count), [`farm`] (throughput of the local farm and the coordinator's
//! overhead per tile). Every figure is printed with its setup and kept in the output folder
//! as CSV and PNG plots (`summary.txt` holds the printed record).
//!
//! Timing: renders run on a private single-thread rayon pool, and each figure is the fastest of
//! a few repeats, because the machine is shared and noisy: compare ratios measured in the same
//! run, never absolute times across runs. Nothing here asserts a speed.

pub mod accuracy;
pub mod farm;
pub mod memory;
pub mod metric;
pub mod plot;
pub mod pruning;
pub mod report;
pub mod scaling;
pub mod scenes;

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use spindle_common::scene as desc;
use spindle_common::stats::RenderStats;
use spindle_common::tile::{TilePixels, TileRect, split_centre_first};
use spindle_render::{Scene, render_tile};

use report::Report;
use scenes::Model;

/// Arguments of `spindle bench`.
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

/// The studies of `spindle bench`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Study {
    Accuracy,
    Scaling,
    Pruning,
    Memory,
    Farm,
}

/// Runs the chosen studies and writes their figures into `args.out`.
pub fn run(args: &BenchArgs) -> Result<()> {
    let started = Instant::now();
    let mut report = Report::new(&args.out)?;
    let runner = Runner::new(if args.quick { 1 } else { 2 })?;
    let wants = |s: Study| args.only.is_empty() || args.only.contains(&s);
    report.line(format!(
        "spindle bench{}: output in {}, meshes from {}",
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
            "warning: this is a debug build; time with `cargo run --release -p spindle-cli -- bench`",
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
    if wants(Study::Farm) {
        farm::run(&mut report, args)?;
    }
    report.line(format!(
        "bench finished in {:.1} s",
        started.elapsed().as_secs_f64()
    ));
    report.finish()
}

/// Seconds beyond which a render is timed once: the noise that repeats average out (a few
/// milliseconds of scheduling) is then below a per cent, and the full accuracy sweep's point
/// sampling at M = 512 and 1024 would otherwise take most of its time repeating itself.
const LONG_RENDER: f64 = 5.0;

/// Renders on a private single-thread pool and times it.
pub struct Runner {
    pool: rayon::ThreadPool,
    /// Each timed render runs this often; the fastest counts.
    pub repeats: usize,
}

/// A timed render of a rectangle.
pub struct Timed {
    pub seconds: f64,
    pub pixels: TilePixels,
}

/// A render cut short by a time budget: which tiles were done, and what they cost.
pub struct Budgeted {
    pub seconds: f64,
    pub stats: RenderStats,
    pub tiles: Vec<TileRect>,
}

impl Runner {
    pub fn new(repeats: usize) -> Result<Runner> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .thread_name(|i| format!("bench-render-{i}"))
            .build()
            .context("cannot start the benchmark render thread")?;
        Ok(Runner {
            pool,
            repeats: repeats.max(1),
        })
    }

    /// Renders `rect` `repeats` times; the fastest time counts (the pixels are the same bits
    /// every time: rendering is deterministic). A render longer than [`LONG_RENDER`] is not
    /// repeated.
    pub fn render(&self, scene: &Scene, rect: TileRect) -> Timed {
        let mut best = f64::INFINITY;
        let mut pixels = None;
        for _ in 0..self.repeats {
            let started = Instant::now();
            let p = self.pool.install(|| render_tile(scene, rect));
            best = best.min(started.elapsed().as_secs_f64());
            pixels = Some(p);
            if best >= LONG_RENDER {
                break;
            }
        }
        Timed {
            seconds: best,
            pixels: pixels.expect("at least one repeat"),
        }
    }

    /// Renders `rect` in `tile`-pixel tiles, centre first, until `budget` seconds have been
    /// spent (at least one tile), once: for costs too different to fix the pixel count ahead.
    pub fn render_budgeted(
        &self,
        scene: &Scene,
        rect: TileRect,
        tile: u32,
        budget: f64,
    ) -> Budgeted {
        let mut done = Budgeted {
            seconds: 0.0,
            stats: RenderStats::default(),
            tiles: Vec::new(),
        };
        for t in split_centre_first(rect.width, rect.height, tile) {
            let t = TileRect {
                x: rect.x + t.x,
                y: rect.y + t.y,
                ..t
            };
            let started = Instant::now();
            let pixels = self.pool.install(|| render_tile(scene, t));
            done.seconds += started.elapsed().as_secs_f64();
            done.stats.add(&pixels.stats);
            done.tiles.push(t);
            if done.seconds >= budget {
                break;
            }
        }
        done
    }
}

/// Builds `model` with `single_scatter` settings on `film`.
pub fn build(
    model: &Model,
    film: desc::Film,
    single_scatter: desc::SingleScatter,
) -> Result<Scene> {
    let desc = model.scene(film, single_scatter);
    Scene::build(&desc, &model.assets).with_context(|| format!("benchmark scene {}", model.name))
}

/// The whole film as one rectangle.
pub fn full_frame(scene: &Scene) -> TileRect {
    TileRect {
        x: 0,
        y: 0,
        width: scene.film().width,
        height: scene.film().height,
    }
}

/// Single-scatter settings for `method`, everything else at its default.
pub fn settings(method: desc::ScatterMethod) -> desc::SingleScatter {
    desc::SingleScatter {
        method,
        ..desc::SingleScatter::default()
    }
}

/// Writes a scene's JSON into `out/scenes/<name>.json`, so every figure's setup can
/// be rendered again with `spindle render`.
pub fn keep_scene(report: &Report, file: &str, scene: &desc::SceneDescription) -> Result<PathBuf> {
    let dir = report.out().join("scenes");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let path = dir.join(file);
    let json = serde_json::to_string_pretty(scene).context("scene JSON")?;
    std::fs::write(&path, json).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(path)
}
