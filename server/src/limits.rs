//! What the coordinator accepts: image size, samples, triangles, tiles, jobs and body sizes.
//!
//! A farm is shared, so a single request must not be able to exhaust its memory, disk or time.
//! Each check names the offending field and the limit, and becomes a 4xx before anything is
//! stored. Triangle counts are known without building geometry: an icosphere of `s`
//! subdivisions has 20·4^s triangles; an OBJ's are counted from its `f` lines.

use spindle_common::scene::{SceneDescription, Shape};
use spindle_common::tile::TileRect;
use spindle_common::validate::MAX_FACE_CORNERS;

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
            max_triangles: 20_000_000,
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

    /// Checks the scene's triangle count; `obj_triangles(path)` gives the count of an OBJ shape's
    /// asset (or an error naming the problem).
    pub fn check_triangles(
        &self,
        scene: &SceneDescription,
        mut obj_triangles: impl FnMut(&str) -> Result<u64, String>,
    ) -> Result<(), String> {
        let mut total: u64 = 0;
        for (i, object) in scene.objects.iter().enumerate() {
            let field = format!("scene.objects[{i}].shape");
            let count = match &object.shape {
                Shape::Obj { path, .. } => {
                    obj_triangles(path).map_err(|e| format!("{field}: {e}"))?
                }
                Shape::Icosphere { subdivisions, .. } | Shape::BumpySphere { subdivisions, .. } => {
                    icosphere_triangles(*subdivisions).unwrap_or(u64::MAX)
                }
            };
            total = total.saturating_add(count);
            if total > self.max_triangles {
                return Err(format!(
                    "{field}: the scene has more than {} triangles (the limit)",
                    self.max_triangles
                ));
            }
        }
        Ok(())
    }
}

/// Triangles of an icosphere subdivided `subdivisions` times: 20·4^s, or `None` past u64.
pub fn icosphere_triangles(subdivisions: u32) -> Option<u64> {
    4u64.checked_pow(subdivisions)?.checked_mul(20)
}

/// Triangles an OBJ file describes: a face line `f v1 v2 … vn` is a fan of n − 2 triangles.
/// A face of more than [`MAX_FACE_CORNERS`] corners is refused, naming its line.
pub fn count_obj_triangles(bytes: &[u8]) -> Result<u64, String> {
    let mut triangles = 0u64;
    for (n, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = line.trim_ascii_start();
        let Some(rest) = line.strip_prefix(b"f") else {
            continue;
        };
        if !rest.first().is_some_and(|b| b.is_ascii_whitespace()) {
            continue; // `fo …` or a bare `f` is not a face.
        }
        let corners = rest
            .split(|b| b.is_ascii_whitespace())
            .filter(|t| !t.is_empty())
            .count();
        if corners > MAX_FACE_CORNERS {
            return Err(format!(
                "line {}: a face of {corners} corners; at most {MAX_FACE_CORNERS} (split it into \
                 smaller faces)",
                n + 1
            ));
        }
        triangles += corners.saturating_sub(2) as u64;
    }
    Ok(triangles)
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

    #[test]
    fn obj_faces_are_counted_as_fans() {
        let obj = b"# a quad and a triangle\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
                    f 1 2 3 4\r\n  f 1/1/1 2/2/2 3/3/3\nfo 1 2 3\nvn 0 0 1\nf\n";
        assert_eq!(count_obj_triangles(obj), Ok(2 + 1));
        assert_eq!(count_obj_triangles(b""), Ok(0));
    }

    /// A fan face of N corners made the scene build quadratic (9.6 s at N = 10,000): such a
    /// face is refused by the count, naming its line; one at the bound is counted.
    #[test]
    fn a_face_of_too_many_corners_is_refused_naming_its_line() {
        let fan = |n: usize| format!("v 0 0 0\nv 1 0 0\nf{}\n", " 1".repeat(n));
        assert_eq!(
            count_obj_triangles(fan(MAX_FACE_CORNERS).as_bytes()),
            Ok(MAX_FACE_CORNERS as u64 - 2)
        );
        let e = count_obj_triangles(fan(10_000).as_bytes()).unwrap_err();
        assert_eq!(
            e,
            "line 3: a face of 10000 corners; at most 64 (split it into smaller faces)"
        );
    }
}
