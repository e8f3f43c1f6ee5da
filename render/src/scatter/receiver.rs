//! A diffuse surface inside a dielectric object's medium (the floor of a pool, a pebble in a glass
//! block), lit by the lights outside through the medium's boundary: the receiver connection of
//! [WZHB09] ("single scatter surface caustics"), with [H15]'s per-triangle solve and pruning.
//!
//! Why it exists: a shadow ray from such a point meets the boundary and is blocked (a dielectric
//! blocks shadow rays), so without this the surface would get only the lights inside its own
//! medium. Here the light reaches the receiver point `R` along every refracted path `L → X → R`,
//! `X` on the boundary mesh with `f(X) = 0` for `V = R` (physics.md §2): the sum over **every**
//! such `X`, a fold caustic's two bright branches included.
//!
//! How the refraction points are found: `R` is the end of the camera segment that reached it,
//! `V(t) = origin + t·dir`, `t_R = length`. The descent and the per-triangle search of the
//! interval method (`prune::descent`, `triangle::branches`) run on that segment, `[0, t_R]`, with
//! the same pruning; every monotone branch whose depth interval reaches `t_R` has exactly one
//! refraction point at `R`, solved at `t_R` from the branch's seeds and kept only on its branch.
//! `R` is a range end, as the segment's ends are for the interval method: a branch through it is
//! found by tracing the arc it lies on from the region's boundary (edges, the other range end,
//! interior lines), or by the solves at the range end. Searching on beyond `R` (so that a fold
//! just below it joins its two branches into one arc) found no refraction point more against a
//! brute-force search on the wavy pool and a coarse glass ball (`render/tests/receivers.rs`),
//! at 2 to 10 times the cost, so it is not done.
//!
//! What one path gives (physics.md §1.1, eq. 1, with the receiver in the role of V): the
//! irradiance across the path at `R`, inside the medium, is `T_P · I · η² · e^{−σ_t d_V} / D`
//! (`η²` of the étendue, cancelled by the camera throughput's `1/η²` when the path leaves the
//! medium toward the camera, which the transport applies); on the surface it is times
//! `cos θ_R = N̂_R·(X − R)/d_V`, and the radiance toward the camera is `ρ/π` of that. For a
//! beam of irradiance `E` through a flat interface onto a floor parallel to it, this is
//! `(1 − F(θ_i)) E cos θ_i e^{−σ_t d_V}`, the power crossing a unit of the interface
//! (`render/tests/receivers.rs` checks it). Visibility: the shadow ray from `X` to the light
//! (any surface blocks it, as for single scattering: one interface only) and the ray from `R`
//! to `X`, whose first hit must be `X`'s triangle.
//!
//! At η = 1 the boundary does not bend light and the solve is singular, so the straight path
//! `R → L` is taken: the first surface it meets must be the medium's own boundary, left outward,
//! and the rest of the way to the light must be clear.
//!
//! One light point per light and camera sample (`light_sample`, all of its apexes at `R`).
//! Lights inside the medium light the surface directly (the transport's shadow rays); lights in
//! the medium around it (the air, or the medium it is nested in) reach it through the boundary,
//! and a directional light in the air through the outer medium's flat faces too
//! (`connect::for_each_outside`); lights elsewhere would need a second interface and give nothing
//! here. Not modelled either: a
//! diffuse surface in the air behind a dielectric (a caustic on a table), which stays in the
//! glass's shadow.

use glam::DVec3;
use spindle_common::stats::RenderStats;

use crate::Rgb;
use crate::ray::{OFFSET_SCALE, Ray};
use crate::sampler::Sampler;
use crate::scatter::light_sample::{APEXES, Receivers, sample_light};
use crate::scatter::methods::connect::{Connection, for_each_outside};
use crate::scatter::methods::edge_scans::EdgeScans;
use crate::scatter::plan::object_bounds;
use crate::scatter::prune::descent::{DescentStack, for_each_candidate};
use crate::scatter::triangle::branches::triangle_intervals_with;
use crate::scatter::triangle::curve::Sign;
use crate::scatter::triangle::ends::DepthRange;
use crate::scatter::triangle::solve::{NewtonSettings, RefractionPath, solve_at};
use crate::scene::{Material, Scene};
use crate::segment::Segment;

/// Relative slack on distances compared along a visibility ray.
const DISTANCE_SLACK: f64 = 1e-7;

/// A point of a Lambertian surface that a camera path reached inside a medium.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Receiver {
    /// The point.
    pub p: DVec3,
    /// The unit shading normal, on the side the camera path arrived from.
    pub normal: DVec3,
    /// The unit geometric normal, on the same side.
    pub geometric: DVec3,
    /// The surface's reflectance ρ.
    pub reflectance: Rgb,
}

/// The radiance leaving `receiver` toward the camera, inside the medium of `segment.object`,
/// from every light outside the medium through the medium's boundary (one light point per
/// light). `segment` is the camera segment that ends on the receiver (`length` = its depth);
/// its throughput is not applied. Zero when the object is not a dielectric.
pub fn through_boundary(
    scene: &Scene,
    segment: &Segment,
    receiver: &Receiver,
    sampler: &mut Sampler,
    stats: &mut RenderStats,
) -> Rgb {
    let object = &scene.objects()[segment.object];
    let Material::Dielectric(dielectric) = object.material else {
        return Rgb::ZERO;
    };
    let Some(bounds) = object_bounds(object) else {
        return Rgb::ZERO;
    };
    let receivers = Receivers {
        object: bounds,
        apexes: [receiver.p; APEXES],
    };
    let mut stack = DescentStack::default();
    let mut scans = EdgeScans::default();
    let mut total = Rgb::ZERO;
    for (j, light) in scene.lights().iter().enumerate() {
        // Always draw the numbers, so later dimensions do not depend on what follows.
        let point = sample_light(light, receivers, sampler);
        if point.is_black() {
            continue;
        }
        for_each_outside(scene, segment.object, j, point, |light, outside| {
            let connection =
                Connection::along(scene, segment, dielectric.medium, j, light, outside);
            total += if connection.ends.eta == 1.0 {
                straight_irradiance(&connection, receiver, stats)
            } else {
                scans.clear();
                refracted_irradiance(
                    &connection,
                    segment.length,
                    receiver,
                    &mut scans,
                    &mut stack,
                    stats,
                )
            };
        });
    }
    debug_assert!(total.is_finite(), "receiver: {total}");
    total * receiver.reflectance / std::f64::consts::PI
}

/// The irradiance on the receiver (at depth `depth` of the connection's camera line) from the
/// connection's light point along every refracted path through the boundary.
fn refracted_irradiance(
    connection: &Connection<'_>,
    depth: f64,
    receiver: &Receiver,
    scans: &mut EdgeScans,
    stack: &mut DescentStack,
    stats: &mut RenderStats,
) -> Rgb {
    let settings = &connection.scene.integrator().single_scatter;
    let tolerance = settings.newton_tolerance;
    let ends = connection.ends;
    if !(depth.is_finite() && depth > 0.0) {
        return Rgb::ZERO;
    }
    let query = connection.query(DepthRange::new(0.0, depth));
    let beams = connection.beams();
    let mesh = &connection.object.mesh;
    let newton = NewtonSettings::new(tolerance, DepthRange::new(depth, depth));
    let mut sum = Rgb::ZERO;
    for_each_candidate(
        connection.object,
        &query,
        beams,
        &settings.pruning,
        stack,
        stats,
        |candidate, stats| {
            if !candidate.range.contains(depth) {
                return;
            }
            let Some(patch) = connection.patch(candidate.triangle) else {
                return;
            };
            let edge_scan = |edge| scans.scan(mesh, candidate.triangle, edge, &ends);
            // The cone test at the single point V(t), as the interval method does.
            let bounds = connection.object.bounds.triangle_at_slot(candidate.slot);
            let may_hold_at = |t: f64| match bounds.cone {
                Some(cone) if settings.pruning.cone => query
                    .with_range(DepthRange { lo: t, hi: t })
                    .triangle_may_contain(beams, candidate.slot, bounds.sphere, cone),
                _ => true,
            };
            let intervals = triangle_intervals_with(
                &patch,
                &ends,
                candidate.range,
                tolerance,
                edge_scan,
                may_hold_at,
                stats,
            );
            // One refraction point per branch through the receiver's depth.
            for interval in intervals.iter() {
                if !(interval.t_min <= depth && depth <= interval.t_max) {
                    continue;
                }
                let (path, spent) =
                    solve_at(&patch, &ends, depth, interval.seed_at(depth), &newton);
                stats.newton_iterations += u64::from(spent);
                match path.filter(|p| Sign::of(p.branch) == Some(interval.branch)) {
                    Some(path) => {
                        stats.samples += 1;
                        sum +=
                            path_irradiance(connection, candidate.triangle, &path, receiver, stats);
                    }
                    None => stats.newton_failures += 1,
                }
            }
        },
    );
    sum
}

/// The irradiance one refracted path `L → X → R` gives the receiver (module doc), or zero if it
/// arrives from behind the surface or is blocked.
fn path_irradiance(
    connection: &Connection<'_>,
    triangle: u32,
    path: &RefractionPath,
    receiver: &Receiver,
    stats: &mut RenderStats,
) -> Rgb {
    // ω_V points from X to R: the receiver looks along −ω_V.
    let toward = -path.omega_v;
    let cos_r = receiver.normal.dot(toward);
    if cos_r <= 0.0 || receiver.geometric.dot(toward) <= 0.0 {
        return Rgb::ZERO;
    }
    let intensity = connection.light.intensity_toward(path.p);
    if intensity.max_element() <= 0.0 {
        return Rgb::ZERO;
    }
    let outside = connection.light_transmittance(triangle as usize, path.p, path.omega_l, stats);
    if outside.max_element() <= 0.0
        || !sees_boundary_point(connection, triangle as usize, receiver, path.p, stats)
    {
        return Rgb::ZERO;
    }
    let eta = connection.ends.eta;
    let scalar = path.fresnel_t * eta * eta * cos_r / path.d_factor;
    outside * intensity * connection.medium.transmittance(path.d_v) * scalar
}

/// The ray from the receiver to `x` on the object's triangle `triangle` meets nothing before
/// `x`: its first hit is that triangle, or lies no nearer than `x`.
fn sees_boundary_point(
    connection: &Connection<'_>,
    triangle: usize,
    receiver: &Receiver,
    x: DVec3,
    stats: &mut RenderStats,
) -> bool {
    stats.shadow_rays += 1;
    let scene = connection.scene;
    let Some(dir) = (x - receiver.p).try_normalize() else {
        return true;
    };
    let ray = Ray::leaving(receiver.p, receiver.geometric, dir, scene.scale());
    let distance = (x - ray.origin).dot(dir);
    let slack = DISTANCE_SLACK * distance + OFFSET_SCALE * scene.scale();
    match scene.bvh().closest_hit_within(&ray, distance + slack) {
        None => true,
        Some(hit) => {
            hit.t >= distance - slack
                || scene.locate(hit.triangle) == (connection.object_index, triangle)
        }
    }
}

/// At η = 1: the irradiance along the straight path from the receiver to the light point, which
/// must leave the medium through its own boundary and meet nothing else on the way.
fn straight_irradiance(
    connection: &Connection<'_>,
    receiver: &Receiver,
    stats: &mut RenderStats,
) -> Rgb {
    let scene = connection.scene;
    let light = connection.light.position();
    let Some(dir) = (light - receiver.p).try_normalize() else {
        return Rgb::ZERO;
    };
    let cos_r = receiver.normal.dot(dir);
    if cos_r <= 0.0 || receiver.geometric.dot(dir) <= 0.0 {
        return Rgb::ZERO;
    }
    // The first surface toward the light: the medium's boundary, crossed outward.
    stats.shadow_rays += 1;
    let ray = Ray::leaving(receiver.p, receiver.geometric, dir, scene.scale());
    let Some(hit) = scene.bvh().closest_hit(&ray) else {
        return Rgb::ZERO;
    };
    let (object, triangle) = scene.locate(hit.triangle);
    let mesh = &connection.object.mesh;
    if object != connection.object_index || mesh.geometric_normal(triangle).dot(dir) <= 0.0 {
        return Rgb::ZERO;
    }
    let x = ray.at(hit.t);
    let outside = connection.light_transmittance(triangle, x, dir, stats);
    if outside.max_element() <= 0.0 {
        return Rgb::ZERO;
    }
    let intensity = connection.light.intensity_toward(receiver.p);
    let distance2 = light.distance_squared(receiver.p);
    outside
        * intensity
        * connection.medium.transmittance(x.distance(receiver.p))
        * (cos_r / distance2)
}
