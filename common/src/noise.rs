//! How noisy a partly rendered image still is, from its `stderr` layer: the number a job's
//! progress shows (`JobInfo::relative_error`), summed tile by tile as tiles come in.
//!
//! The measure is the estimated relative RMS error `sqrt(Σ stderr²) / sqrt(Σ total²)` over every
//! pixel and channel seen: the expected `‖image − converged‖₂ / ‖image‖₂`, the relative RMSE the
//! benchmarks measure against references (`bench/src/metric.rs`), predicted from the samples
//! alone. Unlike a mean of per-pixel relative errors it is not dominated by dark pixels, and
//! its two sums add over tiles in any order.

use serde::{Deserialize, Serialize};

use crate::tile::TilePixels;

/// The two sums of squares behind [`NoiseSums::relative_error`]. Invariant: both are finite
/// and ≥ 0 (sums of squares of finite f32).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseSums {
    /// Σ stderr² over the pixels and channels.
    pub stderr_sq: f64,
    /// Σ total² over the same values.
    pub total_sq: f64,
}

impl NoiseSums {
    /// The sums over two equally long layers (`total` and `stderr` of a tile or an image).
    pub fn of_layers(total: &[f32], stderr: &[f32]) -> NoiseSums {
        let square = |v: &[f32]| v.iter().map(|&x| f64::from(x) * f64::from(x)).sum::<f64>();
        NoiseSums {
            stderr_sq: square(stderr),
            total_sq: square(total),
        }
    }

    /// The sums over a tile's pixels.
    pub fn of_tile(tile: &TilePixels) -> NoiseSums {
        NoiseSums::of_layers(&tile.total, &tile.stderr)
    }

    pub fn add(&mut self, other: &NoiseSums) {
        self.stderr_sq += other.stderr_sq;
        self.total_sq += other.total_sq;
    }

    /// `sqrt(Σ stderr² / Σ total²)` of a render of `spp` samples per pixel; `None` — unknown —
    /// while everything seen is black (nothing to be relative to) and at 1 spp, where no pixel
    /// has two samples to estimate its error from (its `stderr` is 0, which is not "no error").
    /// Every pixel takes at least `min(spp, 16)` samples (adaptive batches and progressive
    /// passes alike), so `spp` ≥ 2 gives every pixel an estimate.
    pub fn relative_error(&self, spp: u32) -> Option<f64> {
        let ratio = self.stderr_sq / self.total_sq;
        (spp >= 2 && self.total_sq > 0.0 && ratio.is_finite()).then(|| ratio.sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two "tiles" by hand: totals (3, 4) and (0, 0, 12) → Σ total² = 25 + 144 = 169;
    /// stderrs (0.3, 0.4) and (0, 0, 1.2) → Σ stderr² = 0.25 + 1.44 = 1.69; ratio 0.01 → 0.1.
    #[test]
    fn adds_up_to_the_hand_computed_ratio() {
        let mut sums = NoiseSums::of_layers(&[3.0, 4.0], &[0.3, 0.4]);
        assert!((sums.relative_error(2).unwrap() - 0.1).abs() < 1e-7);
        sums.add(&NoiseSums::of_layers(&[0.0, 0.0, 12.0], &[0.0, 0.0, 1.2]));
        assert!((sums.total_sq - 169.0).abs() < 1e-9, "{sums:?}");
        assert!((sums.stderr_sq - 1.69).abs() < 1e-6, "{sums:?}");
        assert!((sums.relative_error(64).unwrap() - 0.1).abs() < 1e-7);
    }

    #[test]
    fn black_has_no_relative_error() {
        assert_eq!(NoiseSums::default().relative_error(16), None);
        assert_eq!(
            NoiseSums::of_layers(&[0.0; 6], &[0.0; 6]).relative_error(16),
            None
        );
    }

    /// At 1 spp the `stderr` layer is all zeros, which is no estimate: unknown, not 0.
    #[test]
    fn one_sample_per_pixel_has_an_unknown_relative_error() {
        let sums = NoiseSums::of_layers(&[3.0, 4.0], &[0.0, 0.0]);
        assert_eq!(sums.relative_error(1), None);
        assert_eq!(sums.relative_error(2), Some(0.0));
    }
}
