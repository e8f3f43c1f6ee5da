//! The best unbiased alternative a user has to [`super::multiple_scatter`]: a volumetric path
//! tracer that finds the light only by phase sampling — a path leaving the medium has to hit
//! an area light by chance (what Mitsuba 3's `volpath` does through a refractive boundary). It
//! is the independent check of the estimator (`render/tests/multiple_scatter.rs`) and the
//! yardstick of its speed (`spindle-bench --only multiple`).
//!
//! It estimates exactly the `multiple_scatter` layer's quantity, counting the same paths: two
//! scatterings or more (at most `max_order`), the last followed by one refraction out of the
//! medium straight into a light (no internal reflection in between: the exact connection's
//! rule); before the first scattering at most `internal_reflections` internal reflections (the
//! camera path's rule), after it at most `max_depth`. Interfaces choose reflection with the
//! Fresnel probability. It shares nothing with the estimator but the scene's geometry and
//! lights: its own Fresnel, Snell, phase function and distance sampling, and directions drawn
//! uniformly and weighted by the phase function. One dielectric object with a grey medium
//! (σ_t the same in every channel; the albedo may be coloured), the camera in the air.

use std::f64::consts::PI;

use glam::DVec3;

use crate::Rgb;
use crate::medium::PhaseFunction;
use crate::ray::Ray;
use crate::sampler::Sampler;
use crate::scene::{Material, Scene};

/// Why a scene is outside what the phase-sampling tracer handles.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Unsupported {
    #[error("the phase-sampling tracer handles one dielectric object, found {0}")]
    Objects(usize),
    #[error("the phase-sampling tracer needs a grey medium (one sigma_t), got {0:?}")]
    Coloured([f64; 3]),
    #[error("the phase-sampling tracer needs the camera in the air")]
    CameraInside,
}

/// Checks that `scene` is one the tracer handles.
pub fn check(scene: &Scene) -> Result<(), Unsupported> {
    let media: Vec<_> = scene
        .objects()
        .iter()
        .filter_map(|o| match o.material {
            Material::Dielectric(d) => Some(d.medium),
            Material::Diffuse { .. } => None,
        })
        .collect();
    if media.len() != 1 || scene.objects().len() != 1 {
        return Err(Unsupported::Objects(scene.objects().len()));
    }
    let s = media[0].sigma_t;
    if s.x != s.y || s.y != s.z {
        return Err(Unsupported::Coloured(s.to_array()));
    }
    if scene.camera_medium().is_some() {
        return Err(Unsupported::CameraInside);
    }
    Ok(())
}

/// Unpolarised Fresnel reflectance from index `n1` into `n2` at incidence cosine `c`.
fn fresnel(n1: f64, n2: f64, c: f64) -> f64 {
    let s = n1 / n2 * (1.0 - c * c).max(0.0).sqrt();
    if s >= 1.0 {
        return 1.0;
    }
    let ct = (1.0 - s * s).sqrt();
    let rs = (n1 * c - n2 * ct) / (n1 * c + n2 * ct);
    let rp = (n2 * c - n1 * ct) / (n2 * c + n1 * ct);
    0.5 * (rs * rs + rp * rp)
}

/// The phase function per steradian at cosine `c` between the propagation directions.
fn phase(p: PhaseFunction, c: f64) -> f64 {
    match p {
        PhaseFunction::Isotropic => 1.0 / (4.0 * PI),
        PhaseFunction::HenyeyGreenstein { g } => {
            (1.0 - g * g) / (4.0 * PI * (1.0 + g * g - 2.0 * g * c).powf(1.5))
        }
    }
}

/// A uniformly distributed unit vector.
fn uniform_direction(u: [f64; 2]) -> DVec3 {
    let z = 1.0 - 2.0 * u[0];
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// One camera sample's estimate along `ray` (from the camera, in the air). The scene must pass
/// [`check`]; otherwise the estimate is 0.
pub fn estimate(scene: &Scene, mut ray: Ray, rng: &mut Sampler) -> Rgb {
    if check(scene).is_err() {
        return Rgb::ZERO;
    }
    let Material::Dielectric(dielectric) = scene.objects()[0].material else {
        return Rgb::ZERO;
    };
    let medium = dielectric.medium;
    let (eta, sigma_t) = (dielectric.eta, medium.sigma_t.x);
    let albedo = if sigma_t > 0.0 {
        medium.sigma_s / sigma_t
    } else {
        Rgb::ZERO
    };
    let settings = scene.integrator();
    let mesh = &scene.objects()[0].mesh;
    let mut weight = Rgb::ONE;
    let mut inside = false;
    let (mut scatterings, mut internal, mut reflections) = (0u32, 0u32, 0u32);
    let mut reflected_since_scattering = false;
    loop {
        let Some(hit) = scene.bvh().closest_hit(&ray) else {
            return Rgb::ZERO;
        };
        if !inside {
            // A light before the object ends the path: surface light, not scattering.
            let light_first = scene
                .lights()
                .iter()
                .filter_map(|l| l.intersect(&ray))
                .any(|(t, _)| t < hit.t);
            if light_first {
                return Rgb::ZERO;
            }
        } else if sigma_t > 0.0 {
            let t = -(-rng.next_f64()).ln_1p() / sigma_t;
            if t < hit.t {
                scatterings += 1;
                if scatterings > settings.multiple_scatter.max_order {
                    return Rgb::ZERO;
                }
                reflected_since_scattering = false;
                let dir = uniform_direction(rng.next_2d());
                // Propagation directions −dir (arriving) and −ray.dir (on toward the camera).
                weight *= albedo * (4.0 * PI * phase(medium.phase, dir.dot(ray.dir)));
                ray = Ray::new(ray.at(t), dir);
                continue;
            }
        }
        let (_, triangle) = scene.locate(hit.triangle);
        let p = mesh.point(triangle, hit.a, hit.b);
        let ng = mesh.geometric_normal(triangle).normalize();
        let ns = mesh.shading_normal(triangle, hit.a, hit.b);
        let facing = if ray.dir.dot(ns) < 0.0 { ns } else { -ns };
        let c = -ray.dir.dot(facing);
        let (n1, n2) = if inside { (eta, 1.0) } else { (1.0, eta) };
        let side = |dir: DVec3| if dir.dot(ng) < 0.0 { -ng } else { ng };
        let offset = 1e-9 * scene.scale();
        if rng.next_f64() < fresnel(n1, n2, c) {
            if !inside {
                return Rgb::ZERO; // reflected off the outside: surface light
            }
            if scatterings == 0 {
                internal += 1;
                if internal > settings.internal_reflections {
                    return Rgb::ZERO;
                }
            } else {
                reflections += 1;
                if reflections > settings.max_depth {
                    return Rgb::ZERO;
                }
                reflected_since_scattering = true;
            }
            let dir = ray.dir + 2.0 * c * facing;
            ray = Ray::new(p + side(dir) * offset, dir);
            continue;
        }
        let ratio = n1 / n2;
        let ct = (1.0 - ratio * ratio * (1.0 - c * c)).sqrt();
        let dir = (ratio * ray.dir + (ratio * c - ct) * facing).normalize();
        ray = Ray::new(p + side(dir) * offset, dir);
        if !inside {
            // Radiance mode: the radiance inside is η² times the outside's.
            weight /= eta * eta;
            inside = true;
            continue;
        }
        weight *= eta * eta;
        if scatterings < 2 || reflected_since_scattering {
            return Rgb::ZERO;
        }
        // The nearest light, unless the object itself is nearer (a path that would come back in
        // is not counted).
        let object = scene.bvh().closest_hit(&ray).map_or(f64::INFINITY, |h| h.t);
        let light = scene
            .lights()
            .iter()
            .filter_map(|l| l.intersect(&ray))
            .filter(|&(t, _)| t < object)
            .min_by(|a, b| a.0.total_cmp(&b.0));
        return match light {
            Some((_, emitted)) => weight * emitted,
            None => Rgb::ZERO,
        };
    }
}
