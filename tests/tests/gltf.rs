//! A glTF scene through the `spindle` command: `spindle submit scene.gltf` to a farm gives the
//! same bits as `spindle render scene.gltf --workers 0`, with the camera picked by `--camera`;
//! `--camera` on a spindle JSON scene is refused.

use std::path::Path;
use std::time::Duration;

use spindle_common::image::read_exr;
use spindle_tests::{Farm, assert_bit_identical, output_text, run_spindle};

const SMALL: [&str; 6] = [
    "--set",
    "film.width=32",
    "--set",
    "film.height=24",
    "--spp",
    "1",
];

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_gltf_scene_submitted_to_a_farm_renders_as_in_process() {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    let gltf = scenes.join("glass-cube.gltf");
    let g = gltf.to_str().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let minute = Duration::from_secs(300);

    let mut here = vec![
        "render",
        g,
        "--workers",
        "0",
        "--camera",
        "Front camera",
        "-o",
        "here.exr",
    ];
    here.extend(SMALL);
    let out = run_spindle(Some(dir.path()), &here, None, minute).await;
    assert!(out.status.success(), "{}", output_text(&out));
    // The scene's second camera is listed as not chosen, the first one named.
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("cameras not chosen") && stderr.contains("nodes[3] \"Side camera\""),
        "{}",
        output_text(&out)
    );

    let mut farm = Farm::start(30.0).await.unwrap();
    farm.add_worker("w", 2).unwrap();
    let mut submit = vec![
        "submit",
        g,
        "--camera",
        "Front camera",
        "--tile-size",
        "8",
        "--wait",
        "-o",
        "farm.exr",
    ];
    submit.extend(SMALL);
    let out = run_spindle(Some(dir.path()), &submit, Some(&farm), minute).await;
    assert!(
        out.status.success(),
        "{}\n{}",
        output_text(&out),
        farm.logs()
    );
    assert_bit_identical(
        &read_exr(dir.path().join("here.exr")).unwrap(),
        &read_exr(dir.path().join("farm.exr")).unwrap(),
    );

    // The other camera gives another image (the check above can tell cameras apart).
    let mut side = vec!["render", g, "--workers", "0", "-o", "side.exr"];
    side.extend(SMALL);
    let out = run_spindle(Some(dir.path()), &side, None, minute).await;
    assert!(out.status.success(), "{}", output_text(&out));
    let a = read_exr(dir.path().join("here.exr")).unwrap();
    let b = read_exr(dir.path().join("side.exr")).unwrap();
    assert_ne!(a.layers()[0], b.layers()[0]);

    // --camera names a glTF camera; a spindle scene has one.
    let json = scenes.join("tiny.json");
    let out = run_spindle(
        Some(dir.path()),
        &[
            "render",
            json.to_str().unwrap(),
            "--camera",
            "x",
            "-o",
            "x.exr",
        ],
        None,
        minute,
    )
    .await;
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--camera"),
        "{}",
        output_text(&out)
    );
}
