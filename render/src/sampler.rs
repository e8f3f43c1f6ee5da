//! Counter-based random numbers: a pixel's samples are the same bits on any worker, thread or tile.
//!
//! The `k`-th number of sample `s` of pixel `(x, y)` under seed `seed` is a pure function of
//! `(seed, x, y, s, k)`: a strong 64-bit integer hash (splitmix64's finaliser, applied in a
//! chain) of the packed key. Nothing is shared between pixels and there is no global state, so a
//! failing pixel can be replayed alone.

/// The random numbers of one camera sample of one pixel.
#[derive(Debug, Clone)]
pub struct Sampler {
    key: u64,
    dimension: u64,
}

/// The splitmix64 finaliser: a bijective 64-bit mix with full avalanche.
#[inline]
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Sampler {
    /// The sampler of sample `sample` of pixel `(pixel_x, pixel_y)` under `seed`.
    pub fn new(seed: u64, pixel_x: u32, pixel_y: u32, sample: u32) -> Sampler {
        let pixel = ((pixel_x as u64) << 32) | pixel_y as u64;
        let key = mix(mix(mix(seed) ^ pixel) ^ sample as u64);
        Sampler { key, dimension: 0 }
    }

    /// The next number in `[0, 1)` (53 random bits), advancing the dimension counter.
    pub fn next_f64(&mut self) -> f64 {
        let bits = mix(self.key ^ mix(self.dimension));
        self.dimension += 1;
        (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Two numbers in `[0, 1)`.
    pub fn next_2d(&mut self) -> [f64; 2] {
        [self.next_f64(), self.next_f64()]
    }

    /// How many numbers have been drawn.
    pub fn dimension(&self) -> u64 {
        self.dimension
    }
}

#[cfg(test)]
mod tests;
