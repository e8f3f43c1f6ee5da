//! An event stream whose reader stops reading, over a real loopback socket: the coordinator cuts
//! it and gives its place back within seconds, while events keep coming.

use std::time::{Duration, Instant};

use spindle_common::protocol::EventKind;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};

use crate::events::{EVENT_SEND_WAIT, MAX_EVENT_STREAMS_PER_ADDRESS};
use crate::{AppState, Config, app, serve};

/// Opens `GET /v1/events` and reads the answer's head; its status code.
async fn open_stream(addr: std::net::SocketAddr) -> (u16, TcpStream) {
    let mut stream = TcpStream::connect(addr).await.unwrap();
    stream
        .write_all(b"GET /v1/events HTTP/1.1\r\nhost: spindle\r\n\r\n")
        .await
        .unwrap();
    let mut head = Vec::new();
    let mut byte = [0u8; 1];
    while !head.ends_with(b"\r\n\r\n") {
        assert_eq!(stream.read(&mut byte).await.unwrap(), 1, "closed: {head:?}");
        head.push(byte[0]);
    }
    let status = String::from_utf8_lossy(&head[9..12]).parse().unwrap();
    (status, stream)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_subscriber_that_stops_reading_loses_its_place_within_seconds() {
    // The default header deadline (10 s) is the front door's write deadline for every other
    // answer: a place that comes back sooner was freed by the event stream's own bound.
    let dir = tempfile::tempdir().unwrap();
    let config = Config::new(dir.path());
    assert!(config.timeouts.header >= Duration::from_secs(10));
    let state = AppState::open(config.clone()).await.unwrap();
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let (_stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let router = app(state.clone());
    tokio::spawn(async move {
        serve::serve(&config, listener, router, async {
            let _ = stopped.await;
        })
        .await
    });

    // Events of about a kilobyte, 3 MB/s, for as long as the test runs (a stream's head is
    // sent with its first event).
    let started = Instant::now();
    let events = state.clone();
    let publisher = tokio::spawn(async move {
        for n in 0.. {
            for _ in 0..64 {
                events.events().publish(EventKind::WorkerJoined {
                    worker_id: n,
                    worker: "w".repeat(1000),
                });
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    });

    // Every place of this address taken by readers that never read past the head.
    let mut stalled = Vec::new();
    for _ in 0..MAX_EVENT_STREAMS_PER_ADDRESS {
        let (status, stream) = open_stream(addr).await;
        assert_eq!(status, 200);
        stalled.push(stream);
    }
    assert_eq!(
        open_stream(addr).await.0,
        429,
        "the address's places are full"
    );

    // The buffers fill in a fraction of a second; then a write waits EVENT_SEND_WAIT.
    let limit = EVENT_SEND_WAIT + Duration::from_secs(4);
    let freed = loop {
        let (status, _probe) = open_stream(addr).await;
        if status == 200 {
            break started.elapsed();
        }
        assert_eq!(status, 429);
        assert!(
            started.elapsed() < limit,
            "no place came back within {limit:?} of the readers stopping"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    publisher.abort();
    assert!(freed >= EVENT_SEND_WAIT, "freed after {freed:?}");
    drop(stalled);
}
