//! A whole frame rendered in this process: the CLI's `--workers 0` and the benchmarks share it,
//! so both see exactly the tiles (and the pixels) a farm would assemble.

use spindle_common::image::{Image, ImageError};
use spindle_common::stats::RenderStats;
use spindle_common::tile::{TileRect, split_window_centre_first};

use crate::scene::Scene;
use crate::tile::render_tile_with_progress;

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
    let film = scene.film();
    let mut image = Image::window(film.width, film.height, region)?;
    let mut stats = RenderStats::default();
    for rect in split_window_centre_first(region, TILE_SIZE) {
        let pixels = render_tile_with_progress(scene, rect, rows_done);
        stats.add(&pixels.stats);
        image.insert_tile(&pixels)?;
    }
    Ok((image, stats))
}
