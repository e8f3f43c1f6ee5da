//! A whole frame rendered in this process: the CLI's `--workers 0` and the benchmarks share it,
//! so both see exactly the tiles (and the pixels) a farm would assemble.
//!
//! [`render_frame_passes`] renders the same frame in progressive passes for `film.time_budget_s`:
//! the caller decides after each pass whether to go on (the renderer reads no clock), and the
//! image after pass `k` is, bit for bit, [`render_frame`]'s with `film.spp` = `k ·`
//! [`PASS_SPP`] (capped at `film.spp`), so a budgeted render is reproduced by that spp alone.

use spindle_common::image::{Image, ImageError};
use spindle_common::stats::RenderStats;
use spindle_common::tile::{TileRect, split_window_centre_first};

use rayon::prelude::*;
use spindle_common::scene::ADAPTIVE_BATCH;

use crate::scene::Scene;
use crate::tile::{PixelProgress, film_passes, pixels_to_tile, render_tile_with_progress};

/// Tile edge for in-process rendering: small enough for a lively preview order, large enough to
/// keep every core busy inside a tile.
const TILE_SIZE: u32 = 32;

/// Renders `region` of the scene's film into an image of that window ([`Image::window`]: the
/// whole frame when `region` is the film, else a crop placed in the film), centre tiles of the
/// window first ([`split_window_centre_first`], the farm's tiling of a job's window), calling
/// `rows_done` with the number of rows of a tile as they finish. Rayon runs inside each tile,
/// on the current pool.
pub fn render_frame(
    scene: &Scene,
    region: TileRect,
    rows_done: &(dyn Fn(u64) + Sync),
) -> Result<(Image, RenderStats), ImageError> {
    let frame = render_frame_until(scene, region, rows_done, &mut |_| true)?;
    Ok((frame.image, frame.stats))
}

/// A frame as far as it has been rendered: the tiles done are in `image`, the others are
/// transparent black (alpha 0).
#[derive(Debug, Clone)]
pub struct FrameSoFar {
    pub image: Image,
    /// The summed statistics of the tiles done.
    pub stats: RenderStats,
    pub tiles_done: usize,
    pub tiles_total: usize,
}

/// [`render_frame`], calling `keep_going` with the frame so far after each tile and stopping
/// when it returns `false`: the caller's way to stop early (an interrupted render) or to look
/// at the image midway. The tiles rendered are bit for bit [`render_frame`]'s.
pub fn render_frame_until(
    scene: &Scene,
    region: TileRect,
    rows_done: &(dyn Fn(u64) + Sync),
    keep_going: &mut dyn FnMut(&FrameSoFar) -> bool,
) -> Result<FrameSoFar, ImageError> {
    let film = scene.film();
    let tiles = split_window_centre_first(region, TILE_SIZE);
    let mut frame = FrameSoFar {
        image: Image::window(film.width, film.height, region)?.with_passes(film_passes(scene)),
        stats: RenderStats::default(),
        tiles_done: 0,
        tiles_total: tiles.len(),
    };
    for rect in tiles {
        let pixels = render_tile_with_progress(scene, rect, rows_done);
        frame.stats.add(&pixels.stats);
        frame.image.insert_tile(&pixels)?;
        frame.tiles_done += 1;
        if frame.tiles_done < frame.tiles_total && !keep_going(&frame) {
            break;
        }
    }
    Ok(frame)
}

/// Samples a pixel gains per progressive pass: one batch of the adaptive stopping rule, so that
/// stopping between passes is stopping where [`render_frame`]'s pixels check their error.
pub const PASS_SPP: u32 = ADAPTIVE_BATCH;

/// Where a progressive render stands after a pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PassReport {
    /// Passes completed (1 after the first).
    pub passes: u32,
    /// The sample cap every pixel has reached: `min(passes · PASS_SPP, film.spp)`. The image so
    /// far is [`render_frame`]'s with `film.spp` = this.
    pub spp: u32,
    /// Pixels that would take more samples in another pass (0: the render is complete).
    pub pixels_sampling: usize,
}

/// Renders `region` like [`render_frame`], in passes of [`PASS_SPP`] samples per pixel, calling
/// `keep_going` after each pass that leaves work to do; stops when it returns `false`, when every
/// pixel has `film.spp` samples, or when every pixel met `film.target_error`. Returns the image of
/// the complete passes, their statistics, and the last pass's report. Rayon runs over the
/// region's pixels, on the current pool.
pub fn render_frame_passes(
    scene: &Scene,
    region: TileRect,
    keep_going: &mut dyn FnMut(&PassReport) -> bool,
) -> Result<(Image, RenderStats, PassReport), ImageError> {
    let film = scene.film();
    let width = region.width as usize;
    let mut pixels = vec![PixelProgress::default(); region.pixel_count()];
    let mut report = PassReport {
        passes: 0,
        spp: 0,
        pixels_sampling: pixels.len(),
    };
    loop {
        let cap = (report.passes + 1).saturating_mul(PASS_SPP).min(film.spp);
        pixels.par_iter_mut().enumerate().for_each(|(i, pixel)| {
            let (x, y) = (region.x + (i % width) as u32, region.y + (i / width) as u32);
            pixel.advance(scene, x, y, cap);
        });
        report = PassReport {
            passes: report.passes + 1,
            spp: cap,
            pixels_sampling: if cap == film.spp {
                0
            } else {
                pixels.par_iter().filter(|p| !p.is_done(film.spp)).count()
            },
        };
        if report.pixels_sampling == 0 || !keep_going(&report) {
            break;
        }
    }
    let values: Vec<_> = pixels.par_iter().map(PixelProgress::value).collect();
    let tile = pixels_to_tile(region, film_passes(scene), values.iter());
    let mut image = Image::window(film.width, film.height, region)?.with_passes(film_passes(scene));
    image.insert_tile(&tile)?;
    Ok((image, tile.stats, report))
}
