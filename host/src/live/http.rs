//! The live view's HTTP/1.1 server: hyper on a single-threaded tokio runtime, one task per
//! connection.
//!
//! Every way a client can hold the server is bounded: the request head (size, header count,
//! time to arrive: hyper's limits), request bodies (never read: a request that declares one is
//! answered 413 and the connection closed, so a huge `Content-Length` costs nothing), writes (a
//! client that stops reading is dropped after [`Limits::write_timeout`], see [`TimedIo`]),
//! connections (at most [`Limits::max_connections`], and [`Limits::max_per_client`] from one
//! address: beyond either the oldest idle connection is dropped for the new one, see
//! [`Registry`], so idle or slow-header connections cannot lock a new viewer out) and event
//! streams (at most [`MAX_STREAMS`], counted per response, so pipelining cannot exceed it).
//!
//! Only a `Host` naming this machine's loopback (`127.0.0.1`, `localhost`, `[::1]`, with the
//! server's port or none; or the address given with `--bind`) is answered ([`HostCheck`]): a
//! web page whose name an attacker rebinds to 127.0.0.1 (DNS rebinding) sends its own name
//! as `Host` and is refused 421, so it cannot read the calibration stream.

use super::{page, Published, Shared, KEEPALIVE, MAX_STREAMS};
use http_body_util::{combinators::BoxBody, BodyExt, Full};
use hyper::body::{Body, Bytes, Frame, Incoming};
use hyper::header::{HeaderValue, CACHE_CONTROL, CONNECTION, CONTENT_TYPE};
use hyper::{Method, Request, Response, StatusCode};
use hyper_util::rt::{TokioIo, TokioTimer};
use std::convert::Infallible;
use std::future::Future;
use std::io;
use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddr};
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::sync::{mpsc, oneshot, watch};
use tokio::time::Sleep;

/// The server's bounds on what one client may cost.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// Connections open at once; one more takes the place of the oldest idle one, or is
    /// closed without an answer when every one is busy.
    pub max_connections: usize,
    /// Connections open at once from one client address; as `max_connections`, among that
    /// address's own connections (below `max_connections`, so one address alone never fills
    /// the server and pushes out only its own).
    pub max_per_client: usize,
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
            max_per_client: 16,
            max_head_bytes: 8 * 1024,
            max_headers: 64,
            head_timeout: Duration::from_secs(10),
            write_timeout: Duration::from_secs(10),
            keepalive: KEEPALIVE,
        }
    }
}

/// Serves `listener` (already non-blocking) until the process ends; `host` says which `Host`
/// headers are answered.
pub fn serve(
    listener: std::net::TcpListener,
    shared: Arc<Shared>,
    limits: Limits,
    host: HostCheck,
) -> io::Result<()> {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_io()
        .enable_time()
        .build()?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::from_std(listener)?;
        let registry = Arc::new(Mutex::new(Registry::default()));
        let streams = Arc::new(AtomicUsize::new(0));
        loop {
            let (sock, peer) = match listener.accept().await {
                Ok(accepted) => accepted,
                // Out of descriptors or a connection reset before it was accepted: the
                // listener itself is fine; wait a little so that a full table can drain.
                Err(_) => {
                    tokio::time::sleep(Duration::from_millis(20)).await;
                    continue;
                }
            };
            let admitted = match registry.lock() {
                Ok(mut r) => r.admit(peer.ip(), &limits),
                Err(_) => None,
            };
            // Every connection busy: the socket is dropped (closed) at once.
            let Some(Admitted {
                id,
                activity,
                evicted,
            }) = admitted
            else {
                continue;
            };
            let _ = sock.set_nodelay(true);
            let conn = Connection {
                shared: shared.clone(),
                streams: streams.clone(),
                limits,
                host,
            };
            let registry = registry.clone();
            tokio::spawn(async move {
                until_evicted(conn.serve_counted(sock, activity), evicted).await;
                if let Ok(mut r) = registry.lock() {
                    r.leave(id);
                }
            });
            // Let the new connection's task read what has already arrived (a viewer's whole
            // request) before the next one is admitted: otherwise one poll of `accept` takes
            // a whole backlog, and its admissions can drop connections whose requests were
            // waiting unread (a CI failure of `live_hostile`).
            tokio::task::yield_now().await;
        }
    })
}

/// Runs `work` until it ends or `evicted` fires (dropping `work` closes its connection).
async fn until_evicted(work: impl Future<Output = ()>, mut evicted: oneshot::Receiver<()>) {
    let mut work = std::pin::pin!(work);
    std::future::poll_fn(|cx| {
        if work.as_mut().poll(cx).is_ready() || Pin::new(&mut evicted).poll(cx).is_ready() {
            Poll::Ready(())
        } else {
            Poll::Pending
        }
    })
    .await;
}

/// The open connections, oldest first, for the caps of [`Limits`]. Why: a fixed number of
/// slots taken first come, first served lets anyone who opens that many idle (or slowly
/// sending) connections lock every viewer out for as long as they re-open them. Here a new
/// connection beyond a cap takes the place of an idle one (no request being answered:
/// waiting for a head, half a head, or between keep-alive requests), so a viewer always gets
/// in while any connection is idle; busy ones (a page being sent, an event stream) are never
/// dropped for it.
///
/// Which idle one: the oldest that has sent something, then the oldest that has sent
/// nothing. Why: a new viewer's connection is silent until its request arrives; dropped
/// oldest-first among all, it went after as many newer half-sent connections (slowloris) as
/// there are slots, so an attacker re-opening them fast enough dropped every viewer whose
/// request was a moment late (a CI failure of `live_hostile`). Against connections that send
/// nothing at all it is oldest-first as before.
#[derive(Default)]
pub struct Registry {
    next_id: u64,
    open: Vec<Entry>,
}

/// One open connection.
struct Entry {
    id: u64,
    peer: IpAddr,
    /// What its task reports.
    activity: Activity,
    /// Fired to drop the connection.
    evict: oneshot::Sender<()>,
}

/// What a connection's task tells the [`Registry`] about it.
#[derive(Clone, Default)]
pub struct Activity {
    /// Responses of this connection not yet finished (0: idle).
    pub busy: Arc<AtomicUsize>,
    /// Set once the client has sent any byte.
    pub heard: Arc<AtomicBool>,
}

impl Activity {
    fn idle(&self) -> bool {
        self.busy.load(Ordering::SeqCst) == 0
    }

    fn heard(&self) -> bool {
        self.heard.load(Ordering::SeqCst)
    }
}

/// What an admitted connection's task gets.
pub struct Admitted {
    /// Its number, to [`Registry::leave`] with.
    pub id: u64,
    /// Its state, to keep up to date.
    pub activity: Activity,
    /// Fires when it is dropped for a newer connection.
    pub evicted: oneshot::Receiver<()>,
}

impl Registry {
    /// Admits a connection from `peer`, dropping the oldest idle connection of that address
    /// when it is at [`Limits::max_per_client`], then the oldest idle one of any address when
    /// the server is at [`Limits::max_connections`]; `None` when a cap is reached and no
    /// connection it counts is idle.
    pub fn admit(&mut self, peer: IpAddr, limits: &Limits) -> Option<Admitted> {
        let mine = self.open.iter().filter(|e| e.peer == peer).count();
        if mine >= limits.max_per_client.max(1) && !self.evict_oldest_idle(Some(peer)) {
            return None;
        }
        if self.open.len() >= limits.max_connections.max(1) && !self.evict_oldest_idle(None) {
            return None;
        }
        let (evict, evicted) = oneshot::channel();
        let activity = Activity::default();
        self.next_id += 1;
        self.open.push(Entry {
            id: self.next_id,
            peer,
            activity: activity.clone(),
            evict,
        });
        Some(Admitted {
            id: self.next_id,
            activity,
            evicted,
        })
    }

    /// Drops an idle connection (of `peer` only, when given): the oldest that has sent
    /// something, else the oldest silent one (see the type's docs); false when none is idle.
    fn evict_oldest_idle(&mut self, peer: Option<IpAddr>) -> bool {
        let idle = |e: &Entry| peer.is_none_or(|p| e.peer == p) && e.activity.idle();
        let victim = self
            .open
            .iter()
            .position(|e| idle(e) && e.activity.heard())
            .or_else(|| self.open.iter().position(idle));
        let Some(i) = victim else {
            return false;
        };
        let _ = self.open.remove(i).evict.send(());
        true
    }

    /// Forgets connection `id` (ended by itself; nothing if it was evicted).
    pub fn leave(&mut self, id: u64) {
        self.open.retain(|e| e.id != id);
    }

    /// Connections open.
    pub fn len(&self) -> usize {
        self.open.len()
    }

    /// True when none is open.
    pub fn is_empty(&self) -> bool {
        self.open.is_empty()
    }
}

/// Which `Host` a request may name (the DNS-rebinding defence, module docs): `localhost`,
/// `127.0.0.1` or `[::1]`, or the address the server was bound to with `--bind` (any IP
/// literal when bound to all addresses: an address cannot be rebound, a name can), each with
/// the server's port or without a port.
#[derive(Clone, Copy, Debug)]
pub struct HostCheck {
    bound: SocketAddr,
}

impl HostCheck {
    /// The check for a server listening on `bound`.
    pub fn new(bound: SocketAddr) -> Self {
        Self { bound }
    }

    /// True when `host` (a `Host` header's value or a URI's authority) may be answered.
    pub fn allows(&self, host: &str) -> bool {
        let Some((name, port)) = split_host(host) else {
            return false;
        };
        if port.is_some_and(|p| p != self.bound.port()) {
            return false;
        }
        if name.eq_ignore_ascii_case("localhost") {
            return true;
        }
        let Ok(ip) = name.parse::<IpAddr>() else {
            return false;
        };
        let loopback =
            ip == IpAddr::V4(Ipv4Addr::LOCALHOST) || ip == IpAddr::V6(Ipv6Addr::LOCALHOST);
        loopback || ip == self.bound.ip() || self.bound.ip().is_unspecified()
    }

    /// The sentence of the refusal.
    fn refusal(&self) -> String {
        format!(
            "this server answers only Host 127.0.0.1, localhost or [::1] (port {}); open http://127.0.0.1:{}/",
            self.bound.port(),
            self.bound.port()
        )
    }
}

/// `host[:port]` or `[v6][:port]` split into the name (brackets removed) and the port; `None`
/// when malformed (an unbracketed IPv6 address, a port that is not a number).
fn split_host(host: &str) -> Option<(&str, Option<u16>)> {
    let (name, rest) = match host.strip_prefix('[') {
        Some(inner) => {
            let (name, rest) = inner.split_once(']')?;
            name.parse::<Ipv6Addr>().ok()?;
            (name, rest)
        }
        None => host.split_at(host.find(':').unwrap_or(host.len())),
    };
    let port = match rest {
        "" => None,
        _ => {
            let digits = rest.strip_prefix(':')?;
            if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
                return None;
            }
            Some(digits.parse().ok()?)
        }
    };
    (!name.is_empty()).then_some((name, port))
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
    /// Which `Host` headers are answered.
    pub host: HostCheck,
}

impl Connection {
    /// Serves HTTP/1.1 on `io` until the client closes it, an error, or a limit ends it.
    pub async fn serve<T>(self, io: T)
    where
        T: AsyncRead + AsyncWrite + Unpin + Send + 'static,
    {
        self.serve_counted(io, Activity::default()).await;
    }

    /// [`Connection::serve`], keeping in `activity` the number of its responses not yet
    /// finished (a response's body holds one until it is dropped: sent, or the connection
    /// gone) and whether the client has sent anything, which tell the [`Registry`] whether
    /// the connection is idle and which idle one to drop first.
    pub async fn serve_counted<T>(self, io: T, activity: Activity)
    where
        T: AsyncRead + AsyncWrite + Unpin + Send + 'static,
    {
        let limits = self.limits;
        let Activity { busy, heard } = activity;
        let svc = hyper::service::service_fn(move |req| {
            let guard = BusyGuard::new(busy.clone());
            let resp = self.route(&req).map(|body| {
                Busy {
                    body,
                    _guard: guard,
                }
                .boxed()
            });
            async move { Ok::<_, Infallible>(resp) }
        });
        let conn = hyper::server::conn::http1::Builder::new()
            .timer(TokioTimer::new())
            .header_read_timeout(limits.head_timeout)
            .max_buf_size(limits.max_head_bytes.max(8192))
            .max_header_size(limits.max_head_bytes)
            .max_headers(limits.max_headers)
            .serve_connection(
                TokioIo::new(TimedIo::new(io, limits.write_timeout, heard)),
                svc,
            );
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
        if !self.host_allowed(req) {
            let msg = self.host.refusal();
            return closing(text(StatusCode::MISDIRECTED_REQUEST, &msg));
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

    /// True when the request's `Host` (and the authority of an absolute URI, which HTTP
    /// puts before it) names this server ([`HostCheck`]); a request without one is refused.
    fn host_allowed(&self, req: &Request<Incoming>) -> bool {
        let header = req
            .headers()
            .get(hyper::header::HOST)
            .and_then(|h| h.to_str().ok());
        let authority = req.uri().authority().map(|a| a.as_str());
        match (header, authority) {
            (None, None) => false,
            (h, a) => h.into_iter().chain(a).all(|v| self.host.allows(v)),
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

/// One response in progress on a connection ([`Connection::serve_counted`]): counted from
/// when the request arrives until the response's body is dropped.
struct BusyGuard(Arc<AtomicUsize>);

impl BusyGuard {
    fn new(busy: Arc<AtomicUsize>) -> Self {
        busy.fetch_add(1, Ordering::SeqCst);
        Self(busy)
    }
}

impl Drop for BusyGuard {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

/// A response body that holds its connection's [`BusyGuard`] until it is dropped.
struct Busy {
    body: BoxBody<Bytes, Infallible>,
    _guard: BusyGuard,
}

impl Body for Busy {
    type Data = Bytes;
    type Error = Infallible;

    fn poll_frame(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
    ) -> Poll<Option<Result<Frame<Bytes>, Infallible>>> {
        Pin::new(&mut self.body).poll_frame(cx)
    }

    fn is_end_stream(&self) -> bool {
        self.body.is_end_stream()
    }

    fn size_hint(&self) -> hyper::body::SizeHint {
        self.body.size_hint()
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
/// read, and which sets `heard` at the first byte read. Written by hand because hyper bounds
/// reading the head but has no write timeout, and tokio's `timeout` would bound the whole
/// connection (an event stream is meant to last).
pub struct TimedIo<T> {
    io: T,
    timeout: Duration,
    stalled: Option<Pin<Box<Sleep>>>,
    heard: Arc<AtomicBool>,
}

impl<T> TimedIo<T> {
    /// Wraps `io`; `heard` is set once anything has been read from it.
    pub fn new(io: T, timeout: Duration, heard: Arc<AtomicBool>) -> Self {
        Self {
            io,
            timeout,
            stalled: None,
            heard,
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
        let before = buf.filled().len();
        let r = Pin::new(&mut self.io).poll_read(cx, buf);
        if matches!(r, Poll::Ready(Ok(()))) && buf.filled().len() > before {
            self.heard.store(true, Ordering::SeqCst);
        }
        r
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
