//! The farm end to end: a real `spindle-server` and real `spindle-worker` processes on
//! loopback render a job whose image must be bit-identical to a single-process render of the
//! same scene, whatever happens to the processes along the way.

use std::time::Duration;

use spindle_tests::{
    Farm, accepted_tiles, assert_bit_identical, reference_image, scattering_test_scene, test_scene,
};

/// The longest any test here may take before it fails by itself.
const TEST_TIMEOUT: Duration = Duration::from_secs(150);

/// The image's estimated relative RMS error computed here from its layers, independently of
/// the coordinator's running sums: `sqrt(Σ stderr² / Σ total²)` over every pixel and channel.
fn noise_of(image: &spindle_common::image::Image) -> f64 {
    let (mut stderr_sq, mut total_sq) = (0.0f64, 0.0f64);
    for i in 0..image.total.len() {
        stderr_sq += f64::from(image.stderr[i]).powi(2);
        total_sq += f64::from(image.total[i]).powi(2);
    }
    (stderr_sq / total_sq).sqrt()
}

/// The job's `relative_error` is the one its EXR's layers give (to rounding: the sums add in
/// another order), and a real noise level (the 2–12 spp test renders are noisy, not converged).
fn check_noise(done: &spindle_common::protocol::JobInfo, image: &spindle_common::image::Image) {
    let expected = noise_of(image);
    let reported = done.relative_error.expect("a done job reports its noise");
    assert!(
        (reported - expected).abs() <= 1e-9 * expected,
        "reported {reported}, the EXR's layers give {expected}"
    );
    assert!(0.001 < expected && expected < 1.0, "{expected}");
}

/// Runs a test body with [`TEST_TIMEOUT`].
async fn bounded(body: impl Future<Output = anyhow::Result<()>>) {
    match tokio::time::timeout(TEST_TIMEOUT, body).await {
        Ok(result) => result.unwrap(),
        Err(_) => panic!("the test did not finish within {TEST_TIMEOUT:?}"),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_workers_render_a_job_bit_identical_to_one_process() {
    bounded(async {
        let (scene, assets) = scattering_test_scene(48, 32, 2);
        let reference = reference_image(&scene, &assets)?;
        // The single-scattering layer must carry light, or its bit identity proves nothing.
        assert!(reference.single_scatter.iter().any(|&v| v > 0.0));
        let farm = Farm::of_two_workers(5.0).await?;
        let job = farm.submit(&scene, &assets, 8).await?;
        let done = farm.wait_done(job.id, Duration::from_secs(120)).await?;
        let image = farm.image(job.id).await?;
        assert_bit_identical(&image, &reference);
        check_noise(&done, &image);

        // Every tile counted once: the coordinator's summed statistics hold exactly one camera
        // ray per pixel sample.
        assert_eq!(done.tiles_done, done.tiles_total);
        assert_eq!(done.tiles_total, 6 * 4);
        assert_eq!(done.stats.camera_rays, 48 * 32 * 2);

        // Both workers rendered tiles, as acknowledged by the coordinator.
        let (a, b) = (
            accepted_tiles(&farm.workers[0].log()),
            accepted_tiles(&farm.workers[1].log()),
        );
        assert!(
            a >= 1 && b >= 1,
            "tiles accepted per worker: {a} and {b}\n{}",
            farm.logs()
        );
        assert_eq!(a + b, done.tiles_total as usize, "{}", farm.logs());
        Ok(())
    })
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_worker_killed_mid_job_does_not_change_the_image() {
    bounded(async {
        let (scene, assets) = test_scene(48, 32, 12);
        let reference = reference_image(&scene, &assets)?;
        // A short lease, so the killed worker's tile goes back to the queue quickly.
        let mut farm = Farm::start(1.0).await?;
        farm.add_worker("doomed", 1)?;
        farm.add_worker("survivor", 1)?;
        farm.wait_registered(0).await?;
        let job = farm.submit(&scene, &assets, 4).await?;
        // Mid-job: the doomed worker has delivered a tile and the job is not finished.
        let deadline = std::time::Instant::now() + Duration::from_secs(60);
        while accepted_tiles(&farm.workers[0].log()) == 0 {
            assert!(
                std::time::Instant::now() < deadline,
                "no tile from the doomed worker\n{}",
                farm.logs()
            );
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
        farm.workers[0].kill();
        let at_kill = farm.job(job.id).await?;
        assert!(
            at_kill.tiles_done < at_kill.tiles_total,
            "the job finished before the worker was killed; make the scene slower\n{}",
            farm.logs()
        );

        let done = farm.wait_done(job.id, Duration::from_secs(120)).await?;
        assert_bit_identical(&farm.image(job.id).await?, &reference);
        assert_eq!(done.tiles_done, done.tiles_total);
        assert_eq!(done.stats.camera_rays, 48 * 32 * 12);
        assert!(accepted_tiles(&farm.workers[1].log()) >= 1);
        Ok(())
    })
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_coordinator_killed_and_restarted_mid_job_loses_and_doubles_nothing() {
    bounded(async {
        let (scene, assets) = test_scene(48, 32, 12);
        let reference = reference_image(&scene, &assets)?;
        let mut farm = Farm::start(2.0).await?;
        farm.add_worker("w1", 1)?;
        farm.add_worker("w2", 1)?;
        let job = farm.submit(&scene, &assets, 4).await?;
        let total = job.tiles_total;
        let before = farm
            .wait_job(job.id, Duration::from_secs(60), |j| {
                j.tiles_done >= total / 4
            })
            .await?;
        assert!(
            before.tiles_done < total,
            "the job finished before the coordinator was killed"
        );
        farm.kill_server();
        // Workers keep rendering and retrying while it is away.
        tokio::time::sleep(Duration::from_millis(700)).await;
        farm.start_server().await?;

        let done = farm.wait_done(job.id, Duration::from_secs(120)).await?;
        let image = farm.image(job.id).await?;
        assert_bit_identical(&image, &reference);
        // The noise of the tiles done before the restart is restored with them.
        assert!(before.relative_error.is_some(), "{before:?}");
        check_noise(&done, &image);
        assert_eq!(done.tiles_done, total);
        // No tile counted twice (nor lost): exactly one camera ray per pixel sample.
        assert_eq!(done.stats.camera_rays, 48 * 32 * 12, "{}", farm.logs());
        for w in &mut farm.workers {
            assert!(
                w.try_status().is_none(),
                "worker {} exited:\n{}",
                w.name,
                w.log()
            );
        }
        Ok(())
    })
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sigterm_mid_job_exits_cleanly_and_the_job_completes_elsewhere() {
    bounded(async {
        let (scene, assets) = test_scene(32, 24, 6);
        let reference = reference_image(&scene, &assets)?;
        let mut farm = Farm::start(1.0).await?;
        farm.add_worker("stopping", 1)?;
        farm.wait_registered(0).await?;
        let job = farm.submit(&scene, &assets, 4).await?;
        let deadline = std::time::Instant::now() + Duration::from_secs(60);
        while accepted_tiles(&farm.workers[0].log()) == 0 {
            assert!(
                std::time::Instant::now() < deadline,
                "no tile delivered\n{}",
                farm.logs()
            );
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
        farm.workers[0].terminate()?;
        let status = farm.workers[0].wait_exit(Duration::from_secs(40)).await?;
        assert!(status.success(), "exit status {status}\n{}", farm.logs());
        let log = farm.workers[0].log();
        assert!(log.contains("worker stopped"), "{log}");

        farm.add_worker("finisher", 1)?;
        farm.wait_done(job.id, Duration::from_secs(120)).await?;
        assert_bit_identical(&farm.image(job.id).await?, &reference);
        Ok(())
    })
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn heartbeats_keep_a_lease_alive_through_a_tile_longer_than_its_ttl() {
    bounded(async {
        // One 32×32 tile that takes several times the 0.3 s lease to render on one thread, and
        // well under the lease's greatest age, 20 TTLs = 6 s, on a loaded machine (1024 spp:
        // about 1.8 s on an idle core; 512 spp took 0.89 s on an idle CI machine). A second
        // worker waits for work: if the first one's lease lapsed during the render, the tile
        // would be leased to the second and the first one's upload refused.
        let (scene, assets) = test_scene(32, 32, 1024);
        let reference = reference_image(&scene, &assets)?;
        let mut farm = Farm::start(0.3).await?;
        farm.add_worker("renderer", 1)?;
        farm.wait_registered(0).await?;
        let job = farm.submit(&scene, &assets, 32).await?;
        assert_eq!(job.tiles_total, 1);
        // The tile is leased: now start the worker that would steal it.
        farm.wait_job(job.id, Duration::from_secs(30), |j| {
            j.state != spindle_common::protocol::JobState::Queued
        })
        .await?;
        farm.add_worker("thief", 1)?;
        let done = farm.wait_done(job.id, Duration::from_secs(120)).await?;
        assert_bit_identical(&farm.image(job.id).await?, &reference);
        assert!(
            done.elapsed_s > 0.9,
            "the tile took {:.2} s; it must outlast the 0.3 s lease several times for this \
             test to mean anything",
            done.elapsed_s
        );
        let (renderer, thief) = (farm.workers[0].log(), farm.workers[1].log());
        assert_eq!(accepted_tiles(&renderer), 1, "{}", farm.logs());
        assert_eq!(accepted_tiles(&thief), 0, "{}", farm.logs());
        assert!(!renderer.contains("lease lost"), "{}", farm.logs());
        Ok(())
    })
    .await;
}
