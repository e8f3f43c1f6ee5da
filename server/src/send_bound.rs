//! A connection's send bound, which a handler may tighten for the rest of its connection.
//!
//! Every connection has the front door's write deadline ([`crate::serve`]): a write that makes
//! no progress within the header deadline ends it. That is loose for an answer that never ends,
//! an event stream: the coordinator's send buffer (the kernel grows it to megabytes on a fast
//! link) and the client's receive buffer go on taking a stream's events long after its reader
//! stopped reading, so the deadline would start only once megabytes had piled up, and the
//! stream's place (one of few, [`crate::events`]) stays taken all that while. A handler serving
//! such an answer tightens its connection with [`SendBound::tighten`]: the socket's send buffer
//! is fixed at a few kilobytes and a write may wait only a short time, so a reader that stops is
//! cut once its own receive buffer is full, seconds after the events that filled it.
//!
//! Invariant: a [`Tightened`] bound, once set, holds for every later write of the connection
//! (answers on it are sent in order, so the tightening answer's bytes and all after it).

use std::io;
use std::pin::Pin;
use std::sync::{Arc, OnceLock};
use std::task::{Context, Poll};
use std::time::Duration;

use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::TcpStream;
use tokio_io_timeout::TimeoutStream;

/// What a tightened connection may hold back from a reader that does not read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tightened {
    /// The longest a write may make no progress before the connection is closed.
    pub write_wait: Duration,
    /// The socket's send buffer (`SO_SNDBUF`; Linux keeps twice this for its bookkeeping).
    pub send_buffer: usize,
}

/// A handle on one connection's bound, given to its requests as an extension (absent in the
/// in-process router of tests, where there is no socket).
#[derive(Clone, Debug, Default)]
pub struct SendBound(Arc<OnceLock<Tightened>>);

impl SendBound {
    /// Tightens the connection from its next write on; the first tightening stays.
    pub fn tighten(&self, bound: Tightened) {
        let _ = self.0.set(bound);
    }
}

/// A client's socket with the front door's write deadline and the bound its handlers set.
pub struct BoundedStream {
    inner: Pin<Box<TimeoutStream<TcpStream>>>,
    bound: SendBound,
    applied: bool,
}

impl BoundedStream {
    /// `stream` whose writes may make no progress for at most `write_wait`, and the handle
    /// through which a handler tightens it.
    pub fn new(stream: TcpStream, write_wait: Duration) -> (BoundedStream, SendBound) {
        let mut stream = TimeoutStream::new(stream);
        stream.set_write_timeout(Some(write_wait));
        let bound = SendBound::default();
        let bounded = BoundedStream {
            inner: Box::pin(stream),
            bound: bound.clone(),
            applied: false,
        };
        (bounded, bound)
    }

    /// Applies a tightening asked for since the last write.
    fn apply(&mut self) {
        if self.applied {
            return;
        }
        let Some(bound) = self.bound.0.get() else {
            return;
        };
        self.applied = true;
        let socket = socket2::SockRef::from(self.inner.get_ref());
        if let Err(e) = socket.set_send_buffer_size(bound.send_buffer) {
            // The write deadline below still holds; only the buffering before it is longer.
            tracing::debug!(error = %e, "shrinking a connection's send buffer failed");
        }
        self.inner
            .as_mut()
            .set_write_timeout_pinned(Some(bound.write_wait));
    }
}

impl AsyncRead for BoundedStream {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        self.get_mut().inner.as_mut().poll_read(cx, buf)
    }
}

impl AsyncWrite for BoundedStream {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        let this = self.get_mut();
        this.apply();
        this.inner.as_mut().poll_write(cx, buf)
    }

    fn poll_write_vectored(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[io::IoSlice<'_>],
    ) -> Poll<io::Result<usize>> {
        let this = self.get_mut();
        this.apply();
        this.inner.as_mut().poll_write_vectored(cx, bufs)
    }

    fn is_write_vectored(&self) -> bool {
        self.inner.is_write_vectored()
    }

    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        this.apply();
        this.inner.as_mut().poll_flush(cx)
    }

    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        self.get_mut().inner.as_mut().poll_shutdown(cx)
    }
}
