//! The real scanned meshes beside the project (`../shared/meshes`, or `$SPINDLE_MESHES`).
//! Each test skips with a printed reason when the files are absent.

use std::path::PathBuf;

use spindle_render::obj::parse_obj;

fn mesh_file(name: &str) -> Option<Vec<u8>> {
    let dir = std::env::var_os("SPINDLE_MESHES")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/meshes"));
    let path = dir.join(name);
    match std::fs::read(&path) {
        Ok(bytes) => Some(bytes),
        Err(e) => {
            println!("skipped: {} is absent ({e})", path.display());
            None
        }
    }
}

#[test]
fn open_bunny_reports_its_holes() {
    let Some(bytes) = mesh_file("bunny-70k-open.obj") else {
        return;
    };
    let mesh = parse_obj(&bytes).unwrap();
    let report = mesh.report();
    println!("bunny-70k-open: {report:?}");
    assert_eq!(report.triangles, 69_451);
    assert!(!report.closed);
    assert_eq!(report.boundary_edges, 223);
}

#[test]
fn closed_bunny_is_closed() {
    let Some(bytes) = mesh_file("bunny-4k.obj") else {
        return;
    };
    let report = parse_obj(&bytes).unwrap().report();
    println!("bunny-4k: {report:?}");
    assert_eq!(report.triangles, 4_000);
    assert!(report.closed && report.boundary_edges == 0);
}

#[test]
fn open_bunny_renders_as_glass_without_hanging_or_nan() {
    use spindle_common::tile::TileRect;
    use spindle_render::{Assets, Scene, render_tile};

    let Some(bytes) = mesh_file("bunny-70k-open.obj") else {
        return;
    };
    // Frame the bunny from its own bounds (the scan is at its original scale).
    let (lo, hi) = parse_obj(&bytes).unwrap().bounds();
    let centre = (lo + hi) / 2.0;
    let size = (hi - lo).length();
    let json = format!(
        r#"{{
        "camera": {{ "position": [{}, {}, {}], "look_at": [{}, {}, {}], "fov_y": 40 }},
        "film": {{ "width": 24, "height": 18, "spp": 2 }},
        "background": [0.05, 0.05, 0.05],
        "lights": [ {{ "type": "sphere", "center": [{}, {}, {}], "radius": {}, "radiance": [4, 4, 4] }} ],
        "objects": [ {{ "shape": {{ "type": "obj", "path": "bunny.obj" }},
            "material": {{ "type": "dielectric", "eta": 1.5,
                "medium": {{ "sigma_t": [{s}, {s}, {s}], "albedo": [0.8, 0.8, 0.8] }} }} }} ]
    }}"#,
        centre.x,
        centre.y,
        centre.z + 1.5 * size,
        centre.x,
        centre.y,
        centre.z,
        centre.x,
        centre.y + size,
        centre.z - size,
        0.3 * size,
        s = 2.0 / size
    );
    let desc = serde_json::from_str(&json).unwrap();
    let assets = Assets::from([("bunny.obj".to_string(), bytes)]);
    let scene = Scene::build(&desc, &assets).unwrap();
    println!("warnings: {:?}", scene.warnings());
    assert!(
        scene
            .warnings()
            .iter()
            .any(|w| w.contains("not closed (223 boundary edges)"))
    );
    let tile = render_tile(
        &scene,
        TileRect {
            x: 0,
            y: 0,
            width: 24,
            height: 18,
        },
    );
    assert!(tile.total.iter().all(|v| v.is_finite() && *v >= 0.0));
    assert!(
        tile.stats.camera_segments > 0,
        "the bunny should be in view"
    );
    println!("open bunny: {:?}", tile.stats);
}
