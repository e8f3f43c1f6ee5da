//! A worker gives up a scene build or a tile render past its time limit, and a render whose job
//! was cancelled, reports what it must and takes its next lease: measured on a real worker with
//! the real renderer against a scripted coordinator on loopback, which notes when each request
//! came. Run with `--nocapture` to see the figures.

use std::collections::{HashMap, VecDeque};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use spindle_common::protocol::{JobSpec, Lease, TileFailure};
use spindle_common::scene::SceneDescription;
use spindle_common::tile::TileRect;
use spindle_worker::Config;
use spindle_worker::backoff::Backoff;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_util::sync::CancellationToken;

/// What the scripted coordinator saw, with when.
#[derive(Debug, Clone)]
enum Seen {
    /// A lease of this job was handed out.
    Leased(u64),
    /// A heartbeat of this job was answered 409 (the job was cancelled).
    Refused(u64),
    Failed(u64, TileFailure),
    Uploaded(u64),
}

/// A coordinator that hands out the leases it was given, in order, serves their jobs' specs
/// and assets, answers heartbeats (409 once a job is cancelled) and notes everything.
#[derive(Default)]
struct Script {
    leases: Mutex<VecDeque<Lease>>,
    specs: Mutex<HashMap<u64, Vec<u8>>>,
    cancelled: Mutex<Vec<u64>>,
    seen: Mutex<Vec<(Instant, Seen)>>,
}

/// Heartbeats every 100 ms (a third of the TTL).
const TTL_MS: u64 = 300;

impl Script {
    /// Queues a lease of the whole film of `scene` as job `job`'s tile 0.
    fn lease(&self, job: u64, scene: serde_json::Value) {
        let (width, height) = (
            scene["film"]["width"].as_u64().unwrap() as u32,
            scene["film"]["height"].as_u64().unwrap() as u32,
        );
        let spec = JobSpec {
            scene: serde_json::from_value::<SceneDescription>(scene).unwrap(),
            assets: Default::default(),
            tile_size: width.max(height),
            crop: None,
            frame: None,
        };
        self.specs
            .lock()
            .unwrap()
            .insert(job, serde_json::to_vec(&spec).unwrap());
        self.leases.lock().unwrap().push_back(Lease {
            job_id: job,
            tile_index: 0,
            rect: TileRect {
                x: 0,
                y: 0,
                width,
                height,
            },
            epoch: 1,
            ttl_ms: TTL_MS,
            pass: None,
        });
    }

    fn cancel(&self, job: u64) {
        self.cancelled.lock().unwrap().push(job);
    }

    fn note(&self, seen: Seen) {
        self.seen.lock().unwrap().push((Instant::now(), seen));
    }

    fn seen(&self) -> Vec<(Instant, Seen)> {
        self.seen.lock().unwrap().clone()
    }

    /// The first time something `matching` was seen.
    fn when(&self, matching: impl Fn(&Seen) -> bool) -> Option<Instant> {
        self.seen()
            .into_iter()
            .find(|(_, s)| matching(s))
            .map(|(t, _)| t)
    }

    /// Waits up to `limit` for something `matching`.
    async fn wait_for(&self, limit: Duration, matching: impl Fn(&Seen) -> bool) -> Instant {
        let started = Instant::now();
        loop {
            if let Some(t) = self.when(&matching) {
                return t;
            }
            assert!(
                started.elapsed() < limit,
                "not seen within {limit:?}; seen: {:?}",
                self.seen()
            );
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    }

    /// Status and body of the answer to `method path` with `body`.
    async fn answer(&self, method: &str, path: &str, body: &[u8]) -> (u16, Vec<u8>) {
        let parts: Vec<&str> = path.trim_start_matches('/').split('/').collect();
        let job = |i: usize| parts.get(i).and_then(|p| p.parse::<u64>().ok());
        match (method, parts.as_slice()) {
            ("POST", ["v1", "workers"]) => (
                200,
                format!(
                    r#"{{"worker_id":1,"worker_secret":"1.{}"}}"#,
                    "0".repeat(64)
                )
                .into(),
            ),
            ("POST", ["v1", "workers", _, "lease"]) => {
                let lease = self.leases.lock().unwrap().pop_front();
                match lease {
                    Some(lease) => {
                        self.note(Seen::Leased(lease.job_id));
                        (200, serde_json::to_vec(&lease).unwrap())
                    }
                    None => {
                        tokio::time::sleep(Duration::from_millis(50)).await;
                        (204, Vec::new())
                    }
                }
            }
            ("GET", ["v1", "jobs", _, "spec"]) => {
                match self.specs.lock().unwrap().get(&job(2).unwrap()) {
                    Some(spec) => (200, spec.clone()),
                    None => (404, br#"{"error":"no such job"}"#.to_vec()),
                }
            }
            ("POST", ["v1", "leases", _, _, "heartbeat"]) => {
                let job = job(2).unwrap();
                if self.cancelled.lock().unwrap().contains(&job) {
                    self.note(Seen::Refused(job));
                    (409, br#"{"error":"the job was cancelled"}"#.to_vec())
                } else {
                    (200, format!(r#"{{"ttl_ms":{TTL_MS}}}"#).into())
                }
            }
            ("POST", ["v1", "leases", _, _, "fail"]) => {
                let failure: TileFailure = serde_json::from_slice(body).unwrap();
                self.note(Seen::Failed(job(2).unwrap(), failure));
                (200, b"{}".to_vec())
            }
            ("PUT", ["v1", "jobs", _, "tiles", _]) => {
                self.note(Seen::Uploaded(job(2).unwrap()));
                (200, br#"{"outcome":"accepted"}"#.to_vec())
            }
            _ => (404, br#"{"error":"not scripted"}"#.to_vec()),
        }
    }
}

/// Serves `script` on loopback, one request per connection; returns the base URL.
async fn serve(script: Arc<Script>) -> String {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let base = format!("http://{}", listener.local_addr().unwrap());
    tokio::spawn(async move {
        while let Ok((mut socket, _)) = listener.accept().await {
            let script = script.clone();
            tokio::spawn(async move {
                let mut request = Vec::new();
                let mut buf = [0u8; 8192];
                let head_end = loop {
                    if let Some(i) = request.windows(4).position(|w| w == b"\r\n\r\n") {
                        break i + 4;
                    }
                    match socket.read(&mut buf).await {
                        Ok(0) | Err(_) => return,
                        Ok(n) => request.extend_from_slice(&buf[..n]),
                    }
                };
                let head = String::from_utf8_lossy(&request[..head_end]).to_string();
                let length = head
                    .lines()
                    .filter_map(|l| l.split_once(':'))
                    .find(|(k, _)| k.eq_ignore_ascii_case("content-length"))
                    .and_then(|(_, v)| v.trim().parse::<usize>().ok())
                    .unwrap_or(0);
                while request.len() < head_end + length {
                    match socket.read(&mut buf).await {
                        Ok(0) | Err(_) => return,
                        Ok(n) => request.extend_from_slice(&buf[..n]),
                    }
                }
                let mut words = head.split_whitespace();
                let (method, path) = (words.next().unwrap_or(""), words.next().unwrap_or("/"));
                let (status, body) = script
                    .answer(method, path, &request[head_end..head_end + length])
                    .await;
                let reply = format!(
                    "HTTP/1.1 {status} X\r\ncontent-length: {}\r\ncontent-type: application/json\r\nconnection: close\r\n\r\n",
                    body.len()
                );
                let _ = socket.write_all(reply.as_bytes()).await;
                let _ = socket.write_all(&body).await;
            });
        }
    });
    base
}

/// The example caustic scene (a glass ellipsoid holding a scattering medium) on a `size` ×
/// `size` film zoomed onto the glass, at `spp` samples per pixel.
fn caustic(size: u32, spp: u32) -> serde_json::Value {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/caustic.json");
    let mut scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    scene["film"]["width"] = size.into();
    scene["film"]["height"] = size.into();
    scene["film"]["spp"] = spp.into();
    scene["camera"]["fov_y"] = 12.into();
    scene
}

/// A tile that takes many seconds on one thread (each band, one row, under a second).
fn slow_tile() -> serde_json::Value {
    caustic(16, SLOW_SPP)
}
const SLOW_SPP: u32 = 40;

/// A worker of one render thread for the coordinator at `base`, with the given limits.
fn worker(base: &str, build_limit_s: f64, tile_limit_s: f64) -> Config {
    let mut config = Config::new(base, None, Some("limits".into()), Some(1))
        .unwrap()
        .with_time_limits(build_limit_s, tile_limit_s)
        .unwrap();
    config.lease_wait = Duration::from_millis(200);
    config.backoff = Backoff {
        initial: Duration::from_millis(10),
        max: Duration::from_millis(50),
    };
    config.shutdown_grace = Duration::from_millis(500);
    config
}

/// Runs a worker with `config` until `body` returns, then stops it.
async fn with_worker(config: Config, body: impl Future<Output = ()>) {
    let shutdown = CancellationToken::new();
    let worker = tokio::spawn(spindle_worker::run(config, shutdown.clone()));
    body.await;
    shutdown.cancel();
    let summary = tokio::time::timeout(Duration::from_secs(10), worker)
        .await
        .expect("the worker stops")
        .unwrap()
        .unwrap();
    println!("worker summary: {summary:?}");
}

fn secs(d: Duration) -> String {
    format!("{:.3} s", d.as_secs_f64())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_tile_past_its_limit_is_reported_and_the_next_lease_taken() {
    let script = Arc::new(Script::default());
    script.lease(1, slow_tile());
    script.lease(2, caustic(8, 1));
    let base = serve(script.clone()).await;
    with_worker(worker(&base, 600.0, 1.0), async {
        let uploaded = script
            .wait_for(Duration::from_secs(30), |s| matches!(s, Seen::Uploaded(2)))
            .await;
        let leased = script.when(|s| matches!(s, Seen::Leased(1))).unwrap();
        let seen = script.seen();
        let (failed, failure) = seen
            .iter()
            .find_map(|(t, s)| match s {
                Seen::Failed(1, f) => Some((*t, f.clone())),
                _ => None,
            })
            .expect("the tile was reported as failed");
        let next = script.when(|s| matches!(s, Seen::Leased(2))).unwrap();
        println!(
            "tile limit 1 s: failure reported {} after the lease, next lease {} after it, \
             its tile uploaded {} after it; reason: {}",
            secs(failed - leased),
            secs(next - failed),
            secs(uploaded - failed),
            failure.reason
        );
        assert!(!failure.deterministic, "{failure:?}");
        assert!(
            failure.reason.contains("--tile-time-limit-s") && failure.reason.contains("1 s"),
            "{failure:?}"
        );
        assert!(
            failed - leased >= Duration::from_secs(1) && failed - leased < Duration::from_secs(3),
            "reported {:?} after the lease",
            failed - leased
        );
        assert!(
            next - failed < Duration::from_secs(1),
            "{:?}",
            next - failed
        );
    })
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cancelled_job_stops_its_render_and_the_next_lease_comes_at_once() {
    let script = Arc::new(Script::default());
    script.lease(1, slow_tile());
    script.lease(2, caustic(8, 1));
    let base = serve(script.clone()).await;
    with_worker(worker(&base, 600.0, 3600.0), async {
        let leased = script
            .wait_for(Duration::from_secs(10), |s| matches!(s, Seen::Leased(1)))
            .await;
        // Well into the render.
        tokio::time::sleep(Duration::from_millis(1500)).await;
        script.cancel(1);
        let uploaded = script
            .wait_for(Duration::from_secs(30), |s| matches!(s, Seen::Uploaded(2)))
            .await;
        let refused = script.when(|s| matches!(s, Seen::Refused(1))).unwrap();
        let next = script.when(|s| matches!(s, Seen::Leased(2))).unwrap();
        println!(
            "cancelled {} after the lease: heartbeat answered 409 {} later, next lease {} \
             after the 409, its tile uploaded {} after the 409",
            secs(Duration::from_millis(1500)),
            secs(refused - leased - Duration::from_millis(1500)),
            secs(next - refused),
            secs(uploaded - refused)
        );
        assert!(
            next - refused < Duration::from_secs(1),
            "{:?}",
            next - refused
        );
        let seen = script.seen();
        assert!(
            !seen
                .iter()
                .any(|(_, s)| matches!(s, Seen::Uploaded(1) | Seen::Failed(1, _))),
            "the cancelled tile was delivered or reported: {seen:?}"
        );
    })
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_build_past_its_limit_is_given_up_at_once() {
    // A scene whose build takes a while: a finely subdivided glass sphere.
    let mut scene = caustic(8, 1);
    scene["objects"][0]["shape"]["subdivisions"] = 6.into();
    let desc: SceneDescription = serde_json::from_value(scene.clone()).unwrap();
    let started = Instant::now();
    spindle_render::Scene::build(&desc, &Default::default()).unwrap();
    let build = started.elapsed();

    let script = Arc::new(Script::default());
    script.lease(1, scene);
    let base = serve(script.clone()).await;
    with_worker(worker(&base, 0.001, 3600.0), async {
        script
            .wait_for(Duration::from_secs(30), |s| matches!(s, Seen::Failed(1, _)))
            .await;
        let leased = script.when(|s| matches!(s, Seen::Leased(1))).unwrap();
        let seen = script.seen();
        let (failed, failure) = seen
            .iter()
            .find_map(|(t, s)| match s {
                Seen::Failed(1, f) => Some((*t, f.clone())),
                _ => None,
            })
            .expect("the tile was reported as failed");
        println!(
            "build limit 1 ms: the build alone takes {}; failure reported {} after the lease; \
             reason: {}",
            secs(build),
            secs(failed - leased),
            failure.reason
        );
        assert!(!failure.deterministic, "{failure:?}");
        assert!(
            failure.reason.contains("--build-time-limit-s") && failure.reason.contains("0.001 s"),
            "{failure:?}"
        );
        assert!(
            failed - leased < build,
            "{:?} ≥ the build's {build:?}",
            failed - leased
        );
        assert!(
            failed - leased < Duration::from_millis(500),
            "{:?}",
            failed - leased
        );
    })
    .await;
}
