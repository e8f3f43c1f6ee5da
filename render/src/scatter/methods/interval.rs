//! The interval method of [H15] §3.2 for one camera segment and one light point: the pruned
//! descent gives candidate triangles with trimmed `t`-ranges; on each, the per-triangle depth
//! intervals (one per monotone branch of the solution curve, folds split; see `branches`) are
//! sampled with `K = k` points each. [H15] eqs. 18–19 place them uniformly (the midpoint rule);
//! here they are placed at the quantiles `(i + u_i)/K` of a density that follows the paths'
//! attenuation (`depth_density`), so that dense media are right with K = 1: `u_i = ½` without
//! `jitter` (deterministic), or `u_i = frac(u + i·φ)` with one uniform `u` per interval and the
//! golden ratio φ: every `u_i` is uniform on [0, 1), so each sample follows the density within
//! its stratum and the estimate is unbiased.

use spindle_common::scene::SingleScatter;
use spindle_common::stats::RenderStats;

use crate::Rgb;
use crate::sampler::Sampler;
use crate::scatter::methods::connect::Connection;
use crate::scatter::methods::edge_scans::EdgeScans;
use crate::scatter::prune::descent::{DescentStack, for_each_candidate};
use crate::scatter::triangle::branches::{SampleRule, for_each_sample, triangle_intervals_with};
use crate::scatter::triangle::ends::DepthRange;

/// The fractional part of the golden ratio, the stride of the jittered offsets.
const GOLDEN: f64 = 0.618_033_988_749_894_9;

/// The interval-method estimate of the segment `[0, length]` lit by the connection's light point.
pub fn estimate(
    connection: &Connection<'_>,
    length: f64,
    settings: &SingleScatter,
    stack: &mut DescentStack,
    sampler: &mut Sampler,
    stats: &mut RenderStats,
) -> Rgb {
    let k = settings.k.max(1);
    let tolerance = settings.newton_tolerance;
    let ends = connection.ends;
    let query = connection.query(DepthRange {
        lo: 0.0,
        hi: length,
    });
    let mut sum = Rgb::ZERO;
    // Each edge is scanned once for this query and shared by its two triangles.
    let mut scans = EdgeScans::default();
    let mesh = &connection.object.mesh;
    let beams = connection.beams();
    for_each_candidate(
        connection.object,
        &query,
        beams,
        &settings.pruning,
        stack,
        stats,
        |candidate, stats| {
            let Some(patch) = connection.patch(candidate.triangle) else {
                return;
            };
            let edge_scan = |edge| scans.scan(mesh, candidate.triangle, edge, &ends);
            // The cone test at the single point V(t) (no sweep, so tighter than on a range):
            // most range-end solves of a candidate fail, each after several evaluations, and
            // this test spares about a quarter of those evaluations (docs/benchmarks.md).
            let bounds = connection.object.bounds.triangle_at_slot(candidate.slot);
            let may_hold_at = |t: f64| match bounds.cone {
                Some(cone) if settings.pruning.cone => query
                    .with_range(DepthRange { lo: t, hi: t })
                    .triangle_may_contain(beams, candidate.slot, bounds.sphere, cone),
                _ => true,
            };
            let intervals = triangle_intervals_with(
                &patch,
                &ends,
                candidate.range,
                tolerance,
                edge_scan,
                may_hold_at,
                stats,
            );
            for interval in intervals.iter() {
                let u = if settings.jitter {
                    sampler.next_f64()
                } else {
                    0.5
                };
                let jitter = settings.jitter;
                let rule = SampleRule {
                    k,
                    offset: move |i: u32| {
                        if jitter {
                            (u + f64::from(i) * GOLDEN).fract()
                        } else {
                            0.5
                        }
                    },
                    sigma_t: connection.medium.sigma_t,
                };
                // Visibility rays are counted apart: `for_each_sample` holds `stats`.
                let mut visibility = RenderStats::default();
                for_each_sample(
                    &patch,
                    &ends,
                    interval,
                    &rule,
                    tolerance,
                    stats,
                    |path, ln_weight| {
                        sum += connection.path_radiance(
                            candidate.triangle,
                            path,
                            ln_weight,
                            &mut visibility,
                        );
                    },
                );
                stats.add(&visibility);
            }
        },
    );
    sum
}
