//! Timed renders for the studies: a private single-thread rayon pool, so a figure measures one
//! thread's work whatever else the machine runs, and the fastest of a few repeats counts.

use std::time::Instant;

use anyhow::{Context, Result};
use spindle_common::stats::RenderStats;
use spindle_common::tile::{TilePixels, TileRect, split_centre_first};
use spindle_render::{Scene, render_tile};

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

/// The whole film as one rectangle.
pub fn full_frame(scene: &Scene) -> TileRect {
    TileRect {
        x: 0,
        y: 0,
        width: scene.film().width,
        height: scene.film().height,
    }
}
