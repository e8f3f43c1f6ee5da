//! Media inside media (issue 32, parts 2 and 3): a glass slab inside a water box, against closed
//! forms that do not use the renderer's Fresnel, Snell or η² bookkeeping — the straight camera
//! path through four flat interfaces with the relative index at each; the sun through the flat
//! water surface lighting a floor inside the nested glass and scattering in the glass (the
//! power crossing each interface); and a light inside the water lighting a small nested sphere
//! as the same sphere in the air would, times the water's attenuation.

#[path = "support/optics.rs"]
mod optics;
mod support;

use std::f64::consts::PI;

use glam::DVec3;
use optics::{cos_in, fresnel};
use serde_json::{Value, json};
use spindle_common::stats::RenderStats;
use spindle_render::ray::{OFFSET_SCALE, Ray};
use spindle_render::sampler::Sampler;
use spindle_render::scatter::receiver::{Receiver, through_boundary};
use spindle_render::scatter::single_scatter;
use spindle_render::segment::Segment;
use spindle_render::transport::radiance;
use spindle_render::{Assets, Rgb, Scene};
use support::box_obj;

const WATER: f64 = 1.33;
const GLASS: f64 = 1.5;
const RHO: f64 = 0.6;

fn dielectric(path: &str, eta: f64, sigma_t: f64, albedo: f64) -> Value {
    json!({"shape": {"type": "obj", "path": path},
           "material": {"type": "dielectric", "eta": eta, "medium": {
               "sigma_t": [sigma_t, sigma_t, sigma_t], "albedo": [albedo, albedo, albedo]}}})
}

fn build(objects: Value, lights: Value, integrator: Value, assets: Assets) -> Scene {
    let scene = json!({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 10},
        "film": {"width": 4, "height": 4, "spp": 1},
        "lights": lights,
        "objects": objects,
        "integrator": integrator,
    });
    let desc = serde_json::from_value(scene).expect("test scene parses");
    Scene::build(&desc, &assets).expect("test scene builds")
}

/// Water `z ∈ [−4, 0]` (80 × 80), a glass slab `z ∈ [−3, −1]` (40 × 40) inside it, and, with
/// `floor`, a diffuse floor whose top is at `z = −2.5` inside the glass.
fn tank(sigma_water: f64, sigma_glass: f64, albedo: f64, floor: bool, lights: Value) -> Scene {
    let mut objects = vec![
        dielectric("water.obj", WATER, sigma_water, albedo),
        dielectric("glass.obj", GLASS, sigma_glass, albedo),
    ];
    let mut assets = Assets::from([
        (
            "water.obj".to_string(),
            box_obj(
                DVec3::new(-40.0, -40.0, -4.0),
                DVec3::new(40.0, 40.0, 0.0),
                false,
            )
            .into_bytes(),
        ),
        (
            "glass.obj".to_string(),
            box_obj(
                DVec3::new(-20.0, -20.0, -3.0),
                DVec3::new(20.0, 20.0, -1.0),
                false,
            )
            .into_bytes(),
        ),
    ]);
    if floor {
        objects.push(json!({"shape": {"type": "obj", "path": "floor.obj"},
            "material": {"type": "diffuse", "reflectance": [RHO, RHO, RHO]}}));
        assets.insert(
            "floor.obj".to_string(),
            box_obj(
                DVec3::new(-10.0, -10.0, -2.8),
                DVec3::new(10.0, 10.0, -2.5),
                false,
            )
            .into_bytes(),
        );
    }
    build(
        json!(objects),
        lights,
        json!({"max_depth": 16, "internal_reflections": 0}),
        assets,
    )
}

/// A camera ray straight through water, glass, water into a quad light below the tank: with no
/// internal reflections followed and a black background, the only light is the straight path's,
/// `L · Π(1 − F_i) · e^{−σ_w d_w − σ_g d_g}` with each F at its interface's *relative* index and
/// angle (the n² factors cancel from air to air). With the glass's absolute index at the
/// water–glass surfaces this would be off by several per cent at the oblique angles.
#[test]
fn a_camera_path_crosses_nested_media_with_the_relative_index_at_each_interface() {
    let l = 3.0;
    let lights = json!([{"type": "quad", "corner": [-200, -200, -6], "edge_u": [400, 0, 0],
                         "edge_v": [0, 400, 0], "radiance": [l, l, l]}]);
    let (sw, sg) = (0.3, 0.2);
    let scene = tank(sw, sg, 0.0, false, lights);
    assert_eq!(scene.outer(1), Some(0));
    assert_eq!(scene.outer(0), None);
    assert!((scene.relative_eta(1) - GLASS / WATER).abs() < 1e-15);
    let mut worst: f64 = 0.0;
    for degrees in [0.0f64, 25.0, 50.0, 70.0] {
        let theta = degrees.to_radians();
        let dir = DVec3::new(theta.sin(), 0.0, -theta.cos());
        let invariant = theta.sin();
        let (cw, cg) = (cos_in(WATER, invariant), cos_in(GLASS, invariant));
        let transmitted = (1.0 - fresnel(1.0, WATER, theta.cos()))
            * (1.0 - fresnel(WATER, GLASS, cw))
            * (1.0 - fresnel(GLASS, WATER, cg))
            * (1.0 - fresnel(WATER, 1.0, cw));
        // 2 units of water (1 above the glass, 1 below), 2 of glass, along the slanted path,
        // less the surface offset (`Ray::leaving`: δ along the normal) at each of the two
        // entries into the water and the one into the glass.
        let delta = OFFSET_SCALE * scene.scale();
        let attenuation = (-sw * (2.0 - 2.0 * delta) / cw - sg * (2.0 - delta) / cg).exp();
        let truth = l * transmitted * attenuation;
        let ray = Ray::new(DVec3::new(0.1, 0.2, 0.0) - dir * (1.0 / theta.cos()), dir);
        let mut stats = RenderStats::default();
        let seen = radiance(&scene, &ray, &mut Sampler::new(1, 0, 0, 0), &mut stats);
        let error = seen.surface.x / truth - 1.0;
        println!(
            "{degrees}°: {:.10e} vs {truth:.10e} ({error:+.2e}); single scatter {}",
            seen.surface.x, seen.single_scatter.x
        );
        assert_eq!(seen.single_scatter, Rgb::ZERO, "albedo 0 scatters nothing");
        worst = worst.max(error.abs());
    }
    assert!(worst < 1e-12, "worst relative error {worst:e}");
}

/// The sun over the tank lights the floor inside the nested glass through two flat interfaces:
/// the power crossing a unit of each horizontal surface is conserved but for `(1 − F)` there, so
/// the floor receives `E cos θ₀ (1 − F₀)(1 − F₁) e^{−σ_w d_w/cos θ_w − σ_g d_g/cos θ_g}`, the
/// water's surface giving the directional light in the water (`flat_face`) and the glass's
/// surface the one refraction the receiver connection solves. Through the receiver connection
/// alone, and through the whole camera path from the air.
#[test]
fn the_sun_through_the_water_lights_a_floor_inside_the_nested_glass() {
    let e = 2.0;
    let mut worst: f64 = 0.0;
    for sun in [DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.5, 0.3, -1.0)] {
        for (sw, sg) in [(0.0, 0.0), (0.4, 0.7)] {
            let lights = json!([{"type": "directional", "direction": sun.to_array(),
                                 "irradiance": [e, e, e]}]);
            let scene = tank(sw, sg, 0.5, true, lights);
            let cos0 = -sun.normalize().z;
            let invariant = (1.0 - cos0 * cos0).sqrt();
            let (cw, cg) = (cos_in(WATER, invariant), cos_in(GLASS, invariant));
            let e_floor = e
                * cos0
                * (1.0 - fresnel(1.0, WATER, cos0))
                * (1.0 - fresnel(WATER, GLASS, cw))
                * (-sw * 1.0 / cw - sg * 1.5 / cg).exp();
            let truth = RHO / PI * e_floor;

            // The receiver connection alone: a camera segment in the glass, straight down from
            // its top to the floor.
            let on_floor = DVec3::new(0.3, -0.2, -2.5);
            let segment = Segment {
                origin: on_floor + DVec3::Z * 1.5,
                dir: -DVec3::Z,
                length: 1.5,
                object: 1,
                throughput: Rgb::ONE,
            };
            let receiver = Receiver {
                p: on_floor,
                normal: DVec3::Z,
                geometric: DVec3::Z,
                reflectance: Rgb::splat(RHO),
            };
            let mut stats = RenderStats::default();
            let mut sampler = Sampler::new(3, 0, 0, 0);
            let value = through_boundary(&scene, &segment, &receiver, &mut sampler, &mut stats);
            let error = value.x / truth - 1.0;
            println!(
                "sun {sun}, σ ({sw}, {sg}): receiver {:.10e} vs {truth:.10e} ({error:+.2e}), \
                 {} refraction point(s)",
                value.x, stats.samples
            );
            // One refraction point through the glass's top per flat face of the water that faces
            // the sun (the sides' are blocked on their way to their face).
            assert!((1..=3).contains(&stats.samples), "{} points", stats.samples);
            worst = worst.max(error.abs());

            // The whole camera path, straight down from the air: its throughput to the floor
            // is Π(1 − F)/n_g² at normal incidence, times the attenuation down to it.
            let f = |n1, n2| fresnel(n1, n2, 1.0);
            let throughput = (1.0 - f(1.0, WATER)) * (1.0 - f(WATER, GLASS)) / (GLASS * GLASS)
                * (-sw * 1.0 - sg * 1.5).exp();
            let ray = Ray::new(DVec3::new(0.3, -0.2, 2.0), -DVec3::Z);
            let mut stats = RenderStats::default();
            let seen = radiance(&scene, &ray, &mut Sampler::new(3, 0, 0, 0), &mut stats);
            let error = seen.surface.x / (throughput * truth) - 1.0;
            println!("    camera path: {:.10e} ({error:+.2e})", seen.surface.x);
            worst = worst.max(error.abs());
        }
    }
    // As for one interface (render/tests/receivers.rs), the sun's far point spreads its rays by
    // about 1e-5 over the depths here.
    println!("worst relative error {worst:.2e}");
    assert!(worst < 3e-5, "worst relative error {worst:e}");
}

/// Single scattering in the nested glass from the sun through the water's surface: along a
/// camera segment straight down from the glass's top, the light at depth t has crossed the water
/// (d_w = 1) and t/cos θ_g of glass, so with an isotropic phase the radiance toward the camera is
/// `σ_s/(4π) E_g ∫₀^ℓ e^{−σ_g t (1 + 1/cos θ_g)} dt`, `E_g = E (1 − F₀)(1 − F₁) cos θ₀/cos θ_g
/// e^{−σ_w/cos θ_w}` the perpendicular irradiance just inside the glass.
#[test]
fn the_sun_through_the_water_scatters_in_the_nested_glass() {
    let e = 2.0;
    let (sw, sg, albedo) = (0.4, 0.8, 0.6);
    let mut worst: f64 = 0.0;
    for sun in [DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.6, -0.2, -1.0)] {
        let lights = json!([{"type": "directional", "direction": sun.to_array(),
                             "irradiance": [e, e, e]}]);
        let scene = tank(sw, sg, albedo, false, lights);
        let cos0 = -sun.normalize().z;
        let invariant = (1.0 - cos0 * cos0).sqrt();
        let (cw, cg) = (cos_in(WATER, invariant), cos_in(GLASS, invariant));
        let e_glass =
            e * (1.0 - fresnel(1.0, WATER, cos0)) * (1.0 - fresnel(WATER, GLASS, cw)) * cos0 / cg
                * (-sw / cw).exp();
        let length = 1.5;
        let k = sg * (1.0 + 1.0 / cg);
        let truth = albedo * sg / (4.0 * PI) * e_glass * (1.0 - (-k * length).exp()) / k;
        let segment = Segment {
            origin: DVec3::new(0.2, 0.1, -1.0 - 1e-9),
            dir: -DVec3::Z,
            length,
            object: 1,
            throughput: Rgb::ONE,
        };
        let samples = 64;
        let mut sum = 0.0;
        let mut stats = RenderStats::default();
        for i in 0..samples {
            let mut sampler = Sampler::new(5, 0, 0, i);
            sum += single_scatter(&scene, &segment, &mut sampler, &mut stats).x;
        }
        let estimate = sum / f64::from(samples);
        let error = estimate / truth - 1.0;
        println!(
            "sun {sun}: {estimate:.10e} vs {truth:.10e} ({error:+.2e}), {} samples",
            stats.samples
        );
        worst = worst.max(error.abs());
    }
    println!("worst relative error {worst:.2e}");
    assert!(worst < 1e-3, "worst relative error {worst:e}");
}

/// A point light inside the water and a small glass ball nested in it: single scattering in the
/// ball sees the light through the ball's one surface at the relative index, attenuated by the
/// water on the way. So it equals, sample for sample, the same ball in the air with the index
/// `n_g/n_w` and the light in the air, times the water's `e^{−σ_w d}` — d within the ball's
/// radius of the light's distance to its centre.
#[test]
fn a_light_in_the_water_lights_a_nested_ball_as_the_ball_in_air_times_the_attenuation() {
    let ball = |eta: f64| {
        json!({"shape": {"type": "icosphere", "radius": 0.05, "subdivisions": 3},
               "material": {"type": "dielectric", "eta": eta, "medium": {
                   "sigma_t": [2, 2, 2], "albedo": [0.8, 0.8, 0.8]}}})
    };
    let light = json!([{"type": "point", "position": [0, 2, 0], "intensity": [5, 5, 5]}]);
    let sw = 0.5;
    let water = json!({"shape": {"type": "obj", "path": "water.obj"},
        "material": {"type": "dielectric", "eta": WATER, "medium": {
            "sigma_t": [sw, sw, sw], "albedo": [0, 0, 0]}}});
    let assets = Assets::from([(
        "water.obj".to_string(),
        box_obj(DVec3::splat(-5.0), DVec3::splat(5.0), false).into_bytes(),
    )]);
    let nested = build(
        json!([water, ball(GLASS)]),
        light.clone(),
        json!({}),
        assets,
    );
    let alone = build(
        json!([ball(GLASS / WATER)]),
        light,
        json!({}),
        Assets::new(),
    );
    let segment = |object| Segment {
        origin: DVec3::new(0.01, 0.0, 0.04),
        dir: DVec3::new(0.1, 0.0, -1.0).normalize(),
        length: 0.07,
        object,
        throughput: Rgb::ONE,
    };
    let (mut in_water, mut in_air) = (0.0, 0.0);
    for i in 0..32 {
        let mut stats = RenderStats::default();
        in_water += single_scatter(
            &nested,
            &segment(1),
            &mut Sampler::new(9, 0, 0, i),
            &mut stats,
        )
        .x;
        in_air += single_scatter(
            &alone,
            &segment(0),
            &mut Sampler::new(9, 0, 0, i),
            &mut stats,
        )
        .x;
    }
    let ratio = in_water / in_air;
    let (near, far) = ((-sw * 2.05f64).exp(), (-sw * 1.95f64).exp());
    println!(
        "in water {in_water:.8e}, in air {in_air:.8e}: ratio {ratio:.6} in [{near:.6}, {far:.6}]"
    );
    assert!(in_air > 0.0);
    assert!(near <= ratio && ratio <= far, "ratio {ratio}");
}
