//! A leased tile rendered in bands of rows, so that the worker can stop it between two bands.
//!
//! The renderer knows nothing of leases, clocks or cancellation: it renders a rectangle. The
//! worker hands it the tile a band of whole rows at a time ([`TileRect::rows`]) and checks its
//! [`Interrupt`] before each band, so a render the worker has walked away from (the lease lost,
//! the tile's time limit passed) stops within one band. A pixel depends only on the scene, the
//! seed, the pixel and the sample, so the bands stacked together ([`TilePixels::stack`]) are the
//! bits of [`render_tile`] (or [`render_tile_pass`]) on the whole tile, as
//! `spindle render --workers 0` renders it.

use spindle_common::tile::{TilePixels, TileRect};
use spindle_render::{PassError, Scene, render_tile, render_tile_pass};

use crate::detached::Interrupt;

/// Pixels per render thread in a band: enough for rayon to balance slow and fast pixels,
/// few enough that a band is short.
const PIXELS_PER_THREAD: u32 = 4;

/// Renders the tile `rect` (in one pass, or pass `pass` continuing from `previous`) band by
/// band on the current rayon pool; `None` if `interrupt` was set before the last band.
pub fn render(
    scene: &Scene,
    rect: TileRect,
    pass: Option<u32>,
    previous: Option<&TilePixels>,
    interrupt: &Interrupt,
) -> Option<Result<TilePixels, PassError>> {
    if let Some(before) = previous
        && !continues_whole(before, rect)
    {
        // Refused before a sample is taken, with the renderer's words about the whole tile.
        return Some(render_tile_pass(scene, rect, pass.unwrap_or(1), previous));
    }
    let threads = u32::try_from(rayon::current_num_threads()).unwrap_or(u32::MAX);
    let rows = band_rows(rect.width, threads);
    let mut bands = Vec::with_capacity(rect.height.div_ceil(rows) as usize);
    for first in (0..rect.height).step_by(rows as usize) {
        if interrupt.is_set() {
            return None;
        }
        let band = rect.rows(first, rows);
        bands.push(match pass {
            None => render_tile(scene, band),
            Some(pass) => {
                let before = previous.map(|p| p.band(first, rows));
                match render_tile_pass(scene, band, pass, before.as_ref()) {
                    Ok(pixels) => pixels,
                    Err(e) => return Some(Err(e)),
                }
            }
        });
    }
    let mut tile = TilePixels::stack(bands);
    if let Some(previous) = previous {
        // Each band's statistics are its own pass's; the earlier passes' are the tile's.
        tile.stats.add(&previous.stats);
    }
    Some(Ok(tile))
}

/// Does `before` carry a pass state for every pixel of `rect`, so that each band of it is the
/// earlier pass of the same band of the tile?
fn continues_whole(before: &TilePixels, rect: TileRect) -> bool {
    before.rect == rect
        && before
            .progress
            .as_ref()
            .is_some_and(|p| p.pixels.len() == rect.pixel_count())
}

/// Rows in a band of a tile `width` pixels wide, for `threads` render threads.
fn band_rows(width: u32, threads: u32) -> u32 {
    threads
        .saturating_mul(PIXELS_PER_THREAD)
        .div_ceil(width.max(1))
        .max(1)
}

#[cfg(test)]
mod tests;
