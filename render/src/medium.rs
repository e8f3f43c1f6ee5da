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

    /// A direction `ω` whose cosine with `axis` (a unit vector) is distributed by this phase
    /// function, from two uniform numbers, by inverting the cosine's distribution (the density
    /// of `ω` is then exactly [`PhaseFunction::eval`]`(ω · axis)`, so a sample's weight
    /// `eval / pdf` is 1). With `axis` the direction the path is traced in (away from the
    /// camera), `ω` is the next traced direction: the two propagation directions of the light
    /// are `−ω` and `−axis`, whose cosine is the same `ω · axis`.
    pub fn sample(&self, axis: DVec3, u: [f64; 2]) -> DVec3 {
        let cos_theta = match *self {
            PhaseFunction::HenyeyGreenstein { g } if g.abs() >= 1e-3 => {
                let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u[0]);
                ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
            }
            // Isotropic, and Henyey–Greenstein so close to it that the inversion above loses
            // its precision (its error is then below 1e-3 in the cosine's density).
            _ => 1.0 - 2.0 * u[0],
        };
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let phi = 2.0 * std::f64::consts::PI * u[1];
        let (b1, b2) = axis.any_orthonormal_pair();
        (axis * cos_theta + (b1 * phi.cos() + b2 * phi.sin()) * sin_theta).normalize()
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

    /// A scattering point on `[0, length)` of a path that must scatter there (the first
    /// scattering of a multiple-scattering path on a camera segment): the distance `t`, drawn
    /// by the attenuation truncated to the segment, and the weight `σ_s e^{−σ_t t} / p(t)` per
    /// channel. The channel whose σ_t draws the distance is picked uniformly and `p` is the
    /// mixture of the three channels' densities (the one-sample balance heuristic), so a
    /// channel that attenuates less is not starved. `None` when nothing scatters or the segment
    /// is empty. Uses `u[0]` for the channel and the distance together.
    pub fn scatter_within(&self, length: f64, u: f64) -> Option<(f64, Rgb)> {
        if !(length > 0.0 && length.is_finite()) || self.sigma_s.max_element() <= 0.0 {
            return None;
        }
        let (channel, v) = pick_channel(u);
        // The share of the channel's free flights that end within the segment.
        let within = |sigma: f64| -(-sigma * length).exp_m1();
        let sigma = self.sigma_t[channel];
        let t = if within(sigma) > 0.0 {
            (-(-v * within(sigma)).ln_1p() / sigma).min(length)
        } else {
            v * length
        };
        let density = |sigma: f64| {
            let w = within(sigma);
            if w > 0.0 {
                sigma * (-sigma * t).exp() / w
            } else {
                1.0 / length
            }
        };
        let pdf =
            (density(self.sigma_t.x) + density(self.sigma_t.y) + density(self.sigma_t.z)) / 3.0;
        (pdf > 0.0).then(|| (t, self.sigma_s * self.transmittance(t) / pdf))
    }

    /// Where a path travelling `length` through the medium next scatters, if it does before
    /// the end: free-flight distances by the attenuation (a channel's σ_t picked uniformly,
    /// weighted by the balance heuristic over the three, as [`Medium::scatter_within`]), with
    /// the weight that keeps the estimate unbiased: `σ_s e^{−σ_t t} / p(t)` for a scattering at
    /// `t`, `e^{−σ_t L} / P(L)` for reaching the end.
    pub fn free_flight(&self, length: f64, u: f64) -> Flight {
        let (channel, v) = pick_channel(u);
        let sigma = self.sigma_t[channel];
        let t = if sigma > 0.0 {
            -(-v).ln_1p() / sigma
        } else {
            f64::INFINITY
        };
        if t < length {
            let pdf = (self.sigma_t * (-self.sigma_t * t).exp()).element_sum() / 3.0;
            Flight::Scatter {
                t,
                weight: self.sigma_s * self.transmittance(t) / pdf,
            }
        } else {
            let transmittance = self.transmittance(length);
            let probability = transmittance.element_sum() / 3.0;
            Flight::Through {
                weight: if probability > 0.0 {
                    transmittance / probability
                } else {
                    Rgb::ZERO
                },
            }
        }
    }
}

/// Where a free flight ends ([`Medium::free_flight`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Flight {
    /// Scattered at distance `t`.
    Scatter { t: f64, weight: Rgb },
    /// Reached the end of the segment.
    Through { weight: Rgb },
}

/// A colour channel picked uniformly by `u`, and `u` stretched back onto `[0, 1)`.
fn pick_channel(u: f64) -> (usize, f64) {
    let scaled = u * 3.0;
    let channel = (scaled as usize).min(2);
    (
        channel,
        (scaled - channel as f64).clamp(0.0, 1.0 - f64::EPSILON),
    )
}

#[cfg(test)]
mod tests;
