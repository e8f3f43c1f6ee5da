//! `--crop` end to end: a window of the film rendered on a farm (`spindle submit --crop`, the
//! local farm of `spindle render --crop`) and in process (`--workers 0 --crop`) gives the same
//! EXR — the window as the data window inside the film's display window — whose pixels are
//! those of a full render; a crop outside the film or without pixels is refused naming `crop`.

use std::path::Path;
use std::process::Output;
use std::time::Duration;

use reqwest::{Method, StatusCode};
use serde_json::{Value, json};
use spindle_common::image::{Image, Placement, read_exr};
use spindle_common::protocol::{JobInfo, JobList, asset_hash};
use spindle_common::tile::TileRect;
use spindle_tests::{
    Farm, assert_bit_identical, output_text, reference_image, run_spindle, scattering_test_scene,
    write_scene_files,
};

const TEST_TIMEOUT: Duration = Duration::from_secs(240);

/// The film of these tests, and the window cut from it: off-centre, not a multiple of the tile
/// size, touching neither edge.
const FILM: (u32, u32) = (36, 20);
const CROP: TileRect = TileRect {
    x: 5,
    y: 3,
    width: 21,
    height: 13,
};
const CROP_ARG: &str = "5,3,21,13";

/// Writes the scene (interval single scattering on, so every layer is non-trivial) and its
/// mesh into `dir`; returns the scene file's path.
fn write_scene(dir: &Path) -> std::path::PathBuf {
    let (scene, assets) = scattering_test_scene(FILM.0, FILM.1, 2);
    write_scene_files(dir, &scene, &assets).unwrap()
}

/// Runs `spindle` with `args`, talking to `farm` if given.
async fn spindle(args: &[&str], farm: Option<&Farm>) -> Output {
    run_spindle(None, args, farm, TEST_TIMEOUT).await
}

fn text(out: &Output) -> String {
    output_text(out)
}

/// A `box2i` attribute of an EXR header (`dataWindow`, `displayWindow`) as
/// `[x_min, y_min, x_max, y_max]`, read from the bytes by the OpenEXR file layout (magic,
/// version, then `name\0type\0size value` records), independently of spindle's reader.
fn header_box(bytes: &[u8], name: &str) -> [i32; 4] {
    let mut at = 8;
    loop {
        let end = |from: usize| from + bytes[from..].iter().position(|&b| b == 0).unwrap();
        let name_end = end(at);
        assert!(name_end > at, "no {name} in the header");
        let type_end = end(name_end + 1);
        let size = i32::from_le_bytes(bytes[type_end + 1..type_end + 5].try_into().unwrap());
        let value = &bytes[type_end + 5..type_end + 5 + size as usize];
        if &bytes[at..name_end] == name.as_bytes() {
            assert_eq!(&bytes[name_end + 1..type_end], b"box2i");
            let i = |k: usize| i32::from_le_bytes(value[4 * k..4 * k + 4].try_into().unwrap());
            return [i(0), i(1), i(2), i(3)];
        }
        at = type_end + 5 + size as usize;
    }
}

/// Panics unless `window` holds, bit for bit, the pixels of `full` inside `rect`.
fn assert_window_of(window: &Image, full: &Image, rect: TileRect) {
    assert_eq!((window.width, window.height), (rect.width, rect.height));
    for (layer, (w, f)) in window.layers().iter().zip(full.layers()).enumerate() {
        let n = spindle_common::tile::LAYERS[layer].channels;
        for row in 0..rect.height {
            for col in 0..rect.width {
                for c in 0..n {
                    let a = w[(row * rect.width + col) as usize * n + c];
                    let (x, y) = (rect.x + col, rect.y + row);
                    let b = f[(y * full.width + x) as usize * n + c];
                    assert_eq!(
                        a.to_bits(),
                        b.to_bits(),
                        "layer {layer} pixel ({x}, {y}) channel {c}: {a} in the crop, {b} in the full render"
                    );
                }
            }
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_crop_on_the_farm_writes_the_window_as_render_in_process_does() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path());
    let s = scene.to_str().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();

    // A remote farm: `spindle submit --crop`, waited for and fetched.
    let mut farm = Farm::start(5.0).await.unwrap();
    for name in ["worker-a", "worker-b"] {
        farm.add_worker(name, 1).unwrap();
    }
    let submitted = path("submitted.exr");
    let out = spindle(
        &[
            "submit",
            s,
            "--crop",
            CROP_ARG,
            "--tile-size",
            "8",
            "--wait",
            "-o",
            &submitted,
        ],
        Some(&farm),
    )
    .await;
    assert!(out.status.success(), "{}\n{}", text(&out), farm.logs());
    let id: u64 = String::from_utf8_lossy(&out.stdout)
        .lines()
        .next()
        .and_then(|l| l.trim().parse().ok())
        .unwrap_or_else(|| panic!("no job id: {}", text(&out)));
    let job: JobInfo = farm.job(id).await.unwrap();
    assert_eq!(job.crop, Some(CROP));
    assert_eq!((job.width, job.height), FILM);
    // Only the window is tiled: 21 x 13 pixels in 8-px tiles.
    assert_eq!((job.tiles_done, job.tiles_total), (6, 6));
    let out = spindle(&["status", &id.to_string()], Some(&farm)).await;
    assert!(
        text(&out).contains("36x20 (crop 5,3 21x13)"),
        "{}",
        text(&out)
    );

    // In this process, and on the local farm of `spindle render`.
    let here = path("here.exr");
    let out = spindle(
        &[
            "render",
            s,
            "--crop",
            CROP_ARG,
            "--workers",
            "0",
            "-o",
            &here,
        ],
        None,
    )
    .await;
    assert!(out.status.success(), "{}", text(&out));
    let local = path("local.exr");
    let out = spindle(
        &[
            "render",
            s,
            "--crop",
            CROP_ARG,
            "--workers",
            "2",
            "--tile-size",
            "8",
            "-o",
            &local,
        ],
        None,
    )
    .await;
    assert!(out.status.success(), "{}", text(&out));
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("region 5,3 21x13"),
        "{}",
        text(&out)
    );

    // The file: the crop is the data window, the film the display window (inclusive corners).
    let submitted_bytes = std::fs::read(&submitted).unwrap();
    for (name, bytes) in [
        ("submitted", submitted_bytes.clone()),
        ("here", std::fs::read(&here).unwrap()),
        ("local", std::fs::read(&local).unwrap()),
    ] {
        assert_eq!(header_box(&bytes, "dataWindow"), [5, 3, 25, 15], "{name}");
        assert_eq!(
            header_box(&bytes, "displayWindow"),
            [0, 0, 35, 19],
            "{name}"
        );
    }

    // The same image: pixels, place in the film and header, but for the scene file's path
    // (which the coordinator never sees) and the local farm's worker count.
    let submitted = read_exr(&submitted).unwrap();
    let mut here = read_exr(&here).unwrap();
    let mut local = read_exr(&local).unwrap();
    let placement = Placement {
        x: 5,
        y: 3,
        film_width: 36,
        film_height: 20,
    };
    assert_eq!(submitted.placement, placement);
    assert_bit_identical(&submitted, &here);
    assert_bit_identical(&local, &here);
    assert_eq!(
        here.attributes.get("spindle.region").map(String::as_str),
        Some("5,3,21,13")
    );
    assert!(here.attributes.remove("spindle.scene").is_some());
    assert!(local.attributes.remove("spindle.scene").is_some());
    assert!(local.attributes.remove("spindle.workers").is_some());
    assert_eq!(local.attributes, here.attributes);
    assert_eq!(submitted.attributes, here.attributes);
    // So the coordinator's file is, byte for byte, what `--workers 0 --crop` writes, once given
    // the same `renderTime` (the one value that differs from run to run).
    assert_eq!(here.standard.world_to_ndc, submitted.standard.world_to_ndc);
    assert_eq!(here.standard.software, submitted.standard.software);
    here.standard.render_time = submitted.standard.render_time;
    assert_eq!(here.to_exr_bytes().unwrap(), submitted_bytes);

    // And the window holds the very pixels of a full render, every layer non-trivial.
    let (desc, assets) = scattering_test_scene(FILM.0, FILM.1, 2);
    let full = reference_image(&desc, &assets).unwrap();
    assert_window_of(&submitted, &full, CROP);
    for (name, layer) in ["surface", "single_scatter"]
        .iter()
        .zip([&submitted.surface, &submitted.single_scatter])
    {
        assert!(layer.iter().any(|&v| v > 0.0), "{name} is black");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_crop_outside_the_film_or_without_pixels_is_refused_naming_crop() {
    let dir = tempfile::tempdir().unwrap();
    let scene_file = write_scene(dir.path());
    let s = scene_file.to_str().unwrap();
    let farm = Farm::start(5.0).await.unwrap();
    let (scene, assets) = scattering_test_scene(FILM.0, FILM.1, 1);
    // A first job, so the assets are stored and the refusals are about the crop alone.
    let first = farm.submit(&scene, &assets, 8).await.unwrap();
    let hash = asset_hash(&assets["meshes/floor.obj"]);
    let rect = |x: u64, y: u64, w: u64, h: u64| json!({"x": x, "y": y, "width": w, "height": h});
    for crop in [
        rect(0, 0, 0, 5),
        rect(2, 2, 5, 0),
        rect(30, 0, 7, 5),
        rect(0, 10, 5, 11),
        rect(36, 0, 1, 1),
        rect(u32::MAX as u64, 0, 2, 2),
    ] {
        let body = json!({
            "scene": scene,
            "assets": { "meshes/floor.obj": hash },
            "crop": crop,
        });
        let resp = farm
            .client(Method::POST, "/v1/jobs")
            .json(&body)
            .send()
            .await
            .unwrap();
        let status = resp.status();
        let error: Value = resp.json().await.unwrap();
        assert_eq!(status, StatusCode::BAD_REQUEST, "{crop}: {error}");
        let message = error["error"].as_str().unwrap();
        assert!(message.starts_with("crop: "), "{crop}: {message}");
    }
    // Nothing was added.
    let list: JobList = farm
        .client(Method::GET, "/v1/jobs")
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(
        list.jobs.iter().map(|j| j.id).collect::<Vec<_>>(),
        vec![first.id]
    );

    // The command refuses the same before any upload or render, naming --crop.
    let out = spindle(&["submit", s, "--crop", "30,0,7,5"], Some(&farm)).await;
    assert!(!out.status.success(), "{}", text(&out));
    assert!(
        text(&out).contains("--crop: the window 30,0 7x5"),
        "{}",
        text(&out)
    );
    let exr = dir.path().join("out.exr");
    let exr = exr.to_str().unwrap();
    for workers in ["0", "2"] {
        let out = spindle(
            &[
                "render",
                s,
                "--crop",
                "0,10,5,11",
                "--workers",
                workers,
                "-o",
                exr,
            ],
            None,
        )
        .await;
        assert!(!out.status.success(), "{}", text(&out));
        assert!(
            text(&out).contains("--crop: the window 0,10 5x11"),
            "{}",
            text(&out)
        );
        let out = spindle(
            &[
                "render",
                s,
                "--crop",
                "0,0,0,4",
                "--workers",
                workers,
                "-o",
                exr,
            ],
            None,
        )
        .await;
        assert!(!out.status.success(), "{}", text(&out));
        assert!(text(&out).contains("--crop"), "{}", text(&out));
    }
    assert!(!Path::new(exr).exists());
}
