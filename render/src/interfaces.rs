//! Light that would have to cross a second dielectric interface to reach a medium: found per
//! object and light when the scene is built, so the plan, the log and the EXR header can say it.
//!
//! Single scattering here follows light through **one** refractive interface ([H15]'s model),
//! the object's own, from a light in the medium around it (`nesting::Route::Around`) — plus,
//! exactly, a directional light entering the medium around a nested object through that
//! medium's flat faces (`Route::FlatFaces`, `flat_face`). Where another dielectric object lies
//! on the way (a second glass sphere between the light and the first, a jade bunny under a wavy
//! water surface), the path is blocked by the shadow ray, not refracted twice: that light is
//! missing from the image. This module measures how much of each object's lit surface is
//! affected, so the loss is never silent.
//!
//! The share is estimated from [`SURFACE_POINTS`] points spread over the object's surface by
//! area (deterministically): of the points whose front faces the light, the fraction whose path
//! to it — the straight line to the light's centre, or the line toward each flat face's refracted
//! sun and on from the face to the sun — meets another dielectric first. A light that reaches a
//! nested object by no modelled route at all (a point light above the water) is reported with the
//! whole surface affected.

use glam::DVec3;

use crate::flat_face::{FlatFaces, through_face};
use crate::light::Light;
use crate::nesting::{Route, absolute_eta, route};
use crate::ray::Ray;
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

/// Where the lights are with respect to the media, as `Scene::build` found it.
#[derive(Debug, Clone, Copy)]
pub struct Layout<'a> {
    pub lights: &'a [Light],
    /// Per light, the medium holding it.
    pub light_media: &'a [Option<usize>],
    /// Per object, the medium around it (`nesting::outer_media`).
    pub outer: &'a [Option<usize>],
    /// Per object, its flat faces (found for objects with a dielectric inside).
    pub flat_faces: &'a [FlatFaces],
}

/// Every (dielectric object, light outside its medium) pair whose light crosses another
/// dielectric on its way to some of the object's surface. A light in a medium that is neither
/// the object's nor the one around it is not listed (the plan says it gives nothing there).
pub fn second_interfaces(objects: &[Object], layout: &Layout<'_>) -> Vec<SecondInterface> {
    let dielectric = |o: &Object| matches!(o.material, Material::Dielectric(_));
    let mut found = Vec::new();
    if objects.iter().filter(|o| dielectric(o)).count() < 2 {
        // Nothing else can be in the way.
        return found;
    }
    for (o, object) in objects.iter().enumerate().filter(|(_, o)| dielectric(o)) {
        let points = surface_points(object);
        for (j, light) in layout.lights.iter().enumerate() {
            let light_medium = layout.light_media[j];
            let paths = match route(o, light, light_medium, layout.outer, layout.flat_faces) {
                Route::Inside => continue,
                Route::Around => Paths::Straight(light.center()),
                Route::FlatFaces { outer } => {
                    let Light::Directional { direction, .. } = *light else {
                        continue;
                    };
                    let eta = absolute_eta(objects, Some(outer));
                    let faces = &layout.flat_faces[outer];
                    Paths::Faces {
                        outer,
                        faces,
                        toward_air: -direction,
                        refracted: faces
                            .faces
                            .iter()
                            .map(|f| {
                                through_face(f, -direction, eta).map(|r| r.toward_light_inside)
                            })
                            .collect(),
                    }
                }
                Route::Unmodelled if light_medium.is_none() => {
                    if let Some(q) = layout.outer[o] {
                        found.push(SecondInterface {
                            object: o,
                            light: j,
                            blockers: vec![q],
                            share: 1.0,
                        });
                    }
                    continue;
                }
                Route::Unmodelled => continue,
            };
            let mut facing = 0usize;
            let mut blocked = 0usize;
            let mut blockers = Vec::new();
            for &(p, normal) in &points {
                match paths.reach(objects, o, p, normal) {
                    Reach::Away => {}
                    Reach::Clear => facing += 1,
                    Reach::Blocked(by) => {
                        facing += 1;
                        blocked += 1;
                        for k in by {
                            if !blockers.contains(&k) {
                                blockers.push(k);
                            }
                        }
                    }
                }
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

/// The paths from an object's surface to one light.
enum Paths<'a> {
    /// Straight lines to the light's centre.
    Straight(DVec3),
    /// Lines toward each flat face's refracted sun (`refracted[f]`, if it enters through face
    /// `f`), then on from the face toward the sun.
    Faces {
        outer: usize,
        faces: &'a FlatFaces,
        toward_air: DVec3,
        refracted: Vec<Option<DVec3>>,
    },
}

/// What a surface point's paths to a light meet.
enum Reach {
    /// The point faces away from the light.
    Away,
    /// A path reaches the light with no other dielectric in the way.
    Clear,
    /// Every path facing the light meets these dielectrics first.
    Blocked(Vec<usize>),
}

impl Paths<'_> {
    fn reach(&self, objects: &[Object], o: usize, p: DVec3, normal: DVec3) -> Reach {
        let dielectric =
            |k: usize| k != o && matches!(objects[k].material, Material::Dielectric(_));
        let blockers_on = |from: DVec3, dir: DVec3, distance: f64, except: usize| -> Vec<usize> {
            (0..objects.len())
                .filter(|&k| dielectric(k) && k != except)
                .filter(|&k| objects[k].bvh.any_hit(from, dir, distance))
                .collect()
        };
        match self {
            Paths::Straight(light) => {
                let to_light = *light - p;
                if normal.dot(to_light) <= 0.0 {
                    return Reach::Away;
                }
                let distance = to_light.length();
                let by = blockers_on(p, to_light / distance, distance, o);
                if by.is_empty() {
                    Reach::Clear
                } else {
                    Reach::Blocked(by)
                }
            }
            Paths::Faces {
                outer,
                faces,
                toward_air,
                refracted,
            } => {
                let mut facing = false;
                let mut all = Vec::new();
                for (f, dir) in refracted.iter().enumerate() {
                    let Some(dir) = *dir else { continue };
                    if normal.dot(dir) <= 0.0 {
                        continue;
                    }
                    let Some(exit) = objects[*outer].bvh.closest_hit(&Ray::new(p, dir)) else {
                        continue;
                    };
                    match faces.face_of(exit.triangle as usize) {
                        Some(g) if g == f => facing = true,
                        // Toward another flat face: no light comes from there along this
                        // direction (the rays that would have entered through `f` do not reach
                        // `p`), so this direction is not the light's.
                        Some(_) => continue,
                        // Out through a curved part of the surface: light arrives there through
                        // an interface that is not modelled.
                        None => {
                            facing = true;
                            all.push(*outer);
                            continue;
                        }
                    }
                    let mut by = blockers_on(p, dir, exit.t, *outer);
                    let x = p + exit.t * dir;
                    by.extend(blockers_on(x, *toward_air, f64::INFINITY, *outer));
                    if by.is_empty() {
                        return Reach::Clear;
                    }
                    all.extend(by);
                }
                if facing {
                    Reach::Blocked(all)
                } else {
                    Reach::Away
                }
            }
        }
    }
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
