//! glTF node animations as spindle tracks, on the hand-written cube scene (`support`): each
//! frame's imported placement against the value glTF's interpolation gives by hand, and the
//! errors that name the sampler at fault.

// Shared with gltf_files.rs, which uses the rest of it.
#[allow(dead_code)]
mod support;

use std::path::{Path, PathBuf};

use serde_json::{Value, json};
use spindle_common::scene::{Light, SceneDescription};
use spindle_import::{ImportError, Imported, Options, import_gltf};
use support::{add_animation, glass_cube};

fn import(document: &Value) -> Result<Imported, ImportError> {
    let dir = tempfile::tempdir().unwrap();
    let path: PathBuf = write(dir.path(), document);
    import_gltf(&path, &Options::default())
}

fn write(dir: &Path, document: &Value) -> PathBuf {
    let path = dir.join("scene.gltf");
    std::fs::write(&path, serde_json::to_string_pretty(document).unwrap()).unwrap();
    path
}

/// The glass cube's node (`nodes[1]`: scale 0.5) moved from (0, 1, 0) at 0 s to (0, 2, 0) at
/// 1 s, with `interpolation`.
fn moving_cube(interpolation: &str) -> SceneDescription {
    let mut document = glass_cube();
    add_animation(&mut document);
    document["animations"][0]["samplers"][0]["interpolation"] = json!(interpolation);
    import(&document).unwrap().files.desc
}

fn translate_at(desc: &SceneDescription, frame: u32) -> [f64; 3] {
    desc.at_frame(frame).objects[1].transform.translate
}

#[test]
fn a_linear_translation_becomes_keys_at_every_frame() {
    let desc = moving_cube("LINEAR");
    let animation = desc.animation.as_ref().unwrap();
    // 0 s … 1 s at 24 frames a second.
    assert_eq!(
        animation.frames,
        Some(spindle_common::scene::FrameRange { start: 0, end: 24 })
    );
    assert_eq!(animation.frame_rate, Some(24.0));
    assert_eq!(translate_at(&desc, 0), [0.0, 1.0, 0.0]);
    assert_eq!(translate_at(&desc, 12), [0.0, 1.5, 0.0]);
    assert_eq!(translate_at(&desc, 6), [0.0, 1.25, 0.0]);
    assert_eq!(translate_at(&desc, 24), [0.0, 2.0, 0.0]);
    assert_eq!(translate_at(&desc, 100), [0.0, 2.0, 0.0]);
    // The node's own scale is kept, and the OBJ holds the node's own vertices (a unit cube's
    // corners at ±1, not the placed ±0.5).
    let still = desc.at_frame(12);
    assert_eq!(still.objects[1].transform.scale, [0.5, 0.5, 0.5]);
    assert_eq!(still.objects[1].transform.rotate_deg, [0.0, 0.0, 0.0]);
    // The floor (not animated) keeps its placed vertices and no track.
    assert!(animation.objects.iter().all(|a| a.object == 1));
}

#[test]
fn step_and_cubic_spline_samplers() {
    let desc = moving_cube("STEP");
    assert_eq!(translate_at(&desc, 12), [0.0, 1.0, 0.0]);
    assert_eq!(translate_at(&desc, 23), [0.0, 1.0, 0.0]);
    assert_eq!(translate_at(&desc, 24), [0.0, 2.0, 0.0]);

    // CUBICSPLINE: (in-tangent, value, out-tangent) per key. Key 0's out-tangent (0, 2, 0) per
    // second, key 1's in-tangent 0: at s = 1/2 over 1 s, h00 = h01 = 1/2, h10 = 1/8, h11 = −1/8:
    // y = ½·1 + ⅛·1·2 + ½·2 − ⅛·1·0 = 1.75.
    let mut document = glass_cube();
    add_animation(&mut document);
    let output = support_vec3(
        &mut document,
        &[
            [0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 2.0, 0.0],
            [0.0, 0.0, 0.0],
            [0.0, 2.0, 0.0],
            [0.0, 0.0, 0.0],
        ],
    );
    document["animations"][0]["samplers"][0]["output"] = json!(output);
    document["animations"][0]["samplers"][0]["interpolation"] = json!("CUBICSPLINE");
    let desc = import(&document).unwrap().files.desc;
    let y = translate_at(&desc, 12)[1];
    assert!((y - 1.75).abs() < 1e-12, "{y}");
    assert_eq!(translate_at(&desc, 0), [0.0, 1.0, 0.0]);
    assert_eq!(translate_at(&desc, 24), [0.0, 2.0, 0.0]);
}

#[test]
fn a_camera_moved_by_its_parent_moves_with_it() {
    // The side camera sits on `nodes[3]` under "Rig" (`nodes[2]`, at (5, 1, 0), turned 90°
    // about +y, so the camera looks along −x). Animating the rig's translation to (5, 1, 2)
    // moves the camera: at frame 12, (5, 1, 1), still looking along −x.
    let mut document = glass_cube();
    add_animation(&mut document);
    let output = support_vec3(&mut document, &[[5.0, 1.0, 0.0], [5.0, 1.0, 2.0]]);
    document["animations"][0]["samplers"][0]["output"] = json!(output);
    document["animations"][0]["channels"][0]["target"]["node"] = json!(2);
    let desc = import(&document).unwrap().files.desc;
    let camera = desc.at_frame(12).camera;
    let close = |a: [f64; 3], b: [f64; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12);
    assert!(close(camera.position, [5.0, 1.0, 1.0]), "{camera:?}");
    assert!(close(camera.look_at, [4.0, 1.0, 1.0]), "{camera:?}");
    assert!(close(camera.up, [0.0, 1.0, 0.0]), "{camera:?}");
    // The lamp and the sun are not animated.
    assert!(
        matches!(desc.at_frame(12).lights[0], Light::Point { position, .. } if position == [1.0, 4.0, 2.0])
    );
}

/// Adds a VEC3 FLOAT accessor of `values` (in a buffer of its own) and returns its index.
fn support_vec3(document: &mut Value, values: &[[f32; 3]]) -> usize {
    use base64::Engine;
    let bytes: Vec<u8> = values
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bytes)
    );
    let buffers = document["buffers"].as_array().unwrap().len();
    document["buffers"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "uri": uri, "byteLength": bytes.len() }));
    let views = document["bufferViews"].as_array().unwrap().len();
    document["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "buffer": buffers, "byteLength": bytes.len() }));
    document["accessors"].as_array_mut().unwrap().push(json!({
        "bufferView": views, "componentType": 5126, "count": values.len(), "type": "VEC3"
    }));
    document["accessors"].as_array().unwrap().len() - 1
}

#[test]
fn keys_out_of_order_are_an_error_naming_the_sampler() {
    let mut document = glass_cube();
    add_animation(&mut document);
    // The input accessor's times, swapped: 1 s, then 0 s.
    let times = support_scalars(&mut document, &[1.0, 0.0]);
    document["animations"][0]["samplers"][0]["input"] = json!(times);
    let e = import(&document).err().expect("refused").to_string();
    assert_eq!(
        e,
        "animations[0].samplers[0]: its key times must increase: input[1] = 0 s is not after \
         input[0] = 1 s"
    );
}

/// Adds a SCALAR FLOAT accessor of `values` and returns its index.
fn support_scalars(document: &mut Value, values: &[f32]) -> usize {
    use base64::Engine;
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bytes)
    );
    let buffers = document["buffers"].as_array().unwrap().len();
    document["buffers"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "uri": uri, "byteLength": bytes.len() }));
    let views = document["bufferViews"].as_array().unwrap().len();
    document["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "buffer": buffers, "byteLength": bytes.len() }));
    let min = values.iter().copied().fold(f32::INFINITY, f32::min);
    let max = values.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    document["accessors"].as_array_mut().unwrap().push(json!({
        "bufferView": views, "componentType": 5126, "count": values.len(), "type": "SCALAR",
        "min": [min], "max": [max]
    }));
    document["accessors"].as_array().unwrap().len() - 1
}
