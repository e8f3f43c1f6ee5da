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
mod tests;
