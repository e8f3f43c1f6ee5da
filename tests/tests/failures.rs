//! Jobs that cannot finish end `failed` with the reason, quickly, on a farm of real processes:
//! never a silent loop, never a hang while workers wait.

use std::time::Duration;

use spindle_common::protocol::JobState;
use spindle_tests::{Farm, test_scene};

/// The longest any test here may take before it fails by itself.
const TEST_TIMEOUT: Duration = Duration::from_secs(60);

async fn bounded(body: impl Future<Output = anyhow::Result<()>>) {
    match tokio::time::timeout(TEST_TIMEOUT, body).await {
        Ok(result) => result.unwrap(),
        Err(_) => panic!("the test did not finish within {TEST_TIMEOUT:?}"),
    }
}

/// A light of 1e300 validates but renders +inf: the tile can never be uploaded. It used to be
/// dropped by the worker and leased again forever ("running 0/1").
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn pixels_beyond_f32_fail_the_job_with_the_reason_instead_of_looping() {
    bounded(async {
        let (mut scene, assets) = test_scene(16, 16, 1);
        scene["lights"][0]["intensity"] = serde_json::json!([1e300, 1e300, 1e300]);
        let farm = Farm::of_two_workers(1.0).await?;
        let job = farm.submit(&scene, &assets, 16).await?;
        let end = farm
            .wait_job(job.id, Duration::from_secs(30), |j| j.state.is_finished())
            .await?;
        assert_eq!(end.state, JobState::Failed, "{end:?}");
        let error = end.error.unwrap();
        // One worker's report is a claim; the second worker's confirms it.
        assert!(
            error.contains("overflows 32-bit floats") && error.contains("2 workers found so"),
            "{error}"
        );
        assert!(
            (2..=3).contains(&end.recent_errors.len()),
            "{:?}",
            end.recent_errors
        );
        for e in &end.recent_errors {
            assert!(["w1", "w2"].contains(&e.worker.as_str()), "{e:?}");
        }
        Ok(())
    })
    .await;
}

/// A sphere light across the glass sphere's surface: every value and the mesh file are
/// fine, so the coordinator (which builds no geometry) accepts the scene, but no worker can
/// build it (a light must lie wholly inside or wholly outside a dielectric).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_scene_no_worker_can_build_fails_at_once_with_the_reason() {
    bounded(async {
        let (mut scene, assets) = test_scene(16, 16, 1);
        scene["lights"][1]["center"] = serde_json::json!([1.0, 1.0, 0.0]);
        let farm = Farm::of_two_workers(5.0).await?;
        let job = farm.submit(&scene, &assets, 8).await?;
        let end = farm
            .wait_job(job.id, Duration::from_secs(30), |j| j.state.is_finished())
            .await?;
        assert_eq!(end.state, JobState::Failed, "{end:?}");
        let error = end.error.unwrap();
        // Confirmed by the second worker, or, when one worker has failed its share of the
        // tiles first (the build fails in microseconds), no worker left may take a failed tile.
        assert!(
            error.contains("the scene does not build")
                && (error.contains("2 workers found so")
                    || error.contains("no other connected worker may take it")),
            "{error}"
        );
        // At once: a failure is confirmed per tile, by a second worker, and a worker is never
        // given a tile it failed, so each of the 4 tiles fails at most once before some tile's
        // second report confirms it: 2 to 5 reports, whoever leases first.
        assert!(
            (2..=5).contains(&end.recent_errors.len()),
            "{:?}",
            end.recent_errors
        );
        for e in &end.recent_errors {
            assert!(e.message.contains("the scene does not build"), "{e:?}");
            assert!(e.message.contains("crosses the surface"), "{e:?}");
            assert!(["w1", "w2"].contains(&e.worker.as_str()), "{e:?}");
        }
        Ok(())
    })
    .await;
}
