//! The routes anyone may call: liveness, readiness and the API document.

use std::sync::Arc;

use axum::extract::State;
use axum::{Extension, Json};
use spindle_common::protocol::ApiError;
use utoipa_axum::routes;

use super::Declared;
use crate::AppState;
use crate::auth::Role;
use crate::error::Error;

pub(super) fn routes() -> Declared {
    vec![
        (Role::Public, routes!(healthz)),
        (Role::Public, routes!(readyz)),
        (Role::Public, routes!(openapi_json)),
    ]
}

/// The process is up.
#[utoipa::path(get, path = "/healthz", responses((status = 200, body = String)))]
async fn healthz() -> &'static str {
    "ok"
}

/// The database answers and the coordinator is not shutting down.
#[utoipa::path(get, path = "/readyz", responses(
    (status = 200, body = String), (status = 503, body = ApiError)))]
async fn readyz(State(state): State<AppState>) -> Result<&'static str, Error> {
    if state.is_shutting_down() {
        return Err(Error::Unavailable("shutting down"));
    }
    state.ledger().check_database()?;
    Ok("ready")
}

/// This document.
#[utoipa::path(get, path = "/v1/openapi.json", responses((status = 200, body = Object)))]
async fn openapi_json(
    Extension(document): Extension<Arc<utoipa::openapi::OpenApi>>,
) -> Json<utoipa::openapi::OpenApi> {
    Json(utoipa::openapi::OpenApi::clone(&document))
}
