//! Light that would have to cross a second dielectric interface to reach a medium: found per
//! object and light when the scene is built, so the plan, the log and the EXR header can say it.
//!
//! Single scattering here follows light through **one** refractive interface ([H15]'s model):
//! from a light in the air, the path `L → P` to a refraction point P on the object's surface is a
//! straight line in the air. Where another dielectric object lies on that line (a second glass
//! sphere between the light and the first, an ice cube inside water seen from a light above the
//! water), the path is blocked by the shadow ray, not refracted twice: that light is missing from
//! the image. Two interfaces — even a flat one — are not modelled; this module measures how much
//! of each object's lit surface is affected, so the loss is never silent.
//!
//! The share is estimated from [`SURFACE_POINTS`] points spread over the object's surface by
//! area (deterministically): of the points whose front faces the light, the fraction whose
//! straight line to the light (its centre) meets another dielectric object. Objects nested inside
//! another dielectric are reported too (media do not nest).

use glam::DVec3;

use crate::containment;
use crate::scene::{Material, Object};

/// Surface points per object and light.
pub const SURFACE_POINTS: usize = 512;

/// The share of an object's lit surface whose light would cross another dielectric first.
#[derive(Debug, Clone, PartialEq)]
pub struct SecondInterface {
    /// `objects[object]`, the medium that light would reach through two interfaces.
    pub object: usize,
    /// `lights[light]`.
    pub light: usize,
    /// The dielectric objects in the way.
    pub blockers: Vec<usize>,
    /// Share in [0, 1] of the surface points facing the light whose line to it is blocked by them.
    pub share: f64,
}

impl SecondInterface {
    /// The sentence for the plan, the log and the EXR header.
    pub fn describe(&self) -> String {
        let blockers: Vec<String> = self
            .blockers
            .iter()
            .map(|b| format!("objects[{b}]"))
            .collect();
        format!(
            "objects[{}] and lights[{}]: {:.0}% of the surface lit by the light sees it through \
             {} (a second refractive interface, not modelled: that light is blocked)",
            self.object,
            self.light,
            100.0 * self.share,
            blockers.join(", ")
        )
    }
}

/// Every (dielectric object, light in the air) pair whose light crosses another dielectric on its
/// way to some of the object's surface. `light_positions[j]` is `None` for a light inside a
/// medium (those reach other media through two interfaces by definition; the plan says so).
pub fn second_interfaces(
    objects: &[Object],
    light_positions: &[Option<DVec3>],
) -> Vec<SecondInterface> {
    let dielectric = |o: &Object| matches!(o.material, Material::Dielectric(_));
    let mut found = Vec::new();
    if objects.iter().filter(|o| dielectric(o)).count() < 2 {
        // Nothing else can be in the way.
        return found;
    }
    for (o, object) in objects.iter().enumerate().filter(|(_, o)| dielectric(o)) {
        let points = surface_points(object);
        for (j, light) in light_positions.iter().enumerate() {
            let Some(light) = *light else { continue };
            let mut facing = 0usize;
            let mut blocked = 0usize;
            let mut blockers = Vec::new();
            for &(p, normal) in &points {
                let to_light = light - p;
                if normal.dot(to_light) <= 0.0 {
                    continue;
                }
                facing += 1;
                let distance = to_light.length();
                let dir = to_light / distance;
                let mut hit = false;
                for (k, other) in objects.iter().enumerate() {
                    if k == o || !dielectric(other) {
                        continue;
                    }
                    if other.bvh.any_hit(p, dir, distance) {
                        hit = true;
                        if !blockers.contains(&k) {
                            blockers.push(k);
                        }
                    }
                }
                blocked += usize::from(hit);
            }
            if blocked > 0 {
                blockers.sort_unstable();
                found.push(SecondInterface {
                    object: o,
                    light: j,
                    blockers,
                    share: blocked as f64 / facing as f64,
                });
            }
        }
    }
    found
}

/// Dielectric objects that lie inside another dielectric object (by the winding number of one of
/// their vertices): `(inner, outer)`.
pub fn nested(objects: &[Object]) -> Vec<(usize, usize)> {
    let dielectric = |o: &Object| matches!(o.material, Material::Dielectric(_));
    let mut pairs = Vec::new();
    for (i, inner) in objects.iter().enumerate().filter(|(_, o)| dielectric(o)) {
        let Some(&vertex) = inner.mesh.positions().first() else {
            continue;
        };
        for (k, outer) in objects.iter().enumerate() {
            if k != i && dielectric(outer) && containment::holds(&outer.mesh, vertex) {
                pairs.push((i, k));
            }
        }
    }
    pairs
}

/// [`SURFACE_POINTS`] points with their geometric normals, spread over the mesh by area: the
/// i-th point lies in the triangle where the cumulative area reaches `(i + ½)/N` of the total,
/// at barycentrics from a golden-ratio sequence.
fn surface_points(object: &Object) -> Vec<(DVec3, DVec3)> {
    let mesh = &object.mesh;
    let areas: Vec<f64> = (0..mesh.triangle_count())
        .map(|t| 0.5 * mesh.geometric_normal(t).length())
        .collect();
    let total: f64 = areas.iter().sum();
    if total.is_nan() || total <= 0.0 {
        return Vec::new();
    }
    let mut points = Vec::with_capacity(SURFACE_POINTS);
    let (mut triangle, mut below) = (0, 0.0);
    for i in 0..SURFACE_POINTS {
        let target = (i as f64 + 0.5) / SURFACE_POINTS as f64 * total;
        while triangle + 1 < areas.len() && below + areas[triangle] < target {
            below += areas[triangle];
            triangle += 1;
        }
        // Uniform on the triangle from two numbers of the R2 sequence.
        let u = (0.5 + i as f64 * 0.754_877_666_246_692_7).fract();
        let v = (0.5 + i as f64 * 0.569_840_290_998_053_3).fract();
        let s = u.sqrt();
        let (a, b) = (s * (1.0 - v), s * v);
        let normal = mesh.geometric_normal(triangle).normalize_or_zero();
        points.push((mesh.point(triangle, a, b), normal));
    }
    points
}

#[cfg(test)]
mod tests;
