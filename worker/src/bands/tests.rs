use super::*;
use spindle_common::scene::SceneDescription;
use spindle_render::Assets;

/// The example caustic scene, a glass ellipsoid holding a scattering medium, on a small film.
fn caustic(width: u32, height: u32, spp: u32) -> Scene {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/caustic.json");
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    json["film"]["width"] = width.into();
    json["film"]["height"] = height.into();
    json["film"]["spp"] = spp.into();
    json["camera"]["fov_y"] = 12.into();
    let desc = SceneDescription::from_json(&json.to_string()).unwrap();
    Scene::build(&desc, &Assets::default()).unwrap()
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

#[test]
fn a_tile_in_bands_is_the_tile_at_once_to_the_bit() {
    let scene = caustic(24, 20, 2);
    // Odd sizes: the last band is short.
    let rect = TileRect {
        x: 5,
        y: 3,
        width: 13,
        height: 11,
    };
    let whole = render_tile(&scene, rect);
    assert!(
        whole.total.iter().any(|v| *v > 0.0),
        "a black tile proves nothing"
    );
    for threads in [1, 3, 8] {
        // 1 thread: one row a band; 8 threads: 3 rows a band.
        let banded = pool(threads)
            .install(|| render(&scene, rect, None, None, &Interrupt::default()))
            .unwrap()
            .unwrap();
        assert_eq!(banded, whole, "{threads} threads");
    }
}

#[test]
fn a_pass_in_bands_continues_the_earlier_pass_to_the_bit() {
    let scene = caustic(16, 16, 48);
    let rect = TileRect {
        x: 2,
        y: 1,
        width: 9,
        height: 7,
    };
    let first = render_tile_pass(&scene, rect, 1, None).unwrap();
    let second = render_tile_pass(&scene, rect, 2, Some(&first)).unwrap();
    let banded_first = pool(2)
        .install(|| render(&scene, rect, Some(1), None, &Interrupt::default()))
        .unwrap()
        .unwrap();
    assert_eq!(banded_first, first);
    let banded_second = pool(2)
        .install(|| render(&scene, rect, Some(2), Some(&first), &Interrupt::default()))
        .unwrap()
        .unwrap();
    assert_eq!(banded_second, second);
    // A previous result of another tile is refused about the whole tile, before any band.
    let mut other = first.clone();
    other.rect.x += 1;
    let err = render(&scene, rect, Some(2), Some(&other), &Interrupt::default())
        .unwrap()
        .unwrap_err();
    assert!(
        err.to_string().contains("the earlier result is of"),
        "{err}"
    );
}

#[test]
fn an_interrupted_render_stops_before_its_next_band() {
    let scene = caustic(16, 16, 1);
    let rect = TileRect {
        x: 0,
        y: 0,
        width: 16,
        height: 16,
    };
    let interrupt = Interrupt::default();
    interrupt.set();
    assert!(render(&scene, rect, None, None, &interrupt).is_none());
}
