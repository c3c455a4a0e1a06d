//! `wiical device …` and `wiical device-sim` end to end on a pseudo-terminal: argument parsing
//! as main.rs wires it, and the command functions' output. The client and the simulated
//! adapter themselves are tested in crates/client/tests, whose fixtures this file shares.
//! Unix only (pseudo-terminals).
#![cfg(unix)]

#[path = "../../crates/client/tests/support/mod.rs"]
mod support;
use support::*;

use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use clap::Parser;
use wiical::cmd::device::{self, DeviceAction, DeviceArgs};
use wiical::cmd::device_sim::SimArgs;
use wiical_client::Device;
use wiical_core::Calibration;
use wiical_device_sim::{spawn, SimOptions};
use wiical_wire::WireCalibration;

/// The CLI layer: argument parsing as main.rs wires it, and the command functions' output.
#[derive(Parser)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(clap::Subcommand)]
enum Cmd {
    Device(DeviceArgs),
    DeviceSim(SimArgs),
}

fn parse(args: &[&str]) -> Cmd {
    Cli::try_parse_from(std::iter::once("wiical").chain(args.iter().copied()))
        .unwrap_or_else(|e| panic!("{args:?}: {e}"))
        .cmd
}

fn device_args(args: &[&str]) -> DeviceArgs {
    match parse(args) {
        Cmd::Device(a) => a,
        Cmd::DeviceSim(_) => panic!(),
    }
}

#[test]
#[allow(clippy::too_many_lines, reason = "a test reads top to bottom")]
fn cli_commands_over_the_pty() {
    // Parsing: options before or after the action.
    let a = device_args(&[
        "device", "stream", "--count", "5", "--port", "/dev/x", "--json",
    ]);
    assert!(a.json);
    assert_eq!(a.port.as_deref(), Some("/dev/x"));
    assert!(matches!(
        a.action,
        DeviceAction::Stream {
            count: Some(5),
            divider: 1
        }
    ));
    let a = device_args(&["device", "--port", "/dev/y", "put", "cal.json"]);
    assert!(matches!(a.action, DeviceAction::Put { .. }));
    match parse(&["device-sim", "--pty", "--seconds", "2"]) {
        Cmd::DeviceSim(s) => assert!(s.pty && s.seconds == Some(2.0)),
        Cmd::Device(_) => panic!(),
    }
    let (path, sim) = spawn(SimOptions::default()).unwrap();
    let p = port(&path);
    let run = |args: &[&str]| -> (String, String) {
        let mut full = vec!["device"];
        full.extend_from_slice(args);
        full.extend_from_slice(&["--port", &p]);
        let mut out = Vec::new();
        let text = device::run(&device_args(&full), &mut out).unwrap();
        (text, String::from_utf8(out).unwrap())
    };

    let (info, _) = run(&["info", "--json"]);
    let info: serde_json::Value = serde_json::from_str(&info).unwrap();
    assert_eq!(info["host_schema_key"], info["schema_key"]);
    assert_eq!(info["device_id"], "77696963616C534D");
    let (text, _) = run(&["info"]);
    assert!(text.contains("stale-calibration monitor"), "{text}");
    let (text, _) = run(&["selfcal-status"]);
    // The simulated Nunchuk presses C + Z for the first 0.5 s (too short to enter the mode).
    assert!(
        text.starts_with("self-calibration: not running")
            || text.starts_with("self-calibration: arming"),
        "{text}"
    );
    assert!(text.contains("last result: none since power-up"), "{text}");
    let (st, _) = run(&["selfcal-status", "--json"]);
    let st: serde_json::Value = serde_json::from_str(&st).unwrap();
    assert!(st["phase"] == "Off" || st["phase"] == "Arming", "{st}");
    assert_eq!(st["recalibration_suggested"], false);
    // The background recalibration: a fresh simulator stores nothing, adoption is on.
    assert!(text.contains("background recalibration:"), "{text}");
    assert!(
        text.contains("adoption           on; a host upload is kept"),
        "{text}"
    );
    assert_eq!(st["background"]["adopt"], true, "{st}");
    assert_eq!(st["background"]["bins"], 54, "{st}");
    assert_eq!(st["background"]["origin"], "Factory", "{st}");
    // selfcal-set stores the settings; the status reads them back.
    let (text, _) = run(&["selfcal-set", "--background", "off"]);
    assert!(
        text.contains("adoption off (monitor only), a host upload is kept"),
        "{text}"
    );
    let (text, _) = run(&[
        "selfcal-set",
        "--background",
        "on",
        "--replace-uploaded",
        "yes",
    ]);
    assert!(
        text.contains("adoption on, a host upload may be replaced"),
        "{text}"
    );
    let (st, _) = run(&["selfcal-status", "--json"]);
    let st: serde_json::Value = serde_json::from_str(&st).unwrap();
    assert_eq!(st["background"]["replace_uploaded"], true, "{st}");
    let (text, _) = run(&[
        "selfcal-set",
        "--background",
        "on",
        "--replace-uploaded",
        "no",
    ]);
    assert!(text.contains("a host upload is kept"), "{text}");
    assert!(
        Cli::try_parse_from(["wiical", "device", "selfcal-set", "--background", "maybe"]).is_err()
    );
    // The budget and the fit interval: the flags not given keep the adapter's values.
    assert!(text.contains("at most one commit per 1800 s of play and 8 per 24 h of play; a fit every 60 s of play"), "{text}");
    let (text, _) = run(&[
        "selfcal-set",
        "--commit-every",
        "45",
        "--commits-per-day",
        "16",
        "--fit-every",
        "1.5",
    ]);
    assert!(
        text.contains("adoption on, a host upload is kept"),
        "{text}"
    );
    assert!(text.contains("at most one commit per 45 s of play and 16 per 24 h of play; a fit every 1.5 s of play"), "{text}");
    let (text, _) = run(&["selfcal-set", "--commits-per-day", "3"]);
    assert!(
        text.contains("one commit per 45 s of play and 3 per 24 h of play; a fit every 1.5 s"),
        "{text}"
    );
    let (text, _) = run(&["selfcal-status"]);
    assert!(text.contains("budget             at most one commit per 45 s of play and 3 per 24 h of play; a fit every 1.5 s of play"), "{text}");
    let (st, _) = run(&["selfcal-status", "--json"]);
    let st: serde_json::Value = serde_json::from_str(&st).unwrap();
    assert_eq!(st["background"]["commit_interval_s"], 45, "{st}");
    assert_eq!(st["background"]["commits_per_day"], 3, "{st}");
    assert_eq!(st["background"]["fit_interval_s"], 1.5, "{st}");
    // Out of bounds: one sentence naming the flag; nothing changes in the adapter.
    for (flag, value, words) in [
        (
            "--commit-every",
            "0",
            "--commit-every 0: must be between 10 and 604800 seconds",
        ),
        (
            "--commits-per-day",
            "0",
            "--commits-per-day 0: must be between 1 and 16",
        ),
        (
            "--commits-per-day",
            "17",
            "--commits-per-day 17: must be between 1 and 16",
        ),
        (
            "--fit-every",
            "0.1",
            "--fit-every 0.1: must be between 0.5 and 3600",
        ),
        (
            "--fit-every",
            "nan",
            "--fit-every NaN: must be between 0.5 and 3600",
        ),
    ] {
        let args = ["device", "selfcal-set", flag, value, "--port", &p];
        let err = device::run(&device_args(&args), &mut Vec::new()).unwrap_err();
        assert!(err.to_string().contains(words), "{flag} {value}: {err}");
    }
    assert!(Cli::try_parse_from([
        "wiical",
        "device",
        "selfcal-set",
        "--commits-per-day",
        "1000000000"
    ])
    .is_err());
    let (st, _) = run(&["selfcal-status", "--json"]);
    let st: serde_json::Value = serde_json::from_str(&st).unwrap();
    assert_eq!(st["background"]["commits_per_day"], 3, "{st}");
    // No setting at all is a usage error.
    assert!(Cli::try_parse_from(["wiical", "device", "selfcal-set"]).is_err());

    // put reads what `wiical fit --out` writes (pretty serde JSON of a Calibration).
    let cal = true_calibration();
    let file = temp_path("cal.json");
    std::fs::write(&file, serde_json::to_string_pretty(&cal).unwrap()).unwrap();
    let (text, _) = run(&["put", file.to_str().unwrap()]);
    assert!(text.contains("verified bit for bit"), "{text}");
    assert!(
        text.contains("applied by the adapter: bias and K\n"),
        "{text}"
    );
    assert!(!text.contains("not applied"), "{text}");
    // The upload belonged to that session: a later commit finds nothing.
    let mut o = Vec::new();
    let err = device::run(&device_args(&["device", "get", "--port", &p]), &mut o).unwrap();
    assert!(err.contains("nothing staged"), "{err}");
    let (text, _) = run(&["commit", file.to_str().unwrap()]);
    assert!(text.contains("live and stored"), "{text}");
    let out_file = temp_path("live.json");
    let (state, _) = run(&["get", "--json", "--out", out_file.to_str().unwrap()]);
    let state: serde_json::Value = serde_json::from_str(&state).unwrap();
    assert_eq!(state["stored"], true);
    let back: Calibration =
        serde_json::from_str(&std::fs::read_to_string(&out_file).unwrap()).unwrap();
    assert_eq!(bits(&back), bits(&cal));
    assert_eq!(WireCalibration::from(back), WireCalibration::from(cal));

    // Stream as CSV: header, then rows whose corrected columns are the correction of the
    // raw columns (Rust prints f32 so that it parses back exactly).
    let (_, csv) = run(&["stream", "--count", "8"]);
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("seq,raw_x,raw_y,raw_z,ax,ay,az,c,z,stick_x,stick_y")
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 8);
    for r in &rows {
        let raw: [f32; 3] = std::array::from_fn(|i| r[1 + i].parse().unwrap());
        let a: [f32; 3] = std::array::from_fn(|i| r[4 + i].parse().unwrap());
        assert_eq!(a, cal.correct_linear(raw));
    }
    // JSON lines.
    let (_, jl) = run(&["stream", "--count", "3", "--json"]);
    assert_eq!(jl.lines().count(), 3);
    for l in jl.lines() {
        let v: serde_json::Value = serde_json::from_str(l).unwrap();
        assert!(v["corrected"].as_array().unwrap().len() == 3);
    }
    // Orientation-dependent cross terms are applied by the adapter, the drift
    // term in the same file is not: `commit` says so, and the stream is the correction with
    // the acceleration-only terms.
    let mut cross = cal;
    cross.effects.cross_quadratic[2][2] = 0.02; // a_z += 0.02·xy
    cross.effects.cross_cubic[0][8] = -0.01; // a_x −= 0.01·xyz
    cross.effects.bias_drift = [0.05, 0.0, 0.0];
    let cross_file = temp_path("cross.json");
    wiical_analysis::output::calfile::write_calibration(&cross_file, &cross).unwrap();
    let (text, _) = run(&["commit", cross_file.to_str().unwrap()]);
    assert!(
        text.contains("applied by the adapter: bias and K, cross_quadratic (orientation), cross_cubic (orientation)\n"),
        "{text}"
    );
    assert!(
        text.contains("not applied by the adapter: bias_drift (time)"),
        "{text}"
    );
    let (_, csv) = run(&["stream", "--count", "6"]);
    let mut changed = 0;
    for r in csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
    {
        let raw: [f32; 3] = std::array::from_fn(|i| r[1 + i].parse().unwrap());
        let a: [f32; 3] = std::array::from_fn(|i| r[4 + i].parse().unwrap());
        let want = cross.correct(raw, &wiical_core::Conditions::default());
        assert_eq!(a, want);
        changed += usize::from(a != cal.correct_linear(raw));
    }
    assert!(changed > 0, "the cross terms changed no sample");
    let _ = std::fs::remove_file(&cross_file);
    // A missing --port is a clear error.
    let mut sink = Vec::new();
    let err = device::run(&device_args(&["device", "info"]), &mut sink)
        .err()
        .unwrap()
        .to_string();
    assert!(err.contains("--port"), "{err}");
    // An invalid calibration file is refused before anything is sent.
    let mut bad = cal;
    bad.matrix[0] = [0.0; 3];
    std::fs::write(&file, serde_json::to_string(&bad).unwrap()).unwrap();
    let args = device_args(&["device", "put", file.to_str().unwrap(), "--port", &p]);
    let err = device::run(&args, &mut sink).err().unwrap().to_string();
    assert!(err.contains("invalid calibration"), "{err}");
    let _ = std::fs::remove_file(&file);
    let _ = std::fs::remove_file(&out_file);
    sim.stop().unwrap();
}

/// The session is the host's, not the port's: while another process keeps the port open
/// (so the adapter sees no hang-up), `device put` without `--commit` exits, and that process
/// then sends one bare `CommitCalibration` frame without a Hello: it is refused and nothing
/// becomes live or stored.
#[test]
fn a_bare_commit_from_another_opener_cannot_make_an_upload_live() {
    use std::io::Write as _;
    use wiical_wire::{encode_frame, DefaultFrameDecoder, ErrorCode, Request, Response};
    let (path, sim) = spawn(SimOptions::default()).unwrap();
    let p = port(&path);
    // The other process: holds the port open (without a lock) and reads nothing yet.
    let holding = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(&path)
        .unwrap();
    let file = temp_path("bare-commit.json");
    wiical_analysis::output::calfile::write_calibration(&file, &true_calibration()).unwrap();
    let args = device_args(&["device", "put", file.to_str().unwrap(), "--port", &p]);
    let text = device::run(&args, &mut Vec::new()).unwrap();
    assert!(text.contains("for this session only"), "{text}");
    assert_eq!(
        sim.counters().hangups.load(Ordering::Relaxed),
        0,
        "the port stayed open"
    );
    // That process now speaks on the port it held: one bare frame, no Hello.
    let mut holder = serialport::new(&p, 115_200)
        .timeout(Duration::from_millis(300))
        .open()
        .unwrap();
    let mut buf = [0u8; wiical_wire::MAX_FRAME_LEN];
    let frame = encode_frame(&Request::CommitCalibration, &mut buf)
        .unwrap()
        .to_vec();
    holder.write_all(&frame).unwrap();
    holder.flush().unwrap();
    // Answers the holder sees: the Ack of `device put`'s EndSession (written as it closed,
    // not read), then the answer to the bare commit.
    let mut dec = DefaultFrameDecoder::new();
    let mut answers: Vec<Response> = Vec::new();
    let t0 = Instant::now();
    while !answers.iter().any(|r| matches!(r, Response::Error(_))) {
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "no answer: {answers:?}"
        );
        let mut chunk = [0u8; 256];
        if let Ok(n) = std::io::Read::read(&mut holder, &mut chunk) {
            answers.extend(dec.feed::<Response>(&chunk[..n]).filter_map(Result::ok));
        }
    }
    assert_eq!(
        answers.last(),
        Some(&Response::Error(ErrorCode::SchemaMismatch)),
        "{answers:?}"
    );
    drop(holder);
    drop(holding);
    let (mut dev, _) = Device::connect(&p, opts(2000)).unwrap();
    let s = dev.get_calibration().unwrap();
    assert!(!s.stored && s.staged.is_none(), "{s:?}");
    drop(dev);
    sim.stop().unwrap();
    let _ = std::fs::remove_file(&file);
}

/// Sends `req` as one frame on `port` and returns the first non-sample answer (bounded).
fn ask(
    port: &mut Box<dyn serialport::SerialPort>,
    req: &wiical_wire::Request,
) -> wiical_wire::Response {
    use std::io::Write as _;
    use wiical_wire::{encode_frame, DefaultFrameDecoder, Response};
    let mut buf = [0u8; wiical_wire::MAX_FRAME_LEN];
    port.write_all(encode_frame(req, &mut buf).unwrap())
        .unwrap();
    port.flush().unwrap();
    let mut dec = DefaultFrameDecoder::new();
    let t0 = Instant::now();
    loop {
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "no answer to {req:?}"
        );
        let mut chunk = [0u8; 256];
        if let Ok(n) = std::io::Read::read(port, &mut chunk) {
            let got = dec.feed::<Response>(&chunk[..n]).filter_map(Result::ok);
            if let Some(r) = got.into_iter().find(|r| !matches!(r, Response::Sample(_))) {
                return r;
            }
        }
    }
}

/// A host killed mid-session sends no `EndSession`: the adapter ends the session itself when
/// the port hangs up, so a second opener's bare `CommitCalibration` is refused and the first
/// host's staged upload never becomes live or stored.
#[test]
fn a_killed_hosts_upload_dies_with_its_hang_up() {
    use wiical_wire::{ErrorCode, Hello, Request, Response};
    let (path, sim) = spawn(SimOptions::default()).unwrap();
    let p = port(&path);
    let open = || {
        serialport::new(&p, 115_200)
            .timeout(Duration::from_millis(300))
            .open()
            .unwrap()
    };
    let mut first = open();
    assert!(matches!(
        ask(&mut first, &Request::Hello(Hello::CURRENT)),
        Response::Hello(_)
    ));
    let put = Request::PutCalibration(true_calibration().into());
    assert!(
        matches!(ask(&mut first, &put), Response::Ack),
        "the upload is staged"
    );
    // Killed: the port closes with no EndSession.
    drop(first);
    wait_for("the hang-up", || {
        sim.counters().hangups.load(Ordering::Relaxed) >= 1
    });
    let mut second = open();
    assert_eq!(
        ask(&mut second, &Request::CommitCalibration),
        Response::Error(ErrorCode::SchemaMismatch),
        "a bare commit from the next opener"
    );
    drop(second);
    let (mut dev, _) = Device::connect(&p, opts(2000)).unwrap();
    let s = dev.get_calibration().unwrap();
    assert!(!s.stored && s.staged.is_none(), "{s:?}");
    drop(dev);
    // `device get --out -` is refused as every command's `--out -` is (not a file named -).
    let args = device_args(&["device", "get", "--out", "-", "--port", &p]);
    let err = device::run(&args, &mut Vec::new()).unwrap_err().to_string();
    assert!(err.contains("standard output carries the report"), "{err}");
    assert!(!std::path::Path::new("-").exists());
    sim.stop().unwrap();
}

/// A MotionPlus gyro file as `gyrofit --out` writes it (the real writer; version 2 with a
/// g-sensitivity), in a Wii Remote accelerometer's frame: count axis yaw turns about −z, roll
/// about +y, pitch about −x, with 18.2 counts per °/s and 0.4–1.2 % misalignment (written
/// out here). Returns the file's calibration and the count-axes mounting (axis, sign).
fn motionplus_gyro_file(
    path: &std::path::Path,
    bias: [f64; 3],
) -> (
    wiical_core::gyro_correct::GyroCorrection<f64>,
    [(usize, f64); 3],
) {
    use wiical_analysis::output::gyrocal::{write_gyro_calibration, GyroCalFile};
    use wiical_core::gyro_correct::{GyroCorrection, GyroEffects};
    let s = std::f64::consts::PI / 180.0 / 18.2;
    let kc = [
        [s, 0.012 * s, -0.004 * s],
        [-0.008 * s, 1.015 * s, 0.0],
        [0.006 * s, 0.0, 0.985 * s],
    ];
    let mount = [(2usize, -1.0), (1, 1.0), (0, -1.0)];
    let mut k = [[0.0; 3]; 3];
    for (i, (a, sign)) in mount.iter().enumerate() {
        k[*a] = kc[i].map(|x| sign * x);
    }
    let mut correction = GyroCorrection {
        bias,
        matrix: k,
        effects: GyroEffects::default(),
    };
    correction.effects.g_sensitivity[0] = [1.5e-3, 0.0, -2e-4];
    let file = GyroCalFile {
        model: "full+bias".into(),
        correction,
        cv_rms_deg: 0.3,
    };
    write_gyro_calibration(path, &file).unwrap();
    (correction, mount)
}

/// Issue 50 item 2 end to end on the simulated adapter: `device put GYRO.json` (told from an
/// accelerometer file by its content) stages the count-axes calibration for the session
/// only, `device commit` stores it, `device get` reports it, and the live one equals the file
/// turned into the count axes (`K_c[i] = sign_i · K[axis_i]`, computed here in f64) within
/// f32 rounding; the g-sensitivity is named as kept on the host. An implausible file (an
/// MPU's zero near 0 counts) is refused in one sentence naming the parameter, before the
/// port is opened, and nothing changes on the adapter.
#[test]
fn a_gyro_file_is_put_committed_and_reported_by_device_get() {
    let (path, sim) = spawn(SimOptions::default()).unwrap();
    let p = port(&path);
    let run = |args: &[&str]| -> anyhow::Result<String> {
        let mut full = vec!["device"];
        full.extend_from_slice(args);
        full.extend_from_slice(&["--port", &p]);
        device::run(&device_args(&full), &mut Vec::new())
    };
    // No gyro calibration: `get` prints what it printed before the gyro existed.
    let before = run(&["get", "--json"]).unwrap();
    assert!(!before.contains("gyro"), "{before}");
    let file = temp_path("gyro.json");
    let (cal, mount) = motionplus_gyro_file(&file, [8100.5, 8230.0, 8150.25]);
    let f = file.to_str().unwrap();
    let text = run(&["put", f]).unwrap();
    assert!(text.contains("staged the gyro calibration"), "{text}");
    assert!(
        text.contains(
            "count axes from the file's accelerometer frame: yaw = -z, roll = +y, pitch = -x"
        ),
        "{text}"
    );
    assert!(
        text.contains("kept for hosts, not on the adapter: g_sensitivity"),
        "{text}"
    );
    // The upload belonged to that session.
    let get = run(&["get"]).unwrap();
    assert!(!get.contains("gyro"), "{get}");
    let text = run(&["commit", f]).unwrap();
    assert!(text.contains("it is live and stored"), "{text}");
    let get = run(&["get"]).unwrap();
    assert!(
        get.contains("live gyro calibration (MotionPlus, committed, stored on the adapter):"),
        "{get}"
    );
    assert!(get.contains("no gyro calibration staged"), "{get}");
    let state: serde_json::Value = serde_json::from_str(&run(&["get", "--json"]).unwrap()).unwrap();
    let live = &state["gyro"]["live"];
    assert_eq!(live["axes"], serde_json::json!(["yaw", "roll", "pitch"]));
    for (i, &(a, sign)) in mount.iter().enumerate() {
        let b = live["bias"][i].as_f64().unwrap();
        assert_eq!(b, f64::from(cal.bias[i] as f32), "bias {i}");
        for j in 0..3 {
            let got = live["matrix"][i][j].as_f64().unwrap();
            let want = sign * cal.matrix[a][j];
            // Within the f32 rounding of the value (plus serde's last digit of the file).
            assert!(
                (got - want).abs() <= 1.0 * f64::from(f32::EPSILON) * want.abs(),
                "K[{i}][{j}]: {got} vs {want}"
            );
        }
    }
    // An accelerometer file still goes the accelerometer's way beside it.
    let acc = temp_path("acc-beside-gyro.json");
    wiical_analysis::output::calfile::write_calibration(&acc, &true_calibration()).unwrap();
    let text = run(&["commit", acc.to_str().unwrap()]).unwrap();
    assert!(text.contains("live and stored"), "{text}");
    let state: serde_json::Value = serde_json::from_str(&run(&["get", "--json"]).unwrap()).unwrap();
    assert_eq!(state["stored"], true);
    assert!(state["gyro"]["live"].is_object(), "{state}");

    // Implausible: fitted to an MPU (zero near 0 counts). One sentence naming the offset.
    let bad = temp_path("gyro-mpu.json");
    motionplus_gyro_file(&bad, [-31.0, 12.5, 7.25]);
    let err = run(&["commit", bad.to_str().unwrap()])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("not plausible for a MotionPlus: x offset -8223 counts from nominal is beyond the limit"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    let after: serde_json::Value = serde_json::from_str(&run(&["get", "--json"]).unwrap()).unwrap();
    assert_eq!(after["gyro"], state["gyro"]);
    // With --force the adapter refuses it too, and still nothing changes.
    let err = run(&["commit", bad.to_str().unwrap(), "--force"])
        .unwrap_err()
        .to_string();
    assert!(err.contains("implausible"), "{err}");
    let after: serde_json::Value = serde_json::from_str(&run(&["get", "--json"]).unwrap()).unwrap();
    assert_eq!(after["gyro"], state["gyro"]);
    for f in [&file, &acc, &bad] {
        let _ = std::fs::remove_file(f);
    }
    sim.stop().unwrap();
}
