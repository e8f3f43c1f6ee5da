//! The spindle test ([H15] §3.2.4, "geometry-based test") on a bounding sphere `(C, r)` (a BVH
//! node or a triangle): the deviation of a refracted ray, the angle between `ω_V` and `−ω_L`, is at
//! most `π/2 − asin(1/η)` whatever the normal is, so if every direction from the sphere to the
//! segment is farther than that (plus the cone half-angles `θ_V`, `θ_L`) from the direction away
//! from the light, the sphere holds no solution.

use glam::DVec3;

use crate::scatter::geometry::{ANGLE_MARGIN, BoundingSphere};
use crate::scatter::prune::SegmentQuery;

/// `cos(ANGLE_MARGIN)`, rounded down (its sine is taken as `ANGLE_MARGIN`, rounded up), so that
/// adding the margin by a rotation widens a bound by at least the margin.
const COS_MARGIN: f64 = 1.0 - 5.000_000_000_001e-13;

impl SegmentQuery {
    /// The spindle test ([H15] §3.2.4, "geometry-based test"): `false` only if no point of the
    /// sphere can be the refraction point of a path from the light to any `V(t)` of the range.
    ///
    /// A refracted path deviates by at most `D = π/2 − asin(1/η)` (for η < 1, not a supported
    /// medium, nothing is bounded), and seen from the sphere `ω_L` and `ω_V` lie within
    /// `θ_L = asin(r/d_L)` and `θ_V = asin(r/d_V)` of the directions from its centre. So the
    /// smallest angle between the direction away from the light and the directions to the
    /// segment is at most `Θ = D + θ_V + θ_L` (+ margin). Compared by cosines, with `Θ` summed
    /// as a rotation from the sines and cosines (`cos D = 1/η`): no trigonometry, since the test
    /// runs on most nodes of every query.
    pub fn spindle_may_contain(&self, sphere: BoundingSphere) -> bool {
        if self.ends.eta.is_nan() || self.ends.eta < 1.0 {
            return true;
        }
        let (c, r) = (sphere.center, sphere.radius);
        let a = self.ends.camera_point(self.range.lo) - c;
        let b = self.ends.camera_point(self.range.hi) - c;
        let to_light = self.ends.light - c;
        let d_light = to_light.length();
        let d_segment = distance_to_segment(a, b);
        // Cone half-angles of ω_L and ω_V; undefined (no culling) when L or V is inside the sphere.
        if !(d_light > r && d_segment > r) {
            return true;
        }
        let turn =
            |(c0, s0): (f64, f64), (c1, s1): (f64, f64)| (c0 * c1 - s0 * s1, s0 * c1 + c0 * s1);
        let from_sine = |s: f64| ((1.0 - s * s).max(0.0).sqrt(), s);
        let inv_eta = self.ends.eta.recip();
        let deviation = (inv_eta, (1.0 - inv_eta * inv_eta).max(0.0).sqrt());
        let margin = (COS_MARGIN, ANGLE_MARGIN);
        let bound = turn(
            turn(turn(deviation, margin), from_sine(r / d_segment)),
            from_sine(r / d_light),
        );
        // Each term is below π/2 (+ margin), so Θ < 2π, and Θ > π exactly where its sine is
        // negative: then every angle is within it.
        if bound.1.is_nan() || bound.1 < 0.0 {
            return true;
        }
        let away_from_light = -to_light / d_light;
        max_cosine_to_arc(away_from_light, a, b) >= bound.0
    }
}

/// The distance from the origin to the segment `[a, b]`.
fn distance_to_segment(a: DVec3, b: DVec3) -> f64 {
    distance_squared_to_segment(a, b).sqrt()
}

/// The squared distance from the origin to the segment `[a, b]`.
fn distance_squared_to_segment(a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    if len2 == 0.0 {
        return a.length_squared();
    }
    let s = (-a.dot(ab) / len2).clamp(0.0, 1.0);
    (a + s * ab).length_squared()
}

/// The largest cosine between the unit direction `w` and the directions of the points of the
/// segment `[a, b]` (seen from the origin, which is not on the segment), i.e. the cosine of the
/// smallest angle between them. Those directions form the shorter great-circle arc from `â` to
/// `b̂`.
pub(super) fn max_cosine_to_arc(w: DVec3, a: DVec3, b: DVec3) -> f64 {
    let at_ends = (w.dot(a) / a.length()).max(w.dot(b) / b.length());
    let Some(n) = a.cross(b).try_normalize() else {
        // Collinear with the origin and not through it: a single direction.
        return at_ends;
    };
    let in_plane = w - w.dot(n) * n;
    // Is the projection of w between â and b̂ along the arc? Then the nearest direction is
    // along it, at the cosine |in_plane| (w is a unit vector).
    if a.cross(in_plane).dot(n) >= 0.0 && in_plane.cross(b).dot(n) >= 0.0 {
        in_plane.length()
    } else {
        at_ends
    }
}
