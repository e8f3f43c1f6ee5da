//! `spindle render` stopped by a real signal: the built binary, on a scene of 20 tiles that takes
//! tens of seconds on one thread (25 s on two workers of one thread each, measured), is sent
//! SIGHUP until its output holds a tile, then SIGINT or SIGTERM. The EXR it leaves must hold the finished tiles with the bits the library renders for
//! them and the others transparent black, the exit status must be 128 + the signal, and the
//! local farm's `spindle-farm-*` directory must be gone from the (test-private) TMPDIR.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use spindle_common::image::{Image, read_exr};
use spindle_common::tile::{TileRect, split_window_centre_first};
use spindle_render::{Scene, render_tile};
use spindle_tests::{Proc, assert_bit_identical, binary, scattering_test_scene, write_scene_files};

/// The longest the test waits for a tile, or for the command to end after the signal.
const PATIENCE: Duration = Duration::from_secs(600);

/// Sends `signal` (`HUP`, `INT`, `TERM`) to `pid` through kill(1).
fn send(signal: &str, pid: u32) {
    let status = Command::new("kill")
        .args([&format!("-{signal}"), &pid.to_string()])
        .status()
        .expect("running kill");
    assert!(status.success(), "kill -{signal} {pid}: {status}");
}

/// The tiles an output says it holds, from its `spindle.tiles_done` (`N of M`).
fn tiles_done(image: &Image) -> Option<(usize, usize)> {
    let text = image.attributes.get("spindle.tiles_done")?;
    let (done, total) = text.split_once(" of ")?;
    Some((done.parse().ok()?, total.parse().ok()?))
}

/// Renders scene `args` (after `render`) to `dir/out.exr`, asks for the image with SIGHUP until it
/// holds a tile, sends `stop`, and checks what is left against the library's tiles.
async fn interrupted_render(extra: &[&str], stop: &str, exit_code: i32) {
    let dir = tempfile::tempdir().unwrap();
    let tmp = dir.path().join("tmp");
    std::fs::create_dir(&tmp).unwrap();
    // 20 tiles of 32 pixels, the centre ones taking seconds each on one thread.
    let (scene, assets) = scattering_test_scene(160, 120, 4);
    let scene_path = write_scene_files(dir.path(), &scene, &assets).unwrap();
    let out = dir.path().join("out.exr");
    let mut command = Command::new(binary("spindle"));
    command
        .args([
            "render",
            scene_path.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ])
        .args(["--threads", "1", "--tile-size", "32"])
        .args(extra)
        .env("TMPDIR", &tmp);
    let mut render = Proc::spawn(command, &[("RUST_LOG", "warn")], dir.path(), "render").unwrap();

    // Signals are taken over before the plan is printed; before that SIGHUP would end it.
    let started = Instant::now();
    while !render.log().contains("single scattering:") {
        assert!(started.elapsed() < PATIENCE, "no plan:\n{}", render.log());
        assert!(render.try_status().is_none(), "{}", render.log());
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    loop {
        assert!(
            render.try_status().is_none(),
            "the render ended before it was stopped:\n{}",
            render.log()
        );
        assert!(
            started.elapsed() < PATIENCE,
            "no tile came:\n{}",
            render.log()
        );
        send("HUP", render.pid());
        tokio::time::sleep(Duration::from_secs(1)).await;
        if let Ok(image) = read_exr(&out)
            && tiles_done(&image).is_some_and(|(done, _)| done > 0)
        {
            break;
        }
    }
    send(stop, render.pid());
    let status = render.wait_exit(PATIENCE).await.unwrap();
    let log = render.log();
    assert_eq!(status.code(), Some(exit_code), "{log}");

    let image = read_exr(&out).unwrap();
    let (done, total) = tiles_done(&image).expect("spindle.tiles_done in the header");
    assert_eq!(total, 20, "{log}");
    assert!(done >= 1 && done < total, "{done} of {total} tiles\n{log}");
    assert!(
        log.contains(&format!(
            "interrupted by SIG{stop}: wrote {done} of {total} tiles"
        )),
        "{log}"
    );

    // The library's pixels for each finished tile (one with any light in it: the background is
    // not black), and nothing at all, alpha 0 included, elsewhere.
    let desc = serde_json::from_value(scene.clone()).unwrap();
    let built = Scene::build(&desc, &assets).unwrap();
    let full = TileRect {
        x: 0,
        y: 0,
        width: 160,
        height: 120,
    };
    let mut expected = Image::new(160, 120);
    let mut finished = 0;
    for rect in split_window_centre_first(full, 32) {
        if has_light(&image, rect) {
            expected.insert_tile(&render_tile(&built, rect)).unwrap();
            finished += 1;
        }
    }
    assert_eq!(finished, done, "tiles with pixels vs the header's count");
    assert_bit_identical(&image, &expected);

    let left: Vec<_> = std::fs::read_dir(&tmp)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .filter(|n| n.to_string_lossy().starts_with("spindle-farm-"))
        .collect();
    assert!(left.is_empty(), "left behind in TMPDIR: {left:?}");
    assert!(Path::new(&out.with_extension("png")).is_file());
}

/// Does any pixel of `rect` in `image` (the whole film) have light?
fn has_light(image: &Image, rect: TileRect) -> bool {
    (rect.y..rect.y + rect.height).any(|y| {
        (rect.x..rect.x + rect.width).any(|x| {
            let i = 3 * (y * image.width + x) as usize;
            image.total[i..i + 3].iter().any(|&v| v != 0.0)
        })
    })
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ctrl_c_in_process_writes_the_finished_tiles_and_exits_130() {
    interrupted_render(&["--workers", "0"], "INT", 130).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sigterm_on_the_local_farm_writes_the_finished_tiles_exits_143_and_leaves_no_farm_dir() {
    interrupted_render(&["--workers", "2"], "TERM", 143).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ctrl_c_on_the_local_farm_exits_130_and_leaves_no_farm_dir() {
    interrupted_render(&["--workers", "1"], "INT", 130).await;
}
