//! Light sources: isotropic point lights, spherical and rectangular (quad) area lights, and
//! distant (directional) lights.
//!
//! A directional light — the sun — is parallel rays, or a small disk of directions. Where the
//! single-scattering solve needs a light *point*, it gets one [`FAR`] scene radii away against
//! the rays, whose irradiance is made exact at every receiver (`LightPoint::Distant`): the only
//! approximation left is that rays from that point spread by at most `1/FAR` radians.
//!
//! Lights live in the air, or inside one medium (a point, sphere or quad light). Area lights are
//! seen by camera paths (directly, in reflection and in transmission) through
//! [`Light::intersect`], and light diffuse surfaces through [`Light::sample_incident`]: a sphere
//! uniformly over the cone it subtends, a quad uniformly over its spherical rectangle
//! ([`rectangle`]) — both by solid angle, so no sample is wasted on a side the receiver cannot
//! see. [`Light::sample_area`] samples an area light by area, for integrators that need a point
//! and a normal on the light.

use glam::DVec3;
use spindle_common::scene as desc;
use spindle_common::validate::MAX_ANGULAR_DIAMETER;

use crate::Rgb;
use crate::ray::Ray;

pub mod rectangle;

use rectangle::SphericalRectangle;

/// A light source.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Light {
    /// Isotropic point light; `intensity` in W/sr.
    Point { position: DVec3, intensity: Rgb },
    /// A sphere emitting `radiance` uniformly from its surface.
    Sphere {
        center: DVec3,
        radius: f64,
        radiance: Rgb,
    },
    /// A distant light: rays travel along the unit `direction` from a disk of directions of
    /// half-angle `acos(cos_half_angle)` (1: parallel rays), giving `irradiance` on a surface
    /// facing it. Where a light *point* is needed it is put `distance` (= [`FAR`] scene radii)
    /// from the scene's centre `anchor`, against the rays.
    Directional {
        direction: DVec3,
        irradiance: Rgb,
        cos_half_angle: f64,
        anchor: DVec3,
        distance: f64,
    },
    /// A one-sided rectangle `corner + s·edge_u + t·edge_v` (`s, t ∈ [0, 1]`; the edges exactly
    /// perpendicular) emitting `radiance` toward the unit `normal = edge_u × edge_v / |…|`.
    Quad {
        corner: DVec3,
        edge_u: DVec3,
        edge_v: DVec3,
        normal: DVec3,
        radiance: Rgb,
    },
}

/// How far, in radii of the objects' bounding sphere, a directional light's points are put:
/// rays from one point to anywhere in the scene differ in direction by at most `1/FAR` radians
/// (0.0057°, a fiftieth of the sun's own angular radius), and [`Light::Directional`]'s
/// irradiance does not fall off with distance (see `LightPoint::Distant`).
pub const FAR: f64 = 1e4;

/// The sphere the objects lie in, which a directional light must reach from afar.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneSphere {
    pub center: DVec3,
    pub radius: f64,
}

/// Light arriving at a point from one light sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IncidentSample {
    /// Unit direction from the receiver toward the light.
    pub dir: DVec3,
    /// Distance to the sampled light point (for the shadow ray).
    pub distance: f64,
    /// Radiance over the direction pdf (sphere) or intensity over distance² (point): multiply
    /// by the BSDF and the receiver's cosine for the estimate of reflected radiance.
    pub weight: Rgb,
}

/// A point sampled on a light's surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AreaSample {
    pub point: DVec3,
    /// Unit outward normal of the light at `point`.
    pub normal: DVec3,
    /// Density per unit area.
    pub pdf_area: f64,
}

/// What is wrong with a light; the field is named relative to the light.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LightError {
    #[error("{field}: must be finite and >= 0 in every component, got {value:?}")]
    Power {
        field: &'static str,
        value: [f64; 3],
    },
    #[error("{field}: must be finite, got {value:?}")]
    Position {
        field: &'static str,
        value: [f64; 3],
    },
    #[error("radius: must be finite and > 0, got {0}")]
    Radius(f64),
    #[error("direction: must be a finite, non-zero direction, got {0:?}")]
    Direction([f64; 3]),
    #[error("angular_diameter: must be in [0, 30] degrees, got {0}")]
    AngularDiameter(f64),
    #[error(
        "{field}: must be a finite edge of positive length perpendicular to the other, got {value:?}"
    )]
    Edge {
        field: &'static str,
        value: [f64; 3],
    },
}

fn power(field: &'static str, v: [f64; 3]) -> Result<Rgb, LightError> {
    let c = DVec3::from_array(v);
    if c.is_finite() && c.min_element() >= 0.0 {
        Ok(c)
    } else {
        Err(LightError::Power { field, value: v })
    }
}

fn position(field: &'static str, v: [f64; 3]) -> Result<DVec3, LightError> {
    let p = DVec3::from_array(v);
    if p.is_finite() {
        Ok(p)
    } else {
        Err(LightError::Position { field, value: v })
    }
}

impl Light {
    /// The light's position (a sphere light's centre; a directional light's far point).
    pub fn center(&self) -> DVec3 {
        match *self {
            Light::Point { position, .. } => position,
            Light::Sphere { center, .. } => center,
            Light::Directional {
                direction,
                anchor,
                distance,
                ..
            } => anchor - direction * distance,
            Light::Quad {
                corner,
                edge_u,
                edge_v,
                ..
            } => corner + 0.5 * (edge_u + edge_v),
        }
    }

    /// The light of a scene description; a directional light is placed against `scene`.
    pub fn new(light: &desc::Light, scene: SceneSphere) -> Result<Light, LightError> {
        Ok(match *light {
            desc::Light::Point {
                position: p,
                intensity,
            } => Light::Point {
                position: position("position", p)?,
                intensity: power("intensity", intensity)?,
            },
            desc::Light::Sphere {
                center,
                radius,
                radiance,
            } => {
                if !(radius.is_finite() && radius > 0.0) {
                    return Err(LightError::Radius(radius));
                }
                Light::Sphere {
                    center: position("center", center)?,
                    radius,
                    radiance: power("radiance", radiance)?,
                }
            }
            desc::Light::Directional {
                direction,
                irradiance,
                angular_diameter,
            } => {
                let d = DVec3::from_array(direction);
                let unit = (d / d.abs().max_element())
                    .try_normalize()
                    .filter(|_| d.is_finite())
                    .ok_or(LightError::Direction(direction))?;
                if !(angular_diameter.is_finite()
                    && (0.0..=MAX_ANGULAR_DIAMETER).contains(&angular_diameter))
                {
                    return Err(LightError::AngularDiameter(angular_diameter));
                }
                Light::Directional {
                    direction: unit,
                    irradiance: power("irradiance", irradiance)?,
                    cos_half_angle: (0.5 * angular_diameter).to_radians().cos(),
                    anchor: scene.center,
                    distance: FAR * scene.radius.max(f64::MIN_POSITIVE),
                }
            }
            desc::Light::Quad {
                corner,
                edge_u,
                edge_v,
                radiance,
            } => {
                let u = DVec3::from_array(edge_u);
                let v = DVec3::from_array(edge_v);
                let edge = |field, e: DVec3, value| {
                    if e.is_finite() && e.length() > 0.0 {
                        Ok(e)
                    } else {
                        Err(LightError::Edge { field, value })
                    }
                };
                let u = edge("edge_u", u, edge_u)?;
                let unit_u = u.normalize();
                // Validation allows |cos| ≤ 1e-6 between the edges; remove that component.
                let v = edge("edge_v", v - v.dot(unit_u) * unit_u, edge_v)?;
                if u.normalize()
                    .dot(DVec3::from_array(edge_v).normalize())
                    .abs()
                    > 1e-6
                {
                    return Err(LightError::Edge {
                        field: "edge_v",
                        value: edge_v,
                    });
                }
                Light::Quad {
                    corner: position("corner", corner)?,
                    edge_u: u,
                    edge_v: v,
                    normal: u.cross(v).normalize(),
                    radiance: power("radiance", radiance)?,
                }
            }
        })
    }

    /// For a directional light with a disk of directions: its radiance `E / (π sin²α)` (the
    /// irradiance `E` of a disk of half-angle α at normal incidence is `L π sin²α`).
    fn disk_radiance(irradiance: Rgb, cos_half_angle: f64) -> Rgb {
        let sin2 = (1.0 - cos_half_angle * cos_half_angle).max(0.0);
        irradiance / (std::f64::consts::PI * sin2)
    }

    /// A direction of a directional light's disk toward the light (against the rays), from two
    /// uniform numbers, and the weight `L / pdf_ω` it carries (`E` itself for parallel rays).
    pub fn distant_direction(&self, u: [f64; 2]) -> Option<(DVec3, Rgb)> {
        let Light::Directional {
            direction,
            irradiance,
            cos_half_angle,
            ..
        } = *self
        else {
            return None;
        };
        if cos_half_angle >= 1.0 {
            return Some((-direction, irradiance));
        }
        let one_minus_cos_max = 1.0 - cos_half_angle;
        let one_minus_cos = u[0] * one_minus_cos_max;
        let cos = 1.0 - one_minus_cos;
        let sin = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0).sqrt();
        let phi = 2.0 * std::f64::consts::PI * u[1];
        let (t1, t2) = (-direction).any_orthonormal_pair();
        let dir = (-direction * cos + (t1 * phi.cos() + t2 * phi.sin()) * sin).normalize();
        let weight = Light::disk_radiance(irradiance, cos_half_angle)
            * (2.0 * std::f64::consts::PI * one_minus_cos_max);
        Some((dir, weight))
    }

    /// The nearest `t > 0` where `ray` (unit direction) hits the light's surface, and the
    /// radiance it sees there. Point lights cannot be hit.
    pub fn intersect(&self, ray: &Ray) -> Option<(f64, Rgb)> {
        match *self {
            Light::Point { .. } => None,
            Light::Sphere {
                center,
                radius,
                radiance,
            } => sphere_hit(ray.origin, ray.dir, center, radius).map(|t| (t, radiance)),
            // Behind everything: any surface hit is nearer.
            Light::Directional {
                direction,
                irradiance,
                cos_half_angle,
                ..
            } => (cos_half_angle < 1.0 && ray.dir.dot(-direction) >= cos_half_angle)
                .then(|| (f64::MAX, Light::disk_radiance(irradiance, cos_half_angle))),
            // One-sided: seen from behind it is there, and black.
            Light::Quad {
                corner,
                edge_u,
                edge_v,
                normal,
                radiance,
            } => {
                let facing = ray.dir.dot(normal);
                let t = (corner - ray.origin).dot(normal) / facing;
                if !(t > 0.0 && t.is_finite()) {
                    return None;
                }
                let local = ray.origin + t * ray.dir - corner;
                let s = local.dot(edge_u) / edge_u.length_squared();
                let r = local.dot(edge_v) / edge_v.length_squared();
                let seen = if facing < 0.0 { radiance } else { Rgb::ZERO };
                ((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&r)).then_some((t, seen))
            }
        }
    }

    /// One light sample for a receiver at `p` from two uniform numbers. `None` when the
    /// receiver is inside a sphere light or the light is black.
    pub fn sample_incident(&self, p: DVec3, u: [f64; 2]) -> Option<IncidentSample> {
        match *self {
            Light::Point {
                position,
                intensity,
            } => {
                let to = position - p;
                let d2 = to.length_squared();
                let distance = d2.sqrt();
                (distance > 0.0).then(|| IncidentSample {
                    dir: to / distance,
                    distance,
                    weight: intensity / d2,
                })
            }
            Light::Sphere {
                center,
                radius,
                radiance,
            } => {
                let to = center - p;
                let dc = to.length();
                if dc <= radius {
                    return None;
                }
                let axis = to / dc;
                // Uniform in the subtended cone; 1 − cos θmax written without cancellation.
                let sin2_max = (radius / dc).powi(2);
                let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
                let one_minus_cos_max = sin2_max / (1.0 + cos_max);
                let one_minus_cos = u[0] * one_minus_cos_max;
                let cos = 1.0 - one_minus_cos;
                let sin = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0).sqrt();
                let phi = 2.0 * std::f64::consts::PI * u[1];
                let (t1, t2) = axis.any_orthonormal_pair();
                let dir = (axis * cos + (t1 * phi.cos() + t2 * phi.sin()) * sin).normalize();
                // Distance to the near surface; at the silhouette, the tangent distance.
                let distance = sphere_hit(p, dir, center, radius)
                    .unwrap_or_else(|| (dc * dc - radius * radius).max(0.0).sqrt());
                let pdf = 1.0 / (2.0 * std::f64::consts::PI * one_minus_cos_max);
                Some(IncidentSample {
                    dir,
                    distance,
                    weight: radiance / pdf,
                })
            }
            Light::Directional { distance, .. } => {
                let (dir, weight) = self.distant_direction(u)?;
                // Twice the far point's distance: past every object, wherever `p` is among them.
                Some(IncidentSample {
                    dir,
                    distance: 2.0 * distance,
                    weight,
                })
            }
            Light::Quad {
                corner,
                edge_u,
                edge_v,
                normal,
                radiance,
            } => {
                // Only the front side emits.
                if (p - corner).dot(normal) <= 0.0 {
                    return None;
                }
                let (y, weight) = match SphericalRectangle::new(p, corner, edge_u, edge_v) {
                    Some(rect) => (rect.sample(u), radiance * rect.solid_angle()),
                    None => {
                        // Small as seen from `p`: by area, `L cos_y / (pdf_A r²)` per sample.
                        let a = self.sample_area(u)?;
                        let to = p - a.point;
                        let d2 = to.length_squared();
                        let cos_y = normal.dot(to) / d2.sqrt();
                        (a.point, radiance * (cos_y / (a.pdf_area * d2)))
                    }
                };
                let to = y - p;
                let distance = to.length();
                (distance > 0.0 && weight.is_finite()).then(|| IncidentSample {
                    dir: to / distance,
                    distance,
                    weight,
                })
            }
        }
    }

    /// A point uniformly distributed over an area light's surface (`None` for a point or
    /// directional light).
    pub fn sample_area(&self, u: [f64; 2]) -> Option<AreaSample> {
        match *self {
            Light::Quad {
                corner,
                edge_u,
                edge_v,
                normal,
                ..
            } => Some(AreaSample {
                point: corner + u[0] * edge_u + u[1] * edge_v,
                normal,
                pdf_area: 1.0 / (edge_u.length() * edge_v.length()),
            }),
            Light::Point { .. } | Light::Directional { .. } => None,
            Light::Sphere { center, radius, .. } => {
                let z = 1.0 - 2.0 * u[0];
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = 2.0 * std::f64::consts::PI * u[1];
                let normal = DVec3::new(r * phi.cos(), r * phi.sin(), z);
                Some(AreaSample {
                    point: center + radius * normal,
                    normal,
                    pdf_area: 1.0 / (4.0 * std::f64::consts::PI * radius * radius),
                })
            }
        }
    }
}

/// The nearest `t > 0` where `origin + t·dir` (unit `dir`) meets the sphere.
fn sphere_hit(origin: DVec3, dir: DVec3, center: DVec3, radius: f64) -> Option<f64> {
    // Stable form: distance along the ray to the closest approach, then the half chord.
    let oc = center - origin;
    let along = oc.dot(dir);
    let closest = oc - along * dir;
    let h2 = radius * radius - closest.length_squared();
    if h2 < 0.0 {
        return None;
    }
    let half = h2.sqrt();
    let (near, far) = (along - half, along + half);
    if near > 0.0 {
        Some(near)
    } else if far > 0.0 {
        Some(far)
    } else {
        None
    }
}

#[cfg(test)]
mod tests;
