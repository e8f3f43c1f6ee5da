//! Multiple scattering inside a medium, each segment's light found exactly.
//!
//! The light that reaches the camera after scattering twice or more inside a medium (the
//! `multiple_scatter` layer). A volumetric path starts on every camera segment inside a medium:
//! a scattering point drawn by the attenuation on the segment, a direction by the phase
//! function, a straight flight to where the path next scatters (drawn by the attenuation) or
//! reaches the boundary, where it reflects internally with the exact Fresnel factor (total
//! internal reflection included) and goes on. Along every such *secondary* segment the
//! single-scattering integral toward every light is added — [`scatter::single_scatter_by`], the
//! interval method through the refractive boundary (or the model the settings name) — weighted
//! by the path's throughput. That integral is the exact next-event estimate through the
//! boundary which ordinary next-event estimation cannot make, so no path has to find a light by
//! chance.
//!
//! Which paths it counts (and so which it leaves out, each a stated cut):
//! * orders 2 to `integrator.multiple_scatter.max_order`; a path continues past its second
//!   scattering by Russian roulette on its throughput (unbiased);
//! * the light's last connection is the single-scattering one: one refraction through the
//!   object's own boundary (or a straight path from a light inside the medium); a path that
//!   leaves the medium is not followed (the light it would find on leaving is what the
//!   single-scattering integral of its last segment already holds), nor one that meets another
//!   object inside the medium (a nested object or a diffuse surface);
//! * at most `integrator.max_depth` internal reflections per path;
//! * a diffuse surface inside the medium that a camera path reaches (a pool's floor under milky
//!   water) gets the light scattered in the medium on its way there ([`onto_surface`]): orders
//!   1 to `max_order − 1`, its reflection counted as one more.
//!
//! Random numbers: each camera segment's paths draw from a [`Sampler::fork`], so the other
//! layers are the same bits with multiple scattering on or off, and a pixel's value stays a
//! pure function of (scene, seed, pixel, sample).

use spindle_common::scene::SecondaryMethod;
use spindle_common::stats::RenderStats;

use crate::Rgb;
use crate::crossing::Crossing;
use crate::fresnel::{reflect, reflectance};
use crate::medium::Flight;
use crate::ray::Ray;
use crate::sampler::Sampler;
use crate::scatter;
use crate::scatter::plan::{INDEX_MATCHED, Model, plan_for};
use crate::scatter::receiver::Receiver;
use crate::scene::{Material, Scene};
use crate::segment::Segment;

/// Paths continue unconditionally up to this scattering order, then by Russian roulette.
const ROULETTE_FROM_ORDER: u32 = 3;

/// Whether multiple scattering runs for an object, with which model for the secondary
/// segments' light, and why.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Plan {
    /// `None`: off.
    pub model: Option<Model>,
    pub reason: &'static str,
}

/// The multiple-scattering plan of `objects[o]` under the integrator settings.
pub fn plan(scene: &Scene, o: usize) -> Plan {
    let off = |reason| Plan {
        model: None,
        reason,
    };
    let Material::Dielectric(dielectric) = scene.objects()[o].material else {
        return off("opaque: no medium");
    };
    let settings = &scene.integrator().multiple_scatter;
    if settings.max_order < 2 {
        return off("max_order 1");
    }
    if dielectric.medium.sigma_s.max_element() <= 0.0 {
        return off("sigma_s = 0 (albedo 0 or sigma_t 0), nothing scatters");
    }
    let single = plan_for(scene, o);
    if single.model == Model::Skip {
        return off("the single-scattering model is none, so no segment's light is computed");
    }
    let index_matched = (scene.relative_eta(o) - 1.0).abs() <= INDEX_MATCHED;
    let on = |model, reason| Plan {
        model: Some(model),
        reason,
    };
    match settings.method {
        SecondaryMethod::Auto => on(single.model, "method auto: the single-scattering model"),
        SecondaryMethod::StraightLine => on(Model::StraightLine, "method straight_line"),
        _ if index_matched => on(
            Model::StraightLine,
            "eta = 1 (within 1e-7): the straight path is exact",
        ),
        SecondaryMethod::Interval => on(Model::Interval, "method interval"),
        SecondaryMethod::PointSampling => on(Model::PointSampling, "method point_sampling"),
    }
}

/// One line per object with a medium saying whether multiple scattering runs, how, and why.
pub fn describe(scene: &Scene) -> Vec<String> {
    let settings = &scene.integrator().multiple_scatter;
    (0..scene.objects().len())
        .filter(|&o| matches!(scene.objects()[o].material, Material::Dielectric(_)))
        .map(|o| {
            let plan = plan(scene, o);
            match plan.model {
                None => format!("objects[{o}]: multiple scattering off ({})", plan.reason),
                Some(model) => format!(
                    "objects[{o}]: multiple scattering, orders 2 to {}, {} path{} per camera \
                     segment, each segment's light by {} ({})",
                    settings.max_order,
                    settings.paths,
                    if settings.paths == 1 { "" } else { "s" },
                    model.name(),
                    plan.reason
                ),
            }
        })
        .collect()
}

/// Radiance arriving at `segment.origin`, inside the medium, toward the camera, from light
/// scattered two to `max_order` times in the medium of `segment.object`, the last time on a
/// secondary segment. Like [`scatter::single_scatter`], it excludes the segment's throughput.
pub fn multiple_scatter(
    scene: &Scene,
    segment: &Segment,
    sampler: &mut Sampler,
    stats: &mut RenderStats,
) -> Rgb {
    let Some(model) = plan(scene, segment.object).model else {
        return Rgb::ZERO;
    };
    let Material::Dielectric(dielectric) = scene.objects()[segment.object].material else {
        return Rgb::ZERO;
    };
    let medium = dielectric.medium;
    let settings = &scene.integrator().multiple_scatter;
    let walk = Walk {
        scene,
        object: segment.object,
        model,
        max_order: settings.max_order,
    };
    let mut total = Rgb::ZERO;
    for _ in 0..settings.paths {
        let Some((t, weight)) = medium.scatter_within(segment.length, sampler.next_f64()) else {
            continue;
        };
        total += walk.from(
            segment.origin + segment.dir * t,
            segment.dir,
            weight,
            sampler,
            stats,
        );
    }
    total / f64::from(settings.paths)
}

/// Radiance leaving a Lambertian surface inside the medium of `medium_object` toward the camera
/// (its throughput not applied), from light that scattered in the medium on its way to the
/// surface (a pool's floor under milky water, a pebble in jade): the light arriving in a
/// cosine-distributed direction drawn on the camera's side of the surface — the single-scattering
/// integral along the ray from the surface to where it leaves the medium, and the walk from a
/// scattering on it — times the reflectance. The reflection counts as one of the `max_order`
/// scatterings, so the medium adds orders 1 to `max_order − 1`; it runs where multiple scattering
/// runs for the medium ([`plan`]).
pub fn onto_surface(
    scene: &Scene,
    medium_object: usize,
    receiver: &Receiver,
    sampler: &mut Sampler,
    stats: &mut RenderStats,
) -> Rgb {
    let Some(model) = plan(scene, medium_object).model else {
        return Rgb::ZERO;
    };
    let Material::Dielectric(dielectric) = scene.objects()[medium_object].material else {
        return Rgb::ZERO;
    };
    let settings = &scene.integrator().multiple_scatter;
    let walk = Walk {
        scene,
        object: medium_object,
        model,
        max_order: settings.max_order - 1,
    };
    let (s, t) = receiver.normal.any_orthonormal_pair();
    let mut total = Rgb::ZERO;
    for _ in 0..settings.paths {
        let [u, v] = sampler.next_2d();
        let first = sampler.next_f64();
        let (r, phi) = (u.sqrt(), 2.0 * std::f64::consts::PI * v);
        let dir = (s * (r * phi.cos()) + t * (r * phi.sin()) + receiver.normal * (1.0 - u).sqrt())
            .normalize();
        if dir.dot(receiver.geometric) <= 0.0 {
            continue;
        }
        let ray = Ray::leaving(receiver.p, receiver.geometric, dir, scene.scale());
        let Some(hit) = scene.bvh().closest_hit(&ray) else {
            continue;
        };
        let segment = Segment {
            origin: ray.origin,
            dir,
            length: hit.t,
            object: medium_object,
            throughput: Rgb::ONE,
        };
        total += walk.segment_light(&segment, sampler, stats);
        if walk.max_order >= 2
            && let Some((t, weight)) = dielectric.medium.scatter_within(hit.t, first)
        {
            total += walk.from(ray.at(t), dir, weight, sampler, stats);
        }
    }
    receiver.reflectance * total / f64::from(settings.paths)
}

/// A path's fixed settings.
struct Walk<'a> {
    scene: &'a Scene,
    object: usize,
    model: Model,
    max_order: u32,
}

impl Walk<'_> {
    /// The single-scattering integral along a secondary segment, its capacity drops counted
    /// apart from the camera segments'.
    fn segment_light(
        &self,
        segment: &Segment,
        sampler: &mut Sampler,
        stats: &mut RenderStats,
    ) -> Rgb {
        stats.secondary_segments += 1;
        let before = stats.capacity_drops;
        let light = scatter::single_scatter_by(self.scene, segment, self.model, sampler, stats);
        stats.secondary_capacity_drops += stats.capacity_drops - before;
        stats.capacity_drops = before;
        light
    }

    /// The path from its first scattering at `x`, where it arrived travelling `arrived` (the
    /// tracing direction), with throughput `beta`: the sum over its secondary segments of
    /// throughput × the segment's single-scattering integral.
    fn from(
        &self,
        mut x: glam::DVec3,
        arrived: glam::DVec3,
        mut beta: Rgb,
        sampler: &mut Sampler,
        stats: &mut RenderStats,
    ) -> Rgb {
        let scene = self.scene;
        let Material::Dielectric(dielectric) = scene.objects()[self.object].material else {
            return Rgb::ZERO;
        };
        let medium = dielectric.medium;
        let mut sum = Rgb::ZERO;
        // Scatterings so far; the integral along the next segment adds one more.
        let mut order = 1;
        let mut reflections = 0;
        let mut ray = Ray::new(x, medium.phase.sample(arrived, sampler.next_2d()));
        loop {
            let hit = scene.bvh().closest_hit(&ray);
            let Some(hit) = hit else {
                // An open or leaking mesh: the path is lost.
                return sum;
            };
            let secondary = Segment {
                origin: ray.origin,
                dir: ray.dir,
                length: hit.t,
                object: self.object,
                throughput: beta,
            };
            sum += beta * self.segment_light(&secondary, sampler, stats);
            match medium.free_flight(hit.t, sampler.next_f64()) {
                Flight::Scatter { t, weight } => {
                    // The segment after this scattering would add order + 2.
                    if order + 2 > self.max_order {
                        return sum;
                    }
                    beta *= weight;
                    order += 1;
                    x = ray.at(t);
                    if order >= ROULETTE_FROM_ORDER {
                        let survive = beta.max_element().min(1.0);
                        if sampler.next_f64() >= survive {
                            return sum;
                        }
                        beta /= survive;
                    }
                    ray = Ray::new(x, medium.phase.sample(ray.dir, sampler.next_2d()));
                }
                Flight::Through { weight } => {
                    beta *= weight;
                    let crossing = Crossing::at(scene, &hit, ray.dir);
                    // The path goes on only off the medium's own boundary (shared interfaces
                    // included), not off an object inside it.
                    let own = matches!(
                        scene.objects()[crossing.object].material,
                        Material::Dielectric(_)
                    ) && crossing.internal
                        && crossing.before == Some(self.object);
                    if !own || reflections >= scene.integrator().max_depth {
                        return sum;
                    }
                    reflections += 1;
                    let Crossing {
                        p,
                        geometric,
                        facing,
                        eta,
                        ..
                    } = crossing;
                    // From inside the medium out: the index beyond over this one's.
                    beta *= reflectance(-ray.dir.dot(facing), eta);
                    let dir = reflect(ray.dir, facing);
                    if crossing.medium_toward(dir) != Some(self.object) || beta.max_element() <= 0.0
                    {
                        // The shading normal sends the reflection out of the medium.
                        return sum;
                    }
                    ray = Ray::leaving(p, geometric, dir, scene.scale());
                }
            }
        }
    }
}

pub mod phase_sampling;

#[cfg(test)]
mod tests;
