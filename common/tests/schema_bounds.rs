//! The API document's scene schema states the same bounds as the validator: each bound the
//! schema gives is checked against the constant `validate` uses, and a value just past it is
//! refused by `SceneDescription::from_json` while the bound itself is accepted.

use serde_json::{Value, json};
use spindle_common::scene::SceneDescription;
use spindle_common::validate::{
    MAX_COORDINATE, MAX_DEPTH, MAX_ETA, MAX_IMAGE_SIDE, MAX_K, MAX_NEWTON_TOLERANCE, MAX_ORDER,
    MAX_SAMPLES_PER_SEGMENT, MAX_SECONDARY_PATHS, MAX_SPP, MAX_SUBDIVISIONS,
};
use utoipa::{PartialSchema, ToSchema};

/// Every component schema the scene's document holds, by name, as JSON.
fn components() -> serde_json::Map<String, Value> {
    let mut schemas = Vec::new();
    SceneDescription::schemas(&mut schemas);
    let mut map: serde_json::Map<String, Value> = schemas
        .into_iter()
        .map(|(name, schema)| (name, serde_json::to_value(schema).unwrap()))
        .collect();
    map.insert(
        "SceneDescription".into(),
        serde_json::to_value(SceneDescription::schema()).unwrap(),
    );
    map
}

fn property<'a>(schemas: &'a serde_json::Map<String, Value>, name: &str, field: &str) -> &'a Value {
    schemas[name]["properties"]
        .get(field)
        .unwrap_or_else(|| panic!("{name}.{field} is not in the document"))
}

fn number(v: &Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("no {key} in {v}"))
}

fn scene() -> Value {
    json!({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 30},
        "film": {"width": 4, "height": 4},
        "objects": [{"shape": {"type": "icosphere", "radius": 1, "subdivisions": 1},
                     "material": {"type": "dielectric", "eta": 1.5,
                                  "medium": {"sigma_t": [1, 1, 1], "albedo": [0.9, 0.9, 0.9]}}}]
    })
}

/// `set` writes a value into a copy of the scene; the bound is accepted, one past it refused.
fn accepts_bound_refuses_past(what: &str, bound: f64, past: f64, set: impl Fn(&mut Value, f64)) {
    let mut ok = scene();
    set(&mut ok, bound);
    SceneDescription::from_json(&ok.to_string())
        .unwrap_or_else(|e| panic!("{what} = {bound} (the document's bound) is refused: {e}"));
    let mut bad = scene();
    set(&mut bad, past);
    assert!(
        SceneDescription::from_json(&bad.to_string()).is_err(),
        "{what} = {past}, past the document's bound {bound}, is accepted"
    );
}

#[test]
fn scene_schema_bounds_are_the_validators() {
    let s = components();
    let max = |name: &str, field: &str| number(property(&s, name, field), "maximum");
    assert_eq!(max("Film", "width"), MAX_IMAGE_SIDE as f64);
    assert_eq!(max("Film", "height"), MAX_IMAGE_SIDE as f64);
    assert_eq!(max("Film", "spp"), MAX_SPP as f64);
    assert_eq!(max("Integrator", "max_depth"), MAX_DEPTH as f64);
    assert_eq!(max("SingleScatter", "k"), MAX_K as f64);
    assert_eq!(
        max("SingleScatter", "samples_per_segment"),
        MAX_SAMPLES_PER_SEGMENT as f64
    );
    assert_eq!(
        max("SingleScatter", "newton_tolerance"),
        MAX_NEWTON_TOLERANCE
    );
    assert_eq!(max("MultipleScatter", "max_order"), MAX_ORDER as f64);
    assert_eq!(max("MultipleScatter", "paths"), MAX_SECONDARY_PATHS as f64);
    assert_eq!(number(&s["Point"]["items"], "maximum"), MAX_COORDINATE);
    assert_eq!(number(&s["Point"]["items"], "minimum"), -MAX_COORDINATE);
    let doc = serde_json::to_string(&s).unwrap();
    assert!(
        doc.contains(&format!("\"maximum\":{}", MAX_ETA)),
        "eta's maximum"
    );
    assert!(
        doc.contains(&format!("\"maximum\":{MAX_SUBDIVISIONS}")),
        "subdivisions' maximum"
    );

    accepts_bound_refuses_past("film.spp", MAX_SPP as f64, MAX_SPP as f64 + 1.0, |v, x| {
        v["film"]["spp"] = json!(x as u64)
    });
    accepts_bound_refuses_past("film.width", 1.0, 0.0, |v, x| {
        v["film"]["width"] = json!(x as u64)
    });
    accepts_bound_refuses_past("eta", MAX_ETA, MAX_ETA * 1.001, |v, x| {
        v["objects"][0]["material"]["eta"] = json!(x)
    });
    accepts_bound_refuses_past(
        "camera.position[0]",
        MAX_COORDINATE,
        MAX_COORDINATE * 1.001,
        |v, x| v["camera"]["position"][0] = json!(x),
    );
    accepts_bound_refuses_past(
        "integrator.single_scatter.newton_tolerance",
        MAX_NEWTON_TOLERANCE,
        MAX_NEWTON_TOLERANCE * 1.001,
        |v, x| v["integrator"] = json!({"single_scatter": {"newton_tolerance": x}}),
    );
    accepts_bound_refuses_past(
        "integrator.multiple_scatter.max_order",
        MAX_ORDER as f64,
        MAX_ORDER as f64 + 1.0,
        |v, x| v["integrator"] = json!({"multiple_scatter": {"max_order": x as u64}}),
    );
    accepts_bound_refuses_past("integrator.multiple_scatter.max_order", 1.0, 0.0, |v, x| {
        v["integrator"] = json!({"multiple_scatter": {"max_order": x as u64}})
    });
    accepts_bound_refuses_past(
        "integrator.multiple_scatter.paths",
        MAX_SECONDARY_PATHS as f64,
        MAX_SECONDARY_PATHS as f64 + 1.0,
        |v, x| v["integrator"] = json!({"multiple_scatter": {"paths": x as u64}}),
    );
}

#[test]
fn animation_schema_bounds_are_the_validators() {
    use spindle_common::validate::{MAX_FRAME, MAX_FRAME_RATE};
    let s = components();
    let max = |name: &str, field: &str| number(property(&s, name, field), "maximum");
    assert_eq!(max("FrameRange", "start"), f64::from(MAX_FRAME));
    assert_eq!(max("FrameRange", "end"), f64::from(MAX_FRAME));
    assert_eq!(max("Animation", "frame_rate"), MAX_FRAME_RATE);
    accepts_bound_refuses_past(
        "animation.frames.end",
        f64::from(MAX_FRAME),
        f64::from(MAX_FRAME) + 1.0,
        |v, x| v["animation"] = json!({"frames": {"start": 0, "end": x as u64}}),
    );
    accepts_bound_refuses_past(
        "animation.frame_rate",
        MAX_FRAME_RATE,
        MAX_FRAME_RATE * 1.001,
        |v, x| v["animation"] = json!({"frame_rate": x}),
    );
    // A key's frame: within ±MAX_FRAME, as the tracks' documents say.
    let doc = serde_json::to_string(&s).unwrap();
    assert!(
        doc.contains(&format!("\"maximum\":{MAX_FRAME}")),
        "a key frame's maximum"
    );
    accepts_bound_refuses_past(
        "animation.camera.fov_y.keys[0].frame",
        f64::from(MAX_FRAME),
        f64::from(MAX_FRAME) + 0.5,
        |v, x| v["animation"] = json!({"camera": {"fov_y": {"keys": [{"frame": x, "value": 30}]}}}),
    );
}
