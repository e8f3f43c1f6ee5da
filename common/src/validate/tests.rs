use super::*;
use crate::scene::{Pruning, ScatterMethod};
use serde_json::{Value, json};

/// A valid scene using every kind of light, shape, material and phase function.
fn full_scene() -> Value {
    json!({
        "camera": { "position": [0, 1, 5], "look_at": [0, 1, 0], "up": [0, 1, 0], "fov_y": 40 },
        "film": { "width": 64, "height": 48, "spp": 2, "seed": 7 },
        "lights": [
            { "type": "point", "position": [0, 4, -3], "intensity": [10, 10, 10] },
            { "type": "sphere", "center": [2, 3, -2], "radius": 0.5, "radiance": [5, 5, 5] },
            { "type": "directional", "direction": [1, -2, 0], "irradiance": [2, 2, 2],
              "angular_diameter": 0.53 },
            { "type": "quad", "corner": [-1, 4, -1], "edge_u": [2, 0, 0], "edge_v": [0, 0, 2],
              "radiance": [3, 3, 3] }
        ],
        "objects": [
            {
                "shape": { "type": "obj", "path": "meshes/floor.obj" },
                "material": { "type": "diffuse", "reflectance": [0.5, 0.5, 0.5] }
            },
            {
                "shape": { "type": "icosphere", "radius": 1, "subdivisions": 3 },
                "transform": { "scale": [1, 1, 1], "rotate_deg": [0, 30, 0], "translate": [0, 1, 0] },
                "material": {
                    "type": "dielectric", "eta": 1.5,
                    "medium": { "sigma_t": [0.5, 0.5, 0.5], "albedo": [0.9, 0.9, 0.9],
                                "phase": { "type": "hg", "g": 0.3 } }
                }
            },
            {
                "shape": { "type": "bumpy_sphere", "radius": 1, "subdivisions": 4,
                           "amplitude": 0.1, "frequency": 3, "seed": 2 },
                "material": {
                    "type": "dielectric", "eta": 1.33,
                    "medium": { "sigma_t": [1, 1, 1], "albedo": [1, 1, 1] }
                }
            }
        ],
        "background": [0.1, 0.1, 0.1],
        "integrator": {
            "max_depth": 8, "internal_reflections": 2,
            "single_scatter": { "method": "interval", "k": 2, "newton_tolerance": 1e-8,
                                "samples_per_segment": 16, "auto_tolerance": 0.01 },
            "multiple_scatter": { "max_order": 16, "paths": 2, "method": "point_sampling" }
        }
    })
}

/// `full_scene` with the value at JSON pointer `pointer` replaced, parsed and validated.
fn with(pointer: &str, value: Value) -> Result<SceneDescription, SceneError> {
    let mut scene = full_scene();
    *scene
        .pointer_mut(pointer)
        .unwrap_or_else(|| panic!("test pointer {pointer} names no value")) = value;
    SceneDescription::from_json(&scene.to_string())
}

/// Asserts that setting `pointer` to `value` is rejected at exactly `path`, with a message
/// containing `word`.
#[track_caller]
fn rejects(pointer: &str, value: Value, path: &str, word: &str) {
    match with(pointer, value.clone()) {
        Ok(_) => panic!("{pointer} = {value} was accepted"),
        Err(e) => {
            assert_eq!(e.path, path, "{pointer} = {value}: {e}");
            assert!(
                e.problem.contains(word),
                "{pointer} = {value}: {e} lacks `{word}`"
            );
            assert_eq!(e.to_string(), format!("{}: {}", e.path, e.problem));
        }
    }
}

/// The same check on a scene built in code (values JSON cannot carry, like NaN).
#[track_caller]
fn rejects_value(edit: impl FnOnce(&mut SceneDescription), path: &str, word: &str) {
    let mut scene =
        SceneDescription::from_json(&full_scene().to_string()).expect("valid base scene");
    edit(&mut scene);
    let e = scene.validate().expect_err("edited scene was accepted");
    assert_eq!(e.path, path, "{e}");
    assert!(e.problem.contains(word), "{e} lacks `{word}`");
}

#[test]
fn full_scene_is_valid() {
    let scene = SceneDescription::from_json(&full_scene().to_string()).expect("valid");
    assert_eq!(scene.lights.len(), 4);
    assert_eq!(scene.objects.len(), 3);
    assert_eq!(
        scene.objects[1].material,
        Material::Dielectric {
            eta: 1.5,
            medium: Medium {
                sigma_t: [0.5; 3],
                albedo: [0.9; 3],
                phase: Phase::Hg { g: 0.3 }
            }
        }
    );
}

#[test]
fn minimal_scene_gets_the_documented_defaults() {
    let text = r#"{
        "camera": { "position": [0, 0, 3], "look_at": [0, 0, 0], "fov_y": 45 },
        "film": { "width": 4, "height": 3 },
        "objects": [ {
            "shape": { "type": "bumpy_sphere", "radius": 1, "subdivisions": 1,
                       "amplitude": 0, "frequency": 0 },
            "material": { "type": "dielectric", "eta": 1,
                          "medium": { "sigma_t": [0, 0, 0], "albedo": [0, 0, 0] } }
        } ]
    }"#;
    let scene = SceneDescription::from_json(text).expect("valid");
    assert_eq!(scene.camera.up, [0.0, 1.0, 0.0]);
    assert_eq!((scene.film.spp, scene.film.seed), (4, 0));
    assert!(scene.lights.is_empty());
    assert_eq!(scene.background, [0.0; 3]);
    let object = &scene.objects[0];
    assert_eq!(object.transform.scale, [1.0; 3]);
    assert_eq!(object.transform.rotate_deg, [0.0; 3]);
    assert_eq!(object.transform.translate, [0.0; 3]);
    let Shape::BumpySphere { seed, .. } = object.shape else {
        panic!("shape kind changed")
    };
    assert_eq!(seed, 0);
    let Material::Dielectric { medium, .. } = &object.material else {
        panic!("material kind changed")
    };
    assert_eq!(medium.phase, Phase::Isotropic);
    let integrator = &scene.integrator;
    assert_eq!(
        (integrator.max_depth, integrator.internal_reflections),
        (8, 2)
    );
    let s = &integrator.single_scatter;
    assert_eq!(s.method, ScatterMethod::Auto);
    assert_eq!((s.k, s.jitter, s.samples_per_segment), (1, false, 64));
    assert_eq!((s.newton_tolerance, s.auto_tolerance), (1e-10, 0.0));
    assert_eq!(
        s.pruning,
        Pruning {
            spindle: true,
            cone: true,
            plane: true,
        }
    );
}

#[test]
fn unknown_fields_are_rejected_with_their_path() {
    let mut scene = full_scene();
    scene["camera"]["fov_x"] = json!(40);
    let e = SceneDescription::from_json(&scene.to_string()).unwrap_err();
    assert_eq!(e.path, "camera.fov_x", "{e}");
    assert!(e.problem.contains("unknown field `fov_x`"), "{e}");

    let mut scene = full_scene();
    scene["integrator"]["single_scatter"]["pruning"] = json!({ "spindle": true, "cones": false });
    let e = SceneDescription::from_json(&scene.to_string()).unwrap_err();
    assert_eq!(e.path, "integrator.single_scatter.pruning.cones", "{e}");
    assert!(e.problem.contains("unknown field"), "{e}");

    let mut scene = full_scene();
    scene["colour"] = json!([1, 1, 1]);
    let e = SceneDescription::from_json(&scene.to_string()).unwrap_err();
    assert_eq!(e.path, "colour", "{e}");

    // Inside a tagged enum (shape, material, light) the path reaches the enum value.
    let mut scene = full_scene();
    scene["objects"][1]["shape"]["e"] = json!(3);
    let e = SceneDescription::from_json(&scene.to_string()).unwrap_err();
    assert_eq!(e.path, "objects[1].shape.e", "{e}");
    let mut scene = full_scene();
    scene["objects"][1]["shape"]["segments"] = json!(3);
    let e = SceneDescription::from_json(&scene.to_string()).unwrap_err();
    assert_eq!(e.path, "objects[1].shape.segments", "{e}");
    assert!(e.problem.contains("unknown field `segments`"), "{e}");
    let mut scene = full_scene();
    scene["lights"][1]["intensity"] = json!([1, 1, 1]);
    let e = SceneDescription::from_json(&scene.to_string()).unwrap_err();
    assert_eq!(e.path, "lights[1].intensity", "{e}");
    let mut scene = full_scene();
    scene["objects"][1]["material"]["medium"]["phase"]["k"] = json!(0.1);
    let e = SceneDescription::from_json(&scene.to_string()).unwrap_err();
    assert!(e.path.starts_with("objects[1].material"), "{e}");
    assert!(e.path.ends_with(".k"), "{e}");

    let mut scene = full_scene();
    scene["objects"][0]["shape"]["type"] = json!("cube");
    let e = SceneDescription::from_json(&scene.to_string()).unwrap_err();
    assert_eq!(e.path, "objects[0].shape.type", "{e}");
    assert!(e.problem.contains("unknown variant `cube`"), "{e}");
}

#[test]
fn malformed_json_is_rejected_with_its_path() {
    rejects("/film/width", json!(-1), "film.width", "invalid value");
    rejects("/film/width", json!("64"), "film.width", "invalid type");
    rejects(
        "/camera/position/2",
        json!("far"),
        "camera.position[2]",
        "invalid type",
    );
    rejects(
        "/integrator/single_scatter/method",
        json!("magic"),
        "integrator.single_scatter.method",
        "unknown variant",
    );
    let mut scene = full_scene();
    scene["camera"].as_object_mut().unwrap().remove("fov_y");
    let e = SceneDescription::from_json(&scene.to_string()).unwrap_err();
    assert_eq!(e.path, "camera", "{e}");
    assert!(e.problem.contains("missing field `fov_y`"), "{e}");
    let e = SceneDescription::from_json(&format!("{} {{}}", full_scene())).unwrap_err();
    assert_eq!(e.path, ".", "{e}");
    assert!(e.problem.contains("trailing"), "{e}");
    let e = SceneDescription::from_json("{ \"camera\": ").unwrap_err();
    assert!(e.problem.contains("EOF"), "{e}");
    // Numbers beyond f64 are not turned into infinity.
    let text = full_scene()
        .to_string()
        .replace("\"fov_y\":40", "\"fov_y\":1e400");
    let e = SceneDescription::from_json(&text).unwrap_err();
    assert_eq!(e.path, "camera.fov_y", "{e}");
    assert!(e.problem.contains("out of range"), "{e}");
}

#[test]
fn non_finite_numbers_are_rejected_everywhere() {
    for (edit, path) in [
        (
            Box::new(|s: &mut SceneDescription| s.camera.position[1] = f64::NAN)
                as Box<dyn FnOnce(&mut SceneDescription)>,
            "camera.position[1]",
        ),
        (
            Box::new(|s: &mut SceneDescription| s.camera.up[0] = f64::INFINITY),
            "camera.up[0]",
        ),
        (
            Box::new(|s: &mut SceneDescription| s.camera.fov_y = f64::NAN),
            "camera.fov_y",
        ),
        (
            Box::new(|s: &mut SceneDescription| s.background[2] = f64::INFINITY),
            "background[2]",
        ),
        (
            Box::new(|s: &mut SceneDescription| {
                s.objects[1].transform.translate[0] = f64::NEG_INFINITY
            }),
            "objects[1].transform.translate[0]",
        ),
        (
            Box::new(|s: &mut SceneDescription| s.objects[1].transform.rotate_deg[2] = f64::NAN),
            "objects[1].transform.rotate_deg[2]",
        ),
        (
            Box::new(|s: &mut SceneDescription| {
                s.integrator.single_scatter.newton_tolerance = f64::NAN
            }),
            "integrator.single_scatter.newton_tolerance",
        ),
    ] {
        rejects_value(edit, path, "finite");
    }
    rejects_value(
        |s| {
            s.lights[1] = Light::Sphere {
                center: [0.0; 3],
                radius: f64::NAN,
                radiance: [1.0; 3],
            }
        },
        "lights[1].radius",
        "finite",
    );
    rejects_value(
        |s| {
            s.objects[1].material = Material::Dielectric {
                eta: f64::INFINITY,
                medium: Medium {
                    sigma_t: [1.0; 3],
                    albedo: [0.5; 3],
                    phase: Phase::Isotropic,
                },
            }
        },
        "objects[1].material.eta",
        "finite",
    );
    rejects_value(
        |s| {
            s.objects[1].material = Material::Dielectric {
                eta: 1.5,
                medium: Medium {
                    sigma_t: [1.0, f64::NAN, 1.0],
                    albedo: [0.5; 3],
                    phase: Phase::Isotropic,
                },
            }
        },
        "objects[1].material.medium.sigma_t[1]",
        "finite",
    );
    rejects_value(
        |s| {
            s.objects[1].material = Material::Dielectric {
                eta: 1.5,
                medium: Medium {
                    sigma_t: [1.0; 3],
                    albedo: [0.5; 3],
                    phase: Phase::Hg { g: f64::NAN },
                },
            }
        },
        "objects[1].material.medium.phase.g",
        "finite",
    );
}

#[test]
fn camera_values_are_checked() {
    rejects("/camera/fov_y", json!(0), "camera.fov_y", "(0, 180)");
    rejects("/camera/fov_y", json!(180), "camera.fov_y", "(0, 180)");
    rejects("/camera/fov_y", json!(-10), "camera.fov_y", "(0, 180)");
    rejects(
        "/camera/look_at",
        json!([0, 1, 5]),
        "camera.look_at",
        "differ",
    );
    rejects_value(
        |s| {
            s.camera.position = [0.0, 1.0, 1e308];
            s.camera.look_at = [0.0, 1.0, -1e308];
        },
        "camera.position[2]",
        "within ±1e6",
    );
    rejects(
        "/camera/position/0",
        json!(1.7e308),
        "camera.position[0]",
        "within ±1e6",
    );
    rejects(
        "/camera/look_at/1",
        json!(-1.000001e6),
        "camera.look_at[1]",
        "within ±1e6",
    );
    assert!(with("/camera/position/0", json!(1e6)).is_ok());
    rejects("/camera/up", json!([0, 0, 0]), "camera.up", "zero");
    rejects("/camera/up", json!([0, 0, 1]), "camera.up", "parallel");
    rejects("/camera/up", json!([0, 0, -3]), "camera.up", "parallel");
    // Far from parallel but huge or tiny: fine.
    assert!(with("/camera/up", json!([0, 1e300, 1e300])).is_ok());
    assert!(with("/camera/up", json!([1e-300, 0, 0])).is_ok());
}

#[test]
fn film_values_are_checked() {
    rejects("/film/width", json!(0), "film.width", ">= 1");
    rejects("/film/height", json!(0), "film.height", ">= 1");
    rejects("/film/width", json!(16385), "film.width", "<= 16384");
    assert!(with("/film/height", json!(16384)).is_ok());
    rejects("/film/spp", json!(0), "film.spp", ">= 1");
    // One bound for the CLI, the renderer and the coordinator.
    rejects("/film/spp", json!(65537), "film.spp", "<= 65536");
    assert!(with("/film/spp", json!(65536)).is_ok());
    let mut film = json!({"width": 8, "height": 8, "spp": 256, "target_error": 0.02});
    assert!(with("/film", film.clone()).is_ok());
    for bad in [json!(0), json!(1.5), json!(-0.1)] {
        film["target_error"] = bad;
        rejects(
            "/film",
            film.clone(),
            "film.target_error",
            "must be in (0, 1)",
        );
    }
    let mut film = json!({"width": 8, "height": 8, "spp": 256, "time_budget_s": 60});
    assert!(with("/film", film.clone()).is_ok());
    for bad in [json!(0), json!(-1), json!(1e9)] {
        film["time_budget_s"] = bad;
        rejects(
            "/film",
            film.clone(),
            "film.time_budget_s",
            "must be in (0, ",
        );
    }
}

#[test]
fn light_values_are_checked() {
    rejects(
        "/lights/0/intensity/1",
        json!(-1),
        "lights[0].intensity[1]",
        ">= 0",
    );
    rejects(
        "/lights/1/radiance/0",
        json!(-0.5),
        "lights[1].radiance[0]",
        ">= 0",
    );
    rejects("/lights/1/radius", json!(0), "lights[1].radius", "> 0");
    rejects("/lights/1/radius", json!(-1), "lights[1].radius", "> 0");
    rejects(
        "/lights/1/radius",
        json!(2e6),
        "lights[1].radius",
        "between",
    );
    rejects(
        "/lights/0/position/2",
        json!(1e7),
        "lights[0].position[2]",
        "within ±1e6",
    );
    rejects(
        "/lights/1/center/0",
        json!(-1e300),
        "lights[1].center[0]",
        "within ±1e6",
    );
    assert!(with("/lights/0/intensity", json!([0, 0, 0])).is_ok());
    let sun = |field: &str, value: Value| {
        let mut light = json!({"type": "directional", "direction": [0, -1, 0],
                               "irradiance": [1, 1, 1], "angular_diameter": 0.53});
        light[field] = value;
        with("/lights/0", light)
    };
    assert!(sun("angular_diameter", json!(0.53)).is_ok());
    for (field, value, problem) in [
        ("direction", json!([0, 0, 0]), "zero vector"),
        ("irradiance", json!([1, -1, 1]), ">= 0"),
        ("angular_diameter", json!(31), "between 0 and 30"),
        ("angular_diameter", json!(-0.1), "between 0 and 30"),
    ] {
        let e = sun(field, value).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("lights[0].{field}")) && e.contains(problem),
            "{field}: {e}"
        );
    }
    let quad = |field: &str, value: Value| {
        let mut light = json!({"type": "quad", "corner": [0, 2, 0], "edge_u": [1, 0, 0],
                               "edge_v": [0, 0, 1], "radiance": [1, 1, 1]});
        light[field] = value;
        with("/lights/0", light)
    };
    // A rotated rectangle written with rounded decimals: perpendicular within the tolerance.
    let rounded = json!({"type": "quad", "corner": [0, 2, 0], "edge_u": [0.6, 0.8, 0],
                         "edge_v": [-0.8000001, 0.6, 0], "radiance": [1, 1, 1]});
    assert!(with("/lights/0", rounded).is_ok());
    assert!(quad("edge_v", json!([0, 0, -3])).is_ok());
    for (field, value, path, problem) in [
        (
            "edge_u",
            json!([0, 0, 0]),
            "edge_u",
            "length must be between",
        ),
        (
            "edge_v",
            json!([0, 1e7, 0]),
            "edge_v",
            "length must be between",
        ),
        (
            "edge_v",
            json!([0.01, 0, 1]),
            "edge_v",
            "perpendicular to lights[0].edge_u",
        ),
        ("edge_u", json!([0, 0, 1]), "edge_v", "perpendicular"),
        (
            "corner",
            json!([1e6, 0, 0]),
            "corner + edge_u + edge_v[0]",
            "within ±1e6",
        ),
        ("radiance", json!([1, -1, 1]), "radiance", ">= 0"),
    ] {
        let e = quad(field, value).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("lights[0].{path}")) && e.contains(problem),
            "{field}: {e}"
        );
    }
}

#[test]
fn shape_values_are_checked() {
    rejects(
        "/objects/0/shape/path",
        json!(""),
        "objects[0].shape.path",
        "empty",
    );
    rejects(
        "/objects/1/shape/radius",
        json!(0),
        "objects[1].shape.radius",
        "> 0",
    );
    rejects(
        "/objects/1/shape/subdivisions",
        json!(11),
        "objects[1].shape.subdivisions",
        "21 million",
    );
    assert!(with("/objects/1/shape/subdivisions", json!(10)).is_ok());
    rejects(
        "/objects/2/shape/radius",
        json!(-2),
        "objects[2].shape.radius",
        "> 0",
    );
    rejects(
        "/objects/2/shape/subdivisions",
        json!(12),
        "objects[2].shape.subdivisions",
        "<= 10",
    );
    rejects(
        "/objects/2/shape/amplitude",
        json!(1),
        "objects[2].shape.amplitude",
        "[0, 1)",
    );
    rejects(
        "/objects/2/shape/amplitude",
        json!(-0.1),
        "objects[2].shape.amplitude",
        "[0, 1)",
    );
    rejects(
        "/objects/2/shape/frequency",
        json!(-1),
        "objects[2].shape.frequency",
        ">= 0",
    );
}

#[test]
fn transform_values_are_checked() {
    rejects(
        "/objects/1/transform/scale/2",
        json!(0),
        "objects[1].transform.scale[2]",
        "not be 0",
    );
    // A negative scale mirrors the object; that is allowed.
    assert!(with("/objects/1/transform/scale/0", json!(-1)).is_ok());
    // Magnitudes: the scene must fit where f32 boxes and f64 solves stay meaningful.
    for (value, word) in [(1e200, "between"), (-1e7, "between"), (1e-7, "between")] {
        rejects(
            "/objects/1/transform/scale/0",
            json!(value),
            "objects[1].transform.scale[0]",
            word,
        );
    }
    // The largest scale is a valid scale; on this unit sphere lifted by 1 it carries the
    // shape's bounding sphere past the extent, which is refused at the transform.
    rejects(
        "/objects/1/transform/scale/0",
        json!(1e6),
        "objects[1].transform",
        "bounding sphere",
    );
    let mut small = full_scene();
    small["objects"][1]["shape"]["radius"] = json!(0.5);
    small["objects"][1]["transform"]["scale"][0] = json!(1e6);
    small["objects"][1]["transform"]["translate"] = json!([0, 0, 0]);
    assert!(SceneDescription::from_json(&small.to_string()).is_ok());
    assert!(with("/objects/1/transform/scale/0", json!(-1e-6)).is_ok());
    rejects(
        "/objects/1/transform/translate/1",
        json!(2e6),
        "objects[1].transform.translate[1]",
        "within ±1e6",
    );
    rejects(
        "/objects/1/shape/radius",
        json!(1e7),
        "objects[1].shape.radius",
        "between",
    );
    rejects(
        "/objects/2/shape/radius",
        json!(1e-9),
        "objects[2].shape.radius",
        "between",
    );
}

#[test]
fn material_values_are_checked() {
    rejects(
        "/objects/1/material/eta",
        json!(0.9),
        "objects[1].material.eta",
        "unsupported",
    );
    rejects(
        "/objects/1/material/eta",
        json!(10.5),
        "objects[1].material.eta",
        "<= 10",
    );
    assert!(with("/objects/1/material/eta", json!(1)).is_ok());
    rejects(
        "/objects/1/material/medium/sigma_t/1",
        json!(-0.5),
        "objects[1].material.medium.sigma_t[1]",
        ">= 0",
    );
    rejects(
        "/objects/1/material/medium/albedo/2",
        json!(1.01),
        "objects[1].material.medium.albedo[2]",
        "[0, 1]",
    );
    rejects(
        "/objects/1/material/medium/albedo/0",
        json!(-0.01),
        "objects[1].material.medium.albedo[0]",
        "[0, 1]",
    );
    rejects(
        "/objects/1/material/medium/phase/g",
        json!(1),
        "objects[1].material.medium.phase.g",
        "(-1, 1)",
    );
    rejects(
        "/objects/1/material/medium/phase/g",
        json!(-1),
        "objects[1].material.medium.phase.g",
        "(-1, 1)",
    );
    rejects(
        "/objects/0/material/reflectance/1",
        json!(1.5),
        "objects[0].material.reflectance[1]",
        "[0, 1]",
    );
    rejects(
        "/objects/0/material/reflectance/0",
        json!(-0.1),
        "objects[0].material.reflectance[0]",
        "[0, 1]",
    );
}

#[test]
fn background_is_checked() {
    rejects("/background/1", json!(-0.1), "background[1]", ">= 0");
}

#[test]
fn integrator_values_are_checked() {
    rejects(
        "/integrator/max_depth",
        json!(65),
        "integrator.max_depth",
        "<= 64",
    );
    rejects(
        "/integrator/internal_reflections",
        json!(9),
        "integrator.internal_reflections",
        "max_depth",
    );
    assert!(with("/integrator/internal_reflections", json!(8)).is_ok());
    let ss = "/integrator/single_scatter";
    rejects(
        &format!("{ss}/k"),
        json!(0),
        "integrator.single_scatter.k",
        ">= 1",
    );
    rejects(
        &format!("{ss}/newton_tolerance"),
        json!(0),
        "integrator.single_scatter.newton_tolerance",
        "(0, 0.01]",
    );
    rejects(
        &format!("{ss}/newton_tolerance"),
        json!(0.02),
        "integrator.single_scatter.newton_tolerance",
        "(0, 0.01]",
    );
    assert!(with(&format!("{ss}/newton_tolerance"), json!(0.01)).is_ok());
    rejects(
        &format!("{ss}/samples_per_segment"),
        json!(0),
        "integrator.single_scatter.samples_per_segment",
        ">= 1",
    );
    rejects(
        &format!("{ss}/auto_tolerance"),
        json!(1),
        "integrator.single_scatter.auto_tolerance",
        "[0, 1)",
    );
    rejects(
        &format!("{ss}/auto_tolerance"),
        json!(-0.1),
        "integrator.single_scatter.auto_tolerance",
        "[0, 1)",
    );
    let ms = "/integrator/multiple_scatter";
    rejects(
        &format!("{ms}/max_order"),
        json!(0),
        "integrator.multiple_scatter.max_order",
        ">= 1",
    );
    rejects(
        &format!("{ms}/max_order"),
        json!(1025),
        "integrator.multiple_scatter.max_order",
        "<= 1024",
    );
    rejects(
        &format!("{ms}/paths"),
        json!(0),
        "integrator.multiple_scatter.paths",
        ">= 1",
    );
    rejects(
        &format!("{ms}/method"),
        json!("reference"),
        "integrator.multiple_scatter.method",
        "unknown variant",
    );
    assert!(with(&format!("{ms}/max_order"), json!(1)).is_ok());
}

#[test]
fn the_first_bad_value_in_document_order_is_named() {
    let mut scene = full_scene();
    scene["film"]["spp"] = json!(0);
    scene["objects"][2]["shape"]["radius"] = json!(0);
    let e = SceneDescription::from_json(&scene.to_string()).unwrap_err();
    assert_eq!(e.path, "film.spp");
}

#[test]
fn obj_faces_are_counted_as_fans() {
    let obj = b"# a quad and a triangle\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
                f 1 2 3 4\r\n  f 1/1/1 2/2/2 3/3/3\nfo 1 2 3\nvn 0 0 1\nf\n";
    assert_eq!(count_obj_triangles(obj), Ok(2 + 1));
}

/// What would fail the renderer's build is refused by the same linear scan the coordinator
/// runs at submission, naming the line.
#[test]
fn an_obj_the_renderer_would_refuse_is_refused_by_the_count() {
    let refused = |text: &str| count_obj_triangles(text.as_bytes()).unwrap_err();
    let e = refused("v 0 0 0\nv 2e6 0 0\nv 0 1 0\nf 1 2 3\n");
    assert!(e.starts_with("line 2: a vertex coordinate \"2e6\""), "{e}");
    assert!(refused("v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").starts_with("line 1: "));
    assert!(refused("v 0 0 0\nv 1 0\n").contains("line 2: a vertex needs three coordinates"));
    assert_eq!(
        refused("v -4 0 -4\nv 4 0 -4\nv 4 0 4\nf 1 2 9\n"),
        "line 4: a face names vertex 9, but the file has 3 vertices"
    );
    assert!(
        refused("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n").starts_with("line 4: a face corner \"0\"")
    );
    assert!(refused("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 -2 -1\n").contains("\"-4\""));
    assert!(refused("").contains("no faces"));
    assert!(refused("v 0 0 0\nv 1 0 0\nf 1 2\n").contains("no faces"));
    // Relative indices, texture and normal indices, extra vertex values and faces given before
    // their vertices are all fine.
    let fine = "f 1 2 3\nv 0 0 0 1\nv 1 0 0 0.5 0.5 0.5\nv 0 1 0\nvn 0 0 1\nf -3/1/1 -2//1 -1\n";
    assert_eq!(count_obj_triangles(fine.as_bytes()), Ok(2));
}

#[test]
fn the_scene_triangles_are_counted_and_bounded_naming_the_object() {
    let scene = SceneDescription::from_json(&full_scene().to_string()).unwrap();
    let floor = |path: &str| {
        assert_eq!(path, "meshes/floor.obj");
        Ok(2)
    };
    // The floor, an icosphere of level 3 and a bumpy sphere of level 4.
    let total = 2 + 20 * 4u64.pow(3) + 20 * 4u64.pow(4);
    assert_eq!(scene_triangles(&scene, floor, MAX_TRIANGLES), Ok(total));
    let e = scene_triangles(&scene, floor, total - 1).unwrap_err();
    assert_eq!(e.path, "objects[2].shape");
    assert!(e.problem.contains("more than"), "{e}");
    let e = scene_triangles(&scene, |_| Err("line 3: broken".into()), MAX_TRIANGLES).unwrap_err();
    assert_eq!(e.to_string(), "objects[0].shape.path: line 3: broken");
    // One icosphere of the largest level fits the bound; two do not.
    assert!(icosphere_triangles(MAX_SUBDIVISIONS).unwrap() <= MAX_TRIANGLES);
    assert!(2 * icosphere_triangles(MAX_SUBDIVISIONS).unwrap() > MAX_TRIANGLES);
}

/// A fan face of N corners made the scene build quadratic (9.6 s at N = 10,000): such a
/// face is refused by the count, naming its line; one at the bound is counted.
#[test]
fn a_face_of_too_many_corners_is_refused_naming_its_line() {
    let fan = |n: usize| format!("v 0 0 0\nv 1 0 0\nf{}\n", " 1".repeat(n));
    assert_eq!(
        count_obj_triangles(fan(MAX_FACE_CORNERS).as_bytes()),
        Ok(MAX_FACE_CORNERS as u64 - 2)
    );
    let e = count_obj_triangles(fan(10_000).as_bytes()).unwrap_err();
    assert_eq!(
        e,
        "line 3: a face of 10000 corners; at most 64 (split it into smaller faces)"
    );
}

#[test]
fn box_values_are_checked() {
    let wavy = json!({ "type": "box", "size": [2, 1, 3],
                       "waves": { "amplitude": 0.1, "wavelength": 1.5 } });
    let scene = with("/objects/2/shape", wavy.clone()).expect("a wavy box is valid");
    let Shape::Box {
        size,
        waves: Some(waves),
    } = &scene.objects[2].shape
    else {
        panic!("not a wavy box: {:?}", scene.objects[2].shape);
    };
    assert_eq!(*size, [2.0, 1.0, 3.0]);
    assert_eq!(
        (waves.seed, waves.segments),
        (0, 64),
        "the documented defaults"
    );
    assert_eq!(box_triangles(Some(waves)), 2 * 64 * 64 + 12 * 64);
    assert_eq!(box_triangles(None), 14);
    #[track_caller]
    fn refuses(edit: &str, value: Value, path: &str, word: &str) {
        let mut shape = json!({ "type": "box", "size": [2, 1, 3],
                                "waves": { "amplitude": 0.1, "wavelength": 1.5 } });
        let (parent, key) = edit.rsplit_once('/').expect("a JSON pointer");
        match shape.pointer_mut(parent).expect("a field of the box") {
            Value::Object(fields) => {
                fields.insert(key.to_string(), value.clone());
            }
            Value::Array(items) => items[key.parse::<usize>().expect("an index")] = value.clone(),
            other => panic!("{parent} is {other}"),
        }
        match with("/objects/2/shape", shape) {
            Ok(_) => panic!("{edit} = {value} was accepted"),
            Err(e) => {
                assert_eq!(e.path, path, "{edit} = {value}: {e}");
                assert!(e.problem.contains(word), "{e} lacks `{word}`");
            }
        }
    }
    refuses("/size/1", json!(0), "objects[2].shape.size[1]", "> 0");
    refuses("/size/2", json!(2e6), "objects[2].shape.size[2]", "between");
    // Parse errors inside a shape name the shape (scenes/README.md, Conventions).
    refuses("/size", json!([1, 1]), "objects[2].shape", "length 3");
    refuses(
        "/waves/amplitude",
        json!(-0.1),
        "objects[2].shape.waves.amplitude",
        ">= 0",
    );
    refuses(
        "/waves/amplitude",
        json!(0.5),
        "objects[2].shape.waves.amplitude",
        "half",
    );
    refuses(
        "/waves/wavelength",
        json!(0),
        "objects[2].shape.waves.wavelength",
        "> 0",
    );
    refuses(
        "/waves/segments",
        json!(0),
        "objects[2].shape.waves.segments",
        "from 1 to 1024",
    );
    refuses(
        "/waves/segments",
        json!(1025),
        "objects[2].shape.waves.segments",
        "1024",
    );
    let mut unknown = wavy;
    unknown["waves"]["height"] = json!(1);
    let e = with("/objects/2/shape", unknown).expect_err("an unknown field is refused");
    assert!(e.path.starts_with("objects[2].shape"), "{e}");
    assert!(e.problem.contains("unknown field `height`"), "{e}");
}

const FAR_OBJ: &[u8] = b"v 0 0 0\nv 1e5 0 0\nv 0 1 0\nf 1 2 3\n";

fn stretched(x: f64) -> Transform {
    Transform {
        scale: [x, 1.0, 1.0],
        ..Transform::default()
    }
}

/// A file whose own coordinates are in the extent, carried past it by its object's transform,
/// is refused by the scan the coordinator runs at submission and the renderer at build.
#[test]
fn an_obj_carried_past_the_extent_by_its_transform_is_refused_naming_the_line() {
    // Vertex 2 at x = 1e5: scaled 9× it is at 9e5, 10× at exactly 1e6 (inside), 11× past.
    assert_eq!(check_obj_placement(FAR_OBJ, &stretched(9.0)), Ok(()));
    assert_eq!(check_obj_placement(FAR_OBJ, &stretched(10.0)), Ok(()));
    let e = check_obj_placement(FAR_OBJ, &stretched(11.0)).unwrap_err();
    assert!(
        e.starts_with("line 2: places a vertex at [1100000.0, 0.0, 0.0], outside"),
        "{e}"
    );
    assert!(e.contains("±1e6"), "{e}");
    // A rotation alone: (9e5, 9e5, 0) turned 45° about z is at y = 9e5·√2 ≈ 1.27e6.
    let diagonal = b"v 0 0 0\nv 9e5 9e5 0\nv 0 1 0\nf 1 2 3\n";
    let turned = Transform {
        rotate_deg: [0.0, 0.0, 45.0],
        ..Transform::default()
    };
    assert_eq!(check_obj_placement(diagonal, &Transform::default()), Ok(()));
    let e = check_obj_placement(diagonal, &turned).unwrap_err();
    assert!(e.starts_with("line 2: "), "{e}");
    // A translation: z = −1 moved by −999,999.5 is at −1,000,000.5.
    let moved = Transform {
        translate: [0.0, 0.0, -999_999.5],
        ..Transform::default()
    };
    let e = check_obj_placement(b"v 1 0 0\nv 0 0 -1\nv 0 1 0\nf 1 2 3\n", &moved).unwrap_err();
    assert!(e.starts_with("line 2: "), "{e}");
    // The same rule as for any placed vertex.
    assert!(check_in_extent([0.0, -1e6, 1e6]).is_ok());
    assert!(check_in_extent([0.0, 1e6 * (1.0 + f64::EPSILON), 0.0]).is_err());
    assert!(check_in_extent([f64::NAN, 0.0, 0.0]).is_err());
}

/// The quick test by the file's radius never admits what the exact scan refuses, and admits
/// the ordinary placements.
#[test]
fn the_quick_test_by_radius_admits_only_what_the_scan_admits() {
    assert_eq!(obj_radius(FAR_OBJ), 1e5);
    assert_eq!(obj_radius(b"v 3 4 0\nv 0 0 -2\n"), 5.0);
    assert!(surely_within_extent(&stretched(9.0), 1e5));
    assert!(!surely_within_extent(&stretched(11.0), 1e5));
    // Every placement it admits, the scan admits: random scales, turns and shifts of a file
    // of radius 1e5 in every direction.
    let cube = b"v 57735.02691896258 57735.02691896258 57735.02691896258\n\
                 v -57735.02691896258 57735.02691896258 -57735.02691896258\n\
                 v 1e5 0 0\nv 0 -1e5 0\nf 1 2 3\nf 2 3 4\n";
    let radius = obj_radius(cube);
    assert!((radius - 1e5).abs() < 1e-6, "{radius}");
    let mut state = 7u64;
    let mut uniform = |lo: f64, hi: f64| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        lo + (hi - lo) * (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut admitted, mut scanned) = (0, 0);
    for _ in 0..5000 {
        let transform = Transform {
            scale: [0; 3].map(|_| uniform(-12.0, 12.0)),
            rotate_deg: [0; 3].map(|_| uniform(-180.0, 180.0)),
            translate: [0; 3].map(|_| uniform(-5e5, 5e5)),
        };
        if surely_within_extent(&transform, radius) {
            admitted += 1;
            assert_eq!(
                check_obj_placement(cube, &transform),
                Ok(()),
                "{transform:?}"
            );
        } else if check_obj_placement(cube, &transform).is_ok() {
            scanned += 1;
        }
    }
    // Both ways are taken: the quick test is not vacuous, and it leaves some to the scan.
    assert!(admitted > 100 && scanned > 100, "{admitted} {scanned}");
}

/// A procedural shape carried past the extent by its transform is refused at validation (so by
/// the coordinator at submission, as the renderer would at build), naming the transform; the
/// bound is its bounding sphere, exact for an icosphere's vertices.
#[test]
fn a_procedural_shape_past_the_extent_is_refused_naming_its_transform() {
    let place = |shape: Value, translate: f64| {
        let mut scene = full_scene();
        scene["objects"][0]["shape"] = shape;
        scene["objects"][0]["transform"] = json!({"translate": [translate, 0, 0]});
        SceneDescription::from_json(&scene.to_string())
    };
    let ico = json!({"type": "icosphere", "radius": 10, "subdivisions": 1});
    assert!(place(ico.clone(), 1e6 - 11.0).is_ok());
    let e = place(ico, 1e6 - 9.0).unwrap_err();
    assert_eq!(e.path, "objects[0].transform", "{e}");
    assert!(e.problem.contains("bounding sphere (radius 1e1"), "{e}");
    // The bumps and the waves count: 10 · (1 + 0.5) = 15; the box's half diagonal
    // √(1 + (1 + 0.5)² + 1) = 2.06.
    let bumpy = json!({"type": "bumpy_sphere", "radius": 10, "subdivisions": 1,
                       "amplitude": 0.5, "frequency": 1});
    assert!(place(bumpy.clone(), 1e6 - 16.0).is_ok());
    assert!(place(bumpy, 1e6 - 14.0).is_err());
    let wavy = json!({"type": "box", "size": [2, 2, 2],
                      "waves": {"amplitude": 0.5, "wavelength": 1, "segments": 2}});
    assert!(place(wavy.clone(), 1e6 - 2.1).is_ok());
    assert!(place(wavy, 1e6 - 2.0).is_err());
    assert!(
        (procedural_radius(&Shape::Box {
            size: [2.0, 2.0, 2.0],
            waves: None
        })
        .unwrap()
            - 3f64.sqrt())
        .abs()
            < 1e-15
    );
}

#[test]
fn film_passes_are_known_names_each_listed_once() {
    let with = |passes: Value| {
        let mut scene = full_scene();
        scene["film"]["passes"] = passes;
        SceneDescription::from_json(&scene.to_string())
    };
    let scene = with(json!(["normal", "id", "depth", "albedo"])).unwrap();
    assert_eq!(scene.film.passes.len(), 4);
    let e = with(json!(["depth", "id", "depth"])).unwrap_err();
    assert_eq!(e.path, "film.passes[2]", "{e}");
    assert!(e.problem.contains("`depth` is listed twice"), "{e}");
    // Alpha is always written: it is no optional pass.
    let e = with(json!(["alpha"])).unwrap_err();
    assert_eq!(e.path, "film.passes[0]", "{e}");
    assert!(
        e.problem.contains("unknown variant `alpha`") && e.problem.contains("`depth`"),
        "{e}"
    );
}
