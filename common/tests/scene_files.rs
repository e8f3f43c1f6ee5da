//! `scene_files::load_scene`: a scene file and its OBJ files become bytes, relative to the scene
//! file; each failure names the file it is about.

use std::path::Path;

use spindle_common::scene_files::{SceneFileError, load_scene};

/// A scene with two objects naming `mesh` (same string twice) after an icosphere.
fn scene_naming(mesh: &str) -> String {
    let object = format!(
        r#"{{ "shape": {{ "type": "obj", "path": "{mesh}" }},
             "material": {{ "type": "diffuse", "reflectance": [0.5, 0.5, 0.5] }} }}"#
    );
    format!(
        r#"{{
  "camera": {{ "position": [0.0, 0.0, 5.0], "look_at": [0.0, 0.0, 0.0], "fov_y": 35.0 }},
  "film": {{ "width": 4, "height": 4, "spp": 1, "seed": 0 }},
  "lights": [],
  "objects": [
    {{ "shape": {{ "type": "icosphere", "radius": 1.0, "subdivisions": 0 }},
       "material": {{ "type": "diffuse", "reflectance": [0.5, 0.5, 0.5] }} }},
    {object},
    {object}
  ]
}}"#
    )
}

const TRIANGLE: &[u8] = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

#[test]
fn the_tiny_example_loads_with_its_floor_mesh() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/tiny.json");
    let files = load_scene(&path).unwrap();
    assert_eq!(files.desc.objects.len(), 2);
    let floor = std::fs::read(path.parent().unwrap().join("meshes/floor.obj")).unwrap();
    assert_eq!(files.assets.len(), 1);
    assert_eq!(files.assets["meshes/floor.obj"], floor);
}

#[test]
fn meshes_are_read_relative_to_the_scene_file_once_each() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("meshes")).unwrap();
    std::fs::write(dir.path().join("meshes/t.obj"), TRIANGLE).unwrap();
    let scene = dir.path().join("scene.json");
    std::fs::write(&scene, scene_naming("meshes/t.obj")).unwrap();
    let files = load_scene(&scene).unwrap();
    assert_eq!(files.desc.objects.len(), 3);
    assert_eq!(files.assets.len(), 1);
    assert_eq!(files.assets["meshes/t.obj"], TRIANGLE);
}

#[test]
fn a_missing_scene_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("absent.json");
    let err = load_scene(&scene).err().unwrap();
    assert!(matches!(err, SceneFileError::Read { .. }), "{err:?}");
    assert_eq!(
        err.to_string(),
        format!("cannot read scene file {}", scene.display())
    );
}

#[test]
fn an_invalid_scene_names_the_file_and_the_bad_value() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("bad.json");
    let text = scene_naming("t.obj").replace(r#""spp": 1"#, r#""spp": 0"#);
    std::fs::write(&scene, text).unwrap();
    let err = load_scene(&scene).err().unwrap();
    assert_eq!(
        err.to_string(),
        format!("invalid scene {}", scene.display())
    );
    let SceneFileError::Invalid { source, .. } = &err else {
        panic!("{err:?}");
    };
    assert_eq!(source.path, "film.spp");
}

#[test]
fn a_missing_mesh_names_the_object_and_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.json");
    std::fs::write(&scene, scene_naming("absent.obj")).unwrap();
    let err = load_scene(&scene).err().unwrap();
    assert_eq!(
        err.to_string(),
        format!(
            "objects[1].shape.path: cannot read {}",
            dir.path().join("absent.obj").display()
        )
    );
}
