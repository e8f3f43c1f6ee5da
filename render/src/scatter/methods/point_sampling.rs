//! Point sampling ([WZHB09]; physics.md §1.1, "point sampling"): `M = samples_per_segment`
//! stratified, jittered camera points `t_j` along the segment, drawn with the density
//! `q(t) ∝ e^{−σ_t t}` of the camera side's attenuation (`depth_density` with `ℓ = t`; uniform for
//! σ_t = 0; one density per group of channels with distinct σ_t, combined by the balance
//! heuristic); at each, every refraction path through every candidate triangle of the pruned
//! descent (a fixed-`t` Newton solve per triangle from the straight-line starting guess); the
//! estimate is `(1/M) Σ_j Σ_k C_k(t_j)/q(t_j)`.
//!
//! Each candidate triangle is solved from the straight-line guess, and from the centroid where
//! that finds no valid path (the straight-line guess alone missed 27 of 512 solutions on a glass
//! icosphere: Newton leaves the triangle). At most one solution per triangle is kept; a triangle
//! with two (near a fold) loses one, the method's known limitation that `reference` exposes.

use spindle_common::scene::SingleScatter;
use spindle_common::stats::RenderStats;

use super::CENTROID;
use crate::Rgb;
use crate::sampler::Sampler;
use crate::scatter::methods::connect::Connection;
use crate::scatter::prune::descent::{DescentStack, for_each_candidate};
use crate::scatter::triangle::depth_density::{DepthDensity, DepthSample, PathLengths};
use crate::scatter::triangle::ends::DepthRange;
use crate::scatter::triangle::solve::{
    INSIDE_TOLERANCE, NewtonSettings, RefractionPath, Slice, newton, straight_line_guess,
};

/// The point-sampling estimate of the segment `[0, length]` lit by the connection's light point.
pub fn estimate(
    connection: &Connection<'_>,
    length: f64,
    settings: &SingleScatter,
    stack: &mut DescentStack,
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
    let mut sum = Rgb::ZERO;
    let camera_side = PathLengths::new([(0.0, 0.0), (length, length)]);
    let Some(density) = DepthDensity::new(camera_side, connection.medium.sigma_t) else {
        return Rgb::ZERO;
    };
    let mut points = Vec::with_capacity(m as usize);
    density.for_each(m, |_| sampler.next_f64(), |sample| points.push(sample));
    for DepthSample { t, ln_weight } in points {
        let query = connection.query(DepthRange { lo: t, hi: t });
        for_each_candidate(
            connection.object,
            &query,
            connection.beams(),
            &settings.pruning,
            stack,
            stats,
            |candidate, stats| {
                let Some(patch) = connection.patch(candidate.triangle) else {
                    return;
                };
                // The straight-line guess first; where it finds nothing valid, the centroid.
                let guess = straight_line_guess(&patch, &connection.ends, t);
                for start in guess.into_iter().chain(std::iter::once(CENTROID)) {
                    let slice = Slice::fixed_t(t);
                    let (zero, evaluations) =
                        newton(&patch, &connection.ends, &slice, start, &newton_settings);
                    stats.newton_iterations += u64::from(evaluations);
                    let Some(zero) = zero else {
                        stats.newton_failures += 1;
                        continue;
                    };
                    let (a, b) = (zero.x.a, zero.x.b);
                    let ends = &connection.ends;
                    if let Some(path) =
                        RefractionPath::from_zero(&patch, ends, t, a, b, &zero.residual)
                            .filter(|_| patch.owns(a, b, INSIDE_TOLERANCE))
                    {
                        stats.samples += 1;
                        sum +=
                            connection.path_radiance(candidate.triangle, &path, ln_weight, stats);
                        break;
                    }
                }
            },
        );
    }
    sum
}
