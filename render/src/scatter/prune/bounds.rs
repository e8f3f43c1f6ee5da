//! What the pruning tests read, computed once per object instead of once per query: for every
//! triangle its bounding sphere, the cone of its vertex normals and its plane; for every BVH node
//! the sphere around its box and the cone of every vertex normal below it.
//!
//! The node cones let the half-vector / normal cone test ([H15] §3.2.4) cull whole subtrees, not
//! only single triangles: the test is sound for any set of surface points inside a sphere whose
//! shading normals lie in a convex cone, and a node's cone contains its triangles' cones. Without
//! them, the spindle test alone passes most of a convex object's tree (for η = 1.5 a refracted ray
//! may turn by up to 48°), and every triangle below paid for its own cone.

use glam::DVec3;

use crate::bvh::Bvh;
use crate::mesh::TriangleMesh;
use crate::scatter::prune::cull::{BoundingSphere, NormalCone, angle_between};

/// The plane of a triangle: unit geometric normal `n` (the winding's, outward on a closed mesh)
/// and offset `n·p0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrianglePlane {
    pub normal: DVec3,
    pub offset: f64,
}

impl TrianglePlane {
    /// The plane of the triangle `p`, its normal oriented like the vertex normals `n` (as
    /// `TrianglePatch` orients it). None for a degenerate triangle (no normal).
    pub fn of_triangle(p: [DVec3; 3], n: [DVec3; 3]) -> Option<Self> {
        let winding = (p[1] - p[0]).cross(p[2] - p[0]).try_normalize()?;
        let normal = if (n[0] + n[1] + n[2]).dot(winding) < 0.0 {
            -winding
        } else {
            winding
        };
        Some(TrianglePlane {
            normal,
            offset: normal.dot(p[0]),
        })
    }

    /// Signed distance of `x` from the plane, positive on the normal's side.
    pub fn distance(&self, x: DVec3) -> f64 {
        self.normal.dot(x) - self.offset
    }

    /// Geometric sidedness (physics.md §2.3) for the camera points `origin + t·dir`, `t ∈ range`,
    /// and the light point `light`: None if the light is not strictly in front of the plane or
    /// no camera point of the range is behind it by at least `margin`; else the closed part of
    /// the range where they are.
    pub fn behind_range(
        &self,
        origin: DVec3,
        dir: DVec3,
        light: DVec3,
        range: (f64, f64),
        margin: f64,
    ) -> Option<(f64, f64)> {
        if self.distance(light) <= 0.0 {
            return None;
        }
        let height = self.distance(origin);
        let rate = self.normal.dot(dir);
        let (mut lo, mut hi) = range;
        // height + rate·t ≤ −margin.
        if rate > 0.0 {
            hi = hi.min((-height - margin) / rate);
        } else if rate < 0.0 {
            lo = lo.max((-height - margin) / rate);
        } else if height > -margin {
            return None;
        }
        (lo <= hi).then_some((lo, hi))
    }
}

/// Bounds `(lo, hi)` on `n(a, b)·(x − P(a, b))` over the triangle `P(a, b)` with vertices `p`
/// and linearly interpolated (unnormalised) normal `n(a, b)` from the vertex normals `n`: the
/// sign of how the point `x` faces the shading normal. The function is a product of two linear
/// functions, a quadratic whose Bernstein coefficients on the triangle are `n_i·(x − p_i)` at
/// the vertices and `(n_i·(x − p_j) + n_j·(x − p_i))/2` on the edges; it lies between their
/// smallest and largest.
pub fn facing_bounds(p: [DVec3; 3], n: [DVec3; 3], x: DVec3) -> (f64, f64) {
    let d = [x - p[0], x - p[1], x - p[2]];
    let coefficients = [
        n[0].dot(d[0]),
        n[1].dot(d[1]),
        n[2].dot(d[2]),
        0.5 * (n[0].dot(d[1]) + n[1].dot(d[0])),
        0.5 * (n[1].dot(d[2]) + n[2].dot(d[1])),
        0.5 * (n[2].dot(d[0]) + n[0].dot(d[2])),
    ];
    coefficients
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &c| {
            (lo.min(c), hi.max(c))
        })
}

/// Per-triangle pruning data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriangleBounds {
    pub sphere: BoundingSphere,
    /// None when the vertex normals spread too far for a useful (convex) cone.
    pub cone: Option<NormalCone>,
    /// None for a degenerate triangle.
    pub plane: Option<TrianglePlane>,
}

/// Per-node pruning data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeBounds {
    pub sphere: BoundingSphere,
    /// The cone holding every vertex normal of every triangle below the node; None when they
    /// spread over a hemisphere or more.
    pub cone: Option<NormalCone>,
}

/// The pruning data of one object: per triangle, indexed by the BVH's leaf slot (see
/// [`Bvh::leaf_slots`]: a descent reads them in order, which matters once a mesh outgrows the
/// caches), and per BVH node.
#[derive(Debug, Clone, Default)]
pub struct PruneBounds {
    /// By leaf slot.
    triangles: Vec<TriangleBounds>,
    nodes: Vec<NodeBounds>,
}

impl PruneBounds {
    /// Computes the bounds of every triangle of `mesh` and every node of `bvh` (built over it).
    pub fn build(mesh: &TriangleMesh, bvh: &Bvh) -> Self {
        let triangles: Vec<TriangleBounds> = (0..bvh.triangle_count() as u32)
            .map(|slot| {
                let i = bvh.slot_triangle(slot) as usize;
                let (corners, normals) = (mesh.corners(i), mesh.corner_normals(i));
                TriangleBounds {
                    sphere: BoundingSphere::of_triangle(corners),
                    cone: NormalCone::of_normals(normals),
                    plane: TrianglePlane::of_triangle(corners, normals),
                }
            })
            .collect();
        let node_count = bvh.nodes().len();
        let mut cones: Vec<Option<NormalCone>> = vec![None; node_count];
        // Children come after their parent in obvhs's layout, so a reverse sweep sees children
        // first; the order is checked, not assumed (`merged` of an unvisited child is None).
        let mut done = vec![false; node_count];
        for node in (0..node_count as u32).rev() {
            let cone = match bvh.children(node) {
                Some([l, r]) if done[l as usize] && done[r as usize] => {
                    match (cones[l as usize], cones[r as usize]) {
                        (Some(x), Some(y)) => merge(x, y),
                        _ => None,
                    }
                }
                Some(_) => None,
                None => leaf_cone(mesh, &bvh.leaf_triangles(node).collect::<Vec<_>>()),
            };
            cones[node as usize] = cone;
            done[node as usize] = true;
        }
        let nodes = (0..node_count as u32)
            .map(|node| {
                let (lo, hi) = bvh.node_bounds(node);
                NodeBounds {
                    sphere: BoundingSphere::of_box(lo, hi),
                    cone: cones[node as usize],
                }
            })
            .collect();
        PruneBounds { triangles, nodes }
    }

    /// The bounds of the triangle in BVH leaf slot `slot`.
    pub fn triangle_at_slot(&self, slot: u32) -> &TriangleBounds {
        &self.triangles[slot as usize]
    }

    pub fn node(&self, index: u32) -> &NodeBounds {
        &self.nodes[index as usize]
    }
}

/// The cone of every vertex normal of the given triangles: axis along their normalised sum,
/// half-angle the largest angle from it.
fn leaf_cone(mesh: &TriangleMesh, triangles: &[u32]) -> Option<NormalCone> {
    let normals = || {
        triangles
            .iter()
            .flat_map(|&t| mesh.corner_normals(t as usize))
    };
    let axis = normals().sum::<DVec3>().try_normalize()?;
    let half_angle = normals()
        .map(|n| angle_between(axis, n))
        .fold(0.0_f64, f64::max);
    NormalCone::convex(axis, half_angle)
}

/// A cone containing two cones: axis along the sum of the axes, half-angle the farthest reach of
/// either from it.
fn merge(x: NormalCone, y: NormalCone) -> Option<NormalCone> {
    let axis = (x.axis + y.axis).try_normalize()?;
    let half_angle = (angle_between(axis, x.axis) + x.half_angle)
        .max(angle_between(axis, y.axis) + y.half_angle);
    NormalCone::convex(axis, half_angle)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural::bumpy_sphere;

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

    #[test]
    fn triangle_plane_is_the_triangle_plane() {
        let p = [
            DVec3::new(1.0, 0.0, 2.0),
            DVec3::new(0.0, 1.0, 2.0),
            DVec3::new(0.0, 0.0, 2.0),
        ];
        let up = [DVec3::Z; 3];
        let plane = TrianglePlane::of_triangle(p, up).unwrap();
        assert_eq!(plane.normal, DVec3::new(0.0, 0.0, 1.0));
        assert!((plane.distance(DVec3::new(5.0, -3.0, 2.5)) - 0.5).abs() < 1e-15);
        // Oriented by the vertex normals, whatever the winding.
        let flipped = TrianglePlane::of_triangle([p[1], p[0], p[2]], up).unwrap();
        assert_eq!(flipped.normal, DVec3::new(0.0, 0.0, 1.0));
        let down = TrianglePlane::of_triangle(p, [-DVec3::Z; 3]).unwrap();
        assert_eq!(down.normal, DVec3::new(0.0, 0.0, -1.0));
        assert!(TrianglePlane::of_triangle([p[0], p[0], p[1]], up).is_none());
    }

    /// The camera points behind the plane z = 0 by a margin, for a segment running either way
    /// through it, along it, and with the light behind: hand-solved ranges.
    #[test]
    fn behind_range_keeps_the_camera_points_behind_the_plane() {
        let plane =
            TrianglePlane::of_triangle([DVec3::ZERO, DVec3::X, DVec3::Y], [DVec3::Z; 3]).unwrap();
        let light = DVec3::new(0.0, 0.0, 5.0);
        let m = 1e-3;
        // From z = 1 going down: behind (z <= -m) from t = 1 + m on.
        let down = plane.behind_range(DVec3::Z, -DVec3::Z, light, (0.0, 3.0), m);
        assert_eq!(down, Some((1.0 + m, 3.0)));
        // From z = -1 going up: behind until t = 1 - m.
        let up = plane.behind_range(-DVec3::Z, DVec3::Z, light, (0.0, 3.0), m);
        assert_eq!(up, Some((0.0, 1.0 - m)));
        // Along the plane: all behind, or none.
        let below = plane.behind_range(-DVec3::Z, DVec3::X, light, (0.0, 3.0), m);
        assert_eq!(below, Some((0.0, 3.0)));
        assert_eq!(
            plane.behind_range(DVec3::ZERO, DVec3::X, light, (0.0, 3.0), m),
            None
        );
        // The light behind the plane: nothing.
        assert_eq!(
            plane.behind_range(DVec3::Z, -DVec3::Z, -light, (0.0, 3.0), m),
            None
        );
        // Entirely in front.
        assert_eq!(
            plane.behind_range(DVec3::Z, -DVec3::Z, light, (0.0, 0.5), m),
            None
        );
    }

    /// The facing bounds hold `n(a, b)·(x − P(a, b))` at 20,000 random points of random curved
    /// triangles, and are attained at the vertices when the function is linear (flat normals).
    #[test]
    fn facing_bounds_bound_the_facing_function() {
        let mut state = 5u64;
        let mut next = || {
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut vec = |scale: f64| DVec3::new(next(), next(), next()) * scale;
        for _ in 0..200 {
            let p = [vec(1.0), vec(1.0), vec(1.0)];
            let n = [
                (DVec3::Z + vec(0.8)).normalize(),
                (DVec3::Z + vec(0.8)).normalize(),
                (DVec3::Z + vec(0.8)).normalize(),
            ];
            let x = vec(3.0);
            let (lo, hi) = facing_bounds(p, n, x);
            for i in 0..100 {
                let (mut a, mut b) = (f64::from(i % 10) / 9.0, f64::from(i / 10) / 9.0);
                if a + b > 1.0 {
                    (a, b) = (1.0 - a, 1.0 - b);
                }
                let point = p[0] + a * (p[1] - p[0]) + b * (p[2] - p[0]);
                let normal = n[0] + a * (n[1] - n[0]) + b * (n[2] - n[0]);
                let q = normal.dot(x - point);
                assert!(lo - 1e-12 <= q && q <= hi + 1e-12, "{lo} <= {q} <= {hi}");
            }
        }
        let p = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let (lo, hi) = facing_bounds(p, [DVec3::Z; 3], DVec3::new(0.2, 0.3, 1.5));
        assert_eq!((lo, hi), (1.5, 1.5));
    }
}
