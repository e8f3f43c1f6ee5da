//! Bearer tokens: one for clients (`SPINDLE_TOKEN`), one for workers (`SPINDLE_WORKER_TOKEN`);
//! and, on the routes of a registered worker, that worker's own secret.
//!
//! Each route belongs to one [`Role`]; a middleware checks the `Authorization: Bearer …`
//! header against that role's token before the handler runs. A role without a configured token
//! is open — [`crate::config::Config::check_listen_address`] allows that only on loopback. The
//! worker secret ([`crate::worker_secret`]) is required whether or not tokens are configured.

use axum::extract::{Request, State};
use axum::http::header::AUTHORIZATION;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use spindle_common::protocol::WORKER_SECRET_HEADER;

use crate::AppState;
use crate::error::Error;
use crate::worker_secret::WorkerIdentity;

/// Who may call a route.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// Anyone (health, readiness, the API document).
    Public,
    /// Users submitting and fetching jobs.
    Client,
    /// A worker process not registered yet: the registration route only (worker token).
    NewWorker,
    /// A registered worker: the worker token and its worker secret, which the middleware turns
    /// into the request's [`WorkerIdentity`].
    Worker,
}

/// Middleware: lets the request through when it carries the token of `role`.
pub async fn require(
    State((state, role)): State<(AppState, Role)>,
    request: Request,
    next: Next,
) -> Response {
    let expected = match role {
        Role::Public => None,
        Role::Client => state.config().client_token.as_deref(),
        Role::Worker | Role::NewWorker => state.config().worker_token.as_deref(),
    };
    if let Some(expected) = expected {
        let given = request
            .headers()
            .get(AUTHORIZATION)
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.strip_prefix("Bearer "));
        match given {
            None => {
                return Error::Unauthorized("missing bearer token (Authorization: Bearer …)")
                    .into_response();
            }
            Some(given) if !same(given.as_bytes(), expected.as_bytes()) => {
                return Error::Unauthorized("wrong token for this route").into_response();
            }
            Some(_) => {}
        }
    }
    let mut request = request;
    if role == Role::Worker {
        let presented = request
            .headers()
            .get(WORKER_SECRET_HEADER)
            .map(|v| v.to_str().unwrap_or(""));
        let identity = state.ledger().authenticate(presented);
        match identity {
            Ok(identity) => {
                request.extensions_mut().insert::<WorkerIdentity>(identity);
            }
            Err(e) => return e.into_response(),
        }
    }
    next.run(request).await
}

/// Compares in time independent of the inputs' contents and lengths, so a token cannot be
/// guessed a byte at a time, nor its length learnt, from response times: both sides are hashed
/// to 32 bytes, compared with `constant_time_eq`.
fn same(given: &[u8], expected: &[u8]) -> bool {
    let given = blake3::hash(given);
    let expected = blake3::hash(expected);
    constant_time_eq::constant_time_eq_32(given.as_bytes(), expected.as_bytes())
}

#[cfg(test)]
mod tests {
    #[test]
    fn comparison() {
        assert!(super::same(b"abc", b"abc"));
        assert!(!super::same(b"abc", b"abd"));
        assert!(!super::same(b"abc", b"abcd"));
        assert!(!super::same(b"abc ", b"abc"), "no trimming");
    }
}
