//! The colour type of the renderer: radiance and throughput carried per RGB channel.

/// Linear RGB radiance (or throughput), one f64 per channel.
pub type Rgb = glam::DVec3;
