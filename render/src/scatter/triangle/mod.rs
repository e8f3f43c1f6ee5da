//! The per-triangle mathematics of single scattering, in f64 and independent of the scene: a
//! triangle with interpolated normals ([`patch`]), the coordinates `(t, a, b)` of the solution
//! curve ([`curve`]), the fixed ends of a path and the depth range ([`ends`]), the damped Newton
//! solver for refraction points ([`solve`]), the distance factor D ([`distance`]), the
//! contribution of one path ([`contribution`]), the crossings of the solution curve with the
//! triangle's edges ([`edge`]) and the per-triangle monotone branches, folds included
//! ([`branches`]).

pub mod branches;
pub mod contribution;
pub mod curve;
pub mod depth_density;
pub mod distance;
pub mod edge;
pub mod ends;
pub mod patch;
pub mod small_list;
pub mod solve;

#[cfg(test)]
pub(crate) mod ground_truth;
