//! Bounding spheres: the shape every pruning bound is taken around (a triangle, a BVH node's
//! box, a whole object for light sampling).

use glam::DVec3;

/// A sphere that contains some geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundingSphere {
    pub center: DVec3,
    pub radius: f64,
}

impl BoundingSphere {
    /// The sphere around an axis-aligned box, inflated to contain every f64 point that rounds into
    /// an f32 box (obvhs keeps its boxes in f32).
    pub fn of_box(min: DVec3, max: DVec3) -> Self {
        let center = 0.5 * (min + max);
        let half_diagonal = 0.5 * (max - min).length();
        let rounding = 4.0 * f64::from(f32::EPSILON) * (center.abs().max_element() + half_diagonal);
        BoundingSphere {
            center,
            radius: half_diagonal + rounding,
        }
    }

    /// A sphere around a triangle: its centroid and the farthest vertex (not the smallest sphere,
    /// but close and cheap), inflated by a relative 1e-12 for rounding.
    pub fn of_triangle(p: [DVec3; 3]) -> Self {
        let center = (p[0] + p[1] + p[2]) / 3.0;
        let radius = p.iter().map(|q| q.distance(center)).fold(0.0_f64, f64::max);
        BoundingSphere {
            center,
            radius: radius * (1.0 + 1e-12) + 1e-300,
        }
    }
}
