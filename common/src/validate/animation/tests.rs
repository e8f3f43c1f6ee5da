use serde_json::{Value, json};

use crate::scene::SceneDescription;

/// A small valid scene with a camera, a point and a directional light, and an icosphere of
/// radius 1.
fn base() -> Value {
    json!({
        "camera": { "position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 40 },
        "film": { "width": 8, "height": 8, "spp": 1 },
        "lights": [
            { "type": "point", "position": [0, 4, 0], "intensity": [1, 1, 1] },
            { "type": "directional", "direction": [0, -1, 0], "irradiance": [1, 1, 1] }
        ],
        "objects": [ {
            "shape": { "type": "icosphere", "radius": 1, "subdivisions": 1 },
            "material": { "type": "diffuse", "reflectance": [0.5, 0.5, 0.5] }
        } ]
    })
}

fn with_animation(animation: Value) -> Value {
    let mut scene = base();
    scene["animation"] = animation;
    scene
}

fn error(scene: &Value) -> String {
    match SceneDescription::from_json(&scene.to_string()) {
        Ok(_) => panic!("accepted {scene}"),
        Err(e) => e.to_string(),
    }
}

fn keys(pairs: &[(f64, Value)]) -> Value {
    Value::Array(
        pairs
            .iter()
            .map(|(f, v)| json!({ "frame": f, "value": v }))
            .collect(),
    )
}

#[test]
fn a_valid_animation_is_accepted() {
    let scene = with_animation(json!({
        "frame_rate": 24, "frames": { "start": 1, "end": 3 },
        "camera": { "position": { "interpolation": "smooth",
            "keys": keys(&[(1.0, json!([0, 0, 5])), (2.0, json!([5, 0, 0])), (3.0, json!([0, 0, -5]))]) } },
        "objects": [ { "object": 0, "rotation": { "keys": keys(&[(1.0, json!([0, 0, 0, 1])), (3.0, json!([0, 1, 0, 1]))]) } } ],
        "lights": [ { "light": 1, "direction": { "keys": keys(&[(1.0, json!([0, -1, 0])), (3.0, json!([1, -1, 0]))]) } } ]
    }));
    SceneDescription::from_json(&scene.to_string()).unwrap();
}

#[test]
fn keys_out_of_order_or_repeated_are_named() {
    let scene = with_animation(json!({ "objects": [ { "object": 0, "translate": {
        "keys": keys(&[(1.0, json!([0, 0, 0])), (5.0, json!([1, 0, 0])), (3.0, json!([2, 0, 0]))]) } } ] }));
    assert_eq!(
        error(&scene),
        "animation.objects[0].translate.keys[2].frame: must come after keys[1].frame (5), got 3: \
         keys go in frame order"
    );
    let scene = with_animation(json!({ "camera": { "fov_y": {
        "keys": keys(&[(1.0, json!(40)), (1.0, json!(50))]) } } }));
    assert_eq!(
        error(&scene),
        "animation.camera.fov_y.keys[1].frame: repeats keys[0].frame (1): one key a frame"
    );
    let scene = with_animation(json!({ "camera": { "fov_y": { "keys": [] } } }));
    assert_eq!(
        error(&scene),
        "animation.camera.fov_y.keys: must hold at least one key"
    );
}

#[test]
fn non_finite_values_are_named() {
    let mut scene = SceneDescription::from_json(
        &with_animation(json!({ "objects": [ { "object": 0, "translate": {
            "keys": keys(&[(1.0, json!([0, 0, 0]))]) } } ] }))
        .to_string(),
    )
    .unwrap();
    let animation = scene.animation.as_mut().unwrap();
    animation.objects[0].translate.as_mut().unwrap().keys[0].value[1] = f64::NAN;
    let e = scene.validate().unwrap_err().to_string();
    assert_eq!(
        e,
        "animation.objects[0].translate.keys[0].value[1]: must be a finite number, got NaN"
    );
    let animation = scene.animation.as_mut().unwrap();
    animation.objects[0].translate.as_mut().unwrap().keys[0].value[1] = 0.0;
    animation.objects[0].translate.as_mut().unwrap().keys[0].frame = f64::INFINITY;
    let e = scene.validate().unwrap_err().to_string();
    assert_eq!(
        e,
        "animation.objects[0].translate.keys[0].frame: must be a finite number, got inf"
    );
}

#[test]
fn a_zero_quaternion_is_refused() {
    let scene = with_animation(json!({ "objects": [ { "object": 0, "rotation": {
        "keys": keys(&[(1.0, json!([0, 0, 0, 1])), (2.0, json!([0, 0, 0, 0]))]) } } ] }));
    assert!(
        error(&scene).starts_with(
            "animation.objects[0].rotation.keys[1].value: must not be the zero quaternion"
        ),
        "{}",
        error(&scene)
    );
}

#[test]
fn a_backward_frame_range_is_refused() {
    let scene = with_animation(json!({ "frames": { "start": 10, "end": 9 } }));
    assert_eq!(
        error(&scene),
        "animation.frames.end: must be at least frames.start (10), got 9: a range runs forward"
    );
    let scene = with_animation(json!({ "frames": { "start": 1, "end": 1000000 } }));
    assert_eq!(
        error(&scene),
        "animation.frames.end: must be at most 999999, got 1000000"
    );
}

#[test]
fn indices_and_kinds_are_checked() {
    let scene = with_animation(json!({ "objects": [ { "object": 1 } ] }));
    assert_eq!(
        error(&scene),
        "animation.objects[0].object: names objects[1], but the scene has 1 objects"
    );
    let scene = with_animation(json!({ "objects": [ { "object": 0 }, { "object": 0 } ] }));
    assert!(error(&scene).starts_with("animation.objects[1].object: objects[0] is animated"));
    let scene = with_animation(json!({ "lights": [ { "light": 1,
        "position": { "keys": keys(&[(1.0, json!([0, 0, 0]))]) } } ] }));
    assert!(error(&scene).starts_with("animation.lights[0].position: lights[1] is directional"));
    let scene = with_animation(json!({ "lights": [ { "light": 0,
        "direction": { "keys": keys(&[(1.0, json!([0, 1, 0]))]) } } ] }));
    assert!(
        error(&scene).starts_with("animation.lights[0].direction: lights[0] is not directional")
    );
}

/// The extent rule at the keys (linear: a convex combination of keys stays inside), and on
/// a smooth track's control points (the curve stays in their hull).
#[test]
fn the_extent_holds_at_every_frame() {
    // A key past the extent.
    let scene = with_animation(json!({ "objects": [ { "object": 0, "translate": {
        "keys": keys(&[(1.0, json!([0, 0, 0])), (2.0, json!([2e6, 0, 0]))]) } } ] }));
    assert!(
        error(&scene)
            .starts_with("animation.objects[0].translate.keys[1].value[0]: must be within ±1e6")
    );
    // Every key inside, but the bounding sphere (radius 1 · scale 10) past it at a key.
    let scene = with_animation(json!({ "objects": [ { "object": 0,
        "translate": { "keys": keys(&[(1.0, json!([0, 0, 0])), (2.0, json!([999_995, 0, 0]))]) },
        "scale": { "keys": keys(&[(1.0, json!([1, 1, 1])), (3.0, json!([10, 10, 10]))]) } } ] }));
    assert!(
        error(&scene).starts_with("animation.objects[0]: may place objects[0]'s bounding sphere"),
        "{}",
        error(&scene)
    );
    // Keys inside, a smooth curve overshooting: 0 → 9.9e5 → 9.9e5 → 0 at frames 0, 1, 9, 10
    // overshoots past 1e6 after the second key (its slope there is 9.9e5 / 9 per frame, and the
    // control point before the third key is at 9.9e5 + 8 · 1.1e5 / 3).
    let scene = with_animation(json!({ "camera": { "position": { "interpolation": "smooth",
        "keys": keys(&[(0.0, json!([0, 0, 5])), (1.0, json!([990_000, 0, 5])),
                       (9.0, json!([990_000, 0, 5])), (10.0, json!([0, 0, 5]))]) } } }));
    assert!(
        error(&scene).starts_with("animation.camera.position: the smooth curve from keys[1] to keys[2] may leave the scene's extent"),
        "{}",
        error(&scene)
    );
    // The same keys, linear: accepted.
    let mut linear = scene.clone();
    linear["animation"]["camera"]["position"]["interpolation"] = json!("linear");
    SceneDescription::from_json(&linear.to_string()).unwrap();
}

#[test]
fn the_camera_is_checked_at_every_frame() {
    // The camera passes through its look_at at frame 5.
    let scene = with_animation(json!({ "camera": { "position": {
        "keys": keys(&[(0.0, json!([0, 0, 5])), (10.0, json!([0, 0, -5]))]) } } }));
    assert_eq!(
        error(&scene),
        "animation.camera: at frame 5, camera.look_at: must differ from camera.position (the \
         camera needs a view direction)"
    );
    // A sun turning through the zero vector.
    let scene = with_animation(json!({ "lights": [ { "light": 1, "direction": {
        "keys": keys(&[(0.0, json!([0, -1, 0])), (2.0, json!([0, 1, 0]))]) } } ] }));
    assert_eq!(
        error(&scene),
        "animation.lights[0].direction: at frame 1, must be a direction, got the zero vector"
    );
}

#[test]
fn a_scale_through_zero_is_refused() {
    let scene = with_animation(json!({ "objects": [ { "object": 0, "scale": {
        "keys": keys(&[(0.0, json!([1, 1, 1])), (2.0, json!([-1, 1, 1]))]) } } ] }));
    assert!(
        error(&scene).starts_with(
            "animation.objects[0].scale: scale[0] from keys[0] to keys[1] would pass through 0"
        ),
        "{}",
        error(&scene)
    );
    // As a step, a mirror is fine.
    let mut step = scene.clone();
    step["animation"]["objects"][0]["scale"]["interpolation"] = json!("step");
    SceneDescription::from_json(&step.to_string()).unwrap();
}
