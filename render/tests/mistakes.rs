//! The safety nets of `render::mistakes`: each likely mistake gives one warning before any work,
//! naming the light or object, and the same scene made right gives none.

use serde_json::{Value, json};
use spindle_render::{Assets, Scene};

/// The unit cube's 12 triangles as OBJ text, each wound counter-clockwise from outside but those
/// of the faces in `flipped` (0..6: −x, +x, −y, +y, −z, +z), scaled by `size` about the origin.
fn cube_obj(size: f64, flipped: &[usize]) -> String {
    let corner = |k: usize| [k & 1, (k >> 1) & 1, (k >> 2) & 1].map(|b| (b as f64 - 0.5) * size);
    let mut text: String = (0..8)
        .map(|k| {
            let [x, y, z] = corner(k);
            format!("v {x} {y} {z}\n")
        })
        .collect();
    for face in 0..6 {
        let (axis, side) = (face / 2, face % 2);
        // The face's corners in order around it.
        let on: Vec<usize> = (0..8).filter(|k| (k >> axis) & 1 == side).collect();
        let mut quad = [on[0], on[1], on[3], on[2]];
        // Counter-clockwise seen from outside: the normal (b − a) × (c − a) points out.
        let [a, b, c] = [quad[0], quad[1], quad[2]].map(corner);
        let cross = |u: [f64; 3], v: [f64; 3]| {
            [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ]
        };
        let sub = |u: [f64; 3], v: [f64; 3]| [u[0] - v[0], u[1] - v[1], u[2] - v[2]];
        let n = cross(sub(b, a), sub(c, a));
        let outward = if side == 1 { 1.0 } else { -1.0 };
        if (n[axis] * outward < 0.0) != flipped.contains(&face) {
            quad.reverse();
        }
        let [p, q, r, s] = quad.map(|k| k + 1);
        text += &format!("f {p} {q} {r}\nf {p} {r} {s}\n");
    }
    text
}

fn build(desc: Value, assets: &[(&str, String)]) -> Scene {
    let assets: Assets = assets
        .iter()
        .map(|(p, t)| (p.to_string(), t.clone().into_bytes()))
        .collect();
    Scene::build(&serde_json::from_value(desc).unwrap(), &assets).unwrap()
}

fn scene(camera: [f64; 3], lights: Value, objects: Value) -> Value {
    json!({
        "camera": {"position": camera, "look_at": [0, 0, 0.001], "fov_y": 40},
        "film": {"width": 8, "height": 8, "spp": 1},
        "lights": lights,
        "objects": objects
    })
}

fn diffuse(path: &str) -> Value {
    json!({"shape": {"type": "obj", "path": path, "crease_angle": 30},
           "material": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}})
}

fn glass(path: &str) -> Value {
    json!({"shape": {"type": "obj", "path": path, "crease_angle": 30},
           "material": {"type": "dielectric", "eta": 1.5,
                        "medium": {"sigma_t": [1, 1, 1], "albedo": [0.5, 0.5, 0.5]}}})
}

/// The warnings that mention `word`.
fn warnings_with(scene: &Scene, word: &str) -> Vec<String> {
    scene
        .warnings()
        .iter()
        .filter(|w| w.contains(word))
        .cloned()
        .collect()
}

#[test]
fn a_quad_light_facing_away_from_every_object_is_named() {
    // A 1-unit quad at y = 3 above the cube; edge_u × edge_v = x × z = −y points down at it.
    let quad = |u: [f64; 3], v: [f64; 3]| {
        json!([{"type": "quad", "corner": [-0.5, 3, -0.5], "edge_u": u, "edge_v": v,
                "radiance": [1, 1, 1]}])
    };
    let cube = [("cube.obj", cube_obj(1.0, &[]))];
    let down = build(
        scene(
            [0.0, 0.0, 5.0],
            quad([1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            json!([diffuse("cube.obj")]),
        ),
        &cube,
    );
    assert_eq!(warnings_with(&down, "faces away"), Vec::<String>::new());
    let up = build(
        scene(
            [0.0, 0.0, 5.0],
            quad([0.0, 0.0, 1.0], [1.0, 0.0, 0.0]),
            json!([diffuse("cube.obj")]),
        ),
        &cube,
    );
    let w = warnings_with(&up, "faces away");
    assert_eq!(w.len(), 1, "{:?}", up.warnings());
    assert!(
        w[0].starts_with("lights[0]: the quad light faces away from every object")
            && w[0].contains("(0.000, 1.000, 0.000)")
            && w[0].contains("swap edge_u and edge_v"),
        "{}",
        w[0]
    );
}

#[test]
fn a_camera_inside_an_unlit_opaque_object_is_named_but_a_lit_room_is_not() {
    let room = [
        ("room.obj", cube_obj(10.0, &[])),
        ("cube.obj", cube_obj(1.0, &[])),
    ];
    let point = |p: [f64; 3]| json!([{"type": "point", "position": p, "intensity": [1, 1, 1]}]);
    let objects = json!([diffuse("room.obj"), diffuse("cube.obj")]);
    let outside_light = build(
        scene([0.0, 0.0, 3.0], point([0.0, 20.0, 0.0]), objects.clone()),
        &room,
    );
    let w = warnings_with(&outside_light, "camera:");
    assert_eq!(w.len(), 1, "{:?}", outside_light.warnings());
    assert!(
        w[0].contains("inside objects[0] (room.obj)") || w[0].contains("inside objects[0]"),
        "{}",
        w[0]
    );
    assert!(w[0].contains("holds no light"), "{}", w[0]);
    let lit_room = build(
        scene([0.0, 0.0, 3.0], point([0.0, 3.0, 0.0]), objects),
        &room,
    );
    assert_eq!(warnings_with(&lit_room, "camera:"), Vec::<String>::new());
}

#[test]
fn a_camera_inside_a_dielectric_a_thousand_times_too_large_is_named() {
    let point = json!([{"type": "point", "position": [0, 3, 0], "intensity": [1, 1, 1]}]);
    // A 1 m cube and a "glass" modelled in millimetres: 1000 units across, around the camera.
    let files = [
        ("cube.obj", cube_obj(1.0, &[])),
        ("glass.obj", cube_obj(1000.0, &[])),
    ];
    let mm = build(
        scene(
            [0.0, 0.0, 3.0],
            point.clone(),
            json!([diffuse("cube.obj"), glass("glass.obj")]),
        ),
        &files,
    );
    let w = warnings_with(&mm, "camera:");
    assert_eq!(w.len(), 1, "{:?}", mm.warnings());
    assert!(
        w[0].contains("inside objects[1]")
            && w[0].contains("a dielectric 1000 times the size")
            && w[0].contains("millimetres"),
        "{}",
        w[0]
    );
    // A tank 20 times the subject's size around the camera is meant: no warning.
    let files = [
        ("cube.obj", cube_obj(1.0, &[])),
        ("glass.obj", cube_obj(20.0, &[])),
    ];
    let tank = build(
        scene(
            [0.0, 0.0, 3.0],
            point,
            json!([diffuse("cube.obj"), glass("glass.obj")]),
        ),
        &files,
    );
    assert_eq!(warnings_with(&tank, "camera:"), Vec::<String>::new());
}

#[test]
fn flipped_faces_are_named_with_the_fix_instead_of_not_closed() {
    let point = json!([{"type": "point", "position": [0, 3, 0], "intensity": [1, 1, 1]}]);
    // One face (two triangles) wound inward: its 4 outer edges each join it to a neighbour
    // traversed the same way.
    let files = [("cube.obj", cube_obj(1.0, &[5]))];
    let one = build(
        scene([0.0, 0.0, 5.0], point.clone(), json!([glass("cube.obj")])),
        &files,
    );
    let w = warnings_with(&one, "objects[0]");
    assert_eq!(w.len(), 1, "{:?}", one.warnings());
    assert!(
        w[0].starts_with("objects[0] (cube.obj): the mesh has no holes, but 4 of its edges join faces wound in opposite senses")
            && w[0].contains("Recalculate Outside")
            && !w[0].contains("not closed"),
        "{}",
        w[0]
    );
    // Every face inward: inside-out, rendered turned outward, with the same fix.
    let files = [("cube.obj", cube_obj(1.0, &[0, 1, 2, 3, 4, 5]))];
    let all = build(
        scene([0.0, 0.0, 5.0], point.clone(), json!([diffuse("cube.obj")])),
        &files,
    );
    let w = warnings_with(&all, "objects[0]");
    assert_eq!(w.len(), 1, "{:?}", all.warnings());
    assert!(
        w[0].starts_with("objects[0] (cube.obj): the mesh is inside-out")
            && w[0].contains("Recalculate Outside"),
        "{}",
        w[0]
    );
    // Wound right: nothing to say.
    let files = [("cube.obj", cube_obj(1.0, &[]))];
    let right = build(
        scene([0.0, 0.0, 5.0], point, json!([glass("cube.obj")])),
        &files,
    );
    assert_eq!(right.warnings(), &[] as &[String]);
}
