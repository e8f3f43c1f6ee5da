//! One light point per camera sample, in the role of the point light of [H15] eq. 10.
//!
//! Every single-scattering method connects a whole camera segment to one light *point* `L`: the
//! refraction solve needs fixed ends. A point light is used as it is. A sphere light is sampled
//! by area, one point `y` per camera sample (per light), and then acts as a point light of
//! direction-dependent intensity `I_eff(ω) = L_e · max(0, n_y·ω) / pdf_A(y)` toward a receiver
//! in direction `ω` from `y` (physics.md §1.1, "Area lights"). Emission is one-sided: a receiver
//! behind the tangent plane at `y` sees the sphere's other side there, so it gets nothing from
//! this sample (which is also what a shadow ray against the sphere would say).
//!
//! The points are drawn uniformly on the **cap of the sphere that can be seen from the object's
//! bounding sphere** (a cone about the axis toward the object, of half-angle
//! `acos(R/(d + r_o)) + asin(r_o/d)` for a light of radius `R` at distance `d` from the centre of
//! an object of bounding radius `r_o`), so no sample is spent on the far side of the light, yet
//! every point visible from anywhere in the object can be drawn (the estimator stays unbiased).
//! When the object's bounding sphere reaches the light, the whole sphere is sampled. Several
//! lights are summed by the caller, one sample each.

use glam::DVec3;

use crate::Rgb;
use crate::light::Light;
use crate::scatter::geometry::BoundingSphere;

/// A point that lights a camera segment, for one camera sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LightPoint {
    /// An isotropic point light of `intensity` W/sr.
    Point { position: DVec3, intensity: Rgb },
    /// A point `position` on an area light with unit outward `normal`, carrying
    /// `L_e / pdf_A` (radiance over the area density of the sample).
    Area {
        position: DVec3,
        normal: DVec3,
        radiance_over_pdf: Rgb,
    },
}

impl LightPoint {
    /// Where the light point is.
    pub fn position(&self) -> DVec3 {
        match *self {
            LightPoint::Point { position, .. } | LightPoint::Area { position, .. } => position,
        }
    }

    /// The intensity (W/sr) the point sends toward the receiver `p`: `I` for a point light,
    /// `L_e · max(0, n_y·ω) / pdf_A` for an area sample (ω the unit direction from the light point
    /// to `p`).
    pub fn intensity_toward(&self, p: DVec3) -> Rgb {
        match *self {
            LightPoint::Point { intensity, .. } => intensity,
            LightPoint::Area {
                position,
                normal,
                radiance_over_pdf,
            } => {
                let Some(toward) = (p - position).try_normalize() else {
                    return Rgb::ZERO;
                };
                radiance_over_pdf * normal.dot(toward).max(0.0)
            }
        }
    }

    /// Whether the point emits nothing at all (zero power).
    pub fn is_black(&self) -> bool {
        match *self {
            LightPoint::Point { intensity, .. } => intensity.max_element() <= 0.0,
            LightPoint::Area {
                radiance_over_pdf, ..
            } => radiance_over_pdf.max_element() <= 0.0,
        }
    }
}

/// The light point of `light` for a receiver anywhere in `object` (its bounding sphere), from two
/// uniform numbers in `[0, 1)`.
pub fn sample_light(light: &Light, object: BoundingSphere, u: [f64; 2]) -> LightPoint {
    match *light {
        Light::Point {
            position,
            intensity,
        } => LightPoint::Point {
            position,
            intensity,
        },
        Light::Sphere {
            center,
            radius,
            radiance,
        } => {
            // The cap of the light seen from the object's bounding sphere, as (axis, 1 − cos γ).
            let to_object = object.center - center;
            let d = to_object.length();
            let (axis, one_minus_cos) = match to_object.try_normalize() {
                Some(axis) if d > object.radius + radius => {
                    let gamma = (radius / (d + object.radius)).acos() + (object.radius / d).asin();
                    if gamma < std::f64::consts::PI {
                        (axis, 1.0 - gamma.cos())
                    } else {
                        (axis, 2.0)
                    }
                }
                _ => (DVec3::Z, 2.0),
            };
            // Uniform on the cap: cos θ uniform in [cos γ, 1].
            let cos_theta = 1.0 - u[0] * one_minus_cos;
            let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
            let phi = std::f64::consts::TAU * u[1];
            let (s, t) = axis.any_orthonormal_pair();
            let normal =
                (cos_theta * axis + sin_theta * (phi.cos() * s + phi.sin() * t)).normalize();
            let pdf_area = 1.0 / (std::f64::consts::TAU * radius * radius * one_minus_cos);
            LightPoint::Area {
                position: center + radius * normal,
                normal,
                radiance_over_pdf: radiance / pdf_area,
            }
        }
    }
}

#[cfg(test)]
mod tests;
