//! The example scenes in `scenes/` and their documentation: every scene must load and validate
//! with its OBJ files present, and `scenes/README.md` must show a valid full example that uses
//! every field, and name every field and type.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use serde_json::Value;
use spindle_common::scene::{SceneDescription, Shape};

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes")
}

#[test]
fn every_example_scene_loads_and_validates() {
    let mut names = Vec::new();
    for entry in std::fs::read_dir(scenes_dir()).expect("scenes/ exists") {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "json") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        let scene = SceneDescription::from_json(&text)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        for (i, object) in scene.objects.iter().enumerate() {
            if let Shape::Obj { path: mesh, .. } = &object.shape {
                let file = path.parent().unwrap().join(mesh);
                let text = std::fs::read_to_string(&file).unwrap_or_else(|e| {
                    panic!("{}: objects[{i}]: {}: {e}", path.display(), file.display())
                });
                assert!(
                    text.lines().any(|l| l.starts_with("f ")),
                    "{} has no faces",
                    file.display()
                );
            }
        }
        names.push(path.file_name().unwrap().to_string_lossy().into_owned());
    }
    names.sort();
    assert_eq!(
        names,
        [
            "aquarium.json",
            "bumpy-sphere.json",
            "caustic.json",
            "glass-sphere.json",
            "jade.json",
            "orbit.json",
            "pool-full.json",
            "pool.json",
            "tank.json",
            "tiny.json"
        ]
    );
}

#[test]
fn the_examples_have_the_documented_sizes() {
    let load = |name: &str| {
        SceneDescription::from_json(&std::fs::read_to_string(scenes_dir().join(name)).unwrap())
            .unwrap()
    };
    let tiny = load("tiny.json");
    assert_eq!(
        (tiny.film.width, tiny.film.height, tiny.film.spp),
        (32, 24, 1)
    );
    let caustic = load("caustic.json");
    assert_eq!((caustic.film.width, caustic.film.height), (640, 480));
    // The README's first command renders the quick pool (about 30 s on two cores); its picture
    // is the full one, the same scene at 2.5 times the resolution.
    let (quick, full) = (load("pool.json"), load("pool-full.json"));
    assert_eq!((quick.film.width, quick.film.height), (256, 144));
    assert_eq!((full.film.width, full.film.height), (640, 360));
    let (mut same, mut other) = (quick.clone(), full.clone());
    same.film.width = 0;
    same.film.height = 0;
    other.film.width = 0;
    other.film.height = 0;
    assert_eq!(
        same, other,
        "the quick and full pools differ only in their size"
    );
    for name in ["glass-sphere.json", "bumpy-sphere.json"] {
        let scene = load(name);
        assert_eq!(
            (scene.film.width, scene.film.height, scene.film.spp),
            (160, 120, 2),
            "{name}"
        );
        assert_eq!(
            scene.lights.len(),
            2,
            "{name}: a point light and a sphere light"
        );
    }
}

/// The ```jsonc block of the README with its `//` comments removed.
fn readme_example(readme: &str) -> String {
    let start = readme
        .find("```jsonc\n")
        .expect("README has a ```jsonc example")
        + 9;
    let end = start + readme[start..].find("```").unwrap();
    readme[start..end]
        .lines()
        .map(|line| line.split("//").next().unwrap())
        .collect::<Vec<_>>()
        .join("\n")
}

/// Every object key, and every `type`/`method` value, in a JSON value.
fn names(value: &Value, out: &mut BTreeSet<String>) {
    match value {
        Value::Object(map) => {
            for (key, v) in map {
                out.insert(key.clone());
                if key == "type" || key == "method" {
                    out.insert(v.as_str().unwrap().to_string());
                }
                names(v, out);
            }
        }
        Value::Array(items) => items.iter().for_each(|v| names(v, out)),
        _ => {}
    }
}

#[test]
fn the_readme_example_is_valid_uses_every_field_and_every_name_is_documented() {
    let readme = std::fs::read_to_string(scenes_dir().join("README.md")).unwrap();
    let example = readme_example(&readme);
    let scene =
        SceneDescription::from_json(&example).unwrap_or_else(|e| panic!("README example: {e}"));

    // Serializing writes every field, defaults included; the example must show them all.
    let mut written = BTreeSet::new();
    names(&serde_json::from_str(&example).unwrap(), &mut written);
    let mut all = BTreeSet::new();
    names(&serde_json::to_value(&scene).unwrap(), &mut all);
    let missing: Vec<_> = all.difference(&written).collect();
    assert!(missing.is_empty(), "the README example lacks {missing:?}");

    // Every field, type and method is named in the README's text.
    let mut documented = all.clone();
    documented.extend(
        [
            "point_sampling",
            "straight_line",
            "reference",
            "none",
            "interval",
        ]
        .map(String::from),
    );
    let undocumented: Vec<_> = documented
        .iter()
        .filter(|name| {
            ![
                format!("`{name}`"),
                format!("`\"{name}\"`"),
                format!("\"type\": \"{name}\""),
            ]
            .iter()
            .any(|form| readme.contains(form))
        })
        .collect();
    assert!(
        undocumented.is_empty(),
        "scenes/README.md does not name {undocumented:?}"
    );
}

#[test]
fn the_readme_error_examples_are_real() {
    let readme = std::fs::read_to_string(scenes_dir().join("README.md")).unwrap();
    let example = readme_example(&readme);
    let mut value: Value = serde_json::from_str(&example).unwrap();
    value["objects"][1]["material"]["medium"]["sigma_t"][1] = (-0.5).into();
    let e = SceneDescription::from_json(&value.to_string())
        .unwrap_err()
        .to_string();
    assert!(readme.contains(&e), "README lacks `{e}`");
    let mut value: Value = serde_json::from_str(&example).unwrap();
    value["objects"][1]["material"]["eta"] = 0.9.into();
    let e = SceneDescription::from_json(&value.to_string())
        .unwrap_err()
        .to_string();
    assert!(readme.contains(&e), "README lacks `{e}`");
    // The line and column depend on the layout, so only the text before them is compared.
    let mut value: Value = serde_json::from_str(&example).unwrap();
    value["camera"]["fov_x"] = 35.0.into();
    let e = SceneDescription::from_json(&value.to_string())
        .unwrap_err()
        .to_string();
    let (text, _) = e.split_once(" at line ").unwrap();
    assert!(readme.contains(text), "README lacks `{text}`");
}
