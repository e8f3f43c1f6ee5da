//! The worker routes: a worker registers itself (the worker token, [`Role::NewWorker`]);
//! operators list the workers and drain one (the client token). (The routes a registered
//! worker calls about its tiles are in [`super::leases`] and [`super::tiles`].)

use axum::Json;
use axum::extract::State;
use spindle_common::protocol::{ApiError, RegisterWorker, WorkerList, WorkerRegistered};
use utoipa_axum::routes;

use super::Declared;
use crate::AppState;
use crate::auth::Role;
use crate::error::Error;
use crate::extract::{ApiPath, JsonBody};

pub(super) fn routes() -> Declared {
    vec![
        (Role::NewWorker, routes!(register_worker)),
        (Role::Client, routes!(list_workers)),
        (Role::Client, routes!(drain_worker)),
    ]
}

/// Lists the workers by id: every connected one, and the lost ones heard from within the last
/// hour, with state, lease in hand, counts and throughput.
#[utoipa::path(get, path = "/v1/workers",
    responses((status = 200, body = WorkerList)))]
async fn list_workers(State(state): State<AppState>) -> Json<WorkerList> {
    Json(WorkerList {
        workers: state.ledger().worker_list(),
    })
}

/// Tells a worker (by id, or every connected worker with that name) to drain: it finishes the
/// tile in hand, takes no more and exits. Answers the workers told.
#[utoipa::path(post, path = "/v1/workers/{id}/drain",
    params(("id" = String, Path, description = "worker id or name")),
    responses((status = 200, body = WorkerList), (status = 404, body = ApiError),
              (status = 409, body = ApiError, description = "the worker is lost")))]
async fn drain_worker(
    State(state): State<AppState>,
    ApiPath(name_or_id): ApiPath<String>,
) -> Result<Json<WorkerList>, Error> {
    let workers = state.with_ledger(move |l| l.drain(&name_or_id)).await?;
    // Lease polls of the drained workers wake and answer 410.
    state.work_available();
    Ok(Json(WorkerList { workers }))
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
