//! `wiical capture` and `wiical decode-cal` end to end: the command line over a raw log
//! recorded from the scripted fake remote, the live page while capturing, and the flags
//! checked before anything is opened. The capture library itself is tested in
//! crates/capture/tests, whose fixtures this file shares.

mod common;
#[path = "../../crates/capture/tests/support/mod.rs"]
mod support;
use common::wiical;
use support::*;

use serde_json::Value;
use wiical_capture::guided::GuidedConfig;
use wiical_capture::io::RawLogger;
use wiical_capture::{capture, CaptureMode, CollectUi};

/// GET `path` from a local HTTP server (`Connection: close`): the body.
fn http_get(port: u16, path: &str) -> String {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut buf = String::new();
    s.read_to_string(&mut buf).unwrap();
    buf.split_once("\r\n\r\n")
        .map_or("", |(_, b)| b)
        .to_string()
}

#[test]
fn cli_capture_without_a_remote_fails_with_the_pairing_advice() {
    let out = tmp("cli_nodev.csv");
    let (ok, _, err) = wiical(&[
        "capture",
        "--out",
        out.to_str().unwrap(),
        "--duration-s",
        "1",
    ]);
    if ok {
        eprintln!("a Wii Remote is connected: the no-device path cannot be tested here");
        return;
    }
    assert!(
        err.starts_with("error: no Wii Remote found: pair it over Bluetooth (press 1+2")
            || err.starts_with("error: cannot initialise HID access"),
        "{err}"
    );
    assert!(!out.exists(), "nothing is written without a device");
}

#[test]
#[allow(clippy::too_many_lines, reason = "a test reads top to bottom")]
fn cli_capture_replays_a_raw_log_in_guided_mode() {
    // Record a guided session from the fake remote through --raw-log's logger…
    let poses = twelve_poses();
    let mut segs = vec![Seg::Still(poses[0], 5.0)];
    for w in poses[..4].windows(2) {
        segs.push(Seg::Turn(w[0], w[1], 1.5));
        segs.push(Seg::Still(w[1], 5.0));
    }
    let mut dev = fake(true);
    script(&mut dev, &segs, true, 12, 0.0);
    let log_path = tmp("session.log");
    {
        let f = std::io::BufWriter::new(std::fs::File::create(&log_path).unwrap());
        let mut logged = RawLogger::new(&mut dev, f).unwrap();
        let cfg = GuidedConfig {
            poses: 4,
            ..Default::default()
        };
        capture(
            &mut logged,
            &opts(tmp("session.csv"), CaptureMode::Guided(cfg)),
            &mut CollectUi::default(),
        )
        .unwrap();
        logged.flush().unwrap();
    }
    // …and replay it through the command line.
    let out = tmp("cli_replay.csv");
    let (ok, stdout, err) = wiical(&[
        "capture",
        "--replay",
        log_path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--guided",
        "4",
        "--json",
    ]);
    assert!(ok, "{err}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["capture"]["poses"].as_array().unwrap().len(), 4);
    assert_eq!(u64s(&v["wiimote"]["zero"]), WIIMOTE_ZERO);
    assert!(v["device"]
        .as_str()
        .unwrap()
        .starts_with("replay of replayed Wii Remote"));
    // Messages go to stderr (not a terminal here: plain lines, no spinner).
    assert!(
        err.contains("pose 3 done: turn the remote to a new orientation"),
        "{err}"
    );
    assert!(err.contains("all 4 poses done"), "{err}");
    assert_eq!(
        std::fs::read_to_string(&out)
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with('#'))
            .count(),
        std::fs::read_to_string(tmp("session.csv"))
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with('#'))
            .count(),
    );
    // The text summary.
    let (ok, stdout, err) = wiical(&[
        "capture",
        "--replay",
        log_path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--guided",
        "4",
    ]);
    assert!(ok, "{err}");
    assert!(stdout.contains("wiimote factory calibration: zero [521, 521, 521], counts per g [106, 105, 111] (first copy)"), "{stdout}");
    assert!(stdout.contains("poses: 4"), "{stdout}");
    // Bad arguments are refused with a clear message.
    let (ok, _, err) = wiical(&[
        "capture",
        "--replay",
        log_path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--duration-s=-1",
    ]);
    assert!(
        !ok && err.contains("--duration-s") && err.contains("must be a finite number above 0"),
        "{err}"
    );
}

#[test]
#[allow(clippy::too_many_lines, reason = "a test reads top to bottom")]
fn cli_capture_live_feeds_the_live_page_while_capturing() {
    use std::io::BufRead;
    // A guided session of twelve poses from the fake remote, logged as a real one would be…
    let poses = twelve_poses();
    let mut segs = vec![Seg::Still(poses[0], 5.0)];
    for w in poses.windows(2) {
        segs.push(Seg::Turn(w[0], w[1], 1.5));
        segs.push(Seg::Still(w[1], 5.0));
    }
    let mut dev = fake(false);
    script(&mut dev, &segs, false, 21, 0.0);
    let log_path = tmp("live_session.log");
    {
        let f = std::io::BufWriter::new(std::fs::File::create(&log_path).unwrap());
        let mut logged = RawLogger::new(&mut dev, f).unwrap();
        let cfg = GuidedConfig {
            poses: 12,
            ..Default::default()
        };
        capture(
            &mut logged,
            &opts(tmp("live_session.csv"), CaptureMode::Guided(cfg)),
            &mut CollectUi::default(),
        )
        .unwrap();
        logged.flush().unwrap();
    }
    // …replayed by `wiical capture --live` at 10× its pace (≈ 8 s): the page's address comes
    // first on stderr.
    let out = tmp("live_capture.csv");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_wiical"))
        .args(["capture", "--replay", log_path.to_str().unwrap()])
        .args(["--out", out.to_str().unwrap(), "--guided", "12", "--json"])
        .args(["--live", "--live-port", "0", "--replay-speed", "10"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = std::io::BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    err.read_line(&mut line).unwrap();
    let port: u16 = line
        .split("http://127.0.0.1:")
        .nth(1)
        .and_then(|r| r.split('/').next())
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("no address in {line:?}"));
    std::thread::spawn(move || std::io::copy(&mut err, &mut std::io::sink()));
    let t0 = std::time::Instant::now();
    let mut during = Vec::new();
    let v = loop {
        let snap: Value = serde_json::from_str(&http_get(port, "/snapshot.json")).unwrap();
        if snap["ended"].is_string() {
            break snap;
        }
        during.push(snap["pose_count"].as_u64().unwrap());
        assert!(t0.elapsed().as_secs() < 60, "{snap}");
        std::thread::sleep(std::time::Duration::from_millis(100));
    };
    // Poses appeared on the page while the capture was running.
    assert!(during.windows(2).all(|w| w[0] <= w[1]), "{during:?}");
    assert!(
        during.iter().filter(|&&n| n > 0 && n < 12).count() >= 3,
        "{during:?}"
    );
    // The page is served after the capture too: its status is the capture's end.
    assert!(http_get(port, "/").contains("capture finished"));
    let _ = child.kill();
    let _ = child.wait();
    assert_eq!(v["ended"], "capture finished");
    assert_eq!(v["source_status"], "all 12 poses done");
    // Independent reference: the batch fit (same detector, 2 s rest) of the CSV the capture
    // wrote; the live view saw the same samples, so the same poses and fit.
    let csv_rows = std::fs::read_to_string(&out)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with('t'))
        .count() as u64;
    assert_eq!(v["samples"].as_u64(), Some(csv_rows));
    let (ok, fit, e) = wiical(&["fit", "--json", "--init-s", "2", out.to_str().unwrap()]);
    assert!(ok, "{e}");
    let fit: Value = serde_json::from_str(&fit).unwrap();
    assert_eq!(fit["static_windows"].as_u64(), Some(12));
    assert_eq!(v["pose_count"].as_u64(), Some(12));
    assert_eq!(v["fit"]["verdict"], fit["quality"]["verdict"]);
    assert_eq!(v["fit"]["verdict"], "good");
    let (live_rms, fit_rms) = (
        v["fit"]["rms_mg"].as_f64().unwrap(),
        fit["rms_mg"].as_f64().unwrap(),
    );
    assert!((live_rms - fit_rms).abs() < 0.01, "{live_rms} vs {fit_rms}");
}

#[test]
fn cli_capture_live_flags_are_checked_before_anything_is_opened() {
    let out = tmp("live_flags.csv");
    let out = out.to_str().unwrap();
    for (args, flag) in [
        (&["--live", "--live-port", "99999"][..], "--live-port"),
        (&["--live", "--live-port", "nowhere:80"][..], "--live-port"),
        (&["--live", "--live-port", "0.0.0.0:0"][..], "--live-bind"),
        (&["--live-port", "0"][..], "--live"),
        (&["--replay-speed", "2"][..], "--replay"),
        (
            &["--replay", out, "--replay-speed", "0"][..],
            "--replay-speed",
        ),
    ] {
        let (ok, _, err) = wiical(&[&["capture", "--out", out][..], args].concat());
        assert!(!ok && err.contains(flag), "{args:?}: {err}");
    }
    assert!(!std::path::Path::new(out).exists());
}

#[test]
fn decode_cal_motionplus_reads_the_block_and_its_crc() {
    use wiical::cmd::decode_cal::{run, Args};
    let hex: Vec<String> = mp_block().iter().map(|b| format!("{b:02X}")).collect();
    let args = |hex: Vec<String>, json| Args {
        device: "motionplus".into(),
        hex,
        json,
    };
    let out: serde_json::Value =
        serde_json::from_str(&run(&args(hex.clone(), true)).unwrap()).unwrap();
    assert_eq!(out["checksum_ok"], true);
    assert_eq!(out["fast"]["degrees"], 1200);
    assert_eq!(out["slow"]["zero"][1], 0x8010);
    let roll = out["slow"]["counts_per_dps"][1].as_f64().unwrap();
    assert!((roll - (0xC400 - 0x8010) as f64 / 4.0 / 270.0).abs() < 1e-4);
    assert!(out.get("mode").is_none());
    let text = run(&args(hex.clone(), false)).unwrap();
    assert!(text.contains("CRC-32:   ok"), "{text}");
    // A bad CRC-32 is printed and the command fails, as for the other devices;
    // the device name is case-insensitive.
    let mut bad = hex.clone();
    bad[20] = "00".into();
    let e = run(&args(bad, false)).unwrap_err().to_string();
    assert!(e.contains("checksum is wrong"), "{e}");
    let mixed = Args {
        device: "MotionPlus".into(),
        hex: hex.clone(),
        json: true,
    };
    assert!(run(&mixed).is_ok());
    let short = run(&args(hex[..31].to_vec(), false))
        .unwrap_err()
        .to_string();
    assert!(short.contains("expected 32 bytes, got 31"), "{short}");
}
