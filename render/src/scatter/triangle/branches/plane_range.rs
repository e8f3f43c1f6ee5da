//! The restriction of a triangle's depth range by its plane: a refraction path needs V behind
//! the triangle's plane and L in front of it (physics.md §2.3), so only the part of the camera
//! segment behind the plane is searched.

use crate::scatter::geometry::TrianglePlane;
use crate::scatter::triangle::ends::{DepthRange, PathEnds};
use crate::scatter::triangle::patch::TrianglePatch;

/// Range ends on the triangle's plane are pulled in by this fraction of the triangle's size: at
/// the plane V = P and f is singular. The contribution lost is of the same relative order.
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
