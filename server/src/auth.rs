//! Bearer tokens: one for clients (`SPINDLE_TOKEN`), one for workers (`SPINDLE_WORKER_TOKEN`).
//!
//! Each route belongs to one [`Role`]; a middleware checks the `Authorization: Bearer …`
//! header against that role's token before the handler runs. A role without a configured token
//! is open — [`crate::config::Config::check_listen_address`] allows that only on loopback.

use axum::extract::{Request, State};
use axum::http::header::AUTHORIZATION;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use crate::AppState;
use crate::error::Error;

/// Who may call a route.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// Anyone (health, readiness, the API document).
    Public,
    /// Users submitting and fetching jobs.
    Client,
    /// Worker processes.
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
        Role::Worker => state.config().worker_token.as_deref(),
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
