//! A frame of an animated scene on a farm: `spindle submit scenes/orbit.json --frames N` sends
//! the scene with the frame, each worker makes the still with `SceneDescription::at_frame`, and
//! the job's EXR is bit-identical to `spindle render --workers 0 --frames N`'s — its header's
//! camera matrices those of the camera at that frame.

use std::path::Path;
use std::time::Duration;

use spindle_common::image::read_exr;
use spindle_tests::{Farm, assert_bit_identical, output_text, run_spindle};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_frame_submitted_to_a_farm_renders_as_in_process() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/orbit.json");
    let s = scene.to_str().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let limit = Duration::from_secs(300);

    let here = [
        "render",
        s,
        "--workers",
        "0",
        "--frames",
        "3",
        "-o",
        "here.####.exr",
    ];
    let out = run_spindle(Some(dir.path()), &here, None, limit).await;
    assert!(out.status.success(), "{}", output_text(&out));

    let farm = Farm::of_two_workers(30.0).await.unwrap();
    let submit = [
        "submit",
        s,
        "--frames",
        "3",
        "--tile-size",
        "8",
        "--wait",
        "-o",
        "farm.exr",
    ];
    let out = run_spindle(Some(dir.path()), &submit, Some(&farm), limit).await;
    assert!(
        out.status.success(),
        "{}\n{}",
        output_text(&out),
        farm.logs()
    );
    let (here, there) = (
        read_exr(dir.path().join("here.0003.exr")).unwrap(),
        read_exr(dir.path().join("farm.exr")).unwrap(),
    );
    assert_bit_identical(&here, &there);
    assert_eq!(
        here.attributes.get("worldToCamera"),
        there.attributes.get("worldToCamera")
    );

    // Frame 1 is another picture: the frame reached the workers.
    let first = [
        "render",
        s,
        "--workers",
        "0",
        "--frames",
        "1",
        "-o",
        "first.exr",
    ];
    let out = run_spindle(Some(dir.path()), &first, None, limit).await;
    assert!(out.status.success(), "{}", output_text(&out));
    let first = read_exr(dir.path().join("first.exr")).unwrap();
    assert_ne!(first.layers()[0], there.layers()[0]);

    // A range is refused (one frame a job), naming the flag, before anything is sent.
    let out = run_spindle(
        Some(dir.path()),
        &["submit", s, "--frames", "1-3"],
        Some(&farm),
        limit,
    )
    .await;
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--frames 1-3: a job renders one frame"),
        "{}",
        output_text(&out)
    );
}
