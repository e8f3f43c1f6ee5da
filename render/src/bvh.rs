//! The bounding volume hierarchy: closest-hit and any-hit queries over triangles, and the node
//! hierarchy itself for integrators that run their own descent.
//!
//! The tree is an obvhs BVH2 (obvhs is f32-only); every triangle test is done in f64 on our own
//! copy of the triangles, so hit distances and barycentrics have full f64 precision and the
//! triangle test includes its edges (no ray slips between two triangles that share an edge as
//! long as the arithmetic agrees on which side it passes). The f32 boxes are padded outward so
//! the f32 traversal never culls a box an f64 triangle pokes out of.

use std::time::Duration;

use glam::{DVec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::builder::build_bvh2;
use obvhs::ray::{Ray as F32Ray, RayHit};

pub use obvhs::bvh2::node::Bvh2Node;

use crate::ray::Ray;

/// A closest hit: `t` along the ray, the triangle's index (as given to [`Bvh::build`]) and its
/// barycentrics, `a` = weight of P1 and `b` = weight of P2, so the point is `P0 + a·E1 + b·E2`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    pub t: f64,
    pub triangle: u32,
    pub a: f64,
    pub b: f64,
}

/// One triangle in leaf (slot) order, ready for the f64 test.
#[derive(Debug, Clone, Copy)]
struct SlotTriangle {
    p: [DVec3; 3],
    index: u32,
}

/// A BVH over triangles. Node `0` is the root; an inner node's children are the nodes
/// `first_index` and `first_index + 1`; a leaf (`prim_count > 0`) holds the slots
/// `first_index .. first_index + prim_count`, mapped to triangle indices by
/// [`Bvh::slot_triangle`] (or all at once by [`Bvh::leaf_triangles`]). Each triangle is in
/// exactly one leaf (no spatial splits).
#[derive(Clone)]
pub struct Bvh {
    tree: Bvh2,
    slots: Vec<SlotTriangle>,
}

impl std::fmt::Debug for Bvh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bvh")
            .field("triangles", &self.slots.len())
            .field("nodes", &self.tree.nodes.len())
            .finish()
    }
}

impl Bvh {
    /// Builds the tree over `triangles` (each `[P0, P1, P2]`); hits report indices into this slice.
    pub fn build(triangles: &[[DVec3; 3]]) -> Bvh {
        if triangles.is_empty() {
            return Bvh {
                tree: Bvh2::default(),
                slots: Vec::new(),
            };
        }
        let boxes: Vec<Aabb> = triangles.iter().map(padded_box).collect();
        let tree = build_bvh2(
            &boxes,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let slots = tree
            .primitive_indices
            .iter()
            .map(|&i| SlotTriangle {
                p: triangles[i as usize],
                index: i,
            })
            .collect();
        Bvh { tree, slots }
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.slots.len()
    }

    /// The nearest triangle hit by `ray` at `t > 0`, if any.
    pub fn closest_hit(&self, ray: &Ray) -> Option<Hit> {
        self.closest_hit_within(ray, f64::INFINITY)
    }

    /// The nearest triangle hit by `ray` at `0 < t < t_max`, if any.
    pub fn closest_hit_within(&self, ray: &Ray, t_max: f64) -> Option<Hit> {
        if self.slots.is_empty() {
            return None;
        }
        let mut best: Option<Hit> = None;
        let mut best_t = t_max;
        let sheared = ShearedRay::new(ray);
        let query = F32Ray::new(
            ray.origin.as_vec3a(),
            ray.dir.as_vec3a(),
            0.0,
            f32::INFINITY,
        );
        let mut f32_hit = RayHit::none();
        self.tree.ray_traverse(query, &mut f32_hit, |_, slot| {
            let tri = &self.slots[slot];
            match sheared.intersect(tri) {
                Some((t, a, b)) if t < best_t => {
                    best_t = t;
                    best = Some(Hit {
                        t,
                        triangle: tri.index,
                        a,
                        b,
                    });
                    conservative_f32(t)
                }
                _ => f32::INFINITY,
            }
        });
        best
    }

    /// Whether any triangle is hit at `0 < t < t_max` (stops at the first one found).
    pub fn any_hit(&self, origin: DVec3, dir: DVec3, t_max: f64) -> bool {
        if self.slots.is_empty() {
            return false;
        }
        let sheared = ShearedRay::new(&Ray::new(origin, dir));
        let query = F32Ray::new(origin.as_vec3a(), dir.as_vec3a(), 0.0, f32::INFINITY);
        let missed = self.tree.ray_traverse_miss(query, |_, slot| {
            match sheared.intersect(&self.slots[slot]) {
                Some((t, _, _)) if t < t_max => 0.0,
                _ => f32::INFINITY,
            }
        });
        !missed
    }

    /// Brute force: the nearest hit over all triangles, the yardstick of the tests.
    #[cfg(test)]
    pub fn closest_hit_brute_force(&self, ray: &Ray) -> Option<Hit> {
        let sheared = ShearedRay::new(ray);
        self.slots
            .iter()
            .filter_map(|tri| {
                sheared.intersect(tri).map(|(t, a, b)| Hit {
                    t,
                    triangle: tri.index,
                    a,
                    b,
                })
            })
            .min_by(|x, y| x.t.total_cmp(&y.t))
    }

    /// The tree's nodes; `nodes()[0]` is the root (empty for an empty BVH).
    pub fn nodes(&self) -> &[Bvh2Node] {
        &self.tree.nodes
    }

    /// The two children of inner node `node`, or `None` for a leaf.
    pub fn children(&self, node: u32) -> Option<[u32; 2]> {
        let n = &self.tree.nodes[node as usize];
        (!n.is_leaf()).then_some([n.first_index, n.first_index + 1])
    }

    /// The f64 bounds `(min, max)` of node `node` (its f32 box, padded, widened to f64).
    pub fn node_bounds(&self, node: u32) -> (DVec3, DVec3) {
        let b = &self.tree.nodes[node as usize].aabb;
        (b.min.as_dvec3(), b.max.as_dvec3())
    }

    /// The triangle index of a leaf slot.
    pub fn slot_triangle(&self, slot: u32) -> u32 {
        self.slots[slot as usize].index
    }

    /// The triangle indices held by leaf `node` (empty for an inner node).
    pub fn leaf_triangles(&self, node: u32) -> impl Iterator<Item = u32> + '_ {
        self.leaf_slots(node).map(|(_, triangle)| triangle)
    }

    /// The `(slot, triangle index)` pairs of leaf `node` (empty for an inner node). Slots are
    /// consecutive within a leaf and leaves of a subtree are near each other, so per-triangle
    /// data stored by slot is read in order by a descent.
    pub fn leaf_slots(&self, node: u32) -> impl Iterator<Item = (u32, u32)> + '_ {
        let n = &self.tree.nodes[node as usize];
        let range = n.first_index..n.first_index + n.prim_count;
        range.map(|slot| (slot, self.slots[slot as usize].index))
    }
}

/// An f32 box containing the f64 triangle, padded by a relative 1e-6 so that rounding to f32
/// never cuts a corner off.
fn padded_box(tri: &[DVec3; 3]) -> Aabb {
    let lo = tri[0].min(tri[1]).min(tri[2]);
    let hi = tri[0].max(tri[1]).max(tri[2]);
    let pad = (hi - lo)
        .max_element()
        .max(lo.abs().max(hi.abs()).max_element())
        * 1e-6;
    Aabb::new(
        Vec3A::from((lo - DVec3::splat(pad)).as_vec3()),
        Vec3A::from((hi + DVec3::splat(pad)).as_vec3()),
    )
}

/// An f32 distance no smaller than `t`, so the traversal's pruning (boxes farther than the
/// current hit) never skips a box holding a nearer f64 hit.
fn conservative_f32(t: f64) -> f32 {
    let t32 = t as f32;
    if (t32 as f64) < t { t32.next_up() } else { t32 }
}

/// A ray prepared for the watertight ray–triangle test of Woop, Benthin and Wald (JCGT 2013):
/// the ray is the z axis of a sheared frame, so each edge function depends only on its two
/// vertices, and two triangles sharing an edge or a vertex agree exactly on which side the ray
/// passes. No ray slips between them.
#[derive(Debug, Clone, Copy)]
struct ShearedRay {
    origin: DVec3,
    axes: [usize; 3],
    shear: DVec3,
}

impl ShearedRay {
    fn new(ray: &Ray) -> ShearedRay {
        // The dominant axis becomes z; swap x and y if that flips the winding.
        let d = ray.dir;
        let kz = d.abs().max_position();
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        ShearedRay {
            origin: ray.origin,
            axes: [kx, ky, kz],
            shear: DVec3::new(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]),
        }
    }

    /// `(t, a, b)` for a hit at `t > 0`, edges and vertices included; `a`, `b` are the weights
    /// of P1 and P2.
    #[inline]
    fn intersect(&self, tri: &SlotTriangle) -> Option<(f64, f64, f64)> {
        let [kx, ky, kz] = self.axes;
        let s = self.shear;
        // Vertices relative to the origin, sheared so the ray runs along +z.
        let [a, b, c] = tri.p.map(|p| p - self.origin);
        let (ax, ay) = (a[kx] - s.x * a[kz], a[ky] - s.y * a[kz]);
        let (bx, by) = (b[kx] - s.x * b[kz], b[ky] - s.y * b[kz]);
        let (cx, cy) = (c[kx] - s.x * c[kz], c[ky] - s.y * c[kz]);
        // Edge functions (scaled barycentrics of P0, P1, P2).
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        // Distance along the ray, from the sheared z coordinates.
        let t = (u * a[kz] + v * b[kz] + w * c[kz]) * s.z / det;
        (t > 0.0).then_some((t, v / det, w / det))
    }
}

#[cfg(test)]
mod tests;
