//! The geometric bounds of a triangle and of groups of triangles: bounding spheres, cones of
//! shading normals, the triangle's plane and how a point faces its shading normals. Both the
//! per-triangle mathematics ([`triangle`](super::triangle)) and the pruning
//! ([`prune`](super::prune)) build on them.

mod cone;
mod plane;
mod sphere;

#[cfg(test)]
mod tests;

pub use cone::{NormalCone, angle_between};
pub use plane::{TrianglePlane, facing_bounds};
pub use sphere::BoundingSphere;

/// Angular slack added to every pruning comparison, radians. Covers rounding in the bounds (node
/// boxes are stored in f32) and solutions accepted a hair outside their triangle by the solver.
pub(crate) const ANGLE_MARGIN: f64 = 1e-6;
