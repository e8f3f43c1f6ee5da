//! `GET /v1/jobs/{id}/tiles`: where each tile of a job is, for the dashboard's tile map.
//!
//! Read-only: it reports the ledger's view (queued, leased, done, failed) and the worker of
//! each lease or result, so a page can draw the map once and then follow `tile_done` events.

use axum::Json;
use axum::extract::State;
use spindle_common::protocol::{ApiError, JobTiles, TileInfo, TileState};
use utoipa_axum::routes;

use super::Declared;
use crate::AppState;
use crate::auth::Role;
use crate::error::Error;
use crate::extract::ApiPath;
use crate::jobs::TileStatus;

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
    let tiles = job
        .rects
        .iter()
        .zip(&job.tiles)
        .enumerate()
        .map(|(index, (rect, tile))| {
            let index = index as u32;
            let failures = job.failed_by.get(&index).map_or(0, |w| w.len() as u32);
            let state = match tile.status {
                TileStatus::Done { .. } => TileState::Done,
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
            }
        })
        .collect();
    Ok(Json(JobTiles { job: id, tiles }))
}
