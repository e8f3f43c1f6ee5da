//! Progressive passes on the farm (`film.time_budget_s`): what a tile result carries so that the
//! tile's next pass continues where this one stopped.
//!
//! A farm job with a time budget renders its tiles in passes of [`crate::scene::ADAPTIVE_BATCH`]
//! samples per pixel; pass `k + 1` of a tile starts from each pixel's running sums after pass
//! `k` ([`PixelSums`]), which the pass-`k` result carries ([`TileProgress`], the optional
//! [`crate::tile::TilePixels::progress`]). The sums are kept to the bit (f64, in the compact
//! encoding), so after `k` passes a tile's pixels are the bits of a one-pass render at
//! `spp` = `16 k`: the renderer's `PixelProgress` invariant, carried across processes.

use serde::{Deserialize, Serialize};

/// One pixel's running sums after the samples it has taken: what the renderer's
/// `PixelProgress` holds, as plain numbers (the renderer converts both ways).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PixelSums {
    /// Σ of the samples' `surface` radiance, RGB.
    pub surface: [f64; 3],
    /// Σ of the samples' `single_scatter` radiance, RGB.
    pub single_scatter: [f64; 3],
    /// Σ of the samples' `multiple_scatter` radiance, RGB.
    pub multiple_scatter: [f64; 3],
    /// Welford's running mean of the total, RGB.
    pub mean: [f64; 3],
    /// Welford's sum of squared deviations of the total from its mean, RGB.
    pub m2: [f64; 3],
    /// The same two for the luminance (the adaptive stopping rule's).
    pub mean_y: f64,
    pub m2_y: f64,
    /// Samples taken (indices `0 .. taken`).
    pub taken: u32,
    /// Of those, the samples whose camera ray hit an object (the `alpha` layer's count).
    pub hits: u32,
    /// The pixel met `film.target_error` and takes no more samples.
    pub converged: bool,
    /// The sums of the optional passes, when the film asks for any (`film.passes`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub aov: Option<crate::aov::AovSums>,
}

/// A tile's state after a progressive pass: each pixel's sums in row-major order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TileProgress {
    /// Passes this result completes (1 after the first).
    pub pass: u32,
    /// The sample cap of this pass: `min(pass · 16, film.spp)`.
    pub spp: u32,
    pub pixels: Vec<PixelSums>,
}

impl TileProgress {
    /// The canonical bytes of the state, little-endian, in field order: `pass`, `spp`, then per
    /// pixel its fields (f64 bits, `taken` and `hits` as u32, `converged` as one byte, then the
    /// passes' sums if any, [`crate::aov::AovSums::canonical_bytes`]). Part of a tile
    /// result's hash ([`crate::protocol::pixel_hash`]), so a stored state cannot change
    /// unnoticed.
    pub fn canonical_bytes(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.pass.to_le_bytes());
        out.extend_from_slice(&self.spp.to_le_bytes());
        for p in &self.pixels {
            for v in p
                .surface
                .iter()
                .chain(&p.single_scatter)
                .chain(&p.multiple_scatter)
                .chain(&p.mean)
                .chain(&p.m2)
            {
                out.extend_from_slice(&v.to_bits().to_le_bytes());
            }
            out.extend_from_slice(&p.mean_y.to_bits().to_le_bytes());
            out.extend_from_slice(&p.m2_y.to_bits().to_le_bytes());
            out.extend_from_slice(&p.taken.to_le_bytes());
            out.extend_from_slice(&p.hits.to_le_bytes());
            out.push(u8::from(p.converged));
            if let Some(aov) = &p.aov {
                aov.canonical_bytes(out);
            }
        }
    }
}

/// The sample cap of pass `pass` (from 1) of a film of `spp` samples per pixel:
/// `min(pass · 16, spp)`.
pub fn pass_cap(pass: u32, spp: u32) -> u32 {
    pass.saturating_mul(crate::scene::ADAPTIVE_BATCH).min(spp)
}

/// The largest tile edge of a job in passes: a result then carries about 200 bytes of running
/// sums per pixel besides its layers, and a 128-pixel tile's (3.3 MB of sums, 1 MB of layers as
/// MessagePack) stays within what the coordinator takes in an upload (16 MB by default, decoded)
/// and so reads back from its tile store.
pub const MAX_PASS_TILE_SIZE: u32 = 128;
