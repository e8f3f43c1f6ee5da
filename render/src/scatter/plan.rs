//! Which single-scattering model runs for an object, and why: the `auto` method's choice, and the
//! explicit methods' resolution, said in words for the render log and the EXR header.
//!
//! `auto` models only what the scene requires:
//! * nothing at all where nothing can scatter: an opaque object, a medium with σ_s = 0 (albedo 0
//!   or σ_t = 0), or a scene without lights;
//! * η within [`INDEX_MATCHED`] of 1: the boundary does not bend light (or by less than any
//!   solve resolves), so the straight path is exact (to about `0.4·(η − 1)`, physics.md §1.2, §4)
//!   and no refraction is solved (`straight_line`) — for the explicit refraction methods too
//!   (`interval`, `point_sampling`, `reference`), whose solve is singular at η = 1 and loses its
//!   precision as η → 1 (`‖h‖ ≥ η − 1`, physics.md §2.5 item 2);
//! * otherwise the interval method of [H15], dense media included: [H15] App. B.3 observes that
//!   the straight-line model comes close above 30 mean free paths, but measured on a front-lit
//!   sphere at 100 and 10,000 times that it is more than 100 % off (docs/benchmarks.md, "Dense
//!   media"), beyond any `auto_tolerance`, while the interval method with depths sampled by
//!   attenuation is right to 0.3 % at K = 1 there. Where an object's normals are flat the per-triangle
//!   solver uses the closed-form D (physics.md eq. 3) by itself; the plan says so.

use spindle_common::scene::ScatterMethod;

use glam::DVec3;

use crate::containment;
use crate::light::{FAR, Light};
use crate::nesting::Route;
use crate::scatter::geometry::BoundingSphere;
use crate::scene::{Material, Object, Scene};

/// The model that runs for an object.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Model {
    /// Nothing scatters (or the method is `none`): black.
    Skip,
    Interval,
    PointSampling,
    StraightLine,
    Reference,
}

impl Model {
    /// The model's name as the scene's `method` spells it (`none` for [`Model::Skip`]).
    pub fn name(self) -> &'static str {
        match self {
            Model::Skip => "none",
            Model::Interval => "interval",
            Model::PointSampling => "point_sampling",
            Model::StraightLine => "straight_line",
            Model::Reference => "reference",
        }
    }
}

/// A model and the reason it was chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Plan {
    pub model: Model,
    pub reason: &'static str,
}

/// Indices closer to 1 than this are taken as 1: the straight path is then within about
/// `0.4 · INDEX_MATCHED` = 4e-8 of the refracted one, while the interval method on the unit
/// icosphere is off by 4e-7 at η = 1 + 1e-7, 6e-6 at 1 + 1e-8, 7e-5 at 1 + 1e-9, 1.5 % at
/// 1 + 1e-10 and black at 1 + 1e-11 (render/tests/degenerate.rs, `eta_tends_to_one`).
pub const INDEX_MATCHED: f64 = 1e-7;

/// The plan for `objects[o]` of `scene` under the integrator settings.
pub fn plan_for(scene: &Scene, o: usize) -> Plan {
    let object = &scene.objects()[o];
    let settings = &scene.integrator().single_scatter;
    let skip = |reason| Plan {
        model: Model::Skip,
        reason,
    };
    let Material::Dielectric(dielectric) = object.material else {
        return skip("opaque: no medium");
    };
    let medium = dielectric.medium;
    let explicit = |model, reason| Plan { model, reason };
    let index_matched = (scene.relative_eta(o) - 1.0).abs() <= INDEX_MATCHED;
    match settings.method {
        ScatterMethod::None => return skip("method none"),
        ScatterMethod::Interval | ScatterMethod::PointSampling | ScatterMethod::Reference
            if index_matched =>
        {
            return explicit(
                Model::StraightLine,
                "eta = 1 (within 1e-7): the refraction solve is singular there and the straight \
                 path is exact",
            );
        }
        ScatterMethod::Interval => return explicit(Model::Interval, "method interval"),
        ScatterMethod::PointSampling => {
            return explicit(Model::PointSampling, "method point_sampling");
        }
        ScatterMethod::StraightLine => {
            return explicit(Model::StraightLine, "method straight_line");
        }
        ScatterMethod::Reference => return explicit(Model::Reference, "method reference"),
        ScatterMethod::Auto => {}
    }
    if scene.lights().is_empty() {
        return skip("auto: no lights");
    }
    if medium.sigma_s.max_element() <= 0.0 {
        return skip("auto: sigma_s = 0 (albedo 0 or sigma_t 0), nothing scatters");
    }
    if index_matched {
        return Plan {
            model: Model::StraightLine,
            reason: "auto: eta = 1 (within 1e-7), the straight path is exact (no refraction solve)",
        };
    }
    Plan {
        model: Model::Interval,
        reason: "auto: refractive boundary",
    }
}

/// The bounding sphere of an object (from its BVH root box); `None` for an empty object.
pub fn object_bounds(object: &Object) -> Option<BoundingSphere> {
    if object.bvh.nodes().is_empty() {
        return None;
    }
    let (lo, hi) = object.bvh.node_bounds(0);
    Some(BoundingSphere::of_box(lo, hi))
}

/// Whether every vertex normal of the object equals its triangle's geometric normal (to 1e-9),
/// so D has the closed flat form everywhere.
fn has_flat_normals(object: &Object) -> bool {
    let mesh = &object.mesh;
    (0..mesh.triangle_count()).all(|i| {
        let Some(ng) = mesh.geometric_normal(i).try_normalize() else {
            return true;
        };
        mesh.corner_normals(i).iter().all(|n| n.distance(ng) < 1e-9)
    })
}

/// One line per object saying which single-scattering model runs and why, for the render log
/// and the EXR header (`objects[i]: interval (auto: refractive boundary; shading normals, D
/// from ray differentials)`).
pub fn describe_plan(scene: &Scene) -> Vec<String> {
    scene
        .objects()
        .iter()
        .enumerate()
        .map(|(i, object)| {
            let plan = plan_for(scene, i);
            let model = plan.model.name();
            let normals = match plan.model {
                Model::Interval | Model::PointSampling | Model::Reference => {
                    if has_flat_normals(object) {
                        "; flat normals, closed-form D"
                    } else {
                        "; shading normals, D from ray differentials"
                    }
                }
                _ => "",
            };
            format!("objects[{i}]: {model} ({}{normals})", plan.reason)
        })
        .chain(crate::multiple_scatter::describe(scene))
        .chain(describe_placement(scene))
        .chain(scene.second_interfaces().iter().map(|s| s.describe()))
        .collect()
}

/// The lines that say how a directional light is modelled, and where the camera and the lights
/// are with respect to the media, when not in the air: a camera path starts in the camera's medium; a light in a medium lights that
/// medium along straight paths and no other medium.
fn describe_placement(scene: &Scene) -> Vec<String> {
    let mut lines = Vec::new();
    if let Some(o) = scene.camera_medium() {
        lines.push(format!(
            "camera: inside objects[{o}] (camera paths start in its medium)"
        ));
    }
    lines.extend(describe_receivers(scene));
    lines.extend(describe_nesting(scene));
    lines.extend(describe_contacts(scene));
    for (j, light) in scene.lights().iter().enumerate() {
        if let Light::Directional {
            anchor, distance, ..
        } = *light
        {
            lines.push(format!(
                "lights[{j}]: directional; its light points lie {distance:.3e} from the scene's \
                 centre {anchor} ({FAR:.0e} scene radii), so their rays spread by at most \
                 {:.1e}° across the scene; the irradiance is exact everywhere",
                (1.0 / FAR).to_degrees()
            ));
        }
        let Some(o) = scene.light_medium(j) else {
            continue;
        };
        let others: Vec<String> = scene
            .objects()
            .iter()
            .enumerate()
            .filter(|&(i, _)| {
                i != o
                    && plan_for(scene, i).model != Model::Skip
                    && scene.route(i, j) == Route::Unmodelled
            })
            .map(|(i, _)| format!("objects[{i}]"))
            .collect();
        let unlit = if others.is_empty() {
            String::new()
        } else {
            format!(
                "; {} get no single scattering from it (a second interface, not modelled)",
                others.join(", ")
            )
        };
        lines.push(format!(
            "lights[{j}]: inside objects[{o}] (lights its medium along straight paths, and the \
             media nested in it through their one interface{unlit})"
        ));
    }
    lines
}

/// One line per dielectric object nested in another's medium: the relative index its surface has,
/// and which lights reach it through the flat faces of the medium around it.
fn describe_nesting(scene: &Scene) -> Vec<String> {
    let mut lines = Vec::new();
    for (o, object) in scene.objects().iter().enumerate() {
        let (Some(q), Material::Dielectric(_)) = (scene.outer(o), object.material) else {
            continue;
        };
        let through_faces: Vec<String> = (0..scene.lights().len())
            .filter(|&j| scene.route(o, j) == (Route::FlatFaces { outer: q }))
            .map(|j| format!("lights[{j}]"))
            .collect();
        let faces = if through_faces.is_empty() {
            String::new()
        } else {
            format!(
                "; {} reach objects[{q}]'s medium through its {} flat faces (exact)",
                through_faces.join(", "),
                scene.flat_faces(q).faces.len()
            )
        };
        lines.push(format!(
            "objects[{o}]: nested in objects[{q}]'s medium (relative index {:.4}){faces}",
            scene.relative_eta(o)
        ));
    }
    lines
}

/// One line per pair of media whose surfaces coincide (`contact`): one interface between them.
fn describe_contacts(scene: &Scene) -> Vec<String> {
    let mut lines = Vec::new();
    for o in 0..scene.objects().len() {
        for &k in scene.partners(o).iter().filter(|&&k| k > o) {
            lines.push(format!(
                "objects[{o}] and objects[{k}]: meet at a shared interface (relative index \
                 {:.4}); light reaching either medium through it crosses the other's surface \
                 first (a second interface, blocked)",
                scene.absolute_eta(Some(k)) / scene.absolute_eta(Some(o))
            ));
        }
    }
    lines
}

/// At most this many vertices, and as many triangle centroids, of a diffuse object are tested
/// for lying in a medium (evenly strided), so a large mesh does not make the plan slow.
const RECEIVER_PROBES: usize = 64;

/// One line per diffuse object that lies (at least partly, as far as its probed vertices and
/// centroids tell) inside a dielectric's medium: the lights outside reach it through that
/// boundary (`scatter::receiver`), one interface only.
fn describe_receivers(scene: &Scene) -> Vec<String> {
    let objects = scene.objects();
    let mut lines = Vec::new();
    for (i, object) in objects.iter().enumerate() {
        if !matches!(object.material, Material::Diffuse { .. }) {
            continue;
        }
        let mesh = &object.mesh;
        let strided = |n: usize| (0..n).step_by(n.div_ceil(RECEIVER_PROBES).max(1));
        let vertices = strided(mesh.positions().len()).map(|k| mesh.positions()[k]);
        let centroids = strided(mesh.triangle_count()).map(|k| {
            let [a, b, c] = mesh.corners(k);
            (a + b + c) / 3.0
        });
        let probes: Vec<DVec3> = vertices.chain(centroids).collect();
        for (o, medium) in objects.iter().enumerate() {
            if !matches!(medium.material, Material::Dielectric(_)) {
                continue;
            }
            let (lo, hi) = medium.mesh.bounds();
            let inside = probes
                .iter()
                .filter(|&&p| p.cmpge(lo).all() && p.cmple(hi).all())
                .filter(|&&p| containment::holds(&medium.mesh, p))
                .count();
            if inside == 0 {
                continue;
            }
            let share = if inside == probes.len() {
                "inside"
            } else {
                "partly inside"
            };
            lines.push(format!(
                "objects[{i}]: diffuse, {share} objects[{o}]'s medium: lit by the lights outside \
                 it through its boundary (every refraction point, one interface; a light in \
                 another medium gives nothing)"
            ));
        }
    }
    lines
}
