//! End to end on a pseudo-terminal: the adapter client ([`wiical_client::Device`]) against
//! the simulated adapter (`wiical-device-sim`), which runs the real adapter logic
//! (`wiical-adapter`) with a simulated Nunchuk and flash. Unix only (pseudo-terminals).
#![cfg(unix)]

mod support;
use support::*;

use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use nalgebra::Vector3;
use serialport::SerialPort;
use wiical_client::{ClientOptions, Device};
use wiical_core::Calibration;
use wiical_device_sim::{spawn, SimFlash, SimOptions};
use wiical_wire::{PROTOCOL_VERSION, SCHEMA_KEY};

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
    let f = wiical_device_sim::sim_factory_block();
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
