//! The live view's HTTP/1.1 server: hyper on a single-threaded tokio runtime, one task per
//! connection.
//!
//! Every way a client can hold the server is bounded: the request head (size, header count,
//! time to arrive: hyper's limits), request bodies (never read: a request that declares one is
//! answered 413 and the connection closed, so a huge `Content-Length` costs nothing), writes (a
//! client that stops reading is dropped after [`Limits::write_timeout`], see [`TimedIo`]),
//! connections (at most [`Limits::max_connections`]; more are closed at once) and event streams
//! (at most [`MAX_STREAMS`], counted per response, so pipelining cannot exceed it).

use super::{page, Published, Shared, KEEPALIVE, MAX_STREAMS};
use http_body_util::{combinators::BoxBody, BodyExt, Full};
use hyper::body::{Body, Bytes, Frame, Incoming};
use hyper::header::{HeaderValue, CACHE_CONTROL, CONNECTION, CONTENT_TYPE};
use hyper::{Method, Request, Response, StatusCode};
use hyper_util::rt::{TokioIo, TokioTimer};
use std::convert::Infallible;
use std::future::Future;
use std::io;
use std::pin::Pin;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::task::{Context, Poll};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::sync::{mpsc, watch, Semaphore};
use tokio::time::Sleep;

/// The server's bounds on what one client may cost.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// Connections open at once; one more is closed without an answer.
    pub max_connections: usize,
    /// Bytes of a request head (request line and headers); more is answered 431.
    pub max_head_bytes: usize,
    /// Headers in one request; more is answered 431.
    pub max_headers: usize,
    /// Time for a request head to arrive, counted from when the server waits for it (so an
    /// idle keep-alive connection is closed after this too).
    pub head_timeout: Duration,
    /// Time a write may wait for the client to read before the connection is dropped.
    pub write_timeout: Duration,
    /// Time between keep-alive comments on an event stream with nothing new.
    pub keepalive: Duration,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            max_connections: 64,
            max_head_bytes: 8 * 1024,
            max_headers: 64,
            head_timeout: Duration::from_secs(10),
            write_timeout: Duration::from_secs(10),
            keepalive: KEEPALIVE,
        }
    }
}

/// Serves `listener` (already non-blocking) until the process ends.
pub fn serve(
    listener: std::net::TcpListener,
    shared: Arc<Shared>,
    limits: Limits,
) -> io::Result<()> {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_io()
        .enable_time()
        .build()?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::from_std(listener)?;
        let conns = Arc::new(Semaphore::new(limits.max_connections));
        let streams = Arc::new(AtomicUsize::new(0));
        loop {
            let sock = match listener.accept().await {
                Ok((sock, _)) => sock,
                // Out of descriptors or a connection reset before it was accepted: the
                // listener itself is fine; wait a little so that a full table can drain.
                Err(_) => {
                    tokio::time::sleep(Duration::from_millis(20)).await;
                    continue;
                }
            };
            // Beyond the limit the socket is dropped (closed) at once.
            let Ok(permit) = conns.clone().try_acquire_owned() else {
                continue;
            };
            let _ = sock.set_nodelay(true);
            let conn = Connection {
                shared: shared.clone(),
                streams: streams.clone(),
                limits,
            };
            tokio::spawn(async move {
                conn.serve(sock).await;
                drop(permit);
            });
        }
    })
}

/// What one connection's task needs.
#[derive(Clone)]
pub struct Connection {
    /// The latest snapshot.
    pub shared: Arc<Shared>,
    /// Event streams open across all connections.
    pub streams: Arc<AtomicUsize>,
    /// The bounds.
    pub limits: Limits,
}

impl Connection {
    /// Serves HTTP/1.1 on `io` until the client closes it, an error, or a limit ends it.
    pub async fn serve<T>(self, io: T)
    where
        T: AsyncRead + AsyncWrite + Unpin + Send + 'static,
    {
        let limits = self.limits;
        let svc = hyper::service::service_fn(move |req| {
            let resp = self.route(&req);
            async move { Ok::<_, Infallible>(resp) }
        });
        let conn = hyper::server::conn::http1::Builder::new()
            .timer(TokioTimer::new())
            .header_read_timeout(limits.head_timeout)
            .max_buf_size(limits.max_head_bytes.max(8192))
            .max_header_size(limits.max_head_bytes)
            .max_headers(limits.max_headers)
            .serve_connection(TokioIo::new(TimedIo::new(io, limits.write_timeout)), svc);
        // Errors (malformed requests, timeouts, a vanished client) end only this connection;
        // hyper has already answered what can be answered (400, 431).
        let _ = conn.await;
    }

    /// The answer to one request.
    fn route(&self, req: &Request<Incoming>) -> Response<BoxBody<Bytes, Infallible>> {
        if req.method() != Method::GET {
            return closing(text(StatusCode::METHOD_NOT_ALLOWED, "only GET"));
        }
        if !req.body().is_end_stream() {
            return closing(text(
                StatusCode::PAYLOAD_TOO_LARGE,
                "a GET request carries no body",
            ));
        }
        match req.uri().path() {
            "/" | "/index.html" => {
                let html = page(&self.shared.latest().json);
                typed(StatusCode::OK, html, "text/html; charset=utf-8")
            }
            "/snapshot.json" => {
                let json = self.shared.latest().json.as_str().to_string();
                typed(StatusCode::OK, json, "application/json")
            }
            "/events" => self.start_stream(),
            _ => text(StatusCode::NOT_FOUND, "not found"),
        }
    }

    /// An event stream, or 503 beyond [`MAX_STREAMS`].
    fn start_stream(&self) -> Response<BoxBody<Bytes, Infallible>> {
        let taken = self
            .streams
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| {
                (n < MAX_STREAMS).then_some(n + 1)
            });
        if taken.is_err() {
            let msg = format!("at most {MAX_STREAMS} live views at once");
            return closing(text(StatusCode::SERVICE_UNAVAILABLE, &msg));
        }
        let slot = StreamSlot(self.streams.clone());
        // Two frames in flight at most: a viewer that reads slowly holds no more than that.
        let (tx, rx) = mpsc::channel(2);
        tokio::spawn(pump(self.shared.subscribe(), tx, self.limits.keepalive));
        let body = EventBody { rx, _slot: slot };
        let mut resp = Response::new(body.boxed());
        let h = resp.headers_mut();
        h.insert(CONTENT_TYPE, HeaderValue::from_static("text/event-stream"));
        h.insert(CACHE_CONTROL, HeaderValue::from_static("no-cache"));
        // The stream never ends: nothing pipelined behind it on this connection is answered.
        h.insert(CONNECTION, HeaderValue::from_static("close"));
        resp
    }
}

/// Feeds an event stream: the latest snapshot at once, then every newer one, a keep-alive
/// comment when nothing is new. Ends when the stream's body is dropped (the viewer went away
/// or its connection was dropped).
async fn pump(mut rx: watch::Receiver<Published>, tx: mpsc::Sender<Bytes>, keepalive: Duration) {
    let first = rx.borrow_and_update().clone();
    // Something at once, so that the answer's head is written before the first change.
    let msg = if first.version > 0 {
        event(&first.json)
    } else {
        Bytes::from_static(b": waiting for the first snapshot\n\n")
    };
    if tx.send(msg).await.is_err() {
        return;
    }
    loop {
        let msg = match tokio::time::timeout(keepalive, rx.changed()).await {
            Ok(Ok(())) => event(&rx.borrow_and_update().json),
            // The publisher is gone: the last picture stays; keep the viewer's connection.
            Ok(Err(_)) => {
                tokio::time::sleep(keepalive).await;
                Bytes::from_static(b": keep-alive\n\n")
            }
            Err(_) => Bytes::from_static(b": keep-alive\n\n"),
        };
        if tx.send(msg).await.is_err() {
            return;
        }
    }
}

fn event(json: &str) -> Bytes {
    Bytes::from(format!("data: {json}\n\n"))
}

/// The body of an event stream: frames from [`pump`]; holds its stream slot until dropped.
struct EventBody {
    rx: mpsc::Receiver<Bytes>,
    _slot: StreamSlot,
}

impl Body for EventBody {
    type Data = Bytes;
    type Error = Infallible;

    fn poll_frame(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
    ) -> Poll<Option<Result<Frame<Bytes>, Infallible>>> {
        self.rx.poll_recv(cx).map(|m| m.map(|b| Ok(Frame::data(b))))
    }
}

/// Frees an event-stream slot when its body is dropped, however the stream ends.
struct StreamSlot(Arc<AtomicUsize>);

impl Drop for StreamSlot {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

fn typed(
    code: StatusCode,
    body: String,
    content_type: &'static str,
) -> Response<BoxBody<Bytes, Infallible>> {
    let mut resp = Response::new(Full::new(Bytes::from(body)).boxed());
    *resp.status_mut() = code;
    resp.headers_mut()
        .insert(CONTENT_TYPE, HeaderValue::from_static(content_type));
    resp
}

fn text(code: StatusCode, msg: &str) -> Response<BoxBody<Bytes, Infallible>> {
    typed(code, msg.to_string(), "text/plain; charset=utf-8")
}

/// The answer, and the connection closed after it (what follows on it is not read).
fn closing(mut resp: Response<BoxBody<Bytes, Infallible>>) -> Response<BoxBody<Bytes, Infallible>> {
    resp.headers_mut()
        .insert(CONNECTION, HeaderValue::from_static("close"));
    resp
}

/// A connection whose writes fail with `TimedOut` after waiting `timeout` for the client to
/// read. Written by hand because hyper bounds reading the head but has no write timeout, and
/// tokio's `timeout` would bound the whole connection (an event stream is meant to last).
pub struct TimedIo<T> {
    io: T,
    timeout: Duration,
    stalled: Option<Pin<Box<Sleep>>>,
}

impl<T> TimedIo<T> {
    /// Wraps `io`.
    pub fn new(io: T, timeout: Duration) -> Self {
        Self {
            io,
            timeout,
            stalled: None,
        }
    }

    /// `Ready(Err)` once a write has been pending for the whole timeout; resets on progress.
    fn check<R>(&mut self, cx: &mut Context<'_>, r: Poll<io::Result<R>>) -> Poll<io::Result<R>> {
        if r.is_ready() {
            self.stalled = None;
            return r;
        }
        let timeout = self.timeout;
        let sleep = self
            .stalled
            .get_or_insert_with(|| Box::pin(tokio::time::sleep(timeout)));
        if sleep.as_mut().poll(cx).is_ready() {
            self.stalled = None;
            return Poll::Ready(Err(io::Error::new(
                io::ErrorKind::TimedOut,
                "the client stopped reading",
            )));
        }
        Poll::Pending
    }
}

impl<T: AsyncRead + Unpin> AsyncRead for TimedIo<T> {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        Pin::new(&mut self.io).poll_read(cx, buf)
    }
}

impl<T: AsyncWrite + Unpin> AsyncWrite for TimedIo<T> {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        let r = Pin::new(&mut self.io).poll_write(cx, buf);
        self.check(cx, r)
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let r = Pin::new(&mut self.io).poll_flush(cx);
        self.check(cx, r)
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let r = Pin::new(&mut self.io).poll_shutdown(cx);
        self.check(cx, r)
    }
}
