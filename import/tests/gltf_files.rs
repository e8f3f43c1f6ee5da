//! The glTF importer on small files written by hand (`support`), checked against values
//! computed by hand from what the files say: where the camera's rays go (world points
//! projected to known pixels through the renderer's own camera), where the vertices land,
//! the units of the lights, the media of the materials, and the errors that name the glTF
//! element at fault.

mod support;

use std::path::{Path, PathBuf};

use glam::DVec3;
use serde_json::{Value, json};
use spindle_common::scene::{Light, Material, Phase, SceneDescription, Shape};
use spindle_import::{ImportError, Imported, Options, import_gltf};
use spindle_render::camera::Camera;
use support::{TAN_HALF_FOV, add_animation, glass_cube};

fn write(dir: &Path, document: &Value) -> PathBuf {
    let path = dir.join("scene.gltf");
    std::fs::write(&path, serde_json::to_string_pretty(document).unwrap()).unwrap();
    path
}

fn import(document: &Value, camera: Option<&str>) -> Result<Imported, ImportError> {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), document);
    import_gltf(
        &path,
        &Options {
            camera: camera.map(str::to_string),
        },
    )
}

/// The angle between the ray through pixel point `(x, y)` and the direction to `point`.
fn ray_miss(desc: &SceneDescription, (x, y): (f64, f64), point: [f64; 3]) -> f64 {
    let camera = Camera::new(&desc.camera, desc.film.width, desc.film.height).unwrap();
    let ray = camera.ray(x, y);
    let to_point = (DVec3::from_array(point) - ray.origin).normalize();
    ray.dir.angle_between(to_point)
}

#[test]
fn the_first_camera_sees_known_points_at_known_pixels() {
    let imported = import(&glass_cube(), None).unwrap();
    let desc = &imported.files.desc;
    // aspectRatio 4:3 → 640 × 480; yfov 2·atan(0.5).
    assert_eq!((desc.film.width, desc.film.height), (640, 480));
    let fov = (2.0 * TAN_HALF_FOV.atan()).to_degrees();
    assert!(
        (desc.camera.fov_y - fov).abs() < 1e-5,
        "{}",
        desc.camera.fov_y
    );
    // The side camera (the first in depth-first order): at (5, 1, 0) looking along −x, so its
    // right is −z. The cube's centre (0, 1, 0) is the image centre; (3, 1.5, −1) is 2 ahead,
    // 1 right and 0.5 up: x = 320 + 320·1/(2·0.5·4/3) = 560, y = 240 − 240·0.5/(2·0.5) = 120.
    assert_eq!(imported.light_origins.len(), 2);
    let p = desc.camera.position;
    assert!(
        (DVec3::from_array(p) - DVec3::new(5.0, 1.0, 0.0)).length() < 1e-6,
        "{p:?}"
    );
    assert!(ray_miss(desc, (320.0, 240.0), [0.0, 1.0, 0.0]) < 1e-6);
    assert!(ray_miss(desc, (560.0, 120.0), [3.0, 1.5, -1.0]) < 1e-6);
    // A wrong pixel is far off: the check can fail.
    assert!(ray_miss(desc, (80.0, 120.0), [3.0, 1.5, -1.0]) > 0.1);
    // The other camera is listed as ignored.
    let warnings = imported.warnings.join("\n");
    assert!(
        warnings.contains("cameras not chosen") && warnings.contains("nodes[4] \"Front camera\""),
        "{warnings}"
    );
}

#[test]
fn a_camera_is_chosen_by_its_node_or_camera_name() {
    for name in ["Front camera", "front"] {
        let imported = import(&glass_cube(), Some(name)).unwrap();
        let desc = &imported.files.desc;
        // At (0, 1, 5) looking along −z: (1, 1.5, 3) is 2 ahead, 1 right, 0.5 up.
        assert!(ray_miss(desc, (320.0, 240.0), [0.0, 1.0, 0.0]) < 1e-6);
        assert!(ray_miss(desc, (560.0, 120.0), [1.0, 1.5, 3.0]) < 1e-6);
    }
    let error = import(&glass_cube(), Some("Back")).err().unwrap();
    assert_eq!(error.element, "scenes[0]");
    assert!(
        error.problem.contains("\"Back\"") && error.problem.contains("nodes[3] \"Side camera\""),
        "{error}"
    );
}

/// The vertices of each object, read back from its OBJ asset by the renderer's OBJ reader.
fn vertices(imported: &Imported, object: usize) -> Vec<DVec3> {
    let Shape::Obj { path, .. } = &imported.files.desc.objects[object].shape else {
        panic!("objects[{object}] is not an obj shape");
    };
    let bytes = &imported.files.assets[path];
    spindle_render::obj::parse_obj(bytes)
        .unwrap()
        .positions()
        .to_vec()
}

#[test]
fn meshes_are_placed_by_their_nodes_and_materials_converted() {
    let imported = import(&glass_cube(), None).unwrap();
    let desc = &imported.files.desc;
    assert_eq!(desc.objects.len(), 2);
    assert_eq!(
        imported.object_origins,
        [
            "nodes[0].mesh, meshes[1].primitives[0]",
            "nodes[1].mesh, meshes[0].primitives[0]"
        ]
    );
    // The floor as written; the cube scaled by 0.5 and moved up by 1: corners (±0.5, 1 ± 0.5, ±0.5).
    let floor = vertices(&imported, 0);
    assert_eq!(floor.len(), 4);
    for v in &floor {
        assert!(v.y == 0.0 && v.x.abs() == 5.0 && v.z.abs() == 5.0, "{v}");
    }
    let cube = vertices(&imported, 1);
    assert_eq!(cube.len(), 8);
    for v in &cube {
        assert!(
            v.x.abs() == 0.5 && (v.y == 0.5 || v.y == 1.5) && v.z.abs() == 0.5,
            "{v}"
        );
    }
    // The floor keeps its normals (the renderer uses them); the cube has none, so flat faces.
    assert_eq!(
        desc.objects[1].shape,
        Shape::Obj {
            path: "scene.gltf#nodes[1].mesh.primitives[0]".into(),
            crease_angle: Some(0.0)
        }
    );
    match &desc.objects[0].material {
        Material::Diffuse { reflectance } => {
            for (r, want) in reflectance.iter().zip([0.8, 0.7, 0.6]) {
                assert!((r - want).abs() < 1e-7, "{reflectance:?}");
            }
        }
        other => panic!("the floor is {other:?}"),
    }
    match &desc.objects[1].material {
        Material::Dielectric { eta, medium } => {
            assert!((eta - 1.33).abs() < 1e-6, "{eta}");
            // c = (0.5, 0.25, 1) kept over d = 2: σt = −ln(c)/2 = (ln 2 / 2, ln 2, 0).
            let ln2 = std::f64::consts::LN_2;
            let want = [ln2 / 2.0, ln2, 0.0];
            for (s, w) in medium.sigma_t.iter().zip(want) {
                assert!((s - w).abs() < 1e-12, "{:?}", medium.sigma_t);
            }
            assert_eq!(medium.albedo, [0.9, 0.8, 0.7]);
            assert_eq!(medium.phase, Phase::Hg { g: 0.3 });
        }
        other => panic!("the glass is {other:?}"),
    }
    // And the renderer builds it.
    spindle_render::Scene::build(desc, &imported.files.assets).unwrap();
}

#[test]
fn light_units_are_converted_from_candela_and_lux() {
    let imported = import(&glass_cube(), None).unwrap();
    let lights = &imported.files.desc.lights;
    // 1366 cd = 2 × 683 lm/sr: 2 W/sr at 555 nm, times the colour (1, 0.5, 0.25).
    match &lights[0] {
        Light::Point {
            position,
            intensity,
        } => {
            assert_eq!(*position, [1.0, 4.0, 2.0]);
            for (i, w) in intensity.iter().zip([2.0, 1.0, 0.5]) {
                assert!((i - w).abs() < 1e-12, "{intensity:?}");
            }
        }
        other => panic!("{other:?}"),
    }
    // 2049 lx = 3 × 683 lm/m²: 3 W/m², white; shining along the node's −z turned −90° about x:
    // straight down.
    match &lights[1] {
        Light::Directional {
            direction,
            irradiance,
            angular_diameter,
        } => {
            let d = DVec3::from_array(*direction).normalize();
            assert!((d - DVec3::NEG_Y).length() < 1e-12, "{d}");
            for i in irradiance {
                assert!((i - 3.0).abs() < 1e-12, "{irradiance:?}");
            }
            assert_eq!(*angular_diameter, 0.0);
        }
        other => panic!("{other:?}"),
    }
    // Blender's exporter writes P/(4π)·683 cd for a point light of P W: spindle's intensity is
    // then P/(4π) W/sr, the radiant intensity of an isotropic source of power P.
    let power = 1000.0;
    let candela = power / (4.0 * std::f64::consts::PI) * 683.0;
    let mut document = glass_cube();
    document["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"] = json!(candela);
    document["extensions"]["KHR_lights_punctual"]["lights"][0]["color"] = json!([1.0, 1.0, 1.0]);
    let imported = import(&document, None).unwrap();
    let Light::Point { intensity, .. } = &imported.files.desc.lights[0] else {
        panic!()
    };
    let want = power / (4.0 * std::f64::consts::PI);
    assert!(
        (intensity[0] - want).abs() < 1e-5 * want,
        "{intensity:?} vs {want}"
    );
}

#[test]
fn everything_ignored_is_listed_once_per_kind() {
    let mut document = glass_cube();
    add_animation(&mut document);
    document["extensionsUsed"]
        .as_array_mut()
        .unwrap()
        .push(json!("KHR_materials_clearcoat"));
    document["extensions"]["KHR_lights_punctual"]["lights"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "type": "spot", "intensity": 10.0, "spot": {} }));
    document["nodes"].as_array_mut().unwrap().push(json!({
        "name": "Spot", "extensions": { "KHR_lights_punctual": { "light": 2 } }
    }));
    document["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!(7));
    document["images"] = json!([{ "uri": "wood.png" }]);
    document["textures"] = json!([{ "source": 0, "name": "wood" }]);
    document["materials"][1]["pbrMetallicRoughness"]["baseColorTexture"] = json!({ "index": 0 });
    let imported = import(&document, None).unwrap();
    let warnings = &imported.warnings;
    let with = |needle: &str| warnings.iter().filter(|w| w.contains(needle)).count();
    // Node animations are imported (tests/animations.rs), not ignored.
    assert_eq!(with("animations"), 0, "{warnings:#?}");
    assert_eq!(with("KHR_materials_clearcoat"), 1, "{warnings:#?}");
    assert_eq!(with("spot lights"), 1, "{warnings:#?}");
    assert_eq!(
        with("nodes[7] (KHR_lights_punctual.lights[2])"),
        1,
        "{warnings:#?}"
    );
    assert_eq!(with("textures ("), 1, "{warnings:#?}");
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("textures[0] \"wood\"") && w.contains("materials[1]"))
    );
    assert_eq!(with("cameras not chosen"), 1, "{warnings:#?}");
    // The spot light is not among the scene's lights.
    assert_eq!(imported.files.desc.lights.len(), 2);
}

#[test]
fn bad_files_are_refused_naming_the_gltf_element() {
    let refused = |document: &Value| import(document, None).err().expect("refused");

    // A transmissive mesh that bounds no volume: the floor made of glass.
    let mut document = glass_cube();
    document["meshes"][1]["primitives"][0]["material"] = json!(0);
    let error = refused(&document);
    assert_eq!(error.element, "meshes[1].primitives[0]");
    assert!(
        error.problem.contains("nodes[0]")
            && error.problem.contains("materials[0]")
            && error.problem.contains("4 boundary edges"),
        "{error}"
    );

    // A buffer whose file is not there.
    let mut document = glass_cube();
    document["buffers"][0]["uri"] = json!("missing.bin");
    let error = refused(&document);
    assert_eq!(error.element, "buffers[0]");
    assert!(error.problem.contains("missing.bin"), "{error}");

    // No camera.
    let mut document = glass_cube();
    document["scenes"][0]["nodes"] = json!([0, 1, 5, 6]);
    let error = refused(&document);
    assert_eq!(error.element, "scenes[0]");
    assert!(error.problem.contains("has no camera"), "{error}");

    // An orthographic camera.
    let mut document = glass_cube();
    document["cameras"][0] = json!({
        "type": "orthographic",
        "orthographic": { "xmag": 1.0, "ymag": 1.0, "znear": 0.1, "zfar": 10.0 }
    });
    let error = refused(&document);
    assert_eq!(error.element, "cameras[0]");
    assert!(error.problem.contains("orthographic"), "{error}");

    // An attenuation colour of 0: infinite extinction.
    let mut document = glass_cube();
    document["materials"][0]["extensions"]["KHR_materials_volume"]["attenuationColor"] =
        json!([0.5, 0.5, 0.0]);
    let error = refused(&document);
    assert_eq!(
        error.element,
        "materials[0].extensions.KHR_materials_volume.attenuationColor[2]"
    );

    // An albedo out of range in the extras.
    let mut document = glass_cube();
    document["materials"][0]["extras"]["spindle_albedo"] = json!(1.5);
    assert_eq!(
        refused(&document).element,
        "materials[0].extras.spindle_albedo"
    );

    // An index past the vertices.
    let mut document = glass_cube();
    let mut data = support::Data::default();
    let _ = data.vec3(&support::CUBE_CORNERS);
    let _ = data.indices(&support::CUBE_TRIANGLES);
    let _ = data.vec3(&support::FLOOR_CORNERS);
    let _ = data.vec3(&[[0.0, 1.0, 0.0]; 4]);
    let _ = data.indices(&[0, 3, 2, 0, 2, 9]);
    data.finish(&mut document);
    let error = refused(&document);
    assert_eq!(error.element, "accessors[4]");
    assert!(
        error.problem.contains("index 9") && error.problem.contains("meshes[1].primitives[0]"),
        "{error}"
    );

    // A count far past the data (it must not wrap around to a short read).
    let mut document = glass_cube();
    document["accessors"][4]["count"] = json!(1u64 << 62);
    let error = refused(&document);
    assert_eq!(error.element, "accessors[4]");
    assert!(error.problem.contains("elements reach byte"), "{error}");

    // A buffer view past the end of its buffer.
    let mut document = glass_cube();
    let length = document["buffers"][0]["byteLength"].as_u64().unwrap();
    document["bufferViews"][4]["byteLength"] = json!(length);
    let error = refused(&document);
    assert_eq!(error.element, "bufferViews[4]");
    assert!(error.problem.contains("of buffers[0]"), "{error}");

    // A light outside spindle's extent: spindle's own rule, named by the light's node.
    let mut document = glass_cube();
    document["nodes"][5]["translation"] = json!([2.0e6, 0.0, 0.0]);
    let error = refused(&document);
    assert_eq!(error.element, "nodes[5] (KHR_lights_punctual.lights[0])");
    assert!(error.problem.contains("lights[0].position"), "{error}");

    // Two parents for one node.
    let mut document = glass_cube();
    document["nodes"][4]["children"] = json!([3]);
    let error = refused(&document);
    assert_eq!(error.element, "nodes[3]");

    // Not glTF at all.
    let error = import(&json!({ "asset": "nope" }), None).err().unwrap();
    assert!(error.problem.contains("not a glTF 2.0 file"), "{error}");
}

#[test]
fn a_mirroring_node_keeps_front_faces_front() {
    // Scale −1 along x mirrors the floor; its normal must stay +y and its winding with it.
    let mut document = glass_cube();
    document["nodes"][0]["scale"] = json!([-1.0, 1.0, 1.0]);
    let imported = import(&document, None).unwrap();
    let Shape::Obj { path, .. } = &imported.files.desc.objects[0].shape else {
        panic!()
    };
    let mesh = spindle_render::obj::parse_obj(&imported.files.assets[path]).unwrap();
    for t in 0..mesh.triangle_count() {
        assert!((mesh.geometric_normal(t).normalize() - DVec3::Y).length() < 1e-12);
        for n in mesh.corner_normals(t) {
            assert!((n - DVec3::Y).length() < 1e-12, "{n}");
        }
    }
}

/// `scenes/glass-cube.gltf`, the example glTF scene, is this file's test scene, so what the
/// tests above check holds for it. `SPINDLE_BLESS=1 cargo test -p spindle-import` rewrites it
/// after a change to `support::glass_cube`.
#[test]
fn the_example_glass_cube_is_the_test_scene() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/glass-cube.gltf");
    let text = serde_json::to_string_pretty(&glass_cube()).unwrap() + "\n";
    if std::env::var_os("SPINDLE_BLESS").is_some() {
        std::fs::write(&path, &text).unwrap();
    }
    let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        on_disk == text,
        "{} differs from support::glass_cube(): rewrite it with SPINDLE_BLESS=1 cargo test -p \
         spindle-import",
        path.display()
    );
}

#[test]
fn a_buffer_in_a_file_beside_the_gltf_is_read_by_its_escaped_uri() {
    use base64::Engine;
    let mut document = glass_cube();
    let uri = document["buffers"][0]["uri"].as_str().unwrap().to_string();
    let payload = uri.split_once(";base64,").unwrap().1;
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(payload)
        .unwrap();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene data.bin"), &bytes).unwrap();
    document["buffers"][0]["uri"] = json!("scene%20data.bin");
    let path = write(dir.path(), &document);
    let from_file = import_gltf(&path, &Options::default()).unwrap();
    let inline = import(&glass_cube(), None).unwrap();
    assert_eq!(from_file.files.desc, inline.files.desc);
    assert_eq!(from_file.files.assets, inline.files.assets);
    // One byte short of byteLength: refused, naming the buffer.
    std::fs::write(dir.path().join("scene data.bin"), &bytes[..bytes.len() - 1]).unwrap();
    let error = import_gltf(&path, &Options::default()).err().unwrap();
    assert_eq!(error.element, "buffers[0]");
    assert!(error.problem.contains("byteLength"), "{error}");
}
