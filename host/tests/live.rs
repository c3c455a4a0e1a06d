//! `wiical live` end to end: the page in a real browser (Debian's headless Chromium, installed
//! by scripts/setup) while a real recording is replayed, and the server's bounds: loopback
//! unless `--bind`, at most 8 event streams, viewers that vanish mid-stream.

mod common;

use common::{data_dir, json};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A running `wiical live`, killed when dropped.
struct Live {
    child: Child,
    port: u16,
}

impl Drop for Live {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn xsens() -> PathBuf {
    data_dir().join("imu_tk_xsens/xsens_acc.mat")
}

/// Starts `wiical live ARGS` and reads the port from its first line.
fn start(args: &[&str]) -> Live {
    let mut child = Command::new(env!("CARGO_BIN_EXE_wiical"))
        .arg("live")
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let port = line
        .split("http://")
        .nth(1)
        .and_then(|r| r.split('/').next())
        .and_then(|a| a.rsplit(':').next())
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("no address in {line:?}"));
    Live { child, port }
}

/// One GET with `Connection: close`: status code and body.
fn get(port: u16, path: &str) -> (u16, String) {
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut buf = String::new();
    s.read_to_string(&mut buf).unwrap();
    let code = buf[9..12].parse().unwrap();
    let body = buf
        .split_once("\r\n\r\n")
        .map_or("", |(_, b)| b)
        .to_string();
    (code, body)
}

/// Opens `/events`: the status code and the stream after its status line.
fn open_stream(port: u16) -> (u16, TcpStream) {
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    write!(s, "GET /events HTTP/1.1\r\nHost: localhost\r\n\r\n").unwrap();
    let mut head = [0u8; 12];
    s.read_exact(&mut head).unwrap();
    let code = std::str::from_utf8(&head[9..12]).unwrap().parse().unwrap();
    (code, s)
}

/// Opens `/events`, retrying while the server answers 503 (for up to 5 s).
fn open_when_free(port: u16) -> TcpStream {
    let t0 = Instant::now();
    loop {
        let (code, s) = open_stream(port);
        if code == 200 {
            return s;
        }
        assert_eq!(code, 503);
        assert!(t0.elapsed() < Duration::from_secs(5), "slots never freed");
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Text of the element with `id` in a dumped DOM.
fn element(dom: &str, id: &str) -> Option<String> {
    let at = dom.find(&format!("id=\"{id}\""))?;
    let rest = &dom[at..];
    let open = rest.find('>')? + 1;
    let close = rest[open..].find('<')? + open;
    Some(rest[open..close].trim().to_string())
}

fn chromium() -> String {
    let bin = std::env::var("WIICAL_CHROMIUM").unwrap_or_else(|_| "chromium".into());
    let found = Command::new(&bin)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(
        found,
        "`{bin}` not found: run scripts/setup (it installs Debian's chromium), or set WIICAL_CHROMIUM"
    );
    bin
}

/// The DOM of the page after its script ran (headless Chromium `--dump-dom`).
fn dump_dom(chromium: &str, port: u16) -> String {
    let out = Command::new(chromium)
        .args(["--headless", "--disable-gpu", "--no-sandbox", "--dump-dom"])
        .arg(format!("http://127.0.0.1:{port}/"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn live_replay_in_chromium_shows_poses_appearing_and_38_good_at_the_end() {
    let chromium = chromium();
    let file = xsens();
    let path = file.to_str().unwrap();
    // Independent reference: the batch pipeline with the same detector settings.
    let fit = json(&["fit", "--json", "--init-s", "2", path]);
    let want_poses = fit["static_windows"].as_u64().unwrap() as usize;
    assert_eq!(want_poses, 38);
    let live = start(&["--replay", path, "--speed", "50", "--port", "0"]);
    let t0 = Instant::now();
    let mut seen: Vec<usize> = Vec::new();
    let dom = loop {
        assert!(t0.elapsed() < Duration::from_secs(120), "no end: {seen:?}");
        let dom = dump_dom(&chromium, live.port);
        let poses: usize = element(&dom, "poses").unwrap().parse().unwrap();
        seen.push(poses);
        if element(&dom, "status").unwrap().contains("source ended") {
            break dom;
        }
        std::thread::sleep(Duration::from_millis(700));
    };
    // Poses appear as the replay proceeds: never fewer, and several counts on the way.
    assert!(seen.windows(2).all(|w| w[0] <= w[1]), "{seen:?}");
    let between = seen.iter().filter(|&&n| n > 0 && n < want_poses).count();
    assert!(between >= 2, "too few pictures during the replay: {seen:?}");
    assert_eq!(*seen.last().unwrap(), want_poses);
    assert_eq!(element(&dom, "verdict").unwrap(), "good");
    assert_eq!(element(&dom, "coverage").unwrap(), "covers the sphere");
    let rms: f64 = element(&dom, "rms")
        .unwrap()
        .trim_end_matches(" mg")
        .parse()
        .unwrap();
    let want_rms = fit["rms_mg"].as_f64().unwrap();
    assert!((rms - want_rms).abs() < 0.002, "{rms} vs fit's {want_rms}");
    // One residual row per pose, drawn by the page.
    assert_eq!(dom.matches("<tr class=\"pose\">").count(), want_poses);
}

#[test]
fn live_refuses_a_non_local_address_unless_bind() {
    let path = xsens();
    let out = Command::new(env!("CARGO_BIN_EXE_wiical"))
        .args([
            "live",
            "--replay",
            path.to_str().unwrap(),
            "--port",
            "0.0.0.0:0",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("0.0.0.0") && err.contains("--bind"), "{err}");
    // Bad flags are named.
    for (args, flag) in [
        (&["--port", "99999"][..], "--port"),
        (&["--port", "nowhere:80"][..], "--port"),
        (&["--speed", "0"][..], "--speed"),
        (&["--speed", "1e9"][..], "--speed"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_wiical"))
            .args(["live", "--replay", path.to_str().unwrap()])
            .args(args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(flag),
            "{args:?}: {err}"
        );
    }
    // Asked for, it listens there (and still answers on the loopback).
    let live = start(&[
        "--replay",
        path.to_str().unwrap(),
        "--bind",
        "0.0.0.0",
        "--port",
        "0",
    ]);
    assert_eq!(get(live.port, "/snapshot.json").0, 200);
}

#[test]
fn live_bounds_streams_and_survives_viewers_that_vanish() {
    let path = xsens();
    let live = start(&[
        "--replay",
        path.to_str().unwrap(),
        "--speed",
        "20",
        "--port",
        "0",
    ]);
    // Viewers that close mid-stream, again and again, more of them than there are slots:
    // each vanished viewer's slot is freed at its next write (a snapshot or a keep-alive).
    for _ in 0..20 {
        let mut s = open_when_free(live.port);
        let mut buf = [0u8; 256];
        let _ = s.read(&mut buf).unwrap();
    }
    // Eight streams at once; the ninth is refused with 503 (the vanished viewers' slots are
    // freed at their next write, within a keep-alive period).
    let held: Vec<TcpStream> = (0..8).map(|_| open_when_free(live.port)).collect();
    let (code, _) = open_stream(live.port);
    assert_eq!(code, 503);
    drop(held);
    let mut s = open_when_free(live.port);
    let mut buf = vec![0u8; 4096];
    let n = s.read(&mut buf).unwrap();
    assert!(n > 0);
    // The server still serves the page and snapshots; an unknown path is 404.
    let (code, page) = get(live.port, "/");
    assert_eq!(code, 200);
    assert!(
        page.contains("id=\"verdict\"") && !page.contains("http://") && !page.contains("https://")
    );
    assert_eq!(get(live.port, "/nothing").0, 404);
    let (code, snap) = get(live.port, "/snapshot.json");
    assert_eq!(code, 200);
    let v: serde_json::Value = serde_json::from_str(&snap).unwrap();
    assert!(v["samples"].as_u64().unwrap() > 0);
}

#[test]
fn live_source_end_is_in_the_snapshot() {
    // A short recording (the first 10 s of the Xsens file's rest) ends quickly.
    let text = std::fs::read_to_string(xsens()).unwrap();
    let short: String = text.lines().take(1000).map(|l| format!("{l}\n")).collect();
    let file = common::temp_file("live", "short.txt", &short);
    let live = start(&[
        "--replay",
        file.to_str().unwrap(),
        "--speed",
        "100",
        "--port",
        "0",
    ]);
    let v = wait_for(live.port, |v| v["ended"].is_string());
    assert_eq!(v["ended"], "source ended");
    assert_eq!(v["samples"].as_u64(), Some(1000));
    // One hold (the rest) and no fit: the page says why.
    assert_eq!(v["pose_count"].as_u64(), Some(1));
    assert!(v["fit"].is_null() && v["coverage_gap"].as_str().unwrap().contains("12"));
}

#[test]
fn live_magnetometer_replay_gives_the_ellipsoid_fit_error() {
    // QMC5883L magnetometer (mx,my,mz): the live view keeps one sample in ten; its ellipsoid
    // fit error is close to `magfit`'s on every sample.
    let file = data_dir().join("qmc5883l_mag_tomisuarez/noisy_raw_data.csv");
    let path = file.to_str().unwrap();
    let want = json(&["magfit", "--json", path]);
    let want_pct = want["fit_error_pct"].as_f64().unwrap();
    let live = start(&["--replay", path, "--speed", "2000", "--port", "0"]);
    let v = wait_for(live.port, |v| v["ended"].is_string());
    assert_eq!(v["sensor"], "magnetometer");
    let mag = &v["mag"];
    let n = mag["points"].as_u64().unwrap();
    let samples = v["samples"].as_u64().unwrap();
    // One kept in ten, thinned to stay within the 2000-point bound.
    assert!(
        samples.div_ceil(10) > 2000 && (1000..=2000).contains(&n),
        "{n} of {samples}"
    );
    let pct = mag["fit_error_pct"].as_f64().unwrap();
    assert!((pct - want_pct).abs() < 0.5, "{pct} vs magfit's {want_pct}");
    assert_eq!(mag["directions"].as_array().unwrap().len() as u64, n);
}

/// Polls `/snapshot.json` until `done` holds (30 s at most).
fn wait_for(port: u16, done: impl Fn(&serde_json::Value) -> bool) -> serde_json::Value {
    let t0 = Instant::now();
    loop {
        let (_, snap) = get(port, "/snapshot.json");
        if let Ok(v) = serde_json::from_str::<serde_json::Value>(&snap) {
            if done(&v) {
                return v;
            }
        }
        assert!(t0.elapsed() < Duration::from_secs(30), "{snap}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[cfg(unix)]
#[test]
fn live_streams_the_device_simulator_and_survives_its_disconnect() {
    use wiical::device_sim::{spawn, SimOptions};
    let (pty, sim) = spawn(SimOptions::default()).unwrap();
    let live = start(&["--device", pty.to_str().unwrap(), "--port", "0"]);
    // Samples arrive at the adapter's rate; the simulated Nunchuk turns slowly.
    let v = wait_for(live.port, |v| v["samples"].as_u64().unwrap_or(0) >= 400);
    assert!(v["ended"].is_null(), "{v}");
    assert_eq!(v["sensor"], "accelerometer");
    // The adapter's background-recalibration grid comes with the snapshots: every bin with
    // its centre direction (a unit vector), for the page to draw.
    let v = wait_for(live.port, |v| v["adapter_grid"].is_object());
    let bins = v["adapter_grid"]["bins"].as_array().expect("bins");
    assert_eq!(bins.len(), 54, "{v}");
    for b in bins {
        let d: Vec<f64> = serde_json::from_value(b["direction"].clone()).unwrap();
        let n = d.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!((n - 1.0).abs() < 1e-5, "{b}");
    }
    let line = v["adapter_grid"]["line"].as_str().unwrap();
    assert!(line.contains("of 54 bins fresh"), "{line}");
    // The simulator goes away (cable pulled): the session ends with the reason, and the
    // server keeps serving the last picture.
    sim.stop().unwrap();
    let v = wait_for(live.port, |v| v["ended"].is_string());
    let why = v["ended"].as_str().unwrap();
    assert!(why.starts_with("source ended"), "{why}");
    let (code, page) = get(live.port, "/");
    assert_eq!(code, 200);
    assert!(
        page.contains("source ended"),
        "the page is served with the ended snapshot"
    );
}

/// The gyro view's stretch `v` (`rest` or a steady turn) as °/s and samples.
fn stretch(v: &serde_json::Value) -> ([f64; 3], u64) {
    let m: Vec<f64> = serde_json::from_value(v["mean_dps"].clone()).unwrap();
    ([m[0], m[1], m[2]], v["samples"].as_u64().unwrap())
}

/// The steady turn of the gyro view nearest `want` (°/s), and how far it is.
fn turn_near(v: &serde_json::Value, want: [f64; 3]) -> Option<([f64; 3], f64)> {
    v["gyro"]["steady_turns"]
        .as_array()?
        .iter()
        .map(|t| stretch(t).0)
        .map(|m| {
            (
                m,
                (0..3).map(|i| (m[i] - want[i]).abs()).fold(0.0, f64::max),
            )
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

/// Issue 50 item 3: `wiical live` on an adapter serving a MotionPlus (the simulated one, with
/// its known truth) shows the rates in °/s per axis, at rest the bias that remains, and each
/// steady turn's rate: before a gyro calibration the raw counts on the nominal scales (the
/// device's bias and scale errors show), after committing the calibration that inverts the
/// simulated MotionPlus, zero at rest and the true rates.
#[cfg(unix)]
#[test]
fn live_shows_a_motionplus_corrected_by_the_committed_gyro_calibration() {
    use wiical::client::{ClientOptions, Device};
    use wiical::device_sim::motionplus::{
        true_gyro_calibration, GYRO_TRUE_BIAS, GYRO_TRUE_CPD, GYRO_TURN_FAST_DPS,
        GYRO_TURN_SLOW_DPS,
    };
    use wiical::device_sim::{spawn, SimExtension, SimOptions};
    let (pty, sim) = spawn(SimOptions {
        extension: SimExtension::MotionPlus,
        time_scale: 10.0,
        ..Default::default()
    })
    .unwrap();
    let pty = pty.to_str().unwrap().to_string();
    let gyro_ready = |calibrated: bool| {
        move |v: &serde_json::Value| {
            let g = &v["gyro"];
            g["calibrated"] == calibrated
                && g["rest"]["samples"].as_u64().unwrap_or(0) >= 600
                && g["steady_turns"].as_array().is_some_and(|t| t.len() >= 2)
        }
    };
    // Uncalibrated: the rest reads the device's bias on the nominal 8192/440 counts per °/s,
    // and the slow turn its rate times the device's sensitivity over the nominal one, plus
    // that bias (the raw counts are read against the nominal zero 8192).
    let nominal = 8192.0 / 440.0;
    {
        let live = start(&["--device", &pty, "--port", "0"]);
        let v = wait_for(live.port, gyro_ready(false));
        let (rest, n) = stretch(&v["gyro"]["rest"]);
        for i in 0..3 {
            let want = (GYRO_TRUE_BIAS[i] - 8192.0) / nominal;
            assert!(
                (rest[i] - want).abs() < 0.05,
                "rest {rest:?} over {n}, axis {i}: {want}"
            );
        }
        let want: [f64; 3] = std::array::from_fn(|i| {
            (GYRO_TRUE_BIAS[i] - 8192.0 + GYRO_TURN_SLOW_DPS[i] * GYRO_TRUE_CPD[i]) / nominal
        });
        let (got, err) = turn_near(&v, want).unwrap();
        assert!(err < 0.3, "uncalibrated slow turn {got:?} vs {want:?}");
        assert!(v["gyro"]["line"]
            .as_str()
            .unwrap()
            .contains("no gyro calibration"));
    }
    // Commit the calibration that inverts the simulated MotionPlus.
    {
        let (mut dev, _) = Device::connect(&pty, ClientOptions::default()).unwrap();
        dev.put_gyro_judged(&true_gyro_calibration().into())
            .unwrap();
        dev.commit_gyro().unwrap();
    }
    let live = start(&["--device", &pty, "--port", "0"]);
    let v = wait_for(live.port, gyro_ready(true));
    let (rest, n) = stretch(&v["gyro"]["rest"]);
    assert!(
        rest.iter().all(|r| r.abs() < 0.02),
        "rest {rest:?} over {n} samples"
    );
    let (slow, err) = turn_near(&v, GYRO_TURN_SLOW_DPS).unwrap();
    assert!(err < 0.05, "slow turn {slow:?}");
    let v = wait_for(live.port, |v| {
        turn_near(v, GYRO_TURN_FAST_DPS).is_some_and(|(_, e)| e < 5.0)
    });
    let (fast, err) = turn_near(&v, GYRO_TURN_FAST_DPS).unwrap();
    assert!(err < 0.15, "fast turn {fast:?}");
    eprintln!("live gyro view: rest {rest:?}, slow turn {slow:?}, fast turn {fast:?} °/s");
    drop(live);
    sim.stop().unwrap();
}

/// Headless Chromium with the DevTools protocol on a free port, killed when dropped.
struct Browser {
    child: Child,
    devtools_port: u16,
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn browser(chromium: &str, url: &str, profile: &std::path::Path) -> Browser {
    let mut child = Command::new(chromium)
        .args([
            "--headless",
            "--disable-gpu",
            "--no-sandbox",
            "--remote-debugging-port=0",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(url)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // "DevTools listening on ws://127.0.0.1:PORT/devtools/browser/…"
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    let port = loop {
        line.clear();
        assert!(err.read_line(&mut line).unwrap() > 0, "chromium ended");
        if let Some(rest) = line.split("ws://127.0.0.1:").nth(1) {
            break rest.split('/').next().unwrap().parse().unwrap();
        }
    };
    // Keep draining stderr so that chromium never blocks on it.
    std::thread::spawn(move || std::io::copy(&mut err, &mut std::io::sink()));
    Browser {
        child,
        devtools_port: port,
    }
}

/// The DevTools HTTP endpoint's target list (its answer has a Content-Length; the connection
/// may stay open, so the body is read by length).
fn devtools_targets(port: u16) -> serde_json::Value {
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    write!(
        s,
        "GET /json/list HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n"
    )
    .unwrap();
    let mut r = BufReader::new(s);
    let mut len = 0usize;
    loop {
        let mut line = String::new();
        r.read_line(&mut line).unwrap();
        if line.trim().is_empty() {
            break;
        }
        if let Some(v) = line.to_ascii_lowercase().strip_prefix("content-length:") {
            len = v.trim().parse().unwrap();
        }
    }
    let mut body = vec![0u8; len];
    r.read_exact(&mut body).unwrap();
    serde_json::from_slice(&body).unwrap()
}

#[test]
fn live_page_updates_in_chromium_without_reloading() {
    let chromium = chromium();
    let file = xsens();
    let live = start(&[
        "--replay",
        file.to_str().unwrap(),
        "--speed",
        "50",
        "--port",
        "0",
    ]);
    // The browser's profile, deleted after the browser (dropped first: declared after it).
    let profile = tempfile::Builder::new()
        .prefix("live-chromium-")
        .tempdir_in(env!("CARGO_TARGET_TMPDIR"))
        .unwrap();
    let b = browser(
        &chromium,
        &format!("http://127.0.0.1:{}/", live.port),
        profile.path(),
    );
    let targets = devtools_targets(b.devtools_port);
    let ws_url = targets
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["type"] == "page")
        .and_then(|t| t["webSocketDebuggerUrl"].as_str())
        .unwrap()
        .to_string();
    let (mut ws, _) = tungstenite::connect(ws_url.as_str()).unwrap();
    // The page's own text, read through the DevTools protocol while it stays loaded: the
    // server-sent events redraw it.
    let mut read = |id: u64| -> (u64, u64, String, String) {
        let expr = "['samples','poses','status','verdict'].map(i => document.getElementById(i).textContent).join('|')";
        let msg = serde_json::json!({"id": id, "method": "Runtime.evaluate", "params": {"expression": expr}});
        ws.send(tungstenite::Message::Text(msg.to_string().into()))
            .unwrap();
        loop {
            let reply = ws.read().unwrap();
            let Ok(text) = reply.to_text() else { continue };
            let v: serde_json::Value = serde_json::from_str(text).unwrap();
            if v["id"] == id {
                // Before the page has loaded the expression throws: an empty reading.
                let s = v["result"]["result"]["value"]
                    .as_str()
                    .unwrap_or("")
                    .to_string();
                let f: Vec<&str> = s.split('|').collect();
                if f.len() != 4 {
                    return (0, 0, String::new(), String::new());
                }
                return (
                    f[0].parse().unwrap_or(0),
                    f[1].parse().unwrap_or(0),
                    f[2].into(),
                    f[3].into(),
                );
            }
        }
    };
    let t0 = Instant::now();
    let mut seen = Vec::new();
    let mut id = 0;
    let (poses, verdict) = loop {
        assert!(t0.elapsed() < Duration::from_secs(120), "no end: {seen:?}");
        id += 1;
        let (samples, poses, status, verdict) = read(id);
        seen.push((samples, poses));
        if status.contains("source ended") {
            break (poses, verdict);
        }
        std::thread::sleep(Duration::from_millis(500));
    };
    // One page load, many pictures: samples and poses grow as the events arrive.
    let growing = seen.windows(2).filter(|w| w[1].0 > w[0].0).count();
    assert!(growing >= 5, "{seen:?}");
    assert!(seen.windows(2).all(|w| w[0].1 <= w[1].1), "{seen:?}");
    assert!(seen.iter().any(|&(_, p)| p > 0 && p < 38), "{seen:?}");
    assert_eq!((poses, verdict.as_str()), (38, "good"));
    assert_eq!(seen.last().unwrap().0, 51175);
    drop(b);
    let _ = std::fs::remove_dir_all(&profile);
}

#[cfg(unix)]
#[test]
fn live_device_sim_poses_reach_all_poses_and_a_good_verdict_in_chromium() {
    use wiical::device_sim::{spawn, SimMotion, SimOptions, POSE_DIRECTIONS};
    let chromium = chromium();
    // The simulated hand calibration, its clock 10× the wall clock (≈ 12 s for 116 s).
    let (pty, _sim) = spawn(SimOptions {
        motion: SimMotion::Poses,
        time_scale: 10.0,
        ..Default::default()
    })
    .unwrap();
    let live = start(&["--device", pty.to_str().unwrap(), "--port", "0"]);
    let want = POSE_DIRECTIONS.len();
    let t0 = Instant::now();
    let mut seen: Vec<usize> = Vec::new();
    let mut adapter_seen: Vec<String> = Vec::new();
    let dom = loop {
        assert!(t0.elapsed() < Duration::from_secs(90), "stuck: {seen:?}");
        let dom = dump_dom(&chromium, live.port);
        let poses: usize = element(&dom, "poses").unwrap().parse().unwrap();
        seen.push(poses);
        let adapter = element(&dom, "source-status").unwrap();
        adapter_seen.push(adapter.clone());
        if poses >= want
            && element(&dom, "verdict").as_deref() == Some("good")
            && adapter.contains("last self-calibration stored")
        {
            break dom;
        }
        std::thread::sleep(Duration::from_millis(300));
    };
    // Poses appear one after another while the simulated hand works.
    assert!(seen.windows(2).all(|w| w[0] <= w[1]), "{seen:?}");
    assert!(
        seen.iter().filter(|&&n| n > 0 && n < want).count() >= 2,
        "{seen:?}"
    );
    // Exactly the held orientations: the final rest is still open.
    assert_eq!(*seen.last().unwrap(), want, "{seen:?}");
    assert_eq!(element(&dom, "coverage").unwrap(), "covers the sphere");
    assert_eq!(element(&dom, "status").unwrap(), "receiving");
    let rms: f64 = element(&dom, "rms")
        .unwrap()
        .trim_end_matches(" mg")
        .parse()
        .unwrap();
    // 0.6-count noise averaged over ~800 samples a pose, at ~200 counts/g: well under 1 mg.
    assert!(rms < 1.0, "{rms} mg");
    // The adapter's own state on the page: its stream, and its C + Z self-calibration (the
    // simulated hand held C + Z at plug-in), which took its own poses (20° apart, stopping
    // once they cover the sphere: 12 at least) from the same movements and stored the fit.
    let adapter = element(&dom, "source-status").unwrap();
    eprintln!("{adapter}");
    assert!(
        adapter.starts_with("adapter streaming at 200 Hz: "),
        "{adapter}"
    );
    let stored = adapter
        .split("last self-calibration stored: ")
        .nth(1)
        .unwrap();
    let (rms_mg, rest) = stored.split_once(" mg RMS over ").unwrap();
    let adapter_poses: usize = rest.split(' ').next().unwrap().parse().unwrap();
    assert!((12..=want).contains(&adapter_poses), "{adapter}");
    assert!(rms_mg.parse::<f64>().unwrap() < 1.0, "{adapter}");
    // …and the session was shown while it ran.
    assert!(
        adapter_seen.iter().any(|a| [
            "self-calibration: hold still in a new orientation, ",
            "self-calibration: pose taken, "
        ]
        .iter()
        .any(|p| a.contains(p))),
        "{adapter_seen:#?}"
    );
    // The poses are the simulated ones, in order (the fit's frame is the sensor's to within
    // the true model's ~1 % cross-axis terms).
    let v = wait_for(live.port, |v| v["pose_count"].as_u64() >= Some(want as u64));
    for (p, truth) in v["poses"].as_array().unwrap().iter().zip(POSE_DIRECTIONS) {
        let d: Vec<f64> = p["direction"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        let n = truth.iter().map(|x| x * x).sum::<f64>().sqrt();
        let cos: f64 = d.iter().zip(truth).map(|(a, b)| a * b / n).sum();
        assert!(cos > 3f64.to_radians().cos(), "{d:?} vs {truth:?}");
    }
}

#[test]
fn device_sim_poses_are_spread_and_its_flags_are_checked() {
    use wiical::device_sim::{
        pose_direction, POSE_DIRECTIONS, POSE_HOLD_S, POSE_MOVE_S, POSE_REST_S,
    };
    let unit = |v: [f64; 3]| {
        let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        v.map(|x| x / n)
    };
    let angle = |a: [f64; 3], b: [f64; 3]| {
        let (a, b) = (unit(a), unit(b));
        (a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees()
    };
    // Every two held orientations at least 35° apart (the adapter takes poses 20° apart).
    for (i, a) in POSE_DIRECTIONS.iter().enumerate() {
        for b in &POSE_DIRECTIONS[i + 1..] {
            assert!(angle(*a, *b) >= 35.0, "{a:?} {b:?}");
        }
    }
    // The script holds each orientation, turns smoothly (a unit vector all along, no jump
    // between two 10 ms samples bigger than the peak turn rate allows) and ends at rest.
    let step = POSE_MOVE_S + POSE_HOLD_S;
    for (k, d) in POSE_DIRECTIONS.iter().enumerate().skip(1) {
        let mid_hold = POSE_REST_S + (k - 1) as f64 * step + POSE_MOVE_S + POSE_HOLD_S / 2.0;
        assert!(angle(pose_direction(mid_hold), *d) < 1e-9);
    }
    let end = POSE_REST_S + POSE_DIRECTIONS.len() as f64 * step;
    assert!(angle(pose_direction(end + 100.0), POSE_DIRECTIONS[0]) < 1e-9);
    let mut t = 0.0;
    while t < end {
        let (a, b) = (pose_direction(t), pose_direction(t + 0.01));
        assert!((b.iter().map(|x| x * x).sum::<f64>() - 1.0).abs() < 1e-12);
        // ≤ 180° over 2 s with a smoothstep profile: peak 1.5 × 90°/s.
        assert!(angle(a, b) < 1.5 * 90.0 * 0.01 + 1e-6, "at {t}");
        t += 0.01;
    }
    // A time scale out of range is refused, naming the flag.
    for bad in ["0.5", "51", "nan", "x"] {
        let out = Command::new(env!("CARGO_BIN_EXE_wiical"))
            .args([
                "device-sim",
                "--pty",
                "--motion",
                "poses",
                "--time-scale",
                bad,
            ])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains("--time-scale"),
            "{bad}: {err}"
        );
    }
}
