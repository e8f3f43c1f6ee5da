//! Slow and half-open connections over a real loopback socket: each is cut off at its deadline
//! (the header deadline closes, the request deadline answers 408 and closes), and the
//! connection cap makes later connections wait instead of failing. Deadlines here are a few
//! hundred milliseconds; every wait has a bound a few times larger.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

const HEADER: Duration = Duration::from_millis(300);
const REQUEST: Duration = Duration::from_millis(600);
/// Longer than any deadline above plus scheduling slack; the point where a test gives up.
const GIVE_UP: Duration = Duration::from_secs(3);

struct Server {
    addr: SocketAddr,
    _dir: tempfile::TempDir,
    _stop: tokio::sync::oneshot::Sender<()>,
}

async fn start(max_connections: usize) -> Server {
    start_with(max_connections, 64).await
}

async fn start_with(max_connections: usize, per_address: usize) -> Server {
    let dir = tempfile::tempdir().unwrap();
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let mut config = spindle_server::Config::new(dir.path());
    config.timeouts = spindle_server::Timeouts {
        header: HEADER,
        request: REQUEST,
    };
    config.max_connections = max_connections;
    config.max_connections_per_address = per_address;
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    tokio::spawn(spindle_server::run(config, listener, async {
        let _ = stopped.await;
    }));
    // Ready once it answers.
    let deadline = Instant::now() + GIVE_UP;
    while TcpStream::connect(addr).await.is_err() {
        assert!(Instant::now() < deadline, "the server did not start");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    Server {
        addr,
        _dir: dir,
        _stop: stop,
    }
}

/// Reads until the server closes the connection; the bytes it sent, or `None` if it was still
/// open after [`GIVE_UP`].
async fn read_until_closed(stream: &mut (impl AsyncReadExt + Unpin)) -> Option<String> {
    let mut seen = Vec::new();
    let read = tokio::time::timeout(GIVE_UP, async {
        let mut buf = [0u8; 4096];
        loop {
            match stream.read(&mut buf).await {
                Ok(0) | Err(_) => break,
                Ok(n) => seen.extend_from_slice(&buf[..n]),
            }
        }
    })
    .await;
    read.ok()
        .map(|()| String::from_utf8_lossy(&seen).into_owned())
}

#[tokio::test]
async fn half_a_request_line_is_closed_at_the_header_deadline() {
    let server = start(64).await;
    let mut stream = TcpStream::connect(server.addr).await.unwrap();
    stream.write_all(b"GET /heal").await.unwrap();
    let closed = read_until_closed(&mut stream).await;
    assert_eq!(closed.as_deref(), Some(""), "still open after {GIVE_UP:?}");
}

#[tokio::test]
async fn headers_sent_a_line_at_a_time_are_cut_off() {
    let server = start(64).await;
    let stream = TcpStream::connect(server.addr).await.unwrap();
    let (mut read, mut write) = stream.into_split();
    // One header line every 100 ms, for longer than GIVE_UP: the request would never end.
    let slowloris = tokio::spawn(async move {
        let _ = write.write_all(b"GET /healthz HTTP/1.1\r\n").await;
        for i in 0..60 {
            tokio::time::sleep(Duration::from_millis(100)).await;
            if write
                .write_all(format!("x-slow-{i}: y\r\n").as_bytes())
                .await
                .is_err()
            {
                break;
            }
        }
    });
    let closed = read_until_closed(&mut read).await;
    slowloris.abort();
    assert_eq!(
        closed.as_deref(),
        Some(""),
        "a request whose headers never end was not closed"
    );
}

#[tokio::test]
async fn an_idle_keep_alive_connection_is_closed() {
    let server = start(64).await;
    let mut stream = TcpStream::connect(server.addr).await.unwrap();
    stream
        .write_all(b"GET /healthz HTTP/1.1\r\nhost: x\r\n\r\n")
        .await
        .unwrap();
    let answered = read_until_closed(&mut stream)
        .await
        .expect("an idle connection is closed after the header deadline");
    assert!(answered.starts_with("HTTP/1.1 200"), "{answered}");
    assert!(answered.ends_with("ok"), "{answered}");
}

#[tokio::test]
async fn a_body_trickling_in_gets_408_at_the_request_deadline() {
    let server = start(64).await;
    let stream = TcpStream::connect(server.addr).await.unwrap();
    let (mut read, mut write) = stream.into_split();
    let started = Instant::now();
    // A byte every 100 ms (under the 300 ms pause limit) of a 1000-byte body: 100 s at this rate.
    let trickle = tokio::spawn(async move {
        let head = "POST /v1/assets/missing HTTP/1.1\r\nhost: x\r\ncontent-type: \
                    application/json\r\ncontent-length: 1000\r\n\r\n";
        let _ = write.write_all(head.as_bytes()).await;
        for _ in 0..1000 {
            if write.write_all(b" ").await.is_err() {
                break;
            }
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    });
    let answer = read_until_closed(&mut read).await;
    trickle.abort();
    let answer = answer.expect("a trickled body was still being read");
    assert!(answer.starts_with("HTTP/1.1 408"), "{answer}");
    assert!(
        answer.to_ascii_lowercase().contains("connection: close"),
        "{answer}"
    );
    assert!(answer.contains("request deadline"), "{answer}");
    assert!(started.elapsed() >= REQUEST, "408 before the deadline");
}

#[tokio::test]
async fn past_the_connection_cap_new_connections_wait_and_are_then_served() {
    let server = start(4).await;
    // Eight silent connections: four take the slots, four wait in the backlog.
    let mut silent = Vec::new();
    for _ in 0..8 {
        silent.push(TcpStream::connect(server.addr).await.unwrap());
    }
    let mut health = TcpStream::connect(server.addr).await.unwrap();
    health
        .write_all(b"GET /healthz HTTP/1.1\r\nhost: x\r\nconnection: close\r\n\r\n")
        .await
        .unwrap();
    let answer = read_until_closed(&mut health)
        .await
        .expect("/healthz answered once silent connections were closed");
    assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
    // Every silent connection was closed by the server (the header deadline).
    for mut stream in silent {
        assert_eq!(read_until_closed(&mut stream).await.as_deref(), Some(""));
    }
}

/// Connects with a small receive buffer, so the server's answers fill it at once.
async fn connect_small(addr: SocketAddr) -> TcpStream {
    let socket = tokio::net::TcpSocket::new_v4().unwrap();
    socket.set_recv_buffer_size(4096).unwrap();
    socket.connect(addr).await.unwrap()
}

#[tokio::test]
async fn clients_that_pipeline_large_answers_and_never_read_are_cut_and_others_served() {
    let server = start(4).await;
    // Four connections take every slot, each asking 200 times for the 65-KB API document
    // and reading none of it: the server's writes stall.
    let mut hogs = Vec::new();
    for _ in 0..4 {
        let mut stream = connect_small(server.addr).await;
        let requests = "GET /v1/openapi.json HTTP/1.1\r\nhost: x\r\n\r\n".repeat(200);
        stream.write_all(requests.as_bytes()).await.unwrap();
        hogs.push(stream);
    }
    let mut health = TcpStream::connect(server.addr).await.unwrap();
    health
        .write_all(b"GET /healthz HTTP/1.1\r\nhost: x\r\nconnection: close\r\n\r\n")
        .await
        .unwrap();
    let answer = read_until_closed(&mut health)
        .await
        .expect("/healthz answered while four clients read none of their answers");
    assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
    drop(hogs);
}

#[tokio::test]
async fn a_connection_is_answered_a_bounded_number_of_requests_then_closed() {
    let server = start(4).await;
    let mut stream = TcpStream::connect(server.addr).await.unwrap();
    let n = spindle_server::serve::MAX_REQUESTS_PER_CONNECTION;
    let requests = "GET /healthz HTTP/1.1\r\nhost: x\r\n\r\n".repeat(n + 5);
    stream.write_all(requests.as_bytes()).await.unwrap();
    let answers = read_until_closed(&mut stream)
        .await
        .expect("the connection is closed");
    assert_eq!(answers.matches("HTTP/1.1 200").count(), n, "{answers}");
    assert!(
        answers.to_ascii_lowercase().contains("connection: close"),
        "the last answer says so"
    );
}

#[tokio::test]
async fn one_address_reopening_half_open_connections_leaves_the_probes_answered() {
    let server = start_with(8, 4).await;
    let addr = server.addr;
    // 32 half-open connections from 127.0.0.2, each reopened as soon as the server closes it,
    // for at most GIVE_UP.
    let end = Instant::now() + GIVE_UP;
    let mut attackers = tokio::task::JoinSet::new();
    for _ in 0..32 {
        attackers.spawn(async move {
            while Instant::now() < end {
                let socket = tokio::net::TcpSocket::new_v4().unwrap();
                socket.bind("127.0.0.2:0".parse().unwrap()).unwrap();
                if let Ok(mut stream) = socket.connect(addr).await {
                    let _ = stream.write_all(b"GET /heal").await;
                    let mut buf = [0u8; 64];
                    let _ = tokio::time::timeout_at(end.into(), stream.read(&mut buf)).await;
                }
                tokio::time::sleep(Duration::from_millis(5)).await;
            }
        });
    }
    tokio::time::sleep(Duration::from_millis(200)).await;
    // From 127.0.0.1, each probe is answered well within one header deadline.
    for path in ["/healthz", "/readyz", "/healthz", "/readyz"] {
        let mut probe = TcpStream::connect(addr).await.unwrap();
        probe
            .write_all(
                format!("GET {path} HTTP/1.1\r\nhost: x\r\nconnection: close\r\n\r\n").as_bytes(),
            )
            .await
            .unwrap();
        let mut answer = Vec::new();
        let read = tokio::time::timeout(HEADER * 2 / 3, probe.read_to_end(&mut answer)).await;
        assert!(
            read.is_ok(),
            "{path} not answered within {:?}",
            HEADER * 2 / 3
        );
        let answer = String::from_utf8_lossy(&answer);
        assert!(answer.starts_with("HTTP/1.1 200"), "{path}: {answer}");
    }
    attackers.abort_all();
}

/// Sends `GET /v1/events` and reads the answer's head.
async fn event_stream(addr: SocketAddr) -> (TcpStream, String) {
    let mut stream = TcpStream::connect(addr).await.unwrap();
    stream
        .write_all(b"GET /v1/events HTTP/1.1\r\nhost: x\r\n\r\n")
        .await
        .unwrap();
    let mut head = Vec::new();
    let read = tokio::time::timeout(GIVE_UP, async {
        let mut buf = [0u8; 1024];
        while !head.windows(4).any(|w| w == b"\r\n\r\n") {
            match stream.read(&mut buf).await {
                Ok(0) | Err(_) => break,
                Ok(n) => head.extend_from_slice(&buf[..n]),
            }
        }
    })
    .await;
    assert!(read.is_ok(), "no answer within {GIVE_UP:?}");
    (stream, String::from_utf8_lossy(&head).into_owned())
}

#[tokio::test]
async fn one_address_holds_at_most_four_event_streams() {
    let server = start(64).await;
    let mut open = Vec::new();
    for n in 1..=4 {
        let (stream, head) = event_stream(server.addr).await;
        assert!(head.starts_with("HTTP/1.1 200"), "stream {n}: {head}");
        open.push(stream);
    }
    let (_, head) = event_stream(server.addr).await;
    assert!(head.starts_with("HTTP/1.1 429"), "{head}");
    assert!(head.to_ascii_lowercase().contains("retry-after"), "{head}");
}
