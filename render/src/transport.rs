//! Light transport along a camera path without scattering: specular dielectric interfaces,
//! Beer–Lambert media, sphere lights, directly lit diffuse surfaces and the background.
//!
//! A camera path is traced backward from the camera. At a dielectric interface it splits
//! deterministically into the reflected and the refracted branch (no random choice, so no noise
//! from the interfaces), each weighted by its exact Fresnel factor; a branch is followed while
//! the path has made fewer than `integrator.max_depth` bounces and its throughput is at least
//! [`BRANCH_CUTOFF`]. Inside a medium, reflections off the boundary are followed up to
//! `integrator.internal_reflections` times per visit (total internal reflection counts as one).
//!
//! Media nest (`nesting`) and meet (`contact`): an object's surface is the interface between its
//! medium and the one beyond it at the point hit (the one around it, or a partner's whose
//! surface coincides there), crossed with the index of the medium entered over the one left
//! (`crossing`). Radiance-mode bookkeeping (radiance/n² is invariant): refracting multiplies the
//! throughput by `(1 − F)/η²` with that relative η.
//!
//! Every straight piece of the path inside a medium is a [`Segment`] handed to
//! [`scatter::single_scatter`]; its result times the segment throughput is the `single_scatter`
//! layer; the paths [`multiple_scatter`] starts from it give the `multiple_scatter` layer. Everything else (lights seen directly, reflected or transmitted, lit diffuse surfaces,
//! background) is the `surface` layer.
//!
//! A camera inside a dielectric object starts its paths in that object's medium (throughput 1:
//! the camera measures the radiance inside; leaving the medium multiplies it by `(1 − F)·η²`).
//! A sphere light inside a medium is seen through it, attenuated.
//!
//! Dielectric objects block shadow rays: a diffuse floor under a glass sphere, in the air, gets
//! no light through the glass (caustics on surfaces in the air are not rendered). A diffuse
//! surface *inside* a medium (a pool's floor) is lit by the lights in that medium directly,
//! attenuated, and by the lights outside through the medium's boundary (`scatter::receiver`),
//! into the `surface` layer; the light that scattered in the medium on its way to the surface
//! (`multiple_scatter::onto_surface`) goes into the `multiple_scatter` layer. Dielectric surfaces must not cross (`Scene::build` refuses it).

use glam::DVec3;
use spindle_common::stats::RenderStats;

use crate::Rgb;
use crate::bvh::Hit;
use crate::crossing::Crossing;
use crate::fresnel::{reflect, reflectance, refract};
use crate::multiple_scatter;
use crate::ray::Ray;
use crate::sampler::Sampler;
use crate::scatter;
use crate::scatter::receiver::Receiver;
use crate::scene::{Material, Scene};
use crate::segment::Segment;

/// A branch of a camera path whose weight (largest channel of the throughput, without the
/// pending `1/η²` of the medium it is in, which its exit gives back) falls below this is not
/// followed. It bounds the work of deterministic splitting; the light it drops is at most this
/// fraction of what a light or background behind the branch would give (a documented bias,
/// below f32 resolution of the output; with glass, F ≈ 0.04, so a path needs about four
/// reflections, 0.04⁴ ≈ 2.6e-6, before it comes close).
pub const BRANCH_CUTOFF: f64 = 1e-6;

/// Whether a branch with `throughput`, in the medium of `inside` (if any), is worth following.
fn significant(scene: &Scene, throughput: Rgb, inside: Option<usize>) -> bool {
    let n = scene.absolute_eta(inside);
    throughput.max_element() * (n * n) >= BRANCH_CUTOFF
}

/// The radiance of one camera sample, by layer. `total` = `surface` + `single_scatter` +
/// `multiple_scatter`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Radiance {
    pub surface: Rgb,
    pub single_scatter: Rgb,
    pub multiple_scatter: Rgb,
}

impl Radiance {
    /// The sum of the layers.
    pub fn total(&self) -> Rgb {
        self.surface + self.single_scatter + self.multiple_scatter
    }
}

/// Where a path is and what it carries.
#[derive(Debug, Clone, Copy)]
struct PathState {
    /// The object whose medium the path is in, if any.
    inside: Option<usize>,
    /// Surface interactions (bounces) so far.
    depth: u32,
    /// Internal reflections in the current visit of a medium.
    internal: u32,
    throughput: Rgb,
}

/// The radiance arriving at the camera along `ray` (unit direction).
pub fn radiance(
    scene: &Scene,
    ray: &Ray,
    sampler: &mut Sampler,
    stats: &mut RenderStats,
) -> Radiance {
    let mut out = Radiance::default();
    let state = PathState {
        inside: scene.camera_medium(),
        depth: 0,
        internal: 0,
        throughput: Rgb::ONE,
    };
    trace(scene, *ray, state, sampler, stats, &mut out);
    out
}

fn trace(
    scene: &Scene,
    ray: Ray,
    state: PathState,
    sampler: &mut Sampler,
    stats: &mut RenderStats,
    out: &mut Radiance,
) {
    let hit = scene.bvh().closest_hit(&ray);
    match state.inside {
        None => {
            // In air: the nearest of a light and a surface, else the background.
            let t_surface = hit.map_or(f64::INFINITY, |h| h.t);
            let light = scene
                .lights()
                .iter()
                .filter_map(|l| l.intersect(&ray))
                .filter(|&(t, _)| t < t_surface)
                .min_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((_, emitted)) = light {
                out.surface += state.throughput * emitted;
                return;
            }
            match hit {
                Some(hit) => interact(scene, &ray, &hit, state, sampler, stats, out),
                None => out.surface += state.throughput * scene.background(),
            }
        }
        Some(object) => {
            // In a medium: one camera segment up to the boundary (or, if the ray escapes an
            // open or leaking mesh, up to where it leaves the object's bounds), or up to a light
            // inside this medium, seen through the medium.
            let length = match hit {
                Some(h) => h.t,
                None => exit_distance(scene, object, &ray),
            };
            let Material::Dielectric(dielectric) = scene.objects()[object].material else {
                return;
            };
            let light = (0..scene.lights().len())
                .filter(|&j| scene.light_medium(j) == Some(object))
                .filter_map(|j| scene.lights()[j].intersect(&ray))
                .filter(|&(t, _)| t < length)
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let end = light.map_or(length, |(t_light, _)| t_light);
            let segment = Segment {
                origin: ray.origin,
                dir: ray.dir,
                length: end,
                object,
                throughput: state.throughput,
            };
            stats.camera_segments += 1;
            let scattered = scatter::single_scatter(scene, &segment, sampler, stats);
            debug_assert!(scattered.is_finite(), "single_scatter returned {scattered}");
            out.single_scatter += state.throughput * scattered;
            let multiple =
                multiple_scatter::multiple_scatter(scene, &segment, &mut sampler.fork(), stats);
            debug_assert!(multiple.is_finite(), "multiple_scatter returned {multiple}");
            out.multiple_scatter += state.throughput * multiple;
            if let Some((t_light, emitted)) = light {
                let seen = dielectric.medium.transmittance(t_light) * emitted;
                out.surface += state.throughput * seen;
                return;
            }
            let state = PathState {
                throughput: state.throughput * dielectric.medium.transmittance(length),
                ..state
            };
            match hit {
                Some(hit) => interact(scene, &ray, &hit, state, sampler, stats, out),
                None => {
                    // Escaped through a hole (or a leak between triangles): carry on in the medium
                    // around from the edge of the object's bounds, as if through a perfectly
                    // transmitting interface (no Fresnel; the pending 1/η² is given back).
                    let eta = scene.relative_eta(object);
                    let outside = PathState {
                        inside: scene.outer(object),
                        throughput: state.throughput * (eta * eta),
                        ..state
                    };
                    let from = Ray::new(ray.at(length), ray.dir);
                    trace(scene, from, outside, sampler, stats, out);
                }
            }
        }
    }
}

/// What happens where the path meets a surface.
fn interact(
    scene: &Scene,
    ray: &Ray,
    hit: &Hit,
    state: PathState,
    sampler: &mut Sampler,
    stats: &mut RenderStats,
    out: &mut Radiance,
) {
    let (object, triangle) = scene.locate(hit.triangle);
    let mesh = &scene.objects()[object].mesh;
    let p = mesh.point(triangle, hit.a, hit.b);
    let geometric = mesh.geometric_normal(triangle).normalize_or_zero();
    let shading = mesh.shading_normal(triangle, hit.a, hit.b);
    match scene.objects()[object].material {
        Material::Diffuse { reflectance } => {
            let diffuse = DiffuseHit {
                p,
                geometric,
                shading,
                incoming: ray.dir,
                reflectance,
            };
            out.surface +=
                state.throughput * direct_diffuse(scene, &diffuse, state.inside, sampler, stats);
            // Inside a medium, the lights outside it reach the surface through its boundary.
            if let Some(medium) = state.inside {
                let segment = Segment {
                    origin: ray.origin,
                    dir: ray.dir,
                    length: hit.t,
                    object: medium,
                    throughput: state.throughput,
                };
                let (normal, geometric) = diffuse.facing_camera();
                let receiver = Receiver {
                    p,
                    normal,
                    geometric,
                    reflectance,
                };
                out.surface += state.throughput
                    * scatter::receiver::through_boundary(
                        scene, &segment, &receiver, sampler, stats,
                    );
                // And the light that scattered in the medium on its way to the surface.
                out.multiple_scatter += state.throughput
                    * multiple_scatter::onto_surface(
                        scene,
                        medium,
                        &receiver,
                        &mut sampler.fork(),
                        stats,
                    );
            }
        }
        Material::Dielectric(_) => {
            if state.depth >= scene.integrator().max_depth {
                return;
            }
            // Which side the ray arrives from is geometry's call; the optics use the shading
            // normal turned to face the ray. The surface parts the medium the path is in from
            // the one beyond it there (`crossing`).
            let crossing = Crossing::of(scene, object, p, geometric, shading, ray.dir);
            let Crossing {
                facing,
                internal: reflects_inside,
                eta,
                ..
            } = crossing;
            let fresnel = reflectance(-ray.dir.dot(facing), eta);
            let depth = state.depth + 1;
            let inside_after = |dir: DVec3| crossing.medium_toward(dir);

            // Reflection: outside, always a candidate; inside, one more internal reflection.
            let internal = if reflects_inside {
                state.internal + 1
            } else {
                0
            };
            if !reflects_inside || state.internal < scene.integrator().internal_reflections {
                let throughput = state.throughput * fresnel;
                let dir = reflect(ray.dir, facing);
                if significant(scene, throughput, inside_after(dir)) {
                    let next = PathState {
                        inside: inside_after(dir),
                        depth,
                        internal,
                        throughput,
                    };
                    let from = Ray::leaving(p, geometric, dir, scene.scale());
                    trace(scene, from, next, sampler, stats, out);
                }
            }

            // Refraction (none under total internal reflection), with the n² bookkeeping.
            if let Some(dir) = refract(ray.dir, facing, eta) {
                let throughput = state.throughput * ((1.0 - fresnel) / (eta * eta));
                if significant(scene, throughput, inside_after(dir)) {
                    let next = PathState {
                        inside: inside_after(dir),
                        depth,
                        internal: 0,
                        throughput,
                    };
                    let from = Ray::leaving(p, geometric, dir, scene.scale());
                    trace(scene, from, next, sampler, stats, out);
                }
            }
        }
    }
}

/// A camera path's hit on a Lambertian surface, as its direct lighting sees it.
#[derive(Debug, Clone, Copy)]
struct DiffuseHit {
    /// The point hit.
    p: DVec3,
    /// The geometric normal there.
    geometric: DVec3,
    /// The shading normal there.
    shading: DVec3,
    /// The direction of the ray that hit it.
    incoming: DVec3,
    /// The surface's reflectance.
    reflectance: Rgb,
}

impl DiffuseHit {
    /// The shading and geometric normals turned to the side the camera sees (the surface is
    /// two-sided).
    fn facing_camera(&self) -> (DVec3, DVec3) {
        if self.incoming.dot(self.geometric) < 0.0 {
            (self.shading, self.geometric)
        } else {
            (-self.shading, -self.geometric)
        }
    }
}

/// Radiance leaving a Lambertian surface at `p`, in the medium of `inside` (if any), toward the
/// camera, lit directly by every light (one sample each), with shadow rays against all geometry
/// (dielectrics included) and the medium's attenuation along them. A light in another medium is
/// behind a boundary, which blocks its shadow ray.
fn direct_diffuse(
    scene: &Scene,
    hit: &DiffuseHit,
    inside: Option<usize>,
    sampler: &mut Sampler,
    stats: &mut RenderStats,
) -> Rgb {
    let DiffuseHit { p, reflectance, .. } = *hit;
    let (n, ng) = hit.facing_camera();
    let mut sum = Rgb::ZERO;
    for light in scene.lights() {
        // Always draw the numbers, so later dimensions do not depend on visibility.
        let u = sampler.next_2d();
        let Some(sample) = light.sample_incident(p, u) else {
            continue;
        };
        let cos = n.dot(sample.dir);
        if cos <= 0.0 || ng.dot(sample.dir) <= 0.0 {
            continue;
        }
        stats.shadow_rays += 1;
        let shadow = Ray::leaving(p, ng, sample.dir, scene.scale());
        let reach = (sample.distance - (shadow.origin - p).length()) * (1.0 - 1e-9);
        if scene.bvh().any_hit(shadow.origin, shadow.dir, reach) {
            continue;
        }
        let attenuation = match inside.map(|o| scene.objects()[o].material) {
            Some(Material::Dielectric(d)) => d.medium.transmittance(sample.distance),
            _ => Rgb::ONE,
        };
        sum += sample.weight * attenuation * cos;
    }
    sum * reflectance / std::f64::consts::PI
}

/// How far `ray` (starting inside object `object`'s bounds) travels before leaving them; 0 if
/// it starts outside.
fn exit_distance(scene: &Scene, object: usize, ray: &Ray) -> f64 {
    let (lo, hi) = scene.objects()[object].mesh.bounds();
    let mut t_exit = f64::INFINITY;
    for axis in 0..3 {
        let d = ray.dir[axis];
        if d != 0.0 {
            let bound = if d > 0.0 { hi[axis] } else { lo[axis] };
            t_exit = t_exit.min((bound - ray.origin[axis]) / d);
        }
    }
    if t_exit.is_finite() {
        t_exit.max(0.0)
    } else {
        0.0
    }
}
