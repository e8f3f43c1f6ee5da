//! The per-triangle search: the boundary points and interior seeds of the region
//! `triangle × t-range`, each arc traced from them and split at its folds into [`Interval`](super::Interval)s.

use spindle_common::stats::RenderStats;

use super::Intervals;
use super::boundary::{
    Boundary, BoundaryPoints, INTERIOR_LINES, InteriorSeed, InteriorSeeds, Side,
};
use super::plane_range::{plane_depth, plane_t_range};
use super::trace::{Arc, Node, Tracer, push_node};
use crate::scatter::triangle::curve::Sign;
use crate::scatter::triangle::edge::{Crossing, CrossingSearch, Edge, LineScan, scan_line};
use crate::scatter::triangle::ends::{DepthRange, PathEnds};
use crate::scatter::triangle::patch::TrianglePatch;
use crate::scatter::triangle::small_list::SmallList;
use crate::scatter::triangle::solve::{MIN_COS_LIGHT, is_physical};

/// The Newton tolerance of the search itself (crossings, traced arcs, folds), whatever looser
/// `newton_tolerance` the user sets: the structure must be exact for duplicates to be recognised
/// and arcs paired (a crossing found from two brackets must come out as one point, or its arc is
/// counted twice); the user's tolerance then sets only how exactly each sample point is solved
/// ([`for_each_sample`](super::for_each_sample)).
pub const SEARCH_TOLERANCE: f64 = 1e-10;

/// The per-triangle search: finds every monotone branch of the curve inside the triangle within
/// `range`, solving to `tolerance` or [`SEARCH_TOLERANCE`], whichever is tighter. Newton
/// evaluations and failures, intervals and folds are counted in `stats`. The triangle's edges are
/// scanned from its own patch; [`triangle_intervals_with`] takes the scans from elsewhere and a
/// cheap test of the range ends.
pub fn triangle_intervals(
    patch: &TrianglePatch,
    ends: &PathEnds,
    range: DepthRange,
    tolerance: f64,
    stats: &mut RenderStats,
) -> Intervals {
    let own = |edge: Edge| scan_line(patch, ends, &edge.line());
    triangle_intervals_with(patch, ends, range, tolerance, own, |_| true, stats)
}

/// [`triangle_intervals`] with the scan of each edge (in the direction of [`Edge::line`]) from
/// `edge_scan`, e.g. shared with the neighbouring triangles (`edge_scans`), and with
/// `may_hold_at(t)`, which must be `false` only where no valid refraction point on the triangle
/// sees `V(t)` (e.g. the cone test at the single point `V(t)`): the solves at a range end `t` where
/// it is `false` are skipped (they cannot succeed, and a failing solve is the search's most
/// expensive step).
pub fn triangle_intervals_with(
    patch: &TrianglePatch,
    ends: &PathEnds,
    range: DepthRange,
    tolerance: f64,
    mut edge_scan: impl FnMut(Edge) -> LineScan,
    mut may_hold_at: impl FnMut(f64) -> bool,
    stats: &mut RenderStats,
) -> Intervals {
    let tolerance = tolerance.min(SEARCH_TOLERANCE);
    let mut intervals = Intervals::default();
    let searched = range;
    let Some(range) = plane_t_range(patch, ends, range) else {
        return intervals;
    };
    let tracer = Tracer {
        patch,
        ends,
        range,
        scale: patch.double_area.sqrt(),
        tolerance,
    };

    // Arcs end inside the triangle only where the light grazes the shading normal: where it
    // faces every shading normal of the triangle, no arc misses the boundary and the lines are
    // not scanned (they are most of the per-triangle cost).
    let lines = if patch.min_facing_cosine(ends.light) > 2.0 * MIN_COS_LIGHT {
        &[][..]
    } else {
        &INTERIOR_LINES[..]
    };
    let scans = Edge::ALL.map(&mut edge_scan);
    if lines.is_empty() && !scans.iter().any(changes_sign) {
        // The skew scalar keeps one sign all around the triangle and the light faces every
        // normal (η > 1: no total reflection), so the curve's projection on the triangle
        // touches no edge: it is empty or a closed loop (not searched, see above), and there
        // is no solution at the range ends either.
        return intervals;
    }

    // Find where the curve crosses the region's boundary.
    let search = CrossingSearch {
        patch,
        ends,
        range,
        tolerance,
    };
    let mut crossings: SmallList<Crossing, 12> = SmallList::default();
    for (edge, scan) in Edge::ALL.into_iter().zip(&scans) {
        search.edge_crossings(edge, scan, &mut crossings, stats);
    }
    let mut boundary = BoundaryPoints::default();
    for c in crossings.iter() {
        let point = Boundary {
            side: Side::Edge(c.edge),
            x: c.x,
            g: c.g,
            consumed: false,
        };
        tracer.add_boundary(&mut boundary, point, stats);
    }
    for (side, t) in [(Side::RangeLow, range.lo), (Side::RangeHigh, range.hi)] {
        if may_hold_at(t) {
            tracer.range_end_points(side, t, &mut boundary, stats);
        }
    }
    let mut seeds = InteriorSeeds::default();
    for (line, l) in lines.iter().enumerate() {
        let mut dropped = 0;
        let scan = scan_line(patch, ends, l);
        search.line_crossings(l, &scan, stats, |x, r| {
            if is_physical(patch, r)
                && let Some(g) = r.tangent()
            {
                let seed = InteriorSeed {
                    line,
                    x,
                    g,
                    consumed: false,
                };
                seeds.push_or_count(seed, &mut dropped);
            }
        });
        stats.capacity_drops += dropped;
    }

    // Trace each arc from its entry, split it at folds, and emit its monotone branches.
    // `unfinished[i]`: the intervals emitted by the arc started at boundary point `i` when that
    // arc stopped short of any boundary point (its trace broke down, as next to the end of a
    // segment that ends on the surface, where the path's inside leg shrinks to nothing).
    let mut unfinished: [Option<(usize, usize)>; 16] = [None; 16];
    for start in 0..boundary.len() {
        let Some(&b) = boundary.get(start) else {
            continue;
        };
        if b.consumed {
            continue;
        }
        let inward = match b.side {
            Side::Edge(edge) => edge.inward(b.g),
            Side::RangeLow => b.g.t,
            Side::RangeHigh => -b.g.t,
        };
        let sigma = match Sign::of(inward) {
            Some(sigma) if inward != 0.0 && inward.is_finite() => sigma,
            _ => continue,
        };
        if let Some(entry) = boundary.get_mut(start) {
            entry.consumed = true;
        }
        let mut arc = Arc::default();
        let entry = Node {
            x: b.x,
            g_t: Some(b.g.t),
        };
        arc.push_or_count(entry, &mut stats.capacity_drops);
        let exit = tracer.trace(b.x, b.g, sigma, &mut arc, &mut seeds, stats);
        if let Some(exit) = exit {
            // The exit is another boundary point: do not trace the arc again from there. If an
            // arc started there and broke down, it was this curve traced from its other end, a
            // part of this arc: its intervals are dropped, or they would count twice.
            for other in 0..boundary.len() {
                if let Some(o) = boundary.get_mut(other)
                    && other != start
                    && tracer.distance(o.x, exit) < 1e-6
                {
                    if !o.consumed {
                        o.consumed = true;
                        break;
                    }
                    if let Some(dropped) = unfinished.get_mut(other).and_then(Option::take) {
                        intervals = without(&intervals, dropped);
                        let removed = dropped.1 - dropped.0;
                        for (from, to) in unfinished.iter_mut().flatten() {
                            if *from >= dropped.1 {
                                *from -= removed;
                                *to -= removed;
                            }
                        }
                        break;
                    }
                }
            }
        }
        let first = intervals.len();
        tracer.emit_branches(&arc, sigma, &mut intervals, stats);
        if exit.is_none()
            && let Some(slot) = unfinished.get_mut(start)
        {
            *slot = Some((first, intervals.len()));
        }
    }

    // Arcs that touch no boundary: trace both ways from an interior seed and join the halves.
    for index in 0..seeds.len() {
        let Some(&seed) = seeds.get(index) else {
            continue;
        };
        if seed.consumed {
            continue;
        }
        if let Some(s) = seeds.get_mut(index) {
            s.consumed = true;
        }
        let mut backward = Arc::default();
        tracer.trace(
            seed.x,
            seed.g,
            Sign::Minus,
            &mut backward,
            &mut seeds,
            stats,
        );
        let mut forward = Arc::default();
        tracer.trace(seed.x, seed.g, Sign::Plus, &mut forward, &mut seeds, stats);
        let mut arc = Arc::default();
        let middle = Node {
            x: seed.x,
            g_t: Some(seed.g.t),
        };
        let halves = (0..backward.len()).rev().filter_map(|i| backward.get(i));
        for &n in halves.chain([&middle]).chain(forward.iter()) {
            push_node(&mut arc, n, stats);
        }
        tracer.emit_branches(&arc, Sign::Plus, &mut intervals, stats);
    }
    reach_the_plane(&mut intervals, plane_depth(patch, ends), range, searched);
    intervals
}

/// `intervals` without those at indices `from..to`.
fn without(intervals: &Intervals, (from, to): (usize, usize)) -> Intervals {
    let mut kept = Intervals::default();
    for (i, interval) in intervals.iter().enumerate() {
        if !(from..to).contains(&i) {
            // A part of a list fits a list of the same capacity.
            let fits = kept.push(*interval);
            debug_assert!(fits);
        }
    }
    kept
}

/// Widens the reach of every interval that ends where `plane_t_range` cut the `searched` range
/// short of the triangle's plane (at depth `plane`) to the plane itself, within `searched`.
fn reach_the_plane(
    intervals: &mut Intervals,
    plane: Option<f64>,
    cut: DepthRange,
    searched: DepthRange,
) {
    let Some(plane) = plane else { return };
    let at = |t: f64, end: f64| (t - end).abs() <= 0.01 * (end - plane).abs();
    for interval in intervals.iter_mut() {
        if cut.lo > searched.lo && plane < cut.lo && at(interval.t_min, cut.lo) {
            interval.reach.lo = plane.max(searched.lo);
        }
        if cut.hi < searched.hi && plane > cut.hi && at(interval.t_max, cut.hi) {
            interval.reach.hi = plane.min(searched.hi);
        }
    }
}

/// Whether the skew scalar may change sign along a scanned line: a sign change between two scan
/// points, or a point where it is undefined.
fn changes_sign(scan: &LineScan) -> bool {
    let Some(Some(first)) = scan.first() else {
        return true;
    };
    scan.iter().any(|c| c.is_none_or(|c| !c.same_sign(*first)))
}
