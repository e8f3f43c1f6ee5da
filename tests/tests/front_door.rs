//! The real `spindle-server` under an open-file limit of 128 (`ulimit -n`), flooded with more
//! half-open connections than it has descriptors: it keeps its connection cap under the limit,
//! closes the silent connections at the header deadline, and `/healthz` still answers.

use std::process::Command;
use std::time::{Duration, Instant};

use spindle_tests::{Proc, binary, free_port};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

/// More connections than the 128 descriptors the server may open.
const FLOOD: usize = 200;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn healthz_answers_through_a_flood_of_half_open_connections_at_a_low_fd_limit() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_port();
    // `ulimit -n` sets the soft and hard limits of the shell, which `exec` hands on.
    let mut cmd = Command::new("sh");
    cmd.arg("-c")
        .arg("ulimit -n 128 && exec \"$0\" \"$@\"")
        .arg(binary("spindle-server"))
        .args(["--listen", &format!("127.0.0.1:{port}")])
        .arg("--data")
        .arg(dir.path().join("data"))
        .args(["--header-timeout-s", "0.3"]);
    let server = Proc::spawn(cmd, &[], dir.path(), "server").unwrap();
    let addr = format!("127.0.0.1:{port}");
    let deadline = Instant::now() + Duration::from_secs(30);
    while TcpStream::connect(&addr).await.is_err() {
        assert!(
            Instant::now() < deadline,
            "no server; log:\n{}",
            server.log()
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }

    // Half a request line each, then silence.
    let mut flood = Vec::new();
    for _ in 0..FLOOD {
        let mut stream = TcpStream::connect(&addr).await.unwrap();
        stream.write_all(b"GET /hea").await.unwrap();
        flood.push(stream);
    }
    let started = Instant::now();
    let mut health = TcpStream::connect(&addr).await.unwrap();
    health
        .write_all(b"GET /healthz HTTP/1.1\r\nhost: x\r\nconnection: close\r\n\r\n")
        .await
        .unwrap();
    let mut answer = String::new();
    let read =
        tokio::time::timeout(Duration::from_secs(10), health.read_to_string(&mut answer)).await;
    assert!(
        matches!(read, Ok(Ok(_))),
        "/healthz did not answer within 10 s; log:\n{}",
        server.log()
    );
    assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
    let log = server.log();
    assert!(
        log.contains("--max-connections lowered to fit the open-file limit"),
        "{log}"
    );
    assert!(!log.contains("Too many open files"), "{log}");
    eprintln!(
        "/healthz answered {:?} after {FLOOD} half-open connections",
        started.elapsed()
    );
}
