//! The job routes clients use: submit, list, inspect, cancel, delete, and fetch the image.

use axum::Json;
use axum::extract::State;
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use spindle_common::protocol::{
    ApiError, IDEMPOTENCY_KEY_HEADER, JobInfo, JobList, JobState, SubmitJob, check_labels,
};
use utoipa_axum::routes;

use super::Declared;
use crate::AppState;
use crate::admission;
use crate::assemble;
use crate::auth::Role;
use crate::error::Error;
use crate::extract::{ApiPath, RawBody, parse_json};
use crate::jobs::NewJob;

pub(super) fn routes() -> Declared {
    vec![
        (Role::Client, routes!(submit_job)),
        (Role::Client, routes!(list_jobs)),
        (Role::Client, routes!(get_job)),
        (Role::Client, routes!(delete_job)),
        (Role::Client, routes!(cancel_job)),
        (Role::Client, routes!(image_exr)),
        (Role::Client, routes!(image_png)),
    ]
}

/// Submits a job. With an `Idempotency-Key` header, a retry returns the job the first request
/// created (200) instead of a new one (201).
#[utoipa::path(post, path = "/v1/jobs", request_body = SubmitJob,
    params(("Idempotency-Key" = Option<String>, Header, description = "makes retries safe")),
    responses((status = 201, body = JobInfo), (status = 200, body = JobInfo),
              (status = 400, body = ApiError), (status = 409, body = ApiError),
              (status = 413, body = ApiError), (status = 429, body = ApiError)))]
async fn submit_job(
    State(state): State<AppState>,
    headers: HeaderMap,
    RawBody(body): RawBody,
) -> Result<(StatusCode, Json<JobInfo>), Error> {
    let key = idempotency_key(&headers)?;
    let submit: SubmitJob = parse_json(&body)?;
    check_labels("requires", &submit.requires).map_err(Error::BadRequest)?;
    let limits = &state.config().limits;
    admission::admit(&submit, limits, state.assets()).await?;
    let new = NewJob::new(submit, key)?;
    let (info, created) = state.ledger().submit(new, limits.max_active_jobs)?;
    if created {
        state.work_available();
        Ok((StatusCode::CREATED, Json(info)))
    } else {
        Ok((StatusCode::OK, Json(info)))
    }
}

fn idempotency_key(headers: &HeaderMap) -> Result<Option<String>, Error> {
    let Some(value) = headers.get(IDEMPOTENCY_KEY_HEADER) else {
        return Ok(None);
    };
    let key = value
        .to_str()
        .ok()
        .filter(|k| !k.is_empty() && k.len() <= 256 && k.bytes().all(|b| b.is_ascii_graphic()))
        .ok_or_else(|| {
            Error::BadRequest(
                "Idempotency-Key: must be 1 to 256 printable ASCII characters without spaces"
                    .into(),
            )
        })?;
    Ok(Some(key.to_string()))
}

/// Lists every job, oldest first.
#[utoipa::path(get, path = "/v1/jobs",
    responses((status = 200, body = JobList)))]
async fn list_jobs(State(state): State<AppState>) -> Json<JobList> {
    Json(JobList {
        jobs: state.ledger().list(),
    })
}

/// A job's state and progress.
#[utoipa::path(get, path = "/v1/jobs/{id}", params(("id" = u64, Path, description = "job id")),
    responses((status = 200, body = JobInfo), (status = 404, body = ApiError)))]
async fn get_job(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<Json<JobInfo>, Error> {
    Ok(Json(state.ledger().info(id)?))
}

/// Cancels a job; its tiles are no longer handed out and late uploads are refused.
#[utoipa::path(post, path = "/v1/jobs/{id}/cancel", params(("id" = u64, Path, description = "job id")),
    responses((status = 200, body = JobInfo), (status = 404, body = ApiError),
              (status = 409, body = ApiError)))]
async fn cancel_job(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<Json<JobInfo>, Error> {
    Ok(Json(state.ledger().cancel(id)?))
}

/// Deletes a job and its files.
#[utoipa::path(delete, path = "/v1/jobs/{id}", params(("id" = u64, Path, description = "job id")),
    responses((status = 204), (status = 404, body = ApiError)))]
async fn delete_job(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<StatusCode, Error> {
    state.ledger().delete(id)?;
    // The job is gone for every request from here on. An upload still writing into its
    // directory removes it again when it finds the job gone, so a failed removal (a file
    // appearing meanwhile) is logged, not answered as a failure of the delete.
    if let Err(e) = state.remove_job_files(id).await {
        tracing::warn!(job = id, error = %e, "removing the files of a deleted job failed");
    }
    Ok(StatusCode::NO_CONTENT)
}

/// The final EXR, once every tile is in.
#[utoipa::path(get, path = "/v1/jobs/{id}/image.exr", params(("id" = u64, Path, description = "job id")),
    responses((status = 200, content_type = "image/x-exr", body = Vec<u8>),
              (status = 404, body = ApiError), (status = 409, body = ApiError)))]
async fn image_exr(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<Response, Error> {
    {
        let ledger = state.ledger();
        let job = ledger.job(id)?;
        if job.state != JobState::Done {
            return Err(Error::Conflict(format!(
                "job {id} is {} ({} of {} tiles); the image is ready when the job is done",
                job.state.as_str(),
                job.tiles_done,
                job.tiles.len()
            )));
        }
    }
    let bytes = tokio::fs::read(state.tile_store().image_path(id)).await?;
    Ok(([(header::CONTENT_TYPE, "image/x-exr")], bytes).into_response())
}

/// A PNG preview of the tiles received so far.
#[utoipa::path(get, path = "/v1/jobs/{id}/image.png", params(("id" = u64, Path, description = "job id")),
    responses((status = 200, content_type = "image/png", body = Vec<u8>),
              (status = 404, body = ApiError)))]
async fn image_png(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<Response, Error> {
    let (spec, tiles) = {
        let ledger = state.ledger();
        (ledger.job(id)?.spec.clone(), ledger.done_tiles(id)?)
    };
    let store = state.tile_store().clone();
    let png = tokio::task::spawn_blocking(move || assemble::preview_png(&store, id, &spec, &tiles))
        .await
        .map_err(anyhow::Error::from)??;
    Ok(([(header::CONTENT_TYPE, "image/png")], png).into_response())
}
