//! The provenance of a render from a built scene: the one function `spindle render --workers 0`
//! and the farm's workers both call, so a local EXR and a farm EXR carry the same header.

use spindle_common::provenance::Provenance;

use crate::Scene;
use crate::scatter::describe_plan;

/// This renderer's package and version, as recorded in [`Provenance::renderer`].
pub const RENDERER: &str = concat!(env!("CARGO_PKG_NAME"), " ", env!("CARGO_PKG_VERSION"));

/// What `scene` is, as recorded with an image made from it: its size, warnings and
/// single-scattering plan ([`describe_plan`]).
pub fn provenance(scene: &Scene) -> Provenance {
    let summary = scene.summary();
    Provenance::new(
        RENDERER,
        summary.objects as u64,
        summary.triangles as u64,
        summary.lights as u64,
        &summary.warnings,
        &describe_plan(scene),
    )
}
