//! The coordinator's durable state in SQLite: jobs, workers, leased and finished tiles, and
//! tile failures.
//!
//! The database is the truth a restarted coordinator resumes from; the in-memory ledger
//! ([`crate::ledger::Ledger`]) mirrors it and every change is written here first. WAL with
//! `synchronous = NORMAL`: a commit survives the process being killed at any moment (it is in
//! the OS's page cache) without an fsync per tile. Schema changes are numbered migrations
//! applied in order and tracked with `PRAGMA user_version`.
//!
//! A `done` tile row holds the tile's accepted upload (common's compact tile form) beside the
//! content hash of its pixels, written in the same commit: a tile is recorded with its result
//! or not at all, with no file to create, sync and rename per tile. [`crate::tile_store`] reads
//! them back on its own connection, so assembling an image never holds the ledger.

use std::collections::BTreeMap;
use std::path::Path;

use rusqlite::{Connection, Transaction, params};
use spindle_common::noise::NoiseSums;
use spindle_common::protocol::{JobState, TileUpload};
use spindle_common::stats::RenderStats;

/// Migrations, in order; entry `i` moves the schema from version `i` to `i + 1`.
const MIGRATIONS: &[&str] = &[
    r#"
    CREATE TABLE jobs (
        id              INTEGER PRIMARY KEY AUTOINCREMENT,
        spec            TEXT    NOT NULL,   -- protocol::JobSpec as JSON
        priority        INTEGER NOT NULL,
        state           TEXT    NOT NULL,
        error           TEXT,
        idempotency_key TEXT    UNIQUE,
        request_hash    TEXT    NOT NULL,   -- blake3 of the canonical request, for key reuse
        created_ms      INTEGER NOT NULL,
        started_ms      INTEGER,
        finished_ms     INTEGER
    );
    CREATE TABLE workers (
        id            INTEGER PRIMARY KEY AUTOINCREMENT,
        name          TEXT    NOT NULL,
        threads       INTEGER NOT NULL,
        registered_ms INTEGER NOT NULL
    );
    -- A row exists once a tile has been leased; pending tiles without a row have epoch 0.
    CREATE TABLE tiles (
        job_id     INTEGER NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,
        tile_index INTEGER NOT NULL,
        state      TEXT    NOT NULL CHECK (state IN ('pending', 'leased', 'done')),
        epoch      INTEGER NOT NULL,
        worker_id  INTEGER,
        hash       TEXT,               -- protocol::pixel_hash, when done
        stats      TEXT,               -- RenderStats as JSON, when done
        PRIMARY KEY (job_id, tile_index)
    );
    CREATE TABLE tile_failures (
        job_id     INTEGER NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,
        tile_index INTEGER NOT NULL,
        worker_id  INTEGER NOT NULL,
        epoch      INTEGER NOT NULL,
        reason     TEXT    NOT NULL,
        PRIMARY KEY (job_id, tile_index, worker_id)
    );
"#,
    // When each failure was reported (0 for failures recorded before this column).
    "ALTER TABLE tile_failures ADD COLUMN at_ms INTEGER NOT NULL DEFAULT 0;",
    // Worker labels and job requirements (JSON objects), worker versions, draining workers.
    r#"
    ALTER TABLE jobs ADD COLUMN requires TEXT NOT NULL DEFAULT '{}';
    ALTER TABLE workers ADD COLUMN version TEXT NOT NULL DEFAULT '';
    ALTER TABLE workers ADD COLUMN labels TEXT NOT NULL DEFAULT '{}';
    ALTER TABLE workers ADD COLUMN draining INTEGER NOT NULL DEFAULT 0;
"#,
    // Job names ('' for jobs stored before: shown as job-<id>) and submitters.
    r#"
    ALTER TABLE jobs ADD COLUMN name TEXT NOT NULL DEFAULT '';
    ALTER TABLE jobs ADD COLUMN submitter TEXT;
"#,
    // A done job's tile count and summed statistics: its tile rows are deleted once its image
    // is written (NULL for jobs not done, or done before this column).
    r#"
    ALTER TABLE jobs ADD COLUMN tiles_done INTEGER;
    ALTER TABLE jobs ADD COLUMN stats TEXT;
"#,
    // The SHA-256 of a done job's EXR (hex), recorded when it was written; NULL before.
    "ALTER TABLE jobs ADD COLUMN image_sha256 TEXT;",
    // The SHA-256 of each worker's secret (32 bytes); NULL for workers registered before
    // secrets, which must register again.
    "ALTER TABLE workers ADD COLUMN secret_sha256 BLOB;",
    // A job's provenance (protocol's `Provenance` as JSON, from the first tile that carried
    // one), each done tile's render seconds as its worker reported them, and a done job's
    // `[index, worker id, render seconds]` per tile, kept when its tile rows are deleted.
    r#"
    ALTER TABLE jobs ADD COLUMN provenance TEXT;
    ALTER TABLE tiles ADD COLUMN render_seconds REAL;
    ALTER TABLE jobs ADD COLUMN tile_times TEXT;
"#,
    // Each done tile's noise sums (common's `NoiseSums` as JSON: Σ stderr², Σ total²), and a
    // done job's, kept when its tile rows are deleted; NULL for tiles and jobs done before.
    r#"
    ALTER TABLE tiles ADD COLUMN noise TEXT;
    ALTER TABLE jobs ADD COLUMN noise TEXT;
"#,
    // Each done tile's accepted upload (common's `TileUpload` in the compact tile form: the
    // pixels and the worker's report); NULL for tiles done before this column (their results
    // were files): such a tile reads as missing at assembly and is rendered again.
    "ALTER TABLE tiles ADD COLUMN upload BLOB;",
    // A budgeted job's passes (`passes::PassClock` as JSON: its pass, when it began, the time
    // spent paused, whether the last pass ended), written at submission and at every change;
    // NULL for a job without a budget, or stored before this column. And per done tile of such
    // a job, its pixels that would take more samples in another pass. A tile row not done
    // keeps the previous pass's result (`hash`, `upload`) until its current pass replaces it.
    r#"
    ALTER TABLE jobs ADD COLUMN passes TEXT;
    ALTER TABLE tiles ADD COLUMN sampling INTEGER;
"#,
];

/// Opens (creating if needed) the database at `path` and brings its schema up to date.
pub fn open(path: &Path) -> anyhow::Result<Connection> {
    let mut conn = Connection::open(path)?;
    conn.pragma_update(None, "journal_mode", "WAL")?;
    conn.pragma_update(None, "synchronous", "NORMAL")?;
    // Commits never copy the log into the database: `crate::checkpoint` does, off the ledger.
    conn.pragma_update(None, "wal_autocheckpoint", 0)?;
    conn.pragma_update(None, "foreign_keys", true)?;
    conn.busy_timeout(std::time::Duration::from_secs(5))?;
    migrate(&mut conn)?;
    Ok(conn)
}

/// What an error opening or loading the database at `path` means for the operator: a file
/// SQLite finds damaged (malformed, or not a database at all) is said to be so, with what to
/// do about it; any other error is returned as it is.
pub fn explain_damage(e: anyhow::Error, path: &Path) -> anyhow::Error {
    let damage = e
        .chain()
        .filter_map(|cause| cause.downcast_ref::<rusqlite::Error>())
        .find(|cause| {
            matches!(
                cause.sqlite_error_code(),
                Some(rusqlite::ErrorCode::DatabaseCorrupt | rusqlite::ErrorCode::NotADatabase)
            )
        });
    match damage {
        Some(cause) => anyhow::anyhow!(
            "the database {} is damaged: {cause}; restore it from a backup or move it away to \
             start empty",
            path.display()
        ),
        None => e,
    }
}

/// Before the database at `path` is opened: if the file is gone but its write-ahead log is
/// still there (the file deleted by hand, or lost), the log belongs to a database that no
/// longer exists and must not be replayed into a new one. It is moved aside to
/// `<log>.orphaned` (the log of an earlier such start is replaced) with a warning, and the
/// coordinator starts with an empty database.
pub fn set_aside_orphaned_log(path: &Path) -> anyhow::Result<()> {
    if path.exists() {
        return Ok(());
    }
    let beside = |suffix: &str| {
        let mut name = path.as_os_str().to_owned();
        name.push(suffix);
        std::path::PathBuf::from(name)
    };
    let (log, shared) = (beside("-wal"), beside("-shm"));
    if log.exists() {
        let aside = beside("-wal.orphaned");
        std::fs::rename(&log, &aside).map_err(|e| {
            anyhow::anyhow!(
                "moving the orphaned write-ahead log {} aside to {}: {e}",
                log.display(),
                aside.display()
            )
        })?;
        tracing::warn!(
            database = %path.display(),
            log = %aside.display(),
            "the database file is missing but its write-ahead log was there: starting with an \
             empty database; the log is kept aside (restore the database from a backup to get \
             its jobs back)"
        );
    }
    match std::fs::remove_file(&shared) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(anyhow::anyhow!(
            "removing the stale shared-memory file {}: {e}",
            shared.display()
        )),
        _ => Ok(()),
    }
}

fn migrate(conn: &mut Connection) -> anyhow::Result<()> {
    let version: usize = conn.pragma_query_value(None, "user_version", |r| r.get(0))?;
    if version > MIGRATIONS.len() {
        anyhow::bail!(
            "the database has schema version {version}, newer than this coordinator knows ({})",
            MIGRATIONS.len()
        );
    }
    for (i, sql) in MIGRATIONS.iter().enumerate().skip(version) {
        let tx = conn.transaction()?;
        tx.execute_batch(sql)?;
        tx.pragma_update(None, "user_version", i + 1)?;
        tx.commit()?;
    }
    Ok(())
}

/// A job row as stored.
#[derive(Debug, Clone)]
pub struct JobRow {
    pub id: u64,
    pub spec_json: String,
    pub priority: i32,
    pub state: JobState,
    pub error: Option<String>,
    pub idempotency_key: Option<String>,
    pub request_hash: String,
    /// The worker labels the job needs, a JSON object.
    pub requires_json: String,
    /// '' when the submission had none.
    pub name: String,
    pub submitter: Option<String>,
    pub created_ms: i64,
    pub started_ms: Option<i64>,
    pub finished_ms: Option<i64>,
    /// A done job's tile count and statistics, recorded when its tile rows were deleted.
    pub totals: Option<(u32, RenderStats)>,
    /// The SHA-256 of a done job's EXR, hex.
    pub image_sha256: Option<String>,
    /// The job's provenance as JSON, once a tile brought one.
    pub provenance_json: Option<String>,
    /// A budgeted job's passes as JSON (`passes::PassClock`).
    pub passes_json: Option<String>,
}

/// A tile row as stored.
#[derive(Debug, Clone, PartialEq)]
pub struct TileRow {
    pub state: TileRowState,
    pub epoch: u64,
    pub worker_id: Option<u64>,
    /// A done tile's render seconds as its worker reported them.
    pub render_seconds: Option<f64>,
}

/// Who rendered a done tile and how long it took, as a done job keeps it.
pub type TileTime = (u32, Option<u64>, Option<f64>);

/// The stored state of a tile that has been leased at least once.
#[derive(Debug, Clone, PartialEq)]
pub enum TileRowState {
    Pending,
    Leased,
    Done { hash: String, stats: RenderStats },
}

/// A recorded tile failure.
#[derive(Debug, Clone)]
pub struct FailureRow {
    pub tile_index: u32,
    pub worker_id: u64,
    /// The worker's registered name ("" if its row is gone).
    pub worker_name: String,
    pub reason: String,
    pub at_ms: i64,
}

/// Inserts a new job and returns its id.
pub fn insert_job(conn: &Connection, row: &JobRow) -> rusqlite::Result<u64> {
    conn.execute(
        "INSERT INTO jobs (spec, priority, state, error, idempotency_key, request_hash, created_ms,
                           requires, name, submitter, passes)
         VALUES (?1, ?2, ?3, NULL, ?4, ?5, ?6, ?7, ?8, ?9, ?10)",
        params![
            row.spec_json,
            row.priority,
            row.state.as_str(),
            row.idempotency_key,
            row.request_hash,
            row.created_ms,
            row.requires_json,
            row.name,
            row.submitter,
            row.passes_json
        ],
    )?;
    Ok(conn.last_insert_rowid() as u64)
}

/// Every job, oldest first.
pub fn load_jobs(conn: &Connection) -> anyhow::Result<Vec<JobRow>> {
    let mut stmt = conn.prepare(
        "SELECT id, spec, priority, state, error, idempotency_key, request_hash, created_ms,
                started_ms, finished_ms, requires, name, submitter, tiles_done, stats,
                image_sha256, provenance, passes
         FROM jobs ORDER BY id",
    )?;
    let rows = stmt.query_map([], |r| {
        Ok((
            JobRow {
                id: r.get::<_, i64>(0)? as u64,
                spec_json: r.get(1)?,
                priority: r.get(2)?,
                state: JobState::Queued,
                error: r.get(4)?,
                idempotency_key: r.get(5)?,
                request_hash: r.get(6)?,
                requires_json: r.get(10)?,
                name: r.get(11)?,
                submitter: r.get(12)?,
                created_ms: r.get(7)?,
                started_ms: r.get(8)?,
                finished_ms: r.get(9)?,
                totals: None,
                image_sha256: r.get(15)?,
                provenance_json: r.get(16)?,
                passes_json: r.get(17)?,
            },
            r.get::<_, String>(3)?,
            r.get::<_, Option<u32>>(13)?,
            r.get::<_, Option<String>>(14)?,
        ))
    })?;
    let mut jobs = Vec::new();
    for row in rows {
        let (mut job, state, tiles_done, stats) = row?;
        job.state = JobState::parse(&state)
            .ok_or_else(|| anyhow::anyhow!("job {}: unknown state {state:?}", job.id))?;
        if let (Some(done), Some(stats)) = (tiles_done, stats) {
            let stats = serde_json::from_str(&stats)
                .map_err(|e| anyhow::anyhow!("job {}: stored statistics: {e}", job.id))?;
            job.totals = Some((done, stats));
        }
        jobs.push(job);
    }
    Ok(jobs)
}

/// The stored tiles of a job, by index.
pub fn load_tiles(conn: &Connection, job: u64) -> anyhow::Result<BTreeMap<u32, TileRow>> {
    let mut stmt = conn.prepare(
        "SELECT tile_index, state, epoch, worker_id, hash, stats, render_seconds
         FROM tiles WHERE job_id = ?1",
    )?;
    let mut rows = stmt.query([job as i64])?;
    let mut tiles = BTreeMap::new();
    while let Some(r) = rows.next()? {
        let index: u32 = r.get(0)?;
        let state: String = r.get(1)?;
        let state = match state.as_str() {
            "pending" => TileRowState::Pending,
            "leased" => TileRowState::Leased,
            "done" => {
                let hash: Option<String> = r.get(4)?;
                let stats: Option<String> = r.get(5)?;
                let (Some(hash), Some(stats)) = (hash, stats) else {
                    anyhow::bail!("job {job} tile {index}: done without hash or stats");
                };
                TileRowState::Done {
                    hash,
                    stats: serde_json::from_str(&stats)?,
                }
            }
            other => anyhow::bail!("job {job} tile {index}: unknown state {other:?}"),
        };
        let row = TileRow {
            state,
            epoch: r.get::<_, i64>(2)? as u64,
            worker_id: r.get::<_, Option<i64>>(3)?.map(|w| w as u64),
            render_seconds: r.get(6)?,
        };
        tiles.insert(index, row);
    }
    Ok(tiles)
}

/// How many tiles of a job are done and their summed statistics, read row by row (nothing per
/// tile is kept).
pub fn tile_totals(conn: &Connection, job: u64) -> anyhow::Result<(u32, RenderStats)> {
    let mut stmt = conn.prepare("SELECT stats FROM tiles WHERE job_id = ?1 AND state = 'done'")?;
    let mut rows = stmt.query([job as i64])?;
    let (mut done, mut stats) = (0u32, RenderStats::default());
    while let Some(r) = rows.next()? {
        let s: Option<String> = r.get(0)?;
        let s = s.ok_or_else(|| anyhow::anyhow!("job {job}: a done tile without stats"))?;
        stats.add(&serde_json::from_str(&s)?);
        done += 1;
    }
    Ok((done, stats))
}

/// The finished tiles of a job as `(index, hash)`, in index order.
pub fn done_tiles(conn: &Connection, job: u64) -> rusqlite::Result<Vec<(u32, String)>> {
    let mut stmt = conn.prepare(
        "SELECT tile_index, hash FROM tiles WHERE job_id = ?1 AND state = 'done' \
         AND hash IS NOT NULL ORDER BY tile_index",
    )?;
    let rows = stmt.query_map([job as i64], |r| Ok((r.get(0)?, r.get(1)?)))?;
    rows.collect()
}

/// The recorded result hash of a finished tile.
pub fn done_hash(conn: &Connection, job: u64, index: u32) -> rusqlite::Result<Option<String>> {
    use rusqlite::OptionalExtension;
    conn.query_row(
        "SELECT hash FROM tiles WHERE job_id = ?1 AND tile_index = ?2 AND state = 'done'",
        params![job as i64, index],
        |r| r.get(0),
    )
    .optional()
    .map(Option::flatten)
}

/// Records a done job's totals, its tiles' workers and render times (and its image's
/// SHA-256, when just written) and deletes its tile rows: its image holds the pixels now.
pub fn settle_done_job(
    tx: &Transaction<'_>,
    job: u64,
    tiles_done: u32,
    stats: &RenderStats,
    image_sha256: Option<&str>,
) -> anyhow::Result<()> {
    let times: Vec<TileTime> = tx
        .prepare(
            "SELECT tile_index, worker_id, render_seconds FROM tiles
             WHERE job_id = ?1 AND state = 'done' ORDER BY tile_index",
        )?
        .query_map([job as i64], |r| {
            Ok((
                r.get(0)?,
                r.get::<_, Option<i64>>(1)?.map(|w| w as u64),
                r.get(2)?,
            ))
        })?
        .collect::<rusqlite::Result<_>>()?;
    let times = match times.is_empty() {
        true => None,
        false => Some(serde_json::to_string(&times)?),
    };
    tx.execute(
        "UPDATE jobs SET tiles_done = ?2, stats = ?3, image_sha256 = COALESCE(?4, image_sha256),
                         tile_times = COALESCE(?5, tile_times)
         WHERE id = ?1",
        params![
            job as i64,
            tiles_done,
            serde_json::to_string(stats)?,
            image_sha256,
            times
        ],
    )?;
    tx.execute("DELETE FROM tiles WHERE job_id = ?1", [job as i64])?;
    Ok(())
}

/// A done job's tiles' workers and render times, in index order (empty for a job done before
/// they were kept).
pub fn tile_times(conn: &Connection, job: u64) -> anyhow::Result<Vec<TileTime>> {
    let json: Option<String> = conn.query_row(
        "SELECT tile_times FROM jobs WHERE id = ?1",
        [job as i64],
        |r| r.get(0),
    )?;
    Ok(match json {
        Some(json) => serde_json::from_str(&json)?,
        None => Vec::new(),
    })
}

/// Records a job's provenance unless it has one already.
pub fn set_provenance(tx: &Transaction<'_>, job: u64, json: &str) -> rusqlite::Result<()> {
    tx.execute(
        "UPDATE jobs SET provenance = ?2 WHERE id = ?1 AND provenance IS NULL",
        params![job as i64, json],
    )?;
    Ok(())
}

/// The recorded failures of a job's tiles, oldest first.
pub fn load_failures(conn: &Connection, job: u64) -> anyhow::Result<Vec<FailureRow>> {
    let mut stmt = conn.prepare(
        "SELECT f.tile_index, f.worker_id, COALESCE(w.name, ''), f.reason, f.at_ms
         FROM tile_failures f LEFT JOIN workers w ON w.id = f.worker_id
         WHERE f.job_id = ?1 ORDER BY f.at_ms, f.tile_index, f.worker_id",
    )?;
    let rows = stmt.query_map([job as i64], |r| {
        Ok(FailureRow {
            tile_index: r.get(0)?,
            worker_id: r.get::<_, i64>(1)? as u64,
            worker_name: r.get(2)?,
            reason: r.get(3)?,
            at_ms: r.get(4)?,
        })
    })?;
    Ok(rows.collect::<Result<_, _>>()?)
}

/// A worker row as stored, with its counts of done tiles and failures.
#[derive(Debug, Clone)]
pub struct WorkerRow {
    pub id: u64,
    pub name: String,
    pub threads: u32,
    pub version: String,
    /// Its labels, a JSON object.
    pub labels_json: String,
    pub draining: bool,
    pub registered_ms: i64,
    pub tiles_done: u64,
    pub failures: u64,
    /// The SHA-256 of its secret; `None` if it registered before secrets existed.
    pub secret_sha256: Option<[u8; 32]>,
}

/// Every registered worker.
pub fn load_workers(conn: &Connection) -> rusqlite::Result<Vec<WorkerRow>> {
    let mut stmt = conn.prepare(
        "SELECT w.id, w.name, w.threads, w.version, w.labels, w.draining, w.registered_ms,
                (SELECT COUNT(*) FROM tiles t WHERE t.worker_id = w.id AND t.state = 'done'),
                (SELECT COUNT(*) FROM tile_failures f WHERE f.worker_id = w.id),
                w.secret_sha256
         FROM workers w",
    )?;
    let rows = stmt.query_map([], |r| {
        Ok(WorkerRow {
            id: r.get::<_, i64>(0)? as u64,
            name: r.get(1)?,
            threads: r.get(2)?,
            version: r.get(3)?,
            labels_json: r.get(4)?,
            draining: r.get(5)?,
            registered_ms: r.get(6)?,
            tiles_done: r.get::<_, i64>(7)? as u64,
            failures: r.get::<_, i64>(8)? as u64,
            secret_sha256: r.get(9)?,
        })
    })?;
    rows.collect()
}

/// Registers a worker and returns its id.
pub fn insert_worker(
    conn: &Connection,
    name: &str,
    threads: u32,
    version: &str,
    labels_json: &str,
    now_ms: i64,
) -> rusqlite::Result<u64> {
    conn.execute(
        "INSERT INTO workers (name, threads, registered_ms, version, labels)
         VALUES (?1, ?2, ?3, ?4, ?5)",
        params![name, threads, now_ms, version, labels_json],
    )?;
    Ok(conn.last_insert_rowid() as u64)
}

/// Stores the SHA-256 of a worker's secret.
pub fn set_worker_secret(
    conn: &Connection,
    worker: u64,
    sha256: &[u8; 32],
) -> rusqlite::Result<()> {
    conn.execute(
        "UPDATE workers SET secret_sha256 = ?2 WHERE id = ?1",
        params![worker as i64, &sha256[..]],
    )?;
    Ok(())
}

/// Marks a worker as draining.
pub fn set_worker_draining(conn: &Connection, worker: u64) -> rusqlite::Result<()> {
    conn.execute(
        "UPDATE workers SET draining = 1 WHERE id = ?1",
        [worker as i64],
    )?;
    Ok(())
}

/// The job an idempotency key created, with the hash of the request that created it.
#[cfg(test)]
pub fn job_for_key(conn: &Connection, key: &str) -> rusqlite::Result<Option<(u64, String)>> {
    use rusqlite::OptionalExtension;
    conn.query_row(
        "SELECT id, request_hash FROM jobs WHERE idempotency_key = ?1",
        [key],
        |r| Ok((r.get::<_, i64>(0)? as u64, r.get(1)?)),
    )
    .optional()
}

/// Records a job's state and times.
pub fn set_job_state(
    conn: &Connection,
    job: u64,
    state: JobState,
    error: Option<&str>,
    started_ms: Option<i64>,
    finished_ms: Option<i64>,
) -> rusqlite::Result<()> {
    conn.execute(
        "UPDATE jobs SET state = ?2, error = ?3, started_ms = ?4, finished_ms = ?5 WHERE id = ?1",
        params![job as i64, state.as_str(), error, started_ms, finished_ms],
    )?;
    Ok(())
}

/// Records a job's priority.
pub fn set_job_priority(conn: &Connection, job: u64, priority: i32) -> rusqlite::Result<()> {
    conn.execute(
        "UPDATE jobs SET priority = ?2 WHERE id = ?1",
        params![job as i64, priority],
    )?;
    Ok(())
}

/// Puts a job's unfinished tiles back in the queue and forgets its tile failures (a requeue);
/// done tiles are kept.
pub fn requeue_job(tx: &Transaction<'_>, job: u64) -> rusqlite::Result<()> {
    tx.execute("DELETE FROM tile_failures WHERE job_id = ?1", [job as i64])?;
    tx.execute(
        "UPDATE tiles SET state = 'pending' WHERE job_id = ?1 AND state != 'done'",
        [job as i64],
    )?;
    Ok(())
}

/// Records that `worker` holds tile `index` of `job` under `epoch`.
pub fn record_lease(
    conn: &Connection,
    job: u64,
    index: u32,
    epoch: u64,
    worker: u64,
) -> rusqlite::Result<()> {
    conn.prepare_cached(
        "INSERT INTO tiles (job_id, tile_index, state, epoch, worker_id) VALUES (?1, ?2, 'leased', ?3, ?4)
         ON CONFLICT (job_id, tile_index) DO UPDATE SET state = 'leased', epoch = ?3, worker_id = ?4",
    )?
    .execute(params![job as i64, index, epoch as i64, worker as i64])?;
    Ok(())
}

/// Records a finished tile: its upload (`stored`: `upload` in the compact tile form),
/// statistics and noise sums, and for a pass of a budgeted job its pixels still sampling.
pub fn record_done(
    tx: &Transaction<'_>,
    job: u64,
    index: u32,
    upload: &TileUpload,
    noise: &NoiseSums,
    stored: &[u8],
    sampling: Option<u32>,
) -> anyhow::Result<()> {
    tx.prepare_cached(
        "INSERT INTO tiles (job_id, tile_index, state, epoch, worker_id, hash, stats,
                            render_seconds, noise, upload, sampling)
         VALUES (?1, ?2, 'done', ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)
         ON CONFLICT (job_id, tile_index) DO UPDATE
           SET state = 'done', epoch = ?3, worker_id = ?4, hash = ?5, stats = ?6,
               render_seconds = ?7, noise = ?8, upload = ?9, sampling = ?10",
    )?
    .execute(params![
        job as i64,
        index,
        upload.epoch as i64,
        upload.worker_id as i64,
        upload.hash,
        serde_json::to_string(&upload.pixels.stats)?,
        upload.render_seconds,
        serde_json::to_string(noise)?,
        stored,
        sampling
    ])?;
    Ok(())
}

/// The stored upload of tile `index` of `job` (compact form), if it has a row holding one.
pub fn tile_upload(conn: &Connection, job: u64, index: u32) -> rusqlite::Result<Option<Vec<u8>>> {
    use rusqlite::OptionalExtension;
    let upload = conn
        .prepare_cached("SELECT upload FROM tiles WHERE job_id = ?1 AND tile_index = ?2")?
        .query_row(params![job as i64, index], |r| {
            r.get::<_, Option<Vec<u8>>>(0)
        })
        .optional()?;
    Ok(upload.flatten())
}

/// The noise sums of a job's done tiles added up (tiles done before they were recorded count
/// as nothing).
pub fn tile_noise_totals(conn: &Connection, job: u64) -> anyhow::Result<NoiseSums> {
    let mut stmt = conn.prepare(
        "SELECT noise FROM tiles WHERE job_id = ?1 AND state = 'done' AND noise IS NOT NULL",
    )?;
    let mut rows = stmt.query([job as i64])?;
    let mut sums = NoiseSums::default();
    while let Some(r) = rows.next()? {
        let json: String = r.get(0)?;
        sums.add(&serde_json::from_str(&json)?);
    }
    Ok(sums)
}

/// Records a done job's noise sums (before its tile rows are deleted).
pub fn set_job_noise(tx: &Transaction<'_>, job: u64, noise: &NoiseSums) -> anyhow::Result<()> {
    tx.execute(
        "UPDATE jobs SET noise = ?2 WHERE id = ?1",
        params![job as i64, serde_json::to_string(noise)?],
    )?;
    Ok(())
}

/// A done job's recorded noise sums, if any.
pub fn job_noise(conn: &Connection, job: u64) -> anyhow::Result<Option<NoiseSums>> {
    let json: Option<String> =
        conn.query_row("SELECT noise FROM jobs WHERE id = ?1", [job as i64], |r| {
            r.get(0)
        })?;
    Ok(json.map(|j| serde_json::from_str(&j)).transpose()?)
}

/// Records that `worker` failed tile `index` of `job`, and returns the tile to the queue.
pub fn record_failure(
    tx: &Transaction<'_>,
    job: u64,
    index: u32,
    epoch: u64,
    worker: u64,
    reason: &str,
    at_ms: i64,
) -> rusqlite::Result<()> {
    tx.execute(
        "INSERT OR REPLACE INTO tile_failures (job_id, tile_index, worker_id, epoch, reason, at_ms)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
        params![
            job as i64,
            index,
            worker as i64,
            epoch as i64,
            reason,
            at_ms
        ],
    )?;
    tx.execute(
        "UPDATE tiles SET state = 'pending' WHERE job_id = ?1 AND tile_index = ?2",
        params![job as i64, index],
    )?;
    Ok(())
}

/// Returns a finished tile to the queue (its stored result was damaged); the epoch is kept, so
/// its next lease has a higher one.
pub fn requeue_tile(tx: &Transaction<'_>, job: u64, index: u32) -> rusqlite::Result<()> {
    tx.execute(
        "UPDATE tiles SET state = 'pending', hash = NULL, stats = NULL, render_seconds = NULL,
                         upload = NULL
         WHERE job_id = ?1 AND tile_index = ?2",
        params![job as i64, index],
    )?;
    Ok(())
}

/// Puts a done tile of a job with a time budget back in the queue for its next pass, keeping
/// its result (`hash`, `upload`): the next pass continues from it, and replaces it when done.
pub fn next_pass_tile(tx: &Transaction<'_>, job: u64, index: u32) -> rusqlite::Result<()> {
    tx.execute(
        "UPDATE tiles SET state = 'pending', stats = NULL, render_seconds = NULL, noise = NULL,
                         sampling = NULL
         WHERE job_id = ?1 AND tile_index = ?2",
        params![job as i64, index],
    )?;
    Ok(())
}

/// Records a budgeted job's passes (`passes::PassClock` as JSON).
pub fn set_passes(conn: &Connection, job: u64, json: &str) -> rusqlite::Result<()> {
    conn.execute(
        "UPDATE jobs SET passes = ?2 WHERE id = ?1",
        params![job as i64, json],
    )?;
    Ok(())
}

/// What a budgeted job's tile rows say about its current pass: per tile not done, the result
/// its pass continues from (the previous pass's, kept by [`next_pass_tile`]); per done tile,
/// its pixels still sampling. As `(index, previous hash, sampling)`, in index order.
pub type PassRow = (u32, Option<String>, Option<u32>);

/// The [`PassRow`]s of a job's stored tiles.
pub fn pass_rows(conn: &Connection, job: u64) -> rusqlite::Result<Vec<PassRow>> {
    let mut stmt = conn.prepare(
        "SELECT tile_index, CASE WHEN state = 'done' THEN NULL ELSE hash END,
                CASE WHEN state = 'done' THEN sampling ELSE NULL END
         FROM tiles WHERE job_id = ?1 ORDER BY tile_index",
    )?;
    let rows = stmt.query_map([job as i64], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))?;
    rows.collect()
}

/// The latest result of each tile of a job that has one, `(index, hash)` in index order: a
/// done tile's, or the previous pass's of a budgeted job's tile whose current pass is not in.
pub fn latest_results(conn: &Connection, job: u64) -> rusqlite::Result<Vec<(u32, String)>> {
    let mut stmt = conn.prepare(
        "SELECT tile_index, hash FROM tiles WHERE job_id = ?1 AND hash IS NOT NULL
         ORDER BY tile_index",
    )?;
    let rows = stmt.query_map([job as i64], |r| Ok((r.get(0)?, r.get(1)?)))?;
    rows.collect()
}

/// Forgets a worker (lost long ago); failures it reported keep its id, without a name.
pub fn delete_worker(conn: &Connection, worker: u64) -> rusqlite::Result<()> {
    conn.execute("DELETE FROM workers WHERE id = ?1", [worker as i64])?;
    Ok(())
}

/// Forgets a job and everything recorded about it.
pub fn delete_job(conn: &Connection, job: u64) -> rusqlite::Result<()> {
    conn.execute("DELETE FROM jobs WHERE id = ?1", [job as i64])?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn migrations_apply_once_and_tables_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("spindle.db");
        let conn = open(&path).unwrap();
        let row = JobRow {
            id: 0,
            spec_json: "{}".into(),
            priority: 3,
            state: JobState::Queued,
            error: None,
            idempotency_key: Some("k".into()),
            request_hash: "h".into(),
            requires_json: "{}".into(),
            name: "n".into(),
            submitter: None,
            created_ms: 5,
            started_ms: None,
            finished_ms: None,
            totals: None,
            image_sha256: None,
            provenance_json: None,
            passes_json: None,
        };
        let id = insert_job(&conn, &row).unwrap();
        record_lease(&conn, id, 7, 1, 42).unwrap();
        drop(conn);

        // Reopening must not re-run the migration (it would fail on CREATE TABLE).
        let mut conn = open(&path).unwrap();
        let tx = conn.transaction().unwrap();
        let stats = RenderStats {
            samples: 9,
            ..RenderStats::default()
        };
        let mut pixels = spindle_common::tile::TilePixels::black(spindle_common::tile::TileRect {
            x: 0,
            y: 0,
            width: 1,
            height: 1,
        });
        pixels.stats = stats;
        let upload = TileUpload {
            worker_id: 43,
            epoch: 2,
            hash: "abc".into(),
            pixels,
            render_seconds: Some(0.25),
            provenance: None,
        };
        record_done(
            &tx,
            id,
            7,
            &upload,
            &NoiseSums::default(),
            b"stored upload",
            None,
        )
        .unwrap();
        tx.commit().unwrap();
        assert_eq!(
            tile_upload(&conn, id, 7).unwrap().as_deref(),
            Some(&b"stored upload"[..])
        );
        assert_eq!(tile_upload(&conn, id, 8).unwrap(), None, "no row");
        let tiles = load_tiles(&conn, id).unwrap();
        assert_eq!(tiles[&7].epoch, 2);
        assert_eq!(tiles[&7].worker_id, Some(43));
        assert_eq!(tiles[&7].render_seconds, Some(0.25));
        assert_eq!(
            tiles[&7].state,
            TileRowState::Done {
                hash: "abc".into(),
                stats
            }
        );
        assert_eq!(
            job_for_key(&conn, "k").unwrap(),
            Some((id, "h".to_string()))
        );
        let tx = conn.transaction().unwrap();
        set_provenance(&tx, id, "{\"a\":1}").unwrap();
        set_provenance(&tx, id, "{\"b\":2}").unwrap();
        tx.commit().unwrap();
        assert_eq!(
            load_jobs(&conn).unwrap()[0].provenance_json.as_deref(),
            Some("{\"a\":1}"),
            "the first provenance is kept"
        );

        // Settling a done job keeps who rendered each tile and how long it took.
        let tx = conn.transaction().unwrap();
        settle_done_job(&tx, id, 1, &stats, Some("digest")).unwrap();
        tx.commit().unwrap();
        assert!(load_tiles(&conn, id).unwrap().is_empty());
        assert_eq!(
            tile_times(&conn, id).unwrap(),
            vec![(7, Some(43), Some(0.25))]
        );

        record_lease(&conn, id, 8, 1, 42).unwrap();
        delete_job(&conn, id).unwrap();
        assert!(load_tiles(&conn, id).unwrap().is_empty(), "tiles cascade");
    }
}
