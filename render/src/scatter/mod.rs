//! Single scattering through a refractive triangle-mesh boundary ([H15], physics.md).
//!
//! Entry point: [`single_scatter`], called by the transport for every camera segment inside a
//! medium. For each light it draws one light point (`light_sample`), then runs the model the
//! object's [`plan`] names: the interval method, point sampling, the straight-line model or the
//! brute-force reference (`methods`), all sharing the pruned BVH descent (`prune`, `descent`) and
//! the connection with its visibility tests (`connect`). [`describe_plan`] says in words which
//! model runs for each object.
//!
//! Three wings: [`triangle`], the per-triangle mathematics in f64, independent of the scene;
//! [`prune`], the conservative culling of triangles and BVH nodes; [`methods`], the estimators.
//! [`receiver`] uses the same solve and pruning for a diffuse surface inside a medium, lit
//! through the boundary (surface light, not single scattering).
//!
//! A light inside the segment's own medium needs no refraction at all (`methods::in_medium`,
//! whatever the plan). A light in the medium around the object (the air, or the medium the object
//! is nested in) reaches it through its one interface, with the relative index; a directional
//! light in the air reaches an object nested one level down through the outer medium's flat faces
//! (`flat_face`: a directional light in the outer medium again, exactly). Any other light would
//! need a second interface that is not modelled and gives nothing (said by the plan and the
//! scene's warnings, `interfaces`).
//!
//! Sign conventions, stated once for all of these modules: η = n_medium / n_outside (the medium
//! around it; > 1 when the medium is denser); the light is outside (but for `in_medium`); the shading normal points outward, toward the light;
//! the camera segment is `V(t) = origin + t·dir` with `dir` a unit vector, so t is a distance.

pub mod geometry;
pub mod light_sample;
pub mod methods;
pub mod plan;
pub mod prune;
pub mod receiver;
pub mod triangle;

use spindle_common::stats::RenderStats;

use crate::Rgb;
use crate::nesting::Route;
use crate::sampler::Sampler;
use crate::scene::{Material, Scene};
use crate::segment::Segment;
use light_sample::LightPoint;
use light_sample::{Receivers, sample_light};
use methods::connect::{Connection, Outside, for_each_outside};
pub use plan::describe_plan;
use plan::{Model, object_bounds, plan_for};
use prune::descent::DescentStack;

/// Radiance arriving at `segment.origin`, inside the medium, travelling toward the camera (along
/// `−segment.dir`), from light scattered once along the segment: the sum over the scene's lights
/// of one light point each. It includes the η² of physics.md eq. 1 and not the Fresnel factor of
/// the camera path's entry (both of which the segment's throughput carries as `T/η²`).
pub fn single_scatter(
    scene: &Scene,
    segment: &Segment,
    sampler: &mut Sampler,
    stats: &mut RenderStats,
) -> Rgb {
    let model = plan_for(scene, segment.object).model;
    single_scatter_by(scene, segment, model, sampler, stats)
}

/// [`single_scatter`] by `model` rather than the object's plan (multiple scattering's
/// secondary segments, whose model the settings may name).
pub fn single_scatter_by(
    scene: &Scene,
    segment: &Segment,
    model: Model,
    sampler: &mut Sampler,
    stats: &mut RenderStats,
) -> Rgb {
    let object = &scene.objects()[segment.object];
    let Material::Dielectric(dielectric) = object.material else {
        return Rgb::ZERO;
    };
    let Some(bounds) = object_bounds(object) else {
        return Rgb::ZERO;
    };
    if model == Model::Skip || !segment.length.is_finite() || segment.length <= 0.0 {
        return Rgb::ZERO;
    }
    let medium = dielectric.medium;
    let settings = &scene.integrator().single_scatter;
    let mut stack = DescentStack::default();
    let mut total = Rgb::ZERO;
    let receivers = Receivers::of_segment(bounds, segment.origin, segment.dir, segment.length);
    let length = segment.length;
    for (j, light) in scene.lights().iter().enumerate() {
        let point = sample_light(light, receivers, sampler);
        if point.is_black() {
            continue;
        }
        let connection = |light: LightPoint, outside: Outside| {
            Connection::along(scene, segment, medium, j, light, outside)
        };
        if scene.route(segment.object, j) == Route::Inside {
            let connection = connection(point, Outside::Straight(None));
            total += methods::in_medium::estimate(&connection, length, settings, sampler, stats);
            continue;
        }
        // Around the object, or through the flat faces of the medium around it; a light that
        // reaches the medium by no modelled route gives nothing (the plan says so).
        for_each_outside(scene, segment.object, j, point, |light, outside| {
            let connection = connection(light, outside);
            total += match model {
                Model::Skip => Rgb::ZERO,
                Model::Interval => methods::interval::estimate(
                    &connection,
                    length,
                    settings,
                    &mut stack,
                    sampler,
                    stats,
                ),
                Model::PointSampling => methods::point_sampling::estimate(
                    &connection,
                    length,
                    settings,
                    &mut stack,
                    sampler,
                    stats,
                ),
                Model::StraightLine => {
                    methods::straight_line::estimate(&connection, length, settings, sampler, stats)
                }
                Model::Reference => {
                    methods::reference::estimate(&connection, length, settings, sampler, stats)
                }
            };
        });
    }
    debug_assert!(total.is_finite(), "single_scatter: {total}");
    total
}
