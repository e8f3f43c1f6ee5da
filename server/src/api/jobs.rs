//! The job routes: clients submit, list, inspect, pause, resume, requeue, reprioritise,
//! cancel, delete, and fetch the image; workers read a job's spec.

use axum::Json;
use axum::extract::rejection::QueryRejection;
use axum::extract::{Query, State};
use axum::http::{HeaderMap, HeaderName, StatusCode, header};
use axum::response::{IntoResponse, Response};
use base64::Engine;
use serde::Deserialize;
use spindle_common::protocol::{
    ApiError, DEFAULT_JOB_PAGE, IDEMPOTENCY_KEY_HEADER, JobInfo, JobList, JobOrder, JobPatch,
    JobSpec, JobState, MAX_JOB_PAGE, SubmitJob, check_labels, check_name,
};
use utoipa_axum::routes;

use super::Declared;
use crate::AppState;
use crate::admission;
use crate::assemble;
use crate::auth::Role;
use crate::error::Error;
use crate::extract::JsonBody;
use crate::extract::{ApiPath, RawBody, parse_json};
use crate::ledger::jobs::{JobFilter, NewJob};

pub(super) fn routes() -> Declared {
    vec![
        (Role::Client, routes!(submit_job)),
        (Role::Client, routes!(list_jobs)),
        (Role::Client, routes!(get_job)),
        (Role::Client, routes!(delete_job)),
        (Role::Client, routes!(cancel_job)),
        (Role::Client, routes!(pause_job)),
        (Role::Client, routes!(resume_job)),
        (Role::Client, routes!(requeue_job)),
        (Role::Client, routes!(patch_job)),
        (Role::Client, routes!(image_exr)),
        (Role::Client, routes!(image_png)),
        (Role::Worker, routes!(job_spec)),
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
    for (field, value) in [("name", &submit.name), ("submitter", &submit.submitter)] {
        if let Some(value) = value {
            check_name(field, value).map_err(Error::BadRequest)?;
        }
    }
    let limits = &state.config().limits;
    admission::admit(&submit, limits, state.assets()).await?;
    let new = NewJob::new(submit, key)?;
    let max_active = limits.max_active_jobs;
    let assets = state.clone();
    let (info, created) = state
        .with_ledger(move |ledger| {
            // Checked again under the lock the sweep deletes unreferenced assets under: once
            // the job is stored, its assets are kept as long as it is.
            for (path, hash) in &new.spec.assets {
                if !assets.assets().has(hash)? {
                    return Err(Error::BadRequest(format!(
                        "assets.{path}: asset {hash} is not uploaded (PUT /v1/assets/{hash} first)"
                    )));
                }
            }
            ledger.submit(new, max_active)
        })
        .await?;
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

/// The query of `GET /v1/jobs`.
#[derive(Debug, Deserialize, utoipa::IntoParams)]
#[into_params(parameter_in = Query)]
#[serde(deny_unknown_fields)]
struct ListQuery {
    /// Only jobs in this state.
    #[param(value_type = Option<JobState>)]
    state: Option<String>,
    /// Only jobs whose name contains this.
    name: Option<String>,
    /// Jobs per page (default 100, at most 1000).
    #[param(minimum = 1, maximum = 1000)]
    limit: Option<usize>,
    /// `next_cursor` of the previous page (empty: the first page).
    #[param(pattern = "^[0-9]{0,19}$")]
    cursor: Option<String>,
    /// `asc` (default): oldest first; `desc`: newest first.
    #[param(value_type = Option<JobOrder>)]
    order: Option<String>,
}

/// Lists jobs, oldest first (or newest first with `order=desc`), a page at a time: pass
/// `next_cursor` as `cursor` for the next. Pages are stable: oldest first, jobs submitted
/// meanwhile come after the ones already listed; newest first, they are not listed (they are
/// newer than the first page).
#[utoipa::path(get, path = "/v1/jobs", params(ListQuery),
    responses((status = 200, body = JobList), (status = 400, body = ApiError)))]
async fn list_jobs(
    State(state): State<AppState>,
    query: Result<Query<ListQuery>, QueryRejection>,
) -> Result<Json<JobList>, Error> {
    let Query(query) = query.map_err(|e| Error::BadRequest(format!("query: {}", e.body_text())))?;
    let job_state = match query.state.as_deref() {
        None => None,
        Some(s) => Some(JobState::parse(s).ok_or_else(|| {
            Error::BadRequest(format!(
                "state: {s:?} is not one of queued, running, paused, done, failed, cancelled"
            ))
        })?),
    };
    let limit = query.limit.unwrap_or(DEFAULT_JOB_PAGE);
    if limit == 0 || limit > MAX_JOB_PAGE {
        return Err(Error::BadRequest(format!(
            "limit: must be 1 to {MAX_JOB_PAGE}"
        )));
    }
    let after =
        match query.cursor.as_deref() {
            None | Some("") => None,
            Some(c) => Some(c.parse::<u64>().map_err(|_| {
                Error::BadRequest("cursor: not a cursor this coordinator gave".into())
            })?),
        };
    let order = match query.order.as_deref() {
        None | Some("") => JobOrder::default(),
        Some(o) => JobOrder::parse(o)
            .ok_or_else(|| Error::BadRequest(format!("order: {o:?} is not asc or desc")))?,
    };
    let filter = JobFilter {
        state: job_state,
        name: query.name.filter(|n| !n.is_empty()),
        after,
        limit,
        order,
    };
    let (jobs, next_cursor) = state.ledger().list(&filter);
    Ok(Json(JobList { jobs, next_cursor }))
}

/// Pauses a job: no new tiles are leased; tiles already leased finish and are kept.
#[utoipa::path(post, path = "/v1/jobs/{id}/pause", params(("id" = u64, Path, description = "job id")),
    responses((status = 200, body = JobInfo), (status = 404, body = ApiError),
              (status = 409, body = ApiError)))]
async fn pause_job(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<Json<JobInfo>, Error> {
    Ok(Json(state.with_ledger(move |l| l.pause(id)).await?))
}

/// Resumes a paused job.
#[utoipa::path(post, path = "/v1/jobs/{id}/resume", params(("id" = u64, Path, description = "job id")),
    responses((status = 200, body = JobInfo), (status = 404, body = ApiError),
              (status = 409, body = ApiError)))]
async fn resume_job(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<Json<JobInfo>, Error> {
    let info = state.with_ledger(move |l| l.resume(id)).await?;
    state.work_available();
    Ok(Json(info))
}

/// Puts a failed or cancelled job back in the queue: unfinished tiles pending again, failures
/// forgotten, finished tiles kept. 409 for a job that is not failed or cancelled.
#[utoipa::path(post, path = "/v1/jobs/{id}/requeue", params(("id" = u64, Path, description = "job id")),
    responses((status = 200, body = JobInfo), (status = 404, body = ApiError),
              (status = 409, body = ApiError), (status = 429, body = ApiError)))]
async fn requeue_job(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<Json<JobInfo>, Error> {
    let max = state.config().limits.max_active_jobs;
    let info = state.with_ledger(move |l| l.requeue(id, max)).await?;
    // A job cancelled with every tile in is finished by assembly.
    state.assemble_complete_jobs();
    state.work_available();
    Ok(Json(info))
}

/// Changes a job after submission: its priority.
#[utoipa::path(patch, path = "/v1/jobs/{id}", params(("id" = u64, Path, description = "job id")),
    request_body = JobPatch,
    responses((status = 200, body = JobInfo), (status = 400, body = ApiError),
              (status = 404, body = ApiError)))]
async fn patch_job(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
    JsonBody(patch): JsonBody<JobPatch>,
) -> Result<Json<JobInfo>, Error> {
    let priority = patch.priority;
    let info = state
        .with_ledger(move |l| l.set_priority(id, priority))
        .await?;
    state.work_available();
    Ok(Json(info))
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
    Ok(Json(state.with_ledger(move |l| l.cancel(id)).await?))
}

/// The query of `DELETE /v1/jobs/{id}`.
#[derive(Debug, Default, Deserialize, utoipa::IntoParams)]
#[into_params(parameter_in = Query)]
#[serde(deny_unknown_fields)]
struct DeleteQuery {
    /// Delete a job that has not finished (it is cancelled first).
    #[serde(default)]
    force: bool,
}

/// Deletes a job: its tiles, image files and rows. A job that has not finished is refused
/// (409) unless `?force=true`.
#[utoipa::path(delete, path = "/v1/jobs/{id}",
    params(("id" = u64, Path, description = "job id"), DeleteQuery),
    responses((status = 204), (status = 400, body = ApiError), (status = 404, body = ApiError),
              (status = 409, body = ApiError)))]
async fn delete_job(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
    query: Result<Query<DeleteQuery>, QueryRejection>,
) -> Result<StatusCode, Error> {
    let Query(query) = query.map_err(|e| Error::BadRequest(format!("query: {}", e.body_text())))?;
    let force = query.force;
    state.with_ledger(move |l| l.delete(id, force)).await?;
    // The job is gone for every request from here on. An upload still writing into its
    // directory removes it again when it finds the job gone, so a failed removal (a file
    // appearing meanwhile) is logged, not answered as a failure of the delete.
    if let Err(e) = state.remove_job_files(id).await {
        tracing::warn!(job = id, error = %e, "removing the files of a deleted job failed");
    }
    Ok(StatusCode::NO_CONTENT)
}

/// The final EXR, once every tile is in; for a cancelled job, the EXR of its finished tiles
/// (the missing ones transparent black, alpha 0; `spindle.tiles_done` = `N of M` in the header),
/// made on request with the digest of its bytes.
#[utoipa::path(get, path = "/v1/jobs/{id}/image.exr", params(("id" = u64, Path, description = "job id")),
    responses((status = 200, content_type = "image/x-exr", body = Vec<u8>),
              (status = 404, body = ApiError), (status = 409, body = ApiError)))]
async fn image_exr(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<Response, Error> {
    let cancelled = {
        let ledger = state.ledger();
        let job = ledger.job(id)?;
        match job.state {
            JobState::Done => None,
            JobState::Cancelled => Some((
                job.spec.clone(),
                job.stats,
                job.provenance.clone(),
                ledger.latest_results(id)?,
            )),
            _ => {
                return Err(Error::Conflict(format!(
                    "job {id} is {} ({} of {} tiles); the image is ready when the job is done \
                     (or, its finished tiles, once it is cancelled)",
                    job.state.as_str(),
                    job.tiles_done,
                    job.tiles_total
                )));
            }
        }
    };
    let (bytes, sha256) = match cancelled {
        None => final_image(&state, id).await?,
        Some((spec, stats, provenance, tiles)) => {
            let store = state.tile_store().clone();
            tokio::task::spawn_blocking(move || {
                use sha2::Digest;
                let facts = assemble::JobFacts {
                    stats: &stats,
                    provenance: provenance.as_deref(),
                    passes: None,
                    render_seconds: None,
                };
                let bytes = assemble::partial(&store, id, &spec, &tiles, &facts)?;
                let sha256 = sha2::Sha256::digest(&bytes).to_vec();
                anyhow::Ok((bytes, sha256))
            })
            .await
            .map_err(anyhow::Error::from)??
        }
    };
    let digest = base64::engine::general_purpose::STANDARD.encode(&sha256);
    let hex: String = sha256.iter().map(|b| format!("{b:02x}")).collect();
    Ok((
        [
            (header::CONTENT_TYPE, "image/x-exr".to_string()),
            (header::ETAG, format!("\"{hex}\"")),
            (
                HeaderName::from_static("repr-digest"),
                format!("sha-256=:{digest}:"),
            ),
        ],
        bytes,
    )
        .into_response())
}

/// A done job's EXR and the SHA-256 of its bytes, checked against the digest recorded when it
/// was written: bytes changed on disk are never served (500 naming the job). A job done before
/// digests were recorded is served as read.
async fn final_image(state: &AppState, id: u64) -> Result<(Vec<u8>, Vec<u8>), Error> {
    let recorded = state.ledger().job(id)?.image_sha256.clone();
    let path = state.tile_store().image_path(id);
    tokio::task::spawn_blocking(move || {
        use sha2::Digest;
        let bytes = std::fs::read(&path).map_err(|e| {
            tracing::error!(job = id, path = %path.display(), error = %e, "reading a job's image failed");
            Error::Damaged(format!("the image of job {id} cannot be read on the coordinator"))
        })?;
        let sha256 = sha2::Sha256::digest(&bytes).to_vec();
        let hex: String = sha256.iter().map(|b| format!("{b:02x}")).collect();
        if let Some(recorded) = recorded
            && recorded != hex
        {
            tracing::error!(job = id, path = %path.display(), %recorded, actual = %hex,
                "a job's image changed on disk since it was written; refusing to serve it");
            return Err(Error::Damaged(format!(
                "the image of job {id} is damaged on the coordinator's disk (its SHA-256 is not \
                 the one recorded when it was written); it is not served — render the job again"
            )));
        }
        Ok((bytes, sha256))
    })
    .await
    .map_err(anyhow::Error::from)?
}

/// A PNG preview of the tiles received so far: each tile's latest result (for a job with a
/// time budget, a tile's previous pass until its current pass is in), black where none is.
#[utoipa::path(get, path = "/v1/jobs/{id}/image.png", params(("id" = u64, Path, description = "job id")),
    responses((status = 200, content_type = "image/png", body = Vec<u8>),
              (status = 404, body = ApiError)))]
async fn image_png(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<Response, Error> {
    let (spec, done, tiles) = {
        let ledger = state.ledger();
        let job = ledger.job(id)?;
        let done = job.state == JobState::Done;
        // Each tile's latest result: a budgeted job's previous pass until the current one's is in.
        (job.spec.clone(), done, ledger.latest_results(id)?)
    };
    // A done job's tiles are gone: its preview is made from its (checked) image.
    let exr = if done {
        Some(final_image(&state, id).await?.0)
    } else {
        None
    };
    let store = state.tile_store().clone();
    let png = tokio::task::spawn_blocking(move || {
        if let Some(exr) = exr {
            let image = spindle_common::image::Image::from_exr_bytes(&exr).map_err(|e| {
                tracing::error!(job = id, error = %e, "decoding the image of a done job failed");
                anyhow::anyhow!("the image of job {id} cannot be decoded")
            })?;
            return Ok(image.to_png_preview_bytes()?);
        }
        assemble::preview_png(&store, id, &spec, &tiles)
    })
    .await
    .map_err(anyhow::Error::from)??;
    Ok(([(header::CONTENT_TYPE, "image/png")], png).into_response())
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
