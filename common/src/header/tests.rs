use super::*;
use crate::camera_matrices::{from_m44f, transform_point};

/// The camera of `camera_matrices`' hand-computed example: at (0, 0, 5) looking at the origin,
/// 90° vertically, a 200 × 100 film (at unit depth x ∈ [−2, 2], y ∈ [−1, 1]).
fn scene() -> SceneDescription {
    serde_json::from_value(serde_json::json!({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 90},
        "film": {"width": 200, "height": 100, "spp": 4, "seed": 9},
        "lights": [{"type": "point", "position": [0, 5, 0], "intensity": [1, 1, 1]}],
        "objects": [{
            "shape": {"type": "icosphere", "radius": 1, "subdivisions": 1},
            "material": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}
        }]
    }))
    .unwrap()
}

/// Written and read back from the EXR file: `worldToNDC` puts the origin at pixel (100, 50)
/// and (1, 1, 4) — one unit in front, right and up — at (150, 0), the top edge, as computed by
/// hand; `worldToCamera` puts the origin 5 in front; `software`, `renderTime` and the
/// `spindle.*` attributes are there.
#[test]
fn the_header_read_back_maps_known_points_to_their_pixels() {
    let scene = scene();
    let mut image = Image::new(200, 100);
    let stats = RenderStats::default();
    let window = TileRect {
        x: 0,
        y: 0,
        width: 200,
        height: 100,
    };
    describe(
        &mut image,
        &RenderFacts {
            scene: &scene,
            window,
            stats: &stats,
            provenance: None,
            passes: Some((3, 2.5)),
            render_seconds: Some(1.25),
            scene_file: Some("a.json"),
            workers: None,
        },
    );
    let back = Image::from_exr_bytes(&image.to_exr_bytes().unwrap()).unwrap();
    let standard = &back.standard;
    assert_eq!(standard.software.as_deref(), Some(SOFTWARE));
    assert!(SOFTWARE.starts_with("spindle 0."), "{SOFTWARE}");
    assert_eq!(standard.render_time, Some(1.25));
    let to_ndc = from_m44f(&standard.world_to_ndc.unwrap());
    let pixel = |p: [f64; 3]| {
        let n = transform_point(&to_ndc, p);
        (n[0] * 200.0, n[1] * 100.0)
    };
    let close =
        |(x, y): (f64, f64), (u, v): (f64, f64)| (x - u).abs() < 1e-4 && (y - v).abs() < 1e-4;
    assert!(close(pixel([0.0, 0.0, 0.0]), (100.0, 50.0)));
    assert!(
        close(pixel([1.0, 1.0, 4.0]), (150.0, 0.0)),
        "{:?}",
        pixel([1.0, 1.0, 4.0])
    );
    let to_camera = from_m44f(&standard.world_to_camera.unwrap());
    let c = transform_point(&to_camera, [0.0, 0.0, 0.0]);
    assert!(
        c[0].abs() < 1e-6 && c[1].abs() < 1e-6 && (c[2] - 5.0).abs() < 1e-6,
        "{c:?}"
    );
    let text = |name: &str| back.attributes.get(name).map(String::as_str);
    assert_eq!(text("spindle.spp"), Some("4"));
    assert_eq!(text("spindle.seed"), Some("9"));
    assert_eq!(text("spindle.region"), Some("0,0,200,100"));
    assert_eq!(text("spindle.passes"), Some("3"));
    assert_eq!(text("spindle.time_budget_s"), Some("2.5"));
    assert_eq!(text("spindle.scene"), Some("a.json"));
    assert_eq!(text("spindle.workers"), None);
    assert_eq!(text("renderTime"), None, "a float, not text");
}
