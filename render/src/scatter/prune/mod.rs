//! Conservative pruning of the refraction-point search: the bounds each object carries
//! ([`bounds`]), the spindle and cone tests ([`cull`]) and the pruned BVH descent ([`descent`]).

pub mod bounds;
pub mod cull;
pub mod descent;
