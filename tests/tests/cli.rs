//! The `spindle` command end to end: `render` through its embedded local farm and in process,
//! and `submit` / `status` / `fetch` / `cancel` / `workers` against a real coordinator.

use std::path::Path;
use std::process::{Command, Output};
use std::time::Duration;

use spindle_common::image::read_exr;
use spindle_common::protocol::{JobInfo, JobState, WorkerList, WorkerState};
use spindle_tests::{
    Farm, accepted_tiles, assert_bit_identical, binary, output_text, reference_image, run_spindle,
    test_scene, write_scene_files,
};

const TEST_TIMEOUT: Duration = Duration::from_secs(150);

/// Writes the test scene and its mesh into `dir`; returns the scene file's path.
fn write_scene(dir: &Path, width: u32, height: u32, spp: u32) -> std::path::PathBuf {
    let (scene, assets) = test_scene(width, height, spp);
    write_scene_files(dir, &scene, &assets).unwrap()
}

/// Runs `spindle` with `args` (killed if it outlives the test's timeout) and the farm's
/// address and client token in its environment.
async fn spindle(args: &[&str], farm: Option<&Farm>) -> Output {
    spindle_in(None, args, farm).await
}

/// [`spindle`] run in the directory `cwd`.
async fn spindle_in(cwd: Option<&Path>, args: &[&str], farm: Option<&Farm>) -> Output {
    run_spindle(cwd, args, farm, TEST_TIMEOUT).await
}

fn text(out: &Output) -> String {
    output_text(out)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn render_on_the_local_farm_matches_render_in_process() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), 40, 24, 2);
    let farm_exr = dir.path().join("farm.exr");
    let here_exr = dir.path().join("here.exr");
    let s = scene.to_str().unwrap();

    let out = spindle(
        &[
            "render",
            s,
            "-o",
            farm_exr.to_str().unwrap(),
            "--workers",
            "2",
            "--tile-size",
            "8",
        ],
        None,
    )
    .await;
    assert!(out.status.success(), "{}", text(&out));
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("local farm of 2 workers"),
        "{}",
        text(&out)
    );
    let out = spindle(
        &[
            "render",
            s,
            "-o",
            here_exr.to_str().unwrap(),
            "--workers",
            "0",
        ],
        None,
    )
    .await;
    assert!(out.status.success(), "{}", text(&out));

    let farm = read_exr(&farm_exr).unwrap();
    let here = read_exr(&here_exr).unwrap();
    assert_bit_identical(&farm, &here);
    // And both equal the renderer library called directly.
    let (desc, assets) = test_scene(40, 24, 2);
    assert_bit_identical(&here, &reference_image(&desc, &assets).unwrap());
    for png in ["farm.png", "here.png"] {
        let bytes = std::fs::read(dir.path().join(png)).unwrap();
        assert!(
            bytes.starts_with(b"\x89PNG\r\n\x1a\n"),
            "{png} is not a PNG"
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn render_reports_a_bad_scene_by_its_json_path() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), 8, 8, 1);
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&scene).unwrap()).unwrap();
    json["objects"][1]["material"]["medium"]["albedo"][1] = serde_json::json!(1.5);
    std::fs::write(&scene, json.to_string()).unwrap();
    let out_exr = dir.path().join("x.exr");
    for workers in ["0", "2"] {
        let out = spindle(
            &[
                "render",
                scene.to_str().unwrap(),
                "-o",
                out_exr.to_str().unwrap(),
                "--workers",
                workers,
            ],
            None,
        )
        .await;
        assert!(!out.status.success(), "{}", text(&out));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("objects[1].material.medium.albedo[1]"),
            "{}",
            text(&out)
        );
        assert!(!out_exr.exists());
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn submit_wait_status_fetch_and_cancel_against_a_coordinator() {
    tokio::time::timeout(TEST_TIMEOUT, async {
        let dir = tempfile::tempdir().unwrap();
        let scene = write_scene(dir.path(), 24, 16, 1);
        let s = scene.to_str().unwrap();
        let mut farm = Farm::start(5.0).await.unwrap();

        // With no worker, a job stays queued and can be cancelled.
        let out = spindle(&["submit", s], Some(&farm)).await;
        assert!(out.status.success(), "{}", text(&out));
        let queued: u64 = String::from_utf8_lossy(&out.stdout)
            .trim()
            .parse()
            .expect("a job id");
        let out = spindle(&["status", &queued.to_string()], Some(&farm)).await;
        assert!(
            String::from_utf8_lossy(&out.stdout).contains("queued — no workers connected"),
            "{}",
            text(&out)
        );

        // A scene whose mesh does not build is refused before anything is sent, with the
        // message `render --workers 0` gives.
        let broken = dir.path().join("broken");
        let broken_scene = write_scene(&broken, 8, 8, 1);
        std::fs::write(
            broken.join("meshes/floor.obj"),
            "v -4 0 -4\nv 4 0 -4\nv 4 0 4\nf 1 2 9\n",
        )
        .unwrap();
        let b = broken_scene.to_str().unwrap();
        let local = spindle(&["render", b, "--workers", "0", "-o", "x.exr"], None).await;
        let submitted = spindle(&["submit", b], Some(&farm)).await;
        assert!(!local.status.success() && !submitted.status.success());
        let reason = |out: &Output| {
            let stderr = String::from_utf8_lossy(&out.stderr).to_string();
            let line = stderr
                .lines()
                .find(|l| l.contains("floor.obj"))
                .map(str::to_string);
            line.unwrap_or_else(|| panic!("no mention of the mesh: {}", text(out)))
        };
        assert_eq!(reason(&submitted), reason(&local), "{}", text(&submitted));
        let resp = farm
            .client(reqwest::Method::GET, "/v1/jobs")
            .send()
            .await
            .unwrap();
        let list: spindle_common::protocol::JobList = resp.json().await.unwrap();
        assert_eq!(list.jobs.len(), 1, "only the first job was submitted");

        let out = spindle(&["cancel", &queued.to_string()], Some(&farm)).await;
        assert!(out.status.success(), "{}", text(&out));
        assert_eq!(farm.job(queued).await.unwrap().state, JobState::Cancelled);
        let out = spindle(
            &[
                "fetch",
                &queued.to_string(),
                "-o",
                dir.path().join("no.exr").to_str().unwrap(),
            ],
            Some(&farm),
        )
        .await;
        // A cancelled job's image is its finished tiles, the missing ones transparent: here
        // none was rendered, so every pixel is.
        assert!(
            out.status.success(),
            "fetching a cancelled job: {}",
            text(&out)
        );
        let partial = spindle_common::image::read_exr(dir.path().join("no.exr"))
            .expect("the partial image reads back");
        assert!(
            !partial.alpha.is_empty() && partial.alpha.iter().all(|&a| a == 0.0),
            "no tile was rendered, so no pixel is covered"
        );

        // With a worker, submit --wait returns once the job is done.
        farm.add_worker("w", 2).unwrap();
        let out = spindle(&["submit", s, "--wait", "--tile-size", "8"], Some(&farm)).await;
        assert!(out.status.success(), "{}\n{}", text(&out), farm.logs());
        let id: u64 = String::from_utf8_lossy(&out.stdout)
            .trim()
            .parse()
            .expect("a job id");
        assert_ne!(id, queued);

        let out = spindle(&["status", &id.to_string(), "--json"], Some(&farm)).await;
        assert!(out.status.success(), "{}", text(&out));
        let info: JobInfo =
            serde_json::from_slice(&out.stdout).expect("status --json is a JobInfo");
        assert_eq!(info.state, JobState::Done);
        let out = spindle(&["status"], Some(&farm)).await;
        assert!(out.status.success(), "{}", text(&out));
        assert!(
            String::from_utf8_lossy(&out.stdout).contains("cancelled"),
            "{}",
            text(&out)
        );

        // `status --follow` waits for a job submitted without --wait and shows how it ended;
        // `--spp` and `--seed` of submit change the scene as those of render do.
        let out = spindle(
            &["submit", s, "--tile-size", "8", "--spp", "2", "--seed", "5"],
            Some(&farm),
        )
        .await;
        assert!(out.status.success(), "{}", text(&out));
        let edited: u64 = String::from_utf8_lossy(&out.stdout).trim().parse().unwrap();
        let out = spindle(&["status", &edited.to_string(), "--follow"], Some(&farm)).await;
        assert!(out.status.success(), "{}", text(&out));
        assert!(
            String::from_utf8_lossy(&out.stdout)
                .starts_with(&format!("job {edited} (scene): done\n")),
            "{}",
            text(&out)
        );
        let edited_exr = dir.path().join("edited.exr");
        let out = spindle(
            &[
                "fetch",
                &edited.to_string(),
                "-o",
                edited_exr.to_str().unwrap(),
            ],
            Some(&farm),
        )
        .await;
        assert!(out.status.success(), "{}", text(&out));
        let (mut desc, assets) = test_scene(24, 16, 1);
        desc["film"]["spp"] = 2.into();
        desc["film"]["seed"] = 5.into();
        assert_bit_identical(
            &read_exr(&edited_exr).unwrap(),
            &reference_image(&desc, &assets).unwrap(),
        );

        // `--server HOST:PORT` without a scheme (http on loopback) and the token from a file.
        let token_file = dir.path().join("token");
        std::fs::write(&token_file, format!("{}\n", farm.client_token)).unwrap();
        let out = spindle(
            &[
                "status",
                &edited.to_string(),
                "--server",
                &format!("127.0.0.1:{}", farm.port),
                "--token-file",
                token_file.to_str().unwrap(),
            ],
            None,
        )
        .await;
        assert!(out.status.success(), "{}", text(&out));

        let exr = dir.path().join("fetched.exr");
        let out = spindle(
            &["fetch", &id.to_string(), "-o", exr.to_str().unwrap()],
            Some(&farm),
        )
        .await;
        assert!(out.status.success(), "{}", text(&out));
        let (desc, assets) = test_scene(24, 16, 1);
        let fetched = read_exr(&exr).unwrap();
        assert_bit_identical(&fetched, &reference_image(&desc, &assets).unwrap());
        // The farm writes the header `render --workers 0` writes (provenance included), all
        // but the scene file's path, which the coordinator never sees.
        let here = dir.path().join("here.exr");
        let out = spindle(
            &["render", s, "--workers", "0", "-o", here.to_str().unwrap()],
            None,
        )
        .await;
        assert!(out.status.success(), "{}", text(&out));
        let mut local = read_exr(&here).unwrap().attributes;
        assert!(local.remove("spindle.scene").is_some());
        assert!(
            local.contains_key("spindle.single_scatter.plan"),
            "{local:?}"
        );
        assert_eq!(fetched.attributes, local);

        // One byte of the stored image changed: the coordinator refuses to serve it and fetch
        // fails with its message, leaving no file.
        let stored = farm
            .dir
            .path()
            .join("data/jobs")
            .join(id.to_string())
            .join("image.exr");
        let mut bytes = std::fs::read(&stored).unwrap();
        let middle = bytes.len() / 2;
        bytes[middle] ^= 0x01;
        std::fs::write(&stored, &bytes).unwrap();
        let damaged = dir.path().join("damaged.exr");
        let out = spindle(
            &["fetch", &id.to_string(), "-o", damaged.to_str().unwrap()],
            Some(&farm),
        )
        .await;
        assert!(!out.status.success(), "{}", text(&out));
        assert!(
            text(&out).contains(&format!("the image of job {id} is damaged")),
            "{}",
            text(&out)
        );
        assert!(!damaged.exists());

        // A wrong token is refused with a clear message.
        let mut cmd = Command::new(binary("spindle"));
        cmd.args(["status"])
            .env("SPINDLE_SERVER", farm.base())
            .env("SPINDLE_TOKEN", "wrong");
        let out = cmd.output().unwrap();
        assert!(!out.status.success());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            stderr.contains("401")
                && stderr.contains("SPINDLE_TOKEN")
                && stderr.contains("--token-file"),
            "{}",
            text(&out)
        );
    })
    .await
    .expect("the test finished in time");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_job_requiring_a_label_is_rendered_only_by_the_labelled_worker() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), 32, 16, 1);
    let s = scene.to_str().unwrap();
    let mut farm = Farm::start(5.0).await.unwrap();
    farm.add_worker("day", 1).unwrap();
    farm.add_worker_with("night", 1, &["--label", "pool=night"])
        .unwrap();
    farm.wait_registered(0).await.unwrap();
    farm.wait_registered(1).await.unwrap();

    let out = spindle(&["workers", "--json"], Some(&farm)).await;
    assert!(out.status.success(), "{}", text(&out));
    let list: WorkerList = serde_json::from_slice(&out.stdout).unwrap();
    let night = list.workers.iter().find(|w| w.name == "night").unwrap();
    assert_eq!(night.labels.get("pool").map(String::as_str), Some("night"));
    assert!(list.workers.iter().all(|w| w.state != WorkerState::Lost));

    let out = spindle(
        &[
            "submit",
            s,
            "--require",
            "pool=night",
            "--tile-size",
            "8",
            "--wait",
        ],
        Some(&farm),
    )
    .await;
    assert!(out.status.success(), "{}\n{}", text(&out), farm.logs());
    let (day, night) = (
        accepted_tiles(&farm.workers[0].log()),
        accepted_tiles(&farm.workers[1].log()),
    );
    assert_eq!((day, night), (0, 8), "{}", farm.logs());

    let out = spindle(&["submit", s, "--require", "pool"], Some(&farm)).await;
    assert!(!out.status.success());
    assert!(text(&out).contains("expected key=value"), "{}", text(&out));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_drained_worker_finishes_its_tile_takes_no_more_and_exits_0() {
    let dir = tempfile::tempdir().unwrap();
    // 64 tiles of 64 px × 2000 samples: far more than the worker renders before the drain
    // reaches it.
    let scene = write_scene(dir.path(), 64, 64, 2000);
    let s = scene.to_str().unwrap();
    let mut farm = Farm::start(5.0).await.unwrap();
    farm.add_worker("leaving", 1).unwrap();
    farm.wait_registered(0).await.unwrap();
    let out = spindle(&["submit", s, "--tile-size", "8"], Some(&farm)).await;
    assert!(out.status.success(), "{}", text(&out));
    let id: u64 = String::from_utf8_lossy(&out.stdout).trim().parse().unwrap();

    // Drain it while it renders.
    let deadline = std::time::Instant::now() + Duration::from_secs(60);
    loop {
        let out = spindle(&["workers", "--json"], Some(&farm)).await;
        let list: WorkerList = serde_json::from_slice(&out.stdout).unwrap();
        if list.workers[0].state == WorkerState::Rendering {
            break;
        }
        assert!(std::time::Instant::now() < deadline, "{}", farm.logs());
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let out = spindle(&["workers", "drain", "leaving"], Some(&farm)).await;
    assert!(out.status.success(), "{}", text(&out));
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("draining"),
        "{}",
        text(&out)
    );

    let status = farm.workers[0]
        .wait_exit(Duration::from_secs(60))
        .await
        .unwrap();
    assert!(status.success(), "{status}\n{}", farm.logs());
    let log = farm.workers[0].log();
    assert!(log.contains("drained"), "{log}");
    // The tile in hand was delivered and counted; nothing was taken after it.
    let job = farm.job(id).await.unwrap();
    let delivered = accepted_tiles(&log) as u32;
    assert!(delivered >= 1, "{log}");
    assert_eq!(job.tiles_done, delivered, "{}", farm.logs());
    assert!(job.tiles_done < job.tiles_total, "{}", farm.logs());
    assert_eq!(job.recent_errors, vec![], "{}", farm.logs());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn jobs_are_named_listed_paused_reprioritised_fetched_by_name_and_deleted() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), 16, 16, 1);
    let s = scene.to_str().unwrap();
    let farm = Farm::start(5.0).await.unwrap();
    let id_of = |out: &Output| -> u64 {
        String::from_utf8_lossy(&out.stdout)
            .trim()
            .parse()
            .unwrap_or_else(|_| panic!("a job id: {}", text(out)))
    };

    // No worker: the job waits, and can be paused, resumed and reprioritised.
    let out = spindle(&["submit", s, "--submitter", "ann"], Some(&farm)).await;
    let first = id_of(&out);
    let out = spindle(&["pause", &first.to_string()], Some(&farm)).await;
    assert!(
        text(&out).contains(&format!("job {first}: paused")),
        "{}",
        text(&out)
    );
    let out = spindle(&["jobs", "--state", "paused"], Some(&farm)).await;
    let listing = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        listing.contains("scene") && listing.contains("ann"),
        "{}",
        text(&out)
    );
    let out = spindle(&["resume", &first.to_string()], Some(&farm)).await;
    assert!(text(&out).contains("queued"), "{}", text(&out));
    let out = spindle(&["priority", &first.to_string(), "-3"], Some(&farm)).await;
    assert!(text(&out).contains("priority -3"), "{}", text(&out));
    let out = spindle(&["delete", &first.to_string()], Some(&farm)).await;
    assert!(!out.status.success(), "an unfinished job needs --force");
    assert!(
        text(&out).contains(&format!("spindle delete {first} --force"))
            && !text(&out).contains("?force"),
        "{}",
        text(&out)
    );

    // With a worker: --wait -o downloads the image; fetch without -o writes <name>.exr here.
    let mut farm = farm;
    farm.add_worker("w", 2).unwrap();
    let waited = dir.path().join("waited.exr");
    let out = spindle(
        &[
            "submit",
            s,
            "--name",
            "teapot",
            "--tile-size",
            "8",
            "--wait",
            "-o",
            waited.to_str().unwrap(),
        ],
        Some(&farm),
    )
    .await;
    assert!(out.status.success(), "{}\n{}", text(&out), farm.logs());
    let id = String::from_utf8_lossy(&out.stdout)
        .lines()
        .next()
        .unwrap()
        .trim()
        .parse::<u64>()
        .unwrap();
    let (desc, assets) = test_scene(16, 16, 1);
    let reference = reference_image(&desc, &assets).unwrap();
    assert_bit_identical(&read_exr(&waited).unwrap(), &reference);
    let here = tempfile::tempdir().unwrap();
    let out = spindle_in(Some(here.path()), &["fetch", &id.to_string()], Some(&farm)).await;
    assert!(out.status.success(), "{}", text(&out));
    assert_bit_identical(
        &read_exr(here.path().join("teapot.exr")).unwrap(),
        &reference,
    );
    let out = spindle(&["jobs", "--name", "teap", "--json"], Some(&farm)).await;
    let listed: Vec<JobInfo> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(listed.iter().map(|j| j.id).collect::<Vec<_>>(), vec![id]);

    let out = spindle(&["delete", &id.to_string()], Some(&farm)).await;
    assert!(out.status.success(), "{}", text(&out));
    let out = spindle(&["delete", &first.to_string(), "--force"], Some(&farm)).await;
    assert!(out.status.success(), "{}", text(&out));
    let out = spindle(&["jobs", "--json"], Some(&farm)).await;
    let listed: Vec<JobInfo> = serde_json::from_slice(&out.stdout).unwrap();
    assert!(listed.is_empty(), "{}", text(&out));
}

/// With `$USER` unset, `spindle submit` names the account the system says runs it (`id -un`,
/// the ground truth), and `spindle jobs` lists the newest job first.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_submitter_is_the_account_name_when_user_is_unset_and_jobs_list_newest_first() {
    let id_un = match Command::new("id").arg("-un").output() {
        Ok(out) if out.status.success() => out,
        _ => {
            eprintln!("skipped: `id -un` does not name the account");
            return;
        }
    };
    let account = String::from_utf8_lossy(&id_un.stdout).trim().to_string();
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), 16, 16, 1);
    let s = scene.to_str().unwrap();
    let farm = Farm::start(5.0).await.unwrap();
    let submit = |name: &str| {
        let mut cmd = Command::new(binary("spindle"));
        cmd.args(["submit", s, "--name", name])
            .env_remove("USER")
            .env("SPINDLE_SERVER", farm.base())
            .env("SPINDLE_TOKEN", &farm.client_token);
        cmd.output().unwrap()
    };
    let first = submit("older");
    assert!(first.status.success(), "{}", text(&first));
    let second = submit("newer");
    assert!(second.status.success(), "{}", text(&second));

    let out = spindle(&["jobs", "--json"], Some(&farm)).await;
    let listed: Vec<JobInfo> = serde_json::from_slice(&out.stdout).unwrap();
    let names: Vec<&str> = listed.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(names, ["newer", "older"], "{}", text(&out));
    for job in &listed {
        assert_eq!(job.submitter.as_deref(), Some(account.as_str()));
    }
    let out = spindle(&["jobs", "--limit", "1", "--json"], Some(&farm)).await;
    let listed: Vec<JobInfo> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(listed.len(), 1);
    assert_eq!(listed[0].name, "newer");
}
