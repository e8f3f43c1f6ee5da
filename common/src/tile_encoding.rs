//! The compact binary form of tile results: how a worker uploads a tile and how the coordinator
//! keeps it on disk.
//!
//! A 32-pixel tile is 12,288 f32 values; as JSON numbers they take 10 to 12 bytes each. Here a
//! value ([`crate::protocol::TileUpload`] on the wire, [`crate::tile::TilePixels`] at rest) is
//! MessagePack with named fields (`rmp-serde`) compressed with zstd. MessagePack describes
//! itself, so optional fields, unknown-field refusal and the finite-f32 check of `TilePixels`
//! behave as they do for JSON, and an f32 is its 4 bytes: every value reads back to the same
//! bits (the upload's hash, which the coordinator checks, covers them). Decoding is bounded: a
//! body that would inflate past the caller's limit is refused before it is parsed. Each thread
//! keeps one zstd context of each kind (a context is tens of kilobytes to set up; a tile is
//! often less); a context carries no data from one call to the next.

use std::cell::RefCell;
use std::io::Read;

use serde::Serialize;
use serde::de::DeserializeOwned;

/// The media type of an encoded tile upload (`Content-Type` of `PUT /v1/jobs/{job}/tiles/{tile}`).
pub const CONTENT_TYPE: &str = "application/vnd.spindle.tile+msgpack+zstd";

/// zstd's level: 3, its default; higher levels gain a few percent at several times the time.
const LEVEL: i32 = 3;

/// Why a value could not be encoded or decoded; the message names the field where one is known.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct EncodingError(String);

/// `value` as MessagePack (named fields) compressed with zstd.
pub fn encode<T: Serialize>(value: &T) -> Result<Vec<u8>, EncodingError> {
    let packed = rmp_serde::to_vec_named(value)
        .map_err(|e| EncodingError(format!("encoding as MessagePack: {e}")))?;
    thread_local! {
        static COMPRESSOR: RefCell<Option<zstd::bulk::Compressor<'static>>> = const { RefCell::new(None) };
    }
    COMPRESSOR
        .with_borrow_mut(|compressor| {
            let context = match compressor {
                Some(context) => context,
                None => compressor.insert(zstd::bulk::Compressor::new(LEVEL)?),
            };
            let compressed = context.compress(&packed);
            if compressed.is_err() {
                *compressor = None; // Never reuse a context an error left behind.
            }
            compressed
        })
        .map_err(|e| EncodingError(format!("compressing: {e}")))
}

/// Reads a value written by [`encode`], refusing a body that inflates past `limit` bytes, and
/// naming the path of a bad field (`pixels.total: value 4 is 1e39, beyond the range …`).
///
/// The body is inflated by zstd's streaming decoder read through [`Read::take`]: the buffer
/// grows with what the body really holds, never to `limit` up front, and the decoder's window
/// is bounded by `limit` too (a frame that declares a larger window is refused), so a small
/// body that claims to inflate to gigabytes costs at most `limit` bytes before it is refused.
pub fn decode<T: DeserializeOwned>(bytes: &[u8], limit: usize) -> Result<T, EncodingError> {
    thread_local! {
        static DECOMPRESSOR: RefCell<Option<zstd::zstd_safe::DCtx<'static>>> = const { RefCell::new(None) };
    }
    let refused = |e: &dyn std::fmt::Display| {
        EncodingError(format!(
            "body: not a zstd frame of at most {limit} bytes when decompressed ({e})"
        ))
    };
    let packed = DECOMPRESSOR.with_borrow_mut(|decompressor| {
        let context = match decompressor {
            Some(context) => context,
            None => decompressor
                .insert(zstd::zstd_safe::DCtx::try_create().ok_or_else(|| refused(&"no memory"))?),
        };
        // The window holds at most the whole frame; a frame of `limit` bytes needs no more
        // than the next power of two (zstd's smallest window is 2^10 bytes).
        let window_log = (usize::BITS - limit.saturating_sub(1).leading_zeros()).clamp(10, 30);
        // Parameters change only between frames: end whatever the last call left first.
        context
            .reset(zstd::zstd_safe::ResetDirective::SessionOnly)
            .and_then(|_| {
                context.set_parameter(zstd::zstd_safe::DParameter::WindowLogMax(window_log))
            })
            .map_err(|code| refused(&zstd::zstd_safe::get_error_name(code)))?;
        let mut packed = Vec::new();
        let read = zstd::stream::read::Decoder::with_context(bytes, context)
            .take(limit as u64 + 1)
            .read_to_end(&mut packed);
        match read {
            Err(e) => {
                *decompressor = None; // Never reuse a context an error left behind.
                Err(refused(&e))
            }
            Ok(_) if packed.len() > limit => {
                *decompressor = None;
                Err(refused(&"it inflates past that"))
            }
            Ok(_) => Ok(packed),
        }
    })?;
    // Tracking the path costs about a tenth of a tile's handling; only a refused value needs it.
    let mut rest = packed.as_slice();
    if let Ok(value) = T::deserialize(&mut rmp_serde::Deserializer::new(&mut rest))
        && rest.is_empty()
    {
        return Ok(value);
    }
    let mut rest = packed.as_slice();
    let mut de = rmp_serde::Deserializer::new(&mut rest);
    let value = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        EncodingError(if path == "." || path == "?" {
            format!("body: {inner}")
        } else {
            format!("{path}: {inner}")
        })
    })?;
    if !rest.is_empty() {
        return Err(EncodingError("body: trailing data after the value".into()));
    }
    Ok(value)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::{TileUpload, pixel_hash};
    use crate::stats::RenderStats;
    use crate::tile::{TilePixels, TileRect};

    /// A tile whose values cover what a render produces: zeros of both signs, subnormals,
    /// short and full mantissas, values near the top of f32's range.
    fn tile() -> TilePixels {
        let rect = TileRect {
            x: 32,
            y: 0,
            width: 5,
            height: 3,
        };
        let n = rect.pixel_count() * 3;
        let specials = [0.0f32, -0.0, 1.0, 0.5, f32::MIN_POSITIVE / 8.0, 3e38, 0.1];
        let layer = |k: u32| -> Vec<f32> {
            (0..n)
                .map(|i| {
                    let x = specials[i % specials.len()];
                    if i % 3 == 0 {
                        x
                    } else {
                        x * (1.0 + (i as f32 + k as f32) * 1e-3)
                    }
                })
                .collect()
        };
        TilePixels {
            rect,
            total: layer(0),
            surface: layer(1),
            single_scatter: layer(2),
            multiple_scatter: layer(5),
            stderr: layer(3),
            alpha: layer(4)[..rect.pixel_count()].to_vec(),
            aov: Vec::new(),
            stats: RenderStats::default(),
            progress: None,
        }
    }

    fn bits(p: &TilePixels) -> Vec<u32> {
        p.layers()
            .iter()
            .flat_map(|l| l.iter().map(|v| v.to_bits()))
            .collect()
    }

    #[test]
    fn every_value_reads_back_to_the_same_bits() {
        let pixels = tile();
        let upload = TileUpload {
            worker_id: 7,
            epoch: 3,
            hash: pixel_hash(&pixels),
            pixels: pixels.clone(),
            render_seconds: None,
            provenance: None,
        };
        let back: TileUpload = decode(&encode(&upload).unwrap(), 1 << 20).unwrap();
        assert_eq!(bits(&back.pixels), bits(&pixels));
        assert_eq!(pixel_hash(&back.pixels), upload.hash);
        assert_eq!(back, upload);
    }

    #[test]
    fn bad_bodies_are_refused_with_the_field_or_the_problem() {
        let pixels = tile();
        // A value beyond f32 (written as f64) is refused by the layer's own check, with its path.
        #[derive(Serialize)]
        struct Wide<'a> {
            rect: TileRect,
            total: Vec<f64>,
            surface: &'a [f32],
            single_scatter: &'a [f32],
            multiple_scatter: &'a [f32],
            stderr: &'a [f32],
            alpha: &'a [f32],
            stats: RenderStats,
        }
        let mut total: Vec<f64> = pixels.total.iter().map(|&v| v as f64).collect();
        total[4] = 1e39;
        let wide = Wide {
            rect: pixels.rect,
            total,
            surface: &pixels.surface,
            single_scatter: &pixels.single_scatter,
            multiple_scatter: &pixels.multiple_scatter,
            stderr: &pixels.stderr,
            alpha: &pixels.alpha,
            stats: RenderStats::default(),
        };
        let e = decode::<TilePixels>(&encode(&wide).unwrap(), 1 << 20).unwrap_err();
        assert!(e.0.starts_with("total: value 4 is 1e39"), "{e}");

        // Inflating past the limit, not zstd, not CBOR, trailing bytes.
        let encoded = encode(&pixels).unwrap();
        let e = decode::<TilePixels>(&encoded, 100).unwrap_err();
        assert!(e.0.contains("at most 100 bytes"), "{e}");
        let e = decode::<TilePixels>(b"{\"rect\": 1}", 1 << 20).unwrap_err();
        assert!(e.0.starts_with("body: not a zstd frame"), "{e}");
        let e =
            decode::<TilePixels>(&zstd::bulk::compress(b"\xc1", 3).unwrap(), 1 << 20).unwrap_err();
        assert!(e.0.starts_with("body:"), "{e}");
        let mut packed = rmp_serde::to_vec_named(&pixels).unwrap();
        packed.push(0);
        let e =
            decode::<TilePixels>(&zstd::bulk::compress(&packed, 3).unwrap(), 1 << 20).unwrap_err();
        assert_eq!(e.0, "body: trailing data after the value");
    }

    /// The thread's contexts are reused: after refusals, other values, on another thread too,
    /// every encoding is what a fresh context makes (zstd's one-shot function) and decodes back.
    #[test]
    fn a_reused_context_encodes_and_decodes_as_a_fresh_one() {
        let pixels = tile();
        let mut other = tile();
        other.total[0] = 42.0;
        let fresh =
            |value: &TilePixels| zstd::bulk::compress(&rmp_serde::to_vec_named(value).unwrap(), 3);
        let check = || {
            for value in [&pixels, &other, &pixels] {
                let encoded = encode(value).unwrap();
                assert_eq!(encoded, fresh(value).unwrap());
                assert!(
                    decode::<TilePixels>(&encoded, 100).is_err(),
                    "past the limit"
                );
                assert!(decode::<TilePixels>(b"not zstd", 1 << 20).is_err());
                assert_eq!(&decode::<TilePixels>(&encoded, 1 << 20).unwrap(), value);
            }
        };
        check();
        std::thread::scope(|s| {
            s.spawn(check);
        });
    }
}
