//! The routes anyone may call: liveness, readiness and the API document.

use std::sync::Arc;

use axum::extract::State;
use axum::{Extension, Json};
use spindle_common::protocol::ApiError;
use utoipa_axum::routes;

use super::Declared;
use crate::AppState;
use crate::auth::Role;
use crate::error::{Error, is_disk_full_io};

pub(super) fn routes() -> Declared {
    vec![
        (Role::Public, routes!(healthz)),
        (Role::Public, routes!(readyz)),
        (Role::Public, routes!(openapi_json)),
        (Role::Public, routes!(crate::metrics::metrics)),
    ]
}

/// The process is up.
#[utoipa::path(get, path = "/healthz", responses((status = 200, body = String)))]
async fn healthz() -> &'static str {
    "ok"
}

/// The database answers, the data directory takes a write, and the coordinator is not
/// shutting down.
#[utoipa::path(get, path = "/readyz", responses(
    (status = 200, body = String),
    (status = 503, body = ApiError, description = "shutting down, the database fails, or the disk is full (Retry-After)")))]
async fn readyz(State(state): State<AppState>) -> Result<&'static str, Error> {
    if state.is_shutting_down() {
        return Err(Error::Unavailable("shutting down"));
    }
    state.ledger().check_database()?;
    let dir = state.config().data_dir.clone();
    let probe = tokio::task::spawn_blocking(move || probe_disk(&dir))
        .await
        .map_err(anyhow::Error::from)?;
    readiness(probe)
}

/// Writes and removes a small file in the data directory: the writes the coordinator lives on
/// (tiles, assets, the database) fail the same way when the disk is full.
fn probe_disk(dir: &std::path::Path) -> std::io::Result<()> {
    let path = dir.join(".readyz-probe");
    std::fs::write(&path, [0u8; 4096])?;
    std::fs::remove_file(&path)
}

/// The readiness answer for the outcome of [`probe_disk`].
fn readiness(probe: std::io::Result<()>) -> Result<&'static str, Error> {
    match probe {
        Ok(()) => Ok("ready"),
        Err(e) if is_disk_full_io(&e) => {
            tracing::error!("not ready: the data directory's disk is full");
            Err(Error::Unavailable(
                "disk full: the coordinator cannot store tiles or assets",
            ))
        }
        Err(e) => {
            tracing::error!(error = %e, "not ready: the data directory cannot be written");
            Err(Error::Unavailable(
                "the coordinator cannot write its data directory",
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::http::StatusCode;

    #[test]
    fn readiness_says_the_disk_is_full() {
        assert_eq!(readiness(Ok(())).unwrap(), "ready");
        let full = readiness(Err(std::io::Error::from(std::io::ErrorKind::StorageFull)));
        let e = full.unwrap_err();
        assert_eq!(e.status(), StatusCode::SERVICE_UNAVAILABLE);
        assert!(e.to_string().starts_with("disk full"), "{e}");
        let other = readiness(Err(std::io::Error::from(
            std::io::ErrorKind::PermissionDenied,
        )));
        assert!(other.unwrap_err().to_string().contains("cannot write"));
    }

    #[test]
    fn the_probe_writes_and_cleans_up() {
        let dir = tempfile::tempdir().unwrap();
        probe_disk(dir.path()).unwrap();
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        // A probe that cannot be written (its path is a directory) is an error.
        std::fs::create_dir(dir.path().join(".readyz-probe")).unwrap();
        assert!(probe_disk(dir.path()).is_err());
    }
}

/// This document.
#[utoipa::path(get, path = "/v1/openapi.json", responses((status = 200, body = Object)))]
async fn openapi_json(
    Extension(document): Extension<Arc<utoipa::openapi::OpenApi>>,
) -> Json<utoipa::openapi::OpenApi> {
    Json(utoipa::openapi::OpenApi::clone(&document))
}
