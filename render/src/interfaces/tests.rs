//! Second interfaces against geometry whose answer is known: a sphere shadowing part of another's
//! lit side is found with the share the geometry gives; a light with nothing in the way is not
//! reported; a nested sphere is found, wholly behind the outer one.

use crate::Assets;
use crate::nesting::Route;
use crate::scene::Scene;
use serde_json::json;

fn scene(objects: serde_json::Value, light: [f64; 3]) -> Scene {
    let desc = serde_json::from_value(json!({
        "camera": {"position": [0, 0, 10], "look_at": [0, 0, 0], "fov_y": 30},
        "film": {"width": 4, "height": 4, "spp": 1},
        "lights": [{"type": "point", "position": light, "intensity": [1, 1, 1]}],
        "objects": objects
    }))
    .unwrap();
    Scene::build(&desc, &Assets::new()).unwrap()
}

fn glass(radius: f64, at: [f64; 3]) -> serde_json::Value {
    json!({"shape": {"type": "icosphere", "radius": radius, "subdivisions": 3},
           "transform": {"translate": at},
           "material": {"type": "dielectric", "eta": 1.5,
                        "medium": {"sigma_t": [1, 1, 1], "albedo": [0.5, 0.5, 0.5]}}})
}

#[test]
fn a_sphere_between_the_light_and_another_is_reported_with_its_share() {
    // A small sphere on the line from a far light to a big one: it shadows a disc of the big
    // one's lit hemisphere.
    let s = scene(
        json!([glass(1.0, [0.0, 0.0, 0.0]), glass(0.5, [0.0, 0.0, 3.0])]),
        [0.0, 0.0, 1000.0],
    );
    let found: Vec<_> = s
        .second_interfaces()
        .iter()
        .filter(|f| f.object == 0)
        .collect();
    assert_eq!(found.len(), 1, "{:?}", s.second_interfaces());
    assert_eq!(found[0].blockers, vec![1]);
    // For a light at infinity along +z, a point of the unit sphere at polar angle θ (lit when
    // cos θ > 0) is blocked when its distance to the axis, sin θ, is below 0.5: by area (uniform
    // in cos θ on the hemisphere), the share is 1 − cos(asin 0.5) = 0.134.
    let truth = 1.0 - (1.0f64 - 0.25).sqrt();
    assert!(
        (found[0].share - truth).abs() < 0.03,
        "{} vs {truth}",
        found[0].share
    );
    assert!(
        s.warnings()
            .iter()
            .any(|w| w.contains("objects[0] and lights[0]"))
    );
    assert!(
        crate::scatter::describe_plan(&s)
            .iter()
            .any(|l| l.contains("second refractive interface"))
    );
}

#[test]
fn nothing_in_the_way_is_not_reported() {
    let s = scene(
        json!([glass(1.0, [0.0, 0.0, 0.0]), glass(0.5, [4.0, 0.0, 0.0])]),
        [0.0, 0.0, 1000.0],
    );
    assert!(
        s.second_interfaces().is_empty(),
        "{:?}",
        s.second_interfaces()
    );
}

#[test]
fn a_nested_sphere_is_found_and_fully_behind_the_outer_one() {
    let s = scene(
        json!([glass(1.0, [0.0, 0.0, 0.0]), glass(0.3, [0.1, 0.0, 0.0])]),
        [0.0, 0.0, 50.0],
    );
    assert_eq!(s.outer(1), Some(0));
    assert_eq!(s.outer(0), None);
    let inner = s
        .second_interfaces()
        .iter()
        .find(|f| f.object == 1)
        .expect("the inner sphere is reported");
    // A point light above the outer sphere reaches the inner one only through two curved
    // interfaces: not modelled, the whole lit surface.
    assert_eq!(inner.share, 1.0);
    assert_eq!(inner.blockers, vec![0]);
    assert!(
        s.warnings()
            .iter()
            .any(|w| w.contains("objects[1] and lights[0]: 100%"))
    );
    // No light reaches the inner medium: said, so the render can be refused before it starts.
    let unlit = s.unlit_media();
    assert_eq!(unlit.len(), 1, "{unlit:?}");
    assert!(
        unlit[0].starts_with("objects[1] gets no light"),
        "{unlit:?}"
    );
}

#[test]
fn a_medium_partly_shadowed_or_lit_from_inside_is_not_unlit() {
    // Partly behind another sphere: lit elsewhere.
    let s = scene(
        json!([glass(1.0, [0.0, 0.0, 0.0]), glass(0.5, [0.0, 0.0, 3.0])]),
        [0.0, 0.0, 1000.0],
    );
    assert!(!s.second_interfaces().is_empty());
    assert_eq!(s.unlit_media(), Vec::<String>::new());
    // A light inside one medium lights it directly, and reaches another only through two
    // interfaces: that one is unlit.
    let s = scene(
        json!([glass(1.0, [0.0, 0.0, 0.0]), glass(0.5, [4.0, 0.0, 0.0])]),
        [0.1, 0.0, 0.0],
    );
    let unlit = s.unlit_media();
    assert_eq!(unlit.len(), 1, "{unlit:?}");
    assert!(
        unlit[0].starts_with("objects[1] gets no light"),
        "{unlit:?}"
    );
}

/// A glass sphere nested in a water box under the sun: through a flat top the whole lit side is
/// reached (the sun enters through the box's flat faces, exactly), so nothing is reported and
/// the medium is lit; under a wavy top the light would cross a curved surface first, which is
/// said for most of the lit side, and a point light above the box reaches it by no route at all.
#[test]
fn the_sun_reaches_a_nested_sphere_through_flat_faces_and_not_through_waves() {
    let with = |waves: serde_json::Value, light: serde_json::Value| {
        let mut shape = json!({"type": "box", "size": [4, 2, 4]});
        if !waves.is_null() {
            shape["waves"] = waves;
        }
        let desc = serde_json::from_value(json!({
            "camera": {"position": [0, 0, 10], "look_at": [0, 0, 0], "fov_y": 30},
            "film": {"width": 4, "height": 4, "spp": 1},
            "lights": [light],
            "objects": [
                {"shape": shape, "material": {"type": "dielectric", "eta": 1.33,
                    "medium": {"sigma_t": [0.1, 0.1, 0.1], "albedo": [0.5, 0.5, 0.5]}}},
                glass(0.4, [0.3, -0.2, 0.1])
            ]
        }))
        .unwrap();
        Scene::build(&desc, &Assets::new()).unwrap()
    };
    let sun = json!({"type": "directional", "direction": [0.3, -1, 0.2], "irradiance": [1, 1, 1]});
    let flat = with(serde_json::Value::Null, sun.clone());
    assert_eq!(flat.route(1, 0), Route::FlatFaces { outer: 0 });
    assert!(
        flat.second_interfaces().is_empty(),
        "{:?}",
        flat.second_interfaces()
    );
    assert!(flat.unlit_media().is_empty());

    let waves = json!({"amplitude": 0.05, "wavelength": 1.0, "seed": 2, "segments": 16});
    let wavy = with(waves.clone(), sun);
    let found = &wavy.second_interfaces()[0];
    assert_eq!((found.object, found.light), (1, 0));
    assert_eq!(found.blockers, vec![0]);
    assert!(found.share > 0.9, "{found:?}");

    let lamp = json!({"type": "point", "position": [0, 5, 0], "intensity": [1, 1, 1]});
    let lamp_lit = with(serde_json::Value::Null, lamp);
    assert_eq!(lamp_lit.route(1, 0), Route::Unmodelled);
    assert_eq!(lamp_lit.second_interfaces()[0].share, 1.0);
    assert_eq!(lamp_lit.unlit_media().len(), 1);
}
