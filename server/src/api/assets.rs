//! The asset routes: which hashes are missing, upload (clients) and download (workers).

use axum::Json;
use axum::RequestExt;
use axum::body::Body;
use axum::extract::{DefaultBodyLimit, Request, State};
use axum::http::header;
use axum::response::{IntoResponse, Response};
use spindle_common::protocol::{
    ApiError, AssetStored, MissingAssetsRequest, MissingAssetsResponse, is_hash,
};
use utoipa_axum::router::UtoipaMethodRouterExt;
use utoipa_axum::routes;

use super::Declared;
use crate::AppState;
use crate::auth::Role;
use crate::error::Error;
use crate::extract::{ApiPath, JsonBody};
use crate::limits::Limits;

pub(super) fn routes(limits: &Limits) -> Declared {
    vec![
        (Role::Client, routes!(missing_assets)),
        (
            Role::Client,
            routes!(put_asset).layer(DefaultBodyLimit::max(limits.max_asset_bytes)),
        ),
        (Role::Worker, routes!(get_asset)),
    ]
}

/// Which of these asset hashes must still be uploaded?
#[utoipa::path(post, path = "/v1/assets/missing", request_body = MissingAssetsRequest,
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
        if !state.assets().touch(hash)? && !missing.contains(hash) {
            missing.push(hash.clone());
        }
    }
    Ok(Json(MissingAssetsResponse { missing }))
}

/// Uploads an asset; the body's blake3 hash must be `hash`.
#[utoipa::path(put, path = "/v1/assets/{hash}",
    params(("hash" = String, Path, pattern = "^[0-9a-f]{64}$", description = "blake3 of the body, lowercase hex")),
    request_body(content = Vec<u8>, content_type = "application/octet-stream"),
    responses((status = 200, body = AssetStored), (status = 400, body = ApiError),
              (status = 413, body = ApiError)))]
async fn put_asset(
    State(state): State<AppState>,
    ApiPath(hash): ApiPath<String>,
    request: Request,
) -> Result<Json<AssetStored>, Error> {
    if state.assets().touch(&hash)? {
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
    params(("hash" = String, Path, pattern = "^[0-9a-f]{64}$", description = "blake3 of the asset, lowercase hex")),
    responses((status = 200, content_type = "application/octet-stream", body = Vec<u8>),
              (status = 404, body = ApiError)))]
async fn get_asset(
    State(state): State<AppState>,
    ApiPath(hash): ApiPath<String>,
) -> Result<Response, Error> {
    let bytes = state.assets().read(&hash).await?;
    Ok(([(header::CONTENT_TYPE, "application/octet-stream")], bytes).into_response())
}
