//! The finished image: the three layers of a whole frame, and the files spindle writes.
//!
//! Tiles arrive from anywhere (the coordinator takes them from workers over the network, so a
//! tile is untrusted until checked) and are placed into an [`Image`]; the image is then written
//! as one OpenEXR file with a channel group per layer, and as a tone-mapped PNG preview.
//!
//! Conventions, stated once:
//! - Pixels are RGB `f32`, row-major, row 0 at the top, the same layout as
//!   [`TilePixels`]: sample `(row * width + col) * 3 + channel`.
//! - The EXR file is one part, scanlines in increasing order, ZIP compression (16 lines per
//!   block), channels `R,G,B` (= `total`), `surface.R/G/B` and `single_scatter.R/G/B`, all
//!   32-bit float, and one text header attribute (UTF-8) per entry of [`Image::attributes`].
//! - The bytes of a file are a pure function of the image: no timestamps, and header
//!   attributes are written sorted by name (as OpenEXR's own library does), so the same image
//!   always gives the same bytes.
//! - Files are written with [`atomic_write::write`], so a crash never leaves a half-written
//!   file under the final name.
//! - Non-finite samples (NaN, ±inf) are written as they are; [`Image::non_finite_count`] lets a
//!   caller report them.

use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::Path;

use crate::atomic_write;
use crate::tile::{LAYER_NAMES, TilePixels, TileRect};

/// A bad tile, a bad image or a failed read or write.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// The tile does not lie inside the image.
    #[error(
        "tile {rect:?} lies outside the {width}x{height} image (it must satisfy x + width <= \
         {width} and y + height <= {height})"
    )]
    TileOutside {
        rect: TileRect,
        width: u32,
        height: u32,
    },
    /// The tile covers no pixel.
    #[error("tile {rect:?} is empty (width and height must be >= 1)")]
    EmptyTile { rect: TileRect },
    /// A layer buffer of a tile or an image has the wrong number of samples.
    #[error("layer `{layer}` has {actual} samples, expected {expected} (3 per pixel)")]
    BufferLength {
        layer: &'static str,
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

/// The EXR channel groups of each layer, in [`LAYER_NAMES`] order. `total` is the plain,
/// ungrouped `R,G,B`, so any viewer shows it by default.
const EXR_PREFIXES: [&str; 3] = ["", "surface.", "single_scatter."];
const RGB: [&str; 3] = ["R", "G", "B"];

/// A full frame: the three layers of every pixel, and text attributes for the file header.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// `surface + single_scatter`, RGB, row-major.
    pub total: Vec<f32>,
    /// Reflected and transmitted light, RGB, row-major.
    pub surface: Vec<f32>,
    /// Single scattering inside media, RGB, row-major.
    pub single_scatter: Vec<f32>,
    /// Written as text attributes of the EXR header (e.g. `spindle.spp` = `64`).
    pub attributes: BTreeMap<String, String>,
}

impl Image {
    /// A black `width` × `height` image with no attributes.
    pub fn new(width: u32, height: u32) -> Image {
        let n = width as usize * height as usize * 3;
        Image {
            width,
            height,
            total: vec![0.0; n],
            surface: vec![0.0; n],
            single_scatter: vec![0.0; n],
            attributes: BTreeMap::new(),
        }
    }

    /// Samples per layer: three per pixel.
    fn sample_count(&self) -> usize {
        self.width as usize * self.height as usize * 3
    }

    /// The layers in [`LAYER_NAMES`] order.
    pub fn layers(&self) -> [&[f32]; 3] {
        [&self.total, &self.surface, &self.single_scatter]
    }

    fn layers_mut(&mut self) -> [&mut Vec<f32>; 3] {
        [&mut self.total, &mut self.surface, &mut self.single_scatter]
    }

    /// Copies a rendered tile into its place. The tile is checked first (it may come from the
    /// network): it must be non-empty, lie inside the image, and carry exactly three samples
    /// per pixel in each layer; otherwise the image is left unchanged.
    pub fn insert_tile(&mut self, tile: &TilePixels) -> Result<(), ImageError> {
        self.check_buffers()?;
        let rect = tile.rect;
        if rect.width == 0 || rect.height == 0 {
            return Err(ImageError::EmptyTile { rect });
        }
        // u64 so that a hostile x + width cannot wrap around.
        let inside = u64::from(rect.x) + u64::from(rect.width) <= u64::from(self.width)
            && u64::from(rect.y) + u64::from(rect.height) <= u64::from(self.height);
        if !inside {
            return Err(ImageError::TileOutside {
                rect,
                width: self.width,
                height: self.height,
            });
        }
        let expected = rect.pixel_count() * 3;
        for (layer, samples) in LAYER_NAMES.iter().zip(tile.layers()) {
            if samples.len() != expected {
                return Err(ImageError::BufferLength {
                    layer,
                    expected,
                    actual: samples.len(),
                });
            }
        }

        let image_width = self.width as usize;
        let row_len = rect.width as usize * 3;
        for (dst, src) in self.layers_mut().into_iter().zip(tile.layers()) {
            for row in 0..rect.height as usize {
                let start = ((rect.y as usize + row) * image_width + rect.x as usize) * 3;
                dst[start..start + row_len].copy_from_slice(&src[row * row_len..][..row_len]);
            }
        }
        Ok(())
    }

    /// The number of pixels with a NaN or infinite sample in any layer.
    pub fn non_finite_count(&self) -> usize {
        let pixels = self.width as usize * self.height as usize;
        (0..pixels)
            .filter(|&p| {
                self.layers().iter().any(|layer| {
                    layer
                        .get(p * 3..p * 3 + 3)
                        .is_some_and(|s| s.iter().any(|v| !v.is_finite()))
                })
            })
            .count()
    }

    /// Checks that every layer holds exactly three samples per pixel (the fields are public, so
    /// a caller may have changed one).
    fn check_buffers(&self) -> Result<(), ImageError> {
        let expected = self.sample_count();
        for (layer, samples) in LAYER_NAMES.iter().zip(self.layers()) {
            if samples.len() != expected {
                return Err(ImageError::BufferLength {
                    layer,
                    expected,
                    actual: samples.len(),
                });
            }
        }
        Ok(())
    }

    fn check_writable(&self) -> Result<(), ImageError> {
        if self.width == 0 || self.height == 0 {
            return Err(ImageError::EmptyImage {
                width: self.width,
                height: self.height,
            });
        }
        self.check_buffers()
    }

    /// The complete EXR file as bytes (see the module documentation for its layout).
    pub fn to_exr_bytes(&self) -> Result<Vec<u8>, ImageError> {
        use exr::prelude::{
            AnyChannel, AnyChannels, Blocks, Compression, Encoding, FlatSamples, Layer,
            LayerAttributes, LineOrder, WritableImage,
        };

        self.check_writable()?;
        let exr_error = |e: exr::error::Error| ImageError::Exr {
            path: "(in memory)".into(),
            problem: e.to_string(),
        };

        let mut attributes = LayerAttributes::default();
        for (name, value) in &self.attributes {
            let (name, value) = exr_attribute(name, value)?;
            attributes.other.insert(name, value);
        }

        // One plane per channel, taken out of the interleaved RGB layers.
        let pixels = self.width as usize * self.height as usize;
        let mut channels = smallvec_of_channels();
        for (prefix, layer) in EXR_PREFIXES.iter().zip(self.layers()) {
            for (c, name) in RGB.iter().enumerate() {
                let plane: Vec<f32> = (0..pixels).map(|p| layer[p * 3 + c]).collect();
                channels.push(AnyChannel::new(
                    format!("{prefix}{name}").as_str(),
                    FlatSamples::F32(plane),
                ));
            }
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
        let mut out = Cursor::new(Vec::new());
        exr::prelude::Image::from_layer(layer)
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
    /// nine float channels), with its text header attributes.
    pub fn from_exr_bytes(bytes: &[u8]) -> Result<Image, ImageError> {
        read_exr_from(bytes, "(in memory)")
    }

    /// The `total` layer tone-mapped to an 8-bit sRGB PNG (see [`preview_pixel`]).
    pub fn to_png_preview_bytes(&self) -> Result<Vec<u8>, ImageError> {
        self.check_writable()?;
        let png_error = |e: png::EncodingError| ImageError::Png {
            path: "(in memory)".into(),
            problem: e.to_string(),
        };
        let data: Vec<u8> = self.total.iter().map(|&v| preview_pixel(v)).collect();
        let mut out = Vec::new();
        let mut encoder = png::Encoder::new(&mut out, self.width, self.height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = encoder.write_header().map_err(png_error)?;
        writer.write_image_data(&data).map_err(png_error)?;
        writer.finish().map_err(png_error)?;
        Ok(out)
    }

    /// Writes the PNG preview of the `total` layer, atomically.
    pub fn write_png_preview(&self, path: impl AsRef<Path>) -> Result<(), ImageError> {
        let path = path.as_ref();
        let bytes = self.to_png_preview_bytes().map_err(|e| match e {
            ImageError::Png { problem, .. } => ImageError::Png {
                path: path.display().to_string(),
                problem,
            },
            other => other,
        })?;
        write_file(path, &bytes)
    }
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
    // EXR text is a byte string; we store UTF-8, as OpenEXR tools commonly expect, so any
    // value (a file path, a warning with an η in it) can be recorded.
    let text = |s: &str| exr::prelude::Text::from_slice_unchecked(s.as_bytes());
    let (name_text, value_text) = (text(name), text(value));
    Ok((name_text, exr::prelude::AttributeValue::Text(value_text)))
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
    let mut image = Image::new(w, h);
    let pixels = width * height;

    for (prefix, layer_name) in EXR_PREFIXES.iter().zip(LAYER_NAMES) {
        for (c, name) in RGB.iter().enumerate() {
            let full = format!("{prefix}{name}");
            let channel = layer
                .channel_data
                .list
                .iter()
                .find(|ch| ch.name.eq(&full))
                .ok_or_else(|| exr_error(format!("no channel `{full}`")))?;
            let exr::prelude::FlatSamples::F32(samples) = &channel.sample_data else {
                return Err(exr_error(format!("channel `{full}` is not 32-bit float")));
            };
            if samples.len() != pixels {
                return Err(exr_error(format!("channel `{full}` has the wrong size")));
            }
            let dst = match layer_name {
                "total" => &mut image.total,
                "surface" => &mut image.surface,
                _ => &mut image.single_scatter,
            };
            for (p, v) in samples.iter().enumerate() {
                dst[p * 3 + c] = *v;
            }
        }
    }

    for (name, value) in file
        .attributes
        .other
        .iter()
        .chain(layer.attributes.other.iter())
    {
        if let AttributeValue::Text(text) = value {
            image
                .attributes
                .insert(text_to_string(name), text_to_string(text));
        }
    }
    Ok(image)
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
mod tests {
    use super::*;
    use crate::stats::RenderStats;
    use crate::tile::split_centre_first;

    /// A value unique to (layer, pixel, channel), exactly representable in f32.
    fn value(layer: usize, x: u32, y: u32, c: usize) -> f32 {
        (layer * 100_000 + y as usize * 1000 + x as usize * 4 + c) as f32 * 0.25
    }

    fn patterned(width: u32, height: u32) -> Image {
        let mut image = Image::new(width, height);
        for (l, layer) in image.layers_mut().into_iter().enumerate() {
            for y in 0..height {
                for x in 0..width {
                    for c in 0..3 {
                        layer[((y * width + x) * 3) as usize + c] = value(l, x, y, c);
                    }
                }
            }
        }
        image
    }

    fn tile_of(rect: TileRect) -> TilePixels {
        let mut tile = TilePixels::black(rect);
        for (l, layer) in [&mut tile.total, &mut tile.surface, &mut tile.single_scatter]
            .into_iter()
            .enumerate()
        {
            for row in 0..rect.height {
                for col in 0..rect.width {
                    for c in 0..3 {
                        layer[((row * rect.width + col) * 3) as usize + c] =
                            value(l, rect.x + col, rect.y + row, c);
                    }
                }
            }
        }
        tile
    }

    fn bits(samples: &[f32]) -> Vec<u32> {
        samples.iter().map(|v| v.to_bits()).collect()
    }

    #[test]
    fn a_tile_lands_where_its_rectangle_says() {
        let mut image = Image::new(7, 5);
        let rect = TileRect {
            x: 2,
            y: 1,
            width: 3,
            height: 2,
        };
        image.insert_tile(&tile_of(rect)).expect("tile fits");
        for (l, layer) in image.layers().into_iter().enumerate() {
            for y in 0..5 {
                for x in 0..7 {
                    let inside = (2..5).contains(&x) && (1..3).contains(&y);
                    for c in 0..3 {
                        let expected = if inside { value(l, x, y, c) } else { 0.0 };
                        assert_eq!(
                            layer[((y * 7 + x) * 3) as usize + c],
                            expected,
                            "layer {l} ({x},{y}) c{c}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn tiles_in_any_order_assemble_the_whole_image() {
        let (w, h) = (37, 23);
        let mut image = Image::new(w, h);
        let mut tiles = split_centre_first(w, h, 8);
        tiles.reverse();
        for rect in tiles {
            image.insert_tile(&tile_of(rect)).expect("tile fits");
        }
        assert_eq!(image, patterned(w, h));
    }

    #[test]
    fn bad_tiles_are_rejected_and_leave_the_image_unchanged() {
        let mut image = patterned(16, 8);
        let before = image.clone();
        let rect = |x, y, width, height| TileRect {
            x,
            y,
            width,
            height,
        };
        for r in [
            rect(10, 0, 7, 4),
            rect(0, 5, 4, 4),
            rect(16, 0, 1, 1),
            rect(u32::MAX, 0, 2, 2),
            rect(0, u32::MAX - 1, 1, 4),
        ] {
            let err = image.insert_tile(&TilePixels::black(r)).unwrap_err();
            assert!(
                matches!(err, ImageError::TileOutside { .. }),
                "{r:?}: {err}"
            );
            assert!(err.to_string().contains("outside"), "{err}");
        }
        let err = image
            .insert_tile(&TilePixels::black(rect(3, 3, 0, 2)))
            .unwrap_err();
        assert!(matches!(err, ImageError::EmptyTile { .. }), "{err}");

        // Wrong buffer lengths, one layer at a time.
        for (layer, layer_name) in LAYER_NAMES.into_iter().enumerate() {
            for delta in [-3i64, -1, 1, 3] {
                let mut tile = TilePixels::black(rect(4, 2, 4, 3));
                let buffer = match layer {
                    0 => &mut tile.total,
                    1 => &mut tile.surface,
                    _ => &mut tile.single_scatter,
                };
                buffer.resize((36 + delta) as usize, 0.0);
                let err = image.insert_tile(&tile).unwrap_err();
                let ImageError::BufferLength {
                    layer: name,
                    expected,
                    actual,
                } = err
                else {
                    panic!("layer {layer} delta {delta}: {err}")
                };
                assert_eq!(
                    (name, expected, actual),
                    (layer_name, 36, (36 + delta) as usize)
                );
            }
        }
        assert_eq!(image, before);
    }

    #[test]
    fn exr_round_trip_is_bit_exact_with_attributes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.exr");
        let mut image = patterned(19, 11);
        // Values a lossy or converting writer would change.
        image.total[0] = f32::NAN;
        image.total[1] = f32::INFINITY;
        image.surface[5] = f32::NEG_INFINITY;
        image.surface[6] = -0.0;
        image.single_scatter[7] = f32::from_bits(1); // the smallest subnormal
        image.single_scatter[8] = f32::MAX;
        image.single_scatter[9] = 1.0e-3;
        image.attributes.insert("spindle.spp".into(), "64".into());
        image
            .attributes
            .insert("spindle.scene".into(), "glass-sphere.json".into());
        image
            .attributes
            .insert("spindle.method".into(), "interval (Holzschuch 2015)".into());
        image
            .attributes
            .insert("spindle.empty".into(), String::new());
        image
            .attributes
            .insert("spindle.latin1".into(), "café".into());
        image
            .attributes
            .insert("spindle.json".into(), r#"{"a": [1, 2]}"#.into());
        // Any Unicode, and a NUL inside a value, survive (values are UTF-8 byte strings).
        image
            .attributes
            .insert("spindle.η".into(), "η = 1.5, 日本/scène.json".into());
        image.attributes.insert("spindle.nul".into(), "a\0b".into());

        image.write_exr(&path).expect("written");
        let back = read_exr(&path).expect("read");
        assert_eq!((back.width, back.height), (19, 11));
        for (name, (a, b)) in LAYER_NAMES
            .iter()
            .zip(image.layers().into_iter().zip(back.layers()))
        {
            assert_eq!(bits(a), bits(b), "layer {name}");
        }
        assert_eq!(back.attributes, image.attributes);
        assert_eq!(back.non_finite_count(), 2);
        assert_eq!(back.total[2], value(0, 0, 0, 2));
    }

    #[test]
    fn the_same_image_always_gives_the_same_bytes() {
        let mut image = patterned(33, 17);
        for i in 0..12 {
            image
                .attributes
                .insert(format!("spindle.attr{i}"), format!("value {i}"));
        }
        let first = image.to_exr_bytes().unwrap();
        for _ in 0..5 {
            assert!(
                image.to_exr_bytes().unwrap() == first,
                "EXR bytes differ between writes"
            );
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        image.write_exr(&path).unwrap();
        assert!(std::fs::read(&path).unwrap() == first);
        let png = image.to_png_preview_bytes().unwrap();
        assert!(image.to_png_preview_bytes().unwrap() == png);
        // And the file really is a one-part scanline ZIP file with the nine channels.
        let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(&first), true).unwrap();
        assert_eq!(meta.headers.len(), 1);
        let header = &meta.headers[0];
        assert_eq!(header.compression, exr::prelude::Compression::ZIP16);
        assert_eq!(header.blocks, exr::meta::BlockDescription::ScanLines);
        let names: Vec<String> = header
            .channels
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        assert_eq!(
            names,
            [
                "B",
                "G",
                "R",
                "single_scatter.B",
                "single_scatter.G",
                "single_scatter.R",
                "surface.B",
                "surface.G",
                "surface.R"
            ]
        );
        assert!(
            header
                .channels
                .list
                .iter()
                .all(|c| c.sample_type == exr::prelude::SampleType::F32)
        );
    }

    #[test]
    fn bad_attributes_are_rejected_by_name() {
        for (name, value, word) in [
            ("", "x", "empty"),
            ("channels", "x", "standard"),
            ("comments", "x", "standard"),
            (&"x".repeat(256), "x", "255"),
        ] {
            let mut image = Image::new(2, 2);
            image.attributes.insert(name.into(), value.into());
            let err = image.to_exr_bytes().unwrap_err();
            assert!(
                matches!(&err, ImageError::Attribute { name: n, .. } if n == name),
                "{err}"
            );
            assert!(err.to_string().contains(word), "{err}");
        }
    }

    #[test]
    fn png_preview_is_written_and_decodes_to_the_tone_map() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("preview.png");
        let mut image = Image::new(4, 2);
        // Linear inputs and their 8-bit sRGB values computed by hand from the sRGB curve:
        // 0.5 -> 1.055 * 0.5^(1/2.4) - 0.055 = 0.73536 -> 187.52 -> 188;
        // 0.0031308 -> 12.92 * 0.0031308 = 0.040450 -> 10.31 -> 10;
        // 0.2 -> 1.055 * 0.2^(1/2.4) - 0.055 = 0.48453 -> 123.56 -> 124.
        let cases: [(f32, u8); 8] = [
            (0.0, 0),
            (1.0, 255),
            (0.5, 188),
            (0.003_130_8, 10),
            (0.2, 124),
            (7.5, 255),
            (-2.0, 0),
            (f32::NAN, 0),
        ];
        for (i, (linear, _)) in cases.iter().enumerate() {
            image.total[i * 3..i * 3 + 3].copy_from_slice(&[*linear, *linear, *linear]);
        }
        image.total[1] = f32::INFINITY; // pixel 0, green
        image.surface.fill(9.0); // only `total` is previewed
        image.write_png_preview(&path).expect("written");

        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buffer = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buffer).unwrap();
        assert_eq!((info.width, info.height), (4, 2));
        assert_eq!(
            (info.color_type, info.bit_depth),
            (png::ColorType::Rgb, png::BitDepth::Eight)
        );
        let pixels = &buffer[..info.buffer_size()];
        for (i, (linear, srgb)) in cases.iter().enumerate() {
            let expected_green = if i == 0 { 255 } else { *srgb };
            assert_eq!(
                pixels[i * 3..i * 3 + 3],
                [*srgb, expected_green, *srgb],
                "pixel {i}: {linear}"
            );
        }
        // Nothing but the preview is left in the directory.
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["preview.png"]);
    }

    #[test]
    fn writing_replaces_the_old_file_and_reports_failures() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.exr");
        std::fs::write(&path, b"an older render").unwrap();
        let image = patterned(3, 2);
        image.write_exr(&path).unwrap();
        assert_eq!(read_exr(&path).unwrap(), image);
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["out.exr"]);

        let missing = dir.path().join("no-such-dir").join("out.exr");
        assert!(matches!(
            image.write_exr(&missing),
            Err(ImageError::Io { .. })
        ));
        assert!(matches!(
            image.write_png_preview(&missing),
            Err(ImageError::Io { .. })
        ));
        assert!(matches!(read_exr(&missing), Err(ImageError::Io { .. })));
        std::fs::write(&path, b"not an exr file").unwrap();
        assert!(matches!(read_exr(&path), Err(ImageError::Exr { .. })));

        let empty = Image::new(0, 4);
        assert!(matches!(
            empty.write_exr(&path),
            Err(ImageError::EmptyImage { .. })
        ));
        assert!(matches!(
            empty.write_png_preview(&path),
            Err(ImageError::EmptyImage { .. })
        ));
        let mut broken = patterned(3, 2);
        broken.surface.pop();
        let err = broken.write_exr(&path).unwrap_err();
        assert!(
            matches!(
                err,
                ImageError::BufferLength {
                    layer: "surface",
                    expected: 18,
                    actual: 17
                }
            ),
            "{err}"
        );
    }

    #[test]
    fn non_finite_pixels_are_counted_once_each() {
        let mut image = Image::new(5, 4);
        assert_eq!(image.non_finite_count(), 0);
        image.total[3] = f32::NAN; // pixel 1
        image.surface[4] = f32::INFINITY; // pixel 1 again
        image.single_scatter[59] = f32::NEG_INFINITY; // pixel 19, the last
        image.surface[30] = f32::MAX; // finite
        assert_eq!(image.non_finite_count(), 2);
        let mut tile = TilePixels::black(TileRect {
            x: 0,
            y: 0,
            width: 1,
            height: 1,
        });
        tile.total[0] = f32::NAN;
        tile.stats = RenderStats::default();
        image
            .insert_tile(&tile)
            .expect("NaN pixels are inserted as they are");
        assert!(image.total[0].is_nan());
        assert_eq!(image.non_finite_count(), 3);
    }
}
