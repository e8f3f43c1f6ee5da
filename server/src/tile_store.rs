//! Finished tiles read back for assembly and previews, and the files of a job (its image).
//!
//! A tile's accepted upload ([`TileUpload`], its pixels with the worker's report) is stored in
//! its `done` row of the database in the compact form of [`tile_encoding`] (every f32 kept to
//! the bit; a compact upload's bytes as the worker sent them), by the same commit that records
//! the tile (see [`crate::db`]). This store reads them on a connection of its own, so reading a
//! whole job's tiles never holds the ledger, and checks each against the hash recorded with it. A job's
//! directory, `DATA/jobs/<job>/`, holds only its final `image.exr`.
//!
//! All functions here block; call them from `spawn_blocking`.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use anyhow::Context;
use rusqlite::Connection;
use spindle_common::protocol::{TileUpload, pixel_hash};
use spindle_common::tile::TilePixels;
use spindle_common::tile_encoding;

use crate::db;

/// What a stored upload may inflate to beyond the upload limit: an upload accepted as JSON is
/// stored re-encoded, where an f32 takes 5 bytes, and a 256-pixel tile's four layers take
/// under 4 MB of them.
const STORED_PIXELS_MARGIN: usize = 8 << 20;

/// Why a recorded tile could not be read back.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ReadError {
    /// The result is missing, truncated or altered: the tile must be rendered again.
    #[error("{0}")]
    Damaged(String),
    /// Reading failed otherwise (I/O, a busy database): it may pass.
    #[error("{0}")]
    Io(String),
}

/// Stored tile results and job directories.
#[derive(Debug, Clone)]
pub struct TileStore {
    /// `DATA/jobs`.
    root: PathBuf,
    /// A read-only connection to the coordinator's database (WAL: reading never blocks the
    /// ledger's commits, and sees every committed tile).
    reader: Arc<Mutex<Connection>>,
    /// The most bytes a stored upload may inflate to.
    max_decoded: usize,
}

impl TileStore {
    /// A store of job directories under `root` (created if missing), reading tiles from the
    /// database at `database`, which [`db::open`] has already brought up to date, whose uploads
    /// were accepted within `max_upload_bytes` (decoded).
    pub fn open(
        root: PathBuf,
        database: &Path,
        max_upload_bytes: usize,
    ) -> anyhow::Result<TileStore> {
        std::fs::create_dir_all(&root).with_context(|| format!("creating {}", root.display()))?;
        let reader = Connection::open(database)
            .with_context(|| format!("opening {} for reading tiles", database.display()))?;
        reader.pragma_update(None, "query_only", true)?;
        reader.busy_timeout(std::time::Duration::from_secs(5))?;
        Ok(TileStore {
            root,
            reader: Arc::new(Mutex::new(reader)),
            max_decoded: max_upload_bytes.saturating_add(STORED_PIXELS_MARGIN),
        })
    }

    /// The directory of one job.
    pub fn job_dir(&self, job: u64) -> PathBuf {
        self.root.join(job.to_string())
    }

    /// Where the final EXR of a job goes.
    pub fn image_path(&self, job: u64) -> PathBuf {
        self.job_dir(job).join("image.exr")
    }

    /// Reads a recorded tile result back and checks it is the one recorded (`hash`). Error
    /// messages name the tile, never the database (they may reach clients).
    pub fn read(&self, job: u64, index: u32, hash: &str) -> Result<TilePixels, ReadError> {
        let damaged = |problem: String| {
            tracing::error!(job, tile = index, %problem, "stored tile damaged");
            ReadError::Damaged(format!("the stored result of tile {index} {problem}"))
        };
        let stored = {
            let reader = self.reader.lock().unwrap_or_else(|e| e.into_inner());
            db::tile_upload(&reader, job, index)
        };
        let bytes = match stored {
            Ok(Some(bytes)) => bytes,
            Ok(None) => return Err(damaged("is missing".into())),
            Err(e) => {
                tracing::error!(job, tile = index, error = %e, "reading a stored tile failed");
                return Err(ReadError::Io(format!("reading tile {index}: {e}")));
            }
        };
        let upload: TileUpload = tile_encoding::decode(&bytes, self.max_decoded)
            .map_err(|e| damaged(format!("does not parse ({e})")))?;
        if pixel_hash(&upload.pixels) != hash {
            return Err(damaged("does not hash to the recorded result".into()));
        }
        Ok(upload.pixels)
    }

    /// Removes a job's directory and everything in it.
    pub fn remove_job(&self, job: u64) -> std::io::Result<()> {
        match std::fs::remove_dir_all(self.job_dir(job)) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e),
            _ => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rusqlite::params;
    use spindle_common::tile::TileRect;

    #[test]
    fn a_tile_round_trips_bit_for_bit_and_a_damaged_row_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let database = dir.path().join("spindle.db");
        let writer = db::open(&database).unwrap();
        let store = TileStore::open(dir.path().join("jobs"), &database, 1 << 20).unwrap();
        writer
            .execute(
                "INSERT INTO jobs (id, spec, priority, state, request_hash, created_ms)
                 VALUES (1, '{}', 0, 'running', 'h', 0)",
                [],
            )
            .unwrap();
        let store_row = |bytes: Option<&[u8]>| {
            writer
                .execute(
                    "INSERT INTO tiles (job_id, tile_index, state, epoch, upload)
                     VALUES (1, 4, 'done', 1, ?1)
                     ON CONFLICT (job_id, tile_index) DO UPDATE SET upload = ?1",
                    params![bytes],
                )
                .unwrap();
        };
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
        let upload = |pixels: &TilePixels| TileUpload {
            worker_id: 3,
            epoch: 1,
            hash: pixel_hash(pixels),
            pixels: pixels.clone(),
            render_seconds: None,
            provenance: None,
        };
        let encoded = tile_encoding::encode(&upload(&pixels)).unwrap();
        store_row(Some(&encoded));
        assert_eq!(store.read(1, 4, &hash).unwrap(), pixels);

        let damaged = |e: ReadError, problem: &str| match e {
            ReadError::Damaged(m) => {
                assert!(m.starts_with("the stored result of tile "), "{m}");
                assert!(m.ends_with(problem), "{m}");
            }
            other => panic!("expected Damaged, got {other:?}"),
        };
        let mut other = pixels.clone();
        other.total[0] = f32::from_bits(other.total[0].to_bits() ^ 1);
        store_row(Some(&tile_encoding::encode(&upload(&other)).unwrap()));
        damaged(
            store.read(1, 4, &hash).unwrap_err(),
            "does not hash to the recorded result",
        );
        store_row(Some(&encoded[..encoded.len() / 2]));
        let e = store.read(1, 4, &hash).unwrap_err();
        assert!(
            matches!(&e, ReadError::Damaged(m) if m.contains("does not parse")),
            "{e:?}"
        );
        store_row(None);
        damaged(store.read(1, 4, &hash).unwrap_err(), "is missing");
        damaged(store.read(1, 5, &hash).unwrap_err(), "is missing");

        std::fs::create_dir_all(store.job_dir(1)).unwrap();
        std::fs::write(store.image_path(1), b"exr").unwrap();
        store.remove_job(1).unwrap();
        assert!(!store.job_dir(1).exists());
        store.remove_job(1).unwrap();
    }
}
