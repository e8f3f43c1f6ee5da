//! Single scattering along a camera segment inside a medium ([H15], physics.md).
//!
//! The per-triangle mathematics lives here, in f64 and independent of the scene: a triangle with
//! interpolated normals and the function f whose zeros are refraction paths ([`patch`]), the fixed
//! ends of a path ([`ends`]), the damped Newton solver ([`solve`]), the distance factor D
//! ([`distance`]) and the contribution of one path ([`contribution`]); the interval method's edge
//! crossings ([`edge`]) and per-triangle monotone branches, folds included ([`interval`]).
//!
//! Sign conventions, stated once for all of these modules: η = n_medium / n_outside > 1 (the
//! medium is denser); the light is outside; the shading normal points outward, toward the light;
//! the camera segment is `V(t) = origin + t·dir` with `dir` a unit vector, so t is a distance.
//!
//! The integrators (interval, point sampling, straight line, reference, auto) land with issue 3;
//! until then [`single_scatter`] is the documented empty `single_scatter` layer of issue 2: every
//! segment contributes black. The transport code already hands every camera segment here.

pub mod contribution;
pub mod descent;
pub mod distance;
pub mod edge;
pub mod ends;
pub mod interval;
pub mod light_sample;
pub mod patch;
pub mod prune;
pub mod small_list;
pub mod solve;

#[cfg(test)]
pub(crate) mod ground_truth;

use spindle_common::stats::RenderStats;

use crate::render::Rgb;
use crate::render::sampler::Sampler;
use crate::render::scene::Scene;
use crate::render::segment::Segment;

/// Radiance arriving at `segment.origin`, inside the medium, travelling toward the camera
/// (along `-segment.dir`), from light scattered once inside the segment. Black until the
/// integrator lands (issue 3).
pub fn single_scatter(
    _scene: &Scene,
    _segment: &Segment,
    _sampler: &mut Sampler,
    _stats: &mut RenderStats,
) -> Rgb {
    Rgb::ZERO
}
