//! The worker's side of the coordinator's HTTP API: one method per worker route, typed with
//! `spindle_common::protocol`, nothing else.
//!
//! It knows the coordinator's address and the worker token, and keeps (in memory only) the
//! worker secret of its latest registration, sent with every later request as
//! [`WORKER_SECRET_HEADER`]. It talks HTTP or HTTPS (trusting the
//! roots of [`crate::tls`]) without any system proxy (farm traffic is machine-to-machine), and bounds every request with a
//! timeout so a coordinator that vanishes mid-request cannot stall the worker. It does not
//! retry: deciding what to do about a failure (wait and retry, re-register, drop the tile) is
//! the caller's business, helped by [`ClientError::kind`].

use std::sync::{Arc, Mutex};
use std::time::Duration;

use bytes::Bytes;
use reqwest::StatusCode;
use serde::de::DeserializeOwned;
use spindle_common::protocol::{
    ApiError, Heartbeat, HeartbeatAck, JobSpec, LEASE_EPOCH_HEADER, Lease, LeaseRequest,
    RegisterWorker, TileAck, TileFailure, WORKER_SECRET_HEADER, WorkerRegistered,
};
use spindle_common::tile::TilePixels;
use spindle_common::tile_encoding;

/// How long to wait for a TCP connection to the coordinator.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);
/// The bound on an ordinary request (everything but the lease long poll and asset downloads).
const REQUEST_TIMEOUT: Duration = Duration::from_secs(30);
/// Asset downloads may be large meshes on a slow link.
const ASSET_TIMEOUT: Duration = Duration::from_secs(600);
/// A pooled connection idle this long is closed rather than reused: well inside the
/// coordinator's own idle close (its header timeout, 10 s by default), so no request is sent on
/// a connection the coordinator is closing at that moment, which fails it with "connection
/// closed before message completed".
const POOL_IDLE_TIMEOUT: Duration = Duration::from_secs(4);
/// Slack on top of the long-poll wait before a lease request counts as lost.
const LONG_POLL_SLACK: Duration = Duration::from_secs(15);
/// The most bytes a previous pass's result may inflate to: a 256-pixel tile's layers (f32) and
/// running sums (14 values per pixel, f64) as MessagePack with named fields, with room to spare.
const MAX_PREVIOUS_PASS_BYTES: usize = 64 << 20;

/// A failed request to the coordinator.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// No answer: connection refused or reset, timeout, DNS.
    #[error("coordinator unreachable: {0}")]
    Unreachable(String),
    /// The coordinator answered with an error status; `message` is its JSON `error` field.
    #[error("coordinator answered {status}: {message}")]
    Status { status: StatusCode, message: String },
    /// An answer that is not what the API promises (a proxy page, a truncated body).
    #[error("unexpected answer from the coordinator: {0}")]
    Garbled(String),
}

/// What a caller should do about a [`ClientError`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// May pass: wait (backoff) and try again.
    Transient,
    /// 401: the worker token is wrong; retrying cannot help.
    Unauthorized,
    /// 404: the thing (worker, job, lease, asset) is unknown to the coordinator; or 403: the
    /// coordinator does not take this worker's secret (it forgot the worker). Either way the
    /// worker registers again.
    NotFound,
    /// 409: the lease is no longer this worker's (a newer epoch exists, or the tile is done
    /// with a different result).
    Conflict,
    /// 410 on a lease request: the worker was told to drain; it takes no more tiles and exits.
    Draining,
    /// Any other 4xx: the request itself is wrong; retrying the same request cannot help.
    Rejected,
}

impl ClientError {
    /// Classifies the failure; see [`ErrorKind`].
    pub fn kind(&self) -> ErrorKind {
        match self {
            ClientError::Unreachable(_) | ClientError::Garbled(_) => ErrorKind::Transient,
            ClientError::Status { status, .. } => match *status {
                StatusCode::UNAUTHORIZED => ErrorKind::Unauthorized,
                StatusCode::NOT_FOUND | StatusCode::FORBIDDEN => ErrorKind::NotFound,
                StatusCode::CONFLICT => ErrorKind::Conflict,
                StatusCode::GONE => ErrorKind::Draining,
                StatusCode::REQUEST_TIMEOUT | StatusCode::TOO_MANY_REQUESTS => ErrorKind::Transient,
                s if s.is_server_error() => ErrorKind::Transient,
                _ => ErrorKind::Rejected,
            },
        }
    }
}

impl From<reqwest::Error> for ClientError {
    fn from(e: reqwest::Error) -> Self {
        if e.is_decode() {
            ClientError::Garbled(e.to_string())
        } else {
            // Connect, timeout, request and body errors all mean "no usable answer".
            let chain = error_chain(&e);
            match crate::tls::explain(&e) {
                Some(hint) => ClientError::Unreachable(format!("{chain} ({hint})")),
                None => ClientError::Unreachable(chain),
            }
        }
    }
}

/// `e` and its sources on one line ("error sending request: connection refused").
fn error_chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut source = e.source();
    while let Some(inner) = source {
        s.push_str(": ");
        s.push_str(&inner.to_string());
        source = inner.source();
    }
    s
}

/// A handle on the coordinator's worker routes. Cheap to clone (the connection pool is shared).
#[derive(Debug, Clone)]
pub struct Client {
    http: reqwest::Client,
    /// `http://host:port` with no trailing slash.
    base: String,
    token: Option<String>,
    /// The secret of the latest registration, shared by the clones.
    secret: Arc<Mutex<Option<String>>>,
}

impl Client {
    /// A client for the coordinator at `base` (an `http(s)://host:port` URL, already validated
    /// by [`crate::Config`]), authenticating with the worker token if there is one; https
    /// trusts the system's roots.
    pub fn new(base: &str, token: Option<String>) -> Result<Client, ClientError> {
        Client::with_ca_cert(base, token, None)
    }

    /// [`Client::new`], trusting only the CA certificates of the PEM file `ca_cert` if given.
    pub fn with_ca_cert(
        base: &str,
        token: Option<String>,
        ca_cert: Option<&std::path::Path>,
    ) -> Result<Client, ClientError> {
        let http = crate::tls::client_builder(ca_cert)
            .map_err(|e| ClientError::Unreachable(format!("{e:#}")))?
            .connect_timeout(CONNECT_TIMEOUT)
            .timeout(REQUEST_TIMEOUT)
            .pool_idle_timeout(POOL_IDLE_TIMEOUT)
            .build()
            .map_err(|e| ClientError::Unreachable(error_chain(&e)))?;
        Ok(Client {
            http,
            base: base.trim_end_matches('/').to_string(),
            token,
            secret: Arc::default(),
        })
    }

    /// `POST /v1/workers`; the secret of the answer goes with every later request.
    pub async fn register(&self, body: &RegisterWorker) -> Result<WorkerRegistered, ClientError> {
        let req = self.http.post(self.url("/v1/workers")).json(body);
        let registered: WorkerRegistered = decode(self.send(req).await?).await?;
        *self.secret.lock().expect("not poisoned") = Some(registered.worker_secret.clone());
        Ok(registered)
    }

    /// `POST /v1/workers/{id}/lease`: waits up to `wait` for a tile; `None` when there was none.
    pub async fn lease(
        &self,
        worker_id: u64,
        wait: Duration,
    ) -> Result<Option<Lease>, ClientError> {
        let body = LeaseRequest {
            wait_ms: Some(wait.as_millis() as u64),
        };
        let req = self
            .http
            .post(self.url(&format!("/v1/workers/{worker_id}/lease")))
            .timeout(wait + LONG_POLL_SLACK)
            .json(&body);
        let resp = self.send(req).await?;
        if resp.status() == StatusCode::NO_CONTENT {
            return Ok(None);
        }
        decode(resp).await.map(Some)
    }

    /// `GET /v1/jobs/{id}/spec`.
    pub async fn job_spec(&self, job_id: u64) -> Result<JobSpec, ClientError> {
        let req = self.http.get(self.url(&format!("/v1/jobs/{job_id}/spec")));
        decode(self.send(req).await?).await
    }

    /// `GET /v1/assets/{hash}`: the raw bytes, not yet verified.
    pub async fn asset(&self, hash: &str) -> Result<Vec<u8>, ClientError> {
        let req = self
            .http
            .get(self.url(&format!("/v1/assets/{hash}")))
            .timeout(ASSET_TIMEOUT);
        let resp = self.send(req).await?;
        Ok(resp.bytes().await?.to_vec())
    }

    /// `POST /v1/leases/{job}/{tile}/heartbeat`.
    pub async fn heartbeat(
        &self,
        job_id: u64,
        tile: u32,
        body: &Heartbeat,
    ) -> Result<HeartbeatAck, ClientError> {
        let req = self
            .http
            .post(self.url(&format!("/v1/leases/{job_id}/{tile}/heartbeat")))
            .json(body);
        decode(self.send(req).await?).await
    }

    /// `PUT /v1/jobs/{job}/tiles/{tile}` of a [`TileUpload`] in its compact form
    /// ([`tile_encoding::encode`]), naming the lease's `epoch` in a header so the coordinator
    /// can refuse a stale upload before reading it.
    pub async fn upload(
        &self,
        job_id: u64,
        tile: u32,
        epoch: u64,
        encoded: Bytes,
    ) -> Result<TileAck, ClientError> {
        let req = self
            .http
            .put(self.url(&format!("/v1/jobs/{job_id}/tiles/{tile}")))
            .header(reqwest::header::CONTENT_TYPE, tile_encoding::CONTENT_TYPE)
            .header(LEASE_EPOCH_HEADER, epoch)
            .body(encoded);
        decode(self.send(req).await?).await
    }

    /// `GET /v1/leases/{job}/{tile}/previous`: the tile's result of the previous progressive
    /// pass, with its running sums ([`TilePixels::progress`]).
    pub async fn previous_pass(&self, job_id: u64, tile: u32) -> Result<TilePixels, ClientError> {
        let req = self
            .http
            .get(self.url(&format!("/v1/leases/{job_id}/{tile}/previous")));
        let bytes = self.send(req).await?.bytes().await?;
        tile_encoding::decode(&bytes, MAX_PREVIOUS_PASS_BYTES)
            .map_err(|e| ClientError::Garbled(format!("the previous pass of tile {tile}: {e}")))
    }

    /// `POST /v1/leases/{job}/{tile}/fail`.
    pub async fn fail(
        &self,
        job_id: u64,
        tile: u32,
        body: &TileFailure,
    ) -> Result<(), ClientError> {
        let req = self
            .http
            .post(self.url(&format!("/v1/leases/{job_id}/{tile}/fail")))
            .json(body);
        self.send(req).await.map(drop)
    }

    fn url(&self, path: &str) -> String {
        format!("{}{}", self.base, path)
    }

    /// Sends with the bearer token; a non-2xx answer becomes [`ClientError::Status`].
    async fn send(&self, req: reqwest::RequestBuilder) -> Result<reqwest::Response, ClientError> {
        let req = match &self.token {
            Some(token) => req.bearer_auth(token),
            None => req,
        };
        let secret = self.secret.lock().expect("not poisoned").clone();
        let req = match secret {
            Some(secret) => req.header(WORKER_SECRET_HEADER, secret),
            None => req,
        };
        let resp = req.send().await?;
        let status = resp.status();
        if status.is_success() {
            return Ok(resp);
        }
        // The API promises `{"error": "..."}`; fall back to the raw text for anything else.
        let text = resp.text().await.unwrap_or_default();
        let message = serde_json::from_str::<ApiError>(&text)
            .map(|e| e.error)
            .unwrap_or_else(|_| text.chars().take(200).collect());
        Err(ClientError::Status { status, message })
    }
}

/// Parses a JSON body, reading it as bytes first so a truncated body is reported as such.
async fn decode<T: DeserializeOwned>(resp: reqwest::Response) -> Result<T, ClientError> {
    let bytes = resp.bytes().await?;
    serde_json::from_slice(&bytes).map_err(|e| ClientError::Garbled(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn status(code: u16) -> ClientError {
        ClientError::Status {
            status: StatusCode::from_u16(code).unwrap(),
            message: String::new(),
        }
    }

    #[test]
    fn errors_are_classified_by_what_can_be_done() {
        assert_eq!(
            ClientError::Unreachable("x".into()).kind(),
            ErrorKind::Transient
        );
        assert_eq!(
            ClientError::Garbled("x".into()).kind(),
            ErrorKind::Transient
        );
        for (code, kind) in [
            (500, ErrorKind::Transient),
            (502, ErrorKind::Transient),
            (503, ErrorKind::Transient),
            (408, ErrorKind::Transient),
            (429, ErrorKind::Transient),
            (401, ErrorKind::Unauthorized),
            (403, ErrorKind::NotFound),
            (404, ErrorKind::NotFound),
            (409, ErrorKind::Conflict),
            (400, ErrorKind::Rejected),
            (413, ErrorKind::Rejected),
            (422, ErrorKind::Rejected),
        ] {
            assert_eq!(status(code).kind(), kind, "status {code}");
        }
    }

    #[tokio::test]
    async fn a_closed_port_is_unreachable_not_a_panic() {
        // Bind then drop a listener: the port is now (almost certainly) closed.
        let port = {
            let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
            l.local_addr().unwrap().port()
        };
        let client = Client::new(&format!("http://127.0.0.1:{port}/"), None).unwrap();
        let err = client.job_spec(1).await.unwrap_err();
        assert_eq!(err.kind(), ErrorKind::Transient, "{err}");
    }
}
