//! What the coordinator accepts: image size, samples, triangles, tiles, jobs and body sizes.
//!
//! A farm is shared, so a single request must not be able to exhaust its memory, disk or time.
//! Each check names the offending field and the limit, and becomes a 4xx before anything is
//! stored. Triangle counts are known without building geometry
//! (`spindle_common::validate::scene_triangles`, the renderer's and the CLI's count too).

use spindle_common::scene::SceneDescription;
use spindle_common::tile::TileRect;
use spindle_common::validate::{MAX_TRIANGLES, scene_triangles};
pub use spindle_common::validate::{count_obj_triangles, icosphere_triangles};

/// The coordinator's limits.
#[derive(Debug, Clone, PartialEq)]
pub struct Limits {
    pub max_width: u32,
    pub max_height: u32,
    /// Width × height.
    pub max_pixels: u64,
    pub max_spp: u32,
    /// Triangles of all shapes together.
    pub max_triangles: u64,
    pub min_tile_size: u32,
    pub max_tile_size: u32,
    /// Tiles of one job (each is tracked in memory and leased separately).
    pub max_tiles_per_job: u64,
    /// Jobs queued or running at once (finished jobs do not count).
    pub max_active_jobs: usize,
    /// JSON request bodies (job submissions, asset queries, …).
    pub max_json_bytes: usize,
    /// One tile upload (its pixels as JSON).
    pub max_tile_upload_bytes: usize,
    /// One asset file.
    pub max_asset_bytes: usize,
    /// Hashes in one `POST /v1/assets/missing`.
    pub max_hashes_per_query: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_width: 16_384,
            max_height: 16_384,
            max_pixels: 64 << 20,
            max_spp: spindle_common::validate::MAX_SPP,
            max_triangles: MAX_TRIANGLES,
            min_tile_size: 4,
            max_tile_size: 256,
            max_tiles_per_job: 1 << 16,
            max_active_jobs: 64,
            max_json_bytes: 4 << 20,
            // A 256 × 256 tile is 589 824 floats; as JSON at most ~16 bytes each.
            max_tile_upload_bytes: 16 << 20,
            max_asset_bytes: 1 << 30,
            max_hashes_per_query: 10_000,
        }
    }
}

impl Limits {
    /// Checks the film and the tile size of a job (not its triangles, see
    /// [`Limits::check_triangles`]); the tiles counted are those of the crop window when there
    /// is one (checked against the film before, [`spindle_common::protocol::check_crop`]).
    pub fn check_film(
        &self,
        scene: &SceneDescription,
        tile_size: u32,
        crop: Option<TileRect>,
    ) -> Result<(), String> {
        let film = &scene.film;
        for (field, value, max) in [
            ("scene.film.width", film.width, self.max_width),
            ("scene.film.height", film.height, self.max_height),
            ("scene.film.spp", film.spp, self.max_spp),
        ] {
            if value == 0 {
                return Err(format!("{field}: must be at least 1"));
            }
            if value > max {
                return Err(format!("{field}: {value} exceeds the limit of {max}"));
            }
        }
        let pixels = film.width as u64 * film.height as u64;
        if pixels > self.max_pixels {
            return Err(format!(
                "scene.film: {}x{} = {pixels} pixels exceeds the limit of {}",
                film.width, film.height, self.max_pixels
            ));
        }
        if !(self.min_tile_size..=self.max_tile_size).contains(&tile_size) {
            return Err(format!(
                "tile_size: must be between {} and {}",
                self.min_tile_size, self.max_tile_size
            ));
        }
        let (width, height) = crop.map_or((film.width, film.height), |c| (c.width, c.height));
        let tiles = width.div_ceil(tile_size) as u64 * height.div_ceil(tile_size) as u64;
        if tiles > self.max_tiles_per_job {
            return Err(format!(
                "tile_size: {tile_size} px tiles cut the image into {tiles} tiles, more than the \
                 limit of {}; use larger tiles",
                self.max_tiles_per_job
            ));
        }
        Ok(())
    }

    /// Checks the scene's triangle count against this coordinator's limit; `obj_triangles(path)`
    /// gives the count of an OBJ shape's asset (or an error naming the problem).
    pub fn check_triangles(
        &self,
        scene: &SceneDescription,
        obj_triangles: impl FnMut(&str) -> Result<u64, String>,
    ) -> Result<(), String> {
        scene_triangles(scene, obj_triangles, self.max_triangles)
            .map(|_| ())
            .map_err(|e| format!("scene.{e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn icosphere_counts() {
        assert_eq!(icosphere_triangles(0), Some(20));
        assert_eq!(icosphere_triangles(1), Some(80));
        assert_eq!(icosphere_triangles(5), Some(20_480));
        assert_eq!(icosphere_triangles(40), None);
    }
}
