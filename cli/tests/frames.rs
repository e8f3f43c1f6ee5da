//! `spindle render --frames`: a sequence of stills, each the scene at its frame, written where
//! the `####` of `-o` says, the same bits on the local farm and with `--workers 0`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use spindle_common::image::{Image, read_exr};
use spindle_common::scene::SceneDescription;
use spindle_common::tile::TileRect;
use spindle_render::{Assets, Scene, render_tile};

fn repo() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
}

fn orbit() -> PathBuf {
    repo().join("scenes/orbit.json")
}

fn spindle(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_spindle"))
        .args(args)
        .env_remove("RUST_BACKTRACE")
        .output()
        .unwrap()
}

fn ok(output: &Output) {
    assert!(
        output.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
}

/// Every file in `dir`, sorted.
fn files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// The library's render of the orbit at `frame`, a whole-frame tile.
fn library_frame(frame: u32) -> spindle_common::tile::TilePixels {
    let text = std::fs::read_to_string(orbit()).unwrap();
    let desc = SceneDescription::from_json(&text).unwrap().at_frame(frame);
    let mut assets = Assets::new();
    assets.insert(
        "meshes/floor.obj".into(),
        std::fs::read(repo().join("scenes/meshes/floor.obj")).unwrap(),
    );
    let scene = Scene::build(&desc, &assets).unwrap();
    render_tile(
        &scene,
        TileRect {
            x: 0,
            y: 0,
            width: desc.film.width,
            height: desc.film.height,
        },
    )
}

fn same_pixels(a: &Image, b: &Image) -> bool {
    a.layers() == b.layers()
}

#[test]
fn frames_go_to_their_numbered_files_with_each_frames_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let pattern = dir.path().join("shot.####.exr");
    let output = spindle(&[
        "render",
        orbit().to_str().unwrap(),
        "--workers",
        "0",
        "--frames",
        "2-4",
        "-o",
        pattern.to_str().unwrap(),
    ]);
    ok(&output);
    assert_eq!(
        files(dir.path()),
        [
            "shot.0002.exr",
            "shot.0002.png",
            "shot.0003.exr",
            "shot.0003.png",
            "shot.0004.exr",
            "shot.0004.png"
        ]
    );
    let mut previous: Option<Image> = None;
    for frame in 2..=4 {
        let image = read_exr(dir.path().join(format!("shot.{frame:04}.exr"))).unwrap();
        let library = library_frame(frame);
        assert_eq!(image.total, library.total, "frame {frame}");
        assert_eq!(
            image.single_scatter, library.single_scatter,
            "frame {frame}"
        );
        // The camera moves: no two frames are the same picture.
        if let Some(previous) = previous {
            assert_ne!(previous.total, image.total, "frame {frame}");
        }
        previous = Some(image);
    }
}

#[test]
fn the_local_farm_renders_each_frame_bit_identical_to_in_process() {
    let dir = tempfile::tempdir().unwrap();
    let (farm, alone) = (dir.path().join("farm"), dir.path().join("alone"));
    std::fs::create_dir_all(&farm).unwrap();
    std::fs::create_dir_all(&alone).unwrap();
    for (out, workers) in [(&farm, "2"), (&alone, "0")] {
        let output = spindle(&[
            "render",
            orbit().to_str().unwrap(),
            "--workers",
            workers,
            "--threads",
            "1",
            "--frames",
            "1-3",
            "--quiet",
            "-o",
            out.join("f.#.exr").to_str().unwrap(),
        ]);
        ok(&output);
    }
    for frame in 1..=3 {
        let name = format!("f.{frame}.exr");
        let (a, b) = (
            read_exr(farm.join(&name)).unwrap(),
            read_exr(alone.join(&name)).unwrap(),
        );
        assert!(same_pixels(&a, &b), "frame {frame} differs");
        assert!(a.total.iter().any(|&v| v > 0.0));
        for key in [
            "spindle.single_scatter.plan",
            "spindle.spp",
            "worldToCamera",
        ] {
            assert_eq!(a.attributes.get(key), b.attributes.get(key), "{key}");
        }
    }
}

#[test]
fn a_sequence_without_a_frame_number_is_refused_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("shot.exr");
    let output = spindle(&[
        "render",
        orbit().to_str().unwrap(),
        "--frames",
        "1-3",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("shot.exr: --frames 1-3 asks for 3 frames"),
        "{stderr}"
    );
    // Without --frames, the scene's own range (1-8) is asked for.
    let output = spindle(&[
        "render",
        orbit().to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("the scene's animation.frames 1-8 asks for 8 frames"),
        "{stderr}"
    );
    let output = spindle(&["render", orbit().to_str().unwrap(), "--frames", "3-1"]);
    assert!(!output.status.success());
    assert!(String::from_utf8_lossy(&output.stderr).contains("--frames"));
    assert!(files(dir.path()).is_empty());
}
