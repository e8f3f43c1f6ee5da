//! Deterministic sample numbers: a pixel's samples are the same bits on any worker, thread or
//! tile, and they are spread evenly over the pixel's samples.
//!
//! The `k`-th number of sample `s` of pixel `(x, y)` under seed `seed` is a pure function of
//! `(seed, x, y, s, k)`. Dimensions come in pairs, as pbrt-v4's padded Sobol sampler does: the
//! leading 24 bits of dimensions `2i` and `2i + 1` are the first two dimensions of point `s` of an
//! Owen-scrambled, shuffled Sobol sequence (`sobol_burley`) keyed by `(seed, x, y, i)`. Over the
//! first `2^m` samples of a pixel each pair is a (0, 2)-net — every elementary box of area
//! `2^{-m}` in the unit square holds one point — so smooth integrands converge faster than
//! `N^{-1/2}`; pairs, and pixels, are independent of each other. The remaining 29 bits, and whole
//! numbers of samples past the sequence's 2¹⁶, come from a strong 64-bit hash (splitmix64's
//! finaliser in a chain) of the full key. Nothing is shared between pixels and there is no
//! global state, so a failing pixel can be replayed alone. Where three numbers must be
//! stratified together (a point inside a sphere light), [`Sampler::next_3d`] takes the first
//! three dimensions of one pair's sequence, a (1, 3)-net, and uses up the next pair too, so the
//! pairs after it stay aligned.
//!
//! A sub-estimator that draws an unknown number of numbers (a multiple-scattering path) takes a
//! [`Sampler::fork`]: a sampler of its own, keyed by the parent's key and the fork's index, so
//! the parent's dimensions — and every layer computed from them — are the same bits whether or
//! not the fork is taken.

/// The random numbers of one camera sample of one pixel.
#[derive(Debug, Clone)]
pub struct Sampler {
    /// The hash key of (seed, pixel, sample).
    key: u64,
    /// The Sobol scramble of (seed, pixel).
    scramble: u32,
    sample: u32,
    dimension: u64,
    /// Forks taken so far.
    forks: u64,
}

/// The splitmix64 finaliser: a bijective 64-bit mix with full avalanche.
#[inline]
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Separates the scramble's hash from the samples' keys.
const SCRAMBLE_DOMAIN: u64 = 0x736F_626F_6C5F_6B65;

/// Separates forks' keys and scrambles from the parent's.
const FORK_DOMAIN: u64 = 0x666F_726B_5F6B_6579;

/// Samples of one pixel beyond this index are independent hashes (the sequence's length).
const SOBOL_SAMPLES: u32 = 1 << 16;

impl Sampler {
    /// The sampler of sample `sample` of pixel `(pixel_x, pixel_y)` under `seed`.
    pub fn new(seed: u64, pixel_x: u32, pixel_y: u32, sample: u32) -> Sampler {
        let pixel = ((pixel_x as u64) << 32) | pixel_y as u64;
        let pixel_key = mix(mix(seed) ^ pixel);
        Sampler {
            key: mix(pixel_key ^ sample as u64),
            scramble: (mix(pixel_key ^ SCRAMBLE_DOMAIN) >> 32) as u32,
            sample,
            dimension: 0,
            forks: 0,
        }
    }

    /// A sampler of its own for a sub-estimator: the `i`-th fork of this sampler is a pure
    /// function of (seed, pixel, sample, i) and leaves this sampler's numbers unchanged. Its
    /// scramble depends on the pixel and `i` but not on the sample, so the `i`-th forks of a
    /// pixel's samples are stratified over the samples as the parent's pairs are.
    pub fn fork(&mut self) -> Sampler {
        self.forks += 1;
        let index = mix(FORK_DOMAIN ^ self.forks);
        Sampler {
            key: mix(self.key ^ index),
            scramble: (mix(u64::from(self.scramble) ^ index) >> 32) as u32,
            sample: self.sample,
            dimension: 0,
            forks: 0,
        }
    }

    /// The next number in `[0, 1)` (53 bits), advancing the dimension counter.
    pub fn next_f64(&mut self) -> f64 {
        let dimension = self.dimension;
        self.dimension += 1;
        // Dimensions 2i and 2i + 1 are the first two of a sequence scrambled (and its points
        // shuffled) for pair i alone.
        self.number(dimension >> 1, (dimension & 1) as u32, dimension)
    }

    /// Two numbers in `[0, 1)`.
    pub fn next_2d(&mut self) -> [f64; 2] {
        [self.next_f64(), self.next_f64()]
    }

    /// Three numbers in `[0, 1)` stratified together: the first three dimensions of the sequence
    /// of the next pair, which uses up two pairs (four dimensions; a pair left half-used is
    /// skipped first).
    pub fn next_3d(&mut self) -> [f64; 3] {
        let first = self.dimension.next_multiple_of(2);
        self.dimension = first + 4;
        [0, 1, 2].map(|within| self.number(first >> 1, within, first + u64::from(within)))
    }

    /// Dimension `within` of point `sample` of the sequence scrambled for `pair`, its low bits
    /// (and whole numbers past the sequence's length) from the hash of `dimension`.
    fn number(&self, pair: u64, within: u32, dimension: u64) -> f64 {
        let hash = mix(self.key ^ mix(dimension));
        let bits = if self.sample < SOBOL_SAMPLES {
            let pair_scramble = (mix(u64::from(self.scramble) ^ pair) >> 32) as u32;
            // An f32 in [0, 1) from the sequence carries 24 significant bits at most.
            let sobol = sobol_burley::sample(self.sample, within, pair_scramble);
            let high = ((f64::from(sobol) * (1u64 << 24) as f64) as u64).min((1 << 24) - 1);
            (high << 29) | (hash >> 35)
        } else {
            hash >> 11
        };
        bits as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// How many numbers have been drawn.
    pub fn dimension(&self) -> u64 {
        self.dimension
    }
}

#[cfg(test)]
mod tests;
