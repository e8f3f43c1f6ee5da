//! Shared helpers of the coordinator's tests: a coordinator on a temporary data directory,
//! driven in process through `tower::ServiceExt::oneshot` (no socket), and fake tiles of
//! constant colour.
//!
//! Requests sent with the worker token carry the worker secret of the worker they name (the
//! id in a lease path, or the body's `worker_id`; else the worker registered last), as a
//! worker process would: [`Coordinator::send`] keeps every secret registration answered, per
//! data directory, so a coordinator reopened on the same directory (a restart) is sent the
//! secrets its workers were given before.
//! Tests of the secret itself use [`Coordinator::send_as`].

#![allow(dead_code)] // Each test file uses its own subset of the helpers.

use std::time::Duration;

use axum::Router;
use axum::body::{Body, Bytes};
use axum::http::{Method, Request, StatusCode};
use http_body_util::BodyExt;
use serde_json::{Value, json};
use spindle_common::passes::{PixelSums, TileProgress, pass_cap};
use spindle_common::protocol::{FarmEvent, JobInfo, Lease, TileUpload, pixel_hash};
use spindle_common::provenance::Provenance;
use spindle_common::stats::RenderStats;
use spindle_common::tile::{TilePixels, TileRect};
use spindle_server::{AppState, Config, app};
use tower::ServiceExt;

pub const CLIENT: &str = "client-secret";
pub const WORKER: &str = "worker-secret";

/// Worker id → secret, as registrations answered, and the id registered last.
pub type Secrets = (std::collections::HashMap<u64, String>, Option<u64>);

/// A coordinator and its data directory.
pub struct Coordinator {
    pub app: Router,
    pub state: AppState,
    pub config: Config,
    /// Worker id → secret, as registrations answered, and the id registered last.
    pub secrets: std::sync::Arc<std::sync::Mutex<Secrets>>,
}

pub fn config(dir: &std::path::Path) -> Config {
    let mut config = Config::new(dir);
    config.client_token = Some(CLIENT.into());
    config.worker_token = Some(WORKER.into());
    config
}

impl Coordinator {
    pub async fn open(config: Config) -> Coordinator {
        static BY_DIR: std::sync::Mutex<
            Option<
                std::collections::HashMap<
                    std::path::PathBuf,
                    std::sync::Arc<std::sync::Mutex<Secrets>>,
                >,
            >,
        > = std::sync::Mutex::new(None);
        let state = AppState::open(config.clone())
            .await
            .expect("coordinator opens");
        let secrets = BY_DIR
            .lock()
            .unwrap()
            .get_or_insert_with(Default::default)
            .entry(config.data_dir.clone())
            .or_default()
            .clone();
        Coordinator {
            app: app(state.clone()),
            state,
            config,
            secrets,
        }
    }

    /// Another handle on the same coordinator (for a spawned task).
    pub fn share(&self) -> Coordinator {
        Coordinator {
            app: self.app.clone(),
            state: self.state.clone(),
            config: self.config.clone(),
            secrets: self.secrets.clone(),
        }
    }

    /// Sends a request; `token` is the bearer token (if any); `body` is sent as is. With the
    /// worker token, the secret of the worker the request names goes along (see the module
    /// doc).
    pub async fn send(
        &self,
        method: Method,
        uri: &str,
        token: Option<&str>,
        body: impl Into<Body>,
    ) -> (StatusCode, Bytes) {
        let body: Bytes = axum::body::to_bytes(body.into(), usize::MAX).await.unwrap();
        let secret = if token == Some(WORKER) {
            self.secret_for(uri, &body)
        } else {
            None
        };
        let (status, bytes) = self
            .send_as(method.clone(), uri, token, secret.as_deref(), body)
            .await;
        if token == Some(WORKER)
            && method == Method::POST
            && uri == "/v1/workers"
            && status == StatusCode::OK
        {
            let v: Value = serde_json::from_slice(&bytes).unwrap();
            let id = v["worker_id"].as_u64().unwrap();
            let secret = v["worker_secret"].as_str().unwrap().to_string();
            let mut secrets = self.secrets.lock().unwrap();
            secrets.0.insert(id, secret);
            secrets.1 = Some(id);
        }
        (status, bytes)
    }

    /// Sends a request with exactly the bearer token and worker secret given.
    pub async fn send_as(
        &self,
        method: Method,
        uri: &str,
        token: Option<&str>,
        worker_secret: Option<&str>,
        body: impl Into<Body>,
    ) -> (StatusCode, Bytes) {
        let mut request = Request::builder().method(method).uri(uri);
        if let Some(token) = token {
            request = request.header("authorization", format!("Bearer {token}"));
        }
        if let Some(secret) = worker_secret {
            request = request.header("spindle-worker-secret", secret);
        }
        let response = self
            .app
            .clone()
            .oneshot(request.body(body.into()).unwrap())
            .await
            .unwrap();
        let status = response.status();
        let bytes = response.into_body().collect().await.unwrap().to_bytes();
        (status, bytes)
    }

    /// The secret of the worker a worker request names: the id of `/v1/workers/{id}/…`, or
    /// the body's `worker_id`, else the worker registered last.
    fn secret_for(&self, uri: &str, body: &[u8]) -> Option<String> {
        let from_path = uri
            .strip_prefix("/v1/workers/")
            .and_then(|rest| rest.split('/').next())
            .and_then(|id| id.parse::<u64>().ok());
        let from_body = serde_json::from_slice::<Value>(body)
            .ok()
            .and_then(|v| v["worker_id"].as_u64());
        let secrets = self.secrets.lock().unwrap();
        let id = from_path.or(from_body).or(secrets.1)?;
        secrets.0.get(&id).cloned()
    }

    /// The secret registration gave `worker`.
    pub fn secret(&self, worker: u64) -> String {
        self.secrets.lock().unwrap().0[&worker].clone()
    }

    pub async fn client(
        &self,
        method: Method,
        uri: &str,
        body: Option<Value>,
    ) -> (StatusCode, Value) {
        self.json(method, uri, CLIENT, body).await
    }

    pub async fn worker(
        &self,
        method: Method,
        uri: &str,
        body: Option<Value>,
    ) -> (StatusCode, Value) {
        self.json(method, uri, WORKER, body).await
    }

    async fn json(
        &self,
        method: Method,
        uri: &str,
        token: &str,
        body: Option<Value>,
    ) -> (StatusCode, Value) {
        let body = body.map(|b| b.to_string()).unwrap_or_default();
        let (status, bytes) = self.send(method, uri, Some(token), body).await;
        let value = if bytes.is_empty() {
            Value::Null
        } else {
            serde_json::from_slice(&bytes)
                .unwrap_or_else(|_| panic!("{uri}: not JSON: {}", String::from_utf8_lossy(&bytes)))
        };
        (status, value)
    }

    pub async fn submit(&self, body: Value) -> JobInfo {
        let (status, info) = self.client(Method::POST, "/v1/jobs", Some(body)).await;
        assert_eq!(status, StatusCode::CREATED, "{info}");
        serde_json::from_value(info).unwrap()
    }

    pub async fn job(&self, id: u64) -> JobInfo {
        let (status, info) = self
            .client(Method::GET, &format!("/v1/jobs/{id}"), None)
            .await;
        assert_eq!(status, StatusCode::OK, "{info}");
        serde_json::from_value(info).unwrap()
    }

    pub async fn register(&self, name: &str) -> u64 {
        let (status, v) = self
            .worker(
                Method::POST,
                "/v1/workers",
                Some(json!({"name": name, "threads": 2})),
            )
            .await;
        assert_eq!(status, StatusCode::OK, "{v}");
        v["worker_id"].as_u64().unwrap()
    }

    /// Asks for a lease without waiting; `None` on 204.
    pub async fn lease(&self, worker: u64) -> Option<Lease> {
        let (status, v) = self
            .worker(
                Method::POST,
                &format!("/v1/workers/{worker}/lease"),
                Some(json!({"wait_ms": 0})),
            )
            .await;
        match status {
            StatusCode::OK => Some(serde_json::from_value(v).unwrap()),
            StatusCode::NO_CONTENT => None,
            other => panic!("lease: {other} {v}"),
        }
    }

    /// Uploads a tile; returns the status and body.
    pub async fn upload(&self, job: u64, tile: u32, upload: &TileUpload) -> (StatusCode, Value) {
        self.worker(
            Method::PUT,
            &format!("/v1/jobs/{job}/tiles/{tile}"),
            Some(serde_json::to_value(upload).unwrap()),
        )
        .await
    }

    /// `PUT` of a tile body as given, with `content_type`, by the worker registered last.
    pub async fn upload_bytes(
        &self,
        job: u64,
        tile: u32,
        content_type: &str,
        body: Vec<u8>,
    ) -> (StatusCode, Value) {
        let uri = format!("/v1/jobs/{job}/tiles/{tile}");
        let secret = self.secret_for(&uri, b"");
        let mut request = Request::builder()
            .method(Method::PUT)
            .uri(&uri)
            .header("authorization", format!("Bearer {WORKER}"))
            .header("content-type", content_type);
        if let Some(secret) = secret {
            request = request.header("spindle-worker-secret", secret);
        }
        let response = self
            .app
            .clone()
            .oneshot(request.body(Body::from(body)).unwrap())
            .await
            .unwrap();
        let status = response.status();
        let bytes = response.into_body().collect().await.unwrap().to_bytes();
        (
            status,
            serde_json::from_slice(&bytes).unwrap_or(Value::Null),
        )
    }

    /// Waits (up to 30 s) until the job is finished.
    pub async fn wait_finished(&self, id: u64) -> JobInfo {
        for _ in 0..3000 {
            let info = self.job(id).await;
            if info.state.is_finished() {
                return info;
            }
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
        panic!("job {id} did not finish");
    }
}

/// How many tile rows (leased or done, with their pixels) the database under `data` holds
/// for `job`, read beside the running coordinator.
pub fn tile_rows(data: &std::path::Path, job: u64) -> i64 {
    let db = rusqlite::Connection::open(data.join("spindle.db")).unwrap();
    db.busy_timeout(std::time::Duration::from_secs(5)).unwrap();
    db.query_row(
        "SELECT COUNT(*) FROM tiles WHERE job_id = ?1",
        [job as i64],
        |r| r.get(0),
    )
    .unwrap()
}

/// The colour fake tile `index` is painted: distinct per tile and per layer.
pub fn tile_colour(index: u32, layer: usize, channel: usize) -> f32 {
    0.25 + index as f32 + 0.125 * layer as f32 + 0.03125 * channel as f32
}

/// A fake tile of constant colour per layer and channel, with one camera ray per pixel and one
/// sample in its statistics.
pub fn fake_tile(rect: TileRect, index: u32) -> TilePixels {
    let mut pixels = TilePixels::black(rect);
    for (layer, buffer) in [
        &mut pixels.total,
        &mut pixels.surface,
        &mut pixels.single_scatter,
        &mut pixels.multiple_scatter,
        &mut pixels.stderr,
        &mut pixels.alpha,
    ]
    .into_iter()
    .enumerate()
    {
        let channels = spindle_common::tile::LAYERS[layer].channels;
        for (i, v) in buffer.iter_mut().enumerate() {
            *v = tile_colour(index, layer, i % channels);
        }
    }
    pixels.stats = RenderStats {
        camera_rays: rect.pixel_count() as u64,
        samples: 1,
        ..RenderStats::default()
    };
    pixels
}

/// An EXR's image without its `renderTime`, the one header value that differs from run to
/// run: what two assemblies of the same tiles must agree on, pixels and header alike.
pub fn timeless(exr: &[u8]) -> spindle_common::image::Image {
    let mut image = spindle_common::image::Image::from_exr_bytes(exr).unwrap();
    assert!(
        image.standard.render_time.is_some(),
        "renderTime is written"
    );
    image.standard.render_time = None;
    image
}

/// The upload of a lease's fake tile.
pub fn upload_for(lease: &Lease, worker: u64) -> TileUpload {
    let pixels = fake_tile(lease.rect, lease.tile_index);
    TileUpload {
        worker_id: worker,
        epoch: lease.epoch,
        hash: pixel_hash(&pixels),
        pixels,
        render_seconds: Some(0.5),
        provenance: Some(test_provenance()),
    }
}

/// The provenance the fake workers of these tests report.
pub fn test_provenance() -> Provenance {
    Provenance::new(
        "spindle-render test",
        1,
        320,
        1,
        &[],
        &["objects[0]: interval (test)".into()],
    )
}

/// A small valid scene without assets: `width` × `height`, one sphere.
pub fn scene(width: u32, height: u32) -> Value {
    json!({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 40},
        "film": {"width": width, "height": height, "spp": 2, "seed": 7},
        "lights": [{"type": "point", "position": [0, 5, 0], "intensity": [10, 10, 10]}],
        "objects": [{
            "shape": {"type": "icosphere", "radius": 1, "subdivisions": 2},
            "material": {"type": "dielectric", "eta": 1.5,
                         "medium": {"sigma_t": [1, 1, 1], "albedo": [0.9, 0.9, 0.9]}}
        }]
    })
}

/// The upload of a lease's fake tile of a job with a time budget and `film.spp` = `spp`: the
/// lease's pass, every pixel at the pass's sample cap and still sampling.
pub fn pass_upload_for(lease: &Lease, worker: u64, spp: u32) -> TileUpload {
    let pass = lease
        .pass
        .expect("a lease of a budgeted job carries its pass");
    let cap = pass_cap(pass, spp);
    let mut pixels = fake_tile(lease.rect, lease.tile_index);
    let sums = PixelSums {
        taken: cap,
        ..PixelSums::default()
    };
    pixels.progress = Some(TileProgress {
        pass,
        spp: cap,
        pixels: vec![sums; lease.rect.pixel_count()],
    });
    TileUpload {
        worker_id: worker,
        epoch: lease.epoch,
        hash: pixel_hash(&pixels),
        pixels,
        render_seconds: Some(0.5),
        provenance: Some(test_provenance()),
    }
}

/// Opens the stream (with `Last-Event-ID` if given) and reads `n` events from it.
pub async fn read_events(
    c: &Coordinator,
    last_id: Option<u64>,
    n: usize,
) -> Vec<(String, FarmEvent)> {
    let mut request = Request::builder()
        .method(Method::GET)
        .uri("/v1/events")
        .header("authorization", format!("Bearer {CLIENT}"));
    if let Some(id) = last_id {
        request = request.header("last-event-id", id.to_string());
    }
    let response = c
        .app
        .clone()
        .oneshot(request.body(Body::empty()).unwrap())
        .await
        .unwrap();
    assert_eq!(response.status(), StatusCode::OK);
    assert_eq!(response.headers()["content-type"], "text/event-stream");
    let mut body = response.into_body();
    let mut text = String::new();
    let mut events = Vec::new();
    while events.len() < n {
        let frame = tokio::time::timeout(Duration::from_secs(5), body.frame())
            .await
            .expect("an event within 5 s")
            .expect("the stream goes on")
            .unwrap();
        if let Ok(data) = frame.into_data() {
            text.push_str(std::str::from_utf8(&data).unwrap());
        }
        while let Some(end) = text.find("\n\n") {
            let block: String = text.drain(..end + 2).collect();
            let field = |name: &str| {
                block
                    .lines()
                    .find_map(|l| l.strip_prefix(name).map(|v| v.trim().to_string()))
            };
            let (Some(kind), Some(id), Some(data)) =
                (field("event:"), field("id:"), field("data:"))
            else {
                continue; // a keep-alive comment
            };
            let event: FarmEvent = serde_json::from_str(&data).unwrap();
            assert_eq!(event.id.to_string(), id);
            events.push((kind, event));
        }
    }
    events
}
