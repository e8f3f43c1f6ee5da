//! What a camera ray hits first, as the optional passes (`film.passes`, [`spindle_common::aov`])
//! record it: the camera-space depth, the world-space shading normal, the albedo and the object.
//!
//! The hit is the one the `alpha` layer counts (`Scene::bvh`'s closest hit of the very ray the
//! transport follows), so the passes and the coverage agree sample by sample.

use spindle_common::aov::FirstHit;

use crate::bvh::Hit;
use crate::ray::Ray;
use crate::scene::{Material, Scene};

/// The first hit of `ray` (a camera ray, unit direction) at `hit`; all zero for a miss.
/// Depth is `t` times the cosine between the ray and the camera's viewing axis (the hit's
/// camera-space z); a dielectric's albedo is 1 (OIDN's advice for perfectly specular glass).
pub fn first_hit(scene: &Scene, ray: &Ray, hit: Option<&Hit>) -> FirstHit {
    let Some(hit) = hit else {
        return FirstHit::default();
    };
    let (object, triangle) = scene.locate(hit.triangle);
    let o = &scene.objects()[object];
    let albedo = match o.material {
        Material::Dielectric(_) => [1.0; 3],
        Material::Diffuse { reflectance } => reflectance.to_array(),
    };
    FirstHit {
        depth: hit.t * ray.dir.dot(scene.camera().forward()),
        normal: o.mesh.shading_normal(triangle, hit.a, hit.b).to_array(),
        albedo,
        id: u32::try_from(object + 1).unwrap_or(u32::MAX),
    }
}
