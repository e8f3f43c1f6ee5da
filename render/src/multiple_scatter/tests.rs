use serde_json::json;

use super::*;
use crate::Assets;

fn scene(albedo: f64, integrator: serde_json::Value) -> Scene {
    let desc = serde_json::from_value(json!({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 30},
        "film": {"width": 4, "height": 4},
        "lights": [{"type": "point", "position": [3, 3, 3], "intensity": [1, 1, 1]}],
        "objects": [
            {"shape": {"type": "icosphere", "radius": 1, "subdivisions": 1},
             "material": {"type": "dielectric", "eta": 1.5, "medium": {
                 "sigma_t": [1, 1, 1], "albedo": [albedo, albedo, albedo]}}},
            {"shape": {"type": "icosphere", "radius": 0.5, "subdivisions": 1},
             "transform": {"translate": [3, 0, 0]},
             "material": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}}
        ],
        "integrator": integrator
    }))
    .unwrap();
    Scene::build(&desc, &Assets::new()).unwrap()
}

/// The plan says per object whether multiple scattering runs, with which model, and why not.
#[test]
fn the_plan_says_whether_and_how_it_runs() {
    let on = scene(0.9, json!({}));
    assert_eq!(plan(&on, 0).model, Some(Model::Interval));
    assert_eq!(
        describe(&on),
        [
            "objects[0]: multiple scattering, orders 2 to 64, 1 path per camera segment, each \
          segment's light by interval (method auto: the single-scattering model)"
        ]
    );
    let straight = scene(
        0.9,
        json!({"multiple_scatter": {"method": "straight_line", "paths": 4}}),
    );
    assert_eq!(plan(&straight, 0).model, Some(Model::StraightLine));
    assert!(describe(&straight)[0].contains("4 paths per camera segment"));
    for (albedo, integrator, why) in [
        (0.0, json!({}), "sigma_s = 0"),
        (
            0.9,
            json!({"multiple_scatter": {"max_order": 1}}),
            "max_order 1",
        ),
        (
            0.9,
            json!({"single_scatter": {"method": "none"}}),
            "model is none",
        ),
    ] {
        let s = scene(albedo, integrator);
        assert_eq!(plan(&s, 0).model, None);
        let line = &describe(&s)[0];
        assert!(
            line.starts_with("objects[0]: multiple scattering off (") && line.contains(why),
            "{line}"
        );
    }
    assert_eq!(plan(&on, 1).model, None, "a diffuse object has no medium");
}
