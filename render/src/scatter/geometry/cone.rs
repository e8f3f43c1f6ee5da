//! Cones of directions: the set of shading normals a triangle (or everything below a BVH node)
//! can have, bounded by an axis and a half-angle.

use glam::DVec3;
use std::f64::consts::FRAC_PI_2;

use super::ANGLE_MARGIN;

/// A cone of directions: every direction within `half_angle` of `axis`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormalCone {
    pub axis: DVec3,
    pub half_angle: f64,
    /// `cos²(half_angle)`, and `cos` and `sin` of `half_angle + ANGLE_MARGIN`, for the cone
    /// test's comparisons.
    pub(crate) cos2: f64,
    pub(crate) cos_wide: f64,
    pub(crate) sin_wide: f64,
}

impl NormalCone {
    /// The cone holding every normalised convex combination of three unit vertex normals, i.e.
    /// every interpolated shading normal of the triangle. `None` when no useful cone exists (the
    /// normals spread over a hemisphere or more), in which case the cone test must keep the triangle.
    pub fn of_normals(n: [DVec3; 3]) -> Option<Self> {
        let axis = (n[0] + n[1] + n[2]).try_normalize()?;
        let half_angle = n
            .iter()
            .map(|ni| angle_between(axis, *ni))
            .fold(0.0_f64, f64::max);
        NormalCone::convex(axis, half_angle)
    }

    /// The cone `(axis, half_angle)` if it is narrower than a hemisphere, so that it is convex:
    /// it then contains every normalised convex combination of directions it contains.
    pub fn convex(axis: DVec3, half_angle: f64) -> Option<Self> {
        let wide = half_angle + ANGLE_MARGIN;
        (half_angle < FRAC_PI_2 - 1e-3).then_some(NormalCone {
            axis,
            half_angle,
            cos2: half_angle.cos().powi(2),
            cos_wide: wide.cos(),
            sin_wide: wide.sin(),
        })
    }
}

/// The angle between two nonzero vectors, accurate near 0 and π.
pub fn angle_between(x: DVec3, y: DVec3) -> f64 {
    x.cross(y).length().atan2(x.dot(y))
}
