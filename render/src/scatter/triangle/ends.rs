//! The fixed ends of the refracted paths of one camera segment and one light sample.
//!
//! Every per-triangle computation (the refraction solve, the edge crossings, the intervals)
//! shares these four values; grouping them keeps the argument lists short and the conventions
//! in one place: `V(t) = origin + t·dir` with `dir` a unit vector (so t is a distance, [H15]
//! eq. 13), the light point `light` is outside the medium, and `eta` > 1 is the relative index
//! of the medium.

use glam::DVec3;

/// The camera segment (as a ray) and the light point that a refraction path connects.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathEnds {
    /// The start of the camera segment inside the medium (V_min).
    pub origin: DVec3,
    /// The unit direction of the camera segment (r̂).
    pub dir: DVec3,
    /// The light sample point L, outside the medium.
    pub light: DVec3,
    /// Relative index n_medium / n_outside, > 1.
    pub eta: f64,
}

impl PathEnds {
    /// The camera point V at distance `t` along the segment.
    #[inline]
    pub fn camera_point(&self, t: f64) -> DVec3 {
        self.origin + t * self.dir
    }
}

/// A closed range of depths `t` along the camera segment, `lo ≤ hi` (equal for a single camera
/// point, as in point sampling).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthRange {
    /// The nearest depth.
    pub lo: f64,
    /// The farthest depth.
    pub hi: f64,
}

impl DepthRange {
    /// The range `[lo, hi]`.
    #[inline]
    pub fn new(lo: f64, hi: f64) -> Self {
        debug_assert!(lo <= hi, "DepthRange: {lo} > {hi}");
        DepthRange { lo, hi }
    }

    /// Whether `t` lies in the range, ends included.
    #[inline]
    pub fn contains(&self, t: f64) -> bool {
        t >= self.lo && t <= self.hi
    }
}
