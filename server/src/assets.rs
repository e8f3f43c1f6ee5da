//! Content-addressed assets (mesh files): stored, checked and served by their blake3 hash.
//!
//! A client uploads each file once under its hash; scenes name files by path, and the job's
//! asset table maps each path to a hash. The coordinator stores bytes only under
//! `DATA/assets/<hash>` after checking the hash of what arrived, and never opens a path a
//! client gave it. Uploads stream to a temporary file (so a large mesh is never held in
//! memory), hashing as they go; a mismatch is a 400 and leaves nothing behind.
//!
//! An asset no job names is deleted by the sweep ([`crate::retention`]) once its file is older
//! than the grace period. Asking whether it is missing, uploading it again and admitting a job
//! that names it all renew the file's time ([`AssetStore::touch`]), so a client that uploads
//! first and submits next never sees its asset vanish in between.

use anyhow::Context;
use std::collections::{HashMap, HashSet};
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::{Duration, SystemTime};

use axum::body::Body;
use futures_util::TryStreamExt;
use spindle_common::protocol::is_hash;
use tokio::io::AsyncWriteExt;

use crate::error::Error;
use spindle_common::scene::Transform;
use spindle_common::validate::{check_obj_placement, count_obj_triangles, obj_radius};

/// The asset directory and a cache of what admission needs of each OBJ asset.
#[derive(Debug)]
pub struct AssetStore {
    dir: PathBuf,
    tmp: PathBuf,
    summaries: Mutex<HashMap<String, ObjSummary>>,
}

/// What admission needs of a stored OBJ asset, known from one linear scan of it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjSummary {
    /// Its triangles ([`count_obj_triangles`]; the file passed that function's checks).
    pub triangles: u64,
    /// The largest distance of a vertex from the file's origin ([`obj_radius`]).
    pub radius: f64,
}

impl AssetStore {
    /// Opens `dir` (creating it), discarding uploads a previous process left unfinished.
    pub fn open(dir: PathBuf) -> std::io::Result<AssetStore> {
        let tmp = dir.join("tmp");
        if tmp.exists() {
            std::fs::remove_dir_all(&tmp)?;
        }
        std::fs::create_dir_all(&tmp)?;
        Ok(AssetStore {
            dir,
            tmp,
            summaries: Mutex::new(HashMap::new()),
        })
    }

    /// The file of a well-formed hash.
    pub fn file(&self, hash: &str) -> Result<PathBuf, Error> {
        if !is_hash(hash) {
            return Err(Error::BadRequest(format!(
                "hash: {hash:?} is not a blake3 hash (64 lowercase hex digits)"
            )));
        }
        Ok(self.dir.join(hash))
    }

    /// Is the asset stored?
    pub fn has(&self, hash: &str) -> Result<bool, Error> {
        Ok(self.file(hash)?.is_file())
    }

    /// Renews the asset's time (against the sweep) if it is stored; returns whether it is.
    pub fn touch(&self, hash: &str) -> Result<bool, Error> {
        let path = self.file(hash)?;
        match std::fs::File::open(&path) {
            Ok(file) => {
                file.set_modified(std::time::SystemTime::now())?;
                Ok(true)
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(false),
            Err(e) => Err(e.into()),
        }
    }

    /// Deletes every stored asset not in `referenced` whose file is older than `grace`; returns
    /// how many. Run under the ledger's lock, so no job naming one can be stored meanwhile.
    pub fn remove_unreferenced(
        &self,
        referenced: &HashSet<String>,
        grace: Duration,
    ) -> std::io::Result<usize> {
        let now = SystemTime::now();
        let mut removed = 0;
        for entry in std::fs::read_dir(&self.dir)? {
            let entry = entry?;
            let Ok(name) = entry.file_name().into_string() else {
                continue;
            };
            if !is_hash(&name) || referenced.contains(&name) {
                continue;
            }
            let modified = entry.metadata()?.modified()?;
            if now.duration_since(modified).unwrap_or_default() < grace {
                continue;
            }
            match std::fs::remove_file(entry.path()) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(e),
                _ => {}
            }
            self.lock_cache().remove(&name);
            tracing::info!(hash = %name, "unreferenced asset deleted");
            removed += 1;
        }
        Ok(removed)
    }

    /// The asset's bytes.
    pub async fn read(&self, hash: &str) -> Result<Vec<u8>, Error> {
        let path = self.file(hash)?;
        match tokio::fs::read(&path).await {
            Ok(bytes) => Ok(bytes),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                Err(Error::NotFound(format!("asset {hash} is not stored")))
            }
            Err(e) => Err(e.into()),
        }
    }

    /// Streams `body` into the store under `hash`, checking the bytes' hash; returns their size.
    /// The body must already carry the route's size limit (`into_limited_body`).
    pub async fn store(&self, hash: &str, body: Body) -> Result<u64, Error> {
        let path = self.file(hash)?;
        let tmp = tempfile::Builder::new()
            .prefix(hash)
            .tempfile_in(&self.tmp)?
            .into_temp_path();
        let result = self.stream_to(&tmp, body).await;
        let (size, actual) = match result {
            Ok(v) => v,
            Err(e) => {
                let _ = tmp.close();
                return Err(e);
            }
        };
        if actual != hash {
            let _ = tmp.close();
            return Err(Error::BadRequest(format!(
                "body: the bytes hash to {actual}, not {hash}"
            )));
        }
        tmp.persist(&path).map_err(|e| Error::from(e.error))?;
        let dir = self.dir.clone();
        tokio::task::spawn_blocking(move || {
            spindle_common::atomic_write::sync_dir(&dir)
                .with_context(|| format!("syncing {}", dir.display()))
        })
        .await
        .map_err(anyhow::Error::from)??;
        Ok(size)
    }

    async fn stream_to(&self, tmp: &std::path::Path, body: Body) -> Result<(u64, String), Error> {
        let mut file = tokio::fs::File::create(tmp).await?;
        let mut hasher = blake3::Hasher::new();
        let mut size = 0u64;
        let mut stream = body.into_data_stream();
        loop {
            match stream.try_next().await {
                Ok(Some(chunk)) => {
                    size += chunk.len() as u64;
                    hasher.update(&chunk);
                    file.write_all(&chunk).await?;
                }
                Ok(None) => break,
                Err(e) => return Err(body_error(e)),
            }
        }
        file.flush().await?;
        file.sync_all().await?;
        Ok((size, hasher.finalize().to_hex().to_string()))
    }

    /// What admission needs of a stored OBJ asset (read once, then cached).
    pub async fn obj_summary(&self, hash: &str) -> Result<ObjSummary, Error> {
        if let Some(&summary) = self.lock_cache().get(hash) {
            return Ok(summary);
        }
        let path = self.file(hash)?;
        let summary = tokio::task::spawn_blocking(move || {
            std::fs::read(&path).map(|bytes| {
                count_obj_triangles(&bytes).map(|triangles| ObjSummary {
                    triangles,
                    radius: obj_radius(&bytes),
                })
            })
        })
        .await
        .map_err(anyhow::Error::from)?;
        let summary = self.read_result(hash, summary)?;
        self.lock_cache().insert(hash.to_string(), summary);
        Ok(summary)
    }

    /// Checks that `transform` keeps every vertex of a stored OBJ asset within the scene's
    /// extent, vertex by vertex ([`check_obj_placement`]; for the placements
    /// [`ObjSummary::radius`] does not settle).
    pub async fn check_obj_placement(&self, hash: &str, transform: Transform) -> Result<(), Error> {
        let path = self.file(hash)?;
        let checked = tokio::task::spawn_blocking(move || {
            std::fs::read(&path).map(|bytes| check_obj_placement(&bytes, &transform))
        })
        .await
        .map_err(anyhow::Error::from)?;
        self.read_result(hash, checked)
    }

    /// A check of an asset's bytes: its problem a 400, a missing file a 400 saying to upload it.
    fn read_result<T>(
        &self,
        hash: &str,
        read: std::io::Result<Result<T, String>>,
    ) -> Result<T, Error> {
        match read {
            Ok(Ok(value)) => Ok(value),
            Ok(Err(problem)) => Err(Error::BadRequest(problem)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err(Error::BadRequest(format!(
                "asset {hash} is not uploaded (PUT /v1/assets/{hash} first)"
            ))),
            Err(e) => Err(e.into()),
        }
    }

    fn lock_cache(&self) -> std::sync::MutexGuard<'_, HashMap<String, ObjSummary>> {
        // The cache holds plain numbers; a panic elsewhere cannot leave it inconsistent.
        self.summaries.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// Maps a failed request body to the client's error: over the size limit is 413.
pub fn body_error(e: axum::Error) -> Error {
    let mut source: Option<&(dyn std::error::Error + 'static)> = Some(&e);
    while let Some(s) = source {
        if s.is::<http_body_util::LengthLimitError>() {
            return Error::TooLarge("body: larger than this route accepts".into());
        }
        if s.is::<tower_http::timeout::TimeoutError>() {
            return Error::Timeout("body: not received in time".into());
        }
        source = s.source();
    }
    Error::BadRequest(format!("body: {e}"))
}
