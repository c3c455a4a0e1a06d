//! `wiical live`'s web server: one embedded page (`page.html`: HTML, CSS and script in one
//! file, nothing fetched from the internet), the session's [`Snapshot`] as JSON, and a stream
//! of snapshots as server-sent events.
//!
//! Why hyper on a small single-threaded tokio runtime: every connection is a task of its own
//! with bounded reads and writes (see [`http`]), so one client that never reads, sends slowly,
//! pipelines behind `/events` or declares a huge body cannot stop the others or the server.
//!
//! [`Snapshot`]: wiical_analysis::live::Snapshot

pub mod capture;
pub mod gyro;
pub mod http;
pub mod source;

use std::net::{IpAddr, SocketAddr, TcpListener};
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::watch;
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

/// The latest snapshot, shared between the source (a plain thread) and the viewers (tasks):
/// a watch channel keeps only the newest, so a slow viewer skips pictures rather than queueing
/// them.
pub struct Shared {
    tx: watch::Sender<Published>,
    /// An adapter's background-recalibration grid, published with every snapshot as
    /// `adapter_grid` (set by the device source; `None` for a replay).
    grid: std::sync::Mutex<Option<serde_json::Value>>,
    /// A MotionPlus's rates ([`gyro::GyroSnapshot`]), published with every snapshot as
    /// `gyro` (set by the device source while the adapter streams gyro samples).
    gyro: std::sync::Mutex<Option<serde_json::Value>>,
}

impl Default for Shared {
    fn default() -> Self {
        Self {
            tx: watch::channel(Published::default()).0,
            grid: std::sync::Mutex::new(None),
            gyro: std::sync::Mutex::new(None),
        }
    }
}

/// One published snapshot: its JSON and its number (0: none yet).
#[derive(Clone, Default)]
pub(crate) struct Published {
    pub(crate) json: Arc<String>,
    pub(crate) version: u64,
}

impl Shared {
    /// Publishes a snapshot (serialised once, shared by every viewer).
    pub fn publish(&self, snap: &Snapshot) {
        let grid = self.grid.lock().map(|g| g.clone()).unwrap_or(None);
        let gyro = self.gyro.lock().map(|g| g.clone()).unwrap_or(None);
        let mut json = match (grid, gyro) {
            (None, None) => serde_json::to_string(snap),
            (grid, gyro) => serde_json::to_value(snap).map(|mut v| {
                if let Some(g) = grid {
                    v["adapter_grid"] = g;
                }
                if let Some(g) = gyro {
                    v["gyro"] = g;
                }
                v.to_string()
            }),
        }
        .unwrap_or_else(|e| error_json(&e.to_string()));
        if json.len() > MAX_MESSAGE_BYTES {
            json = error_json(&format!(
                "snapshot of {} bytes exceeds the {MAX_MESSAGE_BYTES}-byte message limit",
                json.len()
            ));
        }
        // send_modify stores the value even while no viewer is subscribed.
        self.tx.send_modify(|p| {
            p.json = Arc::new(json);
            p.version += 1;
        });
    }

    /// Sets the adapter grid published with the next snapshots (see the `grid` field).
    pub fn set_adapter_grid(&self, grid: serde_json::Value) {
        if let Ok(mut g) = self.grid.lock() {
            *g = Some(grid);
        }
    }

    /// Sets the gyro view published with the next snapshots (see the `gyro` field).
    pub fn set_gyro(&self, gyro: serde_json::Value) {
        if let Ok(mut g) = self.gyro.lock() {
            *g = Some(gyro);
        }
    }

    /// The latest snapshot and its version (0: none yet).
    pub(crate) fn latest(&self) -> Published {
        self.tx.borrow().clone()
    }

    /// A receiver that wakes on every newer snapshot.
    pub(crate) fn subscribe(&self) -> watch::Receiver<Published> {
        self.tx.subscribe()
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
    listener: TcpListener,
    addr: SocketAddr,
}

impl LiveServer {
    /// Binds `ip:port` (`port` 0: any free port). A non-loopback `ip` is refused unless
    /// `allow_remote` (the CLI's `--bind`).
    pub fn bind(ip: IpAddr, port: u16, allow_remote: bool) -> Result<Self, ServeError> {
        if !ip.is_loopback() && !allow_remote {
            return Err(ServeError::NotLocal { addr: ip });
        }
        let want = SocketAddr::new(ip, port);
        let bind_err = |e: std::io::Error| ServeError::Bind {
            addr: want,
            reason: e.to_string(),
        };
        let listener = TcpListener::bind(want).map_err(bind_err)?;
        listener.set_nonblocking(true).map_err(bind_err)?;
        let addr = listener.local_addr().unwrap_or(want);
        Ok(Self { listener, addr })
    }

    /// The address it listens on (with the port chosen for port 0).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Serves until the process ends: the page, `/snapshot.json`, `/events`. Returns only if
    /// the runtime cannot be started (the system refuses a timer or a socket poller).
    pub fn serve(self, shared: &Arc<Shared>) -> std::io::Result<()> {
        let host = http::HostCheck::new(self.addr);
        http::serve(self.listener, shared.clone(), http::Limits::default(), host)
    }
}
