//! What the coordinator keeps, and for how long: a periodic sweep deletes finished jobs past
//! their retention, assets no job names past their grace period, and workers lost for long.
//!
//! Without it the database, the data directory and memory would grow with every job ever
//! submitted. The sweep runs every [`Retention::sweep_interval`] until shutdown; each pass
//! changes the database first, then memory, then removes files (a file left by a crash in
//! between is an orphan of a deleted job, removed by hand or never read again). Tile results
//! are not the sweep's: they go when the job's image is written ([`crate::assemble`]) or when
//! the job is deleted.

use crate::AppState;
use crate::clock::now_ms;
use crate::config::Retention;

/// What one pass deleted.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Swept {
    pub jobs: usize,
    pub assets: usize,
    pub workers: usize,
}

/// Starts the sweep (needs a Tokio runtime).
pub(crate) fn spawn(state: AppState) {
    let period = state.config().retention.sweep_interval;
    tokio::spawn(async move {
        let mut tick = tokio::time::interval(period);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            tokio::select! {
                _ = tick.tick() => {}
                _ = state.shutdown_signal() => return,
            }
            if let Err(e) = sweep(&state).await {
                tracing::error!(
                    error = format!("{e:#}"),
                    "retention sweep failed; trying again later"
                );
            }
        }
    });
}

/// One pass of the sweep.
pub async fn sweep(state: &AppState) -> anyhow::Result<Swept> {
    let Retention {
        keep_finished,
        asset_grace,
        keep_lost_workers,
        ..
    } = state.config().retention;
    let mut swept = Swept::default();
    let jobs = match keep_finished {
        Some(keep) => state.ledger().delete_expired_jobs(keep, now_ms())?,
        None => Vec::new(),
    };
    swept.jobs = jobs.len();
    for id in jobs {
        state.remove_job_files(id).await?;
    }
    swept.workers = state.ledger().forget_lost_workers(
        keep_lost_workers,
        tokio::time::Instant::now(),
        now_ms(),
    )?;
    let locked = state.clone();
    swept.assets = tokio::task::spawn_blocking(move || {
        // Under the ledger's lock: no job naming one of these can be stored meanwhile.
        let ledger = locked.ledger();
        locked
            .assets()
            .remove_unreferenced(&ledger.referenced_assets(), asset_grace)
    })
    .await??;
    Ok(swept)
}
