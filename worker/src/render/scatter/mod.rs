//! Single scattering along a camera segment inside a medium.
//!
//! The integrators (interval, point sampling, straight line, reference, auto) land with issue 3;
//! until then this is the documented empty `single_scatter` layer of issue 2: every segment
//! contributes black. The transport code already hands every camera segment here.

pub mod descent;
pub mod light_sample;
pub mod prune;

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
