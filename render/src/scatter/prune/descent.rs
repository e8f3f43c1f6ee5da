//! The hierarchical descent of an object's BVH that yields the triangles worth solving on
//! ([H15] §3.2.4): start at the root, keep a node only if its bounding sphere passes the spindle
//! test and the cone of every normal below it passes the half-vector / normal cone test (which
//! also trims the node's `t`-range, inherited by its children); then put each triangle of a
//! surviving leaf through sidedness (light in front of its plane and of some shading normal on
//! it, camera point behind the plane: physics.md §2.3, §2.5 item 3) and its own cone test on that
//! trimmed range.
//!
//! Every test is conservative (see `prune`), so the descent never loses a solution; each stage
//! can be switched off (`integrator.single_scatter.pruning`) to measure what it saves. The
//! counters go to `RenderStats`: nodes visited, nodes culled by the spindle and by the cone test,
//! triangles tested, triangles culled by the plane and by the cone test.

use spindle_common::scene::Pruning;
use spindle_common::stats::RenderStats;

use crate::scatter::geometry::facing_bounds;
use crate::scatter::prune::SegmentQuery;
use crate::scatter::prune::beam::BeamBound;
use crate::scatter::prune::beam_table::Beams;
use crate::scatter::triangle::ends::DepthRange;
use crate::scene::Object;

/// A triangle of the object that may hold refraction points, and the depths to search on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Index of the triangle in the object's mesh.
    pub triangle: u32,
    /// Its leaf slot in the BVH, where its pruning bounds are (`PruneBounds::triangle_at_slot`).
    pub slot: u32,
    /// The query's range, cut by the triangle's plane.
    pub range: DepthRange,
}

/// Reusable traversal stack of `(node, range)` (one per `single_scatter` call, so the hot loop
/// does not allocate).
#[derive(Debug, Default)]
pub struct DescentStack(Vec<(u32, DepthRange)>);

/// Calls `visit` for every candidate triangle of `object` for the query (segment range and light
/// point), with the pruning stages `pruning` enabled and the beams from `beams`.
pub fn for_each_candidate(
    object: &Object,
    query: &SegmentQuery,
    beams: Beams<'_>,
    pruning: &Pruning,
    stack: &mut DescentStack,
    stats: &mut RenderStats,
    mut visit: impl FnMut(Candidate, &mut RenderStats),
) {
    if object.bvh.nodes().is_empty() || query.range.lo > query.range.hi {
        return;
    }
    let mesh = &object.mesh;
    let stack = &mut stack.0;
    stack.clear();
    stack.push((0, query.range));
    while let Some((node, range)) = stack.pop() {
        stats.bvh_nodes_visited += 1;
        let mut node_query = query.with_range(range);
        let bounds = object.bounds.node(node);
        let children = object.bvh.children(node);
        let beam = match (pruning.cone, bounds.cone) {
            (true, Some(cone)) => beams.node(&query.ends, node, bounds.sphere, cone),
            _ => BeamBound::Unbounded,
        };
        // Where the beam bounds the solutions it culls more than the spindle test, which is
        // then skipped (docs/benchmarks.md, ninth round).
        if matches!(beam, BeamBound::Unbounded)
            && pruning.spindle
            && !node_query.spindle_may_contain(bounds.sphere)
        {
            stats.nodes_culled_spindle += 1;
            continue;
        }
        // An inner node's trimmed range is what its children start from; a leaf's would only
        // narrow the ranges its triangles are culled on, which saves less than the bisection's
        // trimming (from both ends) costs, so a leaf is only tested there.
        let kept = match bounds.cone {
            Some(cone) if pruning.cone => match (beam, children) {
                (BeamBound::Unbounded, None) => node_query
                    .bisected_may_contain(bounds.sphere, cone)
                    .then_some(node_query.range),
                _ => node_query.cone_trim_given(beam, bounds.sphere, cone),
            },
            _ => Some(node_query.range),
        };
        match kept {
            Some(range) => node_query = node_query.with_range(range),
            None => {
                stats.nodes_culled_cone += 1;
                continue;
            }
        }
        if let Some([left, right]) = children {
            stack.push((right, node_query.range));
            stack.push((left, node_query.range));
            continue;
        }
        for (slot, triangle) in object.bvh.leaf_slots(node) {
            stats.triangles_tested += 1;
            let bounds = object.bounds.triangle_at_slot(slot);
            // Two ranges: `search`, handed to the candidate, is the query's range cut by the
            // plane only; `culling` is that cut by the cone tests too, and serves only to cull.
            // (The per-triangle search is cheaper from range ends on the plane or the segment's
            // ends than from the cone tests' ends, where the curve does not reach and the range-
            // end solves fail expensively; docs/benchmarks.md.)
            let mut search = (query.range.lo, query.range.hi);
            if pruning.plane
                && let Some(plane) = bounds.plane
            {
                let index = triangle as usize;
                let faces_light = || {
                    let (corners, normals) = (mesh.corners(index), mesh.corner_normals(index));
                    facing_bounds(corners, normals, query.ends.light).1 > 0.0
                };
                // Closed and without margin, so a solution exactly at the bound is kept; the
                // per-triangle search pulls such bounds in by its own margin.
                match plane.behind_range(
                    query.ends.origin,
                    query.ends.dir,
                    query.ends.light,
                    search,
                    0.0,
                ) {
                    Some(r)
                        if r.0.max(node_query.range.lo) <= r.1.min(node_query.range.hi)
                            && faces_light() =>
                    {
                        search = r;
                    }
                    _ => {
                        stats.triangles_culled_plane += 1;
                        continue;
                    }
                }
            }
            let culling = node_query.with_range(DepthRange {
                lo: search.0.max(node_query.range.lo),
                hi: search.1.min(node_query.range.hi),
            });
            if pruning.cone
                && let Some(cone) = bounds.cone
                && !culling.triangle_may_contain(beams, slot, bounds.sphere, cone)
            {
                stats.triangles_culled_cone += 1;
                continue;
            }
            visit(
                Candidate {
                    triangle,
                    slot,
                    range: DepthRange {
                        lo: search.0,
                        hi: search.1,
                    },
                },
                stats,
            );
        }
    }
}
