//! A job's tiles: `GET /v1/jobs/{id}/tiles`, where each tile is, for the dashboard's tile map
//! (clients), and `PUT /v1/jobs/{job}/tiles/{tile}`, a tile's result (the worker holding its
//! lease).
//!
//! The map is read-only: it reports the ledger's view (queued, leased, done, failed) and the
//! worker of each lease or result, so a page can draw the map once and then follow `tile_done`
//! events. A done tile also carries its worker's name and the render seconds the worker
//! reported. A finished job keeps no per-tile state in memory (retention): its rectangles are
//! recomputed, every tile of a done job is done (its workers and render times are read from the
//! job's row, where they were kept when its tile rows were deleted), and a cancelled or failed
//! job's tiles are read from its stored rows.
//!
//! An upload is judged by its path and the caller's identity before its body is read
//! (`Ledger::admit_upload`), then read and inflated only up to what the tile's rectangle can
//! hold, at most twice the cores at once (`AppState::decode_turn`), and recorded in one commit
//! with the tile.

use std::collections::BTreeMap;

use axum::Json;
use axum::body::Body;
use axum::extract::State;
use axum::http::{HeaderMap, header};
use spindle_common::protocol::{
    ApiError, JobState, JobTiles, LEASE_EPOCH_HEADER, TileAck, TileInfo, TileState, TileUpload,
    pixel_hash,
};
use spindle_common::tile_encoding;
use utoipa_axum::routes;

use super::Declared;
use crate::AppState;
use crate::auth::Role;
use crate::db::{self, TileRowState};
use crate::error::Error;
use crate::extract::{ApiPath, parse_json, read_body};
use crate::ledger::tile::TileStatus;
use crate::worker_secret::WorkerIdentity;

pub(super) fn routes() -> Declared {
    vec![
        (Role::Client, routes!(job_tiles)),
        // The handler reads its body itself, within the tile's bound and
        // `limits.max_tile_upload_bytes`.
        (Role::Worker, routes!(upload_tile)),
    ]
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

/// Uploads a rendered tile.
#[utoipa::path(put, path = "/v1/jobs/{job}/tiles/{tile}",
    params(("job" = u64, Path, description = "job id"), ("tile" = u32, Path, description = "tile index")),
    request_body(description = "a TileUpload: as JSON, or (what spindle-worker sends) as \
        MessagePack with named fields compressed with zstd",
        content((TileUpload = "application/json"),
                (Vec<u8> = "application/vnd.spindle.tile+msgpack+zstd"))),
    responses((status = 200, body = TileAck), (status = 400, body = ApiError),
              (status = 404, body = ApiError), (status = 409, body = ApiError),
              (status = 413, body = ApiError), (status = 415, body = ApiError)))]
async fn upload_tile(
    State(state): State<AppState>,
    identity: WorkerIdentity,
    ApiPath((job, tile)): ApiPath<(u64, u32)>,
    headers: HeaderMap,
    body: Body,
) -> Result<Json<TileAck>, Error> {
    let encoding = UploadEncoding::of(&headers)?;
    let epoch = lease_epoch(&headers)?;
    // Nothing of the body is read before the lease is known to be this worker's; then at most
    // what the tile's rectangle can hold is read, and inflated.
    let rect = state.ledger().admit_upload(job, tile, identity.0, epoch)?;
    let inflated_limit = TileUpload::max_packed_bytes(rect);
    let body_limit = match encoding {
        UploadEncoding::Compact => inflated_limit,
        UploadEncoding::Json => TileUpload::max_json_bytes(rect),
    }
    .min(state.config().limits.max_tile_upload_bytes);
    let body = read_body(body, body_limit).await?;
    crate::metrics::upload_received(body.len());
    let decoding = state.decode_turn().await;
    // Decoding and hashing up to megabytes of floats is CPU work, and recording commits: both
    // off the runtime, on one blocking thread; the ledger is held only to record.
    let (outcome, complete, epoch) = state
        .off_runtime(move |state| {
            let upload: TileUpload = match encoding {
                UploadEncoding::Json => parse_json(&body)?,
                UploadEncoding::Compact => tile_encoding::decode(&body, inflated_limit)
                    .map_err(|e| Error::BadRequest(e.to_string()))?,
            };
            if epoch.is_some_and(|e| e != upload.epoch) {
                return Err(Error::BadRequest(format!(
                    "epoch: {} is not the {LEASE_EPOCH_HEADER} header's {}",
                    upload.epoch,
                    epoch.unwrap_or_default()
                )));
            }
            upload.check_report().map_err(Error::BadRequest)?;
            let actual = pixel_hash(&upload.pixels);
            if actual != upload.hash {
                return Err(Error::BadRequest(format!(
                    "hash: the pixels hash to {actual}, not {}",
                    upload.hash
                )));
            }
            identity.check("worker_id", upload.worker_id)?;
            // The form the upload rests in, recorded by the same commit as the tile: a compact
            // body as received.
            let stored = match encoding {
                UploadEncoding::Compact => body.to_vec(),
                UploadEncoding::Json => {
                    tile_encoding::encode(&upload).map_err(anyhow::Error::from)?
                }
            };
            drop(decoding);
            let (outcome, complete) = state.ledger().record_upload(job, tile, &upload, &stored)?;
            Ok((outcome, complete, upload.epoch))
        })
        .await?;
    crate::metrics::tile_stored(job, tile, epoch, outcome);
    if complete {
        // The last tile of the job, or of a pass: ending the pass queues the next pass's tiles
        // and wakes the lease polls (`assemble::finish`).
        state.assemble_complete_jobs();
    }
    Ok(Json(TileAck { outcome }))
}

/// The lease epoch an upload names in its [`LEASE_EPOCH_HEADER`], if it names one.
fn lease_epoch(headers: &HeaderMap) -> Result<Option<u64>, Error> {
    let Some(value) = headers.get(LEASE_EPOCH_HEADER) else {
        return Ok(None);
    };
    value
        .to_str()
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .map(Some)
        .ok_or_else(|| {
            Error::BadRequest(format!(
                "{LEASE_EPOCH_HEADER}: not an epoch (a whole number)"
            ))
        })
}

/// How a tile upload's body is written, by its `Content-Type`.
#[derive(Debug, Clone, Copy)]
enum UploadEncoding {
    /// `application/json`, or no content type.
    Json,
    /// [`tile_encoding::CONTENT_TYPE`].
    Compact,
}

impl UploadEncoding {
    fn of(headers: &HeaderMap) -> Result<UploadEncoding, Error> {
        let Some(value) = headers.get(header::CONTENT_TYPE) else {
            return Ok(UploadEncoding::Json);
        };
        let essence = value
            .to_str()
            .ok()
            .and_then(|v| v.split(';').next())
            .map(|v| v.trim().to_ascii_lowercase());
        match essence.as_deref() {
            Some("application/json") => Ok(UploadEncoding::Json),
            Some(tile_encoding::CONTENT_TYPE) => Ok(UploadEncoding::Compact),
            _ => Err(Error::UnsupportedMediaType(format!(
                "Content-Type: a tile is application/json or {}",
                tile_encoding::CONTENT_TYPE
            ))),
        }
    }
}
