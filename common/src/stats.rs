//! Render statistics: counters the renderer fills per tile and everyone else adds up.
//!
//! They travel with each tile result, are summed by the coordinator, printed by
//! `spindle render --stats` and kept in the EXR header, so a user can see where the work went
//! (and the benchmarks can measure what each pruning stage culls).

use serde::{Deserialize, Serialize};

/// Counters of one render (or one tile of it). All fields add.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(default, deny_unknown_fields)]
pub struct RenderStats {
    /// Primary camera rays traced.
    pub camera_rays: u64,
    /// Camera path segments inside a medium handed to the single-scattering integrator.
    pub camera_segments: u64,
    /// Segments of multiple-scattering paths handed to the single-scattering integrator.
    pub secondary_segments: u64,
    /// BVH nodes visited by the single-scattering descent.
    pub bvh_nodes_visited: u64,
    /// BVH nodes culled by the spindle test.
    pub nodes_culled_spindle: u64,
    /// BVH nodes culled by the half-vector / normal cone test (on the cone of every normal below).
    pub nodes_culled_cone: u64,
    /// Triangles reached by the descent and tested.
    pub triangles_tested: u64,
    /// Triangles culled by plane sidedness (the t-range from the triangle's plane was empty).
    pub triangles_culled_plane: u64,
    /// Triangles culled by the half-vector / normal cone test.
    pub triangles_culled_cone: u64,
    /// Newton iterations, all solves together.
    pub newton_iterations: u64,
    /// Newton solves that did not converge.
    pub newton_failures: u64,
    /// Non-empty depth intervals found (interval method).
    pub intervals: u64,
    /// Folds of a solution curve found inside a triangle (volume-caustic points).
    pub folds: u64,
    /// Light-path samples evaluated (refraction paths whose contribution was computed).
    pub samples: u64,
    /// Shadow rays traced.
    pub shadow_rays: u64,
    /// Values the single-scattering search dropped because a fixed-capacity per-triangle list
    /// was full (interval method: edge crossings, boundary and interior seed points, points of a
    /// traced arc, intervals; reference: solutions per camera point). Light may be missing
    /// wherever this is not 0; the capacities are sized so that the example scenes never drop.
    pub capacity_drops: u64,
    /// The same on multiple scattering's secondary segments (counted apart: a segment from
    /// anywhere inside the medium in any direction can run through a point focus, such as the
    /// Cartesian oval's of `scenes/caustic.json`, where a whole traced arc lies at one depth).
    pub secondary_capacity_drops: u64,
}

impl RenderStats {
    /// Adds every counter of `other` into `self`.
    pub fn add(&mut self, other: &RenderStats) {
        let RenderStats {
            camera_rays,
            camera_segments,
            secondary_segments,
            bvh_nodes_visited,
            nodes_culled_spindle,
            nodes_culled_cone,
            triangles_tested,
            triangles_culled_plane,
            triangles_culled_cone,
            newton_iterations,
            newton_failures,
            intervals,
            folds,
            samples,
            shadow_rays,
            capacity_drops,
            secondary_capacity_drops,
        } = other;
        self.camera_rays += camera_rays;
        self.camera_segments += camera_segments;
        self.secondary_segments += secondary_segments;
        self.bvh_nodes_visited += bvh_nodes_visited;
        self.nodes_culled_spindle += nodes_culled_spindle;
        self.nodes_culled_cone += nodes_culled_cone;
        self.triangles_tested += triangles_tested;
        self.triangles_culled_plane += triangles_culled_plane;
        self.triangles_culled_cone += triangles_culled_cone;
        self.newton_iterations += newton_iterations;
        self.newton_failures += newton_failures;
        self.intervals += intervals;
        self.folds += folds;
        self.samples += samples;
        self.shadow_rays += shadow_rays;
        self.capacity_drops += capacity_drops;
        self.secondary_capacity_drops += secondary_capacity_drops;
    }

    /// `(name, value)` pairs in a fixed order, for logs and EXR header attributes.
    pub fn entries(&self) -> [(&'static str, u64); 15] {
        [
            ("camera_rays", self.camera_rays),
            ("camera_segments", self.camera_segments),
            ("bvh_nodes_visited", self.bvh_nodes_visited),
            ("nodes_culled_spindle", self.nodes_culled_spindle),
            ("nodes_culled_cone", self.nodes_culled_cone),
            ("triangles_tested", self.triangles_tested),
            ("triangles_culled_plane", self.triangles_culled_plane),
            ("triangles_culled_cone", self.triangles_culled_cone),
            ("newton_iterations", self.newton_iterations),
            ("newton_failures", self.newton_failures),
            ("intervals", self.intervals),
            ("folds", self.folds),
            ("samples", self.samples),
            ("shadow_rays", self.shadow_rays),
            ("capacity_drops", self.capacity_drops),
        ]
    }
}
