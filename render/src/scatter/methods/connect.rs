//! The connection of one camera segment to one light point: what every single-scattering method
//! shares once it has a solved refraction path — the two visibility tests and the contribution.
//!
//! Visibility ([H15] shoots only the shadow ray; physics.md §1.1 adds the second test for
//! non-convex objects):
//! * a shadow ray from `P` to the light point against the whole scene (any other surface,
//!   dielectric or not, blocks it: single scattering follows one refraction only), through the
//!   medium around the object ([`Outside`]): the air, the medium it is nested in (attenuated
//!   from `P` to the light), or — for a directional light entering that medium through one of its
//!   flat faces (`flat_face`) — up to that face, attenuated, and on from the face to the sun;
//! * the camera point `V` must see `P` from inside the object: the first surface hit from `V`
//!   toward `P` is `P`'s own triangle (or lies no nearer than `P`, where `P` sits on an edge).
//!
//! Both rays are counted in `RenderStats::shadow_rays`.

use glam::DVec3;
use spindle_common::stats::RenderStats;

use crate::Rgb;
use crate::flat_face::through_face;
use crate::light::Light;
use crate::medium::Medium;
use crate::nesting::Route;
use crate::ray::{OFFSET_SCALE, Ray};
use crate::scatter::light_sample::LightPoint;
use crate::scatter::prune::beam_table::BeamTable;
use crate::scatter::triangle::contribution::path_contribution;
use crate::scatter::triangle::ends::PathEnds;
use crate::scatter::triangle::solve::RefractionPath;
use crate::scene::{Material, Object, Scene};
use crate::segment::Segment;

/// What lies between the object's surface and the light point: the medium around the object.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Outside {
    /// The light point is in the medium around the object, seen along a straight line: the air
    /// (`None`), or the medium the object is nested in, which attenuates the light.
    Straight(Option<Medium>),
    /// The light point is a directional light refracted through flat face `face` of the outer
    /// object `outer` (`flat_face::through_face`): the shadow ray must leave through that face,
    /// attenuated by `medium` on the way, and beyond it the sun lies toward `toward_air`.
    Face {
        outer: usize,
        face: usize,
        medium: Medium,
        toward_air: DVec3,
    },
}

/// Relative slack on distances compared along a visibility ray.
const DISTANCE_SLACK: f64 = 1e-7;

/// One camera segment of one object connected to one light point.
#[derive(Debug, Clone, Copy)]
pub struct Connection<'a> {
    pub scene: &'a Scene,
    /// Index of the object in `scene.objects()`.
    pub object_index: usize,
    pub object: &'a Object,
    pub ends: PathEnds,
    pub medium: Medium,
    pub light: LightPoint,
    /// How the light point is reached from the object's surface.
    pub outside: Outside,
    /// The object's beams for this light point, if the scene tabled them (see
    /// [`BeamTable`]); [`Connection::beams`] checks they serve `ends`.
    pub beam_table: Option<&'a BeamTable>,
}

impl<'a> Connection<'a> {
    /// The connection of the camera segment `segment` (inside the medium `medium` of its
    /// object) to the light point `light` of `lights[light_index]`, reached as `outside` says;
    /// the index across the object's surface is its relative one (`Scene::relative_eta`).
    pub fn along(
        scene: &'a Scene,
        segment: &Segment,
        medium: Medium,
        light_index: usize,
        light: LightPoint,
        outside: Outside,
    ) -> Self {
        Connection {
            scene,
            object_index: segment.object,
            object: &scene.objects()[segment.object],
            ends: PathEnds {
                origin: segment.origin,
                dir: segment.dir,
                light: light.position(),
                eta: scene.relative_eta(segment.object),
            },
            medium,
            light,
            outside,
            beam_table: scene.beam_table(segment.object, light_index),
        }
    }

    /// The radiance per unit length of the segment that the solved path `path` on the object's
    /// triangle `triangle` sends toward the camera at `V(path.t)` (physics.md eq. 2, with the
    /// η² of eq. 1 and without `T(V_min)`, see `contribution`), times the sample weight
    /// `e^{ln_weight}`, or zero if it is blocked.
    pub fn path_radiance(
        &self,
        triangle: u32,
        path: &RefractionPath,
        ln_weight: Rgb,
        stats: &mut RenderStats,
    ) -> Rgb {
        let intensity = self.light.intensity_toward(path.p);
        if intensity.max_element() <= 0.0 {
            return Rgb::ZERO;
        }
        let outside = self.light_transmittance(triangle as usize, path.p, path.omega_l, stats);
        if outside.max_element() <= 0.0 {
            return Rgb::ZERO;
        }
        let v = self.ends.camera_point(path.t);
        if !self.inside_reaches(triangle, v, path.p, stats) {
            return Rgb::ZERO;
        }
        outside * path_contribution(path, &self.ends, &self.medium, intensity, ln_weight)
    }

    /// What of the light point's light reaches `p` on the object's triangle `triangle` from the
    /// direction `to_light` (unit) through the medium around the object ([`Outside`]): zero if
    /// the shadow ray is blocked, else the transmittance of the medium around (1 in the air).
    pub fn light_transmittance(
        &self,
        triangle: usize,
        p: DVec3,
        to_light: DVec3,
        stats: &mut RenderStats,
    ) -> Rgb {
        stats.shadow_rays += 1;
        let scene = self.scene;
        let normal = self.object.mesh.geometric_normal(triangle);
        let ray = Ray::leaving(p, normal, to_light, scene.scale());
        match self.outside {
            Outside::Straight(medium) => {
                let distance = (self.light.position() - ray.origin).dot(to_light)
                    - self.light.emitter_gap(-to_light);
                if scene.bvh().any_hit(ray.origin, to_light, distance) {
                    return Rgb::ZERO;
                }
                medium.map_or(Rgb::ONE, |m| m.transmittance(distance.max(0.0)))
            }
            Outside::Face {
                outer,
                face,
                medium,
                toward_air,
            } => {
                let Some(exit) = scene.bvh().closest_hit(&ray) else {
                    return Rgb::ZERO;
                };
                let (object, exit_triangle) = scene.locate(exit.triangle);
                if object != outer || scene.flat_faces(outer).face_of(exit_triangle) != Some(face) {
                    return Rgb::ZERO;
                }
                stats.shadow_rays += 1;
                let face_normal = scene.objects()[outer].mesh.geometric_normal(exit_triangle);
                let beyond = Ray::leaving(ray.at(exit.t), face_normal, toward_air, scene.scale());
                if scene
                    .bvh()
                    .any_hit(beyond.origin, toward_air, f64::INFINITY)
                {
                    return Rgb::ZERO;
                }
                medium.transmittance(exit.t)
            }
        }
    }

    /// The camera point `v` sees `p`, on the object's triangle `triangle`, from inside the
    /// object: nothing of the scene lies strictly between them.
    pub fn inside_reaches(
        &self,
        triangle: u32,
        v: DVec3,
        p: DVec3,
        stats: &mut RenderStats,
    ) -> bool {
        stats.shadow_rays += 1;
        let offset = v - p;
        let d_v = offset.length();
        let Some(dir) = (-offset).try_normalize() else {
            return true;
        };
        let slack = DISTANCE_SLACK * d_v + OFFSET_SCALE * self.scene.scale();
        match self
            .scene
            .bvh()
            .closest_hit_within(&Ray::new(v, dir), d_v + slack)
        {
            // No hit at all: the ray slipped through the crack of an edge at P itself.
            None => true,
            Some(hit) => {
                hit.t >= d_v - slack
                    || self.scene.locate(hit.triangle) == (self.object_index, triangle as usize)
            }
        }
    }
}

/// Calls `each(point, outside)` for every light point through which `point`, a sample of
/// `lights[light]`, reaches object `o`'s surface from outside: the sample itself, in the medium
/// around the object (`Route::Around`), or its refraction through each flat face of the medium
/// around that faces it (`Route::FlatFaces`). Nothing for a light inside the object's medium
/// (the caller's straight paths) or one that reaches it by no modelled route.
pub fn for_each_outside(
    scene: &Scene,
    o: usize,
    light: usize,
    point: LightPoint,
    mut each: impl FnMut(LightPoint, Outside),
) {
    let medium_of = |q: usize| match scene.objects()[q].material {
        Material::Dielectric(d) => Some(d.medium),
        Material::Diffuse { .. } => None,
    };
    match scene.route(o, light) {
        Route::Around => each(point, Outside::Straight(scene.outer(o).and_then(medium_of))),
        Route::FlatFaces { outer } => {
            let (
                Light::Directional {
                    anchor, distance, ..
                },
                LightPoint::Distant {
                    position,
                    irradiance,
                },
                Some(medium),
            ) = (&scene.lights()[light], point, medium_of(outer))
            else {
                return;
            };
            let Some(toward_air) = (position - *anchor).try_normalize() else {
                return;
            };
            let eta = scene.relative_eta(outer);
            for (face, plane) in scene.flat_faces(outer).faces.iter().enumerate() {
                let Some(refracted) = through_face(plane, toward_air, eta) else {
                    continue;
                };
                let inside = LightPoint::Distant {
                    position: *anchor + refracted.toward_light_inside * *distance,
                    irradiance: irradiance * refracted.factor,
                };
                each(
                    inside,
                    Outside::Face {
                        outer,
                        face,
                        medium,
                        toward_air,
                    },
                );
            }
        }
        Route::Inside | Route::Unmodelled => {}
    }
}
