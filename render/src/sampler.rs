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
mod tests {
    use super::*;

    #[test]
    fn same_key_same_bits_and_keys_differ() {
        let draw = |seed, x, y, s| {
            let mut r = Sampler::new(seed, x, y, s);
            [r.next_f64(), r.next_f64(), r.next_f64()]
        };
        assert_eq!(draw(1, 2, 3, 4), draw(1, 2, 3, 4));
        let base = draw(1, 2, 3, 4);
        for other in [
            draw(2, 2, 3, 4),
            draw(1, 3, 2, 4),
            draw(1, 2, 3, 5),
            draw(1, 3, 3, 4),
        ] {
            assert_ne!(base, other);
        }
    }

    #[test]
    fn numbers_are_uniform_in_unit_interval() {
        // Mean 1/2 and variance 1/12 within 5 standard errors, over many pixels and dimensions.
        let n = 200_000;
        let (mut sum, mut sum2) = (0.0, 0.0);
        for i in 0..n / 8 {
            let mut r = Sampler::new(42, i % 640, i / 640, 0);
            for _ in 0..8 {
                let u = r.next_f64();
                assert!((0.0..1.0).contains(&u));
                sum += u;
                sum2 += u * u;
            }
        }
        let mean = sum / n as f64;
        let var = sum2 / n as f64 - mean * mean;
        let se_mean = (1.0f64 / 12.0 / n as f64).sqrt();
        assert!((mean - 0.5).abs() < 5.0 * se_mean, "mean {mean}");
        assert!((var - 1.0 / 12.0).abs() < 1e-3, "variance {var}");
    }
}
