//! The final image of a job, and its preview: finished tiles read back from disk and placed
//! into one frame.
//!
//! Tiles are inserted in tile index order and the EXR writer's bytes depend only on the image,
//! so the file does not depend on which worker rendered which tile or in what order tiles
//! arrived. The header carries the film's settings and the summed render statistics
//! (`spindle.stats.<counter>`), the same names `spindle render` writes. Everything here
//! blocks; call it from `spawn_blocking`.

use anyhow::Context;
use spindle_common::image::Image;
use spindle_common::protocol::JobSpec;
use spindle_common::stats::RenderStats;

use crate::tile_store::TileStore;

/// Reads the given finished tiles (`(index, hash)`, in index order) into a frame.
pub fn frame(
    store: &TileStore,
    job: u64,
    spec: &JobSpec,
    tiles: &[(u32, String)],
) -> anyhow::Result<Image> {
    let film = &spec.scene.film;
    let mut image = Image::new(film.width, film.height);
    for (index, hash) in tiles {
        let pixels = store.read(job, *index, hash)?;
        image
            .insert_tile(&pixels)
            .with_context(|| format!("tile {index}"))?;
    }
    Ok(image)
}

/// The EXR header attributes of a finished job.
pub fn attributes(spec: &JobSpec, stats: &RenderStats) -> anyhow::Result<Vec<(String, String)>> {
    let film = &spec.scene.film;
    let mut attributes = vec![
        ("spindle.spp".to_string(), film.spp.to_string()),
        ("spindle.seed".to_string(), film.seed.to_string()),
        (
            "spindle.region".to_string(),
            format!("0,0,{},{}", film.width, film.height),
        ),
        (
            "spindle.integrator".to_string(),
            serde_json::to_string(&spec.scene.integrator)?,
        ),
    ];
    for (name, value) in stats.entries() {
        attributes.push((format!("spindle.stats.{name}"), value.to_string()));
    }
    Ok(attributes)
}

/// Writes the final EXR of a job whose tiles are all in, atomically.
pub fn write_final(
    store: &TileStore,
    job: u64,
    spec: &JobSpec,
    tiles: &[(u32, String)],
    stats: &RenderStats,
) -> anyhow::Result<()> {
    let expected = spindle_common::tile::split_centre_first(
        spec.scene.film.width,
        spec.scene.film.height,
        spec.tile_size,
    )
    .len();
    anyhow::ensure!(
        tiles.len() == expected,
        "{} of {expected} tiles are in",
        tiles.len()
    );
    let mut image = frame(store, job, spec, tiles)?;
    image.attributes.extend(attributes(spec, stats)?);
    image.write_exr(store.image_path(job))?;
    Ok(())
}

/// A PNG preview of the tiles received so far (black where none arrived yet).
pub fn preview_png(
    store: &TileStore,
    job: u64,
    spec: &JobSpec,
    tiles: &[(u32, String)],
) -> anyhow::Result<Vec<u8>> {
    Ok(frame(store, job, spec, tiles)?.to_png_preview_bytes()?)
}
