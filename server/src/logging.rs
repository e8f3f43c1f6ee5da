//! The coordinator's log: human-readable text or one JSON object a line, and a request id on
//! every line logged while serving a request.
//!
//! A request gets the id its client sent in `x-request-id`, or a new one (`r<n>`, counting from
//! the process start), which is echoed in the response's `x-request-id`; the request's span
//! carries it, so a line logged by a handler names the request, and with
//! `RUST_LOG=tower_http=debug` every request gets a line of its own. Text goes without colour
//! codes unless standard error is a terminal.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicU64, Ordering};

use axum::http::{HeaderValue, Request};
use tower_http::request_id::{MakeRequestId, RequestId};
use tracing_subscriber::fmt::MakeWriter;

/// How log lines are written (`--log-format`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum LogFormat {
    /// Human-readable lines.
    #[default]
    Text,
    /// One JSON object a line, with the fields of the line's spans (`request_id`, …).
    Json,
}

/// The header that carries a request's id, in and out.
pub const REQUEST_ID: &str = "x-request-id";

/// The default filter when `RUST_LOG` is unset.
const DEFAULT_FILTER: &str = "info";

/// Installs the process-wide subscriber writing to standard error.
pub fn init(format: LogFormat) {
    let ansi = std::io::stderr().is_terminal();
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| DEFAULT_FILTER.into());
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr);
    match format {
        LogFormat::Text => builder.with_ansi(ansi).init(),
        LogFormat::Json => builder.json().with_current_span(true).init(),
    }
}

/// A subscriber writing `format` to `writer` (for tests, which install it per thread).
pub fn subscriber<W>(format: LogFormat, writer: W) -> Box<dyn tracing::Subscriber + Send + Sync>
where
    W: for<'a> MakeWriter<'a> + Send + Sync + 'static,
{
    let builder = tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::new(DEFAULT_FILTER))
        .with_writer(writer)
        .with_ansi(false);
    match format {
        LogFormat::Text => Box::new(builder.finish()),
        LogFormat::Json => Box::new(builder.json().with_current_span(true).finish()),
    }
}

/// New request ids: `r1`, `r2`, … for this process.
#[derive(Debug, Clone, Default)]
pub struct RequestIds;

static NEXT: AtomicU64 = AtomicU64::new(1);

impl MakeRequestId for RequestIds {
    fn make_request_id<B>(&mut self, _: &Request<B>) -> Option<RequestId> {
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        HeaderValue::from_str(&format!("r{n}"))
            .ok()
            .map(RequestId::new)
    }
}

/// The span of one request: its id, method and path (never the query, which may hold a token
/// of the dashboard's — it does not, but nothing after `?` is logged).
pub fn request_span<B>(request: &Request<B>) -> tracing::Span {
    let id = request
        .headers()
        .get(REQUEST_ID)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("-");
    tracing::info_span!(
        "request",
        request_id = %id,
        method = %request.method(),
        path = %request.uri().path(),
    )
}
