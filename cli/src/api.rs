//! The `spindle` command's side of the coordinator's HTTP API: the client routes (assets, jobs,
//! images), typed with `spindle_common::protocol`.
//!
//! Errors are for people: they say which coordinator, what was asked and what it answered
//! (`job 7: the coordinator at http://… answered 404 Not Found: no job 7`). Requests that may
//! be repeated safely (reads, asset uploads, and job submission thanks to its idempotency key)
//! are retried a few times when the coordinator is briefly unreachable.

use std::time::Duration;

use anyhow::{Context, Result, anyhow};
use eventsource_stream::Eventsource;
use futures_util::StreamExt;
use futures_util::stream::BoxStream;
use reqwest::StatusCode;
use serde::de::DeserializeOwned;
use spindle_common::protocol::{
    ApiError, AssetStored, FarmEvent, IDEMPOTENCY_KEY_HEADER, JobInfo, JobList, JobOrder, JobPatch,
    JobState, MissingAssetsRequest, MissingAssetsResponse, SubmitJob, WorkerList,
};

/// Tries of a request whose failure was transient (connection refused, 502, 503, 504; a 500
/// or 507 says something a retry within seconds does not change, such as a damaged image).
const TRIES: u32 = 5;
/// Requests other than asset and image transfers.
const REQUEST_TIMEOUT: Duration = Duration::from_secs(60);
/// Asset uploads and image downloads can be large.
const TRANSFER_TIMEOUT: Duration = Duration::from_secs(900);
/// An event stream is reopened after this long even if it never broke.
const EVENT_STREAM_TIMEOUT: Duration = Duration::from_secs(6 * 3600);

/// The coordinator answered with an error status.
#[derive(Debug, thiserror::Error)]
#[error("the coordinator at {base} answered {status}: {message}")]
pub struct StatusError {
    pub base: String,
    pub status: StatusCode,
    pub message: String,
}

/// A connection to a coordinator, with the client token.
#[derive(Debug, Clone)]
pub struct Api {
    http: reqwest::Client,
    base: String,
    token: Option<String>,
}

impl Api {
    /// `base` is `http(s)://host:port`; `token` is `SPINDLE_TOKEN`; https trusts the system's
    /// roots.
    pub fn new(base: &str, token: Option<String>) -> Result<Api> {
        Api::with_ca_cert(base, token, None)
    }

    /// [`Api::new`], trusting only the CA certificates of the PEM file `ca_cert` if given
    /// (`--ca-cert`; see `spindle_worker::tls`).
    pub fn with_ca_cert(
        base: &str,
        token: Option<String>,
        ca_cert: Option<&std::path::Path>,
    ) -> Result<Api> {
        let base = &with_scheme(base);
        let url = reqwest::Url::parse(base).map_err(|e| {
            anyhow!(
                "--server {base}: not a URL ({e}); expected https://HOST:PORT or http://HOST:PORT"
            )
        })?;
        if !matches!(url.scheme(), "http" | "https") || url.host_str().is_none_or(str::is_empty) {
            return Err(anyhow!(
                "--server {base}: expected https://HOST:PORT or http://HOST:PORT"
            ));
        }
        let http = spindle_worker::tls::client_builder(ca_cert)?
            .connect_timeout(Duration::from_secs(5))
            .timeout(REQUEST_TIMEOUT)
            .build()
            .context("setting up the HTTP client")?;
        Ok(Api {
            http,
            base: url.as_str().trim_end_matches('/').to_string(),
            token: token
                .filter(|t| !t.trim().is_empty())
                .map(|t| t.trim().to_string()),
        })
    }

    /// `POST /v1/assets/missing`: which of `hashes` must be uploaded.
    pub async fn missing_assets(&self, hashes: Vec<String>) -> Result<Vec<String>> {
        let body = MissingAssetsRequest { hashes };
        let r: MissingAssetsResponse = self
            .json(|| self.http.post(self.url("/v1/assets/missing")).json(&body))
            .await?;
        Ok(r.missing)
    }

    /// `PUT /v1/assets/{hash}`.
    pub async fn put_asset(&self, hash: &str, bytes: &[u8]) -> Result<AssetStored> {
        self.json(|| {
            self.http
                .put(self.url(&format!("/v1/assets/{hash}")))
                .timeout(TRANSFER_TIMEOUT)
                .header(reqwest::header::CONTENT_TYPE, "application/octet-stream")
                .body(bytes.to_vec())
        })
        .await
    }

    /// `POST /v1/jobs` with an idempotency key, so a retry cannot create a second job.
    pub async fn submit(&self, job: &SubmitJob, idempotency_key: &str) -> Result<JobInfo> {
        self.json(|| {
            self.http
                .post(self.url("/v1/jobs"))
                .header(IDEMPOTENCY_KEY_HEADER, idempotency_key)
                .json(job)
        })
        .await
    }

    /// `GET /v1/jobs` (the first page).
    pub async fn jobs(&self) -> Result<JobList> {
        self.json(|| self.http.get(self.url("/v1/jobs"))).await
    }

    /// `GET /v1/jobs?state=&name=&limit=&cursor=&order=`: one page.
    pub async fn jobs_page(&self, query: &JobQuery) -> Result<JobList> {
        let mut pairs: Vec<(&str, String)> = Vec::new();
        if let Some(s) = query.state {
            pairs.push(("state", s.as_str().to_string()));
        }
        if let Some(n) = &query.name {
            pairs.push(("name", n.clone()));
        }
        if let Some(l) = query.limit {
            pairs.push(("limit", l.to_string()));
        }
        if let Some(c) = &query.cursor {
            pairs.push(("cursor", c.clone()));
        }
        if let Some(o) = query.order {
            pairs.push(("order", o.as_str().to_string()));
        }
        let mut url = reqwest::Url::parse(&self.url("/v1/jobs"))?;
        if !pairs.is_empty() {
            url.query_pairs_mut().extend_pairs(&pairs);
        }
        self.json(|| self.http.get(url.clone())).await
    }

    /// `POST /v1/jobs/{id}/{action}` (pause, resume, requeue).
    pub async fn job_action(&self, id: u64, action: &str) -> Result<JobInfo> {
        self.json(|| self.http.post(self.url(&format!("/v1/jobs/{id}/{action}"))))
            .await
    }

    /// `PATCH /v1/jobs/{id}` with a new priority.
    pub async fn set_priority(&self, id: u64, priority: i32) -> Result<JobInfo> {
        let body = JobPatch { priority };
        self.json(|| {
            self.http
                .patch(self.url(&format!("/v1/jobs/{id}")))
                .json(&body)
        })
        .await
    }

    /// `DELETE /v1/jobs/{id}` (`?force=true` for an unfinished job).
    pub async fn delete(&self, id: u64, force: bool) -> Result<()> {
        let force = if force { "?force=true" } else { "" };
        let url = self.url(&format!("/v1/jobs/{id}{force}"));
        self.send(|| self.http.delete(&url)).await?;
        Ok(())
    }

    /// `GET /v1/jobs/{id}`.
    pub async fn job(&self, id: u64) -> Result<JobInfo> {
        self.json(|| self.http.get(self.url(&format!("/v1/jobs/{id}"))))
            .await
    }

    /// `POST /v1/jobs/{id}/cancel`.
    pub async fn cancel(&self, id: u64) -> Result<JobInfo> {
        self.json(|| self.http.post(self.url(&format!("/v1/jobs/{id}/cancel"))))
            .await
    }

    /// `GET /v1/workers`.
    pub async fn workers(&self) -> Result<WorkerList> {
        self.json(|| self.http.get(self.url("/v1/workers"))).await
    }

    /// `POST /v1/workers/{id}/drain` (an id or a name).
    pub async fn drain(&self, name_or_id: &str) -> Result<WorkerList> {
        let mut url = reqwest::Url::parse(&self.url("/v1/workers"))?;
        url.path_segments_mut()
            .map_err(|()| anyhow!("{}: cannot be a base URL", self.base))?
            .push(name_or_id)
            .push("drain");
        self.json(|| self.http.post(url.clone())).await
    }

    /// `GET /v1/events`, resuming after `last_id`: the farm's events as they happen. The stream
    /// ends when the connection does; an event that is not a [`FarmEvent`] is an error item.
    pub async fn events(
        &self,
        last_id: Option<u64>,
    ) -> Result<BoxStream<'static, Result<FarmEvent>>> {
        let url = self.url("/v1/events");
        let resp = self
            .send(|| {
                let req = self.http.get(&url).timeout(EVENT_STREAM_TIMEOUT);
                match last_id {
                    Some(id) => req.header("last-event-id", id.to_string()),
                    None => req,
                }
            })
            .await?;
        let base = self.base.clone();
        Ok(resp
            .bytes_stream()
            .eventsource()
            .map(move |item| {
                let event = item.map_err(|e| anyhow!("the event stream of {base} broke: {e}"))?;
                serde_json::from_str::<FarmEvent>(&event.data)
                    .with_context(|| format!("the coordinator at {base} sent an unexpected event"))
            })
            .boxed())
    }

    /// `GET /v1/jobs/{id}/image.exr` (the final image) or `image.png` (the preview).
    pub async fn image(&self, id: u64, file: ImageFile) -> Result<Vec<u8>> {
        let name = match file {
            ImageFile::Exr => "image.exr",
            ImageFile::Png => "image.png",
        };
        let resp = self
            .send(|| {
                self.http
                    .get(self.url(&format!("/v1/jobs/{id}/{name}")))
                    .timeout(TRANSFER_TIMEOUT)
            })
            .await?;
        let digest = resp
            .headers()
            .get("repr-digest")
            .map(|v| v.to_str().unwrap_or("(not text)").to_string());
        let bytes = resp
            .bytes()
            .await
            .with_context(|| format!("downloading {name} of job {id} from {}", self.base))?;
        if file == ImageFile::Exr {
            check_repr_digest(digest.as_deref(), &bytes)
                .map_err(|problem| anyhow!("{name} of job {id} from {}: {problem}", self.base))?;
        }
        Ok(bytes.to_vec())
    }

    fn url(&self, path: &str) -> String {
        format!("{}{}", self.base, path)
    }

    async fn json<T: DeserializeOwned>(
        &self,
        make: impl Fn() -> reqwest::RequestBuilder,
    ) -> Result<T> {
        let resp = self.send(make).await?;
        let bytes = resp
            .bytes()
            .await
            .with_context(|| format!("reading the answer of {}", self.base))?;
        serde_json::from_slice(&bytes)
            .with_context(|| format!("the coordinator at {} sent an unexpected answer", self.base))
    }

    /// Sends with the token, retrying transient failures; a non-2xx answer is a
    /// [`StatusError`] carrying the coordinator's message.
    async fn send(&self, make: impl Fn() -> reqwest::RequestBuilder) -> Result<reqwest::Response> {
        let mut delay = Duration::from_millis(200);
        let mut tries = 0;
        loop {
            tries += 1;
            let req = match &self.token {
                Some(token) => make().bearer_auth(token),
                None => make(),
            };
            let transient = match req.send().await {
                Ok(resp) if resp.status().is_success() => return Ok(resp),
                Ok(resp) => {
                    let status = resp.status();
                    let text = resp.text().await.unwrap_or_default();
                    let mut message = serde_json::from_str::<ApiError>(&text)
                        .map(|e| e.error)
                        .unwrap_or_else(|_| text.chars().take(300).collect());
                    if status == StatusCode::UNAUTHORIZED {
                        message.push_str(
                            " (give the coordinator's client token in SPINDLE_TOKEN or with \
                             --token-file FILE)",
                        );
                    }
                    let err = StatusError {
                        base: self.base.clone(),
                        status,
                        message,
                    };
                    let transient = matches!(
                        status,
                        StatusCode::BAD_GATEWAY
                            | StatusCode::SERVICE_UNAVAILABLE
                            | StatusCode::GATEWAY_TIMEOUT
                    );
                    if !transient || tries >= TRIES {
                        return Err(err.into());
                    }
                    anyhow::Error::from(err)
                }
                Err(e) => {
                    let hint = spindle_worker::tls::explain(&e);
                    let err = anyhow::Error::from(e)
                        .context(format!("cannot reach the coordinator at {}", self.base));
                    if let Some(hint) = hint {
                        // Retrying cannot change the certificate.
                        return Err(err.context(hint));
                    }
                    if tries >= TRIES {
                        return Err(err);
                    }
                    err
                }
            };
            tracing::warn!("{transient:#}; retrying in {delay:?}");
            tokio::time::sleep(delay).await;
            delay *= 2;
        }
    }
}

/// `HOST:PORT` given without a scheme: `http://` on a loopback host (the local coordinator
/// needs no certificate), `https://` anywhere else (a token must not cross a network in the
/// clear). A URL with a scheme is kept as it is.
fn with_scheme(server: &str) -> String {
    if server.contains("://") {
        return server.to_string();
    }
    let loopback = reqwest::Url::parse(&format!("http://{server}"))
        .ok()
        .and_then(|u| u.host_str().map(str::to_owned))
        .is_some_and(|host| {
            let ip = host.trim_start_matches('[').trim_end_matches(']');
            host.eq_ignore_ascii_case("localhost")
                || ip
                    .parse::<std::net::IpAddr>()
                    .is_ok_and(|ip| ip.is_loopback())
        });
    let scheme = if loopback { "http" } else { "https" };
    format!("{scheme}://{server}")
}

/// The filters and page of `GET /v1/jobs`.
#[derive(Debug, Clone, Default)]
pub struct JobQuery {
    pub state: Option<JobState>,
    pub name: Option<String>,
    pub limit: Option<usize>,
    pub cursor: Option<String>,
    pub order: Option<JobOrder>,
}

/// Which image of a job to download.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageFile {
    Exr,
    Png,
}

/// The HTTP status of a failed request, if the coordinator answered at all.
pub fn status_of(e: &anyhow::Error) -> Option<StatusCode> {
    e.downcast_ref::<StatusError>().map(|s| s.status)
}

/// Checks downloaded bytes against the coordinator's `Repr-Digest` header (RFC 9530; its
/// `sha-256` member), which it sends with every final image.
pub fn check_repr_digest(header: Option<&str>, bytes: &[u8]) -> Result<(), String> {
    use base64::Engine;
    use sha2::Digest;
    let Some(header) = header else {
        return Err(
            "the coordinator sent no Repr-Digest header, so the download cannot be \
                    checked; nothing was written"
                .into(),
        );
    };
    let expected = header
        .split(',')
        .find_map(|member| member.trim().strip_prefix("sha-256=:")?.strip_suffix(':'))
        .and_then(|b64| base64::engine::general_purpose::STANDARD.decode(b64).ok())
        .ok_or_else(|| format!("Repr-Digest {header:?} has no sha-256 digest"))?;
    if sha2::Sha256::digest(bytes).as_slice() != expected.as_slice() {
        return Err(format!(
            "the {} bytes received do not match the coordinator's SHA-256 digest (Repr-Digest); \
             the image is damaged, nothing was written",
            bytes.len()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{check_repr_digest, with_scheme};

    #[test]
    fn a_server_without_scheme_is_http_only_on_loopback() {
        assert_eq!(with_scheme("127.0.0.1:7878"), "http://127.0.0.1:7878");
        assert_eq!(with_scheme("localhost:7878"), "http://localhost:7878");
        assert_eq!(with_scheme("[::1]:7878"), "http://[::1]:7878");
        assert_eq!(
            with_scheme("farm.example:7878"),
            "https://farm.example:7878"
        );
        assert_eq!(with_scheme("10.0.0.5:7878"), "https://10.0.0.5:7878");
        assert_eq!(with_scheme("http://10.0.0.5:7878"), "http://10.0.0.5:7878");
        assert!(super::Api::new("127.0.0.1:7878", None).is_ok());
    }

    #[test]
    fn a_download_must_match_its_repr_digest() {
        // SHA-256 of "abc" (FIPS 180-2), base64.
        let abc = "sha-256=:ungWv48Bz+pBQUDeXa4iI7ADYaOWF3qctBD/YfIAFa0=:";
        assert_eq!(check_repr_digest(Some(abc), b"abc"), Ok(()));
        let with_others = format!("sha-512=:AAAA:, {abc}");
        assert_eq!(check_repr_digest(Some(&with_others), b"abc"), Ok(()));
        let err = check_repr_digest(Some(abc), b"abd").unwrap_err();
        assert!(
            err.contains("do not match") && err.contains("damaged"),
            "{err}"
        );
        let err = check_repr_digest(None, b"abc").unwrap_err();
        assert!(err.contains("no Repr-Digest"), "{err}");
        let err = check_repr_digest(Some("md5=:x:"), b"abc").unwrap_err();
        assert!(err.contains("has no sha-256"), "{err}");
    }
}
