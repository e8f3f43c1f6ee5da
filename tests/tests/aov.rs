//! The optional passes (`film.passes`) end to end: a farm of two real workers — one pass, and a
//! budgeted job whose tiles' passes continue from sums rendered elsewhere — writes, bit for bit,
//! the depth, normal, albedo and id of `spindle render --workers 0`, and its local farm too.

use std::time::Duration;

use spindle_common::aov::{Aov, AovSet};
use spindle_common::image::read_exr;
use spindle_tests::{
    Farm, assert_bit_identical, output_text, reference_image, run_spindle, scattering_test_scene,
    write_scene_files,
};

/// The longest any test here may take before it fails by itself.
const TEST_TIMEOUT: Duration = Duration::from_secs(200);

async fn bounded(body: impl Future<Output = anyhow::Result<()>>) {
    match tokio::time::timeout(TEST_TIMEOUT, body).await {
        Ok(result) => result.unwrap(),
        Err(_) => panic!("the test did not finish within {TEST_TIMEOUT:?}"),
    }
}

/// The test scene with every optional pass.
fn scene(spp: u32) -> (serde_json::Value, spindle_render::Assets) {
    let (mut scene, assets) = scattering_test_scene(20, 12, spp);
    scene["film"]["passes"] = serde_json::json!(["depth", "normal", "albedo", "id"]);
    (scene, assets)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_farm_writes_the_passes_of_workers_0_bit_for_bit() {
    bounded(async {
        let dir = tempfile::tempdir()?;
        let (scene, assets) = scene(3);
        let scene_file = write_scene_files(dir.path(), &scene, &assets)?;
        let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
        let (here, local) = (dir.path().join("here.exr"), dir.path().join("local.exr"));
        for (out, workers) in [(&here, "0"), (&local, "2")] {
            let run = run_spindle(
                None,
                &[
                    "render",
                    &s(&scene_file),
                    "--workers",
                    workers,
                    "--tile-size",
                    "8",
                    "-o",
                    &s(out),
                ],
                None,
                TEST_TIMEOUT,
            )
            .await;
            assert!(run.status.success(), "{}", output_text(&run));
        }
        let here = read_exr(&here)?;
        assert_eq!(here.passes, AovSet::of(&Aov::ALL));
        // Not trivially equal: objects and background both in view.
        let ids: std::collections::BTreeSet<u32> =
            here.aov.chunks(8).map(|p| p[7] as u32).collect();
        assert!(ids.len() >= 2, "ids {ids:?}");
        assert_bit_identical(&read_exr(&local)?, &here);
        assert_bit_identical(&reference_image(&scene, &assets)?, &here);

        let farm = Farm::of_two_workers(5.0).await?;
        let job = farm.submit(&scene, &assets, 8).await?;
        farm.wait_done(job.id, Duration::from_secs(120)).await?;
        assert_bit_identical(&farm.image(job.id).await?, &here);
        Ok(())
    })
    .await
}

/// A budgeted job: each tile's second and third passes start from sums (the passes' among them)
/// another worker may have rendered; the image is the one-pass render at 40 spp.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_budgeted_farm_job_carries_the_passes_sums_between_its_passes() {
    bounded(async {
        let (mut scene, assets) = scene(40);
        scene["film"]["time_budget_s"] = serde_json::json!(3600);
        let farm = Farm::of_two_workers(5.0).await?;
        let job = farm.submit(&scene, &assets, 8).await?;
        let done = farm.wait_done(job.id, Duration::from_secs(150)).await?;
        assert_eq!(done.passes.map(|p| (p.pass, p.spp)), Some((3, 40)));
        let mut reference_scene = scene.clone();
        reference_scene["film"]
            .as_object_mut()
            .unwrap()
            .remove("time_budget_s");
        let reference = reference_image(&reference_scene, &assets)?;
        assert_bit_identical(&farm.image(job.id).await?, &reference);
        Ok(())
    })
    .await
}
