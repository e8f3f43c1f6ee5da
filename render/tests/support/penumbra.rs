//! The penumbra scene the progressive-pass and `stderr` tests share: a diffuse floor lit by a
//! sphere light half hidden behind an opaque box (a penumbra across the film) and a glass
//! sphere's single scattering — noisy enough that adaptive pixels stop after different batches.
//! Included with `#[path]` by the tests that use it.

use glam::DVec3;
use serde_json::json;
use spindle_render::{Assets, Scene};

use crate::support::box_obj;

/// The scene seen with vertical field of view `fov_y` (degrees) on `film` (the scene file's
/// `film` object).
pub fn scene(fov_y: f64, film: serde_json::Value) -> Scene {
    let floor = box_obj(
        DVec3::new(-10.0, -10.0, -1.0),
        DVec3::new(10.0, 10.0, 0.0),
        false,
    );
    let blocker = box_obj(
        DVec3::new(-0.2, -3.0, 0.0),
        DVec3::new(3.0, 3.0, 1.5),
        false,
    );
    let assets = Assets::from([
        ("floor.obj".to_string(), floor.into_bytes()),
        ("blocker.obj".to_string(), blocker.into_bytes()),
    ]);
    let desc = serde_json::from_value(json!({
        "camera": {"position": [-1.0, 0.0, 6.0], "look_at": [-1.0, 0.0, 0.0], "fov_y": fov_y},
        "film": film,
        "lights": [{"type": "sphere", "center": [0.0, 0.0, 3.0], "radius": 0.6,
                    "radiance": [10, 10, 10]}],
        "objects": [
            {"shape": {"type": "obj", "path": "floor.obj"},
             "material": {"type": "diffuse", "reflectance": [0.7, 0.7, 0.7]}},
            {"shape": {"type": "obj", "path": "blocker.obj"},
             "material": {"type": "diffuse", "reflectance": [0.2, 0.2, 0.2]}},
            {"shape": {"type": "icosphere", "radius": 0.5, "subdivisions": 1},
             "transform": {"translate": [-1.5, 0.0, 0.8]},
             "material": {"type": "dielectric", "eta": 1.5,
                          "medium": {"sigma_t": [1, 1, 1], "albedo": [0.9, 0.9, 0.9]}}}
        ]
    }))
    .unwrap();
    Scene::build(&desc, &assets).unwrap()
}
