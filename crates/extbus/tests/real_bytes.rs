//! Tests against the real calibration blocks and the real Nunchuk report in
//! `<WIICAL_DATA>/wii_calibration_bytes` (see its SOURCE.md).

use std::path::PathBuf;

use wiical_extbus::nunchuk::{self, INIT_ENCRYPTED, INIT_UNENCRYPTED};
use wiical_extbus::wiimote::{Buttons, CoreReport, ReportId};
use wiical_extbus::{
    AccelCalibration, CalibrationBlock, CalibrationCopy, Encryption, Error, NunchukRegisters,
    NunchukReport,
};

fn data_dir() -> PathBuf {
    let dir = std::env::var_os("WIICAL_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    let d = dir.join("wii_calibration_bytes");
    assert!(
        d.is_dir(),
        "data directory {} missing: set WIICAL_DATA to the shared data dir",
        d.display()
    );
    d
}

fn hex_bytes(s: &str) -> Vec<u8> {
    s.split_whitespace()
        .map(|h| u8::from_str_radix(h, 16).expect("hex byte"))
        .collect()
}

/// (device, address, bytes, checksum_ok-as-recorded) rows of calibration_blocks.csv.
fn blocks() -> Vec<(String, String, Vec<u8>, bool)> {
    let text = std::fs::read_to_string(data_dir().join("calibration_blocks.csv")).unwrap();
    let rows: Vec<_> = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("device,") && !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (
                f[0].to_string(),
                f[2].to_string(),
                hex_bytes(f[3]),
                f[4] == "yes",
            )
        })
        .collect();
    assert_eq!(rows.len(), 3, "expected 3 calibration rows");
    rows
}

fn block(device: &str, addr: &str) -> Vec<u8> {
    blocks()
        .into_iter()
        .find(|r| r.0 == device && r.1 == addr)
        .map(|r| r.2)
        .unwrap_or_else(|| panic!("no {device} block at {addr}"))
}

#[test]
fn every_recorded_block_checksum_agrees_with_the_csv() {
    for (device, addr, bytes, ok) in blocks() {
        let got = match device.as_str() {
            "wiimote" => AccelCalibration::decode(&bytes).unwrap().checksum_ok,
            "nunchuk" => CalibrationBlock::decode(&bytes).unwrap().checksum_ok,
            d => panic!("unknown device {d}"),
        };
        assert_eq!(got, ok, "{device} @ {addr}");
    }
}

#[test]
fn wiibrew_wiimote_block_decodes_to_documented_values() {
    let b = block("wiimote", "0x0020");
    let c = AccelCalibration::decode(&b).unwrap();
    assert!(c.checksum_ok);
    assert_eq!(c.value.zero, [521, 521, 521]);
    assert_eq!(c.value.one_g, [627, 626, 632]);
    assert_eq!(c.value.counts_per_g(), [106, 105, 111]);
    assert_eq!(c.value.byte8, 0x40);
    // Re-encoding reproduces the stored block byte for byte (checksum included).
    assert_eq!(c.value.encode().unwrap().to_vec(), b);
}

#[test]
fn wiimote_fallback_to_backup_copy() {
    let good = block("wiimote", "0x0020");
    let mut bad = good.clone();
    bad[0] ^= 0x01; // one flipped bit in the first copy
                    // EEPROM dump: first copy at 0x16, backup at 0x20.
    let mut eeprom = vec![0xAAu8; 0x30];
    eeprom[0x16..0x20].copy_from_slice(&bad);
    eeprom[0x20..0x2A].copy_from_slice(&good);
    let r = AccelCalibration::from_eeprom(&eeprom).unwrap();
    assert_eq!(r.copy, CalibrationCopy::Second);
    assert_eq!(r.value.zero, [521, 521, 521]);
    // Good first copy wins.
    eeprom[0x16..0x20].copy_from_slice(&good);
    assert_eq!(
        AccelCalibration::from_eeprom(&eeprom).unwrap().copy,
        CalibrationCopy::First
    );
    // Both bad.
    assert_eq!(
        AccelCalibration::from_copies(&bad, &bad),
        Err(Error::BadChecksum)
    );
    assert!(matches!(
        AccelCalibration::from_eeprom(&eeprom[..0x29]),
        Err(Error::WrongLength { .. })
    ));
}

#[test]
fn windmeadow_nunchuk_block_decodes_to_documented_values() {
    let b = block("nunchuk", "0x20");
    let c = CalibrationBlock::decode(&b).unwrap();
    assert!(c.checksum_ok);
    let v = c.value;
    // The certain 8-bit values (SOURCE.md).
    assert_eq!(v.zero_8bit(), [124, 125, 123]);
    assert_eq!(v.one_g_8bit(), [175, 174, 173]);
    assert_eq!(
        (v.stick_x.max, v.stick_x.min, v.stick_x.centre),
        (223, 24, 129)
    );
    assert_eq!(
        (v.stick_y.max, v.stick_y.min, v.stick_y.centre),
        (227, 32, 129)
    );
    // 10-bit values under the documented --XXYYZZ assumption.
    assert_eq!(v.zero, [496, 502, 493]);
    assert_eq!(v.one_g, [701, 696, 695]);
    assert_eq!(v.encode().unwrap().to_vec(), b);
    // Checksum bytes are EB 40 as recorded.
    assert_eq!(&b[14..], &[0xEB, 0x40]);
}

#[test]
fn nunchuk_register_region_fallback() {
    let first = block("nunchuk", "0x20");
    let second = block("nunchuk", "0x30");
    let mut region = [first.clone(), second.clone()].concat();
    assert_eq!(
        CalibrationBlock::from_registers(&region).unwrap().copy,
        CalibrationCopy::First
    );
    region[15] ^= 0xFF; // corrupt the second checksum byte of the first copy
    let r = CalibrationBlock::from_registers(&region).unwrap();
    assert_eq!(r.copy, CalibrationCopy::Second);
    assert_eq!(r.value.zero_8bit(), [124, 125, 123]);
    region[16 + 3] ^= 0x04; // and a data byte of the second
    assert_eq!(
        CalibrationBlock::from_registers(&region),
        Err(Error::BadChecksum)
    );
}

fn sample_report_bytes() -> Vec<u8> {
    let text = std::fs::read_to_string(data_dir().join("nunchuk_sample_report.csv")).unwrap();
    let line = text
        .lines()
        .find(|l| !l.starts_with('#') && !l.starts_with("joy_x"))
        .expect("sample row");
    line.split(',')
        .map(|h| u8::from_str_radix(h.trim(), 16).unwrap())
        .collect()
}

#[test]
fn real_nunchuk_report_decodes_and_reads_about_plus_one_g_on_x() {
    let b = sample_report_bytes();
    assert_eq!(b, [0x81, 0x81, 0xAD, 0x7F, 0x7B, 0xBF]);
    let r = NunchukReport::decode(&b).unwrap();
    assert_eq!(r.stick, [129, 129]);
    assert_eq!(r.accel_8bit(), [173, 127, 123]);
    // 0xBF = 10 11 11 1 1: Z lsb 2, Y lsb 3, X lsb 3, both buttons released.
    assert_eq!(r.accel, [173 * 4 + 3, 127 * 4 + 3, 123 * 4 + 2]);
    assert!(!r.c && !r.z);
    assert_eq!(r.to_bytes().to_vec(), b);

    // Physical check with the same Nunchuk's factory calibration: lying with +X up, so
    // about +1 g on X and about 0 g on Y and Z; total magnitude about 1 g.
    let cal = CalibrationBlock::decode(&block("nunchuk", "0x20"))
        .unwrap()
        .value;
    let g = cal.accel_to_g(r.accel).unwrap();
    assert!((g[0] - 1.0).abs() < 0.06, "{g:?}");
    assert!(g[1].abs() < 0.1 && g[2].abs() < 0.1, "{g:?}");
    let norm = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
    assert!((norm - 1.0).abs() < 0.06, "{norm}");
    // Same conclusion from the 8-bit values alone (independent of the LSB assumption).
    let (z8, o8) = (cal.zero_8bit(), cal.one_g_8bit());
    let gx8 = (173.0 - f32::from(z8[0])) / (f32::from(o8[0]) - f32::from(z8[0]));
    assert!((gx8 - 1.0).abs() < 0.06, "{gx8}");
}

#[test]
fn register_state_machine_emulates_the_real_nunchuk_unencrypted() {
    let report = NunchukReport::decode(&sample_report_bytes()).unwrap();
    let cal_bytes: [u8; 16] = block("nunchuk", "0x20").try_into().unwrap();
    let mut regs = NunchukRegisters::new();
    regs.set_report(&report);
    regs.set_calibration_bytes(&cal_bytes);
    assert!(!regs.initialised());
    for w in INIT_UNENCRYPTED {
        regs.write(&w.to_bytes());
    }
    assert!(regs.initialised());
    assert_eq!(regs.encryption(), Encryption::None);

    // ID: pointer write then 6-byte read.
    regs.write(&[nunchuk::ID_REGISTER]);
    let mut id = [0u8; 6];
    regs.read(&mut id);
    assert_eq!(id, [0x00, 0x00, 0xA4, 0x20, 0x00, 0x00]);
    assert_eq!(regs.pointer(), 0x00, "pointer wraps after 0xFF");

    // Data: reading on from the wrapped pointer gives the report.
    let mut data = [0u8; 6];
    regs.read(&mut data);
    assert_eq!(data.to_vec(), sample_report_bytes());

    // Calibration: both copies in one 32-byte sequential read.
    regs.write(&[0x20]);
    let mut region = [0u8; 32];
    regs.read(&mut region);
    let cal = CalibrationBlock::from_registers(&region).unwrap();
    assert_eq!(cal.copy, CalibrationCopy::First);
    assert_eq!(cal.value.zero_8bit(), [124, 125, 123]);

    // Writes into read-only areas are ignored, other registers store data.
    regs.write(&[0x00, 1, 2, 3, 4, 5, 6]);
    regs.write(&[0x22, 0xFF]);
    regs.write(&[0xF8, 0x11, 0x22, 0x33]); // 0xF8, 0xF9 writable; 0xFA is ID
    regs.write(&[0x00]);
    regs.read(&mut data);
    assert_eq!(data.to_vec(), sample_report_bytes());
    assert_eq!(regs.register(0x22), 0x7B);
    assert_eq!((regs.register(0xF8), regs.register(0xF9)), (0x11, 0x22));
    assert_eq!(regs.register(0xFA), 0x00);
}

#[test]
fn register_state_machine_legacy_encryption() {
    let report = NunchukReport::decode(&sample_report_bytes()).unwrap();
    let mut regs = NunchukRegisters::new();
    regs.set_report(&report);
    regs.set_calibration(
        &CalibrationBlock::decode(&block("nunchuk", "0x20"))
            .unwrap()
            .value,
    )
    .unwrap();
    for w in INIT_ENCRYPTED {
        regs.write(&w.to_bytes());
    }
    assert_eq!(regs.encryption(), Encryption::Legacy);
    assert!(regs.initialised());
    regs.write(&[0x00]);
    let mut wire = [0u8; 6];
    regs.read(&mut wire);
    assert_ne!(wire.to_vec(), sample_report_bytes());
    // The Wii Remote side recovers each byte as (x ^ 0x17) + 0x17.
    let plain: Vec<u8> = wire.iter().map(|x| (x ^ 0x17).wrapping_add(0x17)).collect();
    assert_eq!(plain, sample_report_bytes());
    assert_eq!(
        NunchukReport::decode_with(&wire, Encryption::Legacy).unwrap(),
        report
    );
    // The unencrypted init switches back to plain reads.
    for w in INIT_UNENCRYPTED {
        regs.write(&w.to_bytes());
    }
    regs.write(&[0x00]);
    regs.read(&mut wire);
    assert_eq!(wire.to_vec(), sample_report_bytes());
}

#[test]
fn core_report_0x31_from_a_real_capture() {
    // "(a1) 31 40 20 86 8a a5": a 0x31 report quoted in the Wiimote-Hacking slides
    // (druid.caughq.org), HID header a1 stripped.
    let bytes = [0x31, 0x40, 0x20, 0x86, 0x8A, 0xA5];
    let r = CoreReport::decode(&bytes).unwrap();
    assert_eq!(r.id, ReportId::ButtonsAccel);
    assert_eq!(r.buttons, Buttons::empty());
    // X = 0x86<<2 | 0b10 (byte0 bits 6:5 = 10); Y = 0x8A<<2 | 1<<1 (byte1 bit5);
    // Z = 0xA5<<2 (byte1 bit6 clear).
    assert_eq!(r.accel, Some([538, 554, 660]));
    let mut out = [0u8; 6];
    assert_eq!(r.encode(&mut out), Ok(6));
    assert_eq!(out, bytes);
}

#[test]
fn core_report_0x35_carries_a_nunchuk() {
    let nun = sample_report_bytes();
    let mut bytes = vec![0x35, 0x08, 0x08, 0x80, 0x80, 0x99];
    bytes.extend_from_slice(&nun);
    bytes.extend_from_slice(&[0u8; 10]);
    let r = CoreReport::decode(&bytes).unwrap();
    assert_eq!(r.buttons, Buttons::UP | Buttons::A);
    assert_eq!(r.accel, Some([512, 512, 612]));
    assert_eq!(r.ext.len(), 16);
    assert_eq!(r.nunchuk().unwrap().accel_8bit(), [173, 127, 123]);
    assert!(matches!(
        CoreReport::decode(&bytes[..21]),
        Err(Error::WrongLength {
            expected: 22,
            got: 21
        })
    ));
    assert_eq!(
        CoreReport::decode(&[]),
        Err(Error::WrongLength {
            expected: 1,
            got: 0
        })
    );
    // Layout mismatch on encode.
    let bad = CoreReport { accel: None, ..r };
    assert_eq!(bad.encode(&mut [0u8; 32]), Err(Error::LayoutMismatch));
    assert!(matches!(
        r.encode(&mut [0u8; 10]),
        Err(Error::BufferTooSmall {
            needed: 22,
            got: 10
        })
    ));
}
