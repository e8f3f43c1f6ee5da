//! The finished image: the layers of a frame or of a window of it (a crop), and the files
//! spindle writes.
//!
//! Tiles arrive from anywhere (the coordinator takes them from workers over the network, so a
//! tile is untrusted until checked) and are placed into an [`Image`]; the image is then written
//! as one OpenEXR file with a channel group per layer, and as a tone-mapped PNG preview.
//!
//! Conventions, stated once:
//! - Pixels are `f32`, row-major, row 0 at the top, the same layout as [`TilePixels`]:
//!   sample `(row * width + col) * 3 + channel` of an RGB layer, `row * width + col` of `alpha`.
//! - An image holds a window of its film ([`Placement`]): the whole film, or a crop. Tiles are
//!   in film coordinates. In the EXR file the film is the display window and the image the
//!   data window (OpenEXR's own notion of a crop, as pbrt-v4 writes one), so a viewer shows a
//!   crop in its place in the frame; the PNG previews hold the window only.
//! - The EXR file is one part, scanlines in increasing order, ZIP compression (16 lines per
//!   block), channels `R,G,B` (= `total`) and `A` (= `alpha`, the coverage a compositor
//!   comps the element over a plate with; the colour is the renderer's mean over samples, so
//!   with the default black `background` it is premultiplied by `A` as OpenEXR expects — a
//!   sample that misses every object adds nothing — and a non-black background is in it),
//!   `surface.R/G/B`, `single_scatter.R/G/B`, `multiple_scatter.R/G/B` and `stderr.R/G/B`,
//!   then the optional passes the image holds (`Z`, `normal.X/Y/Z`, `albedo.R/G/B`, `id.id`:
//!   [`crate::aov`]), all 32-bit float (or all
//!   16-bit half floats with [`Precision::Half`], `film.half`: half the size, about three
//!   significant digits, values above 65504 become infinite; `id.id` stays 32-bit), and one
//!   text header attribute (UTF-8) per entry of [`Image::attributes`], beside the standard
//!   attributes of [`Image::standard`] (`software`, `worldToCamera`, `worldToNDC`,
//!   `renderTime`).
//! - The bytes of a file are a pure function of the image: no timestamps but the image's own
//!   `renderTime`, and header attributes are written sorted by name (as OpenEXR's own library
//!   does), so the same image always gives the same bytes.
//! - Files are written with [`atomic_write::write`], so a crash never leaves a half-written
//!   file under the final name.
//! - Non-finite samples (NaN, ±inf) are written as they are.

use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::Path;

use crate::aov::{Aov, AovSet};
use crate::atomic_write;
use crate::tile::{LAYERS, TilePixels, TileRect};

/// A bad tile, a bad image or a failed read or write.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// The tile does not lie inside the image's window of the film.
    #[error(
        "the tile of {rect} lies outside the image's window of the film, {window} (it must \
         satisfy window.x <= x, x + width <= window.x + window.width, and the same for y)"
    )]
    TileOutside { rect: TileRect, window: TileRect },
    /// The image's window does not lie inside its film.
    #[error(
        "the window of {window} is not inside the {film_width}x{film_height} film (x + width \
         must be <= {film_width} and y + height <= {film_height})"
    )]
    WindowOutside {
        window: TileRect,
        film_width: u32,
        film_height: u32,
    },
    /// The tile covers no pixel.
    #[error("the tile of {rect} is empty (width and height must be >= 1)")]
    EmptyTile { rect: TileRect },
    /// A layer buffer of a tile or an image has the wrong number of samples.
    #[error("layer `{layer}` has {actual} samples, expected {expected} (3 per pixel)")]
    BufferLength {
        layer: &'static str,
        expected: usize,
        actual: usize,
    },
    /// The optional passes of a tile or an image have the wrong number of values.
    #[error(
        "the optional passes (`film.passes`: {passes}) have {actual} values, expected {expected}"
    )]
    PassLength {
        passes: String,
        expected: usize,
        actual: usize,
    },
    /// The image has no pixels, so there is nothing to write.
    #[error("the image is empty ({width}x{height}); width and height must be >= 1")]
    EmptyImage { width: u32, height: u32 },
    /// A header attribute cannot be stored in an EXR file.
    #[error("header attribute `{name}`: {problem}")]
    Attribute { name: String, problem: String },
    /// The EXR library refused to write or read, or the file is not a spindle EXR.
    #[error("EXR {path}: {problem}")]
    Exr { path: String, problem: String },
    /// The PNG encoder failed.
    #[error("PNG {path}: {problem}")]
    Png { path: String, problem: String },
    /// A file could not be read, written or renamed.
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
}

/// The EXR channels of each layer, in [`LAYERS`] order. `total` is the plain, ungrouped
/// `R,G,B` and `alpha` its `A`, so any viewer shows them by default.
const EXR_CHANNELS: [&[&str]; 6] = [
    &["R", "G", "B"],
    &["surface.R", "surface.G", "surface.B"],
    &["single_scatter.R", "single_scatter.G", "single_scatter.B"],
    &[
        "multiple_scatter.R",
        "multiple_scatter.G",
        "multiple_scatter.B",
    ],
    &["stderr.R", "stderr.G", "stderr.B"],
    &["A"],
];

/// Where an image's pixels lie in the film they were rendered from: the film's size (the EXR
/// display window) and the column and row of the image's top-left pixel in it (the origin of
/// the EXR data window). A full frame is at (0, 0) of a film of its own size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Placement {
    pub x: u32,
    pub y: u32,
    pub film_width: u32,
    pub film_height: u32,
}

/// The standard OpenEXR header attributes spindle writes (typed, unlike [`Image::attributes`]),
/// each absent until set.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StandardAttributes {
    /// `software`: the program that wrote the image, `spindle <version>`.
    pub software: Option<String>,
    /// `worldToCamera` and `worldToNDC` (m44f, row after row, as
    /// [`crate::camera_matrices`] defines them).
    pub world_to_camera: Option<[f32; 16]>,
    pub world_to_ndc: Option<[f32; 16]>,
    /// `renderTime`: the render's wall-clock seconds (a float attribute, the name V-Ray and
    /// others write). It differs from run to run, so it is kept apart from the attributes that
    /// say what the pixels are.
    pub render_time: Option<f32>,
}

/// The name of the render-time attribute: not one of OpenEXR's standard names, but the one
/// renderers commonly write and compositors show.
const RENDER_TIME: &str = "renderTime";

/// The sample type of every channel of the EXR file.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Precision {
    /// 32-bit floats: the renderer's values exactly.
    #[default]
    Float,
    /// 16-bit half floats (`film.half`): each value rounded to the nearest half.
    Half,
}

/// A window of a frame (the whole frame, or a crop): the layers of its pixels, where it lies
/// in the film, and attributes for the file header.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// The size of the window (the pixels the layers hold).
    pub width: u32,
    pub height: u32,
    /// Where the window lies in the film.
    pub placement: Placement,
    /// `surface + single_scatter + multiple_scatter`, RGB, row-major.
    pub total: Vec<f32>,
    /// Reflected and transmitted light, RGB, row-major.
    pub surface: Vec<f32>,
    /// Single scattering inside media, RGB, row-major.
    pub single_scatter: Vec<f32>,
    /// Light scattered twice or more inside media, RGB, row-major.
    pub multiple_scatter: Vec<f32>,
    /// The standard error of each pixel's `total`, estimated from its samples, RGB, row-major.
    pub stderr: Vec<f32>,
    /// The coverage of objects against the background, one value per pixel, row-major.
    pub alpha: Vec<f32>,
    /// The optional passes the image holds (`film.passes`; none by default).
    pub passes: AovSet,
    /// Their values, `passes.values_per_pixel()` per pixel, row-major, as
    /// [`TilePixels::aov`] holds them.
    pub aov: Vec<f32>,
    /// Written as text attributes of the EXR header (e.g. `spindle.spp` = `64`).
    pub attributes: BTreeMap<String, String>,
    /// Standard attributes of the EXR header.
    pub standard: StandardAttributes,
    /// How the EXR file stores the samples.
    pub precision: Precision,
}

impl Image {
    /// A black full-frame `width` × `height` image with no attributes.
    pub fn new(width: u32, height: u32) -> Image {
        let n = width as usize * height as usize * 3;
        Image {
            width,
            height,
            placement: Placement {
                x: 0,
                y: 0,
                film_width: width,
                film_height: height,
            },
            total: vec![0.0; n],
            surface: vec![0.0; n],
            single_scatter: vec![0.0; n],
            multiple_scatter: vec![0.0; n],
            stderr: vec![0.0; n],
            alpha: vec![0.0; n / 3],
            passes: AovSet::NONE,
            aov: Vec::new(),
            attributes: BTreeMap::new(),
            standard: StandardAttributes::default(),
            precision: Precision::Float,
        }
    }

    /// A black image of `window`, a rectangle of a `film_width` × `film_height` film, with no
    /// attributes; tiles are then inserted in film coordinates. The window must lie inside the
    /// film.
    pub fn window(
        film_width: u32,
        film_height: u32,
        window: TileRect,
    ) -> Result<Image, ImageError> {
        let image = Image {
            placement: Placement {
                x: window.x,
                y: window.y,
                film_width,
                film_height,
            },
            ..Image::new(window.width, window.height)
        };
        image.check_placement()?;
        Ok(image)
    }

    /// The same image holding the optional passes `passes` too (all zero), which every tile
    /// inserted must then carry.
    pub fn with_passes(mut self, passes: AovSet) -> Image {
        self.passes = passes;
        self.aov = vec![0.0; self.pixel_count() * passes.values_per_pixel()];
        self
    }

    /// The rectangle of the film this image holds, in film coordinates.
    pub fn rect(&self) -> TileRect {
        TileRect {
            x: self.placement.x,
            y: self.placement.y,
            width: self.width,
            height: self.height,
        }
    }

    /// Checks that the window lies inside the film.
    fn check_placement(&self) -> Result<(), ImageError> {
        let p = self.placement;
        // u64 so that x + width cannot wrap around.
        let inside = u64::from(p.x) + u64::from(self.width) <= u64::from(p.film_width)
            && u64::from(p.y) + u64::from(self.height) <= u64::from(p.film_height);
        if inside {
            Ok(())
        } else {
            Err(ImageError::WindowOutside {
                window: self.rect(),
                film_width: p.film_width,
                film_height: p.film_height,
            })
        }
    }

    /// Pixels in the image.
    fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
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

    fn layers_mut(&mut self) -> [&mut Vec<f32>; 6] {
        [
            &mut self.total,
            &mut self.surface,
            &mut self.single_scatter,
            &mut self.multiple_scatter,
            &mut self.stderr,
            &mut self.alpha,
        ]
    }

    /// Copies a rendered tile (in film coordinates) into its place. The tile is checked first
    /// (it may come from the network): it must be non-empty, lie inside the image's window, and
    /// carry exactly its layer's channels per pixel in each layer; otherwise the image is left
    /// unchanged.
    pub fn insert_tile(&mut self, tile: &TilePixels) -> Result<(), ImageError> {
        self.check_buffers()?;
        let rect = tile.rect;
        if rect.width == 0 || rect.height == 0 {
            return Err(ImageError::EmptyTile { rect });
        }
        // u64 so that a hostile x + width cannot wrap around.
        let window = self.rect();
        let inside = window.x <= rect.x
            && window.y <= rect.y
            && u64::from(rect.x) + u64::from(rect.width)
                <= u64::from(window.x) + u64::from(window.width)
            && u64::from(rect.y) + u64::from(rect.height)
                <= u64::from(window.y) + u64::from(window.height);
        if !inside {
            return Err(ImageError::TileOutside { rect, window });
        }
        // The tile's origin in the image's own pixels.
        let (left, top) = ((rect.x - window.x) as usize, (rect.y - window.y) as usize);
        for (layer, samples) in LAYERS.iter().zip(tile.layers()) {
            let expected = rect.pixel_count() * layer.channels;
            if samples.len() != expected {
                return Err(ImageError::BufferLength {
                    layer: layer.name,
                    expected,
                    actual: samples.len(),
                });
            }
        }

        let aov_channels = self.passes.values_per_pixel();
        let expected = rect.pixel_count() * aov_channels;
        if tile.aov.len() != expected {
            return Err(ImageError::PassLength {
                passes: self.passes_named(),
                expected,
                actual: tile.aov.len(),
            });
        }

        let image_width = self.width as usize;
        let copy = |channels: usize, dst: &mut [f32], src: &[f32]| {
            let row_len = rect.width as usize * channels;
            for row in 0..rect.height as usize {
                let start = ((top + row) * image_width + left) * channels;
                dst[start..start + row_len].copy_from_slice(&src[row * row_len..][..row_len]);
            }
        };
        for ((layer, dst), src) in LAYERS.iter().zip(self.layers_mut()).zip(tile.layers()) {
            copy(layer.channels, dst, src);
        }
        copy(aov_channels, &mut self.aov, &tile.aov);
        Ok(())
    }

    /// The number of pixels with a NaN or infinite sample in any layer.
    #[cfg(test)]
    pub fn non_finite_count(&self) -> usize {
        (0..self.pixel_count())
            .filter(|&p| {
                LAYERS.iter().zip(self.layers()).any(|(kind, layer)| {
                    let n = kind.channels;
                    layer
                        .get(p * n..p * n + n)
                        .is_some_and(|s| s.iter().any(|v| !v.is_finite()))
                })
            })
            .count()
    }

    /// Checks that every layer holds exactly its channels per pixel (the fields are public, so
    /// a caller may have changed one).
    fn check_buffers(&self) -> Result<(), ImageError> {
        for (layer, samples) in LAYERS.iter().zip(self.layers()) {
            let expected = self.pixel_count() * layer.channels;
            if samples.len() != expected {
                return Err(ImageError::BufferLength {
                    layer: layer.name,
                    expected,
                    actual: samples.len(),
                });
            }
        }
        let expected = self.pixel_count() * self.passes.values_per_pixel();
        if self.aov.len() != expected {
            return Err(ImageError::PassLength {
                passes: self.passes_named(),
                expected,
                actual: self.aov.len(),
            });
        }
        Ok(())
    }

    /// The image's passes as `film.passes` lists them (`depth, id`), or `none`.
    fn passes_named(&self) -> String {
        let names: Vec<_> = self.passes.iter().map(|a| a.name()).collect();
        if names.is_empty() {
            "none".into()
        } else {
            names.join(", ")
        }
    }

    fn check_writable(&self) -> Result<(), ImageError> {
        if self.width == 0 || self.height == 0 {
            return Err(ImageError::EmptyImage {
                width: self.width,
                height: self.height,
            });
        }
        self.check_placement()?;
        if i32::try_from(self.placement.film_width).is_err()
            || i32::try_from(self.placement.film_height).is_err()
        {
            // EXR windows are i32 rectangles.
            return Err(ImageError::WindowOutside {
                window: self.rect(),
                film_width: self.placement.film_width,
                film_height: self.placement.film_height,
            });
        }
        self.check_buffers()
    }

    /// The complete EXR file as bytes (see the module documentation for its layout).
    pub fn to_exr_bytes(&self) -> Result<Vec<u8>, ImageError> {
        use exr::prelude::{
            AnyChannel, AnyChannels, Blocks, Compression, Encoding, FlatSamples, ImageAttributes,
            IntegerBounds, Layer, LayerAttributes, LineOrder, Vec2, WritableImage,
        };

        self.check_writable()?;
        let exr_error = |e: exr::error::Error| ImageError::Exr {
            path: "(in memory)".into(),
            problem: e.to_string(),
        };

        // The data window starts at the image's place in the film (check_writable: both fit i32).
        let standard = &self.standard;
        let mut attributes = LayerAttributes {
            layer_position: Vec2(self.placement.x as i32, self.placement.y as i32),
            software_name: standard.software.as_deref().map(text),
            world_to_camera: standard.world_to_camera,
            world_to_normalized_device: standard.world_to_ndc,
            ..LayerAttributes::default()
        };
        for (name, value) in &self.attributes {
            if name == RENDER_TIME {
                return Err(ImageError::Attribute {
                    name: name.clone(),
                    problem: "is written from `standard.render_time`".into(),
                });
            }
            let (name, value) = exr_attribute(name, value)?;
            attributes.other.insert(name, value);
        }
        if let Some(seconds) = standard.render_time {
            attributes.other.insert(
                text(RENDER_TIME),
                exr::prelude::AttributeValue::F32(seconds),
            );
        }

        // One plane per channel, taken out of the interleaved layers.
        let pixels = self.pixel_count();
        let mut channels = smallvec_of_channels();
        for (names, layer) in EXR_CHANNELS.iter().zip(self.layers()) {
            let n = names.len();
            for (c, name) in names.iter().enumerate() {
                let plane = (0..pixels).map(|p| layer[p * n + c]);
                let samples = match self.precision {
                    Precision::Float => FlatSamples::F32(plane.collect()),
                    Precision::Half => {
                        FlatSamples::F16(plane.map(exr::prelude::f16::from_f32).collect())
                    }
                };
                channels.push(AnyChannel::new(*name, samples));
            }
        }
        let n = self.passes.values_per_pixel();
        for (c, (aov, name)) in self.passes.exr_channels().enumerate() {
            let plane = (0..pixels).map(|p| self.aov[p * n + c]);
            // An id is a number, not a measure: 32-bit always, so every id stays exact.
            let samples = match self.precision {
                _ if aov == Aov::Id => FlatSamples::F32(plane.collect()),
                Precision::Float => FlatSamples::F32(plane.collect()),
                Precision::Half => {
                    FlatSamples::F16(plane.map(exr::prelude::f16::from_f32).collect())
                }
            };
            channels.push(AnyChannel::new(name, samples));
        }

        let encoding = Encoding {
            compression: Compression::ZIP16,
            blocks: Blocks::ScanLines,
            // Increasing order makes the parallel compressor write blocks in file order.
            line_order: LineOrder::Increasing,
        };
        let layer = Layer::new(
            (self.width as usize, self.height as usize),
            attributes,
            encoding,
            AnyChannels::sort(channels),
        );
        // The display window is the film, at the origin; for a full frame it equals the data
        // window, as `Image::from_layer` would write it.
        let film = IntegerBounds::from_dimensions((
            self.placement.film_width as usize,
            self.placement.film_height as usize,
        ));
        let mut out = Cursor::new(Vec::new());
        exr::prelude::Image::new(ImageAttributes::new(film), layer)
            .write()
            .to_buffered(&mut out)
            .map_err(exr_error)?;
        let mut bytes = out.into_inner();
        sort_exr_header_attributes(&mut bytes)?;
        Ok(bytes)
    }

    /// Writes the image as an OpenEXR file, atomically.
    pub fn write_exr(&self, path: impl AsRef<Path>) -> Result<(), ImageError> {
        let path = path.as_ref();
        let bytes = self.to_exr_bytes().map_err(|e| match e {
            ImageError::Exr { problem, .. } => ImageError::Exr {
                path: path.display().to_string(),
                problem,
            },
            other => other,
        })?;
        write_file(path, &bytes)
    }

    /// Reads an EXR file written by [`Image::write_exr`] (or any one-part EXR with the same
    /// float channels; without the `stderr` or `multiple_scatter` ones, as spindle wrote before
    /// those layers, they are 0; without `A`, as spindle wrote before alpha, `alpha` is 1, opaque, as viewers show
    /// an image without alpha), with its text header attributes and its place in the film (the
    /// data window inside the display window).
    pub fn from_exr_bytes(bytes: &[u8]) -> Result<Image, ImageError> {
        read_exr_from(bytes, "(in memory)")
    }

    /// The `total` layer tone-mapped to an 8-bit sRGB PNG (see [`preview_pixel`]).
    pub fn to_png_preview_bytes(&self) -> Result<Vec<u8>, ImageError> {
        self.check_writable()?;
        let data: Vec<u8> = self.total.iter().map(|&v| preview_pixel(v)).collect();
        self.encode_png(&data)
    }

    /// The relative standard error `stderr / total` of each pixel and channel as an 8-bit sRGB
    /// PNG: black where it is 0, white at [`RELATIVE_ERROR_WHITE`] or more (see
    /// [`relative_error_pixel`]), so noise shows where it is.
    pub fn to_png_relative_error_bytes(&self) -> Result<Vec<u8>, ImageError> {
        self.check_writable()?;
        let data: Vec<u8> = self
            .stderr
            .iter()
            .zip(&self.total)
            .map(|(&e, &t)| relative_error_pixel(e, t))
            .collect();
        self.encode_png(&data)
    }

    /// Writes [`Image::to_png_relative_error_bytes`], atomically.
    pub fn write_png_relative_error(&self, path: impl AsRef<Path>) -> Result<(), ImageError> {
        write_png(path.as_ref(), self.to_png_relative_error_bytes())
    }

    /// RGB bytes of this image's size as an 8-bit sRGB PNG.
    fn encode_png(&self, data: &[u8]) -> Result<Vec<u8>, ImageError> {
        let png_error = |e: png::EncodingError| ImageError::Png {
            path: "(in memory)".into(),
            problem: e.to_string(),
        };
        let mut out = Vec::new();
        let mut encoder = png::Encoder::new(&mut out, self.width, self.height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = encoder.write_header().map_err(png_error)?;
        writer.write_image_data(data).map_err(png_error)?;
        writer.finish().map_err(png_error)?;
        Ok(out)
    }

    /// Writes the PNG preview of the `total` layer, atomically.
    pub fn write_png_preview(&self, path: impl AsRef<Path>) -> Result<(), ImageError> {
        write_png(path.as_ref(), self.to_png_preview_bytes())
    }
}

/// Writes encoded PNG bytes to `path` atomically, naming `path` in an encoding error.
fn write_png(path: &Path, bytes: Result<Vec<u8>, ImageError>) -> Result<(), ImageError> {
    let bytes = bytes.map_err(|e| match e {
        ImageError::Png { problem, .. } => ImageError::Png {
            path: path.display().to_string(),
            problem,
        },
        other => other,
    })?;
    write_file(path, &bytes)
}

/// Reads an EXR file written by [`Image::write_exr`]; see [`Image::from_exr_bytes`].
pub fn read_exr(path: impl AsRef<Path>) -> Result<Image, ImageError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| ImageError::Io {
        path: path.display().to_string(),
        source,
    })?;
    read_exr_from(&bytes, &path.display().to_string())
}

/// The relative standard error shown white by [`Image::to_png_relative_error_bytes`].
pub const RELATIVE_ERROR_WHITE: f32 = 0.1;

/// One channel of the relative-error PNG: `stderr / |total|` over [`RELATIVE_ERROR_WHITE`],
/// clamped to [0, 1] and sRGB-encoded like the preview; a black pixel with no error is black, one
/// with error (or a non-finite value) white.
pub fn relative_error_pixel(stderr: f32, total: f32) -> u8 {
    let relative = if stderr == 0.0 {
        0.0
    } else if total != 0.0 && (stderr / total).is_finite() {
        (stderr / total).abs() / RELATIVE_ERROR_WHITE
    } else {
        1.0
    };
    preview_pixel(relative.min(1.0))
}

/// The preview's tone map for one linear sample: clamp to [0, 1] at exposure 1 (no curve, so a
/// radiance in [0, 1] keeps its value), then the sRGB transfer function, rounded to 8 bits.
/// NaN and negative values show black, +inf white.
pub fn preview_pixel(linear: f32) -> u8 {
    let x = if linear.is_nan() {
        0.0
    } else {
        f64::from(linear).clamp(0.0, 1.0)
    };
    let srgb = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (srgb * 255.0 + 0.5).floor() as u8
}

fn smallvec_of_channels()
-> exr::prelude::SmallVec<[exr::prelude::AnyChannel<exr::prelude::FlatSamples>; 4]> {
    exr::prelude::SmallVec::new()
}

/// Checks one header attribute and converts it to the EXR library's types.
fn exr_attribute(
    name: &str,
    value: &str,
) -> Result<(exr::prelude::Text, exr::prelude::AttributeValue), ImageError> {
    let bad = |problem: &str| ImageError::Attribute {
        name: name.to_string(),
        problem: problem.to_string(),
    };
    if name.is_empty() {
        return Err(bad("the name must not be empty"));
    }
    if name.len() > 255 {
        return Err(bad("the name must be at most 255 bytes long"));
    }
    if name.contains('\0') {
        return Err(bad("the name must not contain a NUL character"));
    }
    if exr::meta::header::standard_names::ALL.contains(&name.as_bytes()) {
        return Err(bad(
            "the name is a standard OpenEXR attribute; choose another (e.g. prefix it `spindle.`)",
        ));
    }
    let (name_text, value_text) = (text(name), text(value));
    Ok((name_text, exr::prelude::AttributeValue::Text(value_text)))
}

/// EXR text of a string. EXR text is a byte string; we store UTF-8, as OpenEXR tools commonly
/// expect, so any value (a file path, a warning with an η in it) can be recorded.
fn text(s: &str) -> exr::prelude::Text {
    exr::prelude::Text::from_slice_unchecked(s.as_bytes())
}

/// Rewrites the header of a one-part EXR file with its attributes sorted by name. The EXR
/// library keeps custom attributes in a hash map, so it writes them in an order that changes
/// from run to run; sorting makes the bytes a function of the image. The header keeps its
/// length, so the offset table after it stays valid.
fn sort_exr_header_attributes(bytes: &mut [u8]) -> Result<(), ImageError> {
    let malformed = |what: &str| ImageError::Exr {
        path: "(in memory)".into(),
        problem: format!("unexpected header written by the EXR library: {what}"),
    };
    const MULTIPART_OR_DEEP: u32 = 0x1000 | 0x800;
    if bytes.len() < 8 || bytes[..4] != [0x76, 0x2f, 0x31, 0x01] {
        return Err(malformed("no magic number"));
    }
    let version = u32::from_le_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]);
    if version & MULTIPART_OR_DEEP != 0 {
        return Err(malformed("not a single-part flat file"));
    }

    // Each attribute: name NUL, type NUL, i32 size, value. A lone NUL ends the header.
    let start = 8;
    let mut attributes: Vec<&[u8]> = Vec::new();
    let mut at = start;
    let nul_after = |from: usize| {
        bytes
            .get(from..)
            .and_then(|rest| rest.iter().position(|&b| b == 0))
            .map(|i| from + i)
    };
    loop {
        let name_end = nul_after(at).ok_or_else(|| malformed("unterminated attribute name"))?;
        if name_end == at {
            break;
        }
        let type_end =
            nul_after(name_end + 1).ok_or_else(|| malformed("unterminated attribute type"))?;
        let size_bytes = bytes
            .get(type_end + 1..type_end + 5)
            .ok_or_else(|| malformed("truncated attribute size"))?;
        let size = i32::from_le_bytes([size_bytes[0], size_bytes[1], size_bytes[2], size_bytes[3]]);
        let size = usize::try_from(size).map_err(|_| malformed("negative attribute size"))?;
        let end = type_end + 5 + size;
        if end > bytes.len() {
            return Err(malformed("attribute runs past the end"));
        }
        attributes.push(&bytes[at..end]);
        at = end;
    }
    let header_end = at;

    // Attribute names are unique, so sorting the whole records sorts by name.
    let name_of = |a: &[u8]| a[..a.iter().position(|&b| b == 0).unwrap_or(a.len())].to_vec();
    attributes.sort_by_key(|a| name_of(a));
    let sorted: Vec<u8> = attributes.concat();
    bytes[start..header_end].copy_from_slice(&sorted);
    Ok(())
}

fn read_exr_from(bytes: &[u8], path: &str) -> Result<Image, ImageError> {
    use exr::prelude::{AttributeValue, ReadChannels, ReadLayers};

    let exr_error = |problem: String| ImageError::Exr {
        path: path.to_string(),
        problem,
    };
    let file = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| exr_error(e.to_string()))?;

    let layer = &file.layer_data;
    let (width, height) = (layer.size.width(), layer.size.height());
    let (Ok(w), Ok(h)) = (u32::try_from(width), u32::try_from(height)) else {
        return Err(exr_error(format!(
            "image size {width}x{height} is too large"
        )));
    };
    // The data window's place in the display window (the film).
    let display = file.attributes.display_window;
    let position = layer.attributes.layer_position;
    let placement = (|| {
        Some(Placement {
            x: u32::try_from(position.x().checked_sub(display.position.x())?).ok()?,
            y: u32::try_from(position.y().checked_sub(display.position.y())?).ok()?,
            film_width: u32::try_from(display.size.width()).ok()?,
            film_height: u32::try_from(display.size.height()).ok()?,
        })
    })();
    let mut image = Image::new(w, h);
    image.placement = placement.ok_or_else(|| {
        exr_error("the data window does not start inside the display window".into())
    })?;
    image.check_placement().map_err(|e| {
        exr_error(format!(
            "the data window is not inside the display window: {e}"
        ))
    })?;
    let pixels = width * height;

    let mut precision = Precision::Float;
    for (names, dst) in EXR_CHANNELS.iter().zip(image.layers_mut()) {
        let n = names.len();
        for (c, name) in names.iter().enumerate() {
            let found = layer.channel_data.list.iter().find(|ch| ch.name.eq(name));
            let channel = match found {
                Some(channel) => channel,
                // Files written before the `stderr` layer existed have none: it reads as 0.
                None if name.starts_with("stderr.") => continue,
                // Files written before multiple scattering have none: it reads as 0.
                None if name.starts_with("multiple_scatter.") => continue,
                // Files written before alpha have none: opaque.
                None if *name == "A" => {
                    dst.fill(1.0);
                    continue;
                }
                None => return Err(exr_error(format!("no channel `{name}`"))),
            };
            let samples: Vec<f32> = match &channel.sample_data {
                exr::prelude::FlatSamples::F32(samples) => samples.clone(),
                exr::prelude::FlatSamples::F16(samples) => {
                    if *name == "R" {
                        precision = Precision::Half;
                    }
                    samples.iter().map(|v| v.to_f32()).collect()
                }
                exr::prelude::FlatSamples::U32(_) => {
                    return Err(exr_error(format!("channel `{name}` is not floating point")));
                }
            };
            if samples.len() != pixels {
                return Err(exr_error(format!("channel `{name}` has the wrong size")));
            }
            for (p, v) in samples.iter().enumerate() {
                dst[p * n + c] = *v;
            }
        }
    }

    for (name, value) in file
        .attributes
        .other
        .iter()
        .chain(layer.attributes.other.iter())
    {
        match value {
            AttributeValue::F32(seconds) if name.eq(RENDER_TIME) => {
                image.standard.render_time = Some(*seconds);
            }
            AttributeValue::Text(text) => {
                image
                    .attributes
                    .insert(text_to_string(name), text_to_string(text));
            }
            _ => {}
        }
    }
    read_passes(layer, &mut image, &exr_error)?;
    image.precision = precision;
    let standard = &layer.attributes;
    image.standard.software = standard.software_name.as_ref().map(text_to_string);
    image.standard.world_to_camera = standard.world_to_camera;
    image.standard.world_to_ndc = standard.world_to_normalized_device;
    Ok(image)
}

/// Reads the optional passes whose channels are all in the file (a pass with some of its
/// channels missing is an error) into `image`.
fn read_passes(
    layer: &exr::prelude::Layer<exr::prelude::AnyChannels<exr::prelude::FlatSamples>>,
    image: &mut Image,
    exr_error: &dyn Fn(String) -> ImageError,
) -> Result<(), ImageError> {
    let find = |name: &str| layer.channel_data.list.iter().find(|ch| ch.name.eq(name));
    let mut present = Vec::new();
    for aov in Aov::ALL {
        let found = aov
            .exr_channels()
            .iter()
            .filter(|n| find(n).is_some())
            .count();
        if found == aov.channels() {
            present.push(aov);
        } else if found > 0 {
            return Err(exr_error(format!(
                "the `{}` pass has only {found} of its channels {:?}",
                aov.name(),
                aov.exr_channels()
            )));
        }
    }
    *image = std::mem::replace(image, Image::new(0, 0)).with_passes(AovSet::of(&present));
    let n = image.passes.values_per_pixel();
    let pixels = image.pixel_count();
    for (c, (_, name)) in image.passes.exr_channels().enumerate() {
        let Some(channel) = find(name) else { continue };
        let samples: Vec<f32> = match &channel.sample_data {
            exr::prelude::FlatSamples::F32(samples) => samples.clone(),
            exr::prelude::FlatSamples::F16(samples) => samples.iter().map(|v| v.to_f32()).collect(),
            exr::prelude::FlatSamples::U32(_) => {
                return Err(exr_error(format!("channel `{name}` is not floating point")));
            }
        };
        if samples.len() != pixels {
            return Err(exr_error(format!("channel `{name}` has the wrong size")));
        }
        for (p, v) in samples.iter().enumerate() {
            image.aov[p * n + c] = *v;
        }
    }
    Ok(())
}

/// EXR text as a string: UTF-8 as spindle writes it, or else Latin-1 (one byte per character,
/// the other common reading).
fn text_to_string(text: &exr::prelude::Text) -> String {
    match std::str::from_utf8(text.bytes()) {
        Ok(s) => s.to_string(),
        Err(_) => text.chars().collect(),
    }
}

/// Writes a finished file with [`atomic_write::write`], reporting a failure as [`ImageError::Io`].
fn write_file(path: &Path, bytes: &[u8]) -> Result<(), ImageError> {
    atomic_write::write(path, bytes).map_err(|e| ImageError::Io {
        path: path.display().to_string(),
        source: std::io::Error::new(e.source.kind(), format!("{}: {}", e.step, e.source)),
    })
}

#[cfg(test)]
mod tests;
