//! The lease routes workers call: ask for a tile (a long poll), renew its lease, report that
//! it could not be rendered, and fetch the previous pass's result it continues. Every one is a
//! registered worker's ([`Role::Worker`]): the worker id in its path or body must be the one
//! its worker secret proves ([`WorkerIdentity::check`]), so no worker can touch another's
//! leases. (The tile's result is uploaded with `PUT /v1/jobs/{job}/tiles/{tile}`, in
//! [`super::tiles`].)

use std::time::Duration;

use axum::Json;
use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use spindle_common::protocol::{
    ApiError, Heartbeat, HeartbeatAck, Lease, LeaseRequest, MAX_LEASE_WAIT_MS, TileFailure,
};
use spindle_common::tile_encoding;
use tokio::time::Instant;
use utoipa_axum::routes;

use super::Declared;
use crate::AppState;
use crate::auth::Role;
use crate::error::Error;
use crate::extract::{ApiPath, JsonBody, RawBody, parse_json};
use crate::throttle;
use crate::tile_store::ReadError;
use crate::worker_secret::WorkerIdentity;

pub(super) fn routes() -> Declared {
    vec![
        (Role::Worker, routes!(lease)),
        (Role::Worker, routes!(heartbeat)),
        (Role::Worker, routes!(fail_tile)),
        (Role::Worker, routes!(previous_pass)),
    ]
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
