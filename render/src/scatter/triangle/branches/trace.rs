//! The tracing of one arc of the solution curve through the region `triangle × t-range`:
//! predictor–corrector continuation from a boundary point or an interior seed until the arc
//! leaves the region or ends where the light grazes the shading normal.

use glam::DVec3;
use spindle_common::stats::RenderStats;

use super::boundary::{Boundary, BoundaryPoints, INTERIOR_LINES, InteriorSeeds, Side};
use crate::scatter::triangle::curve::{CurvePoint, Sign};
use crate::scatter::triangle::edge::Edge;
use crate::scatter::triangle::ends::{DepthRange, PathEnds};
use crate::scatter::triangle::patch::TrianglePatch;
use crate::scatter::triangle::small_list::SmallList;
use crate::scatter::triangle::solve::{
    INSIDE_TOLERANCE, NewtonSettings, RefractionPath, Slice, is_physical, newton, plane_piercing,
    plane_refraction_guess,
};

/// Points kept per traced arc. A longer arc is thinned (see [`push_node`]), so this bounds memory,
/// not the arc's length.
pub(super) const MAX_TRACE: usize = 96;
/// Accepted continuation steps per traced arc. Arcs that run along t much farther than the
/// triangle's size take many steps (on the bumpy-sphere example a small triangle's arc spans 14
/// triangle sizes of t, about 95 steps at [`STEP_MAX`]); 1024 steps cover 150 sizes.
const MAX_STEPS: usize = 1024;
/// Continuation step bounds, in barycentric units (t is scaled by the triangle's size). Steps grow
/// to `STEP_MAX`, and beyond it, up to `STEP_CAP`, only where the curve is nearly straight: the
/// corrector's offset from the prediction (about κh²/2 on a curve of curvature κ) stays near
/// `STEP_BEND` × h, a turn of about 2 × `STEP_BEND` radians per step, so folds (turns of g_t) are
/// still seen between nodes. Long steps stop `STEP_MAX` short of the region's boundary (along the
/// tangent), so the region is always left by a step of at most `STEP_MAX`: the chord of that step
/// decides the exit edge, and a long chord could cut a corner (the arc would then be traced again
/// from its real exit and counted twice).
const STEP_START: f64 = 0.05;
const STEP_MAX: f64 = 0.15;
const STEP_CAP: f64 = 3.0;
const STEP_BEND: f64 = 0.05;
const STEP_MIN: f64 = 1e-7;
/// Points of parameter space closer than this (t scaled by the triangle's size) are one point
/// of the curve: several boundary points found there, or an arc's exit and a boundary point.
pub(super) const SAME_POINT: f64 = 1e-7;

/// One traced point of the curve: its position and the t-component of its oriented tangent,
/// `None` where the tangent is unknown (an exit point that could not be solved exactly).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Node {
    pub x: CurvePoint,
    pub g_t: Option<f64>,
}

impl Node {
    /// g_t, if it is known and finite.
    #[inline]
    pub fn finite_g_t(&self) -> Option<f64> {
        self.g_t.filter(|g| g.is_finite())
    }
}

/// The points of one traced arc, in the order of travel.
pub(super) type Arc = SmallList<Node, MAX_TRACE>;

/// Appends `node` to a traced arc; a full arc is first thinned to every other point, keeping both
/// ends and both points around every sign change of `g_t` (a fold between them is located from
/// that pair). Only where the thinning frees nothing is the node dropped and counted.
pub(super) fn push_node(arc: &mut Arc, node: Node, stats: &mut RenderStats) {
    if arc.len() == MAX_TRACE {
        let g_sign = |i: usize| arc.get(i).and_then(|n| n.g_t).map(f64::signum);
        let last = arc.len() - 1;
        let mut thinned = Arc::default();
        for (i, n) in arc.iter().enumerate() {
            let at_fold = n.finite_g_t().is_none()
                || (i > 0 && g_sign(i - 1) != g_sign(i))
                || (i < last && g_sign(i + 1) != g_sign(i));
            if i % 2 == 0 || i == last || at_fold {
                // Fewer points than before: there is room.
                thinned.push_or_count(*n, &mut stats.capacity_drops);
            }
        }
        *arc = thinned;
    }
    arc.push_or_count(node, &mut stats.capacity_drops);
}

/// A point found by the corrector, with its oriented tangent, and whether it is a physical
/// refraction ([`is_physical`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Corrected {
    pub x: CurvePoint,
    pub g: CurvePoint,
    pub physical: bool,
}

/// The fixed data of one triangle's search.
pub(super) struct Tracer<'a> {
    pub patch: &'a TrianglePatch,
    pub ends: &'a PathEnds,
    pub range: DepthRange,
    /// The triangle's size, which scales t against the barycentric coordinates.
    pub scale: f64,
    pub tolerance: f64,
}

impl Tracer<'_> {
    /// Distance between two parameter-space points, t scaled by the triangle's size.
    pub fn distance(&self, x: CurvePoint, y: CurvePoint) -> f64 {
        DVec3::new((x.t - y.t) / self.scale, x.a - y.a, x.b - y.b).length()
    }

    /// Whether `x` lies in the region `triangle × range`.
    fn inside(&self, x: CurvePoint) -> bool {
        self.range.contains(x.t) && self.patch.contains(x.a, x.b, 0.0)
    }

    /// Solutions inside the triangle at the range end t, from the plane-refraction guess and, when
    /// the end is on the triangle's plane, from the piercing point and its tangent.
    pub fn range_end_points(
        &self,
        side: Side,
        t: f64,
        out: &mut BoundaryPoints,
        stats: &mut RenderStats,
    ) {
        let guess = plane_refraction_guess(self.patch, self.ends, t);
        let near_piercing = plane_piercing(self.patch, self.ends).and_then(|(pierce, tangent)| {
            let dt = t - pierce.t;
            (dt.abs() <= 1e-3 * self.scale)
                .then_some((pierce.a + dt * tangent.a, pierce.b + dt * tangent.b))
        });
        let settings = NewtonSettings::new(self.tolerance, self.range);
        for start in [guess, near_piercing].into_iter().flatten() {
            let (zero, spent) = newton(self.patch, self.ends, &Slice::fixed_t(t), start, &settings);
            stats.newton_iterations += spent as u64;
            let Some(z) = zero else { continue };
            if !self.patch.contains(z.x.a, z.x.b, 0.0) {
                continue;
            }
            if RefractionPath::from_zero(self.patch, self.ends, t, z.x.a, z.x.b, &z.residual)
                .is_none()
            {
                continue;
            }
            let Some(g) = z.residual.tangent() else {
                continue;
            };
            let point = Boundary {
                side,
                x: z.x,
                g,
                consumed: false,
            };
            self.add_boundary(out, point, stats);
        }
    }

    /// Adds a boundary point unless one within [`SAME_POINT`] of it is known already: a point of
    /// the curve at a vertex lies on two edges (and perhaps at a range end), and the curve
    /// through it is one arc, to be traced once. Two arcs that leave the same point would need
    /// a singular point of the curve there.
    pub fn add_boundary(&self, out: &mut BoundaryPoints, point: Boundary, stats: &mut RenderStats) {
        if out.iter().any(|b| self.distance(b.x, point.x) < SAME_POINT) {
            return;
        }
        out.push_or_count(point, &mut stats.capacity_drops);
    }

    /// The unit direction of travel `σ·g` in the scaled metric, back in parameter units.
    fn direction(&self, g: CurvePoint, sigma: Sign) -> CurvePoint {
        let scaled = DVec3::new(g.t / self.scale, g.a, g.b) * sigma.value();
        let unit = scaled.normalize_or_zero();
        CurvePoint::new(unit.x * self.scale, unit.y, unit.z)
    }

    /// Solves back onto the curve from `predicted`, fixing the coordinate along which `direction`
    /// moves most (natural-parameter continuation).
    pub fn correct(
        &self,
        predicted: CurvePoint,
        direction: CurvePoint,
        stats: &mut RenderStats,
    ) -> Option<Corrected> {
        let weights = [
            direction.t.abs() / self.scale,
            direction.a.abs(),
            direction.b.abs(),
        ];
        let fixed = if weights[0] >= weights[1] && weights[0] >= weights[2] {
            0
        } else if weights[1] >= weights[2] {
            1
        } else {
            2
        };
        let (slice, start) = match fixed {
            0 => (Slice::fixed_t(predicted.t), (predicted.a, predicted.b)),
            1 => (
                Slice {
                    origin: [0.0, predicted.a, 0.0],
                    du: [1.0, 0.0, 0.0],
                    dv: [0.0, 0.0, 1.0],
                },
                (predicted.t, predicted.b),
            ),
            _ => (
                Slice {
                    origin: [0.0, 0.0, predicted.b],
                    du: [1.0, 0.0, 0.0],
                    dv: [0.0, 1.0, 0.0],
                },
                (predicted.t, predicted.a),
            ),
        };
        let span = self.range.hi - self.range.lo + self.scale;
        let settings = NewtonSettings::new(
            self.tolerance,
            DepthRange::new(self.range.lo - span, self.range.hi + span),
        );
        let (zero, spent) = newton(self.patch, self.ends, &slice, start, &settings);
        stats.newton_iterations += spent as u64;
        let z = zero?;
        let physical = is_physical(self.patch, &z.residual);
        Some(Corrected {
            x: z.x,
            g: z.residual.tangent()?,
            physical,
        })
    }

    /// Traces the arc from `x` along `σ·g` until it leaves the region, appending nodes to `arc`.
    /// Returns the exit point, or None if the trace ended inside (a singular point or too long).
    pub fn trace(
        &self,
        mut x: CurvePoint,
        mut g: CurvePoint,
        sigma: Sign,
        arc: &mut Arc,
        seeds: &mut InteriorSeeds,
        stats: &mut RenderStats,
    ) -> Option<CurvePoint> {
        let mut h = STEP_START;
        for _ in 0..MAX_STEPS {
            let dir = self.direction(g, sigma);
            h = h.min((self.to_boundary(x, dir) - STEP_MAX).max(STEP_MAX));
            let predicted = x.step(h, dir);
            // Long steps must land nearer the prediction (they are taken only where the curve
            // is straight), so that the corrector cannot jump to a neighbouring arc.
            let offset_limit = if h > STEP_MAX {
                4.0 * STEP_BEND * h
            } else {
                0.5 * h
            };
            let next = self.correct(predicted, dir, stats).filter(|c| {
                // Stay on the same arc: close to the prediction, same orientation.
                let turn = self.direction(c.g, sigma);
                self.distance(c.x, predicted) <= offset_limit
                    && (turn.t * dir.t / (self.scale * self.scale)
                        + turn.a * dir.a
                        + turn.b * dir.b)
                        > 0.0
            });
            let Some(Corrected {
                x: xn,
                g: gn,
                physical,
            }) = next
            else {
                if let Some(end) = self.range_end_exit(x, predicted, h, stats) {
                    push_node(arc, end, stats);
                    return Some(end.x);
                }
                h *= 0.5;
                if h < STEP_MIN {
                    stats.newton_failures += 1;
                    return None;
                }
                continue;
            };
            self.consume_seeds(x, xn, seeds);
            if !self.inside(xn) {
                let exit = self.locate_exit(x, xn, stats);
                let exit_physical = self
                    .patch
                    .residual(self.ends, exit.x.t, exit.x.a, exit.x.b)
                    .is_some_and(|r| is_physical(self.patch, &r));
                if exit_physical {
                    push_node(arc, exit, stats);
                    return Some(exit.x);
                }
                // The light grazes the shading normal before the arc reaches the boundary.
                if let Some(end) = self.locate_grazing_end(x, exit.x, stats) {
                    push_node(arc, end, stats);
                }
                return None;
            }
            if !physical {
                // The light grazes the shading normal here (c_L → 0): the arc ends, with a
                // vanishing contribution; locate the end by bisection along the chord.
                if let Some(end) = self.locate_grazing_end(x, xn, stats) {
                    push_node(arc, end, stats);
                }
                return None;
            }
            let node = Node {
                x: xn,
                g_t: Some(gn.t),
            };
            push_node(arc, node, stats);
            let bend = self.distance(xn, predicted) / h;
            x = xn;
            g = gn;
            let straight = if bend > 0.0 {
                h * (STEP_BEND / bend).clamp(0.5, 2.0)
            } else {
                2.0 * h
            };
            h = (h * 1.5).min(STEP_MAX).max(straight.min(STEP_CAP));
        }
        // The arc needs more steps than allowed: the rest of it is lost.
        stats.capacity_drops += 1;
        None
    }

    /// How far `x` can move along `dir` (in parameter units per unit of `h`) before the straight
    /// line leaves the region `triangle × range`.
    fn to_boundary(&self, x: CurvePoint, dir: CurvePoint) -> f64 {
        let mut h = f64::INFINITY;
        let mut limit = |room: f64, rate: f64| {
            if rate < 0.0 {
                h = h.min((room / -rate).max(0.0));
            }
        };
        limit(x.t - self.range.lo, dir.t);
        limit(self.range.hi - x.t, -dir.t);
        limit(x.a, dir.a);
        limit(x.b, dir.b);
        limit(1.0 - x.a - x.b, -(dir.a + dir.b));
        h
    }

    /// The exit through a range end when the step from `x` to `predicted` crosses it and the
    /// correction found no point of the curve: the solution at the range end itself, from the
    /// chord's point there, if it is physical, inside the triangle and within `h/2` of that
    /// point (the acceptance rule of every step).
    ///
    /// A range end on the triangle's plane (pulled in by [`PLANE_MARGIN`](super::plane_range::PLANE_MARGIN)) is next to the
    /// singular point V = P of the curve, beyond which no correction converges; without this the
    /// trace would halve its step until it gave up a hair short of the end, and the same arc
    /// would then be traced again from the range end's boundary point and counted twice.
    fn range_end_exit(
        &self,
        x: CurvePoint,
        predicted: CurvePoint,
        h: f64,
        stats: &mut RenderStats,
    ) -> Option<Node> {
        let bound = if predicted.t > self.range.hi {
            self.range.hi
        } else if predicted.t < self.range.lo {
            self.range.lo
        } else {
            return None;
        };
        let theta = (bound - x.t) / (predicted.t - x.t);
        let start = x.toward(predicted, theta);
        let settings = NewtonSettings::new(self.tolerance, self.range);
        let (zero, spent) = newton(
            self.patch,
            self.ends,
            &Slice::fixed_t(bound),
            (start.a, start.b),
            &settings,
        );
        stats.newton_iterations += spent as u64;
        let z = zero?;
        let usable = self.patch.contains(z.x.a, z.x.b, 0.0)
            && is_physical(self.patch, &z.residual)
            && self.distance(z.x, start) <= 0.5 * h;
        let g = z.residual.tangent().filter(|_| usable)?;
        Some(Node {
            x: z.x,
            g_t: Some(g.t),
        })
    }

    /// Marks the interior seeds whose line the chord `x → xn` crosses, near the crossing, as
    /// consumed: the arc being traced passes through them.
    fn consume_seeds(&self, x: CurvePoint, xn: CurvePoint, seeds: &mut InteriorSeeds) {
        let chord = self.distance(x, xn);
        for i in 0..seeds.len() {
            let Some(seed) = seeds.get_mut(i) else {
                continue;
            };
            if seed.consumed {
                continue;
            }
            let line = &INTERIOR_LINES[seed.line];
            let (s0, s1) = (line.side(x.a, x.b), line.side(xn.a, xn.b));
            if s0 * s1 > 0.0 {
                continue;
            }
            let theta = if s0 != s1 { s0 / (s0 - s1) } else { 0.5 };
            let hit = x.toward(xn, theta);
            if self.distance(hit, seed.x) <= 0.25 * chord + 1e-9 {
                seed.consumed = true;
            }
        }
    }

    /// The last physical point between the physical `x` and the grazing `xn`, by bisection along
    /// the chord (each point corrected onto the curve).
    fn locate_grazing_end(
        &self,
        x: CurvePoint,
        xn: CurvePoint,
        stats: &mut RenderStats,
    ) -> Option<Node> {
        let chord = xn.minus(x);
        let (mut lo, mut hi) = (0.0, 1.0);
        let mut best = None;
        for _ in 0..16 {
            let mid = 0.5 * (lo + hi);
            let predicted = x.step(mid, chord);
            match self.correct(predicted, chord, stats) {
                Some(Corrected {
                    x: p,
                    g,
                    physical: true,
                }) if self.inside(p) => {
                    best = Some(Node {
                        x: p,
                        g_t: Some(g.t),
                    });
                    lo = mid;
                }
                _ => hi = mid,
            }
        }
        best
    }

    /// The exit point between the inside point `x` and the outside point `xn`: the first boundary
    /// crossed by the chord, then solved exactly on that boundary. Where that solve fails, the
    /// chord's point on the boundary, with an unknown tangent.
    fn locate_exit(&self, x: CurvePoint, xn: CurvePoint, stats: &mut RenderStats) -> Node {
        // Fraction of the chord at which each constraint is crossed.
        let frac = |v0: f64, v1: f64| {
            if v1 < 0.0 && v0 >= 0.0 {
                v0 / (v0 - v1)
            } else {
                f64::INFINITY
            }
        };
        let candidates = [
            (Side::Edge(Edge::A0), frac(x.a, xn.a)),
            (Side::Edge(Edge::B0), frac(x.b, xn.b)),
            (
                Side::Edge(Edge::Ab1),
                frac(1.0 - x.a - x.b, 1.0 - xn.a - xn.b),
            ),
            (
                Side::RangeLow,
                frac(x.t - self.range.lo, xn.t - self.range.lo),
            ),
            (
                Side::RangeHigh,
                frac(self.range.hi - x.t, self.range.hi - xn.t),
            ),
        ];
        // The sides in the order the chord crosses them. Near an edge or a corner of the region
        // the chord may cross a side the curve itself does not (the curve bends between x and
        // xn): then the solve on that side fails, and the next side the chord crosses is tried.
        let mut order = candidates;
        order.sort_by(|p, q| p.1.total_cmp(&q.1));
        let chord = self.distance(x, xn);
        let mut first_seed = None;
        for (rank, &(side, theta)) in order.iter().enumerate() {
            if rank > 0 && !theta.is_finite() {
                break;
            }
            let theta = if theta.is_finite() { theta } else { 1.0 };
            let seed = x.toward(xn, theta);
            first_seed.get_or_insert(seed);
            let Some((found, g_t)) = self.solve_on_side(side, seed, stats) else {
                continue;
            };
            // The first side's solution is taken as it is; another side's must lie on the
            // region's boundary, not beyond a side the chord crossed first.
            let on_region = rank == 0
                || (self.range.contains(found.t)
                    && self.patch.contains(found.a, found.b, INSIDE_TOLERANCE));
            if on_region && self.distance(found, seed) <= chord {
                return Node {
                    x: found,
                    g_t: Some(g_t),
                };
            }
        }
        stats.newton_failures += 1;
        Node {
            x: first_seed.unwrap_or(xn),
            g_t: None,
        }
    }

    /// The point of the curve on the region's side `side` nearest to `seed`, with g_t there.
    fn solve_on_side(
        &self,
        side: Side,
        seed: CurvePoint,
        stats: &mut RenderStats,
    ) -> Option<(CurvePoint, f64)> {
        let settings = NewtonSettings::new(self.tolerance, self.range);
        let (zero, spent) = match side {
            Side::Edge(edge) => {
                let s = match edge {
                    Edge::A0 | Edge::Ab1 => seed.b,
                    Edge::B0 => seed.a,
                };
                newton(self.patch, self.ends, &edge.slice(), (seed.t, s), &settings)
            }
            Side::RangeLow | Side::RangeHigh => {
                let t = if side == Side::RangeLow {
                    self.range.lo
                } else {
                    self.range.hi
                };
                newton(
                    self.patch,
                    self.ends,
                    &Slice::fixed_t(t),
                    (seed.a, seed.b),
                    &settings,
                )
            }
        };
        stats.newton_iterations += spent as u64;
        zero.and_then(|z| z.residual.tangent().map(|g| (z.x, g.t)))
    }
}
