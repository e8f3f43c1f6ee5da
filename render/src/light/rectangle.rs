//! A rectangle as seen from a point: the spherical rectangle it covers, sampled uniformly by
//! solid angle (Ureña, Fajardo and King 2013, "An area-preserving parametrization for
//! spherical rectangles").
//!
//! A quad light lit from close by is the case where sampling its area is poor: points near the
//! receiver carry large weights `cos/dist²` and far ones small. Drawing directions uniformly in
//! the solid angle it fills makes each sample's weight the light's radiance times that solid
//! angle, constant for the fluence and varying only with the receiver's cosine for irradiance.
//! The solid angle is a sum of four angles less 2π, so for a rectangle that fills less than
//! [`MIN_SOLID_ANGLE`] the caller samples by area instead, where the two densities are nearly
//! proportional anyway (pbrt-v4 makes the same choice).

use glam::DVec3;

/// Below this solid angle (steradians) [`SphericalRectangle::new`] declines: the sum of angles
/// loses digits to cancellation, and area sampling is within a few percent of uniform in solid
/// angle there.
pub const MIN_SOLID_ANGLE: f64 = 3e-4;

/// A rectangle with perpendicular edges, seen from a point in front of or behind its plane.
#[derive(Debug, Clone, Copy)]
pub struct SphericalRectangle {
    origin: DVec3,
    /// The local frame: `x`, `y` along the edges, `z` away from the origin's side of the plane.
    x: DVec3,
    y: DVec3,
    z: DVec3,
    /// The rectangle's extent in that frame: `x0..x1`, `y0..y1` at height `z0 < 0`.
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    z0: f64,
    b0: f64,
    b1: f64,
    k: f64,
    solid_angle: f64,
}

impl SphericalRectangle {
    /// The rectangle `corner + s·edge_u + t·edge_v` (`s, t ∈ [0, 1]`, edges perpendicular) seen
    /// from `origin`; `None` when the origin lies in its plane or it fills less than
    /// [`MIN_SOLID_ANGLE`].
    pub fn new(
        origin: DVec3,
        corner: DVec3,
        edge_u: DVec3,
        edge_v: DVec3,
    ) -> Option<SphericalRectangle> {
        let (exl, eyl) = (edge_u.length(), edge_v.length());
        let (x, y) = (edge_u / exl, edge_v / eyl);
        let mut z = x.cross(y);
        let d = corner - origin;
        let mut z0 = d.dot(z);
        if z0 > 0.0 {
            z = -z;
            z0 = -z0;
        }
        // In the plane (or nearly, relative to the rectangle's size): no solid angle.
        if z0 >= -1e-9 * exl.max(eyl) {
            return None;
        }
        let (x0, y0) = (d.dot(x), d.dot(y));
        let (x1, y1) = (x0 + exl, y0 + eyl);
        let v00 = DVec3::new(x0, y0, z0);
        let v01 = DVec3::new(x0, y1, z0);
        let v10 = DVec3::new(x1, y0, z0);
        let v11 = DVec3::new(x1, y1, z0);
        let n0 = v00.cross(v10).normalize();
        let n1 = v10.cross(v11).normalize();
        let n2 = v11.cross(v01).normalize();
        let n3 = v01.cross(v00).normalize();
        let angle = |a: DVec3, b: DVec3| (-a.dot(b)).clamp(-1.0, 1.0).acos();
        let (g0, g1, g2, g3) = (angle(n0, n1), angle(n1, n2), angle(n2, n3), angle(n3, n0));
        let k = std::f64::consts::TAU - g2 - g3;
        let solid_angle = g0 + g1 - k;
        (solid_angle.is_finite() && solid_angle >= MIN_SOLID_ANGLE).then_some(SphericalRectangle {
            origin,
            x,
            y,
            z,
            x0,
            x1,
            y0,
            y1,
            z0,
            b0: n0.z,
            b1: n2.z,
            k,
            solid_angle,
        })
    }

    /// The solid angle the rectangle fills, in steradians.
    pub fn solid_angle(&self) -> f64 {
        self.solid_angle
    }

    /// The point of the rectangle in a direction drawn uniformly in its solid angle from two
    /// uniform numbers.
    pub fn sample(&self, u: [f64; 2]) -> DVec3 {
        let (z0, b0) = (self.z0, self.b0);
        // The x coordinate: the sub-rectangle left of it fills the share u[0] of the angle.
        let au = u[0] * self.solid_angle + self.k;
        let fu = (au.cos() * b0 - self.b1) / au.sin();
        let cu = (fu.signum() / (fu * fu + b0 * b0).sqrt()).clamp(-1.0, 1.0);
        let xu = if cu.abs() < 1.0 {
            (-(cu * z0) / (1.0 - cu * cu).sqrt()).clamp(self.x0, self.x1)
        } else if cu > 0.0 {
            self.x1
        } else {
            self.x0
        };
        // The y coordinate: uniform in the projected height along that column.
        let d = (xu * xu + z0 * z0).sqrt();
        let h0 = self.y0 / (d * d + self.y0 * self.y0).sqrt();
        let h1 = self.y1 / (d * d + self.y1 * self.y1).sqrt();
        let hv = h0 + u[1] * (h1 - h0);
        let hv2 = hv * hv;
        let yv = if hv2 < 1.0 - 1e-12 {
            (hv * d / (1.0 - hv2).sqrt()).clamp(self.y0, self.y1)
        } else {
            self.y1
        };
        self.origin + xu * self.x + yv * self.y + z0 * self.z
    }
}

#[cfg(test)]
pub(crate) mod tests;
