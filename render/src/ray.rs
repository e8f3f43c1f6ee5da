//! Rays, and the one place where a ray leaving a surface gets its origin offset.
//!
//! Refractive boundaries are where scattered epsilons leak light, so every ray that starts on a
//! surface is made by [`Ray::leaving`]: it pushes the origin off the triangle's plane, along the
//! geometric normal, to the side the ray travels toward, by an amount relative to the scene's
//! size (so scenes scaled by 1e-4 or 1e4 behave the same).

use glam::DVec3;

/// Relative size of the surface offset: the origin moves `OFFSET_SCALE × scene scale` off the
/// plane of the triangle it leaves. f64 intersection errors are ~1e-15 of the scene scale, so
/// this leaves seven orders of magnitude of margin and is far below any feature a scene models.
pub const OFFSET_SCALE: f64 = 1e-8;

/// A ray: `origin + t · dir`, `t > 0`. `dir` is a unit vector wherever the renderer makes one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    pub origin: DVec3,
    pub dir: DVec3,
}

impl Ray {
    pub fn new(origin: DVec3, dir: DVec3) -> Ray {
        Ray { origin, dir }
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + t * self.dir
    }

    /// A ray leaving the surface point `p` of a triangle with geometric normal `geometric_normal`
    /// (either orientation) in direction `dir`. The origin is pushed off the triangle's plane to
    /// the side `dir` points to, by `OFFSET_SCALE × scene_scale`, so the ray cannot hit the
    /// triangle it starts on (nor its neighbours, at the start point) from either side.
    pub fn leaving(p: DVec3, geometric_normal: DVec3, dir: DVec3, scene_scale: f64) -> Ray {
        let n = geometric_normal.normalize_or_zero();
        let side = if dir.dot(n) >= 0.0 { 1.0 } else { -1.0 };
        Ray {
            origin: p + n * (side * OFFSET_SCALE * scene_scale),
            dir,
        }
    }
}

#[cfg(test)]
mod tests;
