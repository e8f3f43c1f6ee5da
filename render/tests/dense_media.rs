//! Dense media: the interval method with K = 1 against the closed form of a flat interface over a
//! semi-infinite medium, and against point sampling on whole images, from σ_t → 0 to σ_t = 1e4.
//! Before depths were sampled by attenuation, K = 1 was 82× dark at σ_t = 100 on the slab and
//! lost all light at 1e4.

mod support;

use glam::DVec3;
use serde_json::{Value, json};
use spindle_common::stats::RenderStats;
use spindle_common::tile::TileRect;
use spindle_render::sampler::Sampler;
use spindle_render::scatter::single_scatter;
use spindle_render::segment::Segment;
use spindle_render::{Assets, Rgb, Scene, render_tile};
use support::box_obj;

/// A scene of one dielectric box (η 1.5) with the given medium, lights, camera and integrator.
fn box_scene(obj: String, medium: Value, lights: Value, camera: Value, ss: Value) -> Scene {
    let scene = json!({
        "camera": camera,
        "film": {"width": 8, "height": 8, "spp": 1},
        "lights": lights,
        "objects": [{
            "shape": {"type": "obj", "path": "box.obj"},
            "material": {"type": "dielectric", "eta": 1.5, "medium": medium}
        }],
        "integrator": {"single_scatter": ss}
    });
    let desc = serde_json::from_value(scene).expect("test scene parses");
    let assets = Assets::from([("box.obj".to_string(), obj.into_bytes())]);
    Scene::build(&desc, &assets).expect("test scene builds")
}

/// Unpolarised Fresnel reflectance from air onto index `eta` at incidence cosine `c` (written
/// out here so the closed form does not lean on the renderer's own).
fn fresnel_air_to(eta: f64, c: f64) -> f64 {
    let s = (1.0 - c * c).sqrt() / eta;
    let ct = (1.0 - s * s).sqrt();
    let rs = (c - eta * ct) / (c + eta * ct);
    let rp = (eta * c - ct) / (eta * c + ct);
    0.5 * (rs * rs + rp * rp)
}

/// Single scattering from a flat interface over a semi-infinite medium, at the entry point P of
/// a camera ray, for σ_t → ∞ (then only depths ≪ every other length matter, so every factor but
/// the attenuation is its value at P). With the light's direction ω_L at angle θ_L, refracted to
/// θ_V inside (ω_V), and the camera segment at θ_c to the inward normal, the paths at depth
/// `t cos θ_c` have `d_V = t cos θ_c / cos θ_V` and irradiance `T_P I cos θ_L/(d_L² cos θ_V)`
/// (physics.md eq. 1 with eq. 3 at d_V = 0), so
/// `∫ σ_s p T_P I cos θ_L/(d_L² cos θ_V) e^{−σ_t t (1 + cos θ_c/cos θ_V)} dt
///  = α p T_P I cos θ_L / (d_L² (cos θ_V + cos θ_c))` — the Hanrahan–Krueger single-scattering
/// form, independent of σ_t. (The camera side's `T(V_min)/η²` is the throughput's, not in it.)
fn semi_infinite(p: DVec3, dir: DVec3, light: DVec3, intensity: f64, albedo: f64) -> f64 {
    let eta = 1.5;
    let n = DVec3::Z;
    let to_light = light - p;
    let d_l = to_light.length();
    let omega_l = to_light / d_l;
    let cos_l = omega_l.dot(n);
    let sin_v = (1.0 - cos_l * cos_l).sqrt() / eta;
    let cos_v = (1.0 - sin_v * sin_v).sqrt();
    // ω_V: the light's direction of travel inside, in the plane of ω_L and n.
    let tangent = (omega_l - cos_l * n).normalize_or_zero();
    let omega_v = -cos_v * n - sin_v * tangent;
    let cos_c = dir.dot(-n);
    let phase = 1.0 / (4.0 * std::f64::consts::PI);
    assert!((omega_v.length() - 1.0).abs() < 1e-12 && omega_v.dot(-dir) <= 1.0);
    let t_p = 1.0 - fresnel_air_to(eta, cos_l);
    albedo * phase * t_p * intensity * cos_l / (d_l * d_l * (cos_v + cos_c))
}

/// The semi-infinite medium's closed form at σ_t = 1e3 … 1e5, by the interval method with one
/// deterministic sample per interval and by point sampling with 16 points per segment.
#[test]
fn flat_interface_over_a_semi_infinite_medium() {
    let light = DVec3::new(1.3, 0.4, 3.0);
    let camera = DVec3::new(-0.8, 0.3, 4.0);
    let p = DVec3::new(0.2, -0.1, 0.0);
    let eta = 1.5;
    // The camera ray refracted at P into the medium.
    let d0 = (p - camera).normalize();
    let cos_i = -d0.z;
    let sin_t = (1.0 - cos_i * cos_i).sqrt() / eta;
    let tangent = DVec3::new(d0.x, d0.y, 0.0).normalize();
    let dir = sin_t * tangent - (1.0 - sin_t * sin_t).sqrt() * DVec3::Z;
    let obj = box_obj(
        DVec3::new(-50.0, -50.0, -2.0),
        DVec3::new(50.0, 50.0, 0.0),
        false,
    );
    let albedo = 0.9;
    let truth = semi_infinite(p, dir, light, 5.0, albedo);
    for sigma in [1e3, 1e4, 1e5] {
        for (name, ss) in [
            ("interval K = 1", json!({"method": "interval", "k": 1})),
            ("interval K = 64", json!({"method": "interval", "k": 64})),
            (
                "point sampling M = 16",
                json!({"method": "point_sampling", "samples_per_segment": 16}),
            ),
        ] {
            let scene = box_scene(
                obj.clone(),
                json!({"sigma_t": [sigma, sigma, sigma], "albedo": [albedo, albedo, albedo]}),
                json!([{"type": "point", "position": light.to_array(), "intensity": [5, 5, 5]}]),
                json!({"position": camera.to_array(), "look_at": p.to_array(), "fov_y": 10}),
                ss,
            );
            let segment = Segment {
                origin: p,
                dir,
                length: 2.0 / -dir.z,
                object: 0,
                throughput: Rgb::ONE,
            };
            let mut stats = RenderStats::default();
            let mut sampler = Sampler::new(1, 0, 0, 0);
            let value = single_scatter(&scene, &segment, &mut sampler, &mut stats);
            let error = value.x / truth - 1.0;
            println!(
                "σt {sigma:e}, {name}: {:.6e} vs closed form {truth:.6e} ({:+.3}%)",
                value.x,
                100.0 * error
            );
            assert!(error.abs() < 0.01, "σt {sigma}, {name}: {value} vs {truth}");
            assert_eq!(value.x, value.y);
        }
    }
}

/// The mean of the `single_scatter` layer of the 8×8 image.
fn image_mean(scene: &Scene) -> f64 {
    let tile = render_tile(
        scene,
        TileRect {
            x: 0,
            y: 0,
            width: 8,
            height: 8,
        },
    );
    assert!(tile.single_scatter.iter().all(|v| v.is_finite()));
    tile.single_scatter
        .iter()
        .map(|&v| f64::from(v))
        .sum::<f64>()
        / tile.single_scatter.len() as f64
}

/// The slab of the issue (`[-1,1]² × [-0.15, 0.15]`, camera at z = −5, a point light on the
/// camera's side), and a glass sphere lit from the front: interval K = 1 within 1% of point
/// sampling (M = 256, stratified by the camera side's attenuation) from σ_t = 0.01 to 1e4.
#[test]
fn k_one_agrees_with_point_sampling_from_thin_to_dense() {
    let slab = |sigma: f64, ss: Value| {
        box_scene(
            box_obj(
                DVec3::new(-1.0, -1.0, -0.15),
                DVec3::new(1.0, 1.0, 0.15),
                false,
            ),
            json!({"sigma_t": [sigma, sigma, sigma], "albedo": [0.9, 0.9, 0.9]}),
            json!([{"type": "point", "position": [2.83, 0, -2.83], "intensity": [10, 10, 10]}]),
            json!({"position": [0, 0, -5], "look_at": [0, 0, 0], "fov_y": 30}),
            ss,
        )
    };
    let sphere = |sigma: f64, ss: Value| {
        let scene = json!({
            "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 30},
            "film": {"width": 8, "height": 8, "spp": 1},
            "lights": [{"type": "point", "position": [2.5, 1, 4], "intensity": [10, 10, 10]}],
            "objects": [{"shape": {"type": "icosphere", "radius": 1, "subdivisions": 3},
                "material": {"type": "dielectric", "eta": 1.5,
                    "medium": {"sigma_t": [sigma, sigma, sigma], "albedo": [0.9, 0.9, 0.9]}}}],
            "integrator": {"single_scatter": ss}
        });
        Scene::build(&serde_json::from_value(scene).unwrap(), &Assets::new()).unwrap()
    };
    let k1 = json!({"method": "interval", "k": 1});
    let ps = json!({"method": "point_sampling", "samples_per_segment": 256});
    type Build = dyn Fn(f64, Value) -> Scene;
    let cases: [(&str, &Build, &[f64]); 2] = [
        ("slab", &slab, &[0.01, 1.0, 100.0, 1e4]),
        ("sphere", &sphere, &[100.0, 1e4]),
    ];
    for (name, build, sigmas) in cases {
        for &sigma in sigmas {
            let interval = image_mean(&build(sigma, k1.clone()));
            let points = image_mean(&build(sigma, ps.clone()));
            let error = interval / points - 1.0;
            println!(
                "{name} σt {sigma:e}: interval K = 1 {interval:.6e}, point sampling {points:.6e} ({:+.3}%)",
                100.0 * error
            );
            assert!(points > 0.0 && error.abs() < 0.01, "{name} σt {sigma}");
        }
    }
}
