//! Tiles: rectangles of the image, the unit of work the farm hands out, and their pixels.
//!
//! A tile's pixels depend only on the scene and the tile's rectangle (never on which worker or
//! thread rendered it), so tiles can be rendered anywhere, in any order, and assembled into
//! identical images.

use serde::{Deserialize, Serialize};

use crate::passes::TileProgress;
use crate::stats::RenderStats;

/// A rectangle of pixels: columns `x .. x + width`, rows `y .. y + height` (row 0 at the top).
/// Displayed for people as "32 × 32 pixels at x 0, y 64".
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TileRect {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
}

impl std::fmt::Display for TileRect {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let TileRect {
            x,
            y,
            width,
            height,
        } = self;
        write!(f, "{width} × {height} pixels at x {x}, y {y}")
    }
}

impl TileRect {
    /// Number of pixels in the rectangle.
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Rows `first .. first + count` of the rectangle, counted from its top and cut at its
    /// bottom: a band as wide as the rectangle.
    pub fn rows(&self, first: u32, count: u32) -> TileRect {
        let first = first.min(self.height);
        TileRect {
            x: self.x,
            y: self.y + first,
            width: self.width,
            height: count.min(self.height - first),
        }
    }
}

/// One image layer: its name and how many values each pixel has in it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layer {
    pub name: &'static str,
    /// Values per pixel: 3 (RGB) or 1.
    pub channels: usize,
}

/// The image layers spindle writes, in this order. `total` = `surface` + `single_scatter` +
/// `multiple_scatter` (light scattered twice or more inside a medium);
/// `stderr` is the standard error of each pixel's mean of `total`, estimated from its samples
/// (0 with one sample per pixel, where it cannot be estimated); `alpha` is the coverage of
/// objects against the background: the mean over the pixel's samples of whether the camera
/// ray hits any object (1 wholly inside a silhouette, 0 where only the background is seen).
pub const LAYERS: [Layer; 6] = [
    Layer {
        name: "total",
        channels: 3,
    },
    Layer {
        name: "surface",
        channels: 3,
    },
    Layer {
        name: "single_scatter",
        channels: 3,
    },
    Layer {
        name: "multiple_scatter",
        channels: 3,
    },
    Layer {
        name: "stderr",
        channels: 3,
    },
    Layer {
        name: "alpha",
        channels: 1,
    },
];

/// Values per pixel over all [`LAYERS`].
pub const VALUES_PER_PIXEL: usize = 16;
const _: () = {
    let mut sum = 0;
    let mut i = 0;
    while i < LAYERS.len() {
        sum += LAYERS[i].channels;
        i += 1;
    }
    assert!(sum == VALUES_PER_PIXEL);
};

/// Rendered pixels of one rectangle: for each layer in [`LAYERS`] order, its values in
/// row-major order (`(row * width + col) * channels + channel`: RGB triples, or one alpha value
/// per pixel). Every value is a finite f32: JSON numbers beyond f32's range (which would become
/// ±inf) are refused when a tile is read.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TilePixels {
    pub rect: TileRect,
    #[serde(deserialize_with = "finite_layer")]
    pub total: Vec<f32>,
    #[serde(deserialize_with = "finite_layer")]
    pub surface: Vec<f32>,
    #[serde(deserialize_with = "finite_layer")]
    pub single_scatter: Vec<f32>,
    #[serde(deserialize_with = "finite_layer")]
    pub multiple_scatter: Vec<f32>,
    #[serde(deserialize_with = "finite_layer")]
    pub stderr: Vec<f32>,
    /// One value per pixel (see [`LAYERS`]).
    #[serde(deserialize_with = "finite_layer")]
    pub alpha: Vec<f32>,
    /// The optional passes of `film.passes` ([`crate::aov`]): per pixel the chosen passes'
    /// values in [`crate::aov::Aov::ALL`] order, row-major; empty (and not serialized) when the
    /// film asks for none, so a tile without passes costs nothing more.
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        deserialize_with = "finite_layer"
    )]
    pub aov: Vec<f32>,
    pub stats: RenderStats,
    /// A progressive pass's result (a farm job with `film.time_budget_s`): every pixel's running
    /// sums, from which the tile's next pass continues. Absent for one-pass results; never
    /// part of the image.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub progress: Option<TileProgress>,
}

/// Reads a layer, refusing a value that is not a finite f32 with its index and value. Each
/// number is read as f64 and rounded to f32, as serde reads an f32, so values are unchanged.
fn finite_layer<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<f32>, D::Error> {
    struct Layer;
    impl<'de> serde::de::Visitor<'de> for Layer {
        type Value = Vec<f32>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("an array of finite 32-bit floats")
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<f32>, A::Error> {
            let mut values = Vec::with_capacity(seq.size_hint().unwrap_or(0).min(1 << 20));
            while let Some(v) = seq.next_element::<f64>()? {
                let rounded = v as f32;
                if !rounded.is_finite() {
                    return Err(serde::de::Error::custom(format_args!(
                        "value {} is {v:e}, beyond the range of 32-bit floats (±{:e})",
                        values.len(),
                        f32::MAX
                    )));
                }
                values.push(rounded);
            }
            Ok(values)
        }
    }
    d.deserialize_seq(Layer)
}

impl TilePixels {
    /// A black tile of the given rectangle.
    pub fn black(rect: TileRect) -> TilePixels {
        let n = rect.pixel_count() * 3;
        TilePixels {
            rect,
            total: vec![0.0; n],
            surface: vec![0.0; n],
            single_scatter: vec![0.0; n],
            multiple_scatter: vec![0.0; n],
            stderr: vec![0.0; n],
            alpha: vec![0.0; rect.pixel_count()],
            aov: Vec::new(),
            stats: RenderStats::default(),
            progress: None,
        }
    }

    /// The layers in [`LAYERS`] order.
    pub fn layers(&self) -> [&[f32]; 6] {
        [
            &self.total,
            &self.surface,
            &self.single_scatter,
            &self.multiple_scatter,
            &self.stderr,
            &self.alpha,
        ]
    }

    /// Values per pixel of the optional passes (0 without any, or when `aov` does not hold a
    /// whole number of values per pixel, which `Image::insert_tile` refuses).
    pub fn aov_values_per_pixel(&self) -> usize {
        match self.rect.pixel_count() {
            0 => 0,
            n if self.aov.len().is_multiple_of(n) => self.aov.len() / n,
            _ => 0,
        }
    }

    /// The pixels (and pass state) of the band [`TileRect::rows`]`(first, count)` of this tile;
    /// its statistics are zero, since counters cannot be split by rows. A layer or pass state
    /// too short for the tile's rectangle gives an empty one.
    pub fn band(&self, first: u32, count: u32) -> TilePixels {
        fn part<T: Clone>(values: &[T], range: std::ops::Range<usize>) -> Vec<T> {
            values.get(range).map(<[T]>::to_vec).unwrap_or_default()
        }
        let rect = self.rect.rows(first, count);
        let start = (rect.y - self.rect.y) as usize * self.rect.width as usize;
        let pixels = start..start + rect.pixel_count();
        let values = pixels.start * 3..pixels.end * 3;
        TilePixels {
            rect,
            total: part(&self.total, values.clone()),
            surface: part(&self.surface, values.clone()),
            single_scatter: part(&self.single_scatter, values.clone()),
            multiple_scatter: part(&self.multiple_scatter, values.clone()),
            stderr: part(&self.stderr, values),
            alpha: part(&self.alpha, pixels.clone()),
            aov: part(
                &self.aov,
                pixels.start * self.aov_values_per_pixel()
                    ..pixels.end * self.aov_values_per_pixel(),
            ),
            stats: RenderStats::default(),
            progress: self.progress.as_ref().map(|p| TileProgress {
                pass: p.pass,
                spp: p.spp,
                pixels: part(&p.pixels, pixels),
            }),
        }
    }

    /// The tile made of `bands` of one column of pixels, top to bottom (each starting on the
    /// row below the one before): their pixels in order, their statistics added, their pass
    /// states joined when every band has one. Each pixel keeps its bits, so a tile rendered
    /// band by band is the tile rendered at once.
    pub fn stack(bands: Vec<TilePixels>) -> TilePixels {
        let first = bands.first().map_or(
            TileRect {
                x: 0,
                y: 0,
                width: 0,
                height: 0,
            },
            |b| b.rect,
        );
        let mut tile = TilePixels::black(TileRect { height: 0, ..first });
        let mut progress = match bands.first().and_then(|b| b.progress.as_ref()) {
            Some(p) if bands.iter().all(|b| b.progress.is_some()) => Some(TileProgress {
                pass: p.pass,
                spp: p.spp,
                pixels: Vec::with_capacity(bands.iter().map(|b| b.rect.pixel_count()).sum()),
            }),
            _ => None,
        };
        for band in bands {
            debug_assert_eq!(
                (band.rect.x, band.rect.width, band.rect.y),
                (first.x, first.width, first.y + tile.rect.height),
                "bands of one column, top to bottom"
            );
            tile.rect.height += band.rect.height;
            tile.total.extend_from_slice(&band.total);
            tile.surface.extend_from_slice(&band.surface);
            tile.single_scatter.extend_from_slice(&band.single_scatter);
            tile.multiple_scatter
                .extend_from_slice(&band.multiple_scatter);
            tile.stderr.extend_from_slice(&band.stderr);
            tile.alpha.extend_from_slice(&band.alpha);
            tile.aov.extend_from_slice(&band.aov);
            tile.stats.add(&band.stats);
            if let (Some(all), Some(p)) = (progress.as_mut(), band.progress) {
                all.pixels.extend(p.pixels);
            }
        }
        tile.progress = progress;
        tile
    }
}

/// Splits a `width` × `height` image into tiles of at most `size` × `size` pixels, ordered
/// centre-first (by the distance of each tile's centre from the image centre, ties broken by
/// row then column), so a preview fills in from where the subject usually is.
pub fn split_centre_first(width: u32, height: u32, size: u32) -> Vec<TileRect> {
    let size = size.max(1);
    let mut tiles = Vec::new();
    let mut y = 0;
    while y < height {
        let mut x = 0;
        while x < width {
            tiles.push(TileRect {
                x,
                y,
                width: size.min(width - x),
                height: size.min(height - y),
            });
            x += size;
        }
        y += size;
    }
    // Twice the centre distance, in integers, so the order is exact and platform-independent.
    let key = |t: &TileRect| {
        let dx = (2 * t.x + t.width) as i64 - width as i64;
        let dy = (2 * t.y + t.height) as i64 - height as i64;
        (dx * dx + dy * dy, t.y, t.x)
    };
    tiles.sort_by_key(key);
    tiles
}

/// The tiles of `window`, a rectangle of the film, in film coordinates: the window split as
/// [`split_centre_first`] splits an image of its size (so centre-first about the window's
/// centre), each tile moved by the window's origin. A crop (`--crop`) is rendered as these
/// tiles, on the farm and in process alike; a full frame's window is the film at (0, 0).
pub fn split_window_centre_first(window: TileRect, size: u32) -> Vec<TileRect> {
    split_centre_first(window.width, window.height, size)
        .into_iter()
        .map(|t| TileRect {
            x: window.x + t.x,
            y: window.y + t.y,
            ..t
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn window_tiles_cover_exactly_the_window_in_film_coordinates() {
        let (film_w, film_h) = (50u32, 40u32);
        let window = TileRect {
            x: 7,
            y: 11,
            width: 30,
            height: 17,
        };
        let mut hits = vec![0u32; (film_w * film_h) as usize];
        for t in split_window_centre_first(window, 8) {
            for row in t.y..t.y + t.height {
                for col in t.x..t.x + t.width {
                    hits[(row * film_w + col) as usize] += 1;
                }
            }
        }
        for row in 0..film_h {
            for col in 0..film_w {
                let inside = (7..37).contains(&col) && (11..28).contains(&row);
                assert_eq!(
                    hits[(row * film_w + col) as usize],
                    u32::from(inside),
                    "{col},{row}"
                );
            }
        }
        // The window at the origin of a film of its size is the whole frame's tiling.
        let full = TileRect {
            x: 0,
            y: 0,
            width: 33,
            height: 65,
        };
        assert_eq!(
            split_window_centre_first(full, 16),
            split_centre_first(33, 65, 16)
        );
    }

    #[test]
    fn tiles_cover_every_pixel_exactly_once() {
        for (w, h, s) in [
            (1, 1, 32),
            (100, 37, 32),
            (64, 64, 16),
            (33, 65, 64),
            (7, 300, 5),
        ] {
            let mut hits = vec![0u32; (w * h) as usize];
            for t in split_centre_first(w, h, s) {
                assert!(t.width >= 1 && t.height >= 1 && t.width <= s && t.height <= s);
                for row in t.y..t.y + t.height {
                    for col in t.x..t.x + t.width {
                        hits[(row * w + col) as usize] += 1;
                    }
                }
            }
            assert!(hits.iter().all(|&n| n == 1), "{w}x{h} tile {s}");
        }
    }

    #[test]
    fn first_tile_holds_the_centre() {
        let tiles = split_centre_first(256, 128, 32);
        let t = tiles[0];
        let (cx, cy) = (128, 64);
        assert!(t.x <= cx && cx <= t.x + t.width && t.y <= cy && cy <= t.y + t.height);
    }

    #[test]
    fn pixels_beyond_f32_are_refused_with_their_index_and_finite_ones_kept_exactly() {
        let rect = TileRect {
            x: 0,
            y: 0,
            width: 1,
            height: 1,
        };
        let mut tile = TilePixels::black(rect);
        tile.total = vec![f32::MAX, f32::MIN_POSITIVE, f32::from_bits(1)];
        tile.surface = vec![0.1, -0.0, 3.0e38];
        let json = serde_json::to_string(&tile).unwrap();
        let back: TilePixels = serde_json::from_str(&json).unwrap();
        for (a, b) in tile.layers().iter().zip(back.layers()) {
            let bits = |l: &[f32]| l.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(a), bits(b));
        }

        let mut value = serde_json::to_value(&tile).unwrap();
        value["surface"][2] = serde_json::json!(1e39);
        let err = serde_json::from_value::<TilePixels>(value)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("value 2 is 1e39, beyond the range of 32-bit floats"),
            "{err}"
        );
    }

    #[test]
    fn a_tile_cut_into_bands_and_stacked_again_is_the_same_tile() {
        let rect = TileRect {
            x: 3,
            y: 5,
            width: 2,
            height: 5,
        };
        let mut tile = TilePixels::black(rect);
        for (i, v) in tile.total.iter_mut().enumerate() {
            *v = i as f32;
        }
        tile.stderr[7] = 0.25;
        tile.alpha[4] = 0.5;
        tile.progress = Some(TileProgress {
            pass: 2,
            spp: 32,
            pixels: (0..10)
                .map(|taken| crate::passes::PixelSums {
                    taken,
                    ..Default::default()
                })
                .collect(),
        });
        assert_eq!(
            rect.rows(3, 9),
            TileRect {
                x: 3,
                y: 8,
                width: 2,
                height: 2
            }
        );
        let band = tile.band(1, 2);
        assert_eq!(band.rect, rect.rows(1, 2));
        assert_eq!(band.total, (6..18).map(|v| v as f32).collect::<Vec<_>>());
        assert_eq!(band.progress.as_ref().unwrap().pixels[0].taken, 2);
        // Alpha has one value per pixel: pixels 2..6 of the tile.
        assert_eq!(band.alpha, [0.0, 0.0, 0.5, 0.0]);
        let bands = vec![tile.band(0, 1), tile.band(1, 2), tile.band(3, 2)];
        assert_eq!(TilePixels::stack(bands), tile);
        let mut one_pass = tile.clone();
        one_pass.progress = None;
        assert_eq!(TilePixels::stack(vec![one_pass.band(0, 5)]), one_pass);
    }

    #[test]
    fn a_rectangle_reads_as_words() {
        let rect = TileRect {
            x: 0,
            y: 64,
            width: 32,
            height: 16,
        };
        assert_eq!(rect.to_string(), "32 × 16 pixels at x 0, y 64");
    }
}
