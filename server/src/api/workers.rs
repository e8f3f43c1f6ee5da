//! The worker routes operators use: list the workers and drain one. (The routes workers
//! themselves call are in [`super::work`].)

use axum::Json;
use axum::extract::State;
use spindle_common::protocol::{ApiError, WorkerList};
use utoipa_axum::routes;

use super::Declared;
use crate::AppState;
use crate::auth::Role;
use crate::error::Error;
use crate::extract::ApiPath;

pub(super) fn routes() -> Declared {
    vec![
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
