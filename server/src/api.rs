//! The HTTP routes: one table of (path, method, role, handler), the router built from it, and
//! the OpenAPI document generated from the same handlers.
//!
//! The route table is the single list of what the coordinator serves; the router is built from
//! it and a test checks that the OpenAPI document lists exactly its routes. The route shapes
//! are documented in `spindle_common::protocol`.

use std::time::Duration;

use axum::Json;
use axum::body::Body;
use axum::extract::{DefaultBodyLimit, Request, State};
use axum::http::{HeaderMap, Method, StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::{MethodRouter, delete, get, post, put};
use axum::{RequestExt, Router};
use spindle_common::protocol::{
    ApiError, AssetStored, Heartbeat, HeartbeatAck, IDEMPOTENCY_KEY_HEADER, JobInfo, JobList,
    JobSpec, Lease, LeaseRequest, MAX_LEASE_WAIT_MS, MissingAssetsRequest, MissingAssetsResponse,
    RegisterWorker, SubmitJob, TileAck, TileFailure, TileOutcome, TileUpload, WorkerRegistered,
    is_hash, pixel_hash,
};
use spindle_common::scene::Shape;
use tokio::time::Instant;
use utoipa::OpenApi;

use crate::AppState;
use crate::assemble;
use crate::auth::Role;
use crate::error::Error;
use crate::extract::{ApiPath, JsonBody, RawBody, parse_json};
use crate::jobs::NewJob;
use crate::lease::UploadPlan;
use crate::limits::Limits;

/// One route of the API.
pub struct Route {
    pub path: &'static str,
    pub method: Method,
    pub role: Role,
    pub handler: MethodRouter<AppState>,
}

fn route(path: &'static str, method: Method, role: Role, handler: MethodRouter<AppState>) -> Route {
    Route {
        path,
        method,
        role,
        handler,
    }
}

/// Every route the coordinator serves.
pub fn routes(limits: &Limits) -> Vec<Route> {
    use Role::{Client, Public, Worker};
    vec![
        route("/healthz", Method::GET, Public, get(healthz)),
        route("/readyz", Method::GET, Public, get(readyz)),
        route("/v1/openapi.json", Method::GET, Public, get(openapi_json)),
        route(
            "/v1/assets/missing",
            Method::POST,
            Client,
            post(missing_assets),
        ),
        route(
            "/v1/assets/{hash}",
            Method::PUT,
            Client,
            put(put_asset).layer(DefaultBodyLimit::max(limits.max_asset_bytes)),
        ),
        route("/v1/assets/{hash}", Method::GET, Worker, get(get_asset)),
        route("/v1/jobs", Method::POST, Client, post(submit_job)),
        route("/v1/jobs", Method::GET, Client, get(list_jobs)),
        route("/v1/jobs/{id}", Method::GET, Client, get(get_job)),
        route("/v1/jobs/{id}", Method::DELETE, Client, delete(delete_job)),
        route(
            "/v1/jobs/{id}/cancel",
            Method::POST,
            Client,
            post(cancel_job),
        ),
        route(
            "/v1/jobs/{id}/image.exr",
            Method::GET,
            Client,
            get(image_exr),
        ),
        route(
            "/v1/jobs/{id}/image.png",
            Method::GET,
            Client,
            get(image_png),
        ),
        route("/v1/workers", Method::POST, Worker, post(register_worker)),
        route("/v1/workers/{id}/lease", Method::POST, Worker, post(lease)),
        route("/v1/jobs/{id}/spec", Method::GET, Worker, get(job_spec)),
        route(
            "/v1/leases/{job}/{tile}/heartbeat",
            Method::POST,
            Worker,
            post(heartbeat),
        ),
        route(
            "/v1/jobs/{job}/tiles/{tile}",
            Method::PUT,
            Worker,
            put(upload_tile).layer(DefaultBodyLimit::max(limits.max_tile_upload_bytes)),
        ),
        route(
            "/v1/leases/{job}/{tile}/fail",
            Method::POST,
            Worker,
            post(fail_tile),
        ),
    ]
}

/// The OpenAPI document of the routes above.
#[derive(OpenApi)]
#[openapi(
    info(
        title = "spindle coordinator",
        description = "Jobs, assets, leases and tiles of a spindle render farm. Client routes \
                       take `Authorization: Bearer $SPINDLE_TOKEN`, worker routes \
                       `Authorization: Bearer $SPINDLE_WORKER_TOKEN`. Every error body is \
                       `{\"error\": \"...\"}`."
    ),
    paths(
        healthz, readyz, openapi_json, missing_assets, put_asset, get_asset, submit_job,
        list_jobs, get_job, delete_job, cancel_job, image_exr, image_png, register_worker,
        lease, job_spec, heartbeat, upload_tile, fail_tile
    ),
    modifiers(&BearerTokens)
)]
pub struct ApiDoc;

struct BearerTokens;

impl utoipa::Modify for BearerTokens {
    fn modify(&self, openapi: &mut utoipa::openapi::OpenApi) {
        use utoipa::openapi::security::{HttpAuthScheme, HttpBuilder, SecurityScheme};
        let components = openapi.components.get_or_insert_with(Default::default);
        for name in ["client_token", "worker_token"] {
            components.add_security_scheme(
                name,
                SecurityScheme::Http(HttpBuilder::new().scheme(HttpAuthScheme::Bearer).build()),
            );
        }
    }
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
    state.farm().check_database()?;
    Ok("ready")
}

/// This document.
#[utoipa::path(get, path = "/v1/openapi.json", responses((status = 200, body = Object)))]
async fn openapi_json() -> Json<utoipa::openapi::OpenApi> {
    Json(ApiDoc::openapi())
}

/// Which of these asset hashes must still be uploaded?
#[utoipa::path(post, path = "/v1/assets/missing", request_body = MissingAssetsRequest,
    security(("client_token" = [])),
    responses((status = 200, body = MissingAssetsResponse), (status = 400, body = ApiError)))]
async fn missing_assets(
    State(state): State<AppState>,
    JsonBody(request): JsonBody<MissingAssetsRequest>,
) -> Result<Json<MissingAssetsResponse>, Error> {
    let max = state.config().limits.max_hashes_per_query;
    if request.hashes.len() > max {
        return Err(Error::BadRequest(format!(
            "hashes: {} hashes, at most {max} per request",
            request.hashes.len()
        )));
    }
    let mut missing = Vec::new();
    for (i, hash) in request.hashes.iter().enumerate() {
        if !is_hash(hash) {
            return Err(Error::BadRequest(format!(
                "hashes[{i}]: {hash:?} is not a blake3 hash (64 lowercase hex digits)"
            )));
        }
        if !state.assets().has(hash)? && !missing.contains(hash) {
            missing.push(hash.clone());
        }
    }
    Ok(Json(MissingAssetsResponse { missing }))
}

/// Uploads an asset; the body's blake3 hash must be `hash`.
#[utoipa::path(put, path = "/v1/assets/{hash}",
    params(("hash" = String, Path, description = "blake3 of the body, lowercase hex")),
    request_body(content = Vec<u8>, content_type = "application/octet-stream"),
    security(("client_token" = [])),
    responses((status = 200, body = AssetStored), (status = 400, body = ApiError),
              (status = 413, body = ApiError)))]
async fn put_asset(
    State(state): State<AppState>,
    ApiPath(hash): ApiPath<String>,
    request: Request,
) -> Result<Json<AssetStored>, Error> {
    if state.assets().has(&hash)? {
        let bytes = tokio::fs::metadata(state.assets().file(&hash)?)
            .await?
            .len();
        return Ok(Json(AssetStored { hash, bytes }));
    }
    let body: Body = request.into_limited_body();
    let bytes = state.assets().store(&hash, body).await?;
    tracing::info!(%hash, bytes, "asset stored");
    Ok(Json(AssetStored { hash, bytes }))
}

/// Downloads an asset.
#[utoipa::path(get, path = "/v1/assets/{hash}",
    params(("hash" = String, Path, description = "blake3 of the asset, lowercase hex")),
    security(("worker_token" = [])),
    responses((status = 200, content_type = "application/octet-stream", body = Vec<u8>),
              (status = 404, body = ApiError)))]
async fn get_asset(
    State(state): State<AppState>,
    ApiPath(hash): ApiPath<String>,
) -> Result<Response, Error> {
    let bytes = state.assets().read(&hash).await?;
    Ok(([(header::CONTENT_TYPE, "application/octet-stream")], bytes).into_response())
}

/// Submits a job. With an `Idempotency-Key` header, a retry returns the job the first request
/// created (200) instead of a new one (201).
#[utoipa::path(post, path = "/v1/jobs", request_body = SubmitJob,
    params(("Idempotency-Key" = Option<String>, Header, description = "makes retries safe")),
    security(("client_token" = [])),
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
    let limits = &state.config().limits;
    submit.scene.validate().map_err(|e| {
        Error::BadRequest(if e.path == "." {
            format!("scene: {}", e.problem)
        } else {
            format!("scene.{e}")
        })
    })?;
    limits
        .check_film(&submit.scene, submit.tile_size)
        .map_err(Error::BadRequest)?;
    for (path, hash) in &submit.assets {
        if !is_hash(hash) {
            return Err(Error::BadRequest(format!(
                "assets.{path}: {hash:?} is not a blake3 hash (64 lowercase hex digits)"
            )));
        }
    }
    // Count each OBJ asset's triangles (reading stored files, never client paths).
    let mut obj_triangles = std::collections::HashMap::new();
    for (i, object) in submit.scene.objects.iter().enumerate() {
        if let Shape::Obj { path } = &object.shape {
            let Some(hash) = submit.assets.get(path) else {
                return Err(Error::BadRequest(format!(
                    "scene.objects[{i}].shape.path: no asset given for {path:?} (add it to `assets`)"
                )));
            };
            let count = state
                .assets()
                .obj_triangles(hash)
                .await
                .map_err(|e| match e {
                    Error::BadRequest(m) => Error::BadRequest(format!("assets.{path}: {m}")),
                    other => other,
                })?;
            obj_triangles.insert(path.clone(), count);
        }
    }
    limits
        .check_triangles(&submit.scene, |path| {
            obj_triangles
                .get(path)
                .copied()
                .ok_or_else(|| format!("no asset given for {path:?}"))
        })
        .map_err(Error::BadRequest)?;

    let canonical = serde_json::to_vec(&submit).map_err(anyhow::Error::from)?;
    let new = NewJob {
        request_hash: blake3::hash(&canonical).to_hex().to_string(),
        spec: JobSpec {
            scene: submit.scene,
            assets: submit.assets,
            tile_size: submit.tile_size,
        },
        priority: submit.priority,
        idempotency_key: key,
    };
    let (info, created) = state.farm().submit(new, limits.max_active_jobs)?;
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
#[utoipa::path(get, path = "/v1/jobs", security(("client_token" = [])),
    responses((status = 200, body = JobList)))]
async fn list_jobs(State(state): State<AppState>) -> Json<JobList> {
    Json(JobList {
        jobs: state.farm().list(),
    })
}

/// A job's state and progress.
#[utoipa::path(get, path = "/v1/jobs/{id}", params(("id" = u64, Path, description = "job id")),
    security(("client_token" = [])),
    responses((status = 200, body = JobInfo), (status = 404, body = ApiError)))]
async fn get_job(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<Json<JobInfo>, Error> {
    let info = state.farm().job(id)?.info(crate::jobs::now_ms());
    Ok(Json(info))
}

/// Cancels a job; its tiles are no longer handed out and late uploads are refused.
#[utoipa::path(post, path = "/v1/jobs/{id}/cancel", params(("id" = u64, Path, description = "job id")),
    security(("client_token" = [])),
    responses((status = 200, body = JobInfo), (status = 404, body = ApiError),
              (status = 409, body = ApiError)))]
async fn cancel_job(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<Json<JobInfo>, Error> {
    Ok(Json(state.farm().cancel(id)?))
}

/// Deletes a job and its files.
#[utoipa::path(delete, path = "/v1/jobs/{id}", params(("id" = u64, Path, description = "job id")),
    security(("client_token" = [])),
    responses((status = 204), (status = 404, body = ApiError)))]
async fn delete_job(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<StatusCode, Error> {
    state.farm().delete(id)?;
    state.remove_job_files(id).await?;
    Ok(StatusCode::NO_CONTENT)
}

/// The final EXR, once every tile is in.
#[utoipa::path(get, path = "/v1/jobs/{id}/image.exr", params(("id" = u64, Path, description = "job id")),
    security(("client_token" = [])),
    responses((status = 200, content_type = "image/x-exr", body = Vec<u8>),
              (status = 404, body = ApiError), (status = 409, body = ApiError)))]
async fn image_exr(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<Response, Error> {
    {
        let farm = state.farm();
        let job = farm.job(id)?;
        if job.state != spindle_common::protocol::JobState::Done {
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
    security(("client_token" = [])),
    responses((status = 200, content_type = "image/png", body = Vec<u8>),
              (status = 404, body = ApiError)))]
async fn image_png(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<Response, Error> {
    let (spec, tiles) = {
        let farm = state.farm();
        (farm.job(id)?.spec.clone(), farm.done_tiles(id)?)
    };
    let store = state.tile_store().clone();
    let png = tokio::task::spawn_blocking(move || assemble::preview_png(&store, id, &spec, &tiles))
        .await
        .map_err(anyhow::Error::from)??;
    Ok(([(header::CONTENT_TYPE, "image/png")], png).into_response())
}

/// Registers a worker.
#[utoipa::path(post, path = "/v1/workers", request_body = RegisterWorker,
    security(("worker_token" = [])),
    responses((status = 200, body = WorkerRegistered), (status = 400, body = ApiError)))]
async fn register_worker(
    State(state): State<AppState>,
    JsonBody(request): JsonBody<RegisterWorker>,
) -> Result<Json<WorkerRegistered>, Error> {
    if request.name.is_empty() || request.name.len() > 200 {
        return Err(Error::BadRequest("name: must be 1 to 200 bytes".into()));
    }
    if request.threads == 0 {
        return Err(Error::BadRequest("threads: must be at least 1".into()));
    }
    let worker_id = state
        .farm()
        .register_worker(&request.name, request.threads)?;
    Ok(Json(WorkerRegistered { worker_id }))
}

/// Long-polls for a tile: 200 with a lease, or 204 when none came up within the wait.
#[utoipa::path(post, path = "/v1/workers/{id}/lease", params(("id" = u64, Path, description = "worker id")),
    request_body(content = Option<LeaseRequest>, description = "optional; an empty body means the defaults"),
    security(("worker_token" = [])),
    responses((status = 200, body = Lease), (status = 204, description = "no work right now"),
              (status = 404, body = ApiError)))]
async fn lease(
    State(state): State<AppState>,
    ApiPath(worker): ApiPath<u64>,
    RawBody(body): RawBody,
) -> Result<Response, Error> {
    let request: LeaseRequest = if body.iter().all(u8::is_ascii_whitespace) {
        LeaseRequest::default()
    } else {
        parse_json(&body)?
    };
    let wait = request
        .wait_ms
        .unwrap_or(MAX_LEASE_WAIT_MS)
        .min(MAX_LEASE_WAIT_MS);
    let deadline = Instant::now() + Duration::from_millis(wait);
    loop {
        let notified = state.work_notified();
        tokio::pin!(notified);
        notified.as_mut().enable();
        let (lease, next_expiry) = {
            let mut farm = state.farm();
            (farm.try_lease(worker, Instant::now())?, farm.next_expiry())
        };
        if let Some(lease) = lease {
            return Ok(Json(lease).into_response());
        }
        if Instant::now() >= deadline || state.is_shutting_down() {
            return Ok(StatusCode::NO_CONTENT.into_response());
        }
        let wake = next_expiry.map_or(deadline, |e| e.min(deadline));
        tokio::select! {
            _ = &mut notified => {}
            _ = tokio::time::sleep_until(wake) => {}
            _ = state.shutdown_signal() => return Ok(StatusCode::NO_CONTENT.into_response()),
        }
    }
}

/// What a worker needs to render a job's tiles.
#[utoipa::path(get, path = "/v1/jobs/{id}/spec", params(("id" = u64, Path, description = "job id")),
    security(("worker_token" = [])),
    responses((status = 200, body = JobSpec), (status = 404, body = ApiError)))]
async fn job_spec(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<u64>,
) -> Result<Json<JobSpec>, Error> {
    let spec = state.farm().job(id)?.spec.clone();
    Ok(Json((*spec).clone()))
}

/// Renews a lease.
#[utoipa::path(post, path = "/v1/leases/{job}/{tile}/heartbeat",
    params(("job" = u64, Path, description = "job id"), ("tile" = u32, Path, description = "tile index")),
    request_body = Heartbeat, security(("worker_token" = [])),
    responses((status = 200, body = HeartbeatAck), (status = 404, body = ApiError),
              (status = 409, body = ApiError)))]
async fn heartbeat(
    State(state): State<AppState>,
    ApiPath((job, tile)): ApiPath<(u64, u32)>,
    JsonBody(hb): JsonBody<Heartbeat>,
) -> Result<Json<HeartbeatAck>, Error> {
    Ok(Json(state.farm().heartbeat(
        job,
        tile,
        &hb,
        Instant::now(),
    )?))
}

/// Uploads a rendered tile.
#[utoipa::path(put, path = "/v1/jobs/{job}/tiles/{tile}",
    params(("job" = u64, Path, description = "job id"), ("tile" = u32, Path, description = "tile index")),
    request_body = TileUpload, security(("worker_token" = [])),
    responses((status = 200, body = TileAck), (status = 400, body = ApiError),
              (status = 404, body = ApiError), (status = 409, body = ApiError),
              (status = 413, body = ApiError)))]
async fn upload_tile(
    State(state): State<AppState>,
    ApiPath((job, tile)): ApiPath<(u64, u32)>,
    RawBody(body): RawBody,
) -> Result<Json<TileAck>, Error> {
    // Parsing and hashing up to megabytes of floats is CPU work: off the runtime.
    let upload = tokio::task::spawn_blocking(move || {
        let upload: TileUpload = parse_json(&body)?;
        let actual = pixel_hash(&upload.pixels);
        if actual != upload.hash {
            return Err(Error::BadRequest(format!(
                "hash: the pixels hash to {actual}, not {}",
                upload.hash
            )));
        }
        Ok(upload)
    })
    .await
    .map_err(anyhow::Error::from)??;

    if state.farm().check_upload(job, tile, &upload)? == UploadPlan::Duplicate {
        return Ok(Json(TileAck {
            outcome: TileOutcome::Duplicate,
        }));
    }
    let store = state.tile_store().clone();
    let upload = tokio::task::spawn_blocking(move || {
        store
            .write(job, tile, &upload.hash, &upload.pixels)
            .map(|()| upload)
    })
    .await
    .map_err(anyhow::Error::from)??;
    let recorded = state.farm().record_upload(job, tile, &upload);
    let (outcome, complete) = match recorded {
        Ok(r) => r,
        Err(Error::NotFound(m)) => {
            // Deleted while the file was written: do not leave the file behind.
            state.remove_job_files(job).await?;
            return Err(Error::NotFound(m));
        }
        Err(e) => return Err(e),
    };
    if complete {
        state.assemble_complete_jobs();
    }
    Ok(Json(TileAck { outcome }))
}

/// Reports that a tile could not be rendered.
#[utoipa::path(post, path = "/v1/leases/{job}/{tile}/fail",
    params(("job" = u64, Path, description = "job id"), ("tile" = u32, Path, description = "tile index")),
    request_body = TileFailure, security(("worker_token" = [])),
    responses((status = 204), (status = 404, body = ApiError), (status = 409, body = ApiError)))]
async fn fail_tile(
    State(state): State<AppState>,
    ApiPath((job, tile)): ApiPath<(u64, u32)>,
    JsonBody(mut failure): JsonBody<TileFailure>,
) -> Result<StatusCode, Error> {
    if failure.reason.len() > 2000 {
        let mut end = 2000;
        while !failure.reason.is_char_boundary(end) {
            end -= 1;
        }
        failure.reason.truncate(end);
    }
    state.farm().fail_tile(job, tile, &failure)?;
    state.work_available();
    Ok(StatusCode::NO_CONTENT)
}

/// The answer to a path no route matches.
pub async fn no_route(method: Method, uri: axum::http::Uri) -> Error {
    Error::NotFound(format!("no route for {method} {}", uri.path()))
}

/// The answer to a known path with the wrong method.
pub async fn wrong_method(method: Method, uri: axum::http::Uri) -> Response {
    let body = Json(ApiError {
        error: format!("{method} is not allowed on {}", uri.path()),
    });
    (StatusCode::METHOD_NOT_ALLOWED, body).into_response()
}

/// Builds the router from [`routes`].
pub fn router(state: AppState) -> Router {
    let limits = state.config().limits.clone();
    let mut router = Router::new();
    for r in routes(&limits) {
        let auth =
            axum::middleware::from_fn_with_state((state.clone(), r.role), crate::auth::require);
        router = router.route(r.path, r.handler.layer(auth));
    }
    router
        .fallback(no_route)
        .method_not_allowed_fallback(wrong_method)
        .layer(DefaultBodyLimit::max(limits.max_json_bytes))
        .layer(tower_http::timeout::RequestBodyTimeoutLayer::new(
            Duration::from_secs(60),
        ))
        .layer(tower_http::trace::TraceLayer::new_for_http())
        .with_state(state)
}
