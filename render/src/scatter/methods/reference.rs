//! The brute-force reference estimator, for tests: slow and simple, it must expose any branch the
//! fast methods miss.
//!
//! No pruning: every triangle of the object is tried (only the exact necessary plane-side
//! condition of physics.md §2.3 skips a triangle: V behind its plane and L in front). Camera points
//! are `M = samples_per_segment` stratified jittered `t_j`, drawn by the camera side's attenuation
//! as point sampling draws them (`depth_density`; uniform for σ_t = 0). At each, a fixed-`t`
//! Newton solve runs from every point of a grid of starts inside the triangle (plus the
//! straight-line guess), and *every* distinct valid solution is summed (solutions closer than
//! 1e-7 in barycentrics are the same). The estimate is `(1/M) Σ_j Σ_k C_k(t_j)/q(t_j)`.

use spindle_common::scene::SingleScatter;
use spindle_common::stats::RenderStats;

use super::plane_sides_allow;
use crate::Rgb;
use crate::sampler::Sampler;
use crate::scatter::methods::connect::Connection;
use crate::scatter::triangle::depth_density::{DepthDensity, DepthSample, PathLengths};
use crate::scatter::triangle::ends::DepthRange;
use crate::scatter::triangle::solve::{
    INSIDE_TOLERANCE, NewtonSettings, RefractionPath, Slice, newton, straight_line_guess,
};

/// Grid of starts per side: the starts are `((i + 1/3)/G, (j + 1/3)/G)` for `i + j < G`.
const START_GRID: usize = 5;
/// Most distinct solutions kept per triangle and camera point (more are dropped, and counted in
/// `RenderStats::capacity_drops`).
const MAX_SOLUTIONS: usize = 16;
/// Barycentric distance under which two solutions are the same.
const SAME_SOLUTION: f64 = 1e-7;

/// The reference estimate of the segment `[0, length]` lit by the connection's light point.
pub fn estimate(
    connection: &Connection<'_>,
    length: f64,
    settings: &SingleScatter,
    sampler: &mut Sampler,
    stats: &mut RenderStats,
) -> Rgb {
    let m = settings.samples_per_segment.max(1);
    let newton_settings = NewtonSettings::new(
        settings.newton_tolerance,
        DepthRange {
            lo: 0.0,
            hi: length,
        },
    );
    let ends = connection.ends;
    let mut sum = Rgb::ZERO;
    let camera_side = PathLengths::new([(0.0, 0.0), (length, length)]);
    let Some(density) = DepthDensity::new(camera_side, connection.medium.sigma_t) else {
        return Rgb::ZERO;
    };
    let mut points = Vec::with_capacity(m as usize);
    density.for_each(m, |_| sampler.next_f64(), |sample| points.push(sample));
    for DepthSample { t, ln_weight } in points {
        let v = ends.camera_point(t);
        for triangle in 0..connection.object.mesh.triangle_count() as u32 {
            stats.triangles_tested += 1;
            let Some(patch) = connection.patch(triangle) else {
                continue;
            };
            if !plane_sides_allow(&patch, v, ends.light) {
                stats.triangles_culled_plane += 1;
                continue;
            }
            let mut found = [(0.0, 0.0); MAX_SOLUTIONS];
            let mut count = 0;
            let grid = (0..START_GRID).flat_map(|i| {
                (0..START_GRID - i).map(move |k| {
                    let g = START_GRID as f64;
                    ((i as f64 + 1.0 / 3.0) / g, (k as f64 + 1.0 / 3.0) / g)
                })
            });
            for start in straight_line_guess(&patch, &ends, t)
                .into_iter()
                .chain(grid)
            {
                let (zero, evaluations) =
                    newton(&patch, &ends, &Slice::fixed_t(t), start, &newton_settings);
                stats.newton_iterations += u64::from(evaluations);
                let Some(zero) = zero else {
                    stats.newton_failures += 1;
                    continue;
                };
                let (a, b) = (zero.x.a, zero.x.b);
                let seen = found[..count]
                    .iter()
                    .any(|&(fa, fb)| (fa - a).abs() + (fb - b).abs() < SAME_SOLUTION);
                if seen {
                    continue;
                }
                let Some(path) = RefractionPath::from_zero(&patch, &ends, t, a, b, &zero.residual)
                    .filter(|_| patch.owns(a, b, INSIDE_TOLERANCE))
                else {
                    continue;
                };
                if count == MAX_SOLUTIONS {
                    stats.capacity_drops += 1;
                    continue;
                }
                stats.samples += 1;
                found[count] = (a, b);
                count += 1;
                sum += connection.path_radiance(triangle, &path, ln_weight, stats);
            }
        }
    }
    sum
}
