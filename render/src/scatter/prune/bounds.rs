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
use crate::scatter::geometry::{BoundingSphere, NormalCone, TrianglePlane, angle_between};

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
