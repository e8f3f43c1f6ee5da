use super::*;

fn scene_json(objects: &str, lights: &str) -> desc::SceneDescription {
    serde_json::from_str(&format!(
        r#"{{ "camera": {{ "position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 30 }},
             "film": {{ "width": 8, "height": 6 }},
             "lights": [{lights}], "objects": [{objects}] }}"#
    ))
    .unwrap()
}

const GLASS: &str = r#""material": { "type": "dielectric", "eta": 1.5,
    "medium": { "sigma_t": [1, 1, 1], "albedo": [0.5, 0.5, 0.5] } }"#;
const OPEN_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

fn error(objects: &str, lights: &str, assets: &Assets) -> String {
    Scene::build(&scene_json(objects, lights), assets)
        .unwrap_err()
        .to_string()
}

#[test]
fn bad_values_are_named_by_json_path() {
    let none = Assets::new();
    let ico = |extra: &str| {
        format!(
            r#"{{ "shape": {{ "type": "icosphere", "radius": 1, "subdivisions": 1 }}, {extra} }}"#
        )
    };
    let cases = [
        (
            ico(&GLASS.replace("1.5", "0.8")),
            "",
            "objects[0].material.eta",
        ),
        (
            ico(&GLASS.replace("[1, 1, 1]", "[1, -1, 1]")),
            "",
            "objects[0].material.medium.sigma_t",
        ),
        (
            ico(&GLASS.replace(
                r#""albedo": [0.5, 0.5, 0.5]"#,
                r#""albedo": [0.5, 0.5, 0.5], "phase": { "type": "hg", "g": -1 }"#,
            )),
            "",
            "objects[0].material.medium.phase.g",
        ),
        (
            format!(
                r#"{{ "shape": {{ "type": "icosphere", "radius": 0, "subdivisions": 1 }}, {GLASS} }}"#
            ),
            "",
            "objects[0].shape.radius",
        ),
        (
            format!(
                r#"{{ "shape": {{ "type": "icosphere", "radius": 1, "subdivisions": 40 }}, {GLASS} }}"#
            ),
            "",
            "objects[0].shape.subdivisions",
        ),
        (
            format!(
                r#"{{ "shape": {{ "type": "bumpy_sphere", "radius": 1, "subdivisions": 1, "amplitude": 1.5, "frequency": 2 }}, {GLASS} }}"#
            ),
            "",
            "objects[0].shape.amplitude",
        ),
        (
            ico(&format!(
                r#""transform": {{ "scale": [1, 0, 1] }}, {GLASS}"#
            )),
            "",
            "objects[0].transform.scale",
        ),
        (
            ico(r#""material": { "type": "diffuse", "reflectance": [2, 0, 0] }"#),
            "",
            "objects[0].material.reflectance",
        ),
        (
            format!(r#"{{ "shape": {{ "type": "obj", "path": "missing.obj" }}, {GLASS} }}"#),
            "",
            r#"objects[0].shape.path: no file was supplied for "missing.obj""#,
        ),
        (
            String::new(),
            r#"{ "type": "sphere", "center": [0, 0, 0], "radius": -1, "radiance": [1, 1, 1] }"#,
            "lights[0].radius",
        ),
        (
            String::new(),
            r#"{ "type": "point", "position": [0, 0, 0], "intensity": [1, -1, 1] }"#,
            "lights[0].intensity",
        ),
    ];
    for (objects, lights, expected) in cases {
        let e = error(&objects, lights, &none);
        assert!(e.starts_with(expected), "expected {expected:?}, got {e:?}");
    }
    let mut bad_obj = Assets::new();
    bad_obj.insert(
        "bad.obj".into(),
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n".to_vec(),
    );
    let e = error(
        &format!(r#"{{ "shape": {{ "type": "obj", "path": "bad.obj" }}, {GLASS} }}"#),
        "",
        &bad_obj,
    );
    assert!(e.starts_with("objects[0].shape.path: bad.obj: "), "{e}");
}

#[test]
fn camera_and_film_errors_are_named() {
    let mut d = scene_json("", "");
    d.camera.fov_y = 0.0;
    let e = Scene::build(&d, &Assets::new()).unwrap_err().to_string();
    assert!(e.starts_with("camera.fov_y"), "{e}");
    let mut d = scene_json("", "");
    d.film.spp = 0;
    let e = Scene::build(&d, &Assets::new()).unwrap_err().to_string();
    assert!(e.starts_with("film.spp"), "{e}");
}

#[test]
fn extreme_magnitudes_are_errors_not_panics() {
    // Descriptions that never went through JSON validation: `build` must still refuse them.
    let ico = |transform: &str| {
        format!(
            r#"{{ "shape": {{ "type": "icosphere", "radius": 1, "subdivisions": 1 }},
                 "transform": {transform}, {GLASS} }}"#
        )
    };
    let e = error(
        &ico(r#"{ "scale": [1e200, 1e200, 1e200] }"#),
        "",
        &Assets::new(),
    );
    assert!(e.starts_with("objects[0].transform.scale[0]: "), "{e}");
    let e = error(
        &ico(r#"{ "translate": [0, 0, 1e300] }"#),
        "",
        &Assets::new(),
    );
    assert!(e.starts_with("objects[0].transform.translate[2]: "), "{e}");
    let mut d = scene_json("", "");
    d.camera.position = [1.7e308, 0.0, 5.0];
    let e = Scene::build(&d, &Assets::new()).unwrap_err().to_string();
    assert!(e.starts_with("camera.position[0]: "), "{e}");
    // An OBJ's own coordinates are only seen here: out of the scene's extent after the
    // transform is an error naming the transform.
    let huge = Assets::from([(
        "huge.obj".to_string(),
        b"v 0 0 0\nv 1e200 0 0\nv 0 1 0\nf 1 2 3\n".to_vec(),
    )]);
    let e = error(
        &format!(r#"{{ "shape": {{ "type": "obj", "path": "huge.obj" }}, {GLASS} }}"#),
        "",
        &huge,
    );
    assert!(e.starts_with("objects[0].transform: "), "{e}");
    assert!(e.contains("±1e6"), "{e}");
}

#[test]
fn open_dielectric_mesh_is_a_warning_and_triangles_are_located() {
    let assets = Assets::from([("open.obj".to_string(), OPEN_OBJ.as_bytes().to_vec())]);
    let objects = format!(
        r#"{{ "shape": {{ "type": "icosphere", "radius": 1, "subdivisions": 1 }}, {GLASS} }},
           {{ "shape": {{ "type": "obj", "path": "open.obj" }}, {GLASS} }}"#
    );
    let scene = Scene::build(&scene_json(&objects, ""), &assets).unwrap();
    assert_eq!(scene.warnings().len(), 2, "{:?}", scene.warnings());
    assert!(scene.warnings()[0].starts_with(
        "objects[1] (open.obj): the dielectric mesh is not closed (3 boundary edges)"
    ));
    // The open triangle's corner at the origin lies inside the sphere.
    assert!(scene.warnings()[1].starts_with("objects[1] lies inside objects[0]"));
    assert_eq!(scene.triangle_count(), 81);
    assert_eq!(scene.locate(0), (0, 0));
    assert_eq!(scene.locate(79), (0, 79));
    assert_eq!(scene.locate(80), (1, 0));
    assert_eq!(scene.summary().triangles, 81);
}
