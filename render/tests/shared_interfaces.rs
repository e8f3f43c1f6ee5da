//! Shared interfaces (issue 32, part 2): two media whose surfaces coincide meet at one interface
//! with the index of one over the other, not at two interfaces with a film of air — checked
//! against closed forms that do not use the renderer's Fresnel, Snell or η² bookkeeping: a
//! camera path straight through a glass lid, water and a glass floor stacked face to face; and
//! the sun scattering in water whose side wall is shared with a glass pane, lit through the free
//! top alone (the pane's side would be a second interface). Then the layouts refused.

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
use spindle_render::scatter::single_scatter;
use spindle_render::segment::Segment;
use spindle_render::transport::radiance;
use spindle_render::{Assets, Rgb, Scene};
use support::box_obj;

const WATER: f64 = 1.33;
const GLASS: f64 = 1.5;

fn dielectric(path: &str, eta: f64, sigma_t: f64, albedo: f64) -> Value {
    json!({"shape": {"type": "obj", "path": path},
           "material": {"type": "dielectric", "eta": eta, "medium": {
               "sigma_t": [sigma_t, sigma_t, sigma_t], "albedo": [albedo, albedo, albedo]}}})
}

/// The scene of `boxes` (name, index, σt, albedo, corners), or its error.
fn try_build(
    boxes: &[(&str, f64, f64, f64, DVec3, DVec3)],
    lights: Value,
) -> Result<Scene, String> {
    let objects: Vec<Value> = boxes
        .iter()
        .map(|&(name, eta, sigma, albedo, _, _)| dielectric(name, eta, sigma, albedo))
        .collect();
    let assets: Assets = boxes
        .iter()
        .map(|&(name, _, _, _, lo, hi)| (name.to_string(), box_obj(lo, hi, false).into_bytes()))
        .collect();
    let scene = json!({
        "camera": {"position": [0, 0, 50], "look_at": [0, 0, 0], "fov_y": 10},
        "film": {"width": 4, "height": 4, "spp": 1},
        "lights": lights,
        "objects": objects,
        "integrator": {"max_depth": 16, "internal_reflections": 0},
    });
    let desc = serde_json::from_value(scene).expect("test scene parses");
    Scene::build(&desc, &assets).map_err(|e| e.to_string())
}

fn build(boxes: &[(&str, f64, f64, f64, DVec3, DVec3)], lights: Value) -> Scene {
    try_build(boxes, lights).expect("test scene builds")
}

/// A glass lid `z ∈ [−1, 0]`, water `z ∈ [−3, −1]` and a glass floor `z ∈ [−4, −3]`, face to face
/// (20 × 20 each), over a quad light. A camera ray straight through them: with no internal
/// reflections followed and a black background, the only light is the straight path's,
/// `L · Π(1 − F_i) · e^{−Σ σ d / cos θ}`, with F at glass over air, *water over glass*, glass over
/// water and air over glass — the two shared faces each one interface between the two media.
/// As two interfaces with a film of air between (the model before shared interfaces), the
/// transmittance would be 11 % lower at 0° and 48 % lower at 70°.
#[test]
fn a_camera_path_crosses_a_shared_face_once_with_the_index_of_one_medium_over_the_other() {
    let l = 3.0;
    let lights = json!([{"type": "quad", "corner": [-200, -200, -6], "edge_u": [400, 0, 0],
                         "edge_v": [0, 400, 0], "radiance": [l, l, l]}]);
    let (sg, sw) = (0.2, 0.3);
    let (lo, hi) = (DVec3::new(-10.0, -10.0, 0.0), DVec3::new(10.0, 10.0, 0.0));
    let z = |z: f64| DVec3::new(0.0, 0.0, z);
    let scene = build(
        &[
            ("lid.obj", GLASS, sg, 0.0, lo + z(-1.0), hi),
            ("water.obj", WATER, sw, 0.0, lo + z(-3.0), hi + z(-1.0)),
            ("floor.obj", GLASS, sg, 0.0, lo + z(-4.0), hi + z(-3.0)),
        ],
        lights,
    );
    // Side by side, not nested: the water's vertices lie on the glass, but the air is around it.
    assert_eq!(scene.outer(1), None);
    assert_eq!(
        scene.across(1, DVec3::new(0.3, 0.2, -1.0), DVec3::Z),
        Some(0)
    );
    assert_eq!(
        scene.across(1, DVec3::new(0.3, 0.2, -3.0), -DVec3::Z),
        Some(2)
    );
    assert_eq!(scene.across(0, DVec3::new(0.3, 0.2, 0.0), DVec3::Z), None);
    let plan = spindle_render::scatter::describe_plan(&scene);
    assert!(
        plan.iter().any(|l| l.starts_with(
            "objects[0] and objects[1]: meet at a shared interface (relative index 0.8867)"
        )),
        "{plan:?}"
    );
    let mut worst: f64 = 0.0;
    for degrees in [0.0f64, 25.0, 50.0, 70.0] {
        let theta = degrees.to_radians();
        let dir = DVec3::new(theta.sin(), 0.0, -theta.cos());
        let invariant = theta.sin();
        let (cg, cw) = (cos_in(GLASS, invariant), cos_in(WATER, invariant));
        let transmitted = (1.0 - fresnel(1.0, GLASS, theta.cos()))
            * (1.0 - fresnel(GLASS, WATER, cg))
            * (1.0 - fresnel(WATER, GLASS, cw))
            * (1.0 - fresnel(GLASS, 1.0, cg));
        // 1 of glass, 2 of water, 1 of glass along the slanted path, less the surface offset
        // (`Ray::leaving`: δ along the normal) at each of the three media's entries.
        let delta = OFFSET_SCALE * scene.scale();
        let attenuation = (-sg * 2.0 * (1.0 - delta) / cg - sw * (2.0 - delta) / cw).exp();
        let truth = l * transmitted * attenuation;
        let film_of_air = (1.0 - fresnel(1.0, GLASS, theta.cos()))
            * (1.0 - fresnel(GLASS, 1.0, cg))
            * (1.0 - fresnel(1.0, WATER, theta.cos()))
            * (1.0 - fresnel(WATER, 1.0, cw))
            * (1.0 - fresnel(1.0, GLASS, theta.cos()))
            * (1.0 - fresnel(GLASS, 1.0, cg))
            * l
            * attenuation;
        let ray = Ray::new(DVec3::new(0.1, 0.2, 0.0) - dir * (1.0 / theta.cos()), dir);
        let mut stats = RenderStats::default();
        let seen = radiance(&scene, &ray, &mut Sampler::new(1, 0, 0, 0), &mut stats);
        let error = seen.surface.x / truth - 1.0;
        println!(
            "{degrees}°: {:.10e} vs {truth:.10e} ({error:+.2e}); as a film of air {film_of_air:.6e}",
            seen.surface.x
        );
        assert!(
            film_of_air / truth < 0.96,
            "the test tells the two models apart"
        );
        worst = worst.max(error.abs());
    }
    assert!(worst < 1e-12, "worst relative error {worst:e}");
}

/// Water `x ∈ [−1, 1]`, `z ∈ [−2, 0]` (40 long in y) under the sun from the +x side, with a
/// glass pane against its +x wall. Inside the water the sun is a directional light along the
/// refracted direction, with irradiance `E (1 − F) cos θ₀ / cos θ_w` across it; a point at depth
/// `s` on the vertical line `x = x₀` sees it through the free top only while its refracted ray
/// back to the sun reaches the top before the wall, `s ≤ (1 − x₀) / tan θ_w`: deeper, the light
/// would cross the pane and the shared wall, two interfaces, which give nothing. So a camera
/// segment straight down from the top along that line scatters
/// `σ_s/(4π) E_w (1 − e^{−k s*}) / k`, `k = σ_t (1 + 1/cos θ_w)`, `s* = min(H, (1 − x₀)/tan θ_w)`.
/// Without the pane the wall is the water's own surface to the air and lets the sun in below
/// `s*`: the same segment is brighter, which the test also checks.
#[test]
fn a_shared_wall_lets_no_light_in_and_the_free_top_lets_in_the_closed_form() {
    let e = 2.0;
    let (sigma, albedo) = (0.5, 0.7);
    let sun = DVec3::new(-0.6, 0.0, -1.0);
    let lights = json!([{"type": "directional", "direction": sun.to_array(),
                         "irradiance": [e, e, e]}]);
    let water = (
        "water.obj",
        WATER,
        sigma,
        albedo,
        DVec3::new(-1.0, -20.0, -2.0),
        DVec3::new(1.0, 20.0, 0.0),
    );
    let pane = (
        "pane.obj",
        GLASS,
        0.1,
        0.0,
        DVec3::new(1.0, -20.0, -2.0),
        DVec3::new(1.5, 20.0, 0.0),
    );
    let cos0 = -sun.normalize().z;
    let invariant = (1.0 - cos0 * cos0).sqrt();
    let cw = cos_in(WATER, invariant);
    let tan_w = (1.0 - cw * cw).sqrt() / cw;
    let e_water = e * (1.0 - fresnel(1.0, WATER, cos0)) * cos0 / cw;
    let k = sigma * (1.0 + 1.0 / cw);
    let (x0, length) = (0.85, 1.5);
    let s_star = ((1.0 - x0) / tan_w).min(length);
    let truth = albedo * sigma / (4.0 * PI) * e_water * (1.0 - (-k * s_star).exp()) / k;
    let segment = Segment {
        origin: DVec3::new(x0, 0.3, -1e-9),
        dir: -DVec3::Z,
        length,
        object: 0,
        throughput: Rgb::ONE,
    };
    let scattered = |scene: &Scene| {
        let samples = 64;
        let mut stats = RenderStats::default();
        let sum: f64 = (0..samples)
            .map(|i| single_scatter(scene, &segment, &mut Sampler::new(5, 0, 0, i), &mut stats).x)
            .sum();
        sum / f64::from(samples)
    };
    let shared = scattered(&build(&[water, pane], lights.clone()));
    let open = scattered(&build(&[water], lights));
    let error = shared / truth - 1.0;
    println!(
        "s* = {s_star:.4}: shared wall {shared:.8e} vs {truth:.8e} ({error:+.2e}); \
         without the pane {open:.8e}"
    );
    assert!(error.abs() < 1e-3, "relative error {error:e}");
    assert!(open > 1.2 * truth, "the open wall lets the sun in below s*");
}

/// The layouts that are not one interface are refused before rendering, naming both objects:
/// surfaces 1e-8 apart (within touching distance, not coincident), and an object resting against
/// the inside of the medium around it. A clear gap is two interfaces with a film of air between,
/// as before.
#[test]
fn contact_that_is_not_one_interface_is_refused_naming_both_objects() {
    let lights = json!([{"type": "directional", "direction": [0, 0, -1], "irradiance": [1, 1, 1]}]);
    let lid = (
        "lid.obj",
        GLASS,
        0.1,
        0.0,
        DVec3::new(-1.0, -1.0, 0.0),
        DVec3::new(1.0, 1.0, 1.0),
    );
    let water_at = |top: f64| {
        (
            "water.obj",
            WATER,
            0.1,
            0.0,
            DVec3::new(-1.0, -1.0, -1.0),
            DVec3::new(1.0, 1.0, top),
        )
    };
    let near = try_build(&[lid, water_at(-1e-8)], lights.clone()).expect_err("1e-8 apart");
    println!("{near}");
    assert!(
        near.contains("objects[1]") && near.contains("objects[0]") && near.contains("coincid"),
        "{near}"
    );
    let gap = try_build(&[lid, water_at(-1e-3)], lights.clone()).expect("a clear gap");
    assert_eq!(gap.across(1, DVec3::new(0.0, 0.0, -1e-3), DVec3::Z), None);
    let inner = (
        "inner.obj",
        GLASS,
        0.1,
        0.0,
        DVec3::new(-0.5, -0.5, -1.0),
        DVec3::new(0.5, 0.5, -0.5),
    );
    let resting = try_build(&[water_at(0.0), inner], lights).expect_err("resting inside");
    println!("{resting}");
    assert!(
        resting.contains("objects[1]")
            && resting.contains("objects[0]")
            && resting.contains("from inside"),
        "{resting}"
    );
}
