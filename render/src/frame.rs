//! A whole frame rendered in this process: the CLI's `--workers 0` and the benchmarks share it,
//! so both see exactly the tiles (and the pixels) a farm would assemble.

use spindle_common::image::{Image, ImageError};
use spindle_common::stats::RenderStats;
use spindle_common::tile::{TileRect, split_centre_first};

use crate::scene::Scene;
use crate::tile::render_tile_with_progress;

/// Tile edge for in-process rendering: small enough for a lively preview order, large enough to
/// keep every core busy inside a tile.
const TILE_SIZE: u32 = 32;

/// Renders `region` of the scene's film into a full-frame image (pixels outside the region stay
/// black), centre tiles first, calling `rows_done` with the number of rows of a tile as they
/// finish. Rayon runs inside each tile, on the current pool.
pub fn render_frame(
    scene: &Scene,
    region: TileRect,
    rows_done: &(dyn Fn(u64) + Sync),
) -> Result<(Image, RenderStats), ImageError> {
    let film = scene.film();
    let mut image = Image::new(film.width, film.height);
    let mut stats = RenderStats::default();
    for tile in split_centre_first(region.width, region.height, TILE_SIZE) {
        let rect = TileRect {
            x: region.x + tile.x,
            y: region.y + tile.y,
            ..tile
        };
        let pixels = render_tile_with_progress(scene, rect, rows_done);
        stats.add(&pixels.stats);
        image.insert_tile(&pixels)?;
    }
    Ok((image, stats))
}
