//! Camera segments inside a medium: what the single-scattering integrator integrates along.
//!
//! Every straight piece of a camera path that runs inside a dielectric object's medium becomes a
//! [`Segment`] and is handed to `scatter::single_scatter`. The transport code multiplies the
//! returned radiance by the segment's throughput and adds it to the `single_scatter` layer.

use glam::DVec3;

use crate::Rgb;

/// A straight piece of a camera path inside a medium: points `origin + t·dir`, `0 ≤ t ≤ length`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// The segment's start (V_min): where the camera path entered the medium or was internally
    /// reflected, just off the boundary.
    pub origin: DVec3,
    /// Unit direction, away from the camera (the path's tracing direction).
    pub dir: DVec3,
    /// Length in scene units, to the next boundary hit (or to where an escaping ray leaves the
    /// object's bounding box, for an open mesh).
    pub length: f64,
    /// Index into `Scene::objects()` of the object whose medium this is.
    pub object: usize,
    /// Camera-path throughput at `origin`: the product of every Fresnel factor, the radiance-mode
    /// `1/η²` of each entry (and `η²` of each exit), and the Beer–Lambert attenuation of the
    /// earlier segments. Radiance at `origin` toward the camera is multiplied by this.
    pub throughput: Rgb,
}
