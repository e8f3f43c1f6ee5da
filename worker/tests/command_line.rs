//! The `spindle-worker` binary refuses bad settings before it contacts anyone: it exits non-zero
//! at once with a message that names the setting and the problem.
//!
//! Being the worker package's own integration test, this also makes `cargo test --workspace`
//! build the `spindle-worker` binary before any test runs (Cargo builds a package's binaries for
//! its integration tests only), which the end-to-end tests in `tests/` start.

use std::process::{Command, Output};

fn worker(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_spindle-worker"))
        .args(args)
        .env_clear()
        .output()
        .expect("starting spindle-worker")
}

#[test]
fn bad_settings_stop_the_worker_at_once_naming_the_setting() {
    let missing_token = std::env::temp_dir().join("spindle-worker-test-no-such-token-file");
    let missing_token = missing_token.to_str().expect("a UTF-8 temporary path");
    for (args, expected) in [
        (
            vec!["--coordinator", "ftp://127.0.0.1:7878"],
            "coordinator: scheme `ftp` is not supported",
        ),
        (
            vec!["--coordinator", "not a url"],
            "coordinator: `not a url` is not a URL",
        ),
        (
            vec!["--coordinator", "http://127.0.0.1:7878/?x=1"],
            "must not have a query or fragment",
        ),
        (
            vec!["--coordinator", "http://127.0.0.1:7878", "--threads", "0"],
            "threads: must be >= 1",
        ),
        (
            vec!["--coordinator", "http://127.0.0.1:7878", "--name", " "],
            "name: must not be empty",
        ),
        (
            vec![
                "--coordinator",
                "http://127.0.0.1:7878",
                "--tile-time-limit-s",
                "0",
            ],
            "tile-time-limit-s: 0 s is not a time limit",
        ),
        (
            vec![
                "--coordinator",
                "http://127.0.0.1:7878",
                "--token-file",
                missing_token,
            ],
            "reading the worker token from",
        ),
    ] {
        let out = worker(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} was accepted: {stderr}");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
    }
}

#[test]
fn the_coordinator_is_required() {
    let out = worker(&[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("--coordinator"), "{stderr}");
}
