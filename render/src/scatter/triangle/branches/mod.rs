//! The per-triangle depth intervals of the interval method ([H15] §3.2, Algorithm 1; eqs. 18–19),
//! made robust to folds.
//!
//! For one triangle and one camera segment the refraction points form a curve in `(t, a, b)`
//! ([`CurvePoint`]). [H15] bounds its part inside the triangle by its edge crossings and assumes
//! t is monotone along it. Inside a strongly focusing triangle the curve can turn back in t (a
//! fold: there D = 0, a volume caustic, physics.md §1.3 corollary); then two branches coexist
//! over part of the range and a single fixed-t Newton finds only one of them. So here:
//!
//! 1. the t-range is first restricted by the triangle's plane (V behind it, L in front, §2.3;
//!    [`plane_t_range`]);
//! 2. every point where the curve enters or leaves the region `triangle × t-range` is found
//!    (`search`): edge crossings (see [`edge`](crate::scatter::triangle::edge)) and solutions
//!    inside the triangle at the range ends (the segment's own entry or exit, or the plane's
//!    bound); arcs can also end inside the triangle where the light grazes the shading normal
//!    (`c_L → 0`, contribution → 0), so the curve's crossings with six lines across the triangle
//!    seed arcs that touch no boundary (`boundary`);
//! 3. from each such point the curve is traced inward by predictor–corrector continuation until
//!    it leaves or grazes (`trace`), which pairs entries with exits whatever the edges
//!    (Algorithm 1's second pass is implicit); interior seeds are traced both ways;
//! 4. along each traced arc, sign changes of `g_t` (the t-component of the continuously oriented
//!    tangent) are folds; each is located by solving `g_t = 0` along the curve, and the arc is
//!    split there into monotone branches (`folds`);
//! 5. each branch becomes an [`Interval`] carrying seeds `(t, a, b)` along it, so that the
//!    fixed-t solve at a sample point starts on the right branch; a sample is accepted only if
//!    its branch label (the sign of `N̂s·(J_a×J_b)`) matches the interval's (`sample`).
//!
//! Not found: closed loops of the curve wholly inside one triangle and range, and arcs that touch
//! no boundary and cross none of the six interior lines (a closed loop needs two folds inside one
//! triangle).

mod boundary;
mod folds;
mod plane_range;
mod sample;
mod search;
mod trace;

#[cfg(test)]
mod tests;

pub use plane_range::{plane_depth, plane_t_range};
pub use sample::{SampleRule, for_each_sample};
pub use search::{SEARCH_TOLERANCE, triangle_intervals, triangle_intervals_with};

use crate::scatter::triangle::curve::{CurvePoint, Sign};
use crate::scatter::triangle::ends::DepthRange;
use crate::scatter::triangle::small_list::SmallList;

/// At most this many monotone branches per triangle (more are dropped, and counted in
/// `RenderStats::capacity_drops`).
pub const MAX_INTERVALS: usize = 8;
/// Seeds stored per interval.
const MAX_SEEDS: usize = 8;

/// The monotone branches of the curve on one triangle.
pub type Intervals = SmallList<Interval, MAX_INTERVALS>;

/// One monotone branch of the solution curve on a triangle: for every `t ∈ [t_min, t_max]` there is
/// exactly one refraction point on this branch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// Lower end of the branch in t.
    pub t_min: f64,
    /// Upper end of the branch in t.
    pub t_max: f64,
    /// The depths its samples cover: `[t_min, t_max]`, widened at an end that lies on the
    /// triangle's plane over the thin layer [`plane_t_range`] leaves out there (where f is
    /// singular); samples in that layer use the path at the end. In a dense medium that layer,
    /// just under the surface, is where most of the light scatters.
    pub reach: DepthRange,
    /// The sign of `N̂s·(J_a×J_b)` on the branch: it labels the branch (it flips at a fold).
    pub branch: Sign,
    /// Points of the branch, increasing in t, including both ends.
    seeds: [CurvePoint; MAX_SEEDS],
    seed_count: usize,
}

impl Interval {
    /// The seeds along the branch, increasing in t.
    pub fn seeds(&self) -> &[CurvePoint] {
        &self.seeds[..self.seed_count]
    }

    /// The starting point `(a, b)` of the fixed-t solve at `t`: linear interpolation between the
    /// seeds bracketing t.
    pub fn seed_at(&self, t: f64) -> (f64, f64) {
        let seeds = self.seeds();
        let i = seeds
            .partition_point(|s| s.t <= t)
            .clamp(1, seeds.len().max(2) - 1);
        let (s0, s1) = (seeds[i - 1], seeds[(i).min(seeds.len() - 1)]);
        let span = s1.t - s0.t;
        let theta = if span > 0.0 {
            ((t - s0.t) / span).clamp(0.0, 1.0)
        } else {
            0.5
        };
        (s0.a + theta * (s1.a - s0.a), s0.b + theta * (s1.b - s0.b))
    }
}
