//! The routes workers use: register, lease a tile, read its job, renew the lease, upload the
//! result or report a failure. Every route but registration is a registered worker's
//! ([`Role::Worker`]): the worker id in its path or body must be the one its worker secret
//! proves ([`WorkerIdentity::check`]), so no worker can touch another's leases.

use std::time::Duration;

use axum::Json;
use axum::body::Body;
use axum::extract::State;
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use spindle_common::protocol::{
    ApiError, Heartbeat, HeartbeatAck, JobSpec, LEASE_EPOCH_HEADER, Lease, LeaseRequest,
    MAX_LEASE_WAIT_MS, RegisterWorker, TileAck, TileFailure, TileUpload, WorkerRegistered,
    pixel_hash,
};
use spindle_common::tile_encoding;
use tokio::time::Instant;
use utoipa_axum::routes;

use super::Declared;
use crate::AppState;
use crate::auth::Role;
use crate::error::Error;
use crate::extract::{ApiPath, JsonBody, RawBody, parse_json, read_body};
use crate::throttle;
use crate::tile_store::ReadError;
use crate::worker_secret::WorkerIdentity;

pub(super) fn routes() -> Declared {
    vec![
        (Role::NewWorker, routes!(register_worker)),
        (Role::Worker, routes!(lease)),
        (Role::Worker, routes!(job_spec)),
        (Role::Worker, routes!(heartbeat)),
        // The handler reads its body itself, within the tile's bound and
        // `limits.max_tile_upload_bytes`.
        (Role::Worker, routes!(upload_tile)),
        (Role::Worker, routes!(fail_tile)),
        (Role::Worker, routes!(previous_pass)),
    ]
}

/// Registers a worker: its id, and the secret its later requests carry.
#[utoipa::path(post, path = "/v1/workers", request_body = RegisterWorker,
    responses((status = 200, body = WorkerRegistered), (status = 400, body = ApiError),
              (status = 429, body = ApiError, description = "--max-workers workers are registered and none is lost (Retry-After)")))]
async fn register_worker(
    State(state): State<AppState>,
    JsonBody(request): JsonBody<RegisterWorker>,
) -> Result<Json<WorkerRegistered>, Error> {
    request.check().map_err(Error::BadRequest)?;
    let max_workers = state.config().max_workers;
    let (worker_id, worker_secret) = state
        .with_ledger(move |ledger| {
            ledger.register_worker(
                &request.name,
                request.threads,
                &request.version,
                request.labels,
                max_workers,
            )
        })
        .await?;
    Ok(Json(WorkerRegistered {
        worker_id,
        worker_secret,
    }))
}

/// Long-polls for a tile: 200 with a lease, or 204 when none came up within the wait.
#[utoipa::path(post, path = "/v1/workers/{id}/lease", params(("id" = u64, Path, description = "worker id")),
    request_body(content = Option<LeaseRequest>, description = "optional; an empty body means the defaults"),
    responses((status = 200, body = Lease), (status = 204, description = "no work right now"),
              (status = 404, body = ApiError),
              (status = 410, body = ApiError, description = "the worker is draining: exit"),
              (status = 429, body = ApiError, description = "the worker holds --max-leases-per-worker leases (Retry-After)")))]
async fn lease(
    State(state): State<AppState>,
    identity: WorkerIdentity,
    ApiPath(worker): ApiPath<u64>,
    RawBody(body): RawBody,
) -> Result<Response, Error> {
    identity.check("id", worker)?;
    // An empty body or JSON `null` means the defaults.
    let request: LeaseRequest = if body.iter().all(u8::is_ascii_whitespace) {
        LeaseRequest::default()
    } else {
        parse_json::<Option<LeaseRequest>>(&body)?.unwrap_or_default()
    };
    let wait = request
        .wait_ms
        .unwrap_or(MAX_LEASE_WAIT_MS)
        .min(MAX_LEASE_WAIT_MS)
        .min(state.config().timeouts.long_poll_cap().as_millis() as u64);
    let deadline = Instant::now() + Duration::from_millis(wait);
    let _polling = Polling::start(&state, worker)?;
    // Woken at least once a lease TTL, so a job nobody connected can finish any more is
    // failed even when nothing else happens.
    let recheck = state.config().lease_ttl;
    loop {
        let notified = state.work_notified();
        tokio::pin!(notified);
        notified.as_mut().enable();
        let max_leases = state.config().max_leases_per_worker;
        let (lease, next_expiry) = state
            .with_ledger(move |ledger| {
                throttle::check_lease_cap(ledger, worker, max_leases)?;
                Ok((
                    ledger.try_lease(worker, Instant::now())?,
                    ledger.next_expiry(),
                ))
            })
            .await?;
        if let Some(lease) = lease {
            crate::metrics::lease_granted(&lease);
            return Ok(Json(lease).into_response());
        }
        if Instant::now() >= deadline || state.is_shutting_down() {
            return Ok(StatusCode::NO_CONTENT.into_response());
        }
        let wake = next_expiry
            .map_or(deadline, |e| e.min(deadline))
            .min(Instant::now() + recheck);
        tokio::select! {
            _ = &mut notified => {}
            _ = tokio::time::sleep_until(wake) => {}
            _ = state.shutdown_signal() => return Ok(StatusCode::NO_CONTENT.into_response()),
        }
    }
}

/// A worker's lease poll in progress: it counts as connected until the poll ends, however it
/// ends (answered, or dropped because the client went away).
struct Polling {
    state: AppState,
    worker: u64,
}

impl Polling {
    fn start(state: &AppState, worker: u64) -> Result<Polling, Error> {
        state.ledger().poll_started(worker, Instant::now())?;
        Ok(Polling {
            state: state.clone(),
            worker,
        })
    }
}

impl Drop for Polling {
    fn drop(&mut self) {
        self.state.ledger().poll_ended(self.worker, Instant::now());
    }
}

/// What a worker needs to render a job's tiles.
#[utoipa::path(get, path = "/v1/jobs/{id}/spec", params(("id" = u64, Path, description = "job id")),
    responses((status = 200, body = JobSpec), (status = 404, body = ApiError)))]
async fn job_spec(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<Json<JobSpec>, Error> {
    let spec = state.ledger().job(id)?.spec.clone();
    Ok(Json((*spec).clone()))
}

/// Renews a lease.
#[utoipa::path(post, path = "/v1/leases/{job}/{tile}/heartbeat",
    params(("job" = u64, Path, description = "job id"), ("tile" = u32, Path, description = "tile index")),
    request_body = Heartbeat,
    responses((status = 200, body = HeartbeatAck), (status = 404, body = ApiError),
              (status = 409, body = ApiError)))]
async fn heartbeat(
    State(state): State<AppState>,
    identity: WorkerIdentity,
    ApiPath((job, tile)): ApiPath<(u64, u32)>,
    JsonBody(hb): JsonBody<Heartbeat>,
) -> Result<Json<HeartbeatAck>, Error> {
    identity.check("worker_id", hb.worker_id)?;
    Ok(Json(state.ledger().heartbeat(
        job,
        tile,
        &hb,
        Instant::now(),
    )?))
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

/// Reports that a tile could not be rendered.
#[utoipa::path(post, path = "/v1/leases/{job}/{tile}/fail",
    params(("job" = u64, Path, description = "job id"), ("tile" = u32, Path, description = "tile index")),
    request_body = TileFailure,
    responses((status = 204), (status = 404, body = ApiError), (status = 409, body = ApiError)))]
async fn fail_tile(
    State(state): State<AppState>,
    identity: WorkerIdentity,
    ApiPath((job, tile)): ApiPath<(u64, u32)>,
    JsonBody(mut failure): JsonBody<TileFailure>,
) -> Result<StatusCode, Error> {
    identity.check("worker_id", failure.worker_id)?;
    if failure.reason.len() > 2000 {
        let mut end = 2000;
        while !failure.reason.is_char_boundary(end) {
            end -= 1;
        }
        failure.reason.truncate(end);
    }
    state
        .with_ledger(move |ledger| ledger.fail_tile(job, tile, &failure, Instant::now()))
        .await?;
    crate::metrics::tile_failed();
    state.work_available();
    Ok(StatusCode::NO_CONTENT)
}

/// The previous progressive pass's result of a tile whose current pass the calling worker
/// holds (a job with `film.time_budget_s`): the stored `TilePixels` with its `progress`, in the
/// compact form of uploads, from which the worker continues the tile ([`crate::ledger::passes`]).
#[utoipa::path(get, path = "/v1/leases/{job}/{tile}/previous",
    params(("job" = u64, Path, description = "job id"), ("tile" = u32, Path, description = "tile index")),
    responses((status = 200, description = "the previous pass's TilePixels, MessagePack compressed with zstd",
               content_type = "application/vnd.spindle.tile+msgpack+zstd", body = Vec<u8>),
              (status = 404, body = ApiError, description = "no such job or tile, or the tile is in its first pass"),
              (status = 409, body = ApiError, description = "the tile is not leased to this worker, or its previous result is damaged (the job's passes then start again from pass 1)")))]
async fn previous_pass(
    State(state): State<AppState>,
    identity: WorkerIdentity,
    ApiPath((job, tile)): ApiPath<(u64, u32)>,
) -> Result<Response, Error> {
    let hash = state.ledger().previous_result(job, tile, identity.0)?;
    let store = state.tile_store().clone();
    let read = tokio::task::spawn_blocking(move || match store.read(job, tile, &hash) {
        Ok(pixels) => tile_encoding::encode(&pixels)
            .map(Ok)
            .map_err(|e| Error::Internal(anyhow::anyhow!("{e}"))),
        Err(ReadError::Damaged(why)) => Ok(Err(why)),
        Err(ReadError::Io(why)) => Err(Error::Internal(anyhow::anyhow!(why))),
    })
    .await
    .map_err(anyhow::Error::from)??;
    let bytes = match read {
        Ok(bytes) => bytes,
        // The pass cannot go on from it, nor can the tile's earlier passes be had again: the
        // job starts over from pass 1, and this lease is stale from here.
        Err(why) => {
            let reason = why.clone();
            state
                .with_ledger(move |l| l.restart_passes_after_damage(job, tile, &reason))
                .await?;
            state.work_available();
            return Err(Error::Conflict(format!(
                "{why}; the job's passes start again from pass 1"
            )));
        }
    };
    Ok(([(header::CONTENT_TYPE, tile_encoding::CONTENT_TYPE)], bytes).into_response())
}
