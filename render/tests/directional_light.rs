//! The directional light (the sun) against closed forms: single scattering under a flat
//! interface, a diffuse floor, and the sun's disk seen by the camera.

mod support;

use glam::DVec3;
use serde_json::{Value, json};
use spindle_common::stats::RenderStats;
use spindle_common::tile::TileRect;
use spindle_render::sampler::Sampler;
use spindle_render::scatter::{describe_plan, single_scatter};
use spindle_render::segment::Segment;
use spindle_render::{Assets, Rgb, Scene, render_tile};
use support::box_obj;

fn scene(objects: Value, lights: Value, camera: Value, ss: Value, assets: Assets) -> Scene {
    let scene = json!({
        "camera": camera,
        "film": {"width": 4, "height": 4, "spp": 4},
        "lights": lights,
        "objects": objects,
        "integrator": {"single_scatter": ss}
    });
    let desc = serde_json::from_value(scene).expect("test scene parses");
    Scene::build(&desc, &assets).expect("test scene builds")
}

/// Unpolarised Fresnel reflectance from air onto index `eta` at incidence cosine `c`, written
/// out here so the closed form does not lean on the renderer's own.
fn fresnel_air_to(eta: f64, c: f64) -> f64 {
    let s = (1.0 - c * c).sqrt() / eta;
    let ct = (1.0 - s * s).sqrt();
    let rs = (c - eta * ct) / (c + eta * ct);
    let rp = (eta * c - ct) / (eta * c + ct);
    0.5 * (rs * rs + rp * rp)
}

/// Parallel rays of irradiance `E` cross a flat interface (normal +z, medium below, index η)
/// at incidence θ_L and travel on at θ_V; a beam of cross-section A becomes one of cross-section
/// A cos θ_V / cos θ_L, so inside its irradiance across the beam is `T_P E cos θ_L / cos θ_V`,
/// attenuated by `e^{−σ_t d_V}` after `d_V = depth / cos θ_V`. A camera segment from the surface
/// point P going down at cos θ_c to the inward normal, for a length ℓ, then collects (isotropic
/// phase) `α σ_t/(4π) · T_P E cos θ_L/cos θ_V · (1 − e^{−σ_t k ℓ})/(σ_t k)`, `k = 1 + cos θ_c/cos θ_V`.
fn under_the_sun(sun: DVec3, dir: DVec3, e: f64, sigma: f64, albedo: f64, length: f64) -> f64 {
    let eta = 1.5;
    let cos_l = -sun.normalize().z;
    let sin_v = (1.0 - cos_l * cos_l).sqrt() / eta;
    let cos_v = (1.0 - sin_v * sin_v).sqrt();
    let cos_c = -dir.z;
    let k = 1.0 + cos_c / cos_v;
    let t_p = 1.0 - fresnel_air_to(eta, cos_l);
    albedo * sigma / (4.0 * std::f64::consts::PI) * t_p * e * cos_l / cos_v
        * (1.0 - (-sigma * k * length).exp())
        / (sigma * k)
}

#[test]
fn single_scattering_under_a_flat_interface_matches_the_closed_form() {
    let obj = box_obj(
        DVec3::new(-50.0, -50.0, -2.0),
        DVec3::new(50.0, 50.0, 0.0),
        false,
    );
    let p = DVec3::new(0.2, -0.1, 0.0);
    let dir = DVec3::new(0.3, 0.1, -1.0).normalize();
    let length = 2.0 / -dir.z;
    let albedo = 0.9;
    for sun in [DVec3::new(0.0, 0.0, -1.0), DVec3::new(1.0, 0.4, -1.2)] {
        for sigma in [0.3, 1.0, 30.0] {
            let truth = under_the_sun(sun, dir, 2.0, sigma, albedo, length);
            for (name, ss) in [
                ("interval K = 1", json!({"method": "interval", "k": 1})),
                ("interval K = 8", json!({"method": "interval", "k": 8})),
                (
                    "point sampling M = 256",
                    json!({"method": "point_sampling", "samples_per_segment": 256}),
                ),
            ] {
                let scene = scene(
                    json!([{
                        "shape": {"type": "obj", "path": "slab.obj"},
                        "material": {"type": "dielectric", "eta": 1.5, "medium": {
                            "sigma_t": [sigma, sigma, sigma], "albedo": [albedo, albedo, albedo]}}
                    }]),
                    json!([{"type": "directional", "direction": sun.to_array(),
                            "irradiance": [2, 2, 2]}]),
                    json!({"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 10}),
                    ss,
                    Assets::from([("slab.obj".to_string(), obj.clone().into_bytes())]),
                );
                let segment = Segment {
                    origin: p,
                    dir,
                    length,
                    object: 0,
                    throughput: Rgb::ONE,
                };
                let mut stats = RenderStats::default();
                let mut sampler = Sampler::new(1, 0, 0, 0);
                let value = single_scatter(&scene, &segment, &mut sampler, &mut stats);
                let error = value.x / truth - 1.0;
                println!(
                    "sun {sun}, σt {sigma}, {name}: {:.6e} vs closed form {truth:.6e} ({:+.4}%)",
                    value.x,
                    100.0 * error
                );
                // Measured: the interval method within 2e-6 (the far point's rays reach P
                // within 3e-7 rad of the sun's direction), point sampling within 2.2e-4 (its
                // quadrature error).
                let bound = if name.starts_with("point") {
                    2e-3
                } else {
                    1e-5
                };
                assert!(
                    error.abs() < bound,
                    "sun {sun}, σt {sigma}, {name}: {error}"
                );
            }
        }
    }
}

/// A camera segment inside the slab going *up* to the lit surface and ending on it (a camera
/// looking up from under water, a path's segment after an internal reflection, a secondary
/// segment of multiple scattering). Near its end the scattering point nears the surface and the
/// path's inside leg shrinks to nothing, where the arc traced along the triangle can break down
/// and be traced again from the segment's end: that light was once counted twice (+100 % at
/// cos θ 0.9 and 0.99 under the sun from straight above). Closed form: from depth `D` up at
/// `cos θ_c` for `ℓ = D / cos θ_c`, the sun's leg inside is `(D − s cos θ_c)/cos θ_V`, so the
/// segment collects `α σ/(4π) · T_P E cos θ_L/cos θ_V · e^{−σD/cos θ_V} (1 − e^{−σ k ℓ})/(σ k)`,
/// `k = 1 − cos θ_c / cos θ_V`.
#[test]
fn a_segment_that_ends_on_the_lit_surface_counts_its_light_once() {
    let (eta, e, sigma, albedo, depth) = (1.33f64, 2.0, 0.8, 0.6, 1.0);
    let mut worst: f64 = 0.0;
    let mut doubled = 0;
    for sun in [DVec3::new(0.0, -1.0, 0.0), DVec3::new(0.5, -1.0, 0.2)] {
        let scene = scene(
            json!([{
                "shape": {"type": "box", "size": [100, 2, 100]},
                "transform": {"translate": [0, -1, 0]},
                "material": {"type": "dielectric", "eta": eta, "medium": {
                    "sigma_t": [sigma, sigma, sigma], "albedo": [albedo, albedo, albedo]}}
            }]),
            json!([{"type": "directional", "direction": sun.to_array(),
                    "irradiance": [e, e, e]}]),
            json!({"position": [0, 5, 1], "look_at": [0, 0, 0], "fov_y": 10}),
            json!({"method": "interval", "k": 1}),
            Assets::new(),
        );
        let cos_l = -sun.normalize().y;
        let sin_v = (1.0 - cos_l * cos_l).sqrt() / eta;
        let cos_v = (1.0 - sin_v * sin_v).sqrt();
        let t_p = 1.0 - fresnel_air_to(eta, cos_l);
        let scale = albedo * sigma / (4.0 * std::f64::consts::PI) * t_p * e * cos_l / cos_v
            * (-sigma * depth / cos_v).exp();
        for i in 0..200 {
            let cos_c = 0.05 + 0.945 * f64::from(i) / 199.0;
            let dir = DVec3::new((1.0 - cos_c * cos_c).sqrt(), cos_c, 0.0);
            let length = depth / cos_c;
            let k = 1.0 - cos_c / cos_v;
            let integral = if k.abs() < 1e-12 {
                length
            } else {
                (1.0 - (-sigma * k * length).exp()) / (sigma * k)
            };
            let truth = scale * integral;
            let segment = Segment {
                origin: DVec3::new(0.3, -depth, 0.2),
                dir,
                length,
                object: 0,
                throughput: Rgb::ONE,
            };
            let mut stats = RenderStats::default();
            let value = single_scatter(&scene, &segment, &mut Sampler::new(1, 0, 0, 0), &mut stats);
            let error = value.x / truth - 1.0;
            if error.abs() > 1e-4 {
                println!("sun {sun}, cos θ_c {cos_c:.4}: {error:+.3e}");
            }
            if error > 0.5 {
                doubled += 1;
            }
            worst = worst.max(error.abs());
        }
    }
    println!("worst relative error {worst:.2e}; {doubled} segments counted twice");
    assert!(worst < 1e-3, "worst relative error {worst:e}");
}

/// A diffuse floor under the sun: radiance `ρ/π · E cos θ` wherever the camera looks, for
/// parallel rays and for the sun's 0.53° disk (whose radiance is set so that its irradiance is
/// `E`); looking into the disk, the camera sees `E / (π sin² α)`.
#[test]
fn a_diffuse_floor_and_the_disk_match_the_closed_forms() {
    let floor = box_obj(
        DVec3::new(-10.0, -10.0, -1.0),
        DVec3::new(10.0, 10.0, 0.0),
        false,
    );
    let sun = DVec3::new(0.5, 0.2, -1.0);
    let cos = -sun.normalize().z;
    let rho = 0.6;
    for diameter in [0.0, 0.53] {
        let scene = scene(
            json!([{"shape": {"type": "obj", "path": "floor.obj"},
                    "material": {"type": "diffuse", "reflectance": [rho, rho, rho]}}]),
            json!([{"type": "directional", "direction": sun.to_array(),
                    "irradiance": [3, 3, 3], "angular_diameter": diameter}]),
            json!({"position": [0, -3, 4], "look_at": [0, 0, 0], "fov_y": 10}),
            json!({}),
            Assets::from([("floor.obj".to_string(), floor.clone().into_bytes())]),
        );
        let pixels = render_tile(
            &scene,
            TileRect {
                x: 0,
                y: 0,
                width: 4,
                height: 4,
            },
        );
        let truth = rho / std::f64::consts::PI * 3.0 * cos;
        for (i, &v) in pixels.surface.iter().enumerate() {
            // A disk's directions tilt the cosine by at most α = 0.0046 rad.
            let error = v as f64 / truth - 1.0;
            assert!(
                error.abs() < 2e-3,
                "diameter {diameter}, value {i}: {v} vs {truth} ({error})"
            );
        }
    }
    // Looking straight into the sun's disk.
    let toward = -sun.normalize();
    let scene = scene(
        json!([]),
        json!([{"type": "directional", "direction": sun.to_array(),
                "irradiance": [3, 3, 3], "angular_diameter": 0.53}]),
        json!({"position": [0, 0, 0], "look_at": toward.to_array(), "up": [0, 1, 0],
               "fov_y": 0.05}),
        json!({}),
        Assets::new(),
    );
    let pixels = render_tile(
        &scene,
        TileRect {
            x: 1,
            y: 1,
            width: 2,
            height: 2,
        },
    );
    let sin2 = (0.265f64.to_radians()).sin().powi(2);
    let disk = 3.0 / (std::f64::consts::PI * sin2);
    for &v in &pixels.surface {
        assert!(
            (v as f64 / disk - 1.0).abs() < 1e-5,
            "the disk: {v} vs {disk}"
        );
    }
}

/// The plan says how the sun is modelled.
#[test]
fn the_plan_names_the_far_point() {
    let scene = scene(
        json!([{"shape": {"type": "icosphere", "radius": 1.0, "subdivisions": 1},
                "material": {"type": "dielectric", "eta": 1.5,
                             "medium": {"sigma_t": [1, 1, 1], "albedo": [0.9, 0.9, 0.9]}}}]),
        json!([{"type": "directional", "direction": [0, -1, 0], "irradiance": [1, 1, 1]}]),
        json!({"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 30}),
        json!({}),
        Assets::new(),
    );
    let plan = describe_plan(&scene).join("\n");
    assert!(plan.contains("lights[0]: directional"), "{plan}");
}
