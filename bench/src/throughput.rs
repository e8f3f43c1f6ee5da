//! Study 6: the farm's throughput and the coordinator's overhead per tile.
//!
//! One job (a bumpy sphere) rendered by child processes of the `spindle` command built beside
//! this binary, timed by the wall clock around each child: the single-process renderer (`render --workers 0`, rayon over both
//! cores), the embedded local farm with 1 worker (which gets both cores' threads), 2 workers with
//! one thread each, and 1 worker pinned to one core (`taskset -c 0`, so it runs one thread) as
//! the one-worker baseline of the "two workers ≥ 1.8×" target. Every child reads the scene,
//! builds it, renders and writes the EXR, so the fixed costs are the same on each side; the
//! farm's extra time over the single process, divided by its tiles, is the coordinator's
//! overhead (lease, upload, assembly), for tile sizes 16, 32 and 64; a line fitted through the
//! three sizes splits it into a fixed start-up cost and a cost per tile.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use spindle_common::protocol::DEFAULT_TILE_SIZE;
use spindle_common::scene::ScatterMethod;

use crate::BenchArgs;
use crate::metric::linear_fit;
use crate::report::{Report, Table, keep_scene, secs, sig};
use crate::scenes::{Model, film, settings};

/// How a child process renders.
#[derive(Clone, Copy)]
struct Setup {
    name: &'static str,
    workers: u32,
    /// Pin the child to one core (it then sees one CPU and runs one thread).
    one_core: bool,
    tile_size: u32,
}

/// The `spindle` command built beside this binary (the same `target/<profile>/` folder).
fn spindle_exe() -> Result<PathBuf> {
    let bench = std::env::current_exe().context("cannot find the spindle-bench executable")?;
    let exe = bench.with_file_name(format!("spindle{}", std::env::consts::EXE_SUFFIX));
    if !exe.is_file() {
        bail!(
            "the throughput study runs the `spindle` command, but there is none at {}: \
             build it first with `cargo build --release -p spindle-cli` (the same profile as spindle-bench)",
            exe.display()
        );
    }
    Ok(exe)
}

/// Runs `spindle render` (`exe`) as a child `repeats` times; the fastest wall time counts.
fn time_child(exe: &Path, scene: &Path, out: &Path, setup: Setup, repeats: usize) -> Result<f64> {
    let mut best = f64::INFINITY;
    for _ in 0..repeats {
        let mut command = if setup.one_core {
            let mut c = Command::new("taskset");
            c.arg("-c").arg("0").arg(exe);
            c
        } else {
            Command::new(exe)
        };
        command
            .arg("render")
            .arg(scene)
            .arg("-o")
            .arg(out)
            .arg("--workers")
            .arg(setup.workers.to_string());
        if setup.workers > 0 {
            command.arg("--tile-size").arg(setup.tile_size.to_string());
        }
        let started = Instant::now();
        let output = command
            .output()
            .with_context(|| format!("cannot start {}", setup.name))?;
        let seconds = started.elapsed().as_secs_f64();
        if !output.status.success() {
            bail!(
                "{} failed: {}",
                setup.name,
                String::from_utf8_lossy(&output.stderr).trim()
            );
        }
        best = best.min(seconds);
    }
    Ok(best)
}

fn taskset_works() -> bool {
    Command::new("taskset")
        .args(["-c", "0", "true"])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Runs study 6.
pub fn run(report: &mut Report, args: &BenchArgs) -> Result<()> {
    let exe = spindle_exe()?;
    let (model, size, repeats) = if args.quick {
        (Model::bumpy(4), 64, 1)
    } else {
        (Model::bumpy(5), 128, 2)
    };
    report.line("");
    report.line("== 6. farm throughput ==");
    report.line(format!(
        "setup: {} ({} triangles), interval K=1, {size}x{size} film, 1 spp; child `spindle render` \
         processes timed by wall clock (scene read + build + render + EXR), best of {repeats}",
        model.name, model.triangles
    ));
    let desc = model.scene(film(size, 1), settings(ScatterMethod::Interval));
    let scene = keep_scene(report, "throughput.json", &desc)?;
    let out = report.out().join("throughput-render.exr");
    let pixels = (size * size) as f64;

    let single = Setup {
        name: "single process (--workers 0, 2 threads)",
        workers: 0,
        one_core: false,
        tile_size: DEFAULT_TILE_SIZE,
    };
    let t_single = time_child(&exe, &scene, &out, single, repeats)?;
    let mut table = Table::new(&[
        "setup",
        "tile_size",
        "tiles",
        "seconds",
        "pixels_per_second",
        "vs_single_process",
        "overhead_per_tile_s",
        "overhead_share",
    ]);
    table.push(vec![
        single.name.into(),
        "32".into(),
        "-".into(),
        secs(t_single),
        sig(pixels / t_single),
        "1".into(),
        "-".into(),
        "-".into(),
    ]);
    let mut one_worker_default = None;
    let mut one_worker_overheads: Vec<(f64, f64)> = Vec::new();
    let mut two_workers_default = None;
    for tile_size in [16u32, 32, 64] {
        let tiles = size.div_ceil(tile_size).pow(2) as f64;
        for (name, workers) in [("1 worker x 2 threads", 1u32), ("2 workers x 1 thread", 2)] {
            let setup = Setup {
                name,
                workers,
                one_core: false,
                tile_size,
            };
            let t = time_child(&exe, &scene, &out, setup, repeats)?;
            let overhead = t - t_single;
            if workers == 1 {
                one_worker_overheads.push((tiles, overhead));
            }
            if tile_size == DEFAULT_TILE_SIZE {
                if workers == 1 {
                    one_worker_default = Some(t);
                } else {
                    two_workers_default = Some(t);
                }
            }
            table.push(vec![
                name.into(),
                tile_size.to_string(),
                format!("{tiles}"),
                secs(t),
                sig(pixels / t),
                sig(t_single / t),
                secs(overhead / tiles),
                sig(overhead / t_single),
            ]);
        }
    }
    let mut one_core = None;
    if taskset_works() {
        let setup = Setup {
            name: "1 worker pinned to 1 core (taskset)",
            workers: 1,
            one_core: true,
            tile_size: DEFAULT_TILE_SIZE,
        };
        let t = time_child(&exe, &scene, &out, setup, repeats)?;
        one_core = Some(t);
        table.push(vec![
            setup.name.into(),
            DEFAULT_TILE_SIZE.to_string(),
            format!("{}", size.div_ceil(DEFAULT_TILE_SIZE).pow(2)),
            secs(t),
            sig(pixels / t),
            sig(t_single / t),
            "-".into(),
            "-".into(),
        ]);
    } else {
        report.line("skipping the one-core worker: `taskset` is not available");
    }
    report.line("overhead = (farm time - single-process time) / tiles; share = that over the single-process time");
    report.table("throughput", &table)?;
    if let (Some(one), Some(two)) = (one_core, two_workers_default) {
        report.line(format!(
            "two workers (1 thread each) vs one worker on one core: {}x throughput (target >= 1.8x)",
            sig(one / two)
        ));
    }
    if let (Some(one), Some(two)) = (one_worker_default, two_workers_default) {
        report.line(format!(
            "two workers x 1 thread vs one worker x 2 threads: {}x throughput",
            sig(one / two)
        ));
    }
    if let Some(one) = one_worker_default {
        report.line(format!(
            "farm overhead at the default tile size {DEFAULT_TILE_SIZE}, start-up included: {}% of the single-process time",
            sig(100.0 * (one - t_single) / t_single)
        ));
    }
    // Overhead = fixed start-up + per-tile cost: the slope over the three tile sizes separates them.
    if let Some((per_tile, fixed)) = linear_fit(&one_worker_overheads) {
        let tiles = size.div_ceil(DEFAULT_TILE_SIZE).pow(2) as f64;
        report.line(format!(
            "fit over tile sizes (1 worker): fixed start-up {} s + {} s per tile; per-tile overhead at tile size \
             {DEFAULT_TILE_SIZE} = {}% of the single-process time (target < 2%)",
            secs(fixed),
            secs(per_tile),
            sig(100.0 * per_tile * tiles / t_single)
        ));
    }
    let _ = std::fs::remove_file(&out);
    let _ = std::fs::remove_file(out.with_extension("png"));
    Ok(())
}
