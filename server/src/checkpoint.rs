//! Copying the database's write-ahead log back into the database, on a connection and a
//! thread of its own.
//!
//! In WAL mode every commit appends to the log. By default the commit that takes the log past
//! 1,000 pages also copies the log into the database and syncs the file — milliseconds on a
//! disk — and the ledger's commits run under the ledger's lock, so every request waiting for
//! the lock (a job's status, a lease) waited for that copy too. The ledger's connection
//! therefore never checkpoints ([`crate::db::open`] turns it off) and this task does, every
//! [`PERIOD`], with `PRAGMA wal_checkpoint(PASSIVE)`: a passive checkpoint waits for no reader
//! or writer, so commits go on while it copies. The log then stays about as long as one
//! period's commits.

use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::Context;
use rusqlite::Connection;

use crate::AppState;

/// How often the log is copied into the database.
pub const PERIOD: Duration = Duration::from_millis(250);

/// Starts checkpointing the database at `database` every [`PERIOD`] until shutdown (needs a
/// Tokio runtime).
pub(crate) fn spawn(state: AppState, database: &Path) -> anyhow::Result<()> {
    let conn = Connection::open(database)
        .with_context(|| format!("opening {} for checkpoints", database.display()))?;
    conn.busy_timeout(Duration::from_secs(5))?;
    let conn = Arc::new(Mutex::new(conn));
    tokio::spawn(async move {
        let mut tick = tokio::time::interval(PERIOD);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            tokio::select! {
                _ = tick.tick() => {}
                _ = state.shutdown_signal() => return,
            }
            let conn = conn.clone();
            let done = tokio::task::spawn_blocking(move || {
                let conn = conn.lock().unwrap_or_else(|e| e.into_inner());
                checkpoint(&conn)
            })
            .await;
            match done {
                Ok(Ok(())) => {}
                Ok(Err(e)) => {
                    tracing::warn!(error = %e, "checkpointing the database failed; trying again")
                }
                Err(e) => tracing::error!(error = %e, "the checkpoint task failed"),
            }
        }
    });
    Ok(())
}

/// Copies as much of the log into the database as no reader still needs.
pub fn checkpoint(conn: &Connection) -> rusqlite::Result<()> {
    conn.query_row("PRAGMA wal_checkpoint(PASSIVE)", [], |_| Ok(()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The size of the write-ahead log beside `database`, in bytes.
    fn wal_bytes(database: &Path) -> u64 {
        let mut wal = database.as_os_str().to_owned();
        wal.push("-wal");
        std::fs::metadata(wal).map(|m| m.len()).unwrap_or(0)
    }

    #[test]
    fn the_ledger_connection_leaves_the_log_to_the_checkpoint() {
        let dir = tempfile::tempdir().unwrap();
        let database = dir.path().join("spindle.db");
        let ledger = crate::db::open(&database).unwrap();
        let other = Connection::open(&database).unwrap();
        ledger.execute_batch("CREATE TABLE t (x BLOB);").unwrap();
        // 2,000 commits of a 4 KiB page each: past SQLite's 1,000-page automatic checkpoint.
        let write = |n: usize| {
            for _ in 0..n {
                ledger
                    .execute("INSERT INTO t VALUES (zeroblob(4000))", [])
                    .unwrap();
            }
        };
        write(2000);
        let grown = wal_bytes(&database);
        assert!(
            grown > 2000 * 4096,
            "the ledger's commits did not checkpoint: the log is {grown} bytes"
        );
        checkpoint(&other).unwrap();
        // The log is reused from its start once copied: as many commits again leave it about
        // as long (without the checkpoint it would double).
        write(2000);
        let after = wal_bytes(&database);
        assert!(
            after < grown + grown / 10,
            "the log was not reused after the checkpoint: {grown} then {after} bytes"
        );
        let rows: i64 = other
            .query_row("SELECT COUNT(*) FROM t", [], |r| r.get(0))
            .unwrap();
        assert_eq!(rows, 4000);
    }
}
