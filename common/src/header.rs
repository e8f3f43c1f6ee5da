//! The header of a rendered image's EXR file: every attribute spindle writes about a render,
//! named in one function, [`describe`], which `spindle render --workers 0`, the local farm and
//! the coordinator's assembly all call, so their headers cannot drift apart.
//!
//! Text attributes (`spindle.*`) say what the pixels are: a farm's and an in-process render of
//! the same scene carry the same ones (but `spindle.scene` and `spindle.workers`, which only the
//! command knows). The standard ones a compositor reads are typed: `software`,
//! `worldToCamera`/`worldToNDC` ([`crate::camera_matrices`]) and `renderTime`, the one value
//! that differs from run to run.

use crate::camera_matrices::{CameraMatrices, to_m44f};
use crate::image::{Image, Precision};
use crate::provenance::Provenance;
use crate::scene::SceneDescription;
use crate::stats::RenderStats;
use crate::tile::TileRect;

/// `software`: this program and its version.
pub const SOFTWARE: &str = concat!("spindle ", env!("CARGO_PKG_VERSION"));

/// What the header says about a render.
#[derive(Debug, Clone, Copy)]
pub struct RenderFacts<'a> {
    /// The scene as rendered, `film.spp` the samples per pixel reached (a budgeted render's
    /// last pass's cap).
    pub scene: &'a SceneDescription,
    /// The window of the film rendered (the film, or a crop).
    pub window: TileRect,
    /// The summed render statistics.
    pub stats: &'a RenderStats,
    /// What the scene built to, where known (a farm job's first tile brings it).
    pub provenance: Option<&'a Provenance>,
    /// A budgeted render: the progressive passes done and `film.time_budget_s`.
    pub passes: Option<(u32, f64)>,
    /// The render's wall-clock seconds.
    pub render_seconds: Option<f64>,
    /// The scene file's path as the user gave it (the coordinator never sees it).
    pub scene_file: Option<&'a str>,
    /// The local farm's worker count.
    pub workers: Option<usize>,
}

/// Writes the header attributes of `facts` into `image` (replacing any of the same names):
/// `spindle.spp`, `spindle.seed`, `spindle.region` (`x,y,width,height`), `spindle.integrator`
/// (JSON), `spindle.stats.<counter>`, the provenance's ([`Provenance::header_attributes`]),
/// `spindle.passes` and `spindle.time_budget_s`, `spindle.scene`, `spindle.workers`; the
/// standard `software`, `worldToCamera`, `worldToNDC` and `renderTime`; and the file's
/// precision, `film.half`.
pub fn describe(image: &mut Image, facts: &RenderFacts) {
    let film = &facts.scene.film;
    let w = facts.window;
    let a = &mut image.attributes;
    let mut set = |name: &str, value: String| {
        a.insert(name.to_string(), value);
    };
    set("spindle.spp", film.spp.to_string());
    set("spindle.seed", film.seed.to_string());
    set(
        "spindle.region",
        format!("{},{},{},{}", w.x, w.y, w.width, w.height),
    );
    // Integrator settings are plain numbers and enums: serializing them cannot fail.
    if let Ok(integrator) = serde_json::to_string(&facts.scene.integrator) {
        set("spindle.integrator", integrator);
    }
    for (name, value) in facts.stats.entries() {
        set(&format!("spindle.stats.{name}"), value.to_string());
    }
    if let Some((passes, budget_s)) = facts.passes {
        set("spindle.passes", passes.to_string());
        set("spindle.time_budget_s", budget_s.to_string());
    }
    if let Some(path) = facts.scene_file {
        set("spindle.scene", path.to_string());
    }
    if let Some(workers) = facts.workers {
        set("spindle.workers", workers.to_string());
    }
    if let Some(provenance) = facts.provenance {
        a.extend(provenance.header_attributes());
    }

    image.precision = if film.half {
        Precision::Half
    } else {
        Precision::Float
    };
    let standard = &mut image.standard;
    standard.software = Some(SOFTWARE.to_string());
    let matrices = CameraMatrices::of(&facts.scene.camera, film.width, film.height);
    standard.world_to_camera = matrices.map(|m| to_m44f(&m.world_to_camera));
    standard.world_to_ndc = matrices.map(|m| to_m44f(&m.world_to_ndc));
    standard.render_time = facts.render_seconds.map(|s| s as f32);
}

#[cfg(test)]
mod tests;
