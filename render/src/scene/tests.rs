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
    // An OBJ's coordinates past the extent are refused by the file scan, naming the line…
    let huge = Assets::from([(
        "huge.obj".to_string(),
        b"v 0 0 0\nv 1e200 0 0\nv 0 1 0\nf 1 2 3\n".to_vec(),
    )]);
    let obj = format!(r#"{{ "shape": {{ "type": "obj", "path": "huge.obj" }}, {GLASS} }}"#);
    let e = error(&obj, "", &huge);
    assert!(
        e.starts_with("objects[0].shape.path: huge.obj: line 2: "),
        "{e}"
    );
    assert!(e.contains("±1e6"), "{e}");
    // …and carried past it by the transform, an error naming the transform.
    let far = Assets::from([(
        "huge.obj".to_string(),
        b"v 0 0 0\nv 1e5 0 0\nv 0 1 0\nf 1 2 3\n".to_vec(),
    )]);
    let scaled = format!(
        r#"{{ "shape": {{ "type": "obj", "path": "huge.obj" }}, "transform": {{ "scale": [100, 1, 1] }}, {GLASS} }}"#
    );
    let e = error(&scaled, "", &far);
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
    assert_eq!(scene.warnings().len(), 1, "{:?}", scene.warnings());
    assert!(scene.warnings()[0].starts_with(
        "objects[1] (open.obj): the dielectric mesh is not closed (3 boundary edges)"
    ));
    // The open triangle's corner at the origin lies inside the sphere: nested in its medium.
    assert_eq!(scene.outer(1), Some(0));
    assert!((scene.relative_eta(1) - 1.0).abs() < 1e-15);
    assert_eq!(scene.triangle_count(), 81);
    assert_eq!(scene.locate(0), (0, 0));
    assert_eq!(scene.locate(79), (0, 79));
    assert_eq!(scene.locate(80), (1, 0));
    assert_eq!(scene.summary().triangles, 81);
}

/// A unit cube as an OBJ file without normals.
const CUBE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\n\
    f 1 3 2\nf 2 3 4\nf 5 6 7\nf 6 8 7\nf 1 2 5\nf 2 6 5\nf 3 7 4\nf 4 7 8\nf 1 5 3\nf 3 5 7\n\
    f 2 4 6\nf 4 8 6\n";

#[test]
fn an_obj_without_normals_is_creased_on_request_and_warns_when_smoothed_over() {
    let assets = Assets::from([("cube.obj".to_string(), CUBE_OBJ.as_bytes().to_vec())]);
    let cube = |extra: &str| {
        format!(r#"{{ "shape": {{ "type": "obj", "path": "cube.obj"{extra} }}, {GLASS} }}"#)
    };
    let light = r#"{ "type": "point", "position": [0, 5, 0], "intensity": [1, 1, 1] }"#;
    let smooth = Scene::build(&scene_json(&cube(""), light), &assets).unwrap();
    let warning = smooth
        .warnings()
        .iter()
        .find(|w| w.contains("crease_angle"))
        .expect("a warning about the smoothed edges");
    assert!(
        warning.starts_with("objects[0] (cube.obj): the OBJ has no normals and 12 of its 18 edges"),
        "{warning}"
    );
    // The smooth normal at a corner is the cube's diagonal; creased, the faces are flat.
    assert_eq!(smooth.objects()[0].mesh.positions().len(), 8);
    let creased = Scene::build(
        &scene_json(&cube(r#", "crease_angle": 60"#), light),
        &assets,
    )
    .unwrap();
    assert!(
        creased
            .warnings()
            .iter()
            .all(|w| !w.contains("crease_angle"))
    );
    let mesh = &creased.objects()[0].mesh;
    assert_eq!(mesh.positions().len(), 24);
    for i in 0..mesh.triangle_count() {
        let face = mesh.geometric_normal(i).normalize();
        assert!(
            mesh.corner_normals(i)
                .iter()
                .all(|n| (*n - face).length() < 1e-15)
        );
    }
    let e = error(&cube(r#", "crease_angle": 200"#), light, &assets);
    assert_eq!(
        e,
        "objects[0].shape.crease_angle: must be an angle in degrees from 0 to 180, got 200"
    );
}

/// Two dielectric spheres whose surfaces cross are refused naming both; one inside the other is
/// built (with the nesting warning). A dielectric inside a closed diffuse sphere is refused when
/// the camera is outside it or no light is inside it, and built when both are inside.
#[test]
fn media_that_overlap_or_hide_in_a_diffuse_object_are_refused() {
    let none = Assets::new();
    let sphere = |center: &str, radius: f64, material: &str| {
        format!(
            r#"{{ "shape": {{ "type": "icosphere", "radius": {radius}, "subdivisions": 2 }},
                  "transform": {{ "translate": {center} }}, {material} }}"#
        )
    };
    let diffuse = r#""material": { "type": "diffuse", "reflectance": [0.5, 0.5, 0.5] }"#;
    let light =
        |p: &str| format!(r#"{{ "type": "point", "position": {p}, "intensity": [1, 1, 1] }}"#);
    let overlap = format!(
        "{}, {}",
        sphere("[0, 0, 0]", 1.0, GLASS),
        sphere("[1.2, 0, 0]", 1.0, GLASS)
    );
    let message = error(&overlap, &light("[0, 4, 0]"), &none);
    assert!(
        message.starts_with("objects[1]: its surface crosses the surface of objects[0]"),
        "{message}"
    );
    // A liquid filling the bottom of a glass box's inside, its faces on the box's: one surface
    // between two media, refused rather than met at random.
    let touching = format!(
        r#"{{ "shape": {{ "type": "box", "size": [2, 2, 2] }}, {GLASS} }},
           {{ "shape": {{ "type": "box", "size": [2, 1, 2] }},
              "transform": {{ "translate": [0, -0.5, 0] }}, {GLASS} }}"#
    );
    let message = error(&touching, &light("[0, 4, 0]"), &none);
    assert!(
        message.starts_with("objects[1]: its surface touches the surface of objects[0]"),
        "{message}"
    );
    let nested = format!(
        "{}, {}",
        sphere("[0, 0, 0]", 1.0, GLASS),
        sphere("[0.1, 0, 0]", 0.5, GLASS)
    );
    let scene = Scene::build(&scene_json(&nested, &light("[0, 4, 0]")), &none).unwrap();
    assert_eq!(scene.outer(1), Some(0));
    // A point light above a curved outer surface reaches the nested medium by no modelled route.
    assert!(
        scene
            .warnings()
            .iter()
            .any(|w| w.starts_with("objects[1] and lights[0]: 100% of the surface"))
    );

    let hidden = format!(
        "{}, {}",
        sphere("[0, 0, 0]", 2.0, diffuse),
        sphere("[0, 0, 0]", 1.0, GLASS)
    );
    let message = error(&hidden, &light("[0, 1.5, 0]"), &none);
    assert!(
        message.starts_with("objects[1]: the medium lies inside the closed diffuse object objects[0] and the camera is outside it"),
        "{message}"
    );
    // The camera (0, 0, 5) inside a room of radius 8, the light outside it, then inside.
    let room = format!(
        "{}, {}",
        sphere("[0, 0, 0]", 8.0, diffuse),
        sphere("[0, 0, 0]", 1.0, GLASS)
    );
    let message = error(&room, &light("[0, 9, 0]"), &none);
    assert!(message.contains("no light is inside it"), "{message}");
    Scene::build(&scene_json(&room, &light("[0, 4, 0]")), &none).unwrap();
}
