//! Arbitrary bytes as an HTTP/1.1 client of `wiical live`'s server (one connection, served by
//! the same code as a real socket, over an in-memory pipe): it must never panic, whatever it
//! writes back must be HTTP answers (1.1, or 1.0 to a 1.0 request), and a connection must end
//! (or be cut by the harness after a short wait, for an event stream that legitimately lasts)
//! within a bounded output.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::sync::atomic::AtomicUsize;
use std::sync::{Arc, OnceLock};
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use wiical::live::http::{Connection, HostCheck, Limits};
use wiical::live::Shared;

/// Most of an answer read per input: an event stream never ends by itself.
const MAX_OUTPUT: usize = 1 << 20;

fn runtime() -> &'static tokio::runtime::Runtime {
    static RT: OnceLock<tokio::runtime::Runtime> = OnceLock::new();
    RT.get_or_init(|| {
        tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .expect("a runtime")
    })
}

fuzz_target!(|data: &[u8]| {
    let shared = Arc::new(Shared::default());
    let conn = Connection {
        shared,
        streams: Arc::new(AtomicUsize::new(0)),
        limits: Limits {
            head_timeout: Duration::from_millis(50),
            write_timeout: Duration::from_millis(50),
            keepalive: Duration::from_millis(10),
            ..Limits::default()
        },
        // Requests naming another host are answered 421 before any route.
        host: HostCheck::new(std::net::SocketAddr::from(([127, 0, 0, 1], 8080))),
    };
    let out = runtime().block_on(async move {
        let (mut client, server) = tokio::io::duplex(64 * 1024);
        let task = tokio::spawn(conn.serve(server));
        let request = data.to_vec();
        let writer = async {
            let _ = client.write_all(&request).await;
            let _ = client.shutdown().await;
        };
        let _ = tokio::time::timeout(Duration::from_millis(200), writer).await;
        let mut out = Vec::new();
        let mut buf = [0u8; 8192];
        let read = async {
            while out.len() < MAX_OUTPUT {
                match client.read(&mut buf).await {
                    Ok(0) | Err(_) => break,
                    Ok(n) => out.extend_from_slice(&buf[..n]),
                }
            }
        };
        let _ = tokio::time::timeout(Duration::from_millis(200), read).await;
        drop(client);
        let _ = tokio::time::timeout(Duration::from_millis(200), task).await;
        out
    });
    // hyper answers an HTTP/1.0 request in HTTP/1.0, as RFC 9110 asks.
    assert!(
        out.is_empty() || out.starts_with(b"HTTP/1.1 ") || out.starts_with(b"HTTP/1.0 "),
        "not an HTTP answer: {:?}",
        String::from_utf8_lossy(&out[..out.len().min(200)])
    );
});
