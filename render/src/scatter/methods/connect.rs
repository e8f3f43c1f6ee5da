//! The connection of one camera segment to one light point: what every single-scattering method
//! shares once it has a solved refraction path — the two visibility tests and the contribution.
//!
//! Visibility ([H15] shoots only the shadow ray; physics.md §1.1 adds the second test for
//! non-convex objects):
//! * a shadow ray from `P` to the light point against the whole scene (any other surface,
//!   dielectric or not, blocks it: single scattering follows one refraction only);
//! * the camera point `V` must see `P` from inside the object: the first surface hit from `V`
//!   toward `P` is `P`'s own triangle (or lies no nearer than `P`, where `P` sits on an edge).
//!
//! Both rays are counted in `RenderStats::shadow_rays`.

use glam::DVec3;
use spindle_common::stats::RenderStats;

use crate::Rgb;
use crate::medium::Medium;
use crate::ray::{OFFSET_SCALE, Ray};
use crate::scatter::light_sample::LightPoint;
use crate::scatter::prune::beam_table::BeamTable;
use crate::scatter::triangle::contribution::path_contribution;
use crate::scatter::triangle::ends::PathEnds;
use crate::scatter::triangle::solve::RefractionPath;
use crate::scene::{Object, Scene};

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
    /// The object's beams for this light point, if the scene tabled them (see
    /// [`BeamTable`]); [`Connection::beams`] checks they serve `ends`.
    pub beam_table: Option<&'a BeamTable>,
}

impl Connection<'_> {
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
        if !self.light_reaches(triangle as usize, path.p, path.omega_l, stats) {
            return Rgb::ZERO;
        }
        let v = self.ends.camera_point(path.t);
        if !self.inside_reaches(triangle, v, path.p, stats) {
            return Rgb::ZERO;
        }
        path_contribution(path, &self.ends, &self.medium, intensity, ln_weight)
    }

    /// The shadow ray from `p` on the object's triangle `triangle`, leaving in direction
    /// `to_light` (unit), reaches the light point unblocked.
    pub fn light_reaches(
        &self,
        triangle: usize,
        p: DVec3,
        to_light: DVec3,
        stats: &mut RenderStats,
    ) -> bool {
        stats.shadow_rays += 1;
        let normal = self.object.mesh.geometric_normal(triangle);
        let ray = Ray::leaving(p, normal, to_light, self.scene.scale());
        let distance =
            (self.light.position() - ray.origin).dot(to_light) - self.light.emitter_gap(-to_light);
        !self.scene.bvh().any_hit(ray.origin, to_light, distance)
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
