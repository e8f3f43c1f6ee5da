//! One camera segment through a scene's first object and single scattering's mean along it: what
//! the light tests that check single scattering against closed forms share.

use glam::DVec3;
use spindle_common::stats::RenderStats;
use spindle_render::ray::Ray;
use spindle_render::sampler::Sampler;
use spindle_render::scatter::single_scatter;
use spindle_render::segment::Segment;
use spindle_render::{Rgb, Scene};

/// The segment of object 0 from `origin` (inside it) along `dir` (normalised here) to the first
/// surface.
pub fn segment_to_surface(scene: &Scene, origin: DVec3, dir: DVec3) -> Segment {
    let dir = dir.normalize();
    let hit = scene
        .bvh()
        .closest_hit(&Ray::new(origin, dir))
        .expect("the segment leaves the object");
    Segment {
        origin,
        dir,
        length: hit.t,
        object: 0,
        throughput: Rgb::ONE,
    }
}

/// The mean of the red channel of `single_scatter` over samples `0..n` of pixel `(x, y)` under
/// `seed`, and its standard error (from the samples' spread).
pub fn single_scatter_mean(
    scene: &Scene,
    segment: &Segment,
    n: u32,
    (seed, x, y): (u64, u32, u32),
) -> (f64, f64) {
    let (mut sum, mut sum2) = (0.0, 0.0);
    let mut stats = RenderStats::default();
    for s in 0..n {
        let mut sampler = Sampler::new(seed, x, y, s);
        let v = single_scatter(scene, segment, &mut sampler, &mut stats).x;
        sum += v;
        sum2 += v * v;
    }
    let mean = sum / f64::from(n);
    let stderr = ((sum2 / f64::from(n) - mean * mean).max(0.0) / f64::from(n)).sqrt();
    (mean, stderr)
}
