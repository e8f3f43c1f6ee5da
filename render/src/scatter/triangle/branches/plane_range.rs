//! The restriction of a triangle's depth range by its plane: a refraction path needs V behind
//! the triangle's plane and L in front of it (physics.md §2.3), so only the part of the camera
//! segment behind the plane is searched.

use crate::scatter::geometry::TrianglePlane;
use crate::scatter::triangle::ends::{DepthRange, PathEnds};
use crate::scatter::triangle::patch::TrianglePatch;

/// Range ends on the triangle's plane are pulled in by this fraction of the triangle's size: at
/// the plane V = P and f is singular; far above the rounding of `V − P`, so the solves at the
/// range end converge. The layer left out is where a dense medium scatters the most (a share of
/// about `σ_t · size · PLANE_MARGIN` of the light), so the samples still cover it
/// (`Interval::reach`, [`plane_depth`]).
pub(super) const PLANE_MARGIN: f64 = 1e-7;

/// The part of `range` where V is behind the triangle's plane, or None if it is empty or the light
/// is not in front of the plane (physics.md §2.3). A bound on the plane itself is pulled in by
/// [`PLANE_MARGIN`] times the triangle's size.
pub fn plane_t_range(
    patch: &TrianglePatch,
    ends: &PathEnds,
    range: DepthRange,
) -> Option<DepthRange> {
    let plane = TrianglePlane {
        normal: patch.normal_g,
        offset: patch.normal_g.dot(patch.p0),
    };
    let margin = PLANE_MARGIN * patch.double_area.sqrt();
    plane
        .behind_range(
            ends.origin,
            ends.dir,
            ends.light,
            (range.lo, range.hi),
            margin,
        )
        .filter(|(lo, hi)| lo < hi)
        .map(|(lo, hi)| DepthRange::new(lo, hi))
}

/// The depth at which the camera point crosses the triangle's plane (V on the plane, so `d_V = 0`
/// and `ℓ = t` there), if the segment is not parallel to it.
pub fn plane_depth(patch: &TrianglePatch, ends: &PathEnds) -> Option<f64> {
    let rate = patch.normal_g.dot(ends.dir);
    let height = patch.normal_g.dot(ends.origin - patch.p0);
    (rate != 0.0)
        .then(|| -height / rate)
        .filter(|t| t.is_finite())
}
