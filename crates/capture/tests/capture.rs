//! The capture library against the scripted fake remote: the start-up protocol, the real factory
//! calibration bytes, the CSV and side file, the guided mode, and bad device answers.
//!
//! No test talks to a real Wii Remote (none is available to CI); `open_wiimote` is only tested
//! for its "no device" error.
#![allow(clippy::needless_range_loop)] // per-axis loops over several parallel arrays

mod support;
use support::*;

use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::PathBuf;
use wiical_analysis::fit::base::{self as fit_cmd, FitOptions};
use wiical_analysis::input::front_door as input;
use wiical_analysis::LoadOptions;
use wiical_capture::guided::GuidedConfig;
use wiical_capture::hid::{self, AddressSpace};
use wiical_capture::io::{open_wiimote, LogReplay, RawLogger, NO_DEVICE_HELP};
use wiical_capture::replay::{report_0x35, status_report, EndOfScript, ReadRequest, ReplayWiimote};
use wiical_capture::{capture, CaptureMode, CollectUi};

#[test]
#[allow(clippy::too_many_lines, reason = "a test reads top to bottom")]
fn replay_session_decodes_the_real_calibrations_and_writes_a_loadable_csv() {
    let mut dev = fake(true);
    let end = script(&mut dev, &[Seg::Still([0.0, 0.0, 1.0], 3.0)], true, 1, 0.0);
    assert!((end - 3.0).abs() < 1e-9);
    let out = tmp("plain.csv");
    let mut ui = CollectUi::default();
    let summary = capture(
        &mut dev,
        &opts(out.clone(), CaptureMode::Duration(2.0)),
        &mut ui,
    )
    .unwrap();

    // The start-up sequence sent the documented reports.
    let w = &dev.written;
    assert_eq!(w[0], hid::set_leds(1));
    assert!(w.contains(&vec![0x15, 0x00]));
    assert!(
        w.contains(&vec![0x17, 0x00, 0x00, 0x00, 0x16, 0x00, 0x14]),
        "{w:02X?}"
    );
    let init1 = w
        .iter()
        .position(|r| r.starts_with(&[0x16, 0x04, 0xA4, 0x00, 0xF0, 0x01, 0x55]));
    let init2 = w
        .iter()
        .position(|r| r.starts_with(&[0x16, 0x04, 0xA4, 0x00, 0xFB, 0x01, 0x00]));
    assert!(init1.is_some() && init2 > init1, "{w:02X?}");
    assert!(w.contains(&vec![0x17, 0x04, 0xA4, 0x00, 0xFA, 0x00, 0x06]));
    assert!(w.contains(&vec![0x17, 0x04, 0xA4, 0x00, 0x20, 0x00, 0x20]));
    assert_eq!(w.last().unwrap(), &vec![0x12, 0x04, 0x35]);

    // The side file: both blocks as SOURCE.md decodes them.
    let cal = read_json(&summary.cal_file);
    assert_eq!(summary.cal_file, tmp("plain.csv.cal.json"));
    let wm = &cal["wiimote"];
    assert_eq!(u64s(&wm["zero"]), WIIMOTE_ZERO);
    assert_eq!(u64s(&wm["one_g"]), WIIMOTE_ONE_G);
    assert_eq!(u64s(&wm["counts_per_g"]), [106, 105, 111]);
    assert_eq!(wm["copy_used"], "first");
    assert_eq!(wm["copies"][0]["address"], "0x0016");
    assert_eq!(wm["copies"][1]["address"], "0x0020");
    assert_eq!(wm["copies"][1]["hex"], "82 82 82 15 9C 9C 9E 38 40 3E");
    assert_eq!(wm["copies"][0]["checksum_ok"], true);
    let nc = &cal["nunchuk"];
    assert_eq!(u64s(&nc["zero_8bit"]), NUNCHUK_ZERO_8);
    assert_eq!(u64s(&nc["one_g_8bit"]), NUNCHUK_ONE_G_8);
    assert_eq!(u64s(&nc["zero"]), NUNCHUK_ZERO_10);
    assert_eq!(u64s(&nc["one_g"]), NUNCHUK_ONE_G_10);
    assert_eq!(nc["copies"][1]["address"], "0xA40030");
    assert_eq!(nc["copies"][1]["checksum_ok"], true);
    assert_eq!(nc["lsb_order_confirmed"], false);
    assert_eq!(u64s(&nc["stick"][0]), [0xDF, 0x18, 0x81]);
    assert!(cal["extension_id"]
        .as_str()
        .unwrap()
        .starts_with("00 00 A4 20 00 00"));
    assert_eq!(cal["capture"]["complete"], true);

    // The CSV: comments with the calibrations, then t,x,y,z,ext_x,ext_y,ext_z.
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains("# wiimote_cal_zero: 521 521 521\n"),
        "{text:.600}"
    );
    assert!(text.contains("# nunchuk_cal_one_g_8bit: 175 174 173\n"));
    assert!(
        text.contains("# wiimote_cal_block_0x0016: 82 82 82 15 9C 9C 9E 38 40 3E (checksum ok)\n")
    );
    assert!(text.lines().any(|l| l == "t,x,y,z,ext_x,ext_y,ext_z"));

    // It loads with the CLI's reader: the remote by default, the Nunchuk with --columns.
    let rec = input::load(&out, &LoadOptions::default()).unwrap();
    // 2 s at 100 Hz: samples at t = 0.00 … 2.00.
    assert_eq!(rec.len(), 201);
    let t = rec.t.as_ref().unwrap();
    assert!((t[0]).abs() < 1e-9 && (t[200] - 2.0).abs() < 1e-6);
    // Still with +Z up: x ≈ bias, z ≈ bias + sens; Y and Z are even (9 significant bits).
    let mean = |k: usize, r: &wiical_analysis::Recording| {
        r.xyz.iter().map(|s| s[k]).sum::<f64>() / r.len() as f64
    };
    assert!((mean(0, &rec) - REMOTE.bias[0]).abs() < 0.5);
    assert!((mean(2, &rec) - (REMOTE.bias[2] + REMOTE.sens[2])).abs() < 1.0);
    assert!(rec
        .xyz
        .iter()
        .all(|s| s[1] % 2.0 == 0.0 && s[2] % 2.0 == 0.0));
    let nun = input::load(
        &out,
        &LoadOptions {
            columns: Some(["ext_x".into(), "ext_y".into(), "ext_z".into()]),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(nun.len(), 201);
    assert!((mean(2, &nun) - (NUNCHUK.bias[2] + NUNCHUK.sens[2])).abs() < 0.5);
    assert!((mean(0, &nun) - NUNCHUK.bias[0]).abs() < 0.5);
    assert!(ui
        .messages
        .iter()
        .any(|m| m.contains("wiimote factory calibration (first copy)")));
}

#[test]
fn without_an_extension_the_csv_has_only_the_remote() {
    let mut dev = fake(false);
    script(&mut dev, &[Seg::Still([1.0, 0.0, 0.0], 1.5)], false, 2, 0.0);
    let out = tmp("remote_only.csv");
    let s = capture(
        &mut dev,
        &opts(out.clone(), CaptureMode::Duration(1.0)),
        &mut CollectUi::default(),
    )
    .unwrap();
    assert!(s.calibration.nunchuk.is_none());
    assert!(s.calibration.extension_id.is_none());
    // No extension init was sent.
    assert!(!dev.written.iter().any(|r| r[0] == 0x16));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.lines().any(|l| l == "t,x,y,z"));
    let rec = input::load(&out, &LoadOptions::default()).unwrap();
    assert_eq!(rec.len(), 101);
    assert!((rec.xyz[50][0] - (REMOTE.bias[0] + REMOTE.sens[0])).abs() < 6.0);
}

#[test]
fn an_extension_that_is_not_a_nunchuk_is_not_recorded() {
    let (_, n) = real_blocks();
    // A Classic Controller's ID (WiiBrew: 0000 A420 0101).
    let mut dev = fake(false)
        .with_nunchuk(&n)
        .with_registers(0xA4_00FA, &[0x00, 0x00, 0xA4, 0x20, 0x01, 0x01]);
    script(
        &mut dev,
        &[Seg::Still([0.0, 0.0, 1.0], 1.0)],
        false,
        13,
        0.0,
    );
    let out = tmp("classic.csv");
    let mut ui = CollectUi::default();
    let s = capture(
        &mut dev,
        &opts(out.clone(), CaptureMode::Duration(0.5)),
        &mut ui,
    )
    .unwrap();
    assert!(s.calibration.nunchuk.is_none());
    assert_eq!(
        s.calibration.extension_id.as_deref(),
        Some("00 00 A4 20 01 01 (Classic Controller)")
    );
    // Its calibration was not read.
    assert!(!dev
        .written
        .contains(&vec![0x17, 0x04, 0xA4, 0x00, 0x20, 0x00, 0x20]));
    assert!(ui
        .messages
        .iter()
        .any(|m| m.contains("is not a Nunchuk: only the remote is recorded")));
    assert!(std::fs::read_to_string(&out)
        .unwrap()
        .lines()
        .any(|l| l == "t,x,y,z"));
}

#[test]
#[allow(clippy::too_many_lines, reason = "a test reads top to bottom")]
fn guided_capture_counts_the_poses_and_the_fit_recovers_the_simulated_sensors() {
    let poses = twelve_poses();
    let mut segs = vec![Seg::Still(poses[0], 5.0)];
    for w in poses.windows(2) {
        segs.push(Seg::Turn(w[0], w[1], 1.5));
        segs.push(Seg::Still(w[1], 5.0));
    }
    let mut dev = fake(true);
    script(&mut dev, &segs, true, 3, 0.0);
    let out = tmp("guided.csv");
    let mut ui = CollectUi::default();
    let cfg = GuidedConfig {
        poses: 12,
        ..Default::default()
    };
    let s = capture(
        &mut dev,
        &opts(out.clone(), CaptureMode::Guided(cfg)),
        &mut ui,
    )
    .unwrap();
    let stats = s.calibration.capture.as_ref().unwrap();
    assert!(stats.complete);
    assert_eq!(stats.poses.len(), 12, "{:#?}", ui.messages);
    // Each pose's mean is the simulated reading of its orientation.
    for (p, g) in stats.poses.iter().zip(&poses) {
        for a in 0..3 {
            let want = REMOTE.bias[a] + REMOTE.sens[a] * g[a];
            // Y/Z lose bit 0 on the wire: −0.5 on average.
            let want = if a == 0 { want } else { want - 0.5 };
            assert!(
                (p.mean[0][a] - want).abs() < 0.6,
                "pose {}: {:?} vs {want}",
                p.pose,
                p.mean[0]
            );
            let want_n = NUNCHUK.bias[a] + NUNCHUK.sens[a] * g[a];
            assert!(
                (p.mean[1][a] - want_n).abs() < 0.6,
                "pose {} nunchuk",
                p.pose
            );
        }
        assert!(p.t_end - p.t_start >= 4.0);
    }
    for k in 1..12 {
        assert!(
            ui.messages
                .iter()
                .any(|m| m == &format!("pose {k} done: turn the remote to a new orientation")),
            "{:#?}",
            ui.messages
        );
    }
    assert!(ui.messages.iter().any(|m| m == "all 12 poses done"));
    // The capture stopped at the 12th pose: the rest of the script was not read.
    assert!(dev.remaining() > 0);

    // `wiical fit` on the CSV finds the 12 poses and the simulated sensor, for both devices.
    let check = |columns: Option<[String; 3]>, truth: Sensor, lsb_shift: [f64; 3]| {
        let rec = input::load(
            &out,
            &LoadOptions {
                columns,
                ..Default::default()
            },
        )
        .unwrap();
        let rep = fit_cmd::run(&rec, &FitOptions::default()).unwrap();
        eprintln!(
            "fit: bias {:?} (truth {:?}), K·sens {:?}, rms {} mg",
            rep.bias,
            truth.bias,
            std::array::from_fn::<f64, 3, _>(|a| f64::from(rep.matrix[a][a]) * truth.sens[a]),
            rep.rms_mg
        );
        assert_eq!(rep.static_windows, 12);
        for a in 0..3 {
            let b = truth.bias[a] - lsb_shift[a];
            assert!(
                (f64::from(rep.bias[a]) - b).abs() < 0.2,
                "bias {:?} vs {:?}",
                rep.bias,
                truth.bias
            );
            let k = f64::from(rep.matrix[a][a]);
            assert!(
                (k * truth.sens[a] - 1.0).abs() < 1.5e-3,
                "K {:?} vs sens {:?}",
                rep.matrix,
                truth.sens
            );
        }
        assert!(rep.rms_mg < 5.0, "rms {} mg", rep.rms_mg);
    };
    check(None, REMOTE, [0.0, 0.5, 0.5]);
    check(
        Some(["ext_x".into(), "ext_y".into(), "ext_z".into()]),
        NUNCHUK,
        [0.0; 3],
    );
}

#[test]
fn guided_capture_refuses_a_pose_that_never_gets_still() {
    let p = twelve_poses();
    let mut dev = fake(false);
    // Rest + pose 1, then the remote keeps turning back and forth for 40 s.
    let mut segs = vec![Seg::Still(p[0], 5.0)];
    for _ in 0..20 {
        segs.push(Seg::Turn(p[0], p[1], 1.0));
        segs.push(Seg::Turn(p[1], p[0], 1.0));
    }
    script(&mut dev, &segs, false, 4, 0.0);
    let out = tmp("never_still.csv");
    let cfg = GuidedConfig {
        poses: 3,
        still_timeout_s: 15.0,
        ..Default::default()
    };
    let mut ui = CollectUi::default();
    let e = capture(
        &mut dev,
        &opts(out.clone(), CaptureMode::Guided(cfg)),
        &mut ui,
    )
    .unwrap_err();
    let msg = format!("{e:#}");
    assert!(
        msg.contains("pose 2: the remote did not keep still for 4 s within 15 s"),
        "{msg}"
    );
    assert!(msg.contains("capture stopped after"), "{msg}");
    assert!(ui
        .messages
        .iter()
        .any(|m| m == "pose 1 done: turn the remote to a new orientation"));
    // What was recorded is kept and readable, and the side file says it is partial.
    let rec = input::load(&out, &LoadOptions::default()).unwrap();
    assert!(rec.len() > 1500, "{}", rec.len());
    let cal = read_json(&tmp("never_still.csv.cal.json"));
    assert_eq!(cal["capture"]["complete"], false);
    assert_eq!(cal["capture"]["poses"].as_array().unwrap().len(), 1);
}

#[test]
fn a_bad_first_eeprom_copy_falls_back_to_the_second_and_two_bad_copies_still_record() {
    let (w, _) = real_blocks();
    let mut bad = w;
    bad[2] ^= 0x01;
    let mut dev = ReplayWiimote::new()
        .with_eeprom(0x16, &bad)
        .with_eeprom(0x20, &w);
    script(&mut dev, &[Seg::Still([0.0, 0.0, 1.0], 1.0)], false, 5, 0.0);
    let s = capture(
        &mut dev,
        &opts(tmp("fallback.csv"), CaptureMode::Duration(0.5)),
        &mut CollectUi::default(),
    )
    .unwrap();
    let wm = &s.calibration.wiimote;
    assert_eq!(wm.copy_used.as_deref(), Some("second"));
    assert!(!wm.copies[0].checksum_ok && wm.copies[1].checksum_ok);
    assert_eq!(wm.zero, Some([521, 521, 521]));

    let mut dev = ReplayWiimote::new()
        .with_eeprom(0x16, &bad)
        .with_eeprom(0x20, &bad);
    script(&mut dev, &[Seg::Still([0.0, 0.0, 1.0], 1.0)], false, 5, 0.0);
    let mut ui = CollectUi::default();
    let out = tmp("both_bad.csv");
    let s = capture(
        &mut dev,
        &opts(out.clone(), CaptureMode::Duration(0.5)),
        &mut ui,
    )
    .unwrap();
    assert_eq!(s.calibration.wiimote.copy_used, None);
    assert!(ui
        .messages
        .iter()
        .any(|m| m.contains("no copy of the wiimote calibration has a valid checksum")));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("# wiimote_cal_copy_used: none\n"));
    assert!(text.contains("(checksum BAD)"));
    assert_eq!(
        input::load(&out, &LoadOptions::default()).unwrap().len(),
        51
    );
}

/// Runs the start-up sequence with `hook` answering read requests; returns the error text.
fn setup_error(
    hook: impl FnMut(&ReadRequest) -> Option<Vec<Vec<u8>>> + 'static,
    nunchuk: bool,
) -> String {
    let mut dev = fake(nunchuk).with_end(EndOfScript::Silence);
    dev.read_hook = Some(Box::new(hook));
    script(
        &mut dev,
        &[Seg::Still([0.0, 0.0, 1.0], 1.0)],
        nunchuk,
        6,
        0.0,
    );
    let out = tmp("bad_device.csv");
    let e = capture(
        &mut dev,
        &opts(out, CaptureMode::Duration(0.5)),
        &mut CollectUi::default(),
    )
    .expect_err("the start-up should fail");
    format!("{e:#}")
}

fn reply(error_nibble: u8, address: u16, len: usize) -> Vec<u8> {
    let mut r = vec![0u8; len];
    r[0] = 0x21;
    if len > 5 {
        r[3] = 0xF0 | error_nibble;
        r[4..6].copy_from_slice(&address.to_be_bytes());
    }
    r
}

#[test]
fn bad_device_answers_give_clear_errors() {
    // Error nibble 8 on the EEPROM read.
    let e = setup_error(
        |r| (r.space == AddressSpace::Eeprom).then(|| vec![reply(8, 0x16, 22)]),
        false,
    );
    assert!(
        e.contains("reading the accelerometer calibration from the EEPROM"),
        "{e}"
    );
    assert!(e.contains("error 8 (invalid address"), "{e}");
    // Error nibble 7 on the Nunchuk calibration read (unplugged in the meantime).
    let e = setup_error(
        |r| (r.address == 0xA40020).then(|| vec![reply(7, 0x0020, 22)]),
        true,
    );
    assert!(e.contains("reading the Nunchuk calibration"), "{e}");
    assert!(e.contains("error 7 (no answer on the extension bus"), "{e}");
    // A truncated reply.
    let e = setup_error(|_| Some(vec![reply(0, 0x16, 9)]), false);
    assert!(
        e.contains("short input report 0x21: 9 bytes, expected 22"),
        "{e}"
    );
    // No reply at all.
    let e = setup_error(|_| Some(vec![]), false);
    assert!(e.contains("did not answer within 1000 ms"), "{e}");
    // A reply for another address.
    let e = setup_error(
        |_| {
            Some(vec![{
                let mut r = reply(0, 0x1234, 22);
                r[3] = 0xF0;
                r
            }])
        },
        false,
    );
    assert!(
        e.contains("read reply for address 0x..1234, expected 0x..0016"),
        "{e}"
    );
    // A write refused by the extension (acknowledged with error 7).
    let mut dev = fake(true);
    dev.write_error = Some(7);
    script(&mut dev, &[Seg::Still([0.0, 0.0, 1.0], 1.0)], true, 6, 0.0);
    let e = capture(
        &mut dev,
        &opts(tmp("refused.csv"), CaptureMode::Duration(0.5)),
        &mut CollectUi::default(),
    )
    .unwrap_err();
    let e = format!("{e:#}");
    assert!(
        e.contains(
            "extension init: the Wii Remote refused the registers write at 0xA400F0: error 7"
        ),
        "{e}"
    );
}

#[test]
fn unknown_report_ids_are_skipped_and_counted() {
    let mut dev = fake(false);
    let mut first = true;
    dev.read_hook = Some(Box::new(move |r| {
        if !std::mem::take(&mut first) {
            return None;
        }
        // Before the real reply: an unknown ID and an unsupported one.
        let mut answer = vec![vec![0x99, 1, 2], vec![0x3D; 22]];
        let (w, _) = real_blocks();
        let mut a = reply(0, r.address as u16, 22);
        a[3] = 0xF0; // 16 bytes
        a[6..16].copy_from_slice(&w);
        a[16..22].copy_from_slice(&w[..6]);
        let mut b = reply(0, r.address as u16 + 16, 22);
        b[3] = 0x30; // 4 bytes
        b[6..10].copy_from_slice(&w[6..10]);
        answer.push(a);
        answer.push(b);
        Some(answer)
    }));
    let mut t = 0.0;
    for k in 0..100 {
        dev.push_report(t, report_0x35([600, 500, 400], None));
        if k % 10 == 0 {
            dev.push_report(t, vec![0x3E; 22]);
        }
        t += 0.01;
    }
    let s = capture(
        &mut dev,
        &opts(tmp("unknown.csv"), CaptureMode::Duration(0.5)),
        &mut CollectUi::default(),
    )
    .unwrap();
    assert_eq!(s.calibration.wiimote.copy_used.as_deref(), Some("first"));
    let st = s.calibration.capture.unwrap();
    assert_eq!(st.samples, 51);
    // 2 during the start-up (0x99, 0x3D), 5 during the 0.5 s recorded (t = 0, 0.1, … 0.4).
    assert_eq!(st.unknown_reports, 7);
}

#[test]
fn malformed_data_reports_and_silence_end_the_capture_with_clear_errors() {
    let mut dev = fake(false);
    for k in 0..300 {
        dev.push_report(k as f64 * 0.01, vec![0x35, 0, 0, 1]);
    }
    let e = capture(
        &mut dev,
        &opts(tmp("malformed.csv"), CaptureMode::Duration(5.0)),
        &mut CollectUi::default(),
    )
    .unwrap_err();
    let e = format!("{e:#}");
    assert!(
        e.contains(
            "malformed reports (100 in a row; last: short input report 0x35: 4 bytes, expected 22)"
        ),
        "{e}"
    );

    let mut dev = fake(false).with_end(EndOfScript::Silence);
    script(&mut dev, &[Seg::Still([0.0, 0.0, 1.0], 1.0)], false, 7, 0.0);
    let e = capture(
        &mut dev,
        &opts(tmp("silence.csv"), CaptureMode::Duration(5.0)),
        &mut CollectUi::default(),
    )
    .unwrap_err();
    let e = format!("{e:#}");
    assert!(
        e.contains("no data report from the Wii Remote for 2 s"),
        "{e}"
    );
    assert!(e.contains("capture stopped after 100 samples"), "{e}");

    let mut dev = fake(false);
    script(&mut dev, &[Seg::Still([0.0, 0.0, 1.0], 1.0)], false, 7, 0.0);
    let e = capture(
        &mut dev,
        &opts(tmp("lost.csv"), CaptureMode::Duration(5.0)),
        &mut CollectUi::default(),
    )
    .unwrap_err();
    assert!(format!("{e:#}").contains("lost the Wii Remote"), "{e:#}");
}

#[test]
fn nunchuk_unplugged_and_plugged_back_in() {
    let mut dev = fake(true);
    let t = script(&mut dev, &[Seg::Still([0.0, 0.0, 1.0], 1.0)], true, 8, 0.0);
    dev.push_report(t, status_report(false));
    let t = script(
        &mut dev,
        &[Seg::Still([0.0, 0.0, 1.0], 0.5)],
        false,
        9,
        t + 0.01,
    );
    dev.push_report(t, status_report(true));
    script(
        &mut dev,
        &[Seg::Still([0.0, 0.0, 1.0], 1.0)],
        true,
        10,
        t + 0.01,
    );
    let out = tmp("replug.csv");
    let mut ui = CollectUi::default();
    let s = capture(
        &mut dev,
        &opts(out.clone(), CaptureMode::Duration(2.4)),
        &mut ui,
    )
    .unwrap();
    assert_eq!(s.calibration.capture.as_ref().unwrap().status_reports, 2);
    // The mode was set again after each status report (WiiBrew: else the data stops).
    let modes = dev
        .written
        .iter()
        .filter(|r| r[..] == [0x12, 0x04, 0x35])
        .count();
    assert_eq!(modes, 3);
    // The extension was initialised again after being plugged back in.
    let inits = dev
        .written
        .iter()
        .filter(|r| r.starts_with(&[0x16, 0x04, 0xA4, 0x00, 0xF0, 0x01, 0x55]))
        .count();
    assert_eq!(inits, 2);
    assert!(ui.messages.iter().any(|m| m.contains("Nunchuk unplugged")));
    assert!(ui.messages.iter().any(|m| m == "Nunchuk plugged back in"));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains(": extension unplugged\n") && text.contains(": extension plugged in\n"));
    let empty = text.lines().filter(|l| l.ends_with(",,,")).count();
    assert!(
        (45..=55).contains(&empty),
        "{empty} rows without the Nunchuk"
    );
    // The remote's columns load whole; the Nunchuk's skip the gap and count it.
    let remote = input::load(&out, &LoadOptions::default()).unwrap();
    assert!(remote.len() > 200);
    let nunchuk = input::load(
        &out,
        &LoadOptions {
            columns: Some(["ext_x".into(), "ext_y".into(), "ext_z".into()]),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(nunchuk.skipped_empty_rows, empty);
    assert_eq!(nunchuk.len() + empty, remote.len());
    assert_eq!(nunchuk.t.as_ref().unwrap().len(), nunchuk.len());
}

#[test]
fn a_raw_log_replays_to_the_same_recording() {
    let mut dev = fake(true);
    script(&mut dev, &[Seg::Still([0.0, 1.0, 0.0], 1.5)], true, 11, 0.0);
    let mut log = Vec::new();
    let first = {
        let mut logged = RawLogger::new(&mut dev, &mut log).unwrap();
        capture(
            &mut logged,
            &opts(tmp("logged.csv"), CaptureMode::Duration(1.0)),
            &mut CollectUi::default(),
        )
        .unwrap()
    };
    let text = String::from_utf8(log).unwrap();
    assert!(
        text.lines().any(|l| l.ends_with("out 12 04 35")),
        "{text:.500}"
    );
    let mut replay = LogReplay::parse(&text).unwrap();
    let second = capture(
        &mut replay,
        &opts(tmp("replayed.csv"), CaptureMode::Duration(1.0)),
        &mut CollectUi::default(),
    )
    .unwrap();
    assert_eq!(first.calibration.wiimote, second.calibration.wiimote);
    assert_eq!(first.calibration.nunchuk, second.calibration.nunchuk);
    let rows = |p: &str| -> Vec<String> {
        std::fs::read_to_string(tmp(p))
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with('#'))
            .map(String::from)
            .collect()
    };
    assert_eq!(rows("logged.csv"), rows("replayed.csv"));
    assert_eq!(rows("logged.csv").len(), 102);
    assert!(LogReplay::parse("0.0 in 20 zz").is_err());
    assert!(LogReplay::parse("# nothing\n").is_err());
}

#[test]
fn opening_without_a_remote_is_a_clear_error() {
    match open_wiimote() {
        Err(e) => {
            let e = format!("{e:#}");
            assert!(
                e == NO_DEVICE_HELP || e.starts_with("cannot initialise HID access"),
                "{e}"
            );
            eprintln!("open_wiimote here: {e}");
        }
        Ok(dev) => eprintln!(
            "a Wii Remote is connected ({}): the no-device path cannot be tested on this machine",
            wiical_capture::io::WiimoteIo::describe(&dev)
        ),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn arbitrary_report_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..40)) {
        let _ = hid::parse_input(&bytes);
    }

    #[test]
    fn arbitrary_device_answers_never_panic(
        replies in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..30), 0..6),
        stream in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..30), 0..200),
        nunchuk in any::<bool>(),
        guided in any::<bool>(),
    ) {
        let mut dev = fake(nunchuk);
        let mut replies = Some(replies);
        dev.read_hook = Some(Box::new(move |_| replies.take()));
        let mut rng = ChaCha8Rng::seed_from_u64(stream.len() as u64);
        for (k, r) in stream.into_iter().enumerate() {
            // Mix the random bytes with valid data reports.
            if rng.random_bool(0.5) {
                dev.push_report(k as f64 * 0.01, report_0x35([rng.random_range(0..1024), 500, 600], None));
            }
            dev.push_report(k as f64 * 0.01, r);
        }
        let mode = if guided {
            CaptureMode::Guided(GuidedConfig { poses: 2, init_s: 0.3, hold_s: 0.5, window_s: 0.2, ..Default::default() })
        } else {
            CaptureMode::Duration(1.0)
        };
        let _ = capture(&mut dev, &opts(tmp("prop.csv"), mode), &mut CollectUi::default());
    }
}

#[test]
fn a_failed_capture_leaves_existing_files_untouched() {
    // Malformed reports right after the set-up: the capture fails with no samples.
    let failing = || {
        let mut dev = fake(false);
        for k in 0..300 {
            dev.push_report(k as f64 * 0.01, vec![0x35, 0, 0, 1]);
        }
        dev
    };
    let out = tmp("keep_me.csv");
    let side = PathBuf::from(format!("{}.cal.json", out.display()));
    std::fs::write(&out, "t,x,y,z\n0,512,512,612\n").unwrap();
    std::fs::write(&side, "{\"an\": \"older side file\"}\n").unwrap();
    let e = capture(
        &mut failing(),
        &opts(out.clone(), CaptureMode::Duration(5.0)),
        &mut CollectUi::default(),
    )
    .unwrap_err();
    let e = format!("{e:#}");
    assert!(e.contains("and its side file were left untouched"), "{e}");
    assert_eq!(
        std::fs::read_to_string(&out).unwrap(),
        "t,x,y,z\n0,512,512,612\n"
    );
    assert_eq!(
        std::fs::read_to_string(&side).unwrap(),
        "{\"an\": \"older side file\"}\n"
    );
    // The (empty) partial recording is kept aside, named in the message.
    let kept = e.split("the samples are in ").nth(1).unwrap();
    let kept = PathBuf::from(kept.split(" (side file").next().unwrap());
    assert!(kept.exists(), "{}", kept.display());
    let _ = std::fs::remove_file(&kept);
    let _ = std::fs::remove_file(format!("{}.cal.json", kept.display()));
    // With no file there before, the partial recording becomes OUT (nothing to lose).
    let fresh = tmp("fresh_failure.csv");
    let _ = std::fs::remove_file(&fresh);
    let e = capture(
        &mut failing(),
        &opts(fresh.clone(), CaptureMode::Duration(5.0)),
        &mut CollectUi::default(),
    )
    .unwrap_err();
    assert!(format!("{e:#}").contains("they are in"), "{e:#}");
    assert!(fresh.exists());
}
