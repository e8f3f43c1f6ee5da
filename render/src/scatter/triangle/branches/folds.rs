//! The splitting of a traced arc at its folds (sign changes of `g_t`, where the curve turns back
//! in t) into monotone branches, each stored as an [`Interval`] with seeds along it.

use spindle_common::stats::RenderStats;

use super::trace::{Arc, Corrected, MAX_TRACE, Node, Tracer};
use super::{Interval, Intervals, MAX_SEEDS};
use crate::scatter::triangle::curve::{CurvePoint, Sign};
use crate::scatter::triangle::ends::DepthRange;
use crate::scatter::triangle::small_list::SmallList;

/// Points per monotone branch: an arc's points and the fold points at both of its ends.
const MAX_BRANCH: usize = MAX_TRACE + 2;

/// The points of one monotone branch, in the order of travel.
type BranchPoints = SmallList<CurvePoint, MAX_BRANCH>;

/// The direction in t of travel `σ` at a node: the sign of `σ·g_t`, if g_t is known and finite.
fn travel(node: &Node, sigma: Sign) -> Option<Sign> {
    node.finite_g_t()
        .and_then(|g_t| Sign::of(sigma.value() * g_t))
}

impl Tracer<'_> {
    /// Locates the fold between two traced points `x0`, `x1` whose g_t (`g0`, `g1`) differ in
    /// sign (regula falsi on g_t along the chord, each point corrected onto the curve). Returns
    /// the fold point.
    fn locate_fold(
        &self,
        (x0, g0): (CurvePoint, f64),
        (x1, g1): (CurvePoint, f64),
        stats: &mut RenderStats,
    ) -> CurvePoint {
        let chord = x1.minus(x0);
        let (mut lo, mut hi) = ((0.0, g0), (1.0, g1));
        let mut best = if g0.abs() < g1.abs() { x0 } else { x1 };
        for _ in 0..40 {
            let theta = (lo.0 * hi.1 - hi.0 * lo.1) / (hi.1 - lo.1);
            let theta = if theta > lo.0 && theta < hi.0 {
                theta
            } else {
                0.5 * (lo.0 + hi.0)
            };
            let predicted = x0.step(theta, chord);
            let Some(Corrected { x, g, .. }) = self.correct(predicted, chord, stats) else {
                break;
            };
            best = x;
            if g.t == 0.0 || (hi.0 - lo.0) < 1e-12 {
                break;
            }
            if g.t.signum() == lo.1.signum() {
                lo = (theta, g.t);
            } else {
                hi = (theta, g.t);
            }
        }
        best
    }

    /// Splits a traced arc, travelled in direction `sigma`, at its folds and appends its
    /// monotone branches to `out`.
    pub fn emit_branches(
        &self,
        arc: &Arc,
        sigma: Sign,
        out: &mut Intervals,
        stats: &mut RenderStats,
    ) {
        if arc.len() < 2 {
            return;
        }
        // Walk the arc, closing a branch at every sign change of dt/dλ = σ·g_t.
        let mut branch = BranchPoints::default();
        let mut sign: Option<Sign> = None;
        let mut previous: Option<Node> = None;
        for node in arc.iter().copied() {
            let s = travel(&node, sigma);
            if let Some(prev) = previous
                && let (Some(s), Some(prev_s)) = (s, travel(&prev, sigma))
                && s != prev_s
                && let (Some(g0), Some(g1)) = (prev.g_t, node.g_t)
            {
                let fold = self.locate_fold((prev.x, g0), (node.x, g1), stats);
                stats.folds += 1;
                branch.push_or_count(fold, &mut stats.capacity_drops);
                self.push_branch(&branch, sign, sigma, out, stats);
                branch = BranchPoints::default();
                branch.push_or_count(fold, &mut stats.capacity_drops);
            }
            if s.is_some() {
                sign = s;
            }
            branch.push_or_count(node.x, &mut stats.capacity_drops);
            previous = Some(node);
        }
        self.push_branch(&branch, sign, sigma, out, stats);
    }

    /// Turns the points of one monotone branch, travelled in direction `sigma` and so in
    /// direction `travel` of t, into an [`Interval`] with up to [`MAX_SEEDS`] seeds.
    fn push_branch(
        &self,
        points: &BranchPoints,
        travel: Option<Sign>,
        sigma: Sign,
        out: &mut Intervals,
        stats: &mut RenderStats,
    ) {
        let count = points.len();
        let Some(travel) = travel.filter(|_| count >= 2) else {
            return;
        };
        let first = *points.get(0).expect("non-empty");
        let last = *points.get(count - 1).expect("non-empty");
        let (t_min, t_max) = (first.t.min(last.t), first.t.max(last.t));
        if t_max <= t_min {
            return;
        }
        // Seeds in increasing t: the traversal runs in t's direction when σ·g_t > 0.
        let mut seeds = [CurvePoint::default(); MAX_SEEDS];
        let seed_count = count.min(MAX_SEEDS);
        for (k, seed) in seeds.iter_mut().enumerate().take(seed_count) {
            let index = if seed_count == 1 {
                0
            } else {
                (k * (count - 1) + (seed_count - 1) / 2) / (seed_count - 1)
            };
            let index = if k == seed_count - 1 {
                count - 1
            } else {
                index
            };
            let index = if travel == Sign::Plus {
                index
            } else {
                count - 1 - index
            };
            *seed = *points.get(index).expect("in range");
        }
        // The label of the branch: the sign of g_t of the continuously oriented tangent.
        let branch = travel.times(sigma);
        let interval = Interval {
            t_min,
            t_max,
            reach: DepthRange::new(t_min, t_max),
            branch,
            seeds,
            seed_count,
        };
        if out.push(interval) {
            stats.intervals += 1;
        } else {
            stats.capacity_drops += 1;
        }
    }
}
