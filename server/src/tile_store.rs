//! Finished tiles on disk, one file per tile result, named by the result's content hash.
//!
//! `DATA/jobs/<job>/tiles/<index>-<hash>.tile` holds the [`TilePixels`] in the compact form of
//! [`tile_encoding`] (every f32 kept to the bit). Files are written to a temporary name,
//! synced, then renamed, and only then is the tile recorded as done in the database, so a
//! coordinator killed at any moment never records a tile it does not have. Naming by hash means
//! a slow, stale upload can never overwrite the file a newer, recorded result lives in.
//!
//! All functions here block; call them from `spawn_blocking`.

use std::path::{Path, PathBuf};

use anyhow::Context;
use spindle_common::atomic_write;
use spindle_common::protocol::pixel_hash;
use spindle_common::tile::TilePixels;
use spindle_common::tile_encoding;

/// The most bytes a stored tile may inflate to: a 256-pixel tile's four layers as MessagePack
/// f32s (5 bytes each) are under 4 MB; its statistics add little.
const MAX_DECODED_TILE_BYTES: usize = 8 << 20;

/// Why a recorded tile could not be read back.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ReadError {
    /// The file is missing, truncated or altered: the tile must be rendered again.
    #[error("{0}")]
    Damaged(String),
    /// Reading failed otherwise (I/O): it may pass.
    #[error("{0}")]
    Io(String),
}

/// Job directories under `DATA/jobs`.
#[derive(Debug, Clone)]
pub struct TileStore {
    root: PathBuf,
}

impl TileStore {
    /// A store rooted at `root` (created if missing).
    pub fn open(root: PathBuf) -> std::io::Result<TileStore> {
        std::fs::create_dir_all(&root)?;
        Ok(TileStore { root })
    }

    /// The directory of one job.
    pub fn job_dir(&self, job: u64) -> PathBuf {
        self.root.join(job.to_string())
    }

    /// Where the final EXR of a job goes.
    pub fn image_path(&self, job: u64) -> PathBuf {
        self.job_dir(job).join("image.exr")
    }

    fn tile_path(&self, job: u64, index: u32, hash: &str) -> PathBuf {
        self.job_dir(job)
            .join("tiles")
            .join(format!("{index}-{hash}.tile"))
    }

    /// Writes a tile result durably with [`atomic_write::write`].
    pub fn write(
        &self,
        job: u64,
        index: u32,
        hash: &str,
        pixels: &TilePixels,
    ) -> anyhow::Result<()> {
        let path = self.tile_path(job, index, hash);
        let bytes = tile_encoding::encode(pixels)?;
        let dir = path.parent().context("a tile path has a parent")?;
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        Ok(atomic_write::write(&path, &bytes)?)
    }

    /// Reads a recorded tile result back and checks it is the one recorded. Error messages
    /// name the tile, never a path (they may reach clients); the path is logged.
    pub fn read(&self, job: u64, index: u32, hash: &str) -> Result<TilePixels, ReadError> {
        let path = self.tile_path(job, index, hash);
        let damaged = |problem: String| {
            tracing::error!(job, tile = index, path = %path.display(), %problem, "stored tile damaged");
            ReadError::Damaged(format!("the stored result of tile {index} {problem}"))
        };
        let bytes = match std::fs::read(&path) {
            Ok(bytes) => bytes,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(damaged("is missing".into()));
            }
            Err(e) => {
                tracing::error!(job, tile = index, path = %path.display(), error = %e, "reading a stored tile failed");
                return Err(ReadError::Io(format!("reading tile {index}: {e}")));
            }
        };
        let pixels: TilePixels = tile_encoding::decode(&bytes, MAX_DECODED_TILE_BYTES)
            .map_err(|e| damaged(format!("does not parse ({e})")))?;
        if pixel_hash(&pixels) != hash {
            return Err(damaged("does not hash to the recorded result".into()));
        }
        Ok(pixels)
    }

    /// Removes a job's tile results (its image, if any, stays).
    pub fn remove_tiles(&self, job: u64) -> std::io::Result<()> {
        match std::fs::remove_dir_all(self.job_dir(job).join("tiles")) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e),
            _ => Ok(()),
        }
    }

    /// Removes a job's directory and everything in it.
    pub fn remove_job(&self, job: u64) -> std::io::Result<()> {
        match std::fs::remove_dir_all(self.job_dir(job)) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e),
            _ => Ok(()),
        }
    }
}

/// Makes a rename in `dir` durable.
pub fn sync_dir(dir: &Path) -> anyhow::Result<()> {
    atomic_write::sync_dir(dir).with_context(|| format!("syncing {}", dir.display()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use spindle_common::tile::TileRect;

    #[test]
    fn a_tile_round_trips_bit_for_bit_and_a_tampered_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let store = TileStore::open(dir.path().join("jobs")).unwrap();
        let rect = TileRect {
            x: 0,
            y: 0,
            width: 3,
            height: 2,
        };
        let mut pixels = TilePixels::black(rect);
        pixels.total[1] = 0.1;
        pixels.surface[2] = f32::from_bits(0x0000_0001);
        pixels.single_scatter[17] = 1e30;
        let hash = pixel_hash(&pixels);
        store.write(1, 4, &hash, &pixels).unwrap();
        assert_eq!(store.read(1, 4, &hash).unwrap(), pixels);

        let mut other = pixels.clone();
        other.total[0] = 2.0;
        let path = store.tile_path(1, 4, &hash);
        std::fs::write(&path, serde_json::to_vec(&other).unwrap()).unwrap();
        let damaged = |e: ReadError| match e {
            ReadError::Damaged(m) => {
                assert!(m.starts_with("the stored result of tile 4 "), "{m}");
                assert!(!m.contains(&*dir.path().to_string_lossy()), "no path: {m}");
            }
            other => panic!("expected Damaged, got {other:?}"),
        };
        damaged(store.read(1, 4, &hash).unwrap_err());
        std::fs::write(&path, b"{\"rect\":").unwrap();
        damaged(store.read(1, 4, &hash).unwrap_err());
        std::fs::remove_file(&path).unwrap();
        damaged(store.read(1, 4, &hash).unwrap_err());

        store.remove_job(1).unwrap();
        assert!(!store.job_dir(1).exists());
        store.remove_job(1).unwrap();
    }
}
