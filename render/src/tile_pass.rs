//! One progressive pass of one tile: how a farm worker renders a job with `film.time_budget_s`.
//!
//! Pass `k` takes every pixel of the tile from the samples of pass `k − 1` (the running sums its
//! result carried, [`TileProgress`]) up to the cap `min(16 k, film.spp)` ([`pass_cap`]), exactly as
//! [`crate::frame::render_frame_passes`] does for the whole frame in one process. So after `k`
//! passes the tile's pixels and statistics are the bits of [`crate::render_tile`] at
//! `film.spp` = that cap, whichever workers rendered which pass.

use rayon::prelude::*;
use spindle_common::passes::{TileProgress, pass_cap};
use spindle_common::tile::{TilePixels, TileRect};

use crate::scene::Scene;
use crate::tile::{PixelProgress, film_passes, pixels_to_tile};

/// Why a tile's earlier pass cannot be continued.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct PassError(String);

/// Renders pass `pass` (1-based) of the tile `rect`, continuing from `previous`, the result of
/// pass `pass − 1` of the same tile (none for pass 1). The result carries its own
/// [`TileProgress`] for the next pass; its statistics are the sum over all passes so far.
pub fn render_tile_pass(
    scene: &Scene,
    rect: TileRect,
    pass: u32,
    previous: Option<&TilePixels>,
) -> Result<TilePixels, PassError> {
    let spp = scene.film().spp;
    let mut pixels = match (pass, previous) {
        (0, _) => return Err(PassError("pass: passes are numbered from 1".into())),
        (1, None) => vec![PixelProgress::default(); rect.pixel_count()],
        (1, Some(_)) => {
            return Err(PassError(
                "pass 1 starts from no samples, but an earlier result was given".into(),
            ));
        }
        (_, None) => {
            return Err(PassError(format!(
                "pass {pass} continues pass {}, whose result is missing",
                pass - 1
            )));
        }
        (_, Some(before)) => resume(rect, pass, spp, before)?,
    };
    let cap = pass_cap(pass, spp);
    let width = rect.width as usize;
    pixels.par_iter_mut().enumerate().for_each(|(i, pixel)| {
        let (x, y) = (rect.x + (i % width) as u32, rect.y + (i / width) as u32);
        pixel.advance(scene, x, y, cap);
    });
    let values: Vec<_> = pixels.par_iter().map(PixelProgress::value).collect();
    let mut tile = pixels_to_tile(rect, film_passes(scene), values.iter());
    if let Some(before) = previous {
        tile.stats.add(&before.stats);
    }
    tile.progress = Some(TileProgress {
        pass,
        spp: cap,
        pixels: pixels.iter().map(PixelProgress::sums).collect(),
    });
    Ok(tile)
}

/// The pixels' states after `before`, checked to be pass `pass − 1` of this tile.
fn resume(
    rect: TileRect,
    pass: u32,
    spp: u32,
    before: &TilePixels,
) -> Result<Vec<PixelProgress>, PassError> {
    let Some(progress) = &before.progress else {
        return Err(PassError(format!(
            "pass {pass}: the earlier result of the tile carries no pass state"
        )));
    };
    if before.rect != rect {
        return Err(PassError(format!(
            "pass {pass}: the earlier result is of the tile of {}, not of {rect}",
            before.rect
        )));
    }
    if progress.pass + 1 != pass || progress.spp != pass_cap(progress.pass, spp) {
        return Err(PassError(format!(
            "pass {pass}: the earlier result is pass {} at {} spp, not pass {} at {}",
            progress.pass,
            progress.spp,
            pass - 1,
            pass_cap(pass - 1, spp)
        )));
    }
    if progress.pixels.len() != rect.pixel_count() {
        return Err(PassError(format!(
            "pass {pass}: the earlier result has {} pixel states for {} pixels",
            progress.pixels.len(),
            rect.pixel_count()
        )));
    }
    Ok(progress.pixels.iter().map(PixelProgress::resume).collect())
}
