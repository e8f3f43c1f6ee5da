//! The coordinator's front door: accepting connections and bounding what each may hold.
//!
//! A client that connects and then sends nothing, or a byte at a time, must not be able to keep
//! a connection (and its file descriptor) for long, nor to use up the descriptors that other
//! requests, the database and the image files need. So, per connection:
//! - with TLS ([`crate::tls`]), the handshake must finish within the header deadline too, so a
//!   client that connects and stays silent holds its slot no longer than over plain HTTP;
//! - hyper's HTTP/1 header-read deadline ([`crate::Timeouts::header`]) bounds the request line and
//!   headers, and the wait of an idle keep-alive connection for its next request; past it the
//!   connection is closed (there is no request to answer);
//! - the router's request deadline ([`crate::Timeouts::request`], `api::router`) bounds the body
//!   and the handler together, and answers 408 with `Connection: close`;
//! - an answer must leave at the pace of a reader: a write to the socket that makes no
//!   progress within the header deadline ends the connection (`tokio-io-timeout`'s write
//!   timeout on the socket, under TLS too). The kernel wakes a blocked writer only once a share
//!   of its send buffer has been read, so a client that reads a byte now and then, or not at
//!   all, is cut within that deadline: a minimum send rate of a send-buffer share per
//!   deadline. A handler whose answer never ends (the event stream) tightens this for its
//!   connection ([`crate::send_bound`]);
//! - a connection is answered at most [`MAX_REQUESTS_PER_CONNECTION`] requests (the last
//!   answer says `Connection: close`), and hyper buffers at most [`MAX_READ_BUFFER`] bytes of
//!   what a client sends ahead (pipelined requests wait there, unread, until their turn);
//! - at most [`Config::max_connections`] connections are open at once, kept below the process's
//!   descriptor limit by [`connection_cap`]; further connections wait in the listen backlog
//!   until one closes, so accepting never fails for want of descriptors;
//! - at most [`Config::max_connections_per_address`] of them from one IP address
//!   ([`crate::peers`]): a further one is closed as soon as it is accepted, so one address,
//!   however fast it reopens connections, leaves the other slots to everyone else (`/healthz`
//!   and `/readyz` from another address are answered).
//!
//! Shutdown stops accepting, lets in-flight requests finish (long polls end at once, see
//! [`crate::AppState::begin_shutdown`]) and closes idle connections.

use std::future::Future;
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use axum::Router;
use axum::extract::ConnectInfo;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::server::graceful::GracefulShutdown;
use hyper_util::service::TowerToHyperService;
use tokio::net::TcpListener;
use tokio::sync::Semaphore;
use tower_http::add_extension::AddExtension;

use crate::config::Config;
use crate::peers::Peers;
use crate::send_bound::BoundedStream;
use crate::tls;

/// Descriptors kept for everything but client connections: the database and its journal, asset
/// and image files being written, the log, the listener.
pub const RESERVED_DESCRIPTORS: u64 = 64;

/// How long shutdown waits for in-flight requests before closing their connections.
const DRAIN_LIMIT: Duration = Duration::from_secs(30);

/// Requests answered on one connection; the last answer closes it (a worker opens a new one,
/// which costs nothing next to a tile).
pub const MAX_REQUESTS_PER_CONNECTION: usize = 100;

/// hyper's read buffer per connection: a request's line and headers must fit, and what a
/// client pipelines ahead waits here, unread, so this bounds it.
pub const MAX_READ_BUFFER: usize = 64 * 1024;

/// The number of connections to allow: `configured`, lowered to fit under the descriptor
/// limit `nofile` with [`RESERVED_DESCRIPTORS`] to spare. `None` if the limit leaves no room.
pub fn connection_cap(configured: usize, nofile: u64) -> Option<usize> {
    let room = nofile.saturating_sub(RESERVED_DESCRIPTORS);
    let cap = (configured as u64).min(room) as usize;
    (cap > 0).then_some(cap)
}

/// Raises the soft descriptor limit to the hard one and returns it (`u64::MAX` where there is
/// no such limit).
fn descriptor_limit() -> u64 {
    match rlimit::increase_nofile_limit(u64::MAX) {
        Ok(limit) => limit,
        Err(e) => {
            tracing::warn!(error = %e, "reading the open-file limit failed");
            rlimit::getrlimit(rlimit::Resource::NOFILE).map_or(u64::MAX, |(soft, _)| soft)
        }
    }
}

/// Serves `router` on `listener` until `shutdown` resolves, then drains.
pub async fn serve(
    config: &Config,
    listener: TcpListener,
    router: Router,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> anyhow::Result<()> {
    let nofile = descriptor_limit();
    let Some(max_connections) = connection_cap(config.max_connections, nofile) else {
        anyhow::bail!(
            "the open-file limit ({nofile}) leaves no descriptor for connections: the coordinator \
             keeps {RESERVED_DESCRIPTORS} for itself; raise it (ulimit -n, LimitNOFILE=)"
        );
    };
    if max_connections < config.max_connections {
        tracing::warn!(
            configured = config.max_connections,
            max_connections,
            nofile,
            "--max-connections lowered to fit the open-file limit (raise it with ulimit -n or \
             LimitNOFILE=)"
        );
    }
    tracing::info!(
        max_connections,
        max_connections_per_address = config.max_connections_per_address,
        header_timeout_ms = config.timeouts.header.as_millis() as u64,
        request_timeout_ms = config.timeouts.request.as_millis() as u64,
        "connection limits"
    );
    let tls = match &config.tls {
        Some(files) => {
            let cert = Arc::new(tls::ReloadableCert::open(files.clone())?);
            let reloader = tokio::spawn(tls::reload_on_sighup(cert.clone()));
            tracing::info!(cert = %files.cert.display(), "serving HTTPS (SIGHUP re-reads the certificate)");
            Some((tls::acceptor(cert)?, reloader.abort_handle()))
        }
        None => None,
    };
    let header_timeout = config.timeouts.header;
    let slots = Arc::new(Semaphore::new(max_connections));
    let peers = Peers::new(config.max_connections_per_address);
    let mut http = hyper::server::conn::http1::Builder::new();
    http.timer(TokioTimer::new())
        .header_read_timeout(config.timeouts.header)
        .max_buf_size(MAX_READ_BUFFER)
        .keep_alive(true);
    let graceful = GracefulShutdown::new();
    tokio::pin!(shutdown);
    let mut warned_full = false;
    loop {
        // Wait for a free slot before accepting, so the descriptor is never taken.
        let permit = tokio::select! {
            permit = slots.clone().acquire_owned() => permit?,
            () = &mut shutdown => break,
        };
        if slots.available_permits() == 0 && !warned_full {
            tracing::warn!(
                max_connections,
                "connection limit reached; new connections wait"
            );
        }
        warned_full = slots.available_permits() == 0;
        let (stream, peer) = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok(accepted) => accepted,
                Err(e) => {
                    // Out of descriptors despite the cap (files of requests in flight), or
                    // a connection reset before it was accepted: wait a little, go on.
                    tracing::warn!(error = %e, "accept error");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            },
            () = &mut shutdown => break,
        };
        let Some(held) = peers.admit(peer.ip()) else {
            tracing::debug!(%peer, "the address holds its share of connections; closed");
            continue;
        };
        let permit = (permit, held);
        let _ = stream.set_nodelay(true);
        let (stream, bound) = BoundedStream::new(stream, header_timeout);
        let service = TowerToHyperService::new(CountedRequests::new(AddExtension::new(
            AddExtension::new(router.clone(), ConnectInfo::<SocketAddr>(peer)),
            bound,
        )));
        let Some((acceptor, _)) = &tls else {
            let connection = graceful.watch(http.serve_connection(TokioIo::new(stream), service));
            tokio::spawn(async move {
                if let Err(e) = connection.await {
                    tracing::debug!(%peer, error = %e, "connection ended with an error");
                }
                drop(permit);
            });
            continue;
        };
        let handshake = acceptor.accept(stream);
        let (http, watcher) = (http.clone(), graceful.watcher());
        tokio::spawn(async move {
            match tokio::time::timeout(header_timeout, handshake).await {
                Ok(Ok(stream)) => {
                    let connection = http.serve_connection(TokioIo::new(stream), service);
                    if let Err(e) = watcher.watch(connection).await {
                        tracing::debug!(%peer, error = %e, "connection ended with an error");
                    }
                }
                Ok(Err(e)) => tracing::debug!(%peer, error = %e, "TLS handshake failed"),
                Err(_) => {
                    tracing::debug!(%peer, "TLS handshake not finished within the header deadline")
                }
            }
            drop(permit);
        });
    }
    drop(listener);
    if let Some((_, reloader)) = &tls {
        reloader.abort();
    }
    tracing::info!("shutting down");
    tokio::select! {
        () = graceful.shutdown() => {}
        () = tokio::time::sleep(DRAIN_LIMIT) => {
            tracing::warn!("requests still running after {DRAIN_LIMIT:?}; closing them");
        }
    }
    Ok(())
}

/// A connection's service that counts its requests and closes the connection after the
/// [`MAX_REQUESTS_PER_CONNECTION`]th answer (`Connection: close`, which hyper obeys).
#[derive(Clone)]
struct CountedRequests<S> {
    inner: S,
    served: Arc<AtomicUsize>,
}

impl<S> CountedRequests<S> {
    fn new(inner: S) -> CountedRequests<S> {
        CountedRequests {
            inner,
            served: Arc::default(),
        }
    }
}

impl<S, B> tower::Service<axum::http::Request<B>> for CountedRequests<S>
where
    S: tower::Service<axum::http::Request<B>, Response = axum::response::Response>,
    S::Future: Send + 'static,
{
    type Response = axum::response::Response;
    type Error = S::Error;
    type Future = futures_util::future::BoxFuture<'static, Result<Self::Response, S::Error>>;

    fn poll_ready(
        &mut self,
        cx: &mut std::task::Context<'_>,
    ) -> std::task::Poll<Result<(), S::Error>> {
        self.inner.poll_ready(cx)
    }

    fn call(&mut self, request: axum::http::Request<B>) -> Self::Future {
        let last = self.served.fetch_add(1, Ordering::Relaxed) + 1 >= MAX_REQUESTS_PER_CONNECTION;
        let answer = self.inner.call(request);
        Box::pin(async move {
            let mut response = answer.await?;
            if last {
                response.headers_mut().insert(
                    axum::http::header::CONNECTION,
                    axum::http::HeaderValue::from_static("close"),
                );
            }
            Ok(response)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cap_stays_under_the_descriptor_limit() {
        assert_eq!(connection_cap(1024, u64::MAX), Some(1024));
        assert_eq!(
            connection_cap(1024, 256),
            Some(256 - RESERVED_DESCRIPTORS as usize)
        );
        assert_eq!(connection_cap(10, 256), Some(10));
        assert_eq!(connection_cap(1024, RESERVED_DESCRIPTORS), None);
    }
}
