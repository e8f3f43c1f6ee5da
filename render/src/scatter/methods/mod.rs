//! The single-scattering estimators of one camera segment and one light point, each selectable by
//! `integrator.single_scatter.method`. They share the pruned descent (`descent`), the per-triangle
//! solver (`solve`) and the connection with its visibility tests (`connect`), and differ only in
//! how they place samples along the segment:
//!
//! * [`interval`] — [H15]: per-triangle depth intervals, K samples in each;
//! * [`point_sampling`] — [WZHB09]: M stratified points, every solution at each;
//! * [`straight_line`] — [H15] App. B.3: no refraction, light crosses the boundary in a straight
//!   line (exact for η = 1);
//! * [`reference`] — brute force for tests: no pruning, many Newton starts per triangle;
//! * [`in_medium`] — a light inside the segment's own medium: the straight connection with no
//!   interface at all.

pub mod connect;
pub mod edge_scans;
pub mod in_medium;
pub mod interval;
pub mod point_sampling;
pub mod reference;
pub mod straight_line;

use glam::DVec3;

use crate::Rgb;
use crate::sampler::Sampler;
use crate::scatter::methods::connect::Connection;
use crate::scatter::prune::SegmentQuery;
use crate::scatter::prune::beam_table::Beams;
use crate::scatter::triangle::ends::{DepthRange, PathEnds};
use crate::scatter::triangle::patch::TrianglePatch;

impl Connection<'_> {
    /// The pruning query of the camera points `V(t)`, `t ∈ range`, and this light point.
    pub fn query(&self, range: DepthRange) -> SegmentQuery {
        SegmentQuery {
            ends: self.ends,
            range,
        }
    }

    /// Where the descents of this connection take their beams from.
    pub fn beams(&self) -> Beams<'_> {
        Beams::for_ends(self.beam_table, &self.ends)
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

/// Equiangular sampling of the camera points of a segment about the light point (the
/// substitution `t = x0 + h tan u` of physics.md §4): the density `q(t) = h/((u1 − u0) d²)`
/// cancels the `1/d²` of a light seen along a straight line. Uniform in t when the light lies on
/// the segment's line.
pub(crate) struct Equiangular {
    /// Foot of the perpendicular from the light, along the segment.
    x0: f64,
    /// Distance from the light to the segment's line.
    h: f64,
    /// The angle range `[u0, u1]`, or `None` for the uniform fallback.
    angles: Option<(f64, f64)>,
    length: f64,
}

impl Equiangular {
    pub(crate) fn new(ends: &PathEnds, length: f64) -> Self {
        let x0 = (ends.light - ends.origin).dot(ends.dir);
        let h = (ends.light - ends.origin - x0 * ends.dir).length();
        let usable = h > 1e-9 * (length + x0.abs()) && length > 0.0;
        Equiangular {
            x0,
            h,
            angles: usable.then(|| ((-x0).atan2(h), (length - x0).atan2(h))),
            length,
        }
    }

    /// `(1/M) Σ_j C(t_j)/q(t_j)` over `M = m` strata of the angle, one jittered point in each.
    pub(crate) fn estimate(
        &self,
        m: u32,
        sampler: &mut Sampler,
        mut radiance: impl FnMut(f64) -> Rgb,
    ) -> Rgb {
        let m = m.max(1);
        let mut sum = Rgb::ZERO;
        for j in 0..m {
            let xi = (f64::from(j) + sampler.next_f64()) / f64::from(m);
            let (t, weight) = self.sample(xi);
            sum += weight * radiance(t);
        }
        sum / f64::from(m)
    }

    /// The camera point at the quantile `xi ∈ [0, 1)` and its weight `1/q(t)`.
    pub(crate) fn sample(&self, xi: f64) -> (f64, f64) {
        match self.angles {
            Some((u0, u1)) => {
                let u = u0 + xi * (u1 - u0);
                let t = (self.x0 + self.h * u.tan()).clamp(0.0, self.length);
                let d2 = self.h * self.h + (t - self.x0) * (t - self.x0);
                (t, (u1 - u0) * d2 / self.h)
            }
            None => (xi * self.length, self.length),
        }
    }
}
