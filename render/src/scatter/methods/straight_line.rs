//! The straight-line model ([H15] App. B.3): light from the light point reaches the camera point
//! `V` along the straight line `L → V`, crossing the object's boundary once without bending.
//!
//! Per camera point: the first boundary hit `X` from `V` toward `L` must be the object's own; the
//! light is attenuated over the inside part `‖X − V‖`, transmitted with the Fresnel factor of the
//! line's angle to the shading normal at `X` (as light arriving from the air), and spread as from a
//! point: `D = ‖L − V‖²`. A shadow ray runs from `X` to `L`. So
//! `C(t) = σ_s p(cos θ) T(X) I e^{−σ_t (t + ‖X − V‖)} / ‖L − V‖²`.
//!
//! There is **no η²** here: along an unbent line there is no solid-angle compression, and the
//! model then gives the correct irradiance in the limit of a camera point right under the surface
//! lit at normal incidence (`T I / d_L²`). At η = 1 the model is the exact single-scattering
//! integral (`T = 1`, `D = ‖L − V‖²`, physics.md §1.2), which is why `auto` uses it there.
//!
//! Camera points are drawn by *equiangular* sampling about the light point (the substitution
//! `t = x0 + h tan u` of physics.md §4), stratified in `u` into `M = samples_per_segment` strata
//! and jittered: for an isotropic, non-absorbing medium at η = 1 every sample is then exact.

use spindle_common::scene::SingleScatter;
use spindle_common::stats::RenderStats;

use crate::Rgb;
use crate::fresnel::reflectance;
use crate::ray::Ray;
use crate::sampler::Sampler;
use crate::scatter::methods::Equiangular;
use crate::scatter::methods::connect::Connection;

/// The straight-line estimate of the segment `[0, length]` lit by the connection's light point.
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
    let light = connection.light.position();
    let to_light = light - v;
    let distance = to_light.length();
    let Some(dir) = to_light.try_normalize() else {
        return Rgb::ZERO;
    };
    // Where the line leaves the object: the first boundary hit, which must be the object's own.
    stats.shadow_rays += 1;
    let Some(hit) = connection
        .scene
        .bvh()
        .closest_hit_within(&Ray::new(v, dir), distance)
    else {
        // No boundary between V and L (an open mesh, or a leak through an edge): nothing to cross.
        return Rgb::ZERO;
    };
    let (object, triangle) = connection.scene.locate(hit.triangle);
    if object != connection.object_index {
        return Rgb::ZERO;
    }
    let mesh = &connection.object.mesh;
    let x = mesh.point(triangle, hit.a, hit.b);
    let transmittance = if ends.eta == 1.0 {
        1.0
    } else {
        let cos = dir.dot(mesh.shading_normal(triangle, hit.a, hit.b));
        if cos <= 0.0 {
            return Rgb::ZERO;
        }
        1.0 - reflectance(cos, ends.eta)
    };
    let intensity = connection.light.intensity_toward(v);
    stats.samples += 1;
    if transmittance <= 0.0 || intensity.max_element() <= 0.0 {
        return Rgb::ZERO;
    }
    let outside = connection.light_transmittance(triangle, x, dir, stats);
    if outside.max_element() <= 0.0 {
        return Rgb::ZERO;
    }
    let medium = connection.medium;
    // Light propagates at V along −dir; the camera receives along −r̂: cos θ = (−dir)·(−r̂).
    let phase = medium.phase.eval(dir.dot(ends.dir));
    let inside = hit.t;
    let attenuation = (-(t + inside) * medium.sigma_t).exp();
    medium.sigma_s
        * outside
        * intensity
        * attenuation
        * (phase * transmittance / (distance * distance))
}
