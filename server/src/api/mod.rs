//! The HTTP routes, split by resource, and the OpenAPI document built from the same
//! declarations.
//!
//! Each handler carries its path, method and responses in one `#[utoipa::path]` attribute;
//! each resource module lists its handlers with the [`Role`] that may call them, and
//! [`router`] registers every listed handler with `utoipa_axum`, which routes the path and
//! documents it in one step. So the router and the document cannot disagree, and a role is
//! written once: it selects both the bearer-token middleware and the document's security
//! requirement. One module per resource, whoever calls it (as crates.io's
//! `controllers/<resource>/`): `service` (health, readiness, the document), `assets`, `jobs`
//! (a job, its image, and its spec for workers), `tiles` (a job's tile map and a tile's
//! upload), `leases` (a worker's lease poll, heartbeat, failure report and previous pass),
//! `events` (the live event stream), `workers` (registration, the list, drain). The request
//! and response shapes are documented in `spindle_common::protocol`.

mod assets;
mod events;
mod jobs;
mod leases;
mod service;
mod tiles;
mod workers;

use std::sync::Arc;

use axum::extract::DefaultBodyLimit;
use axum::http::{Method, StatusCode, Uri};
use axum::response::{IntoResponse, Response};
use axum::{Extension, Json, Router};
use spindle_common::protocol::ApiError;
use utoipa::OpenApi;
use utoipa::openapi::path::{Operation, Paths};
use utoipa::openapi::security::SecurityRequirement;
use utoipa_axum::router::{OpenApiRouter, UtoipaMethodRouter};

use crate::AppState;
use crate::auth::{self, Role};
use crate::error::Error;
use crate::throttle;

/// Documented handlers (one `routes!` each) with the role that may call them.
type Declared = Vec<(Role, UtoipaMethodRouter<AppState>)>;

/// The document's parts that are not routes: title, description and the token schemes.
#[derive(OpenApi)]
#[openapi(
    info(
        title = "spindle coordinator",
        description = "Jobs, assets, leases and tiles of a spindle render farm. Client routes \
                       take `Authorization: Bearer $SPINDLE_TOKEN`, worker routes \
                       `Authorization: Bearer $SPINDLE_WORKER_TOKEN`; every worker route but \
                       registration also the worker's own secret from POST /v1/workers in \
                       `Spindle-Worker-Secret` (403 when missing or not the worker's). Every \
                       error body is \
                       `{\"error\": \"...\"}`. Any route answers 408 (and closes the \
                       connection) when its request outlasts the request deadline (300 s by \
                       default) or its body pauses past the header deadline (10 s); headers \
                       not complete within the header deadline close the connection. Client \
                       routes answer 429 past --client-rate-per-s requests a second per \
                       address (50, bursts of 100); every 429 and 503 carries Retry-After."
    ),
    modifiers(&BearerTokens),
    components(schemas(
        spindle_common::protocol::FarmEvent,
        spindle_common::protocol::JobOrder
    ))
)]
struct ApiDoc;

struct BearerTokens;

impl utoipa::Modify for BearerTokens {
    fn modify(&self, openapi: &mut utoipa::openapi::OpenApi) {
        use utoipa::openapi::security::{
            ApiKey, ApiKeyValue, HttpAuthScheme, HttpBuilder, SecurityScheme,
        };
        let components = openapi.components.get_or_insert_with(Default::default);
        for name in [CLIENT_TOKEN, WORKER_TOKEN] {
            components.add_security_scheme(
                name,
                SecurityScheme::Http(HttpBuilder::new().scheme(HttpAuthScheme::Bearer).build()),
            );
        }
        components.add_security_scheme(
            WORKER_SECRET,
            SecurityScheme::ApiKey(ApiKey::Header(ApiKeyValue::with_description(
                "Spindle-Worker-Secret",
                "the worker_secret of the worker's registration (POST /v1/workers)",
            ))),
        );
    }
}

const CLIENT_TOKEN: &str = "client_token";
const WORKER_TOKEN: &str = "worker_token";
const WORKER_SECRET: &str = "worker_secret";

/// The document's names of the credentials `role` needs, all of them together.
fn security_schemes(role: Role) -> &'static [&'static str] {
    match role {
        Role::Public => &[],
        Role::Client => &[CLIENT_TOKEN],
        Role::NewWorker => &[WORKER_TOKEN],
        Role::Worker => &[WORKER_TOKEN, WORKER_SECRET],
    }
}

/// An error answer of the document: `description`, with an [`ApiError`] body.
fn error_response(description: &str) -> utoipa::openapi::Response {
    use utoipa::openapi::{ContentBuilder, Ref, ResponseBuilder};
    ResponseBuilder::new()
        .description(description)
        .content(
            "application/json",
            ContentBuilder::new()
                .schema(Some(Ref::from_schema_name("ApiError")))
                .build(),
        )
        .build()
}

/// Marks every operation in `paths` as needing the credentials of `role`, and documents the
/// answers to missing or wrong ones (401 for a token, 403 for a worker secret).
fn require_token(paths: &mut Paths, role: Role) {
    let schemes = security_schemes(role);
    let Some((first, rest)) = schemes.split_first() else {
        return;
    };
    let mut requirement = SecurityRequirement::new(*first, Vec::<String>::new());
    for scheme in rest {
        requirement = requirement.add(*scheme, Vec::<String>::new());
    }
    for operation in operations_mut(paths) {
        operation.security = Some(vec![requirement.clone()]);
        let responses = &mut operation.responses.responses;
        responses
            .entry("401".into())
            .or_insert_with(|| error_response("missing or wrong bearer token").into());
        if role == Role::Worker {
            responses.entry("403".into()).or_insert_with(|| {
                error_response(
                    "missing or wrong worker secret, or a worker id that is not the secret's \
                     worker",
                )
                .into()
            });
        }
    }
}

/// Every operation of `paths` (the methods the coordinator serves).
fn operations_mut(paths: &mut Paths) -> impl Iterator<Item = &mut Operation> {
    paths.paths.values_mut().flat_map(|item| {
        [
            &mut item.get,
            &mut item.put,
            &mut item.post,
            &mut item.delete,
            &mut item.patch,
        ]
        .into_iter()
        .flatten()
    })
}

/// Documents the 400 every operation with input can answer: a path parameter, query, header or
/// body that does not parse or is out of range (the extractors' errors, [`crate::extract`]).
fn document_bad_request(paths: &mut Paths) {
    for operation in operations_mut(paths) {
        let has_input = operation.request_body.is_some()
            || operation.parameters.as_ref().is_some_and(|p| !p.is_empty());
        if has_input {
            operation
                .responses
                .responses
                .entry("400".into())
                .or_insert_with(|| {
                    error_response(
                        "a path parameter, query, header or body is malformed or out of range \
                         (the message names it)",
                    )
                    .into()
                });
        }
    }
}

/// Every route the coordinator serves and the OpenAPI document of them.
fn routes_and_document(state: &AppState) -> (Router<AppState>, utoipa::openapi::OpenApi) {
    let limits = &state.config().limits;
    let declared: Declared = [
        service::routes(),
        assets::routes(limits),
        jobs::routes(),
        tiles::routes(),
        events::routes(),
        workers::routes(),
        leases::routes(),
    ]
    .into_iter()
    .flatten()
    .collect();
    let mut api = OpenApiRouter::with_openapi(ApiDoc::openapi());
    for (role, (schemas, mut paths, handler)) in declared {
        require_token(&mut paths, role);
        document_bad_request(&mut paths);
        let auth = axum::middleware::from_fn_with_state((state.clone(), role), auth::require);
        // The public routes with large answers (the API document, the metrics) are paced
        // like the client routes, so a client without a token cannot have them sent without
        // end; the probes are never paced.
        let probe = paths
            .paths
            .keys()
            .any(|p| p == "/healthz" || p == "/readyz");
        let handler = if role == Role::Client || (role == Role::Public && !probe) {
            let rate = axum::middleware::from_fn_with_state(state.clone(), throttle::client_rate);
            handler.layer(auth).layer(rate)
        } else {
            handler.layer(auth)
        };
        api = api.routes((schemas, paths, handler));
    }
    api.split_for_parts()
}

/// The answer to a path no route matches.
async fn no_route(method: Method, uri: Uri) -> Error {
    Error::NotFound(format!("no route for {method} {}", uri.path()))
}

/// The answer to a known path with the wrong method.
async fn wrong_method(method: Method, uri: Uri) -> Response {
    let body = Json(ApiError {
        error: format!("{method} is not allowed on {}", uri.path()),
    });
    (StatusCode::METHOD_NOT_ALLOWED, body).into_response()
}

/// The answer to a request that outlived the request deadline.
async fn request_deadline(_: tower::BoxError) -> Error {
    Error::Timeout("request: not completed within the request deadline".into())
}

/// The coordinator's router: every declared route behind its role's token, JSON answers for
/// unknown paths and methods, then the body limit, the request deadline (408) and request
/// tracing.
pub fn router(state: AppState) -> Router {
    let max_json_bytes = state.config().limits.max_json_bytes;
    let timeouts = state.config().timeouts;
    let (routes, document) = routes_and_document(&state);
    routes
        .layer(Extension(Arc::new(document)))
        .fallback(no_route)
        .method_not_allowed_fallback(wrong_method)
        .layer(DefaultBodyLimit::max(max_json_bytes))
        // A body that pauses longer than the header deadline is abandoned (408)…
        .layer(tower_http::timeout::RequestBodyTimeoutLayer::new(
            timeouts.header,
        ))
        // …and so is a request whose body and handler together outlast the request deadline,
        // however steadily its bytes trickle in.
        .layer(
            tower::ServiceBuilder::new()
                .layer(axum::error_handling::HandleErrorLayer::new(
                    request_deadline,
                ))
                .layer(tower::timeout::TimeoutLayer::new(timeouts.request)),
        )
        .layer(
            tower_http::trace::TraceLayer::new_for_http()
                .make_span_with(|r: &axum::http::Request<_>| crate::logging::request_span(r)),
        )
        .layer(tower_http::request_id::PropagateRequestIdLayer::new(
            axum::http::HeaderName::from_static(crate::logging::REQUEST_ID),
        ))
        .layer(tower_http::request_id::SetRequestIdLayer::new(
            axum::http::HeaderName::from_static(crate::logging::REQUEST_ID),
            crate::logging::RequestIds,
        ))
        .with_state(state)
}
