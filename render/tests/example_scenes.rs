//! The example scenes of `scenes/` through the renderer: the single-scattering search along the
//! camera segments never hits one of its fixed capacities there (`RenderStats::capacity_drops`
//! stays 0), so no light is lost to a list that is too small. Multiple scattering's secondary
//! segments are counted apart (`secondary_capacity_drops`, printed): through the caustic's point
//! focus a traced arc can lie at one depth, where thinning frees no room.

use std::path::{Path, PathBuf};

use spindle_common::scene::{SceneDescription, Shape};
use spindle_common::stats::RenderStats;
use spindle_common::tile::TileRect;
use spindle_render::{Assets, Scene, render_tile};

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes")
}

/// Each example scene at a quarter of its resolution (same camera, so the same view sampled
/// more coarsely) and 1 spp, to keep the test short in the dev profile. The full renders were
/// checked too: `spindle render scenes/<name>.json --workers 0 --stats` prints
/// `capacity_drops 0` for both.
#[test]
fn example_scenes_drop_nothing() {
    let mut rendered = 0;
    for entry in std::fs::read_dir(scenes_dir()).expect("scenes/ exists") {
        let path = entry.expect("directory entry").path();
        if path.extension().is_none_or(|e| e != "json") {
            continue;
        }
        // `<name>-full.json` is `<name>.json` at another size (common/tests/scenes.rs checks
        // that they differ in nothing else), so it is rendered once, as `<name>.json`.
        if path.to_string_lossy().ends_with("-full.json") {
            continue;
        }
        let text = std::fs::read_to_string(&path).expect("scene file reads");
        let mut desc = SceneDescription::from_json(&text).expect("example scene validates");
        let mut assets = Assets::new();
        for object in &desc.objects {
            if let Shape::Obj { path: mesh, .. } = &object.shape {
                let file = path.parent().expect("scene has a directory").join(mesh);
                assets.insert(mesh.clone(), std::fs::read(&file).expect("mesh reads"));
            }
        }
        desc.film.width = desc.film.width.div_ceil(4);
        desc.film.height = desc.film.height.div_ceil(4);
        desc.film.spp = 1;
        let scene = Scene::build(&desc, &assets).expect("example scene builds");
        let rect = TileRect {
            x: 0,
            y: 0,
            width: desc.film.width,
            height: desc.film.height,
        };
        let tile = render_tile(&scene, rect);
        let stats: RenderStats = tile.stats;
        println!("{}: {stats:?}", path.display());
        assert!(tile.single_scatter.iter().all(|v| v.is_finite()));
        assert_eq!(stats.capacity_drops, 0, "{}", path.display());
        // Multiple scattering's secondary segments may drop values at a point focus; say how
        // often, per secondary segment.
        println!(
            "{}: {} secondary segments, {} values dropped on them",
            path.display(),
            stats.secondary_segments,
            stats.secondary_capacity_drops
        );
        rendered += 1;
    }
    assert!(rendered >= 3, "only {rendered} example scenes");
}
