//! `wiical live`'s web server: one embedded page (`page.html`: HTML, CSS and script in one
//! file, nothing fetched from the internet), the session's [`Snapshot`] as JSON, and a stream
//! of snapshots as server-sent events.
//!
//! Why tiny_http and threads rather than an async stack: one producer (the source) and at most
//! [`MAX_STREAMS`] viewers on localhost need no runtime; a blocked or vanished viewer costs one
//! thread that ends at its next write (a keep-alive comment every [`KEEPALIVE`]).
//!
//! [`Snapshot`]: wiical_analysis::live::Snapshot

pub mod capture;
pub mod source;

use std::io::Write;
use std::net::{IpAddr, SocketAddr};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;
use wiical_analysis::live::Snapshot;

/// The page, embedded in the binary.
pub const PAGE: &str = include_str!("page.html");

/// Event streams served at once; one more is answered 503.
pub const MAX_STREAMS: usize = 8;

/// Largest snapshot sent (bytes of JSON). The session bounds its poses and points so that a
/// snapshot stays well under this; one over it is replaced by an error message.
pub const MAX_MESSAGE_BYTES: usize = 1 << 20;

/// A stream with nothing new gets a comment this often (finds closed viewers).
pub const KEEPALIVE: Duration = Duration::from_millis(1000);

/// Why the server cannot start.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// A non-loopback address without `--bind`.
    #[error("the live view listens on {addr} only when asked: anyone on that network could watch; give --bind {addr} to mean it")]
    NotLocal {
        /// The address asked for.
        addr: IpAddr,
    },
    /// The port could not be bound.
    #[error("cannot listen on {addr}: {reason}")]
    Bind {
        /// Address and port.
        addr: SocketAddr,
        /// The system's reason.
        reason: String,
    },
}

/// The latest snapshot, shared between the source and the viewers.
#[derive(Default)]
pub struct Shared {
    state: Mutex<Published>,
    changed: Condvar,
}

#[derive(Default)]
struct Published {
    json: Arc<String>,
    version: u64,
}

impl Shared {
    /// Publishes a snapshot (serialised once, shared by every viewer).
    pub fn publish(&self, snap: &Snapshot) {
        let mut json = serde_json::to_string(snap).unwrap_or_else(|e| error_json(&e.to_string()));
        if json.len() > MAX_MESSAGE_BYTES {
            json = error_json(&format!(
                "snapshot of {} bytes exceeds the {MAX_MESSAGE_BYTES}-byte message limit",
                json.len()
            ));
        }
        let mut st = self.state.lock().unwrap_or_else(|p| p.into_inner());
        st.json = Arc::new(json);
        st.version += 1;
        self.changed.notify_all();
    }

    /// The latest snapshot and its version (0: none yet).
    fn latest(&self) -> (Arc<String>, u64) {
        let st = self.state.lock().unwrap_or_else(|p| p.into_inner());
        (st.json.clone(), st.version)
    }

    /// Waits up to `timeout` for a version newer than `seen`.
    fn wait_newer(&self, seen: u64, timeout: Duration) -> Option<(Arc<String>, u64)> {
        let st = self.state.lock().unwrap_or_else(|p| p.into_inner());
        let (st, _) = self
            .changed
            .wait_timeout_while(st, timeout, |s| s.version <= seen)
            .unwrap_or_else(|p| p.into_inner());
        (st.version > seen).then(|| (st.json.clone(), st.version))
    }
}

/// Where the page takes the snapshot it was served with.
const SNAPSHOT_MARK: &str = "/*SNAPSHOT*/null";

/// The page with `json` (the latest snapshot, empty before the first) as its first picture.
/// `<` is escaped so that no string in the snapshot can end the script element.
pub fn page(json: &str) -> String {
    if json.is_empty() {
        return PAGE.to_string();
    }
    PAGE.replacen(SNAPSHOT_MARK, &json.replace('<', "\\u003c"), 1)
}

fn error_json(msg: &str) -> String {
    serde_json::json!({ "error": msg }).to_string()
}

/// A bound server: its address is known before it serves (the CLI prints the port).
pub struct LiveServer {
    server: tiny_http::Server,
    addr: SocketAddr,
    streams: Arc<AtomicUsize>,
}

impl LiveServer {
    /// Binds `ip:port` (`port` 0: any free port). A non-loopback `ip` is refused unless
    /// `allow_remote` (the CLI's `--bind`).
    pub fn bind(ip: IpAddr, port: u16, allow_remote: bool) -> Result<Self, ServeError> {
        if !ip.is_loopback() && !allow_remote {
            return Err(ServeError::NotLocal { addr: ip });
        }
        let want = SocketAddr::new(ip, port);
        let server = tiny_http::Server::http(want).map_err(|e| ServeError::Bind {
            addr: want,
            reason: e.to_string(),
        })?;
        let addr = server.server_addr().to_ip().unwrap_or(want);
        Ok(Self {
            server,
            addr,
            streams: Arc::new(AtomicUsize::new(0)),
        })
    }

    /// The address it listens on (with the port chosen for port 0).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Serves until the process ends: the page, `/snapshot.json`, `/events`.
    pub fn serve(&self, shared: &Arc<Shared>) {
        for req in self.server.incoming_requests() {
            self.handle(req, shared);
        }
    }

    fn handle(&self, req: tiny_http::Request, shared: &Arc<Shared>) {
        use tiny_http::{Method, Response};
        if *req.method() != Method::Get {
            let _ = req.respond(Response::from_string("only GET").with_status_code(405));
            return;
        }
        let path = req.url().split('?').next().unwrap_or("").to_string();
        let result = match path.as_str() {
            "/" | "/index.html" => req.respond(
                Response::from_string(page(&shared.latest().0))
                    .with_header(header("Content-Type", "text/html; charset=utf-8"))
                    .with_chunked_threshold(usize::MAX),
            ),
            "/snapshot.json" => {
                let (json, _) = shared.latest();
                req.respond(
                    Response::from_string(json.as_str())
                        .with_header(header("Content-Type", "application/json"))
                        .with_chunked_threshold(usize::MAX),
                )
            }
            "/events" => {
                self.start_stream(req, shared);
                Ok(())
            }
            _ => req.respond(Response::from_string("not found").with_status_code(404)),
        };
        // A viewer that went away before its answer was written: nothing to do.
        drop(result);
    }

    /// Hands the connection to a thread of its own, or answers 503 beyond [`MAX_STREAMS`].
    fn start_stream(&self, req: tiny_http::Request, shared: &Arc<Shared>) {
        let taken = self
            .streams
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| {
                (n < MAX_STREAMS).then_some(n + 1)
            });
        if taken.is_err() {
            let msg = format!("at most {MAX_STREAMS} live views at once");
            let _ = req.respond(tiny_http::Response::from_string(msg).with_status_code(503));
            return;
        }
        let streams = self.streams.clone();
        let shared = shared.clone();
        std::thread::spawn(move || {
            let _guard = StreamGuard(streams);
            let _ = stream_events(req.into_writer(), &shared);
        });
    }
}

/// Frees a stream slot when its thread ends, however it ends.
struct StreamGuard(Arc<AtomicUsize>);

impl Drop for StreamGuard {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

/// Writes the event stream until the viewer goes away (a write fails).
fn stream_events(mut w: Box<dyn Write + Send>, shared: &Shared) -> std::io::Result<()> {
    w.write_all(
        b"HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-cache\r\nConnection: close\r\n\r\n",
    )?;
    let (json, mut seen) = shared.latest();
    if seen > 0 {
        write!(w, "data: {json}\n\n")?;
    }
    w.flush()?;
    loop {
        match shared.wait_newer(seen, KEEPALIVE) {
            Some((json, v)) => {
                seen = v;
                write!(w, "data: {json}\n\n")?;
            }
            None => w.write_all(b": keep-alive\n\n")?,
        }
        w.flush()?;
    }
}

fn header(name: &str, value: &str) -> tiny_http::Header {
    tiny_http::Header::from_bytes(name.as_bytes(), value.as_bytes())
        .unwrap_or_else(|()| unreachable!("static header"))
}
