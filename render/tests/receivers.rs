//! A diffuse surface inside a medium, lit through the medium's boundary (`scatter::receiver`),
//! against ground truths that do not use the renderer's distance factor D or its η²
//! bookkeeping: energy conservation across a flat interface under the sun, the exact refraction
//! point of a flat interface for a point light (physics.md §5) with the irradiance from the
//! solid angle the light's rays spread over, and light traced forward from the sun through a
//! wavy surface and splatted on a patch of the floor.

mod support;

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;
use serde_json::{Value, json};
use spindle_common::stats::RenderStats;
use spindle_render::ray::Ray;
use spindle_render::sampler::Sampler;
use spindle_render::scatter::receiver::{Receiver, through_boundary};
use spindle_render::scatter::triangle::ends::PathEnds;
use spindle_render::scatter::triangle::patch::TrianglePatch;
use spindle_render::scatter::triangle::solve::solve_all_at;
use spindle_render::segment::Segment;
use spindle_render::transport::radiance;
use spindle_render::{Assets, Rgb, Scene};
use support::box_obj;

const ETA: f64 = 1.33;
const RHO: f64 = 0.6;

fn scene(objects: Value, lights: Value, assets: Assets) -> Scene {
    let scene = json!({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 10},
        "film": {"width": 4, "height": 4, "spp": 1},
        "lights": lights,
        "objects": objects,
    });
    let desc = serde_json::from_value(scene).expect("test scene parses");
    Scene::build(&desc, &assets).expect("test scene builds")
}

/// A water box (top at z = 0, flat) with a diffuse floor box inside it whose top is at z = −1.
fn pool(sigma_t: f64, lights: Value) -> Scene {
    pool_of_index(ETA, sigma_t, lights)
}

/// [`pool`] with the medium's index `eta`.
fn pool_of_index(eta: f64, sigma_t: f64, lights: Value) -> Scene {
    let water = box_obj(
        DVec3::new(-20.0, -20.0, -2.0),
        DVec3::new(20.0, 20.0, 0.0),
        false,
    );
    let floor = box_obj(
        DVec3::new(-10.0, -10.0, -1.5),
        DVec3::new(10.0, 10.0, -1.0),
        false,
    );
    scene(
        json!([
            {"shape": {"type": "obj", "path": "water.obj"},
             "material": {"type": "dielectric", "eta": eta, "medium": {
                 "sigma_t": [sigma_t, sigma_t, sigma_t], "albedo": [0.5, 0.5, 0.5]}}},
            {"shape": {"type": "obj", "path": "floor.obj"},
             "material": {"type": "diffuse", "reflectance": [RHO, RHO, RHO]}}
        ]),
        lights,
        Assets::from([
            ("water.obj".to_string(), water.into_bytes()),
            ("floor.obj".to_string(), floor.into_bytes()),
        ]),
    )
}

/// Unpolarised Fresnel reflectance from air onto index `eta` at incidence cosine `c`, written
/// out here so the ground truths do not lean on the renderer's own.
fn fresnel_air_to(eta: f64, c: f64) -> f64 {
    let s = (1.0 - c * c).sqrt() / eta;
    let ct = (1.0 - s * s).sqrt();
    let rs = (c - eta * ct) / (c + eta * ct);
    let rp = (eta * c - ct) / (eta * c + ct);
    0.5 * (rs * rs + rp * rp)
}

/// The cosine of the refracted angle below a flat interface for incidence cosine `c`.
fn cos_refracted(eta: f64, c: f64) -> f64 {
    let s = (1.0 - c * c).sqrt() / eta;
    (1.0 - s * s).sqrt()
}

/// The camera segment from the point `entry` of the water's surface toward `receiver`, as the
/// transport makes it (its origin pushed off the surface), and the receiver on the floor's top.
fn floor_segment(scene: &Scene, entry: DVec3, receiver: DVec3) -> (Segment, Receiver) {
    let dir = (receiver - entry).normalize();
    let origin = Ray::leaving(entry, DVec3::Z, dir, scene.scale()).origin;
    let segment = Segment {
        origin,
        dir,
        length: receiver.distance(origin),
        object: 0,
        throughput: Rgb::ONE,
    };
    let receiver = Receiver {
        p: receiver,
        normal: DVec3::Z,
        geometric: DVec3::Z,
        reflectance: Rgb::splat(RHO),
    };
    (segment, receiver)
}

/// What the floor point `on_floor` receives through the boundary (`ρ/π` of its irradiance),
/// seen along the camera segment from the surface point `entry`, and the statistics.
fn light_on_floor(
    scene: &Scene,
    entry: DVec3,
    on_floor: DVec3,
    mut sampler: Sampler,
) -> (Rgb, RenderStats) {
    let (segment, receiver) = floor_segment(scene, entry, on_floor);
    let mut stats = RenderStats::default();
    let value = through_boundary(scene, &segment, &receiver, &mut sampler, &mut stats);
    (value, stats)
}

/// The sun (parallel rays of irradiance `E`) over a flat water surface: the power crossing a
/// unit of the interface is `(1 − F(θ_i)) E cos θ_i`, and a floor parallel to it receives that,
/// attenuated by `e^{−σ_t d/cos θ_t}` at depth d. The floor's radiance is `ρ/π` of it: through
/// the receiver connection alone (one refraction point per receiver, exactly), and through the
/// whole camera path, whose throughput into the water is `(1 − F(θ_c))/η² e^{−σ_t d/cos θ_tc}`.
#[test]
fn the_sun_through_a_flat_surface_lights_the_floor_as_energy_conservation_says() {
    let e = 2.0;
    let mut worst: f64 = 0.0;
    for sun in [
        DVec3::new(0.0, 0.0, -1.0),
        DVec3::new(0.3, 0.2, -1.0),
        DVec3::new(1.0, 0.45, -0.8),
    ] {
        for sigma in [0.0, 0.5, 3.0] {
            let scene = pool(
                sigma,
                json!([{"type": "directional", "direction": sun.to_array(),
                        "irradiance": [e, e, e]}]),
            );
            let cos_i = -sun.normalize().z;
            let cos_t = cos_refracted(ETA, cos_i);
            let e_floor = (1.0 - fresnel_air_to(ETA, cos_i)) * e * cos_i * (-sigma / cos_t).exp();
            let truth = RHO / PI * e_floor;
            for camera in [DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.2, 0.1, -1.0)] {
                let camera = camera.normalize();
                // The camera ray's refraction into the water, by Snell's law.
                let cos_c = -camera.z;
                let cos_tc = cos_refracted(ETA, cos_c);
                let horizontal = DVec3::new(camera.x, camera.y, 0.0) / ETA;
                let inside = horizontal - DVec3::Z * cos_tc;
                let entry = DVec3::new(0.31, -0.17, 0.0);
                let on_floor = entry + inside * (1.0 / cos_tc);

                // The receiver connection alone.
                let (value, stats) =
                    light_on_floor(&scene, entry, on_floor, Sampler::new(7, 1, 2, 0));
                let error = value.x / truth - 1.0;
                println!(
                    "sun {sun}, σt {sigma}, camera {camera}: receiver {:.8e} vs {truth:.8e} \
                     ({error:+.2e}), {} refraction point(s)",
                    value.x, stats.samples
                );
                assert_eq!(stats.samples, 1, "one refraction point per receiver");
                worst = worst.max(error.abs());

                // The whole camera path.
                let throughput =
                    (1.0 - fresnel_air_to(ETA, cos_c)) / (ETA * ETA) * (-sigma / cos_tc).exp();
                let ray = Ray::new(entry - camera * (3.0 / cos_c), camera);
                let mut stats = RenderStats::default();
                let mut sampler = Sampler::new(7, 1, 2, 0);
                let seen = radiance(&scene, &ray, &mut sampler, &mut stats);
                let error = seen.surface.x / (throughput * truth) - 1.0;
                println!(
                    "    camera path: surface {:.8e} vs {:.8e} ({error:+.2e})",
                    seen.surface.x,
                    throughput * truth
                );
                worst = worst.max(error.abs());
            }
        }
    }
    // The sun's far point lies d_L = 1e4 scene radii away (2.8e5 here): its rays, parallel at
    // the surface's scale, spread below it over d_V ≈ 1.5 by about 2 d_V/(η d_L) ≈ 1e-5 (measured:
    // at most 1.2e-5).
    println!("worst relative error {worst:.2e}");
    assert!(worst < 2e-5, "worst relative error {worst}");
}

/// The pool of the test above built from `box` shapes instead of OBJ files (the water
/// 40 × 40 × 2 and the floor 20 × 20 × 0.5, turned z-up): the same closed form, through the
/// receiver connection, so the box's faces, normals and winding are what the OBJ boxes' are.
#[test]
fn a_pool_of_box_shapes_lights_its_floor_as_energy_conservation_says() {
    let e = 2.0;
    let mut worst: f64 = 0.0;
    for sun in [DVec3::new(0.0, 0.0, -1.0), DVec3::new(1.0, 0.45, -0.8)] {
        for sigma in [0.0, 0.5] {
            let scene = scene(
                json!([
                    {"shape": {"type": "box", "size": [40, 2, 40]},
                     "transform": {"rotate_deg": [90, 0, 0], "translate": [0, 0, -1]},
                     "material": {"type": "dielectric", "eta": ETA, "medium": {
                         "sigma_t": [sigma, sigma, sigma], "albedo": [0.5, 0.5, 0.5]}}},
                    {"shape": {"type": "box", "size": [20, 0.5, 20]},
                     "transform": {"rotate_deg": [90, 0, 0], "translate": [0, 0, -1.25]},
                     "material": {"type": "diffuse", "reflectance": [RHO, RHO, RHO]}}
                ]),
                json!([{"type": "directional", "direction": sun.to_array(),
                        "irradiance": [e, e, e]}]),
                Assets::new(),
            );
            let cos_i = -sun.normalize().z;
            let cos_t = cos_refracted(ETA, cos_i);
            let truth =
                RHO / PI * (1.0 - fresnel_air_to(ETA, cos_i)) * e * cos_i * (-sigma / cos_t).exp();
            for on_floor in [DVec3::new(0.3, -0.2, -1.0), DVec3::new(-4.0, 6.5, -1.0)] {
                let entry = on_floor + DVec3::new(0.1, 0.05, 1.0);
                let (value, stats) =
                    light_on_floor(&scene, entry, on_floor, Sampler::new(7, 1, 2, 0));
                let error = value.x / truth - 1.0;
                println!(
                    "sun {sun}, σt {sigma}, floor {on_floor}: {:.8e} vs {truth:.8e} ({error:+.2e})",
                    value.x
                );
                assert_eq!(stats.samples, 1, "one refraction point per receiver");
                worst = worst.max(error.abs());
            }
        }
    }
    println!("worst relative error {worst:.2e}");
    assert!(worst < 2e-5, "worst relative error {worst}");
}

/// At η = 1 the boundary bends nothing and reflects nothing: the floor under the sun gets
/// `E cos θ e^{−σ_t d/cos θ}`, from the straight path (and through a point light's, `I cos θ
/// e^{−σ_t d/cos θ} / r²`).
#[test]
fn an_index_matched_medium_lights_its_floor_along_the_straight_path() {
    let mut worst: f64 = 0.0;
    for sigma in [0.0, 0.7] {
        let sun = DVec3::new(0.4, -0.3, -1.0);
        let light = DVec3::new(0.9, 0.2, 2.0);
        for (lights, truth_at) in [
            (
                json!([{"type": "directional", "direction": sun.to_array(),
                        "irradiance": [2, 2, 2]}]),
                Box::new(move |r: DVec3| {
                    let cos = -sun.normalize().z;
                    2.0 * cos * (-sigma * (-r.z) / cos).exp()
                }) as Box<dyn Fn(DVec3) -> f64>,
            ),
            (
                json!([{"type": "point", "position": light.to_array(),
                        "intensity": [3, 3, 3]}]),
                Box::new(move |r: DVec3| {
                    let to = light - r;
                    let cos = to.normalize().z;
                    3.0 * cos / to.length_squared() * (-sigma * (-r.z) / cos).exp()
                }),
            ),
        ] {
            let scene = pool_of_index(1.0, sigma, lights);
            let r = DVec3::new(-0.4, 0.7, -1.0);
            let (value, _) = light_on_floor(
                &scene,
                DVec3::new(-0.2, 0.6, 0.0),
                r,
                Sampler::new(1, 0, 0, 0),
            );
            let truth = RHO / PI * truth_at(r);
            let error = value.x / truth - 1.0;
            println!(
                "η = 1, σt {sigma}: {:.8e} vs {truth:.8e} ({error:+.2e})",
                value.x
            );
            worst = worst.max(error.abs());
        }
    }
    assert!(worst < 2e-5, "worst relative error {worst}");
}

/// Where the ray from the point light `l` to the point `v` under the flat surface z = 0 crosses
/// it: the root in `[0, ℓ]` of Snell's law in the plane of incidence (physics.md §5), by
/// bisection; it is checked to be a root of the quartic (7).
fn flat_refraction_point(v: DVec3, l: DVec3, eta: f64) -> DVec3 {
    let (h_v, h_l) = (-v.z, l.z);
    let across = DVec3::new(l.x - v.x, l.y - v.y, 0.0);
    let ell = across.length();
    let snell = |x: f64| {
        eta * x / (x * x + h_v * h_v).sqrt() - (ell - x) / ((ell - x).powi(2) + h_l * h_l).sqrt()
    };
    let (mut lo, mut hi) = (0.0, ell);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if snell(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let x = 0.5 * (lo + hi);
    let e2 = eta * eta;
    let quartic = (e2 - 1.0) * x.powi(4) - 2.0 * ell * (e2 - 1.0) * x.powi(3)
        + ((e2 - 1.0) * ell * ell + e2 * h_l * h_l - h_v * h_v) * x * x
        + 2.0 * ell * h_v * h_v * x
        - h_v * h_v * ell * ell;
    let scale = (ell + h_v + h_l).powi(4);
    assert!(quartic.abs() < 1e-12 * scale, "quartic residual {quartic}");
    let foot = DVec3::new(v.x, v.y, 0.0);
    if ell > 0.0 {
        foot + across * (x / ell)
    } else {
        foot
    }
}

/// A point light over the flat surface: the irradiance on the floor at R is `I T(θ_i)
/// e^{−σ_t |R − X|} dΩ/dA`, where X is the quartic's refraction point and dΩ/dA the solid angle
/// at the light of the rays that land on a unit of floor around R (finite differences of the
/// direction L → X(R)). No D, no η²: this checks both.
#[test]
fn a_point_light_over_a_flat_surface_matches_the_quartic() {
    let light = DVec3::new(0.7, -0.4, 2.5);
    let intensity = 5.0;
    let mut worst: f64 = 0.0;
    for sigma in [0.0, 0.8] {
        let scene = pool(
            sigma,
            json!([{"type": "point", "position": light.to_array(),
                    "intensity": [intensity, intensity, intensity]}]),
        );
        for r in [
            DVec3::new(0.0, 0.0, -1.0),
            DVec3::new(-1.3, 0.6, -1.0),
            DVec3::new(2.9, -3.1, -1.0),
            DVec3::new(-6.0, 4.5, -1.0),
        ] {
            let x = flat_refraction_point(r, light, ETA);
            let direction = |r: DVec3| (flat_refraction_point(r, light, ETA) - light).normalize();
            let step = 1e-5;
            let dx =
                (direction(r + DVec3::X * step) - direction(r - DVec3::X * step)) / (2.0 * step);
            let dy =
                (direction(r + DVec3::Y * step) - direction(r - DVec3::Y * step)) / (2.0 * step);
            let solid_angle_per_area = dx.cross(dy).dot(direction(r)).abs();
            let cos_i = (light - x).normalize().z;
            let e_floor = intensity
                * (1.0 - fresnel_air_to(ETA, cos_i))
                * (-sigma * r.distance(x)).exp()
                * solid_angle_per_area;
            let truth = RHO / PI * e_floor;

            let entry = DVec3::new(r.x + 0.2, r.y - 0.1, 0.0);
            let (value, stats) = light_on_floor(&scene, entry, r, Sampler::new(3, 0, 0, 0));
            let error = value.x / truth - 1.0;
            println!(
                "σt {sigma}, receiver {r}: {:.8e} vs quartic {truth:.8e} ({error:+.2e}), {} \
                 refraction point(s)",
                value.x, stats.samples
            );
            assert_eq!(stats.samples, 1, "one refraction point per receiver");
            worst = worst.max(error.abs());
        }
    }
    // The finite differences are good to about 1e-9.
    println!("worst relative error {worst:.2e}");
    assert!(worst < 1e-6, "worst relative error {worst}");
}

/// A closed water volume over `[-w, w]²`, bottom at `z = -depth`, whose top is the height field
/// `z = a sin(kx) sin(ky)` on an `n × n` grid (zero on the border when `kw` is a multiple of π),
/// as OBJ text without normals (the scene smooths the top and creases the box's edges).
fn wavy_water_obj(w: f64, depth: f64, a: f64, k: f64, n: usize) -> String {
    let mut s = String::new();
    let coordinate = |i: usize| -w + 2.0 * w * i as f64 / n as f64;
    let height = |x: f64, y: f64| {
        let z = a * (k * x).sin() * (k * y).sin();
        if z.abs() < 1e-12 { 0.0 } else { z }
    };
    let top = |i: usize, j: usize| 1 + j * (n + 1) + i;
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (coordinate(i), coordinate(j));
            s += &format!("v {x} {y} {}\n", height(x, y));
        }
    }
    // The border of the top, counter-clockwise seen from above.
    let mut border = Vec::new();
    border.extend((0..n).map(|i| (i, 0)));
    border.extend((0..n).map(|j| (n, j)));
    border.extend((0..n).map(|i| (n - i, n)));
    border.extend((0..n).map(|j| (0, n - j)));
    let first_bottom = (n + 1) * (n + 1) + 1;
    for &(i, j) in &border {
        s += &format!("v {} {} {}\n", coordinate(i), coordinate(j), -depth);
    }
    let centre = first_bottom + border.len();
    s += &format!("v 0 0 {}\n", -depth);
    for j in 0..n {
        for i in 0..n {
            let (v00, v10, v11, v01) = (top(i, j), top(i + 1, j), top(i + 1, j + 1), top(i, j + 1));
            s += &format!("f {v00} {v10} {v11}\nf {v00} {v11} {v01}\n");
        }
    }
    let m = border.len();
    for k in 0..m {
        let next = (k + 1) % m;
        let (t0, t1) = (
            top(border[k].0, border[k].1),
            top(border[next].0, border[next].1),
        );
        let (b0, b1) = (first_bottom + k, first_bottom + next);
        s += &format!("f {b0} {b1} {t1}\nf {b0} {t1} {t0}\n");
        s += &format!("f {centre} {b1} {b0}\n");
    }
    s
}

/// A camera segment from inside the water, below the crests, down to the floor point `r`, and
/// the receiver there.
fn wavy_segment(r: DVec3) -> (Segment, Receiver) {
    let origin = r + DVec3::new(0.05, -0.03, 0.85);
    let segment = Segment {
        origin,
        dir: (r - origin).normalize(),
        length: r.distance(origin),
        object: 0,
        throughput: Rgb::ONE,
    };
    let receiver = Receiver {
        p: r,
        normal: DVec3::Z,
        geometric: DVec3::Z,
        reflectance: Rgb::splat(RHO),
    };
    (segment, receiver)
}

/// A small counter-based generator for the brute force (splitmix64).
fn uniform(seed: u64, index: u64) -> f64 {
    let mut z = seed
        .wrapping_add(index.wrapping_mul(0x9E37_79B9_7F4A_7C15))
        .wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// The scene of the wavy tests: a closed water volume with a wavy top over a diffuse floor, lit
/// by the sun; returns it with the sun's direction, its irradiance, σ_t and the floor's height.
fn wavy_pool() -> (Scene, DVec3, f64, f64, f64) {
    let (w, depth, a, k, n) = (2.0, 2.0, 0.08, 2.0 * PI, 64);
    let sigma = 0.3;
    let sun = DVec3::new(0.2, 0.1, -1.0).normalize();
    let e = 1.0;
    let water = wavy_water_obj(w, depth, a, k, n);
    // The crests' radius of curvature is 1/(a k²) ≈ 0.32, so they focus about η/(η − 1)·0.32 ≈
    // 1.27 below: the floor, 1.5 down, lies past the cusps, where fold caustics cross it.
    let floor_z = -1.5;
    let floor = box_obj(
        DVec3::new(-1.9, -1.9, floor_z - 0.3),
        DVec3::new(1.9, 1.9, floor_z),
        false,
    );
    let scene = scene(
        json!([
            {"shape": {"type": "obj", "path": "water.obj", "crease_angle": 45.0},
             "material": {"type": "dielectric", "eta": ETA, "medium": {
                 "sigma_t": [sigma, sigma, sigma], "albedo": [0.5, 0.5, 0.5]}}},
            {"shape": {"type": "obj", "path": "floor.obj"},
             "material": {"type": "diffuse", "reflectance": [RHO, RHO, RHO]}}
        ]),
        json!([{"type": "directional", "direction": sun.to_array(), "irradiance": [e, e, e]}]),
        Assets::from([
            ("water.obj".to_string(), water.into_bytes()),
            ("floor.obj".to_string(), floor.into_bytes()),
        ]),
    );
    (scene, sun, e, sigma, floor_z)
}

/// The sun through a wavy water surface whose crests focus above the floor (fold caustics
/// cross the patch): the mean irradiance over a patch of the floor from the receiver
/// connection at stratified points, against rays traced forward from the sun, refracted at the
/// surface with its interpolated normals (Snell's law and Fresnel written out here), and
/// splatted on the patch. Both means must agree within their noise.
#[test]
fn the_sun_through_a_wavy_surface_matches_light_traced_forward() {
    let (scene, sun, e, sigma, floor_z) = wavy_pool();
    // A patch that fold caustics cross (about one receiver in twenty has three refraction
    // points) and no cusp: at a cusp the irradiance's peak is strong enough that the mean of a
    // few thousand points scatters far beyond its estimated noise (the patch around the cusp
    // of the crest at (0.25, 0.25), centre (0.45, 0.35), side 0.3: −10 % ± 4 % at 3456 points,
    // +1 % ± 6 % at 13824).
    let centre = DVec3::new(0.7, 0.1, floor_z);
    let half = 0.1;
    let started = std::time::Instant::now();
    // The receiver connection at m × m jittered points of the patch, in independent replicas:
    // the spread of their means is the stratified estimate's noise (the irradiance has the
    // integrable 1/√ peaks of the folds, so the points' own spread would overstate it).
    let (m, replicas) = (24u64, 6u64);
    let values: Vec<(u64, f64, u64)> = (0..replicas * m * m)
        .into_par_iter()
        .map(|index| {
            let (replica, cell) = (index / (m * m), index % (m * m));
            let (i, j) = (cell % m, cell / m);
            let u = (i as f64 + uniform(1, 2 * index)) / m as f64;
            let v = (j as f64 + uniform(1, 2 * index + 1)) / m as f64;
            let r = centre + DVec3::new((2.0 * u - 1.0) * half, (2.0 * v - 1.0) * half, 0.0);
            let (segment, receiver) = wavy_segment(r);
            let mut stats = RenderStats::default();
            let mut sampler = Sampler::new(5 + replica, i as u32, j as u32, 0);
            let value = through_boundary(&scene, &segment, &receiver, &mut sampler, &mut stats);
            (replica, value.x * PI / RHO, stats.samples)
        })
        .collect();
    let receiver_time = started.elapsed().as_secs_f64() / values.len() as f64;
    let means: Vec<f64> = (0..replicas)
        .map(|k| {
            let of = values.iter().filter(|v| v.0 == k);
            of.map(|v| v.1).sum::<f64>() / (m * m) as f64
        })
        .collect();
    let mean = means.iter().sum::<f64>() / replicas as f64;
    let spread = means.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (replicas - 1) as f64;
    let receiver_error = (spread / replicas as f64).sqrt();
    println!("replica means {means:.4?}");
    let mut branches = [0usize; 5];
    for v in &values {
        branches[(v.2 as usize).min(4)] += 1;
    }

    // Light traced forward from a rectangle at z = 1 over the patch, shifted toward the sun.
    let water_mesh = &scene.objects()[0].mesh;
    let shift = DVec3::new(sun.x, sun.y, 0.0) / -sun.z * 1.0
        + DVec3::new(sun.x, sun.y, 0.0).normalize_or_zero() * (0.16 * -floor_z);
    let source_centre = DVec3::new(centre.x, centre.y, 1.0) - shift;
    let source_half = half + 0.3;
    let rays = 4_000_000u64;
    let power = e * (-sun.z) * (2.0 * source_half).powi(2) / rays as f64;
    let (sum, sum_sq, landed, reach) = (0..rays)
        .into_par_iter()
        .map(|index| {
            let o = source_centre
                + DVec3::new(
                    (2.0 * uniform(2, 2 * index) - 1.0) * source_half,
                    (2.0 * uniform(2, 2 * index + 1) - 1.0) * source_half,
                    0.0,
                );
            let Some(hit) = scene.bvh().closest_hit(&Ray::new(o, sun)) else {
                return (0.0, 0.0, 0, 0.0);
            };
            let (object, triangle) = scene.locate(hit.triangle);
            if object != 0 {
                return (0.0, 0.0, 0, 0.0);
            }
            let x = o + sun * hit.t;
            let ng = water_mesh.geometric_normal(triangle).normalize();
            let ns = water_mesh
                .shading_normal(triangle, hit.a, hit.b)
                .normalize();
            let cos_i = -sun.dot(ns);
            if cos_i <= 1e-9 || sun.dot(ng) >= 0.0 {
                return (0.0, 0.0, 0, 0.0);
            }
            // Snell's law with the shading normal.
            let cos_t = cos_refracted(ETA, cos_i);
            let refracted = sun / ETA + (cos_i / ETA - cos_t) * ns;
            if refracted.dot(ng) >= 0.0 {
                return (0.0, 0.0, 0, 0.0);
            }
            let from = Ray::leaving(x, ng, refracted, scene.scale());
            let Some(below) = scene.bvh().closest_hit(&from) else {
                return (0.0, 0.0, 0, 0.0);
            };
            let r = from.at(below.t);
            if scene.locate(below.triangle).0 != 1
                || (r.z - floor_z).abs() > 1e-9
                || (r.x - centre.x).abs() > half
                || (r.y - centre.y).abs() > half
            {
                return (0.0, 0.0, 0, 0.0);
            }
            // Light traced forward converges to the forward factor D_fwd; the adjoint factor
            // (physics.md eq. 6) turns each ray into the backward quantity the renderer uses.
            let to_light = -sun;
            let adjoint = (refracted.dot(ng) * to_light.dot(ns)
                / (to_light.dot(ng) * refracted.dot(ns)))
            .abs();
            let carried = power
                * (1.0 - fresnel_air_to(ETA, cos_i))
                * (-sigma * r.distance(x)).exp()
                * adjoint;
            let offset = o - source_centre;
            (
                carried,
                carried * carried,
                1u64,
                offset.x.abs().max(offset.y.abs()),
            )
        })
        .reduce(
            || (0.0, 0.0, 0, 0.0),
            |p, q| (p.0 + q.0, p.1 + q.1, p.2 + q.2, p.3.max(q.3)),
        );
    let area = (2.0 * half).powi(2);
    let forward = sum / area;
    let forward_error = (sum_sq - sum * sum / rays as f64).max(0.0).sqrt() / area;

    let difference = mean - forward;
    let sigma_both = (receiver_error.powi(2) + forward_error.powi(2)).sqrt();
    println!(
        "patch irradiance: receiver {mean:.6} ± {receiver_error:.6} ({} points in {replicas} \
         replicas; refraction points per receiver 0/1/2/3/4+: {branches:?}), forward {forward:.6} ± \
         {forward_error:.6} ({landed} of {rays} rays landed, from within {reach:.3} of the source's centre); difference {:+.3}σ ({:+.3}%)",
        values.len(),
        difference / sigma_both,
        100.0 * difference / forward
    );
    println!(
        "receiver connection: {:.3} ms per receiver point (one light, rayon over the points)",
        1e3 * receiver_time * rayon::current_num_threads() as f64
    );
    // Every ray that lands on the patch starts well inside the source rectangle, so none that
    // would land there starts outside it.
    assert!(
        reach < source_half - 0.05,
        "rays landing on the patch start {reach} from the source's centre (half-width \
         {source_half})"
    );
    assert!(
        branches[2..].iter().sum::<usize>() > 0,
        "the patch should hold fold caustics (receivers with several refraction points)"
    );
    assert!(
        difference.abs() < 4.0 * sigma_both,
        "receiver {mean} ± {receiver_error} vs forward {forward} ± {forward_error}"
    );
}

/// Every refraction point that a brute-force search finds (Newton from a grid of 21 starts on
/// every triangle of the surface near the receiver, `solve_all_at`), the receiver connection
/// finds too, on a line of receivers across the fold caustics of the wavy pool: the same count
/// at every receiver, where the count goes 1 → 3 → 1 across the caustics.
#[test]
fn the_receiver_finds_every_refraction_point_across_fold_caustics() {
    let (scene, sun, _, _, floor_z) = wavy_pool();
    let mesh = &scene.objects()[0].mesh;
    let light = DVec3::ZERO - sun * 1e6;
    let receivers = 120;
    let counts: Vec<(usize, u64)> = (0..receivers)
        .into_par_iter()
        .map(|i| {
            let s = i as f64 / (receivers - 1) as f64;
            let r = DVec3::new(0.2 + 0.5 * s, 0.33 + 0.1 * s, floor_z);
            let (segment, receiver) = wavy_segment(r);
            let mut stats = RenderStats::default();
            let mut sampler = Sampler::new(9, i as u32, 0, 0);
            through_boundary(&scene, &segment, &receiver, &mut sampler, &mut stats);
            // The brute force, on the triangles above the receiver (the light is refracted by
            // at most a few degrees: every solution lies within 0.8 of where the straight line
            // to the light crosses z = 0).
            let ends = PathEnds {
                origin: segment.origin,
                dir: segment.dir,
                light,
                eta: ETA,
            };
            let straight = r + (light - r) * (-r.z / (light.z - r.z));
            let mut found = 0;
            let mut brute = RenderStats::default();
            for triangle in 0..mesh.triangle_count() {
                let corners = mesh.corners(triangle);
                let centroid = (corners[0] + corners[1] + corners[2]) / 3.0;
                if centroid.z < -0.5
                    || DVec3::new(centroid.x - straight.x, centroid.y - straight.y, 0.0).length()
                        > 0.8
                {
                    continue;
                }
                let Some(patch) = TrianglePatch::new(corners, mesh.corner_normals(triangle)) else {
                    continue;
                };
                found +=
                    solve_all_at::<8>(&patch, &ends, segment.length, 6, 1e-12, &mut brute).len();
            }
            (found, stats.samples)
        })
        .collect();
    let mut histogram = [0usize; 5];
    for (i, &(brute, receiver)) in counts.iter().enumerate() {
        histogram[brute.min(4)] += 1;
        assert_eq!(
            brute as u64, receiver,
            "receiver {i}: brute force finds {brute} refraction points, the receiver {receiver}"
        );
    }
    println!("receivers by refraction points (brute force = receiver) 0/1/2/3/4+: {histogram:?}");
    assert!(
        histogram[3..].iter().sum::<usize>() > 0,
        "the line should cross fold caustics"
    );
}

/// The irradiance of every refraction path through the wavy surface against the forward map of
/// the light: for each refraction point X that a brute-force search finds for the receiver R,
/// rays from the sun's light point L through points s of a plane above the surface are
/// refracted on X's triangle (its interpolated normal, Snell's law written out here) and meet
/// the floor at R(s); the path's irradiance at R is `I T e^{−σ_t |R − X|} (dΩ/dA_s) / |det
/// ∂R/∂s|` (finite differences): energy conservation through the curved surface, with no D and
/// no η². With shading normals that is the forward (light-tracing) quantity; the renderer's D is
/// the backward one of [WZHB09] and [H15] (what a camera path tracer converges to), so each
/// path is turned into it by Veach's adjoint factor (physics.md eq. 6; 0.1–1 % here). The
/// receiver's irradiance must be the sum over the paths, near and across folds.
#[test]
fn each_path_through_the_wavy_surface_carries_the_light_of_the_forward_map() {
    let (scene, _, e, sigma, floor_z) = wavy_pool();
    let spindle_render::light::Light::Directional {
        direction,
        anchor,
        distance,
        ..
    } = scene.lights()[0]
    else {
        panic!("the wavy pool's light is the sun");
    };
    let light = anchor - direction * distance;
    let mesh = &scene.objects()[0].mesh;
    let mut worst: f64 = 0.0;
    let mut folds = 0;
    for i in 0..40u64 {
        let r = DVec3::new(
            0.3 + 0.3 * uniform(13, 2 * i),
            0.2 + 0.3 * uniform(13, 2 * i + 1),
            floor_z,
        );
        let (segment, receiver) = wavy_segment(r);
        let mut stats = RenderStats::default();
        let mut sampler = Sampler::new(9, i as u32, 0, 0);
        let value = through_boundary(&scene, &segment, &receiver, &mut sampler, &mut stats);
        let irradiance = value.x * PI / RHO;

        let ends = PathEnds {
            origin: segment.origin,
            dir: segment.dir,
            light,
            eta: ETA,
        };
        let straight = r + (light - r) * (-r.z / (light.z - r.z));
        let mut expected = 0.0;
        let mut paths = 0;
        for triangle in 0..mesh.triangle_count() {
            let corners = mesh.corners(triangle);
            let centroid = (corners[0] + corners[1] + corners[2]) / 3.0;
            if centroid.z < -0.5
                || DVec3::new(centroid.x - straight.x, centroid.y - straight.y, 0.0).length() > 0.8
            {
                continue;
            }
            let normals = mesh.corner_normals(triangle);
            let Some(patch) = TrianglePatch::new(corners, normals) else {
                continue;
            };
            let mut brute = RenderStats::default();
            for path in
                solve_all_at::<8>(&patch, &ends, segment.length, 6, 1e-13, &mut brute).iter()
            {
                paths += 1;
                let x = path.p;
                // The forward map s ↦ R(s) on this triangle, from the plane z = 1.
                let (e1, e2) = (corners[1] - corners[0], corners[2] - corners[0]);
                let ng = e1.cross(e2).normalize();
                let land = |s: DVec3| -> DVec3 {
                    let d = (s - light).normalize();
                    let t = (corners[0] - light).dot(ng) / d.dot(ng);
                    let x = light + d * t;
                    // Barycentric coordinates of x, and the interpolated normal there.
                    let q = x - corners[0];
                    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
                    let (q1, q2) = (q.dot(e1), q.dot(e2));
                    let det = d11 * d22 - d12 * d12;
                    let a = (d22 * q1 - d12 * q2) / det;
                    let b = (d11 * q2 - d12 * q1) / det;
                    let n =
                        (normals[0] * (1.0 - a - b) + normals[1] * a + normals[2] * b).normalize();
                    let cos_i = -d.dot(n);
                    let refracted = d / ETA + (cos_i / ETA - cos_refracted(ETA, cos_i)) * n;
                    x + refracted * ((floor_z - x.z) / refracted.z)
                };
                let s0 = light + (x - light) * ((1.0 - light.z) / (x.z - light.z));
                assert!(land(s0).distance(r) < 1e-7, "the forward map lands at R");
                let h = 1e-6;
                let dx = (land(s0 + DVec3::X * h) - land(s0 - DVec3::X * h)) / (2.0 * h);
                let dy = (land(s0 + DVec3::Y * h) - land(s0 - DVec3::Y * h)) / (2.0 * h);
                let det = (dx.x * dy.y - dx.y * dy.x).abs();
                let to_s = s0 - light;
                let solid_angle_per_area = (to_s.z / to_s.length()).abs() / to_s.length_squared();
                let intensity = e * (x - light).length_squared();
                let cos_i = (light - x)
                    .normalize()
                    .dot(path.omega_l.normalize())
                    .min(1.0);
                assert!((cos_i - 1.0).abs() < 1e-12);
                let n_s = (normals[0] * (1.0 - path.a - path.b)
                    + normals[1] * path.a
                    + normals[2] * path.b)
                    .normalize();
                let t_p = 1.0 - fresnel_air_to(ETA, path.omega_l.dot(n_s));
                // The forward map gives the forward factor D_fwd; the renderer's D is the
                // backward one, and with shading normals they differ by Veach's adjoint factor
                // (physics.md eq. 6): D_fwd / D = |ω_V·N̂g| |ω_L·N̂s| / (|ω_L·N̂g| |ω_V·N̂s|).
                let adjoint = (path.omega_v.dot(ng) * path.omega_l.dot(n_s)
                    / (path.omega_l.dot(ng) * path.omega_v.dot(n_s)))
                .abs();
                expected += intensity * t_p * (-sigma * r.distance(x)).exp() * solid_angle_per_area
                    / det
                    * adjoint;
            }
        }
        if paths > 1 {
            folds += 1;
        }
        let error = irradiance / expected - 1.0;
        worst = worst.max(error.abs());
        println!(
            "receiver {r}: {paths} path(s), irradiance {irradiance:.8} vs forward map \
             {expected:.8} ({error:+.2e})"
        );
    }
    println!("worst relative error {worst:.2e}; {folds} receivers with several paths");
    assert!(
        folds > 0,
        "some receivers should lie on the bright side of a fold"
    );
    assert!(worst < 1e-5, "worst relative error {worst}");
}

/// The plan says which diffuse object lies in which medium and how it is lit.
#[test]
fn the_plan_names_the_floor_inside_the_water() {
    let scene = pool(
        0.5,
        json!([{"type": "directional", "direction": [0, 0, -1], "irradiance": [1, 1, 1]}]),
    );
    let plan = spindle_render::scatter::describe_plan(&scene);
    println!("{plan:#?}");
    assert!(
        plan.iter().any(|l| l.starts_with(
            "objects[1]: diffuse, inside objects[0]'s medium: lit by the lights outside it"
        )),
        "{plan:?}"
    );
}

/// A floor inside a coarse glass ball (320 triangles, smooth normals: large curved triangles,
/// on which an arc of the refraction curve may cross a triangle without touching an edge):
/// every refraction point a brute-force search finds on any triangle, the receiver finds.
#[test]
fn the_receiver_finds_every_refraction_point_in_a_coarse_glass_ball() {
    let floor = box_obj(
        DVec3::new(-0.5, -0.5, -0.7),
        DVec3::new(0.5, 0.5, -0.6),
        false,
    );
    let sun = DVec3::new(0.1, 0.05, -1.0);
    let scene = scene(
        json!([
            {"shape": {"type": "icosphere", "radius": 1.0, "subdivisions": 2},
             "material": {"type": "dielectric", "eta": 1.5, "medium": {
                 "sigma_t": [0.2, 0.2, 0.2], "albedo": [0.5, 0.5, 0.5]}}},
            {"shape": {"type": "obj", "path": "floor.obj"},
             "material": {"type": "diffuse", "reflectance": [RHO, RHO, RHO]}}
        ]),
        json!([{"type": "directional", "direction": sun.to_array(), "irradiance": [1, 1, 1]}]),
        Assets::from([("floor.obj".to_string(), floor.into_bytes())]),
    );
    let spindle_render::light::Light::Directional {
        direction,
        anchor,
        distance,
        ..
    } = scene.lights()[0]
    else {
        panic!("the light is the sun");
    };
    let light = anchor - direction * distance;
    let mesh = &scene.objects()[0].mesh;
    let side = 15;
    let counts: Vec<(usize, u64)> = (0..side * side)
        .into_par_iter()
        .map(|index| {
            let (i, j) = (index % side, index / side);
            let r = DVec3::new(
                -0.45 + 0.9 * i as f64 / (side - 1) as f64,
                -0.45 + 0.9 * j as f64 / (side - 1) as f64,
                -0.6,
            );
            let origin = DVec3::new(0.1, -0.2, 0.5);
            let segment = Segment {
                origin,
                dir: (r - origin).normalize(),
                length: r.distance(origin),
                object: 0,
                throughput: Rgb::ONE,
            };
            let receiver = Receiver {
                p: r,
                normal: DVec3::Z,
                geometric: DVec3::Z,
                reflectance: Rgb::splat(RHO),
            };
            let mut stats = RenderStats::default();
            let mut sampler = Sampler::new(3, i as u32, j as u32, 0);
            through_boundary(&scene, &segment, &receiver, &mut sampler, &mut stats);
            let ends = PathEnds {
                origin: segment.origin,
                dir: segment.dir,
                light,
                eta: 1.5,
            };
            let mut brute = RenderStats::default();
            let found: usize = (0..mesh.triangle_count())
                .filter_map(|t| TrianglePatch::new(mesh.corners(t), mesh.corner_normals(t)))
                .map(|patch| {
                    solve_all_at::<8>(&patch, &ends, segment.length, 8, 1e-12, &mut brute).len()
                })
                .sum();
            (found, stats.samples)
        })
        .collect();
    let mut histogram = [0usize; 5];
    for (i, &(brute, receiver)) in counts.iter().enumerate() {
        histogram[brute.min(4)] += 1;
        assert_eq!(
            brute as u64, receiver,
            "receiver {i}: brute force finds {brute} refraction points, the receiver {receiver}"
        );
    }
    println!("receivers by refraction points (brute force = receiver) 0/1/2/3/4+: {histogram:?}");
}
