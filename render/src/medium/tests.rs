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
