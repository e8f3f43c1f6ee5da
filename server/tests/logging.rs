//! Request ids and the JSON log format. The only test in this binary: `tracing` caches, per
//! call site and process-wide, whether anyone listens, so a test that installs its own
//! subscriber must not share the process with tests that log without one.

mod support;

use axum::http::{Method, StatusCode};
use serde_json::{Value, json};
use support::*;

/// Captured log output (`MakeWriter` for a test's own subscriber).
#[derive(Clone, Default)]
struct Captured(std::sync::Arc<std::sync::Mutex<Vec<u8>>>);

impl std::io::Write for Captured {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Every response carries `x-request-id` (the client's, or a new `r<n>`), and with the JSON
/// log format a line logged while serving a request is one JSON object naming that id, the
/// method and the path.
#[tokio::test]
async fn requests_have_ids_and_json_log_lines_name_them() {
    use axum::body::Body;
    use axum::http::Request;
    use spindle_server::logging::{LogFormat, subscriber};
    use tower::ServiceExt;

    let captured = Captured::default();
    let writer = captured.clone();
    let _guard =
        tracing::subscriber::set_default(subscriber(LogFormat::Json, move || writer.clone()));
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(16, 16), "tile_size": 8}))
        .await;

    let send = |id: Option<&str>| {
        let mut request = Request::builder()
            .method(Method::POST)
            .uri(format!("/v1/jobs/{}/pause", job.id))
            .header("authorization", format!("Bearer {CLIENT}"));
        if let Some(id) = id {
            request = request.header("x-request-id", id);
        }
        c.app.clone().oneshot(request.body(Body::empty()).unwrap())
    };
    let response = send(Some("abc-123")).await.unwrap();
    assert_eq!(response.status(), StatusCode::OK);
    assert_eq!(response.headers()["x-request-id"], "abc-123");
    let response = send(None).await.unwrap();
    let fresh = response.headers()["x-request-id"].to_str().unwrap();
    assert!(
        fresh.starts_with('r') && fresh[1..].parse::<u64>().is_ok(),
        "{fresh}"
    );

    let text = String::from_utf8(captured.0.lock().unwrap().clone()).unwrap();
    let paused: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON ({e}): {l}")))
        .filter(|v: &Value| v["fields"]["message"] == "job paused")
        .collect();
    assert_eq!(paused.len(), 1, "{text}");
    let span = &paused[0]["span"];
    assert_eq!(span["request_id"], "abc-123", "{text}");
    assert_eq!(span["method"], "POST");
    assert_eq!(span["path"], format!("/v1/jobs/{}/pause", job.id));
}
