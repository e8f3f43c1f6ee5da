//! The pruning wing: conservative culling of the refraction-point search ([H15] §3.2.4, App. B.2;
//! physics.md §2.4).
//!
//! For one camera segment `V(t) = origin + t·dir`, `t` in a range, and one light point `L` (a
//! [`SegmentQuery`]), most of an object's triangles cannot hold a refraction point `P` of a path
//! `V → P → L`. Two tests discard them without solving anything: the spindle test (`spindle`) on a
//! bounding sphere and the cone test (`cone`) on a sphere and a normal cone, which also trims the
//! range. [`bounds`] holds what they read per triangle and per BVH node, computed once per object;
//! [`descent`] walks an object's BVH with them and yields the candidate triangles.
//!
//! Every test only ever discards what cannot hold a solution: every bound is an upper bound, and
//! a small angular margin covers rounding (node boxes are f32). `tests` prove it on paths built
//! to be valid, including grazing ones.

mod beam;
pub mod beam_table;
pub mod bounds;
mod cone;
pub mod descent;
mod query;
mod spindle;

#[cfg(test)]
mod tests;

pub use query::SegmentQuery;
