//! The single-scattering estimators of one camera segment and one light point, each selectable by
//! `integrator.single_scatter.method`. They share the pruned descent (`descent`), the per-triangle
//! solver (`solve`) and the connection with its visibility tests (`connect`), and differ only in
//! how they place samples along the segment:
//!
//! * [`interval`] — [H15]: per-triangle depth intervals, K samples in each;
//! * [`point_sampling`] — [WZHB09]: M stratified points, every solution at each;
//! * [`straight_line`] — [H15] App. B.3: no refraction, light crosses the boundary in a straight
//!   line (exact for η = 1);
//! * [`reference`] — brute force for tests: no pruning, many Newton starts per triangle.

pub mod connect;
pub mod edge_scans;
pub mod interval;
pub mod point_sampling;
pub mod reference;
pub mod straight_line;

use glam::DVec3;

use crate::scatter::methods::connect::Connection;
use crate::scatter::prune::SegmentQuery;
use crate::scatter::triangle::ends::DepthRange;
use crate::scatter::triangle::patch::TrianglePatch;

impl Connection<'_> {
    /// The pruning query of the camera points `V(t)`, `t ∈ range`, and this light point.
    pub fn query(&self, range: DepthRange) -> SegmentQuery {
        SegmentQuery {
            ends: self.ends,
            range,
        }
    }

    /// The solver's view of the object's triangle `triangle`; `None` if it is degenerate.
    pub fn patch(&self, triangle: u32) -> Option<TrianglePatch> {
        let index = triangle as usize;
        TrianglePatch::new(
            self.object.mesh.corners(index),
            self.object.mesh.corner_normals(index),
        )
    }
}

/// The starting point of a fixed-`t` solve when the straight line V → L gives none: the centroid.
pub(crate) const CENTROID: (f64, f64) = (1.0 / 3.0, 1.0 / 3.0);

/// `true` when both points are on the sides of the triangle's plane that a refraction path needs:
/// `V` strictly behind, `L` strictly in front (physics.md §2.3). A necessary condition of any
/// solution, not a heuristic.
pub(crate) fn plane_sides_allow(patch: &TrianglePatch, v: DVec3, light: DVec3) -> bool {
    patch.plane_distance(v) < 0.0 && patch.plane_distance(light) > 0.0
}
