//! The densities against brute force: CDF inversion against quadrature of the density, exactness
//! of the one-sample rule on a piecewise exponential, unbiasedness of jittered multi-group
//! sampling on an arbitrary integrand, and finite weights at the extremes.

use super::*;
use glam::DVec3;

/// ∫ f over [a, b] by the composite midpoint rule with n panels.
fn midpoint(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    (0..n).map(|i| f(a + (i as f64 + 0.5) * h)).sum::<f64>() * h
}

/// ∫ f over [a, b] with panels graded geometrically toward both ends (down to 1e-12 of the
/// width), 2,000 midpoints each: exact to ~1e-7 for integrands that decay exponentially from an
/// end on any scale.
fn graded(f: impl Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    let mut cuts = vec![0.0];
    cuts.extend((0..12).map(|i| 10f64.powi(i - 12)));
    cuts.push(0.5);
    cuts.extend((0..12).rev().map(|i| 1.0 - 10f64.powi(i - 12)));
    cuts.push(1.0);
    cuts.windows(2)
        .map(|w| midpoint(&f, a + w[0] * (b - a), a + w[1] * (b - a), 2000))
        .sum()
}

/// A deterministic stream of uniform numbers in [0, 1).
fn uniforms(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[test]
fn inverted_cdf_matches_quadrature() {
    for z in [-40.0, -3.0, -1e-14, 0.0, 1e-13, 0.7, 25.0, 700.0, 5e4] {
        for f in [0.0, 0.1, 0.5, 0.9, 0.999] {
            let s = invert_exponential(z, f);
            let density = |x: f64| (-z * x).exp();
            let cdf = graded(density, 0.0, s) / graded(density, 0.0, 1.0);
            assert!((cdf - f).abs() < 1e-6, "z {z} f {f}: s {s}, cdf {cdf}");
            assert!((0.0..=1.0).contains(&s), "z {z} f {f}: s {s}");
        }
    }
    // Very steep: the quantile is the exponential distribution's, −ln(1 − f)/z.
    let s = invert_exponential(5e4, 0.5);
    assert!(
        (s * 5e4 / std::f64::consts::LN_2 - 1.0).abs() < 1e-12,
        "{s}"
    );
}

/// With ℓ exactly piecewise linear and nothing else varying, one midpoint sample per density is
/// exact: `w · e^{−σ ℓ(t)}` equals `∫ e^{−σ ℓ}`, for every σ from 0 to 1e6.
#[test]
fn one_sample_is_exact_on_the_attenuation_itself() {
    let profile = PathLengths::new([(0.1, 0.3), (0.2, 0.45), (0.6, 0.5), (1.0, 0.4)]);
    for sigma in [0.0, 1e-3, 1.0, 30.0, 1e3, 1e6] {
        let density = DepthDensity::new(profile, DVec3::splat(sigma)).unwrap();
        let l_min = 0.3;
        let knots = profile.knots();
        let truth: f64 = knots
            .windows(2)
            .map(|w| graded(|t| (-sigma * (profile.at(t) - l_min)).exp(), w[0].0, w[1].0))
            .sum();
        let mut estimate = 0.0;
        density.for_each(
            1,
            |_| 0.5,
            |s| {
                estimate += (s.ln_weight.x - sigma * (profile.at(s.t) - l_min)).exp();
            },
        );
        assert!(
            (estimate / truth - 1.0).abs() < 1e-6,
            "σ {sigma}: {estimate:e} vs {truth:e}"
        );
    }
}

/// Jittered samples of three channel groups, each channel estimated from its own group, are
/// unbiased for an integrand unrelated to the densities: the mean over many runs matches
/// quadrature.
#[test]
fn jittered_groups_are_unbiased() {
    let profile = PathLengths::new([(0.0, 0.0), (0.5, 1.2), (2.0, 2.0)]);
    let sigma_t = DVec3::new(0.2, 3.0, 40.0);
    let density = DepthDensity::new(profile, sigma_t).unwrap();
    assert_eq!(density.groups.iter().flatten().count(), 3);
    // The integrand per channel: attenuation with a true ℓ that differs from the profile, times
    // a bump.
    let l_true = |t: f64| 1.1 * t + 0.3 * (3.0 * t).sin().powi(2);
    let f = |t: f64, sigma: f64| (1.0 + (5.0 * t).cos() * 0.5) * (-sigma * l_true(t)).exp();
    let mut rng = uniforms(7);
    let runs = 4000;
    let k = 2;
    let mut mean = DVec3::ZERO;
    for _ in 0..runs {
        let u = rng();
        density.for_each(
            k,
            |i| (u + f64::from(i) * 0.618_033_988_749_894_9).fract(),
            |s| {
                for c in 0..3 {
                    let sigma = sigma_t[c];
                    mean[c] += ((s.ln_weight[c] - sigma * l_true(s.t)).exp())
                        * (1.0 + (5.0 * s.t).cos() * 0.5);
                }
            },
        );
    }
    mean /= runs as f64;
    for c in 0..3 {
        let truth = midpoint(|t| f(t, sigma_t[c]), 0.0, 2.0, 200_000);
        assert!(
            (mean[c] / truth - 1.0).abs() < 0.01,
            "channel {c}: mean {:e} vs {truth:e}",
            mean[c]
        );
    }
}

/// Gray media use one density; channels far apart in σ get one each; close ones share.
#[test]
fn channels_group_by_optical_span() {
    let profile = PathLengths::new([(0.0, 0.0), (1.0, 2.0)]);
    let groups = |s: DVec3| {
        DepthDensity::new(profile, s)
            .unwrap()
            .groups
            .iter()
            .flatten()
            .count()
    };
    assert_eq!(groups(DVec3::splat(100.0)), 1);
    assert_eq!(groups(DVec3::new(1.0, 1.2, 1.4)), 1);
    assert_eq!(groups(DVec3::new(1.0, 1.2, 100.0)), 2);
    assert_eq!(groups(DVec3::new(1.0, 10.0, 100.0)), 3);
}

/// Extreme σ and degenerate profiles give finite weights or no density, never NaN.
#[test]
fn extremes_stay_finite() {
    assert!(DepthDensity::new(PathLengths::new([(0.5, 0.5)]), DVec3::ONE).is_none());
    assert!(DepthDensity::new(PathLengths::new([]), DVec3::ONE).is_none());
    let profile = PathLengths::new([(0.0, 3.0), (1e-9, 3.0 + 2e-9), (10.0, 1.0)]);
    for sigma in [0.0, 1e-300, 1.0, 1e8, 1e300] {
        let density = DepthDensity::new(profile, DVec3::splat(sigma)).unwrap();
        for k in [1, 7] {
            density.for_each(
                k,
                |i| f64::from(i % 3) / 3.0,
                |s| {
                    assert!((0.0..=10.0).contains(&s.t), "σ {sigma}: t {}", s.t);
                    assert!(s.ln_weight.x.is_finite(), "σ {sigma}: {s:?}");
                },
            );
        }
    }
}
