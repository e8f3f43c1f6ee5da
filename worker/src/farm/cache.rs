//! The worker's per-job scene cache: a job's scene and BVHs are built once and then render
//! every tile of that job the worker leases.
//!
//! Loading a job means fetching its spec, downloading each asset by its content hash,
//! checking that the bytes really hash to that name (a corrupted or substituted mesh must not
//! render silently), and building the renderer's scene on the worker's render pool (BVH
//! construction is parallel CPU work and stays off the async runtime). Only a few jobs are
//! kept: a farm works through jobs in order, so the last couple are all that will be asked for.

use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;

use spindle_common::protocol::asset_hash;
use tokio_util::sync::CancellationToken;

use crate::farm::backoff::{Backoff, RetryEnd, retry};
use crate::farm::client::{Client, ClientError, ErrorKind};
use crate::render::scene::{Assets, Scene};

/// Jobs whose scenes are kept.
const CAPACITY: usize = 2;
/// Downloads of one asset whose bytes do not match its hash before the tile is failed.
const HASH_ATTEMPTS: u32 = 3;

/// Why a job's scene could not be had.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The job cannot be rendered by anyone (bad asset, scene that does not build): the tile
    /// should be reported as failed with this reason.
    #[error("{0}")]
    Broken(String),
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
                ErrorKind::Rejected => LoadError::Broken(e.to_string()),
            },
        }
    }
}

/// Built scenes of the most recent jobs, newest last.
pub struct SceneCache {
    client: Client,
    pool: Arc<rayon::ThreadPool>,
    backoff: Backoff,
    entries: VecDeque<(u64, Arc<Scene>)>,
    /// Number of scenes built (not served from the cache), for the log and tests.
    builds: u64,
}

impl SceneCache {
    pub fn new(client: Client, pool: Arc<rayon::ThreadPool>, backoff: Backoff) -> SceneCache {
        SceneCache {
            client,
            pool,
            backoff,
            entries: VecDeque::new(),
            builds: 0,
        }
    }

    /// How many scenes this cache has built so far.
    pub fn builds(&self) -> u64 {
        self.builds
    }

    /// The scene of `job_id`, built on first use. Transient failures (coordinator away) are
    /// retried with backoff until `stop` is cancelled.
    pub async fn get(
        &mut self,
        job_id: u64,
        stop: &CancellationToken,
    ) -> Result<Arc<Scene>, LoadError> {
        if let Some(i) = self.entries.iter().position(|(id, _)| *id == job_id) {
            // Move it to the back so the job in use is the last to be evicted.
            let entry = self.entries.remove(i).expect("index from position");
            let scene = entry.1.clone();
            self.entries.push_back(entry);
            return Ok(scene);
        }
        let scene = Arc::new(self.load(job_id, stop).await?);
        self.builds += 1;
        if self.entries.len() == CAPACITY {
            self.entries.pop_front();
        }
        self.entries.push_back((job_id, scene.clone()));
        Ok(scene)
    }

    async fn load(&self, job_id: u64, stop: &CancellationToken) -> Result<Scene, LoadError> {
        let spec = retry(self.backoff, job_id, stop, "fetching the job spec", || {
            self.client.job_spec(job_id)
        })
        .await
        .map_err(|end| match end {
            RetryEnd::Failed(e) if e.kind() == ErrorKind::NotFound => LoadError::Gone,
            end => LoadError::from(end),
        })?;
        let assets = self.download_assets(job_id, &spec.assets, stop).await?;
        let desc = spec.scene;
        let pool = self.pool.clone();
        let built =
            tokio::task::spawn_blocking(move || pool.install(|| Scene::build(&desc, &assets)))
                .await
                .map_err(|e| LoadError::Broken(format!("building the scene panicked: {e}")))?;
        built.map_err(|e| LoadError::Broken(format!("the scene does not build: {e}")))
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
