//! The sphere light through the whole single-scattering path against a closed form: at η = 1
//! (σ_t → 0, isotropic) the radiance scattered along a camera segment is `σ_s/(4π) ∫ Φ(x) ds`,
//! where the fluence rate of a sphere of uniform radiance `L` seen from `x` at distance `d` is
//! `Φ = 2πL(1 − cos α)`, `sin α = R/d`. Its light points lie inside the sphere (the object is
//! far enough), so the test also covers where a shadow ray toward such a point must stop: an
//! opaque box hidden inside the light must not shade anything.

#[path = "support/segment.rs"]
mod segment_support;
mod support;

use glam::DVec3;
use segment_support::{segment_to_surface, single_scatter_mean};
use serde_json::json;
use spindle_render::scatter::describe_plan;
use spindle_render::{Assets, Scene};
use support::box_obj;

/// The mean of 4096 camera samples, each with one light point, against the closed-form integral
/// (a 2000-point midpoint rule along the segment): within four of the mean's standard errors,
/// which must be under 0.5 %.
#[test]
fn single_scattering_at_eta_one_matches_the_closed_form_with_a_box_inside_the_light() {
    let (center, radius, radiance) = (DVec3::new(0.3, 1.4, -2.6), 0.4, 3.0);
    let hidden = box_obj(
        center - DVec3::splat(0.15),
        center + DVec3::splat(0.15),
        false,
    );
    let desc = serde_json::from_value(json!({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 30},
        "film": {"width": 4, "height": 4, "spp": 1},
        "lights": [{"type": "sphere", "center": center.to_array(), "radius": radius,
                    "radiance": [radiance, radiance, radiance]}],
        "objects": [
            {"shape": {"type": "icosphere", "radius": 1, "subdivisions": 3},
             "material": {"type": "dielectric", "eta": 1.0, "medium": {
                "sigma_t": [1e-12, 1e-12, 1e-12], "albedo": [1, 1, 1]}}},
            {"shape": {"type": "obj", "path": "hidden.obj"},
             "material": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}}
        ]
    }))
    .unwrap();
    let assets = Assets::from([("hidden.obj".to_string(), hidden.into_bytes())]);
    let scene = Scene::build(&desc, &assets).unwrap();
    assert!(describe_plan(&scene)[0].contains("straight_line"));
    let (origin, dir) = (
        DVec3::new(-0.6, 0.1, 0.05),
        DVec3::new(1.0, 0.2, -0.1).normalize(),
    );
    let segment = segment_to_surface(&scene, origin, dir);

    let (mean, stderr) = single_scatter_mean(&scene, &segment, 4096, (23, 1, 2));

    let steps = 2000;
    let mut integral = 0.0;
    for i in 0..steps {
        let x = origin + dir * (segment.length * (i as f64 + 0.5) / steps as f64);
        let sin_alpha = radius / x.distance(center);
        let one_minus_cos = sin_alpha * sin_alpha / (1.0 + (1.0 - sin_alpha * sin_alpha).sqrt());
        integral += std::f64::consts::TAU * radiance * one_minus_cos;
    }
    let sigma_s = 1e-12;
    let truth = sigma_s / (4.0 * std::f64::consts::PI) * integral * segment.length / steps as f64;
    let error = mean / truth - 1.0;
    println!(
        "sphere light, eta = 1: {mean:.6e} ± {stderr:.1e} vs closed form {truth:.6e} \
         ({error:+.2e}, {:.1} standard errors)",
        (mean - truth).abs() / stderr
    );
    assert!(stderr < 5e-3 * truth, "too noisy: {stderr} of {truth}");
    assert!((mean - truth).abs() < 4.0 * stderr, "{mean} vs {truth}");
}
