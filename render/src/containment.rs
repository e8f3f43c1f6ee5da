//! Which medium holds a point: where the camera and each light are, decided once per scene.
//!
//! A camera or a light inside a dielectric object changes the transport (the camera path starts
//! in the medium; the light reaches the medium without crossing an interface), so it must be
//! decided robustly. The test is the generalized winding number of the object's mesh (Jacobson,
//! Kavan and Sorkine-Hornung 2013): the sum of the signed solid angles of its triangles over 4π,
//! 1 inside a closed, outward-wound mesh and 0 outside, with no ray to graze an edge or a vertex;
//! for an open mesh it degrades gracefully (a point is inside when the number is above ½). The
//! distance to the mesh tells a sphere light that straddles a surface, which no model supports.
//!
//! Two media must be apart or one wholly inside the other: where their surfaces cross, the
//! region both bound has no one medium, so [`surfaces_cross`] lets the scene refuse it.

use glam::DVec3;

use crate::bvh::Bvh;
use crate::mesh::TriangleMesh;
use crate::ray::Ray;

/// A point counts as inside a mesh when its winding number is above this.
pub const INSIDE_WINDING: f64 = 0.5;

/// A point this close to a mesh (relative to the mesh's size) is on its surface.
pub const ON_SURFACE: f64 = 1e-9;

/// A point whose triple product with a triangle's corners is below this fraction of the
/// product of their distances lies in the triangle's plane (rounding is about 1e-16 of it).
const IN_PLANE: f64 = 1e-12;

/// Whether the medium inside `mesh` holds `p`: inside it, or on its surface (a light on the
/// surface lights the medium directly, with no interface to cross).
pub fn holds(mesh: &TriangleMesh, p: DVec3) -> bool {
    let (lo, hi) = mesh.bounds();
    let size = (hi - lo).max_element();
    if !(p.cmpge(lo - size * ON_SURFACE).all() && p.cmple(hi + size * ON_SURFACE).all()) {
        return false;
    }
    let winding = winding_number(mesh, p);
    winding > INSIDE_WINDING
        || (winding > 0.5 * INSIDE_WINDING && distance_to_mesh(mesh, p) <= size * ON_SURFACE)
}

/// Whether the surface of `a` crosses the surface of `b`: an edge of one passes through the
/// inside of a triangle of the other or through its edges. Ends of an edge that lie on the other
/// surface and edges that lie in the other's plane do not count, so surfaces that only touch do
/// not cross. `a_bvh` and `b_bvh` are the meshes' BVHs (each triangle's own index).
pub fn surfaces_cross(a: &TriangleMesh, a_bvh: &Bvh, b: &TriangleMesh, b_bvh: &Bvh) -> bool {
    let ((a_lo, a_hi), (b_lo, b_hi)) = (a.bounds(), b.bounds());
    if a_hi.cmplt(b_lo).any() || b_hi.cmplt(a_lo).any() {
        return false;
    }
    edge_meets(a, b_bvh) || edge_meets(b, a_bvh)
}

/// Surfaces closer than this share of the larger mesh's size touch.
pub const TOUCHING: f64 = 1e-7;

/// Whether the surfaces of `a` and `b` touch over an area (a liquid against a glass's wall, a
/// box resting in another's corner): the centroid of some triangle of one lies on the other,
/// within [`TOUCHING`] of the larger mesh's size along the triangle's normal. Contact at a
/// point or along a line (a sphere resting on a face) does not count.
pub fn surfaces_touch(a: &TriangleMesh, a_bvh: &Bvh, b: &TriangleMesh, b_bvh: &Bvh) -> bool {
    let ((a_lo, a_hi), (b_lo, b_hi)) = (a.bounds(), b.bounds());
    let size = (a_hi - a_lo).max_element().max((b_hi - b_lo).max_element());
    let tolerance = TOUCHING * size;
    if (a_hi + tolerance).cmplt(b_lo).any() || (b_hi + tolerance).cmplt(a_lo).any() {
        return false;
    }
    let centroid_on = |mesh: &TriangleMesh, other: &Bvh| {
        (0..mesh.triangle_count()).any(|t| {
            let Some(normal) = mesh.geometric_normal(t).try_normalize() else {
                return false;
            };
            let [p, q, r] = mesh.corners(t);
            let centroid = (p + q + r) / 3.0;
            other.any_hit(centroid - tolerance * normal, normal, 2.0 * tolerance)
        })
    };
    centroid_on(a, b_bvh) || centroid_on(b, a_bvh)
}

/// The largest distance between a triangle centroid of `a` that lies within [`TOUCHING`] of the
/// surface of `b` (along the triangle's normal) and that surface: 0 where the surfaces coincide
/// exactly, and 0 when they do not touch at all. `b_bvh` is `b`'s BVH.
pub fn contact_gap(a: &TriangleMesh, b: &TriangleMesh, b_bvh: &Bvh) -> f64 {
    let ((a_lo, a_hi), (b_lo, b_hi)) = (a.bounds(), b.bounds());
    let size = (a_hi - a_lo).max_element().max((b_hi - b_lo).max_element());
    let tolerance = TOUCHING * size;
    (0..a.triangle_count())
        .filter_map(|t| {
            let normal = a.geometric_normal(t).try_normalize()?;
            let [p, q, r] = a.corners(t);
            let ray = Ray::new((p + q + r) / 3.0 - tolerance * normal, normal);
            let hit = b_bvh.closest_hit_within(&ray, 2.0 * tolerance)?;
            Some((hit.t - tolerance).abs())
        })
        .fold(0.0, f64::max)
}

/// Inside a mesh's largest triangles, this share of the mesh's size below the surface, lies a
/// point of its inside ([`interior_point`]).
pub const INTERIOR_DEPTH: f64 = 1e-6;

/// A point strictly inside the closed mesh `mesh`: just below the centroid of one of its largest
/// triangles, the first of them where the winding number says inside; `None` for a mesh that
/// has no inside there (open, or thinner than [`INTERIOR_DEPTH`]). Unlike a vertex, it tells
/// which medium holds the object even where its surface lies on another's.
pub fn interior_point(mesh: &TriangleMesh) -> Option<DVec3> {
    let (lo, hi) = mesh.bounds();
    let depth = INTERIOR_DEPTH * (hi - lo).max_element();
    let mut by_area: Vec<(f64, usize)> = (0..mesh.triangle_count())
        .map(|t| (mesh.geometric_normal(t).length(), t))
        .collect();
    by_area.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
    by_area.into_iter().take(8).find_map(|(_, t)| {
        let normal = mesh.geometric_normal(t).try_normalize()?;
        let [p, q, r] = mesh.corners(t);
        let point = (p + q + r) / 3.0 - depth * normal;
        (winding_number(mesh, point) > INSIDE_WINDING).then_some(point)
    })
}

/// An edge's ends are moved this share of its length inward before it is tested, so an end on
/// the other surface does not count whichever way its rounding falls.
pub const EDGE_END_MARGIN: f64 = 1e-7;

/// Whether an edge of `mesh` meets a triangle of `other_bvh` strictly between its ends.
fn edge_meets(mesh: &TriangleMesh, other_bvh: &Bvh) -> bool {
    (0..mesh.triangle_count()).any(|t| {
        let corners = mesh.corners(t);
        (0..3).any(|k| {
            let (p, q) = (corners[k], corners[(k + 1) % 3]);
            let length = p.distance(q);
            let dir = (q - p) / length;
            let margin = EDGE_END_MARGIN * length;
            length > 0.0 && other_bvh.any_hit(p + margin * dir, dir, length - 2.0 * margin)
        })
    })
}

/// The generalized winding number of `mesh` at `p` (1 inside a closed mesh wound
/// counter-clockwise from outside, 0 outside, ½ on the surface).
///
/// A triangle that `p` lies on (in its plane to [`IN_PLANE`] of the corners' distances, and
/// inside it) is where the solid angle jumps by ±2π from one side to the other; there the sign
/// of the rounded triple product would pick a side at random (a light at the centroid of a face
/// came out outside), so such a triangle counts for the mean of both sides, 0.
pub fn winding_number(mesh: &TriangleMesh, p: DVec3) -> f64 {
    let total: f64 = (0..mesh.triangle_count())
        .map(|i| {
            // Van Oosterom and Strackee's solid angle of the triangle seen from p.
            let [a, b, c] = mesh.corners(i).map(|v| v - p);
            let (la, lb, lc) = (a.length(), b.length(), c.length());
            let numerator = a.dot(b.cross(c));
            let denominator = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
            if numerator.abs() <= IN_PLANE * la * lb * lc && denominator < 0.0 {
                return 0.0;
            }
            2.0 * numerator.atan2(denominator)
        })
        .sum();
    total / (4.0 * std::f64::consts::PI)
}

/// The distance from `p` to the nearest point of `mesh` (infinite for an empty mesh).
pub fn distance_to_mesh(mesh: &TriangleMesh, p: DVec3) -> f64 {
    (0..mesh.triangle_count())
        .map(|i| closest_point_on_triangle(p, mesh.corners(i)).distance(p))
        .fold(f64::INFINITY, f64::min)
}

/// The point of the triangle `[a, b, c]` nearest to `p` (by the Voronoi regions of its vertices,
/// edges and face; Ericson, Real-Time Collision Detection, §5.1.5).
fn closest_point_on_triangle(p: DVec3, [a, b, c]: [DVec3; 3]) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denominator = va + vb + vc;
    if denominator.abs() < f64::MIN_POSITIVE {
        // A degenerate triangle: its vertices are its nearest candidates.
        return [a, b, c]
            .into_iter()
            .min_by(|x, y| x.distance_squared(p).total_cmp(&y.distance_squared(p)))
            .unwrap_or(a);
    }
    a + ab * (vb / denominator) + ac * (vc / denominator)
}

#[cfg(test)]
mod tests;
