//! What the pruning tests read, computed once per object instead of once per query: for every
//! triangle its bounding sphere, the cone of its vertex normals and its plane; for every BVH node
//! a sphere holding every vertex below it and a cone holding every vertex normal below it.
//!
//! A node's bounds are as tight as is cheap: the descent's cost is the number of nodes whose
//! tests pass, and both bounds' sizes enter the cone test directly (docs/benchmarks.md, fifth
//! round). The sphere is centred on the node's box, through the farthest vertex below for a node
//! with at most [`EXACT_BELOW`] triangles, else around its children's spheres; the box's own
//! sphere is kept where smaller (the box is padded f32, and its corners lie well off a curved
//! surface). The cone is taken around the normals below directly for such a node, where tighter
//! than the merge of the children's cones (a merge adds half-angles).
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
        let mut spheres: Vec<Option<BoundingSphere>> = vec![None; node_count];
        let mut counts = vec![0usize; node_count];
        let (mut below, mut stack) = (Vec::new(), Vec::new());
        // Children come after their parent in obvhs's layout, so a reverse sweep sees children
        // first; the order is checked, not assumed (a node with an unvisited child keeps its
        // box's sphere and no cone).
        let mut done = vec![false; node_count];
        for node in (0..node_count as u32).rev() {
            let (lo, hi) = bvh.node_bounds(node);
            let boxed = BoundingSphere::of_box(lo, hi);
            let (sphere, cone) = match bvh.children(node) {
                Some([l, r]) if done[l as usize] && done[r as usize] => {
                    let (l, r) = (l as usize, r as usize);
                    counts[node as usize] = counts[l] + counts[r];
                    let merged = match (cones[l], cones[r]) {
                        (Some(x), Some(y)) => merge(x, y),
                        _ => None,
                    };
                    if counts[node as usize] <= EXACT_BELOW {
                        subtree_triangles(bvh, node, &mut below, &mut stack);
                        let direct = leaf_cone(mesh, &below);
                        let cone = match (merged, direct) {
                            (Some(m), Some(d)) if d.half_angle < m.half_angle => Some(d),
                            (None, d) => d,
                            (m, _) => m,
                        };
                        (vertex_sphere(mesh, &below, boxed.center), cone)
                    } else {
                        let around = spheres[l].zip(spheres[r]).map(|(x, y)| {
                            let reach =
                                |s: BoundingSphere| s.center.distance(boxed.center) + s.radius;
                            BoundingSphere {
                                center: boxed.center,
                                radius: reach(x).max(reach(y)) * (1.0 + 1e-12),
                            }
                        });
                        (around, merged)
                    }
                }
                Some(_) => (None, None),
                None => {
                    below.clear();
                    below.extend(bvh.leaf_triangles(node));
                    counts[node as usize] = below.len();
                    (
                        vertex_sphere(mesh, &below, boxed.center),
                        leaf_cone(mesh, &below),
                    )
                }
            };
            spheres[node as usize] = sphere.filter(|s| s.radius < boxed.radius).or(Some(boxed));
            cones[node as usize] = cone;
            done[node as usize] = true;
        }
        let nodes = (0..node_count)
            .map(|node| NodeBounds {
                sphere: spheres[node].unwrap_or_else(|| {
                    let (lo, hi) = bvh.node_bounds(node as u32);
                    BoundingSphere::of_box(lo, hi)
                }),
                cone: cones[node],
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

    /// Every node's bounds, by node index.
    pub fn nodes(&self) -> &[NodeBounds] {
        &self.nodes
    }

    /// Every triangle's bounds, by leaf slot.
    pub fn triangles(&self) -> &[TriangleBounds] {
        &self.triangles
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

/// Nodes with at most this many triangles below take their bounds around the vertices and
/// normals below (walking the subtree: the build costs O(n log `EXACT_BELOW`)); larger nodes bound
/// their children's bounds. The upper nodes pass the tests anyway.
const EXACT_BELOW: usize = 64;

/// The triangles below `node`, into `below` (`stack` is scratch).
fn subtree_triangles(bvh: &Bvh, node: u32, below: &mut Vec<u32>, stack: &mut Vec<u32>) {
    below.clear();
    stack.clear();
    stack.push(node);
    while let Some(n) = stack.pop() {
        match bvh.children(n) {
            Some(c) => stack.extend_from_slice(&c),
            None => below.extend(bvh.leaf_triangles(n)),
        }
    }
}

/// The sphere about `center` through the farthest vertex of the given triangles, inflated by a
/// relative 1e-12 for rounding (as [`BoundingSphere::of_triangle`]): it holds the triangles,
/// which are the convex hulls of their vertices. None for no triangles.
fn vertex_sphere(mesh: &TriangleMesh, triangles: &[u32], center: DVec3) -> Option<BoundingSphere> {
    let farthest2 = triangles
        .iter()
        .flat_map(|&t| mesh.corners(t as usize))
        .map(|p| p.distance_squared(center))
        .reduce(f64::max)?;
    Some(BoundingSphere {
        center,
        radius: farthest2.sqrt() * (1.0 + 1e-12) + 1e-300,
    })
}

/// A cone containing two cones: axis along the sum of the axes, half-angle the farthest reach of
/// either from it.
fn merge(x: NormalCone, y: NormalCone) -> Option<NormalCone> {
    let axis = (x.axis + y.axis).try_normalize()?;
    let half_angle = (angle_between(axis, x.axis) + x.half_angle)
        .max(angle_between(axis, y.axis) + y.half_angle);
    NormalCone::convex(axis, half_angle)
}
