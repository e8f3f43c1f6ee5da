//! `spindle render` end to end: the real binary on the example scenes.

use std::path::Path;
use std::process::Command;

use spindle_common::image::read_exr;
use spindle_common::scene::SceneDescription;
use spindle_common::tile::TileRect;
use spindle_render::{Assets, Scene, render_tile};

fn repo() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
}

#[test]
fn renders_the_tiny_example_to_exr_and_png_matching_the_library() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("tiny.exr");
    let scene_path = repo().join("scenes/tiny.json");
    let output = Command::new(env!("CARGO_BIN_EXE_spindle"))
        .args([
            "render",
            scene_path.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--stats",
        ])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        stdout.contains("rendered") && stdout.contains("spp") && stdout.contains("camera_rays"),
        "{stdout}"
    );
    assert!(dir.path().join("tiny.png").is_file());
    // The single-scattering plan is said in the log and kept in the header.
    assert!(stdout.contains("single scattering: objects[0]"), "{stdout}");

    let image = read_exr(&out).unwrap();
    let desc = SceneDescription::from_json(&std::fs::read_to_string(&scene_path).unwrap()).unwrap();
    assert_eq!(
        (image.width, image.height),
        (desc.film.width, desc.film.height)
    );
    assert_eq!(
        image.attributes.get("spindle.spp"),
        Some(&desc.film.spp.to_string())
    );
    assert!(
        image
            .attributes
            .get("spindle.single_scatter.plan")
            .is_some_and(|plan| plan.starts_with("objects[0]: ")),
        "{:?}",
        image.attributes
    );

    // The file holds exactly what the library renders for the whole frame.
    let mut assets = Assets::new();
    for object in &desc.objects {
        if let spindle_common::scene::Shape::Obj { path, .. } = &object.shape {
            assets.insert(
                path.clone(),
                std::fs::read(repo().join("scenes").join(path)).unwrap(),
            );
        }
    }
    let scene = Scene::build(&desc, &assets).unwrap();
    let full = TileRect {
        x: 0,
        y: 0,
        width: desc.film.width,
        height: desc.film.height,
    };
    let tile = render_tile(&scene, full);
    assert_eq!(image.total, tile.total);
    assert_eq!(image.surface, tile.surface);
    assert_eq!(image.single_scatter, tile.single_scatter);
    assert!(image.total.iter().any(|&v| v > 0.0));
}

#[test]
fn a_bad_scene_fails_with_the_json_path() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("bad.json");
    let text = std::fs::read_to_string(repo().join("scenes/tiny.json"))
        .unwrap()
        .replacen("\"fov_y\"", "\"fov_y\": -3, \"unused_fov\"", 1);
    std::fs::write(&scene, text).unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_spindle"))
        .args([
            "render",
            scene.to_str().unwrap(),
            "-o",
            dir.path().join("x.exr").to_str().unwrap(),
        ])
        .env_remove("RUST_BACKTRACE")
        .output()
        .unwrap();
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("camera"), "{stderr}");
    assert!(!dir.path().join("x.exr").exists());
}

/// `spindle render` with `args`, in `dir`.
fn render_in(dir: &Path, args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_spindle"))
        .current_dir(dir)
        .arg("render")
        .arg(repo().join("scenes/tiny.json"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn outputs_that_cannot_be_written_as_asked_are_refused_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    // Neither an EXR nor a PNG: refused naming -o and the two kinds, nothing written.
    let out = render_in(dir.path(), &["-o", "out.tif", "--workers", "0"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("-o out.tif: must end in .exr") && stderr.contains(".png"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    // A missing directory is named before any work (no plan printed, nothing rendered).
    let out = render_in(dir.path(), &["-o", "no/such/dir/out.exr"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("the directory no/such/dir does not exist"),
        "{stderr}"
    );
    assert!(
        out.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    // -o is required, except with --pixel, which prints the pixel and writes nothing.
    let out = render_in(dir.path(), &[]);
    assert!(!out.status.success());
    let out = render_in(dir.path(), &["--workers", "0", "--pixel", "16,12"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("pixel 16,12:") && stdout.contains("single_scatter"),
        "{stdout}"
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// A medium that no light reaches (a glass sphere inside another, lit from the air) would come
/// out black: refused before rendering, naming the object and the way to go on, on the local
/// farm, in this process and by `spindle submit` alike; `--allow-blocked` renders it.
#[test]
fn a_medium_no_light_reaches_is_refused_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let glass = |radius: f64| {
        serde_json::json!({"shape": {"type": "icosphere", "radius": radius, "subdivisions": 2},
            "material": {"type": "dielectric", "eta": 1.33,
                         "medium": {"sigma_t": [1, 1, 1], "albedo": [0.5, 0.5, 0.5]}}})
    };
    let scene = serde_json::json!({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 30},
        "film": {"width": 8, "height": 6, "spp": 1},
        "lights": [{"type": "point", "position": [0, 5, 2], "intensity": [5, 5, 5]}],
        "objects": [glass(1.0), glass(0.4)]
    });
    let scene_path = dir.path().join("nested.json");
    std::fs::write(&scene_path, scene.to_string()).unwrap();
    let out = dir.path().join("nested.exr");
    let run = |extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_spindle"))
            .args([
                "render",
                scene_path.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ])
            .args(extra)
            .output()
            .unwrap()
    };
    for workers in [&["--workers", "0"][..], &["--workers", "1"][..]] {
        let refused = run(workers);
        let stderr = String::from_utf8_lossy(&refused.stderr);
        assert!(!refused.status.success(), "{workers:?} rendered: {stderr}");
        assert!(
            stderr.contains("objects[1] gets no light") && stderr.contains("--allow-blocked"),
            "{workers:?}: {stderr}"
        );
        assert!(!out.exists(), "nothing is written");
    }
    // `spindle submit` builds the scene before it talks to a coordinator: refused the same way
    // (the address is a closed port, never reached).
    let submitted = Command::new(env!("CARGO_BIN_EXE_spindle"))
        .args(["submit", scene_path.to_str().unwrap()])
        .args(["--server", "http://127.0.0.1:9"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&submitted.stderr);
    assert!(!submitted.status.success(), "submit went on: {stderr}");
    assert!(
        stderr.contains("objects[1] gets no light") && stderr.contains("--allow-blocked"),
        "submit: {stderr}"
    );
    let allowed = run(&["--workers", "0", "--allow-blocked"]);
    assert!(
        allowed.status.success(),
        "{}",
        String::from_utf8_lossy(&allowed.stderr)
    );
    assert!(out.is_file());
}

/// `--set PATH=VALUE` changes one field without editing the file, checked as the file is: the
/// image has the overridden size, and a bad override is refused naming its path.
#[test]
fn set_overrides_a_scene_field_and_is_checked_like_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("tiny.exr");
    let scene_path = repo().join("scenes/tiny.json");
    let run = |sets: &[&str]| {
        let mut command = Command::new(env!("CARGO_BIN_EXE_spindle"));
        command.args([
            "render",
            scene_path.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        command.args(["--workers", "0"]);
        for set in sets {
            command.args(["--set", set]);
        }
        command.output().unwrap()
    };
    let done = run(&[
        "film.width=12",
        "film.height=10",
        "objects[1].material.eta=1.2",
    ]);
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    let image = read_exr(&out).unwrap();
    assert_eq!((image.width, image.height), (12, 10));
    for (set, path) in [
        ("film.width=0", "film.width"),
        ("objects[7].material.eta=1.2", "objects[7].material.eta"),
        ("film.colour=1", "film.colour"),
    ] {
        let refused = run(&[set]);
        let stderr = String::from_utf8_lossy(&refused.stderr);
        assert!(!refused.status.success(), "{set} was accepted");
        assert!(
            stderr.contains(&format!("--set {path}: ")),
            "{set}: {stderr}"
        );
    }
}

/// The layers of an EXR, alpha included, to compare two renders pixel for pixel.
fn layers(path: &Path) -> [Vec<f32>; 6] {
    let image = read_exr(path).unwrap();
    [
        image.total,
        image.surface,
        image.single_scatter,
        image.multiple_scatter,
        image.stderr,
        image.alpha,
    ]
}

/// `--threads N` sizes the render's own pool (the report names it) and changes no pixel: one
/// and two threads, in this process and on the local farm, give the same image, bit for bit.
/// `--threads 0` is refused naming the flag.
#[test]
fn threads_size_the_render_and_change_no_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let run = |out: &str, args: &[&str]| {
        let done = render_in(dir.path(), &[&["-o", out][..], args].concat());
        let stdout = String::from_utf8_lossy(&done.stdout).into_owned();
        assert!(
            done.status.success(),
            "{args:?}: {stdout}\n{}",
            String::from_utf8_lossy(&done.stderr)
        );
        stdout
    };
    let one = run("one.exr", &["--workers", "0", "--threads", "1"]);
    assert!(one.contains(" on 1 thread "), "{one}");
    let two = run("two.exr", &["--workers", "0", "--threads", "2"]);
    assert!(two.contains(" on 2 threads "), "{two}");
    let farm = run("farm.exr", &["--workers", "2", "--threads", "1"]);
    assert!(
        farm.contains("local farm of 2 workers × 1 thread "),
        "{farm}"
    );
    let reference = layers(&dir.path().join("one.exr"));
    assert!(reference[0].iter().any(|&v| v > 0.0));
    // Alpha is there and not trivial: the objects cover some pixels and leave others.
    assert!(reference[5].iter().any(|&a| a > 0.0) && reference[5].iter().any(|&a| a < 1.0));
    assert_eq!(layers(&dir.path().join("two.exr")), reference);
    assert_eq!(layers(&dir.path().join("farm.exr")), reference);
    // The headers say the same too: the file does not depend on the threads, but for
    // `renderTime`, the one attribute that differs from run to run.
    let timeless = |name: &str| {
        let mut image = read_exr(dir.path().join(name)).unwrap();
        assert!(image.standard.render_time.is_some_and(|s| s > 0.0));
        image.standard.render_time = None;
        image
    };
    assert_eq!(timeless("one.exr"), timeless("two.exr"));

    for workers in ["0", "1"] {
        let refused = render_in(
            dir.path(),
            &["-o", "zero.exr", "--workers", workers, "--threads", "0"],
        );
        let stderr = String::from_utf8_lossy(&refused.stderr);
        assert!(!refused.status.success(), "--threads 0 was accepted");
        assert!(
            stderr.contains("--threads") && stderr.contains("at least 1"),
            "{stderr}"
        );
        assert!(!dir.path().join("zero.exr").exists());
    }
}

/// `-o x.png` writes the tone-mapped preview alone, the film's size, on both paths; the same
/// bytes as the preview an EXR render writes beside its EXR.
#[test]
fn a_png_output_is_the_preview_alone() {
    let dir = tempfile::tempdir().unwrap();
    let desc = SceneDescription::from_json(
        &std::fs::read_to_string(repo().join("scenes/tiny.json")).unwrap(),
    )
    .unwrap();
    for workers in ["0", "1"] {
        let sub = dir.path().join(format!("workers-{workers}"));
        std::fs::create_dir(&sub).unwrap();
        let done = render_in(&sub, &["-o", "tiny.png", "--workers", workers]);
        let stdout = String::from_utf8_lossy(&done.stdout);
        assert!(
            done.status.success(),
            "{stdout}\n{}",
            String::from_utf8_lossy(&done.stderr)
        );
        assert!(stdout.contains("rendered tiny.png"), "{stdout}");
        let names: Vec<_> = std::fs::read_dir(&sub)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        assert_eq!(names, ["tiny.png"], "only the PNG is written");
        let decoder = png::Decoder::new(std::io::BufReader::new(
            std::fs::File::open(sub.join("tiny.png")).unwrap(),
        ));
        let mut reader = decoder.read_info().unwrap();
        let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
        let frame = reader.next_frame(&mut pixels).unwrap();
        assert_eq!(
            (frame.width, frame.height),
            (desc.film.width, desc.film.height)
        );
        assert!(pixels.iter().any(|&v| v > 0), "the preview is all black");
    }
    let exr = render_in(dir.path(), &["-o", "tiny.exr", "--workers", "0"]);
    assert!(exr.status.success());
    assert_eq!(
        std::fs::read(dir.path().join("tiny.png")).unwrap(),
        std::fs::read(dir.path().join("workers-0/tiny.png")).unwrap()
    );
}

/// `--quiet` prints nothing but errors, as pbrt's does: no plan, no progress, no "rendered"
/// line, on both paths; the image is written all the same, and an error still says what is
/// wrong.
#[test]
fn quiet_prints_nothing_but_errors() {
    let dir = tempfile::tempdir().unwrap();
    for workers in ["0", "1"] {
        let out = format!("quiet-{workers}.exr");
        let done = render_in(dir.path(), &["-o", &out, "--workers", workers, "--quiet"]);
        assert!(done.status.success());
        assert_eq!(
            String::from_utf8_lossy(&done.stdout),
            "",
            "{workers}: stdout"
        );
        assert_eq!(
            String::from_utf8_lossy(&done.stderr),
            "",
            "{workers}: stderr"
        );
        assert!(dir.path().join(&out).is_file());
    }
    let refused = render_in(
        dir.path(),
        &["-o", "bad.exr", "--quiet", "--set", "film.width=0"],
    );
    assert!(!refused.status.success());
    assert!(refused.stdout.is_empty());
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(stderr.contains("--set film.width: "), "{stderr}");
}

/// `--error-png` at 1 spp (the tiny scene's) is refused before rendering, naming the flag, since
/// a one-sample pixel has no error estimate; at 2 spp it is written. `--half` writes the EXR in
/// half floats.
#[test]
fn error_png_needs_two_samples_and_half_writes_half_floats() {
    let dir = tempfile::tempdir().unwrap();
    let refused = render_in(
        dir.path(),
        &["-o", "one.exr", "--workers", "0", "--error-png"],
    );
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success());
    assert!(
        stderr.contains("--error-png: film.spp is 1") && stderr.contains("--spp 2"),
        "{stderr}"
    );
    // A sentence, not a source line's indentation.
    assert!(!stderr.contains("  "), "{stderr}");
    assert!(!dir.path().join("one.exr").exists());

    let done = render_in(
        dir.path(),
        &[
            "-o",
            "two.exr",
            "--workers",
            "0",
            "--error-png",
            "--spp",
            "2",
            "--half",
        ],
    );
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    assert!(dir.path().join("two.stderr.png").exists());
    let image = read_exr(dir.path().join("two.exr")).unwrap();
    assert_eq!(image.precision, spindle_common::image::Precision::Half);
    assert!(image.total.iter().any(|&v| v > 0.0));
}
