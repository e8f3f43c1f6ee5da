//! The farm's time budget (`film.time_budget_s`): a real coordinator and two real workers render
//! a budgeted job in progressive passes, each tile's pass continuing from its previous pass's
//! result wherever that was rendered. The image must be, bit for bit, the single-process render
//! at the samples the job reached (`spindle render --workers 0 --no-time-budget --spp N`).

use std::time::Duration;

use spindle_common::image::{Image, read_exr};
use spindle_tests::{
    Farm, assert_bit_identical, output_text, reference_image, run_spindle, scattering_test_scene,
    write_scene_files,
};

/// The longest any test here may take before it fails by itself.
const TEST_TIMEOUT: Duration = Duration::from_secs(150);

async fn bounded(body: impl Future<Output = anyhow::Result<()>>) {
    match tokio::time::timeout(TEST_TIMEOUT, body).await {
        Ok(result) => result.unwrap(),
        Err(_) => panic!("the test did not finish within {TEST_TIMEOUT:?}"),
    }
}

/// A budget the job cannot spend: every pass runs, up to `spp` = 40 (passes of 16, 32, 40
/// samples, the last not a whole pass), and the image is the one-pass render at 40 spp. The
/// header and the job say 40 spp in 3 passes.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_budgeted_job_runs_its_passes_and_equals_the_one_pass_render() {
    bounded(async {
        let (mut scene, assets) = scattering_test_scene(24, 16, 40);
        scene["film"]["time_budget_s"] = serde_json::json!(3600);
        let farm = Farm::of_two_workers(5.0).await?;
        let job = farm.submit(&scene, &assets, 8).await?;
        let done = farm.wait_done(job.id, Duration::from_secs(120)).await?;
        let passes = done.passes.expect("a budgeted job reports its passes");
        assert_eq!((passes.pass, passes.spp), (3, 40), "{done:?}");
        assert_eq!(done.tiles_done, done.tiles_total);
        // Every camera sample counted once over the passes: the statistics are the one-pass
        // render's.
        assert_eq!(done.stats.camera_rays, 24 * 16 * 40);
        let image = farm.image(job.id).await?;
        // The header of `spindle render --workers 0` with the same budget.
        for (name, value) in [
            ("spindle.spp", "40"),
            ("spindle.passes", "3"),
            ("spindle.time_budget_s", "3600"),
        ] {
            assert_eq!(
                image.attributes.get(name).map(String::as_str),
                Some(value),
                "{name}"
            );
        }

        let mut reference_scene = scene.clone();
        reference_scene["film"]
            .as_object_mut()
            .unwrap()
            .remove("time_budget_s");
        let reference = reference_image(&reference_scene, &assets)?;
        assert!(reference.single_scatter.iter().any(|&v| v > 0.0));
        assert_bit_identical(&image, &reference);
        Ok(())
    })
    .await
}

/// A budget spent by the first pass: the job stops after it, at 16 of 64 spp, and its image is
/// the one-pass render at 16 spp.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_budget_spent_by_the_first_pass_ends_the_job_after_it() {
    bounded(async {
        let (mut scene, assets) = scattering_test_scene(24, 16, 64);
        scene["film"]["time_budget_s"] = serde_json::json!(0.001);
        let farm = Farm::of_two_workers(5.0).await?;
        let job = farm.submit(&scene, &assets, 8).await?;
        let done = farm.wait_done(job.id, Duration::from_secs(120)).await?;
        let passes = done.passes.expect("a budgeted job reports its passes");
        assert_eq!((passes.pass, passes.spp), (1, 16), "{done:?}");
        let image = farm.image(job.id).await?;
        assert_eq!(
            image.attributes.get("spindle.spp").map(String::as_str),
            Some("16")
        );

        let mut reference_scene = scene.clone();
        reference_scene["film"]["spp"] = serde_json::json!(16);
        reference_scene["film"]
            .as_object_mut()
            .unwrap()
            .remove("time_budget_s");
        assert_bit_identical(&image, &reference_image(&reference_scene, &assets)?);
        Ok(())
    })
    .await
}

/// The coordinator is killed mid pass 2 and started again on its data directory: the job goes
/// on from the pass it was in (`JobInfo.passes` never goes back, the tiles done in pass 2 stay
/// done) and its image is still, bit for bit, the one-pass render at the samples it reached.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_coordinator_killed_mid_pass_resumes_that_pass() {
    bounded(async {
        let (mut scene, assets) = scattering_test_scene(32, 24, 48);
        scene["film"]["time_budget_s"] = serde_json::json!(3600);
        let mut farm = Farm::of_two_workers(5.0).await?;
        let job = farm.submit(&scene, &assets, 8).await?;
        let total = job.tiles_total;
        let at_kill = farm
            .wait_job(job.id, Duration::from_secs(120), |j| {
                let pass = j.passes.map_or(0, |p| p.pass);
                pass > 2 || j.state.is_finished() || (pass == 2 && j.tiles_done >= 1)
            })
            .await?;
        farm.kill_server();
        let pass_at_kill = at_kill.passes.map(|p| p.pass);
        assert!(
            pass_at_kill == Some(2) && at_kill.tiles_done < total,
            "the kill was meant for the middle of pass 2: {at_kill:?}"
        );
        farm.start_server().await?;
        let mut seen = vec![(2, at_kill.tiles_done)];
        let done = loop {
            let info = farm.job(job.id).await?;
            let pass = info.passes.expect("a budgeted job reports its passes").pass;
            if pass == 2 {
                assert!(
                    info.tiles_done >= at_kill.tiles_done,
                    "tiles done in pass 2 before the kill stay done: {info:?}"
                );
            }
            seen.push((pass, info.tiles_done));
            if info.state.is_finished() {
                break info;
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        };
        assert!(
            seen.windows(2).all(|w| w[1].0 >= w[0].0),
            "the job's pass went back: {seen:?}"
        );
        assert_eq!(
            done.state,
            spindle_common::protocol::JobState::Done,
            "{:?}",
            done.error
        );
        let passes = done.passes.expect("a budgeted job reports its passes");
        assert_eq!((passes.pass, passes.spp), (3, 48), "{done:?}");
        let image = farm.image(job.id).await?;
        assert_eq!(
            image.attributes.get("spindle.spp").map(String::as_str),
            Some("48")
        );
        let mut reference_scene = scene.clone();
        reference_scene["film"]
            .as_object_mut()
            .unwrap()
            .remove("time_budget_s");
        assert_bit_identical(&image, &reference_image(&reference_scene, &assets)?);
        Ok(())
    })
    .await
}

/// A budget that is not a positive number of seconds up to a week is refused with the field
/// named, and so is a tile too large to carry its pixels' sums between passes.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_budgets_are_refused_naming_the_field() {
    bounded(async {
        let (scene, assets) = scattering_test_scene(24, 16, 64);
        let farm = Farm::start(5.0).await?;
        for bad in [
            serde_json::json!(-1.0),
            serde_json::json!(0.0),
            serde_json::json!(1e9),
        ] {
            let mut scene = scene.clone();
            scene["film"]["time_budget_s"] = bad.clone();
            let e = farm
                .submit(&scene, &assets, 8)
                .await
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("400") && e.contains("scene.film.time_budget_s"),
                "{bad}: {e}"
            );
        }
        let mut scene = scene.clone();
        scene["film"]["time_budget_s"] = serde_json::json!(60);
        let e = farm
            .submit(&scene, &assets, 256)
            .await
            .unwrap_err()
            .to_string();
        assert!(e.contains("400") && e.contains("tile_size"), "{e}");
        Ok(())
    })
    .await
}

/// `spindle render` through its local farm honours the budget too, and says what it reached:
/// its EXR has the pixels and `spindle.spp` of `--workers 0 --no-time-budget --spp N`, N the
/// samples it printed and wrote (`spindle.passes` beside them).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_local_farm_renders_a_budget_as_workers_0_renders_the_samples_it_reached() {
    bounded(async {
        let dir = tempfile::tempdir()?;
        let (mut scene, assets) = scattering_test_scene(20, 12, 40);
        scene["film"]["time_budget_s"] = serde_json::json!(3600);
        let scene_file = write_scene_files(dir.path(), &scene, &assets)?;
        let (farm_exr, local_exr) = (dir.path().join("farm.exr"), dir.path().join("local.exr"));
        let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
        let out = run_spindle(
            None,
            &[
                "render",
                &s(&scene_file),
                "--workers",
                "2",
                "--tile-size",
                "8",
                "-o",
                &s(&farm_exr),
            ],
            None,
            TEST_TIMEOUT,
        )
        .await;
        assert!(out.status.success(), "{}", output_text(&out));
        assert!(
            String::from_utf8_lossy(&out.stdout).contains(
                "40 of 40 spp in 3 passes; the same bits: --workers 0 --no-time-budget --spp 40"
            ),
            "{}",
            output_text(&out)
        );
        let out = run_spindle(
            None,
            &[
                "render",
                &s(&scene_file),
                "--workers",
                "0",
                "--no-time-budget",
                "--spp",
                "40",
                "-o",
                &s(&local_exr),
            ],
            None,
            TEST_TIMEOUT,
        )
        .await;
        assert!(out.status.success(), "{}", output_text(&out));
        let farm = read_exr(&farm_exr)?;
        let local = read_exr(&local_exr)?;
        assert_bit_identical(&farm, &local);
        assert_eq!(farm.stderr, local.stderr);
        let attribute = |image: &Image, name: &str| image.attributes.get(name).cloned();
        assert_eq!(attribute(&farm, "spindle.spp").as_deref(), Some("40"));
        assert_eq!(attribute(&farm, "spindle.passes").as_deref(), Some("3"));
        assert_eq!(
            attribute(&farm, "spindle.spp"),
            attribute(&local, "spindle.spp")
        );
        // The statistics summed over the passes are the one-pass render's.
        let stats = |image: &Image| {
            image
                .attributes
                .iter()
                .filter(|(k, _)| k.starts_with("spindle.stats."))
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect::<Vec<_>>()
        };
        assert!(!stats(&local).is_empty());
        assert_eq!(stats(&farm), stats(&local));
        Ok(())
    })
    .await
}
