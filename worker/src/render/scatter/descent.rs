//! The hierarchical descent of an object's BVH that yields the triangles worth solving on
//! ([H15] §3.2.4): start at the root, keep a node only if its bounding sphere passes the spindle
//! test, and put each triangle of a surviving leaf through the half-vector / normal cone test,
//! which also trims its `t`-range.
//!
//! Both tests are conservative (see `prune`), so the descent never loses a solution; each can be
//! switched off (`integrator.single_scatter.pruning`) to measure what it saves. The counters go to
//! `RenderStats`: nodes visited, nodes culled by the spindle test, triangles tested, triangles
//! culled by the cone test.

use spindle_common::scene::Pruning;
use spindle_common::stats::RenderStats;

use super::prune::{BoundingSphere, NormalCone, SegmentQuery};
use crate::render::scene::Object;

/// A triangle of the object that may hold refraction points, and the `t`-range where it may.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Index of the triangle in the object's mesh.
    pub triangle: u32,
    pub t_lo: f64,
    pub t_hi: f64,
}

/// Reusable traversal stack (one per `single_scatter` call, so the hot loop does not allocate).
#[derive(Debug, Default)]
pub struct DescentStack(Vec<u32>);

/// Calls `visit` for every candidate triangle of `object` for the query (segment range and light
/// point), with the pruning stages `pruning` enabled.
pub fn for_each_candidate(
    object: &Object,
    query: &SegmentQuery,
    pruning: &Pruning,
    stack: &mut DescentStack,
    stats: &mut RenderStats,
    mut visit: impl FnMut(Candidate, &mut RenderStats),
) {
    if object.bvh.nodes().is_empty() {
        return;
    }
    let stack = &mut stack.0;
    stack.clear();
    stack.push(0);
    while let Some(node) = stack.pop() {
        stats.bvh_nodes_visited += 1;
        if pruning.spindle {
            let (lo, hi) = object.bvh.node_bounds(node);
            if !query.spindle_may_contain(BoundingSphere::of_box(lo, hi)) {
                stats.nodes_culled_spindle += 1;
                continue;
            }
        }
        if let Some(children) = object.bvh.children(node) {
            stack.extend_from_slice(&children);
            continue;
        }
        for triangle in object.bvh.leaf_triangles(node) {
            stats.triangles_tested += 1;
            let mut candidate = Candidate {
                triangle,
                t_lo: query.t_lo,
                t_hi: query.t_hi,
            };
            if pruning.cone {
                let index = triangle as usize;
                let cone = NormalCone::of_normals(object.mesh.corner_normals(index));
                if let Some(cone) = cone {
                    let sphere = BoundingSphere::of_triangle(object.mesh.corners(index));
                    match query.cone_trim(sphere, cone) {
                        Some((t_lo, t_hi)) => (candidate.t_lo, candidate.t_hi) = (t_lo, t_hi),
                        None => {
                            stats.triangles_culled_cone += 1;
                            continue;
                        }
                    }
                }
            }
            visit(candidate, stats);
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::render::bvh::Bvh;
    use crate::render::medium::{Medium, PhaseFunction};
    use crate::render::procedural::bumpy_sphere;
    use crate::render::scene::{Dielectric, Material};

    fn object() -> Object {
        let mesh = bumpy_sphere(1.0, 3, 0.15, 2.0, 7);
        let triangles: Vec<[DVec3; 3]> = (0..mesh.triangle_count())
            .map(|i| mesh.corners(i))
            .collect();
        let report = mesh.report();
        Object {
            name: "objects[0]".into(),
            bvh: Bvh::build(&triangles),
            mesh,
            material: Material::Dielectric(Dielectric {
                eta: 1.5,
                medium: Medium {
                    sigma_t: DVec3::ONE,
                    sigma_s: DVec3::ONE,
                    phase: PhaseFunction::Isotropic,
                },
            }),
            report,
        }
    }

    /// splitmix64 numbers in [0, 1) for test configurations.
    fn uniform(state: &mut u64) -> f64 {
        *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = *state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Through the whole descent (spindle on BVH nodes, cone on triangles): for valid refraction
    /// paths built forward on random triangles of a bumpy sphere (Snell's law at the interpolated
    /// normal, sidedness checked), the path's triangle is always a candidate and its trimmed range
    /// holds the path's t. The counters add up, and pruning culls most of the tree.
    #[test]
    fn descent_keeps_every_triangle_with_a_valid_path() {
        let object = object();
        let mesh = &object.mesh;
        let mut state = 11;
        let mut stack = DescentStack::default();
        let mut stats = RenderStats::default();
        let mut checked = 0;
        for _ in 0..3000 {
            let triangle = (uniform(&mut state) * mesh.triangle_count() as f64) as usize;
            let (mut a, mut b) = (uniform(&mut state), uniform(&mut state));
            if a + b > 1.0 {
                (a, b) = (1.0 - a, 1.0 - b);
            }
            let p = mesh.point(triangle, a, b);
            let normal = mesh.shading_normal(triangle, a, b);
            let eta = 1.5;
            let cos_l = uniform(&mut state).max(1e-6);
            let sin_v = (1.0 - cos_l * cos_l).sqrt() / eta;
            let cos_v = (1.0 - sin_v * sin_v).sqrt();
            let phi = std::f64::consts::TAU * uniform(&mut state);
            let (s, t) = normal.any_orthonormal_pair();
            let d = cos_v * normal + sin_v * (phi.cos() * s + phi.sin() * t);
            let omega_l = (eta * d - (eta * cos_v - cos_l) * normal).normalize();
            let v = p - 0.5 * uniform(&mut state) * d;
            let light = p + (0.1 + 10.0 * uniform(&mut state)) * omega_l;
            let ng = mesh.geometric_normal(triangle).normalize();
            if (light - p).dot(ng) <= 0.0 || (v - p).dot(ng) >= 0.0 {
                continue;
            }
            let dir =
                DVec3::new(uniform(&mut state) - 0.5, uniform(&mut state) - 0.5, 0.3).normalize();
            let t_v = uniform(&mut state);
            let query = SegmentQuery {
                origin: v - t_v * dir,
                dir,
                t_lo: 0.0,
                t_hi: 1.0 + uniform(&mut state),
                light,
                eta,
            };
            let mut found = false;
            let before = stats;
            for_each_candidate(
                &object,
                &query,
                &Pruning::default(),
                &mut stack,
                &mut stats,
                |c, _| {
                    if c.triangle as usize == triangle {
                        assert!(c.t_lo <= t_v && t_v <= c.t_hi, "{c:?} misses t = {t_v}");
                        found = true;
                    }
                },
            );
            assert!(
                found,
                "triangle {triangle} culled for a valid path: {query:?}"
            );
            assert!(stats.bvh_nodes_visited > before.bvh_nodes_visited);
            checked += 1;
        }
        let nodes = object.bvh.nodes().len() as u64;
        println!(
            "{checked} paths; per query: {:.1} of {nodes} nodes visited, {:.1} culled by the spindle, \
             {:.1} triangles tested, {:.1} culled by the cone",
            stats.bvh_nodes_visited as f64 / checked as f64,
            stats.nodes_culled_spindle as f64 / checked as f64,
            stats.triangles_tested as f64 / checked as f64,
            stats.triangles_culled_cone as f64 / checked as f64,
        );
        assert!(checked > 1000);
        assert!(stats.nodes_culled_spindle > 0 && stats.triangles_culled_cone > 0);
        assert!(stats.triangles_tested < checked * mesh.triangle_count() as u64);
    }

    /// With both stages off, the descent yields every triangle once, with the full range.
    #[test]
    fn descent_without_pruning_yields_every_triangle() {
        let object = object();
        let query = SegmentQuery {
            origin: DVec3::new(0.0, 0.0, -0.5),
            dir: DVec3::Z,
            t_lo: 0.0,
            t_hi: 1.0,
            light: DVec3::new(0.0, 0.0, 5.0),
            eta: 1.5,
        };
        let off = Pruning {
            spindle: false,
            cone: false,
        };
        let mut seen = vec![0; object.mesh.triangle_count()];
        let mut stats = RenderStats::default();
        for_each_candidate(
            &object,
            &query,
            &off,
            &mut DescentStack::default(),
            &mut stats,
            |c, _| {
                assert_eq!((c.t_lo, c.t_hi), (0.0, 1.0));
                seen[c.triangle as usize] += 1;
            },
        );
        assert!(seen.iter().all(|&n| n == 1));
        assert_eq!(stats.triangles_tested, object.mesh.triangle_count() as u64);
    }
}
