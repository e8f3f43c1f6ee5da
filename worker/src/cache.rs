//! The worker's per-job scene cache: a job's scene and BVHs are built once and then render
//! every tile of that job the worker leases.
//!
//! Loading a job means fetching its spec, downloading each asset by its content hash,
//! checking that the bytes really hash to that name (a corrupted or substituted mesh must not
//! render silently), and building the renderer's scene on the worker's render pool (BVH
//! construction is parallel CPU work and stays off the async runtime). The build runs as
//! [`detached`](crate::detached) work: past the worker's build time limit, or once the lease is
//! lost, the worker walks away from it. Only a few jobs are kept: a farm works through jobs in
//! order, so the last couple are all that will be asked for.

use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;
use std::time::Duration;

use spindle_common::protocol::asset_hash;
use spindle_common::provenance::Provenance;
use tokio_util::sync::CancellationToken;

use crate::backoff::{Backoff, RetryEnd, retry};
use crate::client::{Client, ClientError, ErrorKind};
use crate::detached::{self, Ended, Slot};
use spindle_render::scene::{Assets, Scene};

/// A job's built scene and its provenance (sent with every tile of the job).
#[derive(Debug)]
pub struct BuiltJob {
    pub scene: Scene,
    pub provenance: Provenance,
}

/// Jobs whose scenes are kept.
const CAPACITY: usize = 2;
/// Downloads of one asset whose bytes do not match its hash before the tile is failed.
const HASH_ATTEMPTS: u32 = 3;

/// Why a job's scene could not be had.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The job cannot be rendered here (an asset missing or corrupted on the way): the tile
    /// should be reported as failed with this reason.
    #[error("{0}")]
    Broken(String),
    /// The scene does not build: no worker can render it, the job should fail at once.
    #[error("{0}")]
    Unbuildable(String),
    /// The build passed the worker's time limit and was given up: the tile should be reported
    /// as failed with this reason (another worker, or a later try, may be given more time).
    #[error("{0}")]
    OverLimit(String),
    /// The job is gone (deleted or cancelled) or the lease was lost: drop the tile quietly.
    #[error("the job is no longer available")]
    Gone,
    /// Gave up because the worker is shutting down or the lease was lost.
    #[error("interrupted")]
    Interrupted,
    /// The worker token was refused.
    #[error("{0}")]
    Unauthorized(ClientError),
}

impl From<RetryEnd> for LoadError {
    fn from(end: RetryEnd) -> Self {
        match end {
            RetryEnd::Stopped => LoadError::Interrupted,
            RetryEnd::Failed(e) => match e.kind() {
                ErrorKind::Unauthorized => LoadError::Unauthorized(e),
                ErrorKind::Transient | ErrorKind::NotFound | ErrorKind::Conflict => LoadError::Gone,
                ErrorKind::Rejected | ErrorKind::Draining => LoadError::Broken(e.to_string()),
            },
        }
    }
}

/// Built scenes of the most recent jobs, newest last.
pub struct SceneCache {
    client: Client,
    pool: Arc<rayon::ThreadPool>,
    backoff: Backoff,
    /// The longest a scene build may take.
    build_limit: Duration,
    entries: VecDeque<(u64, Arc<BuiltJob>)>,
    /// Number of scenes built (not served from the cache), for the log and tests.
    builds: u64,
}

impl SceneCache {
    pub fn new(
        client: Client,
        pool: Arc<rayon::ThreadPool>,
        backoff: Backoff,
        build_limit: Duration,
    ) -> SceneCache {
        SceneCache {
            client,
            pool,
            backoff,
            build_limit,
            entries: VecDeque::new(),
            builds: 0,
        }
    }

    /// How many scenes this cache has built so far.
    pub fn builds(&self) -> u64 {
        self.builds
    }

    /// The scene of `job_id`, built on first use, on a thread holding `slot`. Transient
    /// failures (coordinator away) are retried with backoff until `stop` is cancelled; `stop`
    /// also ends the wait for a build.
    pub async fn get(
        &mut self,
        job_id: u64,
        slot: &Slot,
        stop: &CancellationToken,
    ) -> Result<Arc<BuiltJob>, LoadError> {
        if let Some(i) = self.entries.iter().position(|(id, _)| *id == job_id) {
            // Move it to the back so the job in use is the last to be evicted.
            let entry = self.entries.remove(i).expect("index from position");
            let scene = entry.1.clone();
            self.entries.push_back(entry);
            return Ok(scene);
        }
        let scene = Arc::new(self.load(job_id, slot, stop).await?);
        self.builds += 1;
        if self.entries.len() == CAPACITY {
            self.entries.pop_front();
        }
        self.entries.push_back((job_id, scene.clone()));
        Ok(scene)
    }

    async fn load(
        &self,
        job_id: u64,
        slot: &Slot,
        stop: &CancellationToken,
    ) -> Result<BuiltJob, LoadError> {
        let spec = retry(self.backoff, job_id, stop, "fetching the job spec", || {
            self.client.job_spec(job_id)
        })
        .await
        .map_err(|end| match end {
            RetryEnd::Failed(e) if e.kind() == ErrorKind::NotFound => LoadError::Gone,
            end => LoadError::from(end),
        })?;
        let assets = self.download_assets(job_id, &spec.assets, stop).await?;
        // The still of the job's frame, by the one function every renderer of a frame calls.
        let desc = spec.still();
        let pool = self.pool.clone();
        let build = move |_: &detached::Interrupt| {
            pool.install(|| {
                let scene = Scene::build(&desc, &assets)?;
                let provenance = spindle_render::provenance(&scene);
                Ok(BuiltJob { scene, provenance })
            })
        };
        let limit = self.build_limit;
        match detached::run(slot, "scene-build", limit, stop, build).await {
            Ended::Done(built) => built.map_err(|e: spindle_render::SceneError| {
                LoadError::Unbuildable(format!("the scene does not build: {e}"))
            }),
            Ended::Broke(how) => Err(LoadError::Broken(format!("building the scene {how}"))),
            Ended::Stopped => Err(LoadError::Interrupted),
            Ended::OverLimit => Err(LoadError::OverLimit(format!(
                "building the scene took longer than this worker's limit of {} s \
                 (--build-time-limit-s) and was given up",
                limit.as_secs_f64()
            ))),
        }
    }

    /// Downloads each distinct asset once and checks its hash; returns them keyed by path.
    async fn download_assets(
        &self,
        job_id: u64,
        table: &BTreeMap<String, String>,
        stop: &CancellationToken,
    ) -> Result<Assets, LoadError> {
        let mut by_hash: BTreeMap<&str, Arc<Vec<u8>>> = BTreeMap::new();
        for hash in table.values() {
            if by_hash.contains_key(hash.as_str()) {
                continue;
            }
            let bytes = self.download_verified(job_id, hash, stop).await?;
            by_hash.insert(hash, Arc::new(bytes));
        }
        Ok(table
            .iter()
            .map(|(path, hash)| (path.clone(), by_hash[hash.as_str()].as_ref().clone()))
            .collect())
    }

    async fn download_verified(
        &self,
        job_id: u64,
        hash: &str,
        stop: &CancellationToken,
    ) -> Result<Vec<u8>, LoadError> {
        let mut got = String::new();
        for attempt in 1..=HASH_ATTEMPTS {
            let bytes = retry(self.backoff, job_id, stop, "downloading an asset", || {
                self.client.asset(hash)
            })
            .await
            .map_err(|end| match end {
                RetryEnd::Failed(e) if e.kind() == ErrorKind::NotFound => {
                    LoadError::Broken(format!("asset {hash} is missing on the coordinator"))
                }
                end => LoadError::from(end),
            })?;
            got = asset_hash(&bytes);
            if got == hash {
                return Ok(bytes);
            }
            tracing::warn!(job = job_id, %hash, %got, attempt, "asset bytes do not match their hash");
        }
        Err(LoadError::Broken(format!(
            "asset {hash}: the coordinator's bytes hash to {got} ({HASH_ATTEMPTS} downloads)"
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use spindle_common::protocol::JobSpec;
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    /// A minimal HTTP/1.1 coordinator on loopback that answers each request with `answer(path)`
    /// (status, body), one request per connection.
    async fn fake_coordinator(answer: fn(&str) -> (u16, Vec<u8>)) -> String {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let base = format!("http://{}", listener.local_addr().unwrap());
        tokio::spawn(async move {
            while let Ok((mut socket, _)) = listener.accept().await {
                tokio::spawn(async move {
                    let mut head = Vec::new();
                    let mut buf = [0u8; 1024];
                    while !head.windows(4).any(|w| w == b"\r\n\r\n") {
                        match socket.read(&mut buf).await {
                            Ok(0) | Err(_) => return,
                            Ok(n) => head.extend_from_slice(&buf[..n]),
                        }
                    }
                    let text = String::from_utf8_lossy(&head);
                    let path = text.split_whitespace().nth(1).unwrap_or("/").to_string();
                    let (status, body) = answer(&path);
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

    const MESH: &[u8] = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

    fn spec_with(hash: &str) -> Vec<u8> {
        let scene = serde_json::json!({
            "camera": { "position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 40 },
            "film": { "width": 4, "height": 4 },
            "objects": [{
                "shape": { "type": "obj", "path": "tri.obj" },
                "material": { "type": "diffuse", "reflectance": [0.5, 0.5, 0.5] }
            }]
        });
        let spec = JobSpec {
            scene: serde_json::from_value(scene).unwrap(),
            assets: BTreeMap::from([("tri.obj".to_string(), hash.to_string())]),
            tile_size: 4,
            crop: None,
            frame: None,
        };
        serde_json::to_vec(&spec).unwrap()
    }

    fn cache(base: &str) -> SceneCache {
        let pool = Arc::new(
            rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .unwrap(),
        );
        let backoff = Backoff {
            initial: std::time::Duration::from_millis(1),
            max: std::time::Duration::from_millis(5),
        };
        SceneCache::new(
            Client::new(base, None).unwrap(),
            pool,
            backoff,
            Duration::from_secs(60),
        )
    }

    async fn slot() -> Slot {
        detached::Gate::new().slot().await
    }

    #[tokio::test]
    async fn an_asset_whose_bytes_do_not_match_its_hash_fails_the_job() {
        let base = fake_coordinator(|path| {
            if path.starts_with("/v1/jobs/") {
                (200, spec_with(&asset_hash(MESH)))
            } else {
                // The right name, the wrong bytes.
                (200, b"v 9 9 9\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_vec())
            }
        })
        .await;
        let Err(err) = cache(&base)
            .get(1, &slot().await, &CancellationToken::new())
            .await
        else {
            panic!("a corrupted asset must not build");
        };
        match err {
            LoadError::Broken(reason) => {
                assert!(reason.contains(&asset_hash(MESH)), "{reason}");
                assert!(reason.contains("hash to"), "{reason}");
            }
            other => panic!("expected Broken, got {other:?}"),
        }
    }

    #[tokio::test]
    async fn a_verified_scene_is_built_once_and_served_from_the_cache() {
        let base = fake_coordinator(|path| {
            if path.starts_with("/v1/jobs/") {
                (200, spec_with(&asset_hash(MESH)))
            } else if path == format!("/v1/assets/{}", asset_hash(MESH)) {
                (200, MESH.to_vec())
            } else {
                (404, br#"{"error":"no such thing"}"#.to_vec())
            }
        })
        .await;
        let mut cache = cache(&base);
        let stop = CancellationToken::new();
        let slot = slot().await;
        let a = cache.get(1, &slot, &stop).await.expect("the scene builds");
        let b = cache
            .get(1, &slot, &stop)
            .await
            .expect("the scene is cached");
        assert!(Arc::ptr_eq(&a, &b));
        assert_eq!(cache.builds(), 1);
        assert_eq!(a.scene.triangle_count(), 1);
        assert_eq!(a.provenance, spindle_render::provenance(&a.scene));
    }

    #[tokio::test]
    async fn a_missing_job_is_gone_not_broken() {
        let base = fake_coordinator(|_| (404, br#"{"error":"no job 1"}"#.to_vec())).await;
        let err = cache(&base)
            .get(1, &slot().await, &CancellationToken::new())
            .await
            .err();
        assert!(matches!(err, Some(LoadError::Gone)), "{err:?}");
    }
}
