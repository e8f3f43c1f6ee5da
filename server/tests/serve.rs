//! `run` on a real loopback socket: it serves, and a shutdown ends even a waiting long poll.

use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};

async fn http(addr: std::net::SocketAddr, request: &str) -> String {
    let mut stream = tokio::net::TcpStream::connect(addr).await.unwrap();
    stream.write_all(request.as_bytes()).await.unwrap();
    let mut response = String::new();
    stream.read_to_string(&mut response).await.unwrap();
    response
}

#[tokio::test]
async fn run_serves_until_shutdown_and_ends_long_polls() {
    let dir = tempfile::tempdir().unwrap();
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let config = spindle_server::Config::new(dir.path());
    let server = tokio::spawn(spindle_server::run(config, listener, async {
        let _ = stopped.await;
    }));

    let health = http(addr, "GET /healthz HTTP/1.0\r\n\r\n").await;
    assert!(
        health.starts_with("HTTP/1.0 200") && health.ends_with("ok"),
        "{health}"
    );
    let body = r#"{"name":"w","threads":1}"#;
    let register = http(
        addr,
        &format!(
            "POST /v1/workers HTTP/1.0\r\ncontent-length: {}\r\n\r\n{body}",
            body.len()
        ),
    )
    .await;
    assert!(register.contains("\"worker_id\":1"), "{register}");
    let secret = register
        .split("\"worker_secret\":\"")
        .nth(1)
        .and_then(|rest| rest.split('"').next())
        .expect("a worker secret");

    // A long poll with nothing to do, then a shutdown: the poll ends with 204 at once.
    let request =
        format!("POST /v1/workers/1/lease HTTP/1.0\r\nspindle-worker-secret: {secret}\r\n\r\n");
    let poll = tokio::spawn(async move { http(addr, &request).await });
    tokio::time::sleep(Duration::from_millis(200)).await;
    stop.send(()).unwrap();
    let answered = tokio::time::timeout(Duration::from_secs(10), poll)
        .await
        .expect("the long poll ends well before its 20 s")
        .unwrap();
    assert!(answered.starts_with("HTTP/1.0 204"), "{answered}");
    tokio::time::timeout(Duration::from_secs(10), server)
        .await
        .expect("the server stops")
        .unwrap()
        .unwrap();
}
