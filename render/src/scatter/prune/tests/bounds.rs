//! The per-object bounds contain what they bound.

use glam::DVec3;

use crate::bvh::Bvh;
use crate::procedural::bumpy_sphere;
use crate::scatter::geometry::angle_between;
use crate::scatter::prune::bounds::PruneBounds;

/// Every node's cone holds every vertex normal below it (to rounding), and every node's sphere
/// every vertex: checked by walking each node's subtree.
#[test]
fn node_bounds_contain_everything_below() {
    let mesh = bumpy_sphere(1.0, 3, 0.15, 2.0, 7);
    let triangles: Vec<[DVec3; 3]> = (0..mesh.triangle_count())
        .map(|i| mesh.corners(i))
        .collect();
    let bvh = Bvh::build(&triangles);
    let bounds = PruneBounds::build(&mesh, &bvh);
    let mut with_cone = 0;
    for node in 0..bvh.nodes().len() as u32 {
        let b = bounds.node(node);
        let mut below = Vec::new();
        let mut stack = vec![node];
        while let Some(n) = stack.pop() {
            match bvh.children(n) {
                Some(c) => stack.extend_from_slice(&c),
                None => below.extend(bvh.leaf_triangles(n)),
            }
        }
        for &t in &below {
            for p in mesh.corners(t as usize) {
                assert!(p.distance(b.sphere.center) <= b.sphere.radius);
            }
            if let Some(cone) = b.cone {
                for n in mesh.corner_normals(t as usize) {
                    assert!(angle_between(cone.axis, n) <= cone.half_angle + 1e-12);
                }
            }
        }
        with_cone += usize::from(b.cone.is_some());
    }
    // The root of a sphere has no convex cone; most small nodes do.
    assert!(bounds.node(0).cone.is_none());
    assert!(with_cone > bvh.nodes().len() / 2, "{with_cone}");
}
