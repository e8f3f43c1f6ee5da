//! The tile driver: renders a rectangle of pixels, knowing nothing of scheduling.
//!
//! Each pixel averages `film.spp` camera samples; sample `s` of pixel `(x, y)` is jittered in
//! the pixel and driven by `Sampler::new(film.seed, x, y, s)`, so a pixel's value is the same bits
//! whichever tile, thread or worker renders it. Pixels run in parallel with rayon.

use rayon::prelude::*;
use spindle_common::scene::ADAPTIVE_BATCH;
use spindle_common::stats::RenderStats;
use spindle_common::tile::{TilePixels, TileRect};

use crate::Rgb;
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::transport::{Radiance, radiance};

/// The mean radiance of one pixel over its samples, the standard error of its total, and what
/// it cost.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PixelValue {
    pub radiance: Radiance,
    /// `sqrt(s² / n)` per channel, with `s²` the unbiased sample variance of the total over the
    /// pixel's `n` samples (Welford's running form); 0 when `n` = 1, where it is unknown.
    pub stderr: Rgb,
    pub stats: RenderStats,
}

/// Renders pixel `(x, y)` alone (also how `--pixel x,y` replays one pixel). With
/// `film.target_error` the pixel takes samples in batches of [`ADAPTIVE_BATCH`] until its
/// luminance's relative standard error reaches the target (or is 0), at most `film.spp`; which
/// samples it takes depends only on the pixel, so any tiling gives the same bits.
pub fn render_pixel(scene: &Scene, x: u32, y: u32) -> PixelValue {
    let film = scene.film();
    let mut stats = RenderStats::default();
    let mut sum = Radiance::default();
    // Welford: the running mean of the total and the sum of squared deviations from it, per
    // channel and for the luminance.
    let (mut mean, mut m2) = (Rgb::ZERO, Rgb::ZERO);
    let (mut mean_y, mut m2_y) = (0.0, 0.0);
    let mut taken = 0;
    while taken < film.spp {
        let mut sampler = Sampler::new(film.seed, x, y, taken);
        let [u, v] = sampler.next_2d();
        let ray = scene.camera().ray(x as f64 + u, y as f64 + v);
        stats.camera_rays += 1;
        let r = radiance(scene, &ray, &mut sampler, &mut stats);
        sum.surface += r.surface;
        sum.single_scatter += r.single_scatter;
        taken += 1;
        let total = r.surface + r.single_scatter;
        let delta = total - mean;
        mean += delta / f64::from(taken);
        m2 += delta * (total - mean);
        let luminance = LUMINANCE.dot(total);
        let delta_y = luminance - mean_y;
        mean_y += delta_y / f64::from(taken);
        m2_y += delta_y * (luminance - mean_y);
        if let Some(target) = film.target_error
            && taken % ADAPTIVE_BATCH == 0
        {
            let n = f64::from(taken);
            let stderr_y = (m2_y.max(0.0) / ((n - 1.0) * n)).sqrt();
            if stderr_y <= target * mean_y.abs() {
                break;
            }
        }
    }
    let n = f64::from(taken.max(1));
    let stderr = if taken > 1 {
        (m2.max(Rgb::ZERO) / ((n - 1.0) * n)).map(f64::sqrt)
    } else {
        Rgb::ZERO
    };
    PixelValue {
        radiance: Radiance {
            surface: sum.surface / n,
            single_scatter: sum.single_scatter / n,
        },
        stderr,
        stats,
    }
}

/// Rec. 709 luminance weights of linear RGB, for the adaptive stopping rule.
const LUMINANCE: Rgb = Rgb::new(0.2126, 0.7152, 0.0722);

/// Renders the pixels of `rect`.
pub fn render_tile(scene: &Scene, rect: TileRect) -> TilePixels {
    render_tile_with_progress(scene, rect, &|_| {})
}

/// Renders the pixels of `rect`, calling `rows_done(1)` after each finished row (from any
/// thread), for progress bars.
pub fn render_tile_with_progress(
    scene: &Scene,
    rect: TileRect,
    rows_done: &(dyn Fn(u64) + Sync),
) -> TilePixels {
    let rows: Vec<Vec<PixelValue>> = (0..rect.height)
        .into_par_iter()
        .map(|row| {
            let values = (0..rect.width)
                .into_par_iter()
                .map(|col| render_pixel(scene, rect.x + col, rect.y + row))
                .collect();
            rows_done(1);
            values
        })
        .collect();
    let mut tile = TilePixels::black(rect);
    for (i, value) in rows.iter().flatten().enumerate() {
        let r = value.radiance;
        let total = r.surface + r.single_scatter;
        for c in 0..3 {
            tile.total[3 * i + c] = total[c] as f32;
            tile.surface[3 * i + c] = r.surface[c] as f32;
            tile.single_scatter[3 * i + c] = r.single_scatter[c] as f32;
            tile.stderr[3 * i + c] = value.stderr[c] as f32;
        }
        tile.stats.add(&value.stats);
    }
    tile
}
