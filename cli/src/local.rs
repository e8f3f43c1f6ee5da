//! Rendering a whole frame in this process, with rayon over all cores (`--workers 0`).

use indicatif::ProgressBar;
use spindle_common::image::Image;
use spindle_common::stats::RenderStats;
use spindle_common::tile::{TileRect, split_centre_first};
use spindle_render::{Scene, render_tile_with_progress};

/// Tile edge for in-process rendering: small enough for a lively preview order, large enough to
/// keep every core busy inside a tile.
const TILE_SIZE: u32 = 32;

/// Renders `region` of the scene's film into a full-frame image (pixels outside the region stay
/// black), centre tiles first, advancing `progress` by one per finished row of a tile.
pub fn render_in_process(
    scene: &Scene,
    region: TileRect,
    progress: &ProgressBar,
) -> anyhow::Result<(Image, RenderStats)> {
    let film = scene.film();
    let mut image = Image::new(film.width, film.height);
    let mut stats = RenderStats::default();
    for tile in split_centre_first(region.width, region.height, TILE_SIZE) {
        let rect = TileRect {
            x: region.x + tile.x,
            y: region.y + tile.y,
            ..tile
        };
        let pixels = render_tile_with_progress(scene, rect, &|rows| progress.inc(rows));
        stats.add(&pixels.stats);
        image.insert_tile(&pixels)?;
    }
    Ok((image, stats))
}
