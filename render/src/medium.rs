//! Homogeneous participating media: extinction, scattering and the phase function.
//!
//! A medium fills a dielectric object. Light inside is attenuated by Beer–Lambert,
//! `T(d) = exp(−σ_t d)` per channel, and scatters with coefficient `σ_s = albedo · σ_t` into
//! directions given by the phase function.

use glam::DVec3;
use spindle_common::scene as desc;

use crate::Rgb;

/// The angular distribution of scattering. `cos_theta` is the cosine between the two
/// **propagation** directions (incoming light's and scattered light's), so forward scattering
/// (`g > 0`) peaks at `cos_theta = 1`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PhaseFunction {
    Isotropic,
    /// Henyey–Greenstein, `p = (1−g²) / (4π (1 + g² − 2g cos θ)^{3/2})`, `g ∈ (−1, 1)`.
    HenyeyGreenstein {
        g: f64,
    },
}

impl PhaseFunction {
    /// The density per steradian; integrates to 1 over the sphere.
    pub fn eval(&self, cos_theta: f64) -> f64 {
        const INV_4PI: f64 = 1.0 / (4.0 * std::f64::consts::PI);
        match *self {
            PhaseFunction::Isotropic => INV_4PI,
            PhaseFunction::HenyeyGreenstein { g } => {
                let denom = 1.0 + g * g - 2.0 * g * cos_theta.clamp(-1.0, 1.0);
                INV_4PI * (1.0 - g * g) / (denom * denom.sqrt())
            }
        }
    }
}

/// A homogeneous medium (coefficients per scene unit).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Medium {
    pub sigma_t: Rgb,
    pub sigma_s: Rgb,
    pub phase: PhaseFunction,
}

/// What is wrong with a medium; the field is named relative to the medium.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MediumError {
    #[error("sigma_t: every component must be finite and >= 0, got {0:?}")]
    SigmaT([f64; 3]),
    #[error("albedo: every component must be in [0, 1], got {0:?}")]
    Albedo([f64; 3]),
    #[error("phase.g: must be in (-1, 1), got {0}")]
    G(f64),
}

impl Medium {
    pub fn new(m: &desc::Medium) -> Result<Medium, MediumError> {
        let sigma_t = DVec3::from_array(m.sigma_t);
        if !sigma_t.is_finite() || sigma_t.min_element() < 0.0 {
            return Err(MediumError::SigmaT(m.sigma_t));
        }
        let albedo = DVec3::from_array(m.albedo);
        if !albedo.is_finite() || albedo.min_element() < 0.0 || albedo.max_element() > 1.0 {
            return Err(MediumError::Albedo(m.albedo));
        }
        let phase = match m.phase {
            desc::Phase::Isotropic => PhaseFunction::Isotropic,
            desc::Phase::Hg { g } => {
                if !(g.is_finite() && g > -1.0 && g < 1.0) {
                    return Err(MediumError::G(g));
                }
                PhaseFunction::HenyeyGreenstein { g }
            }
        };
        Ok(Medium {
            sigma_t,
            sigma_s: albedo * sigma_t,
            phase,
        })
    }

    /// Beer–Lambert transmittance over `distance`.
    pub fn transmittance(&self, distance: f64) -> Rgb {
        (-self.sigma_t * distance).exp()
    }
}

#[cfg(test)]
mod tests {
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
}
