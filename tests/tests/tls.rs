//! The farm over HTTPS: a coordinator with a certificate of a throwaway CA (made here with
//! rcgen), a worker and the `spindle` command trusting that CA through `--ca-cert`. The image is
//! bit-identical to a single-process render, and a client that does not trust the CA is
//! refused with a message that names the certificate and the flag to fix it.

use std::process::Command;
use std::time::Duration;

use spindle_tests::{Farm, assert_bit_identical, binary, reference_image, test_scene};

/// The longest the test may take before it fails by itself.
const TEST_TIMEOUT: Duration = Duration::from_secs(150);

/// Runs `spindle ARGS` against the farm with the client token; returns (success, stderr).
fn spindle(farm: &Farm, args: &[&str]) -> (bool, String) {
    let out = Command::new(binary("spindle"))
        .args(args)
        .env_remove("SPINDLE_CA_CERT")
        .env("SPINDLE_SERVER", farm.base())
        .env("SPINDLE_TOKEN", &farm.client_token)
        // No system roots either: the refusal must not depend on the machine's CA store.
        .env("SSL_CERT_FILE", farm.dir.path().join("no-such-bundle.pem"))
        .env("SSL_CERT_DIR", farm.dir.path().join("no-such-dir"))
        .output()
        .expect("running spindle");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_job_over_https_matches_one_process_and_an_untrusting_client_is_refused() {
    tokio::time::timeout(TEST_TIMEOUT, async {
        let (scene, assets) = test_scene(32, 24, 2);
        let reference = reference_image(&scene, &assets).unwrap();
        let mut farm = Farm::start_with(5.0, true).await.unwrap();
        assert!(farm.base().starts_with("https://"));
        farm.add_worker("w1", 1).unwrap();
        farm.wait_registered(0).await.unwrap();
        let job = farm.submit(&scene, &assets, 16).await.unwrap();
        farm.wait_done(job.id, Duration::from_secs(120))
            .await
            .unwrap();
        assert_bit_identical(&farm.image(job.id).await.unwrap(), &reference);

        let ca = farm
            .tls
            .as_ref()
            .unwrap()
            .ca_cert
            .to_str()
            .unwrap()
            .to_string();
        let (ok, stderr) = spindle(&farm, &["status", "--ca-cert", &ca]);
        assert!(ok, "{stderr}");

        let (ok, stderr) = spindle(&farm, &["status"]);
        assert!(!ok, "a client without the CA was not refused");
        assert!(
            stderr.contains("certificate") && stderr.contains("--ca-cert"),
            "{stderr}"
        );
    })
    .await
    .expect("the test finished in time");
}
