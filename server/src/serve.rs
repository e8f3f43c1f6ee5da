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
//! - at most [`Config::max_connections`] connections are open at once, kept below the process's
//!   descriptor limit by [`connection_cap`]; further connections wait in the listen backlog
//!   until one closes, so accepting never fails for want of descriptors.
//!
//! Shutdown stops accepting, lets in-flight requests finish (long polls end at once, see
//! [`crate::AppState::begin_shutdown`]) and closes idle connections.

use std::future::Future;
use std::net::SocketAddr;
use std::sync::Arc;
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
use crate::tls;

/// Descriptors kept for everything but client connections: the database and its journal, asset
/// and image files being written, the log, the listener.
pub const RESERVED_DESCRIPTORS: u64 = 64;

/// How long shutdown waits for in-flight requests before closing their connections.
const DRAIN_LIMIT: Duration = Duration::from_secs(30);

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
    let mut http = hyper::server::conn::http1::Builder::new();
    http.timer(TokioTimer::new())
        .header_read_timeout(config.timeouts.header)
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
        let _ = stream.set_nodelay(true);
        let service = TowerToHyperService::new(AddExtension::new(
            router.clone(),
            ConnectInfo::<SocketAddr>(peer),
        ));
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
