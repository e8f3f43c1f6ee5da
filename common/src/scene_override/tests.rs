use super::*;
use crate::scene::{Light, Material};

fn scene() -> SceneDescription {
    SceneDescription::from_json(
        r#"{
        "camera": {"position": [0, 1, 5], "look_at": [0, 0, 0], "fov_y": 40},
        "film": {"width": 64, "height": 48, "spp": 2},
        "lights": [{"type": "point", "position": [0, 4, -3], "intensity": [10, 10, 10]}],
        "objects": [{"shape": {"type": "icosphere", "radius": 1, "subdivisions": 2},
                     "material": {"type": "dielectric", "eta": 1.5,
                                  "medium": {"sigma_t": [1, 1, 1], "albedo": [0.5, 0.5, 0.5]}}}]
    }"#,
    )
    .expect("the test scene is valid")
}

fn apply(sets: &[&str]) -> Result<SceneDescription, SceneError> {
    let overrides: Vec<Override> = sets.iter().map(|s| s.parse().unwrap()).collect();
    apply_overrides(&scene(), &overrides)
}

#[test]
fn an_override_changes_that_field_and_nothing_else() {
    let mut expected = scene();
    expected.film.width = 100;
    expected.film.seed = 9;
    let Material::Dielectric { eta, .. } = &mut expected.objects[0].material else {
        unreachable!()
    };
    *eta = 1.33;
    let Light::Point { position, .. } = &mut expected.lights[0] else {
        unreachable!()
    };
    position[2] = 7.0;
    let got = apply(&[
        "film.width=100",
        "film.seed = 9",
        "objects[0].material.eta=1.33",
        "lights[0].position[2]=7",
    ])
    .expect("valid overrides");
    assert_eq!(got, expected);
    assert_eq!(apply(&[]).unwrap(), scene());
}

#[test]
fn a_value_that_is_not_json_is_a_string() {
    let o: Override = "objects[0].shape.path=meshes/bunny.obj".parse().unwrap();
    assert_eq!(o.value, Value::String("meshes/bunny.obj".into()));
    let o: Override = "film.spp=16".parse().unwrap();
    assert_eq!(o.value, serde_json::json!(16));
}

#[test]
fn bad_overrides_are_refused_naming_the_path() {
    #[track_caller]
    fn refused(set: &str, path: &str, word: &str) {
        let e = apply(&[set]).expect_err(set);
        assert_eq!(e.path, path, "{set}: {e}");
        assert!(e.problem.contains(word), "{set}: {e} lacks {word:?}");
    }
    // The overridden scene is validated as a file is.
    refused("film.spp=0", "film.spp", ">= 1");
    refused("film.typo=1", "film.typo", "unknown field");
    refused("objects[0].material.eta=-2", "objects[0].material.eta", "");
    // The path itself.
    refused(
        "objects[3].material.eta=1.2",
        "objects[3].material.eta",
        "past the end",
    );
    refused("film.width.x=1", "film.width.x", "single value");
    refused("film[0]=1", "film[0]", "an object");
    for text in ["film.spp", ".spp=1", "objects[x].material=1", "objects[0=1"] {
        assert!(text.parse::<Override>().is_err(), "{text} parsed");
    }
}
