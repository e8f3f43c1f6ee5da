use super::*;

/// ∫ f(μ) dμ over [−1, 1] by the composite Simpson rule.
fn integrate(f: impl Fn(f64) -> f64) -> f64 {
    let n = 20_000;
    let h = 2.0 / n as f64;
    (0..=n)
        .map(|i| {
            let w = if i == 0 || i == n {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            w * f(-1.0 + i as f64 * h)
        })
        .sum::<f64>()
        * h
        / 3.0
}

#[test]
fn phase_functions_normalise_and_hg_has_mean_cosine_g() {
    let two_pi = 2.0 * std::f64::consts::PI;
    for p in [
        PhaseFunction::Isotropic,
        PhaseFunction::HenyeyGreenstein { g: 0.0 },
        PhaseFunction::HenyeyGreenstein { g: 0.3 },
        PhaseFunction::HenyeyGreenstein { g: -0.6 },
        PhaseFunction::HenyeyGreenstein { g: 0.8 },
    ] {
        let total = two_pi * integrate(|mu| p.eval(mu));
        assert!((total - 1.0).abs() < 1e-8, "{p:?}: {total}");
        let mean = two_pi * integrate(|mu| mu * p.eval(mu));
        let g = match p {
            PhaseFunction::Isotropic => 0.0,
            PhaseFunction::HenyeyGreenstein { g } => g,
        };
        assert!((mean - g).abs() < 1e-8, "{p:?}: mean cosine {mean}");
    }
    // Forward scattering peaks along the propagation direction.
    let hg = PhaseFunction::HenyeyGreenstein { g: 0.5 };
    assert!(hg.eval(1.0) > hg.eval(-1.0));
}

#[test]
fn bad_media_are_rejected_by_field() {
    let ok = desc::Medium {
        sigma_t: [1.0, 2.0, 3.0],
        albedo: [0.5, 0.5, 1.0],
        phase: desc::Phase::Isotropic,
    };
    let m = Medium::new(&ok).unwrap();
    assert_eq!(m.sigma_s, DVec3::new(0.5, 1.0, 3.0));
    assert!((m.transmittance(0.5).x - (-0.5f64).exp()).abs() < 1e-15);
    let e = Medium::new(&desc::Medium {
        sigma_t: [-1.0, 0.0, 0.0],
        ..ok.clone()
    });
    assert!(e.unwrap_err().to_string().starts_with("sigma_t:"));
    let e = Medium::new(&desc::Medium {
        albedo: [1.5, 0.0, 0.0],
        ..ok.clone()
    });
    assert!(e.unwrap_err().to_string().starts_with("albedo:"));
    let e = Medium::new(&desc::Medium {
        phase: desc::Phase::Hg { g: 1.0 },
        ..ok
    });
    assert!(e.unwrap_err().to_string().starts_with("phase.g:"));
}

/// Sampled directions follow the phase function: the empirical distribution of the cosine with
/// the axis matches the CDF of `eval` integrated by Simpson's rule (Kolmogorov–Smirnov distance
/// within its 99.9 % bound) for isotropic, near-isotropic, forward and backward scattering.
#[test]
fn sampled_directions_follow_the_phase_function() {
    let axis = DVec3::new(0.3, -0.5, 0.8).normalize();
    let two_pi = 2.0 * std::f64::consts::PI;
    for p in [
        PhaseFunction::Isotropic,
        PhaseFunction::HenyeyGreenstein { g: 0.0005 },
        PhaseFunction::HenyeyGreenstein { g: 0.7 },
        PhaseFunction::HenyeyGreenstein { g: -0.4 },
    ] {
        let n = 20_000usize;
        let mut cosines: Vec<f64> = (0..n)
            .map(|i| {
                // A plain low-discrepancy-free stream: a 64-bit LCG's top bits.
                let h = |k: u64| {
                    let x = (i as u64 * 2 + k)
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    ((x ^ (x >> 29)).wrapping_mul(0xBF58_476D_1CE4_E5B9) >> 11) as f64
                        / (1u64 << 53) as f64
                };
                let w = p.sample(axis, [h(0), h(1)]);
                assert!((w.length() - 1.0).abs() < 1e-12);
                w.dot(axis)
            })
            .collect();
        cosines.sort_by(f64::total_cmp);
        let mut worst: f64 = 0.0;
        for q in [-0.9, -0.5, 0.0, 0.3, 0.6, 0.9, 0.99] {
            // ∫ over [−1, q], mapped onto [−1, 1].
            let half = (q + 1.0) / 2.0;
            let cdf = two_pi * half * integrate(|x| p.eval(-1.0 + half * (x + 1.0)));
            let empirical = cosines.partition_point(|&c| c <= q) as f64 / n as f64;
            worst = worst.max((cdf - empirical).abs());
        }
        // The Kolmogorov–Smirnov critical value at 99.9 %: 1.95 / sqrt(n).
        assert!(
            worst < 1.95 / (n as f64).sqrt(),
            "{p:?}: KS distance {worst}"
        );
    }
}

/// `∫₀^L σ_s e^{−σ_t t} cos(t) dt` per channel, in closed form.
fn scattered_cosine(m: &Medium, length: f64) -> DVec3 {
    let one = |sigma_s: f64, sigma_t: f64| {
        // ∫ e^{−a t} cos t dt = e^{−a t} (sin t − a cos t) / (1 + a²).
        let f = |t: f64| {
            (-sigma_t * t).exp() * (t.sin() - sigma_t * t.cos()) / (1.0 + sigma_t * sigma_t)
        };
        sigma_s * (f(length) - f(0.0))
    };
    DVec3::new(
        one(m.sigma_s.x, m.sigma_t.x),
        one(m.sigma_s.y, m.sigma_t.y),
        one(m.sigma_s.z, m.sigma_t.z),
    )
}

/// Both distance samplers are unbiased: over evenly spread numbers, the mean of
/// `weight · cos(t)` of the scatterings is the closed-form integral
/// `∫₀^L σ_s e^{−σ_t t} cos t dt`, and the mean weight of reaching the end is `e^{−σ_t L}`, per
/// channel, for channels far apart (one without extinction included).
#[test]
fn distance_sampling_is_unbiased_per_channel() {
    let m = Medium::new(&desc::Medium {
        sigma_t: [0.0, 2.0, 30.0],
        albedo: [0.9, 0.5, 0.2],
        phase: desc::Phase::Isotropic,
    })
    .unwrap();
    let n = 300_000;
    for length in [0.05, 0.7, 3.0] {
        let expected = scattered_cosine(&m, length);
        let mut within = DVec3::ZERO;
        let (mut scattered, mut through) = (DVec3::ZERO, DVec3::ZERO);
        for i in 0..n {
            let u = (i as f64 + 0.5) / n as f64;
            let (t, w) = m.scatter_within(length, u).unwrap();
            assert!((0.0..length).contains(&t) || t == length);
            within += w * t.cos();
            match m.free_flight(length, u) {
                Flight::Scatter { t, weight } => {
                    assert!(t < length);
                    scattered += weight * t.cos();
                }
                Flight::Through { weight } => through += weight,
            }
        }
        let n = n as f64;
        let close = |a: DVec3, b: DVec3| {
            (a - b).abs().max_element() <= 2e-4 * (1.0 + b.abs().max_element())
        };
        assert!(
            close(within / n, expected),
            "L {length}: within {} vs {expected}",
            within / n
        );
        assert!(
            close(scattered / n, expected),
            "L {length}: free flight {} vs {expected}",
            scattered / n
        );
        assert!(
            close(through / n, m.transmittance(length)),
            "L {length}: through {}",
            through / n
        );
    }
    // Nothing scatters without σ_s, or on an empty segment.
    let clear = Medium {
        sigma_s: DVec3::ZERO,
        ..m
    };
    assert!(clear.scatter_within(1.0, 0.5).is_none());
    assert!(m.scatter_within(0.0, 0.5).is_none());
}
