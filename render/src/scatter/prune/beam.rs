//! The beam test: the cone test ([`cone`](super::cone)) answered in closed form. Seen from the
//! light, a refraction point `P` sends the light on along one direction `ω_V(P)` (the refracted
//! direction, from `Ĥ = −N̂s`), and a camera point `V` sees `P` only if `V = P + s·ω_V`, `s ≥ 0`.
//! Over a sphere of points whose shading normals lie in a cone, those directions lie in a cone
//! around the refraction of the light's direction at the centre by the cone's axis, of a
//! half-angle `α` bounded from the normal cone's and the light cone's half-angles (the refraction
//! map's largest stretch over every incidence the cones allow). So every camera point that sees a
//! solution lies in the beam `sphere ⊕ {s·ω : ∠(ω, axis) ≤ α, s ≥ 0}`, which is inside the convex
//! cone of half-angle `α` tangent to the sphere, cut by the plane a radius behind the centre. A
//! line meets a convex set in one interval: the test returns it exactly (one quadratic), where
//! the cone test bisects the range into pieces and bounds each.
//!
//! The beam exists for `η > 1` (a refracted direction for every incidence) with the light outside
//! the sphere and `α` below a right angle; elsewhere it says nothing and the cone test decides.

use glam::DVec3;

use crate::scatter::geometry::{BoundingSphere, NormalCone};
use crate::scatter::prune::SegmentQuery;
use crate::scatter::triangle::ends::DepthRange;

/// The beam is used only for media denser than `1 + MIN_ETA_EXCESS`: near η = 1 the refraction
/// map's stretch bound divides by a vanishing root at grazing incidence.
const MIN_ETA_EXCESS: f64 = 1e-3;
/// Relative widening of the beam's radius and additive widening of `α` and of the returned range:
/// they cover the rounding of the quadratic, so a point on the exact beam's boundary is kept.
const WIDEN: f64 = 1e-7;

/// What the beam says about a sphere of surface points and their normal cone.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum BeamBound {
    /// Every normal of the cone faces away from the light: no solution.
    Empty,
    /// Every camera point seeing a solution lies in this beam.
    Beam(Beam),
    /// Nothing is bounded (η near or below 1, the light inside the sphere, or the refracted
    /// directions spread over a right angle).
    Unbounded,
}

impl SegmentQuery {
    /// The beam of the sphere and normal cone for the query's light and η (see the module doc).
    pub(super) fn beam(&self, sphere: BoundingSphere, normals: NormalCone) -> BeamBound {
        BeamBound::of(self.ends.light, self.ends.eta, sphere, normals)
    }
}

impl BeamBound {
    /// The beam of the sphere and normal cone for the light point `light` and η: it depends on
    /// neither the camera segment nor the range.
    pub(super) fn of(light: DVec3, eta: f64, sphere: BoundingSphere, normals: NormalCone) -> Self {
        let to_light = light - sphere.center;
        let d_light = to_light.length();
        // (NaN bounds nothing.)
        let bounded = eta > 1.0 + MIN_ETA_EXCESS && d_light > sphere.radius;
        if !bounded {
            return BeamBound::Unbounded;
        }
        let light = to_light / d_light;
        // sin θ_L, the light cone's half-angle seen from the sphere.
        let sin_l = sphere.radius / d_light;
        // The central ray: η ω_V + ω_L = −μ N with |ω_V| = 1, so μ = R − c with R = √(c² + m²),
        // c = N·ω_L, m² = η² − 1 (μ = m²/(R + c), without cancellation for c ≥ 0).
        let m2 = eta * eta - 1.0;
        let mu_of = |c: f64| {
            let r = (c * c + m2).sqrt();
            if c >= 0.0 { m2 / (r + c) } else { r - c }
        };
        let c0 = normals.axis.dot(light);
        let mu0 = mu_of(c0);
        let Some(axis) = (-(mu0 * normals.axis + light)).try_normalize() else {
            return BeamBound::Unbounded;
        };
        // For the light's direction at the centre and N in the normal cone (N·A ≥ cos θ_N, c
        // between the cosines of γ ± θ_N, γ the angle from the axis A to the light):
        // η² ω_V(N)·ω_V(A) = μ(c)(μ0 N·A + c) + μ0 c0 + 1 ≥ m² h(c) + μ0 c0 + 1 with
        // h(c) = (μ0 cos θ_N + c)/(R(c) + c), which rises then falls in c, so is least at an end
        // of c's range. The light's own spread turns ω_V by at most θ_L/η (the stretch of
        // ω_L ↦ ω_V is at most 1/η for η > 1). No trigonometry: the angles are summed as
        // rotations, from their sines and cosines.
        let (cos_n, sin_n) = (normals.cos_wide, normals.sin_wide);
        let sin_gamma = normals.axis.cross(light).length();
        let c_lo = if c0 <= -cos_n {
            -1.0
        } else {
            c0 * cos_n - sin_gamma * sin_n
        };
        let c_hi = if c0 >= cos_n {
            1.0
        } else {
            c0 * cos_n + sin_gamma * sin_n
        };
        // A solution has the light in front of its normal (c_L > 0 at P, so N·û_L > −sin θ_L):
        // the normals facing away from the light need no bound, and if all do, nothing is kept.
        let facing = -sin_l - WIDEN;
        if c_hi < facing {
            return BeamBound::Empty;
        }
        let c_lo = c_lo.max(facing);
        let k = mu0 * cos_n;
        let h = |c: f64| {
            let r = (c * c + m2).sqrt();
            (k + c) / (r + c)
        };
        let cos_dev = (m2 * h(c_lo.max(-1.0)).min(h(c_hi.min(1.0))) + mu0 * c0 + 1.0) / (eta * eta);
        let cos_dev = cos_dev.clamp(-1.0, 1.0);
        let sin_dev = (1.0 - cos_dev * cos_dev).sqrt();
        // An angle x ≥ θ_L/η: sin x = tan θ_L / η ≥ θ_L/η ≥ sin(θ_L/η).
        let sin_x = (sin_l / (eta * (1.0 - sin_l * sin_l).sqrt())).min(1.0);
        let cos_x = (1.0 - sin_x * sin_x).sqrt();
        let (sin_a, cos_a) = rotate((sin_dev, cos_dev), (sin_x, cos_x));
        // The margin covers the rounding of sin_dev near 0 (≈ 5e-8 there) and of the sums.
        let (sin_a, cos_a) = rotate((sin_a, cos_a), (2.0 * WIDEN, 1.0));
        // α below a right angle by a margin; NaN bounds nothing.
        let narrow = cos_a > 1e-3 && sin_a >= 0.0;
        if !narrow {
            return BeamBound::Unbounded;
        }
        BeamBound::Beam(Beam {
            center: sphere.center,
            radius: sphere.radius * (1.0 + WIDEN),
            axis,
            sin: sin_a,
            cos: cos_a,
        })
    }
}

/// The sine and cosine of the sum of two angles, from theirs.
fn rotate((sin_a, cos_a): (f64, f64), (sin_b, cos_b): (f64, f64)) -> (f64, f64) {
    (sin_a * cos_b + cos_a * sin_b, cos_a * cos_b - sin_a * sin_b)
}

/// The camera points that may see a solution on a sphere of surface points: the cone of
/// half-angle `alpha` around `axis` tangent to the sphere `(center, radius)`, from a radius
/// behind the centre on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Beam {
    center: DVec3,
    radius: f64,
    axis: DVec3,
    sin: f64,
    cos: f64,
}

impl Beam {
    /// The beam's half-angle `α` and axis.
    #[cfg(test)]
    pub(super) fn cone(&self) -> (f64, DVec3) {
        (self.sin.atan2(self.cos), self.axis)
    }

    /// The part of the query's range whose camera points lie in the beam (widened by rounding
    /// margins), or `None` if none does.
    pub(super) fn trim(&self, query: &SegmentQuery) -> Option<DepthRange> {
        let range = query.range;
        let (r, s, c) = (self.radius, self.sin, self.cos);
        // V(t) − C = o + t·D, split along the beam's axis (p) and across it (u).
        let o = query.ends.origin - self.center;
        let d = query.ends.dir;
        let (p0, p1) = (self.axis.dot(o), self.axis.dot(d));
        let (o_perp, d_perp) = (o - p0 * self.axis, d - p1 * self.axis);
        // The plane a radius behind the centre: p(t) ≥ −r.
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        if p1 == 0.0 {
            if p0 < -r {
                return None;
            }
        } else {
            let t_plane = (-r - p0) / p1;
            if p1 > 0.0 {
                lo = t_plane;
            } else {
                hi = t_plane;
            }
        }
        // The cone: c·|u(t)| ≤ r + s·p(t); behind the plane its right side is ≥ 0, so squared:
        // q(t) = a t² + 2 b t + e ≤ 0.
        let w = r + s * p0;
        let a = c * c * d_perp.length_squared() - s * s * p1 * p1;
        let b = c * c * o_perp.dot(d_perp) - s * p1 * w;
        let e = c * c * o_perp.length_squared() - w * w;
        if !(a.is_finite() && b.is_finite() && e.is_finite()) {
            return Some(range);
        }
        let disc = b * b - a * e;
        let scale = a.abs().max(b.abs()).max(e.abs());
        // `cone`: the t the cone keeps, `None` where it keeps every t; no t at all returns.
        let cone = if a.abs() <= 1e-12 * scale {
            // Nearly linear: 2 b t + e ≤ 0 (a ray; the other nappe is behind the plane).
            if b == 0.0 {
                if e > 0.0 {
                    return None;
                }
                None
            } else if b > 0.0 {
                Some((f64::NEG_INFINITY, -e / (2.0 * b)))
            } else {
                Some((-e / (2.0 * b), f64::INFINITY))
            }
        } else if disc < 0.0 {
            if a > 0.0 {
                return None;
            }
            None
        } else {
            // Roots without cancellation.
            let k = -(b + b.signum() * disc.sqrt());
            let (x0, x1) = if k == 0.0 { (0.0, 0.0) } else { (k / a, e / k) };
            let (x0, x1) = (x0.min(x1), x0.max(x1));
            if a > 0.0 {
                Some((x0, x1))
            } else {
                // Two rays; the other nappe's lies behind the plane, so within the plane's side
                // only one is met: keep the hull of the rays that meet it.
                let low_ray = lo.max(range.lo) <= x0;
                let high_ray = hi.min(range.hi) >= x1;
                match (low_ray, high_ray) {
                    (true, true) => None,
                    (true, false) => Some((f64::NEG_INFINITY, x0)),
                    (false, true) => Some((x1, f64::INFINITY)),
                    (false, false) => Some((x1, x0)),
                }
            }
        };
        if let Some((t0, t1)) = cone {
            (lo, hi) = (lo.max(t0), hi.min(t1));
        }
        let margin = WIDEN * (1.0 + range.lo.abs().max(range.hi.abs()));
        let kept = DepthRange {
            lo: range.lo.max(lo - margin),
            hi: range.hi.min(hi + margin),
        };
        if kept.lo.is_nan() || kept.hi.is_nan() {
            return Some(range);
        }
        (kept.lo <= kept.hi).then_some(kept)
    }
}
