//! One light point per camera sample, in the role of the point light of [H15] eq. 10.
//!
//! Every single-scattering method connects a whole camera segment to one light *point* `L`: the
//! refraction solve needs fixed ends. A point light is used as it is. An area light becomes one
//! point per camera sample (per light) that acts as a point light of direction-dependent
//! intensity `I_eff(ω)` toward a receiver in direction `ω` from it (physics.md §1.1, "Area
//! lights"); the methods only ever ask for `I_eff` of the path they solved.
//!
//! **A sphere light is sampled inside** (when the object's bounding sphere is clear of it), and
//! then it is exactly a point light of intensity `π R² L_e` at a random place. The light that
//! reaches a receiver from a sphere of uniform radiance `L_e` is `L_e` along every line through
//! the sphere, and a line is as well named by any of its points inside the sphere as by the
//! point where it leaves. Along the lines of the pencil that reaches a receiver, `G(y) dV =
//! dω ds` (the pencil's cross-section times the point-light geometric factor is constant along
//! its straight part outside the object, refracted or not), so a point `y` of density `pdf_V`
//! is a point light of intensity `L_e / ∫_ℓ pdf_V ds`, the density integrated along its line
//! `ℓ` toward the receiver. The density here is the uniform distribution on the 3-sphere of
//! radius `R` in four dimensions, seen in three, `1/(π² R² √(R² − |y − c|²))`, whose integral
//! along *every* line through the sphere is `1/(π R²)`: the intensity is `π R² L_e` toward
//! every receiver, whatever the path. No weight varies; the only noise the light adds is that of
//! where its point falls (`Sampler::next_3d`: three numbers stratified together). The light
//! leaves the sphere beyond `y` ([`LightPoint::emitter_gap`]), where a shadow ray toward `y`
//! stops.
//!
//! **On the surface otherwise** (the object's bounding sphere reaches the light, so a receiver
//! may be inside it): points from a mixture of densities (one-sample, weighted by the mixture's
//! density, so unbiased), `I_eff(ω) = L_e · max(0, n_y·ω) / pdf_A(y)`; emission is one-sided (a
//! receiver behind the tangent plane at `y` sees the sphere's other side there). Most are drawn
//! by solid angle as seen from the apexes; the rest uniformly on the **cap of the sphere that can
//! be seen from the object's bounding sphere** (a cone about the axis toward the object, of
//! half-angle `acos(R/(d + r_o)) + asin(r_o/d)` for a light of radius `R` at distance `d` from the
//! centre of an object of bounding radius `r_o`): every point visible from anywhere in the object
//! can be drawn, and no weight exceeds `L_e / ((1 − share) pdf_cap)`. When the object's bounding
//! sphere reaches the light, the cap is the whole sphere; an apex inside the light has no share,
//! and when every apex is, only the cap is used.
//!
//! **A quad light** is sampled the same way on its surface: by solid angle from each apex in
//! front of it (its spherical rectangle seen from there) with the same share, else uniformly by
//! area, which covers every point and bounds every weight by `L_e · A / (1 − share)`; by area
//! alone when no apex is in front of the quad or sees it under less than
//! [`MIN_SOLID_ANGLE`](crate::light::rectangle::MIN_SOLID_ANGLE). Several lights are summed by
//! the caller, one sample each.
//!
//! Why the segment and not the object's centre: a light point serves every receiver of the
//! segment at once (the refraction solve needs it fixed), and the receivers of a segment see the
//! light from closer directions than those of the whole object's lit side (docs/benchmarks.md
//! §7b, §7c).

use glam::DVec3;

use crate::Rgb;
use crate::light::Light;
use crate::light::rectangle::SphericalRectangle;
use crate::sampler::Sampler;
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
    /// A point `position` inside a sphere light (`center`, `radius`), standing for the light's
    /// surface along every line through it: toward any receiver outside the sphere it sends
    /// `intensity`, and the light leaves the sphere [`emitter_gap`](Self::emitter_gap) beyond
    /// `y` (see the module doc).
    Ball {
        position: DVec3,
        center: DVec3,
        radius: f64,
        /// `π R² L_e`, the same toward every receiver outside the sphere.
        intensity: Rgb,
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
            | LightPoint::Ball { position, .. }
            | LightPoint::Distant { position, .. } => position,
        }
    }

    /// The intensity (W/sr) the point sends toward the receiver `p`: `I` for a point light,
    /// `π R² L_e` from inside a sphere light (to a receiver outside it), `L_e · max(0, n_y·ω) /
    /// pdf_A` for a point on an area light's surface (ω the unit direction from the light point
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
            LightPoint::Ball {
                center,
                radius,
                intensity,
                ..
            } => {
                if p.distance_squared(center) > radius * radius {
                    intensity
                } else {
                    Rgb::ZERO
                }
            }
            LightPoint::Distant {
                position,
                irradiance,
            } => irradiance * p.distance_squared(position),
        }
    }

    /// How far beyond the light point, along the unit direction `toward`, the light leaves its
    /// emitter: zero but for a point inside a sphere light, where it is the distance to the
    /// sphere. A shadow ray toward the light point stops there.
    pub fn emitter_gap(&self, toward: DVec3) -> f64 {
        match *self {
            LightPoint::Ball {
                position,
                center,
                radius,
                ..
            } => chord_through(position - center, radius, toward).map_or(0.0, |(_, ahead)| ahead),
            _ => 0.0,
        }
    }

    /// Whether the point emits nothing at all (zero power).
    pub fn is_black(&self) -> bool {
        match *self {
            LightPoint::Point { intensity, .. } => intensity.max_element() <= 0.0,
            LightPoint::Area {
                radiance_over_pdf, ..
            } => radiance_over_pdf.max_element() <= 0.0,
            LightPoint::Ball { intensity, .. } => intensity.max_element() <= 0.0,
            LightPoint::Distant { irradiance, .. } => irradiance.max_element() <= 0.0,
        }
    }
}

/// The share of area-light samples drawn by solid angle from the apexes; the rest are uniform on
/// the visible cap (sphere) or by area (quad), which bounds every sample's weight for receivers
/// anywhere in the object (the solid-angle densities vanish at the apexes' horizons, where other
/// receivers still see the light). Per-pixel relative error at 16 samples per pixel of the
/// lights study (docs/benchmarks.md §7b), sphere light of radius 0.1: 0.042 at a share of 0.8,
/// 0.034 at 0.9, 0.035 at 0.97 (radius 0.5: 0.048, 0.037, 0.046).
pub const SOLID_ANGLE_SHARE: f64 = 0.9;

/// Where the receivers of a light point are: anywhere in the object's bounding sphere, most of
/// them near the camera segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Receivers {
    pub object: BoundingSphere,
    /// The points an area light is sampled by solid angle from, with equal shares.
    pub apexes: [DVec3; APEXES],
}

/// How many points an area light is sampled by solid angle from.
pub const APEXES: usize = 3;

impl Receivers {
    /// Receivers anywhere in `object`, most of them near the camera segment
    /// `origin + t·dir, t ∈ [0, length]`: its two ends and its middle are the apexes.
    pub fn of_segment(object: BoundingSphere, origin: DVec3, dir: DVec3, length: f64) -> Receivers {
        Receivers {
            object,
            apexes: [origin, origin + 0.5 * length * dir, origin + length * dir],
        }
    }

    /// Receivers anywhere in `object`, most of them near its centre.
    pub fn about_centre(object: BoundingSphere) -> Receivers {
        Receivers {
            object,
            apexes: [object.center; APEXES],
        }
    }
}

/// The uniform numbers in `[0, 1)` a light point is drawn from: a pair for most lights, three
/// stratified together for a sphere light sampled inside. The renderer's [`Sampler`] gives them.
pub trait LightNumbers {
    fn pair(&mut self) -> [f64; 2];
    fn triple(&mut self) -> [f64; 3];
}

impl LightNumbers for Sampler {
    fn pair(&mut self) -> [f64; 2] {
        self.next_2d()
    }

    fn triple(&mut self) -> [f64; 3] {
        self.next_3d()
    }
}

/// The light point of `light` for a receiver anywhere in `receivers.object` (its bounding
/// sphere). Every light uses up one pair of numbers (a point light ignores it) but a sphere
/// light sampled inside, which takes a triple.
pub fn sample_light(
    light: &Light,
    receivers: Receivers,
    numbers: &mut impl LightNumbers,
) -> LightPoint {
    if let Light::Sphere {
        center,
        radius,
        radiance,
    } = *light
        && let Some(ball) = BallSampling::new(center, radius, receivers)
    {
        return LightPoint::Ball {
            position: ball.sample(numbers.triple()),
            center,
            radius,
            intensity: radiance * (std::f64::consts::PI * radius * radius),
        };
    }
    let u = numbers.pair();
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
            let sphere = SphereSampling::new(center, radius, receivers);
            let (position, normal) = sphere.sample(u);
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
            let rects = receivers.apexes.map(|apex| {
                ((apex - corner).dot(normal) > 0.0)
                    .then(|| SphericalRectangle::new(apex, corner, edge_u, edge_v))
                    .flatten()
            });
            let seen = rects.iter().flatten().count();
            let (position, pdf) = if seen == 0 {
                (by_area(u[0], u[1]), 1.0 / area)
            } else {
                let position = if u[0] < SOLID_ANGLE_SHARE {
                    let (k, u0) = pick(u[0] / SOLID_ANGLE_SHARE, seen);
                    let rect = rects.iter().flatten().nth(k).expect("k < seen");
                    rect.sample([u0, u[1]])
                } else {
                    by_area((u[0] - SOLID_ANGLE_SHARE) / (1.0 - SOLID_ANGLE_SHARE), u[1])
                };
                // By solid angle from an apex: `cos_y / (Ω r²)` per unit area.
                let by_angle: f64 = receivers
                    .apexes
                    .iter()
                    .zip(&rects)
                    .filter_map(|(&apex, rect)| {
                        let rect = rect.as_ref()?;
                        let to = apex - position;
                        let d2 = to.length_squared();
                        Some(normal.dot(to).max(0.0) / (d2.sqrt() * d2 * rect.solid_angle()))
                    })
                    .sum();
                let pdf =
                    SOLID_ANGLE_SHARE * by_angle / seen as f64 + (1.0 - SOLID_ANGLE_SHARE) / area;
                (position, pdf)
            };
            LightPoint::Area {
                position,
                normal,
                radiance_over_pdf: radiance / pdf,
            }
        }
    }
}

/// Where a sphere light's inside points are drawn: the uniform distribution on the 3-sphere of
/// radius `R` in four dimensions, its fourth coordinate dropped, density
/// `1 / (π² R² √(R² − |y − c|²))`. Along any line through the sphere at distance `ρ` from `c` it
/// integrates to `∫ ds / (π² R² √(h² − s²)) = 1/(π R²)` (`h² = R² − ρ²`), the same for every
/// line: so every line through the light is drawn alike, and the point is a point light of
/// intensity `π R² L_e` (see the module doc).
#[derive(Debug, Clone, Copy)]
struct BallSampling {
    center: DVec3,
    radius: f64,
}

impl BallSampling {
    /// The sampling for receivers in `receivers.object`, or `None` when that sphere reaches the
    /// light (a receiver inside the light would see no line through the sample leave it toward
    /// itself), where the light is sampled on its surface.
    fn new(center: DVec3, radius: f64, receivers: Receivers) -> Option<BallSampling> {
        let object = receivers.object;
        (center.distance(object.center) > (object.radius + radius) * (1.0 + 1e-9))
            .then_some(BallSampling { center, radius })
    }

    /// Uniform on the 3-sphere in Hopf coordinates (`sin² η` uniform, two angles), projected.
    fn sample(&self, [u0, u1, u2]: [f64; 3]) -> DVec3 {
        let eta = u0.sqrt().asin();
        let (a, b) = (std::f64::consts::TAU * u1, std::f64::consts::TAU * u2);
        let offset = DVec3::new(
            eta.cos() * a.cos(),
            eta.cos() * a.sin(),
            eta.sin() * b.cos(),
        );
        self.center + self.radius * offset
    }
}

/// For the point `offset` from a sphere's centre (inside it) and a unit direction `dir`, the
/// distances to the sphere backward and forward along `dir`; `None` when the line misses it.
fn chord_through(offset: DVec3, radius: f64, dir: DVec3) -> Option<(f64, f64)> {
    let b = offset.dot(dir);
    let c = offset.length_squared() - radius * radius;
    let disc = b * b - c;
    (disc >= 0.0).then(|| {
        let root = disc.sqrt();
        (b + root, root - b)
    })
}

/// The densities a sphere light's points are drawn from, and their mixture.
#[derive(Debug, Clone, Copy)]
struct SphereSampling {
    center: DVec3,
    radius: f64,
    cap: Cap,
    /// By solid angle from each apex; `None` for an apex inside the light.
    cones: [Option<Cone>; APEXES],
    /// How many of `cones` are `Some`.
    cone_count: usize,
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
    fn new(center: DVec3, radius: f64, receivers: Receivers) -> SphereSampling {
        let object = receivers.object;
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
        let cones = receivers
            .apexes
            .map(|apex| Cone::toward(apex, center, radius));
        SphereSampling {
            center,
            radius,
            cap,
            cones,
            cone_count: cones.iter().flatten().count(),
        }
    }

    /// A point of the mixture and its outward normal.
    fn sample(&self, u: [f64; 2]) -> (DVec3, DVec3) {
        if self.cone_count == 0 {
            return self.cap.sample(self.center, self.radius, u);
        }
        if u[0] >= SOLID_ANGLE_SHARE {
            let u0 = (u[0] - SOLID_ANGLE_SHARE) / (1.0 - SOLID_ANGLE_SHARE);
            return self.cap.sample(self.center, self.radius, [u0, u[1]]);
        }
        let (k, u0) = pick(u[0] / SOLID_ANGLE_SHARE, self.cone_count);
        let cone = self.cones.iter().flatten().nth(k).expect("k < cone_count");
        cone.sample(self.center, self.radius, [u0, u[1]])
    }

    /// The density by area of the mixture at the light point `y` with outward normal `n`.
    fn pdf_area(&self, y: DVec3, n: DVec3) -> f64 {
        let cap = self.cap.pdf_area(self.radius, n);
        if self.cone_count == 0 {
            return cap;
        }
        let cones: f64 = self.cones.iter().flatten().map(|c| c.pdf_area(y, n)).sum();
        SOLID_ANGLE_SHARE * cones / self.cone_count as f64 + (1.0 - SOLID_ANGLE_SHARE) * cap
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
    /// The cone a sphere light of `radius` about `center` subtends from `apex`; `None` when the
    /// apex is inside the light.
    fn toward(apex: DVec3, center: DVec3, radius: f64) -> Option<Cone> {
        let to_light = center - apex;
        let d = to_light.length();
        (d > radius).then(|| {
            let sin2 = (radius / d).powi(2);
            Cone {
                apex,
                axis: to_light / d,
                distance: d,
                one_minus_cos: sin2 / (1.0 + (1.0 - sin2).max(0.0).sqrt()),
            }
        })
    }

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

/// Which of `count` (≥ 1) equal shares of `[0, 1)` holds `u`, and `u` rescaled to `[0, 1)`
/// within it.
fn pick(u: f64, count: usize) -> (usize, f64) {
    let scaled = u * count as f64;
    let k = (scaled as usize).min(count - 1);
    (k, (scaled - k as f64).min(1.0 - f64::EPSILON / 2.0))
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
