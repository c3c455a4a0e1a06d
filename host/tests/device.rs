//! End to end on a pseudo-terminal: the host client (`wiical device …`) against the
//! simulated adapter (`wiical device-sim`), which runs the real adapter logic
//! (`wiical-adapter`) with a simulated Nunchuk and flash. Unix only (pseudo-terminals).
#![cfg(unix)]

use wiical::cmd::device;
use wiical::{client, device_sim};

use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use clap::Parser;
use client::{ClientOptions, Device};
use device::{DeviceAction, DeviceArgs};
use device_sim::{spawn, SimFlash, SimOptions, TRUE_BIAS, TRUE_D};
use nalgebra::{Matrix3, Vector3};
use serialport::SerialPort;
use wiical::cmd::device_sim::SimArgs;
use wiical_core::Calibration;
use wiical_wire::{WireCalibration, PROTOCOL_VERSION, SCHEMA_KEY};

/// The calibration a perfect fit of the simulated sensor gives: `K = D⁻¹`, `b`.
fn true_calibration() -> Calibration {
    let d = Matrix3::from_fn(|i, j| TRUE_D[i][j]);
    let k = d.try_inverse().expect("invertible");
    Calibration {
        bias: TRUE_BIAS.map(|x| x as f32),
        matrix: std::array::from_fn(|i| std::array::from_fn(|j| k[(i, j)] as f32)),
        effects: Default::default(),
    }
}

fn bits(c: &Calibration) -> Vec<u32> {
    let mut v: Vec<u32> = c.bias.iter().map(|x| x.to_bits()).collect();
    for r in &c.matrix {
        v.extend(r.iter().map(|x| x.to_bits()));
    }
    v
}

fn opts(timeout_ms: u64) -> ClientOptions {
    ClientOptions {
        timeout: Duration::from_millis(timeout_ms),
        retries: 3,
    }
}

fn port(p: &std::path::Path) -> String {
    p.display().to_string()
}

/// Wait (bounded) for a condition the simulator thread sets.
fn wait_for(what: &str, mut cond: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !cond() {
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "timed out waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

fn temp_path(name: &str) -> PathBuf {
    std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("wiical-device-test-{}-{name}", std::process::id()))
}

#[test]
fn upload_read_back_commit_and_stream_corrected_samples() {
    let (path, sim) = spawn(SimOptions::default()).unwrap();
    let (mut dev, hello) = Device::connect(&port(&path), opts(2000)).unwrap();
    assert!(hello.firmware_version.starts_with("device-sim"));
    assert_eq!(hello.schema_key, SCHEMA_KEY);

    // Nothing committed: pass-through, live = the simulated Nunchuk's factory block.
    let s = dev.get_calibration().unwrap();
    assert!(!s.stored);
    assert_eq!(s.staged, None);
    let f = device_sim::sim_factory_block();
    let live = Calibration::from(s.live);
    for i in 0..3 {
        assert_eq!(live.bias[i], f32::from(f.zero[i]));
        assert_eq!(live.matrix[i][i], 1.0 / f32::from(f.one_g[i] - f.zero[i]));
    }

    // Upload, read back bit-identical.
    let cal = true_calibration();
    dev.put_calibration(&cal).unwrap();
    let s = dev.get_calibration().unwrap();
    assert_eq!(bits(&Calibration::from(s.staged.unwrap())), bits(&cal));
    assert!(!s.stored, "staged only");

    dev.commit().unwrap();
    let s = dev.get_calibration().unwrap();
    assert!(s.stored);
    assert_eq!(s.staged, None);
    assert_eq!(bits(&Calibration::from(s.live)), bits(&cal));

    // Stream: every sample is exactly the linear correction of its raw counts, and, since
    // the calibration inverts the simulated sensor, a still-ish Nunchuk reads |a| ≈ 1 g.
    assert_eq!(dev.start_stream(2).unwrap(), 100_000);
    let mut prev = None;
    for _ in 0..60 {
        let smp = dev.next_sample().unwrap();
        let want = cal.correct_linear(smp.raw.map(f32::from));
        assert_eq!(smp.corrected.map(f32::to_bits), want.map(f32::to_bits));
        let norm = Vector3::from(smp.corrected.map(f64::from)).norm();
        assert!((norm - 1.0).abs() < 0.03, "|a| = {norm} g");
        if let Some(p) = prev {
            assert_eq!(smp.seq, p + 1, "no sample lost on a quiet line");
        }
        prev = Some(smp.seq);
    }
    dev.stop_stream().unwrap();
    assert_eq!(dev.stats().frame_errors, 0);
    sim.stop().unwrap();
}

#[test]
fn recovers_from_corrupted_frames_both_ways() {
    let (path, sim) = spawn(SimOptions::default()).unwrap();
    let (mut dev, _) = Device::connect(&port(&path), opts(300)).unwrap();

    // Adapter → host: the answer is damaged on the line; the client discards it, times out
    // and asks again.
    sim.corrupt_next_answers(1);
    let s = dev.get_calibration().unwrap();
    assert!(!s.stored);
    assert!(dev.stats().frame_errors >= 1, "{:?}", dev.stats());
    assert!(dev.stats().retries >= 1);

    // Host → adapter: garbage without a delimiter runs into the next request, which the
    // adapter then rejects as BadFrame; the client re-sends at once.
    let retries_before = dev.stats().retries;
    dev.write_raw(&[0x13, 0x37, 0xFF, 0x42, 0x99, 0x01])
        .unwrap();
    dev.put_calibration(&true_calibration()).unwrap();
    assert!(sim.counters().bad_frames.load(Ordering::Relaxed) >= 1);
    assert!(dev.stats().retries > retries_before);
    let s = dev.get_calibration().unwrap();
    assert_eq!(
        bits(&Calibration::from(s.staged.unwrap())),
        bits(&true_calibration())
    );

    // A lost commit acknowledgement: the retry finds nothing staged, the client confirms
    // by reading the state back.
    let retries_before = dev.stats().retries;
    sim.corrupt_next_acks(1);
    dev.commit().unwrap();
    assert!(dev.stats().retries > retries_before, "the Ack was not lost");
    let s = dev.get_calibration().unwrap();
    assert!(s.stored);
    assert_eq!(bits(&Calibration::from(s.live)), bits(&true_calibration()));

    // Garbage bytes in the middle of a stream: the decoder resynchronises at the next
    // delimiter and samples keep coming.
    dev.start_stream(1).unwrap();
    for _ in 0..5 {
        dev.next_sample().unwrap();
    }
    let errors_before = dev.stats().frame_errors;
    sim.inject_to_host(&[0x05, 0xAB, 0xCD, 0x00, 0x77, 0x88, 0x99]);
    let mut got = 0;
    while got < 40 {
        dev.next_sample().unwrap();
        got += 1;
    }
    assert!(dev.stats().frame_errors > errors_before);
    dev.stop_stream().unwrap();
    sim.stop().unwrap();
}

#[test]
fn reconnect_and_simulator_restart_keep_the_committed_calibration() {
    let flash = SimFlash::in_memory();
    let (path, sim) = spawn(SimOptions {
        flash: flash.clone(),
        ..Default::default()
    })
    .unwrap();
    let cal = true_calibration();
    {
        let (mut dev, _) = Device::connect(&port(&path), opts(2000)).unwrap();
        dev.put_calibration(&cal).unwrap();
        dev.commit().unwrap();
        dev.start_stream(1).unwrap();
        dev.next_sample().unwrap();
        // The port is closed mid-stream (the client is dropped).
    }
    wait_for("the simulator to see the hang-up", || {
        sim.counters().hangups.load(Ordering::Relaxed) >= 1
    });
    {
        let (mut dev, _) = Device::connect(&port(&path), opts(2000)).unwrap();
        let s = dev.get_calibration().unwrap();
        assert!(s.stored);
        assert_eq!(bits(&Calibration::from(s.live)), bits(&cal));
        assert_eq!(dev.start_stream(1).unwrap(), 200_000);
        assert_eq!(dev.next_sample().unwrap().seq, 0, "a fresh stream");
        dev.stop_stream().unwrap();
    }
    sim.stop().unwrap();

    // A new simulator on the same flash boots with the committed calibration.
    let (path2, sim2) = spawn(SimOptions {
        flash,
        seed: 2,
        ..Default::default()
    })
    .unwrap();
    let (mut dev, _) = Device::connect(&port(&path2), opts(2000)).unwrap();
    let s = dev.get_calibration().unwrap();
    assert!(s.stored, "calibration lost across the restart");
    assert_eq!(bits(&Calibration::from(s.live)), bits(&cal));
    let smp = {
        dev.start_stream(1).unwrap();
        dev.next_sample().unwrap()
    };
    assert_eq!(
        smp.corrected.map(f32::to_bits),
        cal.correct_linear(smp.raw.map(f32::from)).map(f32::to_bits)
    );
    sim2.stop().unwrap();
}

#[test]
fn file_backed_flash_survives_a_restart() {
    let file = temp_path("flash.bin");
    let _ = std::fs::remove_file(&file);
    let cal = true_calibration();
    {
        let (path, sim) = spawn(SimOptions {
            flash: SimFlash::file(&file).unwrap(),
            ..Default::default()
        })
        .unwrap();
        let (mut dev, _) = Device::connect(&port(&path), opts(2000)).unwrap();
        dev.put_calibration(&cal).unwrap();
        dev.commit().unwrap();
        sim.stop().unwrap();
    }
    let (path, sim) = spawn(SimOptions {
        flash: SimFlash::file(&file).unwrap(),
        ..Default::default()
    })
    .unwrap();
    let (mut dev, _) = Device::connect(&port(&path), opts(2000)).unwrap();
    assert_eq!(
        bits(&Calibration::from(dev.get_calibration().unwrap().live)),
        bits(&cal)
    );
    sim.stop().unwrap();
    // A file that is not a flash image is refused.
    std::fs::write(&file, b"not a flash image").unwrap();
    assert!(SimFlash::file(&file).is_err());
    let _ = std::fs::remove_file(&file);
}

#[test]
fn schema_mismatch_is_refused_naming_both_versions() {
    let (path, sim) = spawn(SimOptions {
        schema_key: Some(0xDEAD_BEEF),
        ..Default::default()
    })
    .unwrap();
    let err = Device::connect(&port(&path), opts(2000))
        .err()
        .expect("mismatch accepted")
        .to_string();
    assert!(err.contains("0xDEADBEEF"), "{err}");
    assert!(err.contains(&format!("0x{SCHEMA_KEY:08X}")), "{err}");
    assert!(err.contains(&format!("v{PROTOCOL_VERSION}")), "{err}");
    // Nothing else is served on that session either.
    let mut dev = Device::open(&port(&path), opts(300)).unwrap();
    assert!(dev.get_calibration().is_err());
    sim.stop().unwrap();
}

/// An adapter whose key is a known older protocol's gets told apart: the message says which
/// side to update.
#[test]
fn an_older_firmware_is_named_as_such() {
    let (v1, key1) = wiical_wire::PREVIOUS_SCHEMA_KEYS[0];
    let (path, sim) = spawn(SimOptions {
        schema_key: Some(key1),
        ..Default::default()
    })
    .unwrap();
    let err = Device::connect(&port(&path), opts(2000))
        .err()
        .expect("mismatch accepted")
        .to_string();
    assert!(err.contains(&format!("wire protocol v{v1}")), "{err}");
    assert!(err.contains("firmware is older"), "{err}");
    sim.stop().unwrap();
}

#[test]
fn missing_or_silent_port_gives_clear_errors() {
    let err = Device::open("/dev/wiical-no-such-port", opts(100))
        .err()
        .unwrap()
        .to_string();
    assert!(err.contains("does not exist"), "{err}");

    // A pty whose other end never answers.
    let (_master, slave) = serialport::TTYPort::pair().unwrap();
    let name = slave.name().unwrap();
    let err = Device::connect(
        &name,
        ClientOptions {
            timeout: Duration::from_millis(100),
            retries: 1,
        },
    )
    .err()
    .unwrap()
    .to_string();
    assert!(err.contains("did not answer Hello"), "{err}");
    assert!(err.contains("2 attempts"), "{err}");
}

#[test]
fn unplugged_nunchuk_stops_samples_until_replugged() {
    let (path, sim) = spawn(SimOptions::default()).unwrap();
    let (mut dev, _) = Device::connect(&port(&path), opts(400)).unwrap();
    dev.start_stream(1).unwrap();
    dev.next_sample().unwrap();
    sim.set_nunchuk_plugged(false);
    // Samples stop (after the few already in flight).
    let t0 = Instant::now();
    let err = loop {
        match dev.next_sample() {
            Ok(_) => assert!(
                t0.elapsed() < Duration::from_secs(5),
                "samples never stopped"
            ),
            Err(e) => break e.to_string(),
        }
    };
    assert!(err.contains("Nunchuk plugged in"), "{err}");
    sim.set_nunchuk_plugged(true);
    let s = dev.next_sample().unwrap();
    assert!(s.raw.iter().all(|&r| r > 100 && r < 1000));
    dev.stop_stream().unwrap();
    sim.stop().unwrap();
}

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
    // The upload belonged to that session: a later commit finds nothing (issue 11).
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
    // Orientation-dependent cross terms (issue 19) are applied by the adapter, the drift
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
