//! `wiical capture` with a MotionPlus, against the scripted fake remote: detection at
//! `0xA600FA`, the calibration block at `0xA60020`, activation (`0x55` → `0xA600F0`, mode →
//! `0xA600FE`), and the interleaved gyro / pass-through Nunchuk stream. Every MotionPlus byte is
//! built by hand here from the documented layouts (WiiBrew, Dolphin, hid-wiimote; see
//! docs/gyro.md), not with the decoder under test.

mod support;

use std::path::PathBuf;
use support::{mp_block, real_blocks};
use wiical_capture::replay::{report_0x35_ext, EndOfScript, ReplayWiimote};
use wiical_capture::{capture, CaptureMode, CaptureOptions, CollectUi};
use wiical_extbus::NunchukReport;

/// A MotionPlus gyro frame from the table: bytes 0–2 low 8 bits of yaw, roll, pitch; bytes
/// 3–5 bits 13–8 in bits 7–2; byte 3 bit 1 yaw slow, bit 0 pitch slow; byte 4 bit 1 roll slow,
/// bit 0 extension connected; byte 5 bit 1 = 1.
fn gyro_frame(yaw: u16, roll: u16, pitch: u16, slow: [bool; 3], ext: bool) -> [u8; 6] {
    let b = |x: bool| u8::from(x);
    [
        (yaw & 0xFF) as u8,
        (roll & 0xFF) as u8,
        (pitch & 0xFF) as u8,
        (((yaw >> 8) as u8) << 2) | (b(slow[0]) << 1) | b(slow[2]),
        (((roll >> 8) as u8) << 2) | (b(slow[1]) << 1) | b(ext),
        (((pitch >> 8) as u8) << 2) | 0b10,
    ]
}

/// A Nunchuk report passed through: accel LSBs dropped, Z[9:3] in byte 4 bits 7–1 with the
/// extension flag in bit 0, byte 5 = Z2 Z1 Y1 X1 C Z 0 0 (buttons active-low).
fn nunchuk_frame(n: &NunchukReport) -> [u8; 6] {
    let [x, y, z] = n.accel;
    let bit = |v: u16, k: u16| ((v >> k) & 1) as u8;
    [
        n.stick[0],
        n.stick[1],
        (x >> 2) as u8,
        (y >> 2) as u8,
        (((z >> 3) as u8) << 1) | 1,
        (bit(z, 2) << 7)
            | (bit(z, 1) << 6)
            | (bit(y, 1) << 5)
            | (bit(x, 1) << 4)
            | (u8::from(!n.c) << 3)
            | (u8::from(!n.z) << 2),
    ]
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("wiical-capture-mp-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn data_rows(csv: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let mut lines = csv.lines().filter(|l| !l.starts_with('#'));
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (header, rows)
}

fn write_position(written: &[Vec<u8>], address: [u8; 3], value: u8) -> Option<usize> {
    written
        .iter()
        .position(|r| r.starts_with(&[0x16, 0x04, address[0], address[1], address[2], 0x01, value]))
}

#[test]
#[allow(clippy::too_many_lines, reason = "a test reads top to bottom")]
fn motionplus_with_nunchuk_passthrough_records_both_streams() {
    let (w, n) = real_blocks();
    let mut dev = ReplayWiimote::new()
        .with_eeprom(0x16, &w)
        .with_eeprom(0x20, &w)
        .with_nunchuk(&n)
        .with_motionplus(&mp_block())
        .with_end(EndOfScript::Silence);
    let nun = NunchukReport {
        stick: [131, 125],
        accel: [514, 498, 717],
        c: true,
        z: false,
    };
    let mut t = 0.0;
    for k in 0..100u16 {
        let ext = if k.is_multiple_of(2) {
            gyro_frame(
                8000 + k,
                8200 - k,
                0x3FFF - k,
                [true, k.is_multiple_of(4), false],
                true,
            )
        } else {
            nunchuk_frame(&nun)
        };
        dev.push_report(t, report_0x35_ext([512, 520, 616], ext));
        t += 0.01;
    }
    let out = tmp("mp_nunchuk.csv");
    let mut ui = CollectUi::default();
    let opts = CaptureOptions {
        out: out.clone(),
        mode: CaptureMode::Duration(0.9),
        ..Default::default()
    };
    let summary = capture(&mut dev, &opts, &mut ui).unwrap();

    // Probe and calibration read at 0xA6, Nunchuk init through it, then activation in
    // Nunchuk pass-through mode, then reporting.
    let wr = &dev.written;
    let id_read = wr
        .iter()
        .position(|r| r == &vec![0x17, 0x04, 0xA6, 0x00, 0xFA, 0x00, 0x06]);
    let cal_read = wr
        .iter()
        .position(|r| r == &vec![0x17, 0x04, 0xA6, 0x00, 0x20, 0x00, 0x20]);
    let nunchuk_init = write_position(wr, [0xA4, 0x00, 0xF0], 0x55);
    let mp_init = write_position(wr, [0xA6, 0x00, 0xF0], 0x55);
    let mp_mode = write_position(wr, [0xA6, 0x00, 0xFE], 0x05);
    assert!(id_read.is_some() && cal_read > id_read, "{wr:02X?}");
    assert!(nunchuk_init.is_some() && mp_init > nunchuk_init && mp_mode > mp_init);
    assert_eq!(wr.last().unwrap(), &vec![0x12, 0x04, 0x35]);

    // The side file carries the decoded block: (scale − zero)/4/degrees.
    let mp = summary.calibration.motionplus.as_ref().unwrap();
    assert!(mp.checksum_ok);
    assert_eq!(mp.mode, Some(0x05));
    assert_eq!(mp.fast.degrees, 1200);
    assert_eq!(mp.slow.degrees, 270);
    let cpd = mp.slow.counts_per_dps.unwrap();
    let expect_roll = (f64::from(0xC400u16) - f64::from(0x8010u16)) / 4.0 / 270.0;
    assert!((f64::from(cpd[1]) - expect_roll).abs() < 1e-4);
    assert!(
        cpd[0] < 0.0 && cpd[2] < 0.0,
        "yaw and pitch stored negative: {cpd:?}"
    );
    let side: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&summary.cal_file).unwrap()).unwrap();
    assert_eq!(side["motionplus"]["checksum_ok"], true);

    // The CSV: gyro rows and Nunchuk rows alternate; pitch, roll, yaw → gx, gy, gz.
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("# motionplus_cal: "));
    let (header, rows) = data_rows(&text);
    assert_eq!(
        header.join(","),
        "t,x,y,z,ext_x,ext_y,ext_z,gx,gy,gz,gx_slow,gy_slow,gz_slow"
    );
    assert!(rows.len() >= 90, "{} rows", rows.len());
    for (k, row) in rows.iter().enumerate() {
        assert_eq!(row.len(), 13);
        assert_eq!(&row[1..4], ["512", "520", "616"]);
        if k.is_multiple_of(2) {
            let k = k as u16;
            assert_eq!(&row[4..7], ["", "", ""]);
            let expect = [
                (0x3FFF - k).to_string(),
                (8200 - k).to_string(),
                (8000 + k).to_string(),
                "0".into(),
                u8::from(k.is_multiple_of(4)).to_string(),
                "1".into(),
            ];
            assert_eq!(row[7..13], expect, "row {k}");
        } else {
            // The pass-through Nunchuk loses bit 0 of each axis.
            assert_eq!(&row[4..7], ["514", "498", "716"]);
            assert_eq!(&row[7..13], ["", "", "", "", "", ""]);
        }
    }
}

#[test]
fn motionplus_alone_is_activated_gyro_only_and_a_bad_crc_is_reported() {
    let (w, _) = real_blocks();
    let mut block = mp_block();
    block[3] ^= 0x01;
    let mut dev = ReplayWiimote::new()
        .with_eeprom(0x16, &w)
        .with_eeprom(0x20, &w)
        .with_motionplus(&block)
        .with_end(EndOfScript::Silence);
    for k in 0..50 {
        let ext = gyro_frame(8192, 8190, 8195, [true; 3], false);
        dev.push_report(f64::from(k) * 0.01, report_0x35_ext([500, 510, 620], ext));
    }
    let out = tmp("mp_alone.csv");
    let mut ui = CollectUi::default();
    let opts = CaptureOptions {
        out: out.clone(),
        mode: CaptureMode::Duration(0.4),
        ..Default::default()
    };
    let summary = capture(&mut dev, &opts, &mut ui).unwrap();
    assert!(write_position(&dev.written, [0xA6, 0x00, 0xFE], 0x04).is_some());
    let mp = summary.calibration.motionplus.as_ref().unwrap();
    assert!(!mp.checksum_ok);
    assert!(
        ui.messages.iter().any(|m| m.contains("WRONG")),
        "{:?}",
        ui.messages
    );
    let text = std::fs::read_to_string(&out).unwrap();
    let (header, rows) = data_rows(&text);
    assert_eq!(header.join(","), "t,x,y,z,gx,gy,gz,gx_slow,gy_slow,gz_slow");
    assert!(rows
        .iter()
        .all(|r| r[4..] == ["8195", "8190", "8192", "1", "1", "1"]));
}

#[test]
fn without_a_motionplus_nothing_changes() {
    let (w, _) = real_blocks();
    let mut dev = ReplayWiimote::new()
        .with_eeprom(0x16, &w)
        .with_eeprom(0x20, &w)
        .with_end(EndOfScript::Silence);
    for k in 0..20 {
        dev.push_report(
            f64::from(k) * 0.01,
            report_0x35_ext([500, 510, 620], [0xFF; 6]),
        );
    }
    let out = tmp("no_mp.csv");
    let opts = CaptureOptions {
        out: out.clone(),
        mode: CaptureMode::Duration(0.1),
        ..Default::default()
    };
    let summary = capture(&mut dev, &opts, &mut CollectUi::default()).unwrap();
    assert!(summary.calibration.motionplus.is_none());
    assert!(write_position(&dev.written, [0xA6, 0x00, 0xFE], 0x04).is_none());
    let (header, _) = data_rows(&std::fs::read_to_string(&out).unwrap());
    assert_eq!(header.join(","), "t,x,y,z");
}
