//! The sampling of one interval ([H15] eqs. 18–19): K fixed-t solves along the branch, each
//! started from the interval's seeds and kept only on the interval's branch.

use spindle_common::stats::RenderStats;

use super::Interval;
use crate::scatter::triangle::curve::Sign;
use crate::scatter::triangle::ends::{DepthRange, PathEnds};
use crate::scatter::triangle::patch::TrianglePatch;
use crate::scatter::triangle::solve::{NewtonSettings, RefractionPath, solve_at};

/// Where the K samples of an interval go ([H15] eq. 18): `t_i = t_min + (i + u_i)(t_max − t_min)/K`
/// with `u_i = offset(i)`: ½ for the midpoint rule, a uniform number in [0, 1) for the jittered,
/// unbiased variant.
pub struct SampleRule<F: Fn(u32) -> f64> {
    /// K, the samples per interval (at least 1).
    pub k: u32,
    /// `u_i` for sample i.
    pub offset: F,
}

impl SampleRule<fn(u32) -> f64> {
    /// The deterministic midpoint rule with K samples.
    pub fn midpoint(k: u32) -> Self {
        SampleRule { k, offset: |_| 0.5 }
    }
}

/// Calls `visit(path, weight)` for the K sample points of `interval` ([H15] eqs. 18–19), with
/// weight `(t_max − t_min)/K`. Each is solved at fixed t from the interval's seed and kept only on
/// the interval's branch. Samples and Newton work are counted in `stats`; visibility and the
/// contribution are the caller's.
pub fn for_each_sample(
    patch: &TrianglePatch,
    ends: &PathEnds,
    interval: &Interval,
    rule: &SampleRule<impl Fn(u32) -> f64>,
    tolerance: f64,
    stats: &mut RenderStats,
    mut visit: impl FnMut(&RefractionPath, f64),
) {
    let k = rule.k.max(1);
    let width = (interval.t_max - interval.t_min) / k as f64;
    let settings = NewtonSettings::new(tolerance, DepthRange::new(interval.t_min, interval.t_max));
    for i in 0..k {
        let t = interval.t_min + (i as f64 + (rule.offset)(i)) * width;
        stats.samples += 1;
        let (path, spent) = solve_at(patch, ends, t, interval.seed_at(t), &settings);
        stats.newton_iterations += spent as u64;
        match path {
            Some(p) if Sign::of(p.branch) == Some(interval.branch) => visit(&p, width),
            _ => stats.newton_failures += 1,
        }
    }
}
