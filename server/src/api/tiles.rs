//! `GET /v1/jobs/{id}/tiles`: where each tile of a job is, for the dashboard's tile map.
//!
//! Read-only: it reports the ledger's view (queued, leased, done, failed) and the worker of
//! each lease or result, so a page can draw the map once and then follow `tile_done` events.
//! A done tile also carries its worker's name and the render seconds the worker reported.
//! A finished job keeps no per-tile state in memory (retention): its rectangles are recomputed,
//! every tile of a done job is done (its workers and render times are read from the job's row,
//! where they were kept when its tile rows were deleted), and a cancelled or failed job's tiles
//! are read from its stored rows.

use axum::Json;
use axum::extract::State;
use spindle_common::protocol::{ApiError, JobTiles, TileInfo, TileState};
use utoipa_axum::routes;

use std::collections::BTreeMap;

use spindle_common::protocol::JobState;

use super::Declared;
use crate::AppState;
use crate::auth::Role;
use crate::db::{self, TileRowState};
use crate::error::Error;
use crate::extract::ApiPath;
use crate::ledger::tile::TileStatus;

pub(super) fn routes() -> Declared {
    vec![(Role::Client, routes!(job_tiles))]
}

/// Every tile of a job, by index: its rectangle, state (queued, leased, done, failed) and the
/// worker holding or having rendered it, when known.
#[utoipa::path(get, path = "/v1/jobs/{id}/tiles",
    params(("id" = u64, Path, description = "job id")),
    responses((status = 200, body = JobTiles), (status = 404, body = ApiError)))]
async fn job_tiles(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<Json<JobTiles>, Error> {
    let ledger = state.ledger();
    let job = ledger.job(id)?;
    if job.tiles.is_empty() {
        let rects = job.spec.tiles();
        let stored = if job.state == JobState::Done {
            BTreeMap::new()
        } else {
            db::load_tiles(&ledger.db, id).map_err(Error::Internal)?
        };
        // A done job keeps who rendered each tile and how long it took in its row.
        let times: BTreeMap<u32, (Option<u64>, Option<f64>)> = if job.state == JobState::Done {
            db::tile_times(&ledger.db, id)
                .map_err(Error::Internal)?
                .into_iter()
                .map(|(index, worker, seconds)| (index, (worker, seconds)))
                .collect()
        } else {
            stored
                .iter()
                .map(|(index, row)| (*index, (row.worker_id, row.render_seconds)))
                .collect()
        };
        let name = |worker: Option<u64>| {
            worker
                .and_then(|w| ledger.workers.get(&w))
                .map(|w| w.name.clone())
        };
        let tiles = rects
            .into_iter()
            .enumerate()
            .map(|(index, rect)| {
                let index = index as u32;
                let done = job.state == JobState::Done
                    || matches!(
                        stored.get(&index).map(|row| &row.state),
                        Some(TileRowState::Done { .. })
                    );
                let (worker, render_seconds) = match times.get(&index) {
                    Some(&(worker, seconds)) if done => (name(worker), seconds),
                    _ => (None, None),
                };
                TileInfo {
                    index,
                    rect,
                    state: if done {
                        TileState::Done
                    } else {
                        TileState::Queued
                    },
                    worker,
                    failures: 0,
                    render_seconds,
                }
            })
            .collect();
        return Ok(Json(JobTiles { job: id, tiles }));
    }
    let tiles = job
        .rects
        .iter()
        .zip(&job.tiles)
        .enumerate()
        .map(|(index, (rect, tile))| {
            let index = index as u32;
            let failures = job.failed_by.get(&index).map_or(0, |w| w.len() as u32);
            let state = match tile.status {
                TileStatus::Done => TileState::Done,
                TileStatus::Leased { .. } => TileState::Leased,
                TileStatus::Pending if failures > 0 => TileState::Failed,
                TileStatus::Pending => TileState::Queued,
            };
            let worker = tile
                .worker
                .and_then(|w| ledger.workers.get(&w))
                .map(|w| w.name.clone());
            TileInfo {
                index,
                rect: *rect,
                state,
                worker,
                failures,
                render_seconds: tile.render_seconds.filter(|_| state == TileState::Done),
            }
        })
        .collect();
    Ok(Json(JobTiles { job: id, tiles }))
}
