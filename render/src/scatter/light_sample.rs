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
//! The points come from a mixture of two densities (one-sample, weighted by the mixture's
//! density, so unbiased). Most are drawn **by solid angle as seen from the object's centre**: the
//! weight `L_e · cos_y / pdf_A` is then constant for a receiver at the centre and nearly so for
//! receivers that see the light from about the same direction, which is what makes a small or
//! distant sphere light about as quiet as a point light. The rest are drawn uniformly on the
//! **cap of the sphere that can be seen from the object's bounding sphere** (a cone about the
//! axis toward the object, of half-angle `acos(R/(d + r_o)) + asin(r_o/d)` for a light of radius
//! `R` at distance `d` from the centre of an object of bounding radius `r_o`): every point visible
//! from anywhere in the object can be drawn, and no weight exceeds `L_e / ((1 − share) pdf_cap)`.
//! When the object's bounding sphere reaches the light, the cap is the whole sphere; when the
//! centre is inside the light, only the cap is used. A quad light is sampled the same way: by
//! solid angle from the object's centre (its spherical rectangle) with the same share, else
//! uniformly by area, which covers every point and bounds every weight by
//! `L_e · A / (1 − share)`; by area alone when the centre is behind the quad or sees it under
//! less than [`MIN_SOLID_ANGLE`](crate::light::rectangle::MIN_SOLID_ANGLE). Several lights are summed by the caller, one sample each.

use glam::DVec3;

use crate::Rgb;
use crate::light::Light;
use crate::light::rectangle::SphericalRectangle;
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
    /// A directional light's far point (`Light::Directional`): its intensity toward a receiver
    /// is `irradiance · ‖p − position‖²`, so the irradiance it gives is the same everywhere.
    Distant { position: DVec3, irradiance: Rgb },
}

impl LightPoint {
    /// Where the light point is.
    pub fn position(&self) -> DVec3 {
        match *self {
            LightPoint::Point { position, .. }
            | LightPoint::Area { position, .. }
            | LightPoint::Distant { position, .. } => position,
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
            LightPoint::Distant {
                position,
                irradiance,
            } => irradiance * p.distance_squared(position),
        }
    }

    /// Whether the point emits nothing at all (zero power).
    pub fn is_black(&self) -> bool {
        match *self {
            LightPoint::Point { intensity, .. } => intensity.max_element() <= 0.0,
            LightPoint::Area {
                radiance_over_pdf, ..
            } => radiance_over_pdf.max_element() <= 0.0,
            LightPoint::Distant { irradiance, .. } => irradiance.max_element() <= 0.0,
        }
    }
}

/// The share of sphere-light samples drawn by solid angle from the object's centre; the rest are
/// uniform on the visible cap, which bounds every sample's weight for receivers anywhere in the
/// object (the solid-angle density vanishes at the centre's horizon, where other receivers still
/// see the light). Measured per-sample relative spread of the fluence estimate at receivers on
/// the lit side of a unit sphere, light of radius 0.1 at distance 4: 0.84 for the cap alone;
/// 0.17 (centre) to 0.42 (85° off axis) at this share, against 0.46–0.51 at a share of ½.
pub const SOLID_ANGLE_SHARE: f64 = 0.9;

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
        Light::Directional {
            anchor, distance, ..
        } => {
            let (toward, irradiance) = light.distant_direction(u).unwrap_or_default();
            LightPoint::Distant {
                position: anchor + toward * distance,
                irradiance,
            }
        }
        Light::Sphere {
            center,
            radius,
            radiance,
        } => {
            let sphere = SphereSampling::new(center, radius, object);
            let (position, normal) = match sphere.solid_angle {
                Some(cone) if u[0] < SOLID_ANGLE_SHARE => cone.sample(
                    sphere.center,
                    sphere.radius,
                    [u[0] / SOLID_ANGLE_SHARE, u[1]],
                ),
                Some(_) => sphere.cap.sample(
                    sphere.center,
                    sphere.radius,
                    [(u[0] - SOLID_ANGLE_SHARE) / (1.0 - SOLID_ANGLE_SHARE), u[1]],
                ),
                None => sphere.cap.sample(sphere.center, sphere.radius, u),
            };
            // Every sample lies in the cap, whose share of the density is positive.
            let pdf = sphere.pdf_area(position, normal);
            LightPoint::Area {
                position,
                normal,
                radiance_over_pdf: if pdf > 0.0 { radiance / pdf } else { Rgb::ZERO },
            }
        }
        Light::Quad {
            corner,
            edge_u,
            edge_v,
            normal,
            radiance,
        } => {
            let area = edge_u.length() * edge_v.length();
            let by_area = |s: f64, t: f64| corner + s * edge_u + t * edge_v;
            let seen = ((object.center - corner).dot(normal) > 0.0)
                .then(|| SphericalRectangle::new(object.center, corner, edge_u, edge_v))
                .flatten();
            let (position, pdf) = match seen {
                Some(rect) => {
                    let position = if u[0] < SOLID_ANGLE_SHARE {
                        rect.sample([u[0] / SOLID_ANGLE_SHARE, u[1]])
                    } else {
                        by_area((u[0] - SOLID_ANGLE_SHARE) / (1.0 - SOLID_ANGLE_SHARE), u[1])
                    };
                    // By solid angle from the centre: `cos_y / (Ω r²)` per unit area.
                    let to = object.center - position;
                    let d2 = to.length_squared();
                    let by_angle = normal.dot(to).max(0.0) / (d2.sqrt() * d2 * rect.solid_angle());
                    let pdf = SOLID_ANGLE_SHARE * by_angle + (1.0 - SOLID_ANGLE_SHARE) / area;
                    (position, pdf)
                }
                None => (by_area(u[0], u[1]), 1.0 / area),
            };
            LightPoint::Area {
                position,
                normal,
                radiance_over_pdf: radiance / pdf,
            }
        }
    }
}

/// The two densities a sphere light's points are drawn from, and their mixture.
#[derive(Debug, Clone, Copy)]
struct SphereSampling {
    center: DVec3,
    radius: f64,
    cap: Cap,
    /// `None` when the object's centre is inside the light.
    solid_angle: Option<Cone>,
}

/// Uniform by area on the cap `n·axis ≥ 1 − one_minus_cos` of the light (the part visible from
/// the object's bounding sphere; the whole sphere when `one_minus_cos` is 2).
#[derive(Debug, Clone, Copy)]
struct Cap {
    axis: DVec3,
    one_minus_cos: f64,
}

/// Uniform in the cone of directions, seen from `apex`, that the light subtends; the point is
/// where the direction meets the light first. The density by area is `cos_y / (Ω · dist²)` on the
/// hemisphere visible from `apex`, zero elsewhere.
#[derive(Debug, Clone, Copy)]
struct Cone {
    apex: DVec3,
    axis: DVec3,
    distance: f64,
    /// `1 − cos θ_max`, written without cancellation.
    one_minus_cos: f64,
}

impl SphereSampling {
    fn new(center: DVec3, radius: f64, object: BoundingSphere) -> SphereSampling {
        // The cap of the light seen from the object's bounding sphere, as (axis, 1 − cos γ).
        let to_object = object.center - center;
        let d = to_object.length();
        let cap = match to_object.try_normalize() {
            Some(axis) if d > object.radius + radius => {
                let gamma = (radius / (d + object.radius)).acos() + (object.radius / d).asin();
                Cap {
                    axis,
                    one_minus_cos: if gamma < std::f64::consts::PI {
                        1.0 - gamma.cos()
                    } else {
                        2.0
                    },
                }
            }
            _ => Cap {
                axis: DVec3::Z,
                one_minus_cos: 2.0,
            },
        };
        let solid_angle = (d > radius).then(|| {
            let sin2 = (radius / d).powi(2);
            Cone {
                apex: object.center,
                axis: -to_object / d,
                distance: d,
                one_minus_cos: sin2 / (1.0 + (1.0 - sin2).max(0.0).sqrt()),
            }
        });
        SphereSampling {
            center,
            radius,
            cap,
            solid_angle,
        }
    }

    /// The density by area of the mixture at the light point `y` with outward normal `n`.
    fn pdf_area(&self, y: DVec3, n: DVec3) -> f64 {
        let cap = self.cap.pdf_area(self.radius, n);
        match self.solid_angle {
            Some(cone) => SOLID_ANGLE_SHARE * cone.pdf_area(y, n) + (1.0 - SOLID_ANGLE_SHARE) * cap,
            None => cap,
        }
    }
}

impl Cap {
    fn sample(&self, center: DVec3, radius: f64, u: [f64; 2]) -> (DVec3, DVec3) {
        // cos θ uniform in [1 − one_minus_cos, 1].
        let one_minus_cos = u[0] * self.one_minus_cos;
        let normal = around(self.axis, one_minus_cos, u[1]);
        (center + radius * normal, normal)
    }

    fn pdf_area(&self, radius: f64, n: DVec3) -> f64 {
        // A sample of the cap is inside it whatever the rounding of its normal.
        let inside = self.one_minus_cos >= 2.0
            || 1.0 - n.dot(self.axis) <= self.one_minus_cos * (1.0 + 1e-9) + 1e-15;
        if inside {
            1.0 / (std::f64::consts::TAU * radius * radius * self.one_minus_cos)
        } else {
            0.0
        }
    }
}

impl Cone {
    fn sample(&self, center: DVec3, radius: f64, u: [f64; 2]) -> (DVec3, DVec3) {
        let one_minus_cos = u[0] * self.one_minus_cos;
        let dir = around(self.axis, one_minus_cos, u[1]);
        let cos = 1.0 - one_minus_cos;
        let sin2 = one_minus_cos * (2.0 - one_minus_cos);
        // The nearer intersection; at the silhouette the chord closes (clamped).
        let half_chord = (radius * radius - self.distance * self.distance * sin2)
            .max(0.0)
            .sqrt();
        let y = self.apex + (self.distance * cos - half_chord) * dir;
        let normal = (y - center).try_normalize().unwrap_or(-self.axis);
        (center + radius * normal, normal)
    }

    fn pdf_area(&self, y: DVec3, n: DVec3) -> f64 {
        let to_apex = self.apex - y;
        let dist2 = to_apex.length_squared();
        let cos = n.dot(to_apex) / dist2.sqrt();
        if cos > 0.0 {
            cos / (std::f64::consts::TAU * self.one_minus_cos * dist2)
        } else {
            0.0
        }
    }
}

/// The unit vector at `1 − cos θ = one_minus_cos` from `axis`, at azimuth `2π·u`.
fn around(axis: DVec3, one_minus_cos: f64, u: f64) -> DVec3 {
    let cos = 1.0 - one_minus_cos;
    let sin = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0).sqrt();
    let phi = std::f64::consts::TAU * u;
    let (s, t) = axis.any_orthonormal_pair();
    (cos * axis + sin * (phi.cos() * s + phi.sin() * t)).normalize()
}

#[cfg(test)]
mod tests;
