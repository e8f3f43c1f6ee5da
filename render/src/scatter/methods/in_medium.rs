//! A light inside the segment's own medium: no interface lies between the light point and a
//! scattering point, so the connection is the straight line `V → L` through the medium — the
//! cheapest case there is, and the airlight integral of physics.md §4 with attenuation along the
//! whole path:
//!
//! `C(t) = σ_s p(cos θ) I e^{−σ_t (t + ‖L − V‖)} / ‖L − V‖²`, visible when nothing lies between
//! V and L.
//!
//! No Fresnel factor and no η²: light that crosses no interface keeps its étendue. Camera points
//! are drawn by equiangular sampling about the light, stratified into
//! `M = samples_per_segment` strata and jittered, as the straight-line model does.

use spindle_common::scene::SingleScatter;
use spindle_common::stats::RenderStats;

use crate::Rgb;
use crate::ray::OFFSET_SCALE;
use crate::sampler::Sampler;
use crate::scatter::methods::Equiangular;
use crate::scatter::methods::connect::Connection;

/// The estimate of the segment `[0, length]` lit by a light point inside its medium.
pub fn estimate(
    connection: &Connection<'_>,
    length: f64,
    settings: &SingleScatter,
    sampler: &mut Sampler,
    stats: &mut RenderStats,
) -> Rgb {
    Equiangular::new(&connection.ends, length).estimate(
        settings.samples_per_segment,
        sampler,
        |t| point_radiance(connection, t, stats),
    )
}

/// `C(t)` of the module doc at the camera point `V(t)`.
fn point_radiance(connection: &Connection<'_>, t: f64, stats: &mut RenderStats) -> Rgb {
    let ends = connection.ends;
    let v = ends.camera_point(t);
    let to_light = ends.light - v;
    let distance = to_light.length();
    let Some(dir) = to_light.try_normalize() else {
        return Rgb::ZERO;
    };
    stats.samples += 1;
    let intensity = connection.light.intensity_toward(v);
    if intensity.max_element() <= 0.0 {
        return Rgb::ZERO;
    }
    // Nothing may lie between V and L; a surface at L itself (a light on the boundary) does not
    // block it.
    stats.shadow_rays += 1;
    let slack = OFFSET_SCALE * connection.scene.scale();
    let reach = distance - slack;
    if reach > 0.0 && connection.scene.bvh().any_hit(v, dir, reach) {
        return Rgb::ZERO;
    }
    let medium = connection.medium;
    // Light propagates at V along −dir; the camera receives along −r̂: cos θ = dir·r̂.
    let phase = medium.phase.eval(dir.dot(ends.dir));
    let attenuation = (-(t + distance) * medium.sigma_t).exp();
    medium.sigma_s * intensity * attenuation * (phase / (distance * distance))
}
