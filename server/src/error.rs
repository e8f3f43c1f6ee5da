//! The coordinator's one error type, and how each case becomes an HTTP status and a JSON body.
//!
//! Handlers return `Result<_, Error>`. Client mistakes carry a message naming the field or the
//! problem and are sent as [`ApiError`]; internal failures are logged with their cause and
//! answered with a bare "internal error", so no path or SQL text leaks to a client.

use axum::Json;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use spindle_common::protocol::ApiError;

/// Everything a request can fail with.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Malformed or invalid input (400).
    #[error("{0}")]
    BadRequest(String),
    /// Missing or wrong bearer token (401).
    #[error("{0}")]
    Unauthorized(&'static str),
    /// A worker secret that is missing, malformed or not the worker's (403).
    #[error("{0}")]
    Forbidden(String),
    /// No such job, tile, worker or asset (404).
    #[error("{0}")]
    NotFound(String),
    /// The request conflicts with the current state: a stale lease, a job not done yet (409).
    #[error("{0}")]
    Conflict(String),
    /// The worker was told to drain: it must take no more tiles and exit (410).
    #[error("{0}")]
    Gone(String),
    /// The body or the whole request did not arrive in time (408, and the connection closes).
    #[error("{0}")]
    Timeout(String),
    /// The body is larger than the route allows (413).
    #[error("{0}")]
    TooLarge(String),
    /// The body's `Content-Type` is not one the route reads (415).
    #[error("{0}")]
    UnsupportedMediaType(String),
    /// Too many jobs queued (429, `Retry-After: 10`).
    #[error("{0}")]
    TooMany(String),
    /// A caller over its rate or lease allowance (429, `Retry-After` the wait in whole seconds).
    #[error("{message}")]
    RateLimited {
        message: String,
        retry_after: std::time::Duration,
    },
    /// Stored data found damaged that cannot be served or rebuilt (500, with this message,
    /// which names no path).
    #[error("{0}")]
    Damaged(String),
    /// The coordinator is shutting down or not ready (503, `Retry-After: 5`).
    #[error("{0}")]
    Unavailable(&'static str),
    /// A failure of the coordinator itself (500; 507 when the cause is a full disk, see
    /// [`is_disk_full`]); the cause is logged, not sent.
    #[error("internal error: {0:#}")]
    Internal(#[from] anyhow::Error),
}

impl Error {
    /// The HTTP status this error is answered with.
    pub fn status(&self) -> StatusCode {
        match self {
            Error::BadRequest(_) => StatusCode::BAD_REQUEST,
            Error::Unauthorized(_) => StatusCode::UNAUTHORIZED,
            Error::Forbidden(_) => StatusCode::FORBIDDEN,
            Error::NotFound(_) => StatusCode::NOT_FOUND,
            Error::Conflict(_) => StatusCode::CONFLICT,
            Error::Gone(_) => StatusCode::GONE,
            Error::Timeout(_) => StatusCode::REQUEST_TIMEOUT,
            Error::TooLarge(_) => StatusCode::PAYLOAD_TOO_LARGE,
            Error::UnsupportedMediaType(_) => StatusCode::UNSUPPORTED_MEDIA_TYPE,
            Error::TooMany(_) | Error::RateLimited { .. } => StatusCode::TOO_MANY_REQUESTS,
            Error::Unavailable(_) => StatusCode::SERVICE_UNAVAILABLE,
            Error::Internal(cause) if is_disk_full(cause) => StatusCode::INSUFFICIENT_STORAGE,
            Error::Internal(_) | Error::Damaged(_) => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }

    /// How long a client should wait before trying again, for the statuses that say "later"
    /// (every 429 and 503 carries it as `Retry-After`).
    pub fn retry_after(&self) -> Option<std::time::Duration> {
        use std::time::Duration;
        match self {
            Error::TooMany(_) => Some(Duration::from_secs(10)),
            Error::RateLimited { retry_after, .. } => Some(*retry_after),
            Error::Unavailable(_) => Some(Duration::from_secs(5)),
            _ => None,
        }
    }
}

/// The answer to a request that failed for want of disk space.
pub const DISK_FULL: &str = "the coordinator's disk is full: nothing was stored; try again when an \
                             operator has freed space";

/// Whether `cause` is, somewhere in its chain, a full disk: `ENOSPC` / `EDQUOT` from the file
/// system or `SQLITE_FULL` from the database.
pub fn is_disk_full(cause: &anyhow::Error) -> bool {
    cause.chain().any(|e| {
        if let Some(io) = e.downcast_ref::<std::io::Error>() {
            return is_disk_full_io(io);
        }
        if let Some(db) = e.downcast_ref::<rusqlite::Error>() {
            return db.sqlite_error_code() == Some(rusqlite::ErrorCode::DiskFull);
        }
        false
    })
}

/// Whether a file-system error means the disk is full (`ENOSPC`) or the quota spent (`EDQUOT`).
pub fn is_disk_full_io(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        std::io::ErrorKind::StorageFull | std::io::ErrorKind::QuotaExceeded
    )
}

impl From<rusqlite::Error> for Error {
    fn from(e: rusqlite::Error) -> Self {
        Error::Internal(anyhow::Error::new(e).context("database"))
    }
}

impl From<std::io::Error> for Error {
    fn from(e: std::io::Error) -> Self {
        Error::Internal(anyhow::Error::new(e).context("file system"))
    }
}

impl IntoResponse for Error {
    fn into_response(self) -> Response {
        let status = self.status();
        let message = match &self {
            Error::Internal(cause) if is_disk_full(cause) => {
                tracing::error!(error = format!("{cause:#}"), "disk full");
                DISK_FULL.to_string()
            }
            Error::Internal(cause) => {
                tracing::error!(error = format!("{cause:#}"), "internal error");
                "internal error".to_string()
            }
            other => other.to_string(),
        };
        let mut response = (status, Json(ApiError { error: message })).into_response();
        if let Some(wait) = self.retry_after() {
            // Whole seconds, rounded up: never "0", which would invite an immediate retry.
            let seconds = wait.as_secs() + u64::from(wait.subsec_nanos() > 0);
            response.headers_mut().insert(
                axum::http::header::RETRY_AFTER,
                axum::http::HeaderValue::from(seconds.max(1)),
            );
        }
        if matches!(self, Error::Timeout(_)) {
            // The rest of a late body may still be on its way: end the connection.
            response.headers_mut().insert(
                axum::http::header::CONNECTION,
                axum::http::HeaderValue::from_static("close"),
            );
        }
        if matches!(self, Error::Unauthorized(_)) {
            response.headers_mut().insert(
                axum::http::header::WWW_AUTHENTICATE,
                axum::http::HeaderValue::from_static("Bearer"),
            );
        }
        response
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    async fn answer(error: Error) -> (StatusCode, String) {
        let response = error.into_response();
        let status = response.status();
        let body = axum::body::to_bytes(response.into_body(), 1 << 16)
            .await
            .unwrap();
        (status, String::from_utf8(body.to_vec()).unwrap())
    }

    #[tokio::test]
    async fn a_full_disk_anywhere_in_the_cause_is_507_not_500() {
        let enospc = std::io::Error::from(std::io::ErrorKind::StorageFull);
        let wrapped = anyhow::Error::new(enospc).context("writing /data/jobs/1/tiles/3-ab.json");
        let (status, body) = answer(Error::Internal(wrapped.context("storing a tile"))).await;
        assert_eq!(status, StatusCode::INSUFFICIENT_STORAGE);
        assert!(body.contains("disk is full"), "{body}");
        assert!(!body.contains("/data"), "no server path leaks: {body}");
        let (status, _) = answer(Error::from(std::io::Error::from_raw_os_error(28))).await;
        assert_eq!(status, StatusCode::INSUFFICIENT_STORAGE, "raw ENOSPC");
        let full = rusqlite::Error::SqliteFailure(
            rusqlite::ffi::Error::new(rusqlite::ffi::SQLITE_FULL),
            None,
        );
        assert_eq!(
            answer(Error::from(full)).await.0,
            StatusCode::INSUFFICIENT_STORAGE
        );
        // Other failures stay 500.
        let other = std::io::Error::from(std::io::ErrorKind::PermissionDenied);
        assert_eq!(
            answer(Error::from(other)).await.0,
            StatusCode::INTERNAL_SERVER_ERROR
        );
    }
}
