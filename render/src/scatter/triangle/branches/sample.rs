//! The sampling of one interval ([H15] eqs. 18–19, with depths drawn by attenuation): K fixed-t
//! solves along the branch, each started from the interval's seeds and kept only on the
//! interval's branch.
//!
//! [H15] places the K samples uniformly in `[t_min, t_max]`. Here they follow the attenuation
//! `e^{−σ_t (t + d_V(t))}` of the branch's paths (`depth_density`): the path length inside the
//! medium, `ℓ = t + d_V`, is known at the interval's seeds and is interpolated between them; in
//! an optically thick interval the profile is first refined by solving where the density's mass
//! is. With σ_t = 0 the rule is [H15]'s.

use spindle_common::stats::RenderStats;

use super::Interval;
use crate::Rgb;
use crate::scatter::triangle::curve::Sign;
use crate::scatter::triangle::depth_density::{DepthDensity, PathLengths};
use crate::scatter::triangle::ends::{DepthRange, PathEnds};
use crate::scatter::triangle::patch::TrianglePatch;
use crate::scatter::triangle::solve::{INSIDE_TOLERANCE, NewtonSettings, RefractionPath, solve_at};

/// An interval whose ℓ spreads over more than this many mean free paths (of its densest channel)
/// has its profile refined where the density's mass is, [`REFINEMENTS`] times.
const REFINE_OPTICAL_SPAN: f64 = 2.0;
/// Extra solves that refine a thick interval's profile.
const REFINEMENTS: usize = 2;

/// How many samples an interval gets and where: `K` per density, at the quantiles
/// `(i + u_i)/K` with `u_i = offset(i)` (½ for the midpoint rule, uniform in [0, 1) for the
/// jittered, unbiased variant), of densities that follow the attenuation with extinction
/// `sigma_t` (zero: uniform in t, [H15] eq. 18).
pub struct SampleRule<F: Fn(u32) -> f64> {
    /// K, the samples per interval and density (at least 1).
    pub k: u32,
    /// `u_i` for sample i.
    pub offset: F,
    /// The medium's extinction, per channel.
    pub sigma_t: Rgb,
}

impl SampleRule<fn(u32) -> f64> {
    /// [H15]'s deterministic midpoint rule with K samples, uniform in t.
    pub fn midpoint(k: u32) -> Self {
        SampleRule {
            k,
            offset: |_| 0.5,
            sigma_t: Rgb::ZERO,
        }
    }
}

/// Calls `visit(path, ln_weight)` for the sample points of `interval`, where `ln_weight` is the
/// logarithm of the sample's weight per channel without the attenuation (see `depth_density`: the
/// contribution is `e^{ln_weight − σ_t ℓ}` times the rest). Each is solved at fixed t from the
/// interval's seed and kept only on the interval's branch. Samples and Newton work are counted
/// in `stats`; visibility and the contribution are the caller's.
pub fn for_each_sample(
    patch: &TrianglePatch,
    ends: &PathEnds,
    interval: &Interval,
    rule: &SampleRule<impl Fn(u32) -> f64>,
    tolerance: f64,
    stats: &mut RenderStats,
    mut visit: impl FnMut(&RefractionPath, Rgb),
) {
    let settings = NewtonSettings::new(tolerance, DepthRange::new(interval.t_min, interval.t_max));
    // In the layer at the plane (outside [t_min, t_max], see `Interval::reach`) the path at the
    // interval's end stands in.
    let solve = |t: f64, stats: &mut RenderStats| {
        let t = t.clamp(interval.t_min, interval.t_max);
        let (path, spent) = solve_at(patch, ends, t, interval.seed_at(t), &settings);
        stats.newton_iterations += u64::from(spent);
        path.filter(|p| {
            Sign::of(p.branch) == Some(interval.branch) && patch.owns(p.a, p.b, INSIDE_TOLERANCE)
        })
    };
    // Refinements only inside [t_min, t_max]: the layer at the plane is linear already.
    let inside = |t: f64| t >= interval.t_min && t <= interval.t_max;
    let Some(density) = depth_density(patch, ends, interval, rule.sigma_t, |t| {
        inside(t).then(|| solve(t, stats)).flatten().map(|p| p.d_v)
    }) else {
        return;
    };
    density.for_each(rule.k, &rule.offset, |sample| {
        stats.samples += 1;
        match solve(sample.t, stats) {
            Some(mut path) => {
                if path.t != sample.t {
                    // In the layer at the plane: the end's path, at this depth (V on the plane
                    // at the layer's far side, so ℓ̃ is exact to first order there).
                    path.d_v = (density.path_length(sample.t) - sample.t).max(0.0);
                    path.t = sample.t;
                }
                visit(&path, sample.ln_weight)
            }
            None => stats.newton_failures += 1,
        }
    });
}

/// The sampling densities of an interval: ℓ at its seeds, refined by `d_v_at` (a solve on the
/// branch) where an optically thick interval's mass lies. `None` for an empty interval.
fn depth_density(
    patch: &TrianglePatch,
    ends: &PathEnds,
    interval: &Interval,
    sigma_t: Rgb,
    mut d_v_at: impl FnMut(f64) -> Option<f64>,
) -> Option<DepthDensity> {
    let mut profile = PathLengths::new(interval.seeds().iter().map(|s| {
        let d_v = patch.point(s.a, s.b).distance(ends.camera_point(s.t));
        (s.t, s.t + d_v)
    }));
    // The ends of the interval always bound the profile, even if a seed is missing there; an
    // end widened to the triangle's plane has V on the plane there, so ℓ = t.
    for t in [interval.t_min, interval.t_max] {
        if profile.knots().iter().all(|k| k.0 != t) {
            profile.insert(t, profile.at(t).max(t));
        }
    }
    for t in [interval.reach.lo, interval.reach.hi] {
        if t < interval.t_min || t > interval.t_max {
            profile.insert(t, t);
        }
    }
    let mut density = DepthDensity::new(profile, sigma_t)?;
    for _ in 0..REFINEMENTS {
        let (lo, hi) = profile
            .knots()
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), k| {
                (lo.min(k.1), hi.max(k.1))
            });
        if density.densest() * (hi - lo) <= REFINE_OPTICAL_SPAN {
            break;
        }
        let t = density.densest_median();
        let Some(d_v) = d_v_at(t) else { break };
        profile.insert(t, t + d_v);
        density = DepthDensity::new(profile, sigma_t)?;
    }
    Some(density)
}
