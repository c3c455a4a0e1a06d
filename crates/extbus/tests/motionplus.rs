//! MotionPlus byte formats against byte sequences derived by hand from the documentation
//! (WiiBrew's tables, Dolphin's and hid-wiimote's published bit descriptions), an independent
//! bitwise CRC-32, and property tests (no panic on any bytes, exact round trips).

use proptest::prelude::*;
use wiical_extbus::motionplus::{
    calibration_crc, Frame, MotionPlusCalibration, MotionPlusReport, PassthroughMode,
    PassthroughNunchuk, RangeCalibration, ID_INACTIVE, INACTIVE_I2C_ADDRESS,
};
use wiical_extbus::{Error, NunchukReport};

/// Bitwise CRC-32 (reflected polynomial 0xEDB88320, init and final XOR 0xFFFFFFFF), written
/// from the textbook definition.
fn crc32_bitwise(chunks: &[&[u8]]) -> u32 {
    let mut crc = 0xFFFF_FFFFu32;
    for chunk in chunks {
        for &byte in *chunk {
            crc ^= u32::from(byte);
            for _ in 0..8 {
                crc = if crc & 1 != 0 {
                    (crc >> 1) ^ 0xEDB8_8320
                } else {
                    crc >> 1
                };
            }
        }
    }
    !crc
}

#[test]
fn bitwise_crc_reference_has_the_standard_check_value() {
    assert_eq!(crc32_bitwise(&[b"123456789"]), 0xCBF4_3926);
}

/// The calibration Dolphin's emulated MotionPlus carries (documented constants: zero 0x8000,
/// scale offset 0x4400 with yaw and pitch negative, 1200 °/s fast and 270 °/s slow reference
/// rates, UIDs 0x0B and 0xE9), laid out byte by byte from the WiiBrew/Dolphin table.
fn documented_block() -> [u8; 32] {
    let mut b = [0u8; 32];
    let (zero, neg, pos) = (0x8000u16, 0x8000u16 - 0x4400, 0x8000u16 + 0x4400);
    for (offset, deg6, uid) in [(0usize, 1200u16 / 6, 0x0Bu8), (16, 270 / 6, 0xE9)] {
        let words = [zero, zero, zero, neg, pos, neg];
        for (i, w) in words.iter().enumerate() {
            b[offset + 2 * i] = (w >> 8) as u8;
            b[offset + 2 * i + 1] = *w as u8;
        }
        b[offset + 12] = deg6 as u8;
        b[offset + 13] = uid;
    }
    let crc = crc32_bitwise(&[&b[0..14], &b[16..30]]);
    b[14] = (crc >> 24) as u8;
    b[15] = (crc >> 16) as u8;
    b[30] = (crc >> 8) as u8;
    b[31] = crc as u8;
    b
}

#[test]
fn calibration_block_decodes_and_checks_its_crc() {
    let bytes = documented_block();
    assert_eq!(
        calibration_crc(&bytes),
        crc32_bitwise(&[&bytes[0..14], &bytes[16..30]])
    );
    let c = MotionPlusCalibration::decode(&bytes).unwrap();
    assert!(c.checksum_ok);
    assert_eq!(c.value.fast.zero, [0x8000; 3]);
    assert_eq!(c.value.fast.scale, [0x3C00, 0xC400, 0x3C00]);
    assert_eq!(c.value.fast.degrees_div_6, 200);
    assert_eq!(c.value.slow.degrees_div_6, 45);
    assert_eq!(c.value.uid, [0x0B, 0xE9]);
    // 0x4400/4 = 4352 counts (14-bit) at 1200 °/s and at 270 °/s.
    let fast = c.value.fast.counts_per_dps().unwrap();
    let slow = c.value.slow.counts_per_dps().unwrap();
    assert!((fast[1] - 4352.0 / 1200.0).abs() < 1e-5 && (fast[0] + 4352.0 / 1200.0).abs() < 1e-5);
    assert!((slow[1] - 4352.0 / 270.0).abs() < 1e-4 && (slow[2] + 4352.0 / 270.0).abs() < 1e-4);
    assert_eq!(c.value.slow.zero_14bit(), [8192.0; 3]);
    // The encoder reproduces the documented bytes, CRC included.
    assert_eq!(c.value.to_bytes(), bytes);

    // Any single flipped data or CRC bit is caught.
    for i in 0..32 {
        let mut bad = bytes;
        bad[i] ^= 0x10;
        assert!(
            !MotionPlusCalibration::decode(&bad).unwrap().checksum_ok,
            "byte {i}"
        );
    }
    assert_eq!(
        MotionPlusCalibration::decode(&bytes[..31]).unwrap_err(),
        Error::WrongLength {
            expected: 32,
            got: 31
        }
    );
}

#[test]
fn rate_uses_the_range_each_slow_bit_selects() {
    let cal = MotionPlusCalibration::decode(&documented_block())
        .unwrap()
        .value;
    // Roll slow at +100 °/s: 8192 + 100·4352/270 counts; yaw fast at −500 °/s (stored sign
    // negative, so the raw value rises); pitch at rest.
    let roll: f64 = 8192.0 + 100.0 * 4352.0 / 270.0;
    let yaw: f64 = 8192.0 + 500.0 * 4352.0 / 1200.0;
    let report = MotionPlusReport {
        rate: [yaw.round() as u16, roll.round() as u16, 8192],
        slow: [false, true, true],
        extension_connected: false,
    };
    let dps = cal.rate_dps(&report).unwrap();
    assert!((dps[0] + 500.0).abs() < 0.2, "{dps:?}");
    assert!((dps[1] - 100.0).abs() < 0.05, "{dps:?}");
    assert_eq!(dps[2], 0.0);
    let mut zero_range = cal;
    zero_range.slow.degrees_div_6 = 0;
    assert!(zero_range.rate_dps(&report).is_none());
    assert!(RangeCalibration::default().counts_per_dps().is_none());
}

#[test]
fn activation_writes_and_ids() {
    let w = PassthroughMode::Nunchuk.activation();
    assert_eq!(INACTIVE_I2C_ADDRESS, 0x53);
    assert_eq!(
        [w[0].to_bytes(), w[1].to_bytes()],
        [[0xF0, 0x55], [0xFE, 0x05]]
    );
    assert_eq!(
        PassthroughMode::None.activation()[1].to_bytes(),
        [0xFE, 0x04]
    );
    assert_eq!(
        PassthroughMode::Classic.activation()[1].to_bytes(),
        [0xFE, 0x07]
    );
    assert_eq!(ID_INACTIVE, [0x00, 0x00, 0xA6, 0x20, 0x00, 0x05]);
    assert_eq!(
        PassthroughMode::None.active_id(),
        [0x00, 0x00, 0xA4, 0x20, 0x04, 0x05]
    );
    assert_eq!(
        PassthroughMode::from_byte(0x05),
        Some(PassthroughMode::Nunchuk)
    );
    assert_eq!(PassthroughMode::from_byte(0x06), None);
}

/// The pass-through transformation as the documentation words it, applied to a normal Nunchuk
/// report's bytes: the three accelerometer LSBs are dropped, byte 5 bit 7 → bit 6, byte 4
/// bit 0 → byte 5 bit 7, byte 5 bit 3 → bit 4, bit 1 → bit 3, bit 0 → bit 2; then byte 4
/// bit 0 = extension connected, byte 5 bits 1–0 = 0 (extension data).
fn documented_nunchuk_passthrough(plain: [u8; 6], ext: bool) -> [u8; 6] {
    let bit = |b: u8, n: u8| (b >> n) & 1;
    let mut out = plain;
    let b4 = plain[4];
    let b5 = plain[5];
    let mut n5 = b5;
    let set = |v: &mut u8, n: u8, x: u8| *v = (*v & !(1 << n)) | (x << n);
    set(&mut n5, 6, bit(b5, 7));
    set(&mut n5, 7, bit(b4, 0));
    set(&mut n5, 4, bit(b5, 3));
    set(&mut n5, 3, bit(b5, 1));
    set(&mut n5, 2, bit(b5, 0));
    set(&mut n5, 1, 0);
    set(&mut n5, 0, 0);
    set(&mut out[4], 0, u8::from(ext));
    out[5] = n5;
    out
}

#[test]
fn nunchuk_passthrough_matches_the_documented_bit_moves() {
    let reports = [
        NunchukReport {
            stick: [0x80, 0x7F],
            accel: [0x3FF, 0x000, 0x2AB],
            c: true,
            z: false,
        },
        NunchukReport {
            stick: [0x00, 0xFF],
            accel: [0x155, 0x2AA, 0x3FE],
            c: false,
            z: true,
        },
        NunchukReport {
            stick: [0x12, 0x34],
            accel: [513, 700, 301],
            c: true,
            z: true,
        },
    ];
    for r in reports {
        for ext in [false, true] {
            let wire = documented_nunchuk_passthrough(r.to_bytes(), ext);
            let Frame::Nunchuk(p) = Frame::decode(&wire, PassthroughMode::Nunchuk).unwrap() else {
                panic!("byte 5 bit 1 clear must decode as extension data");
            };
            let mut expected = r;
            expected.accel = r.accel.map(|a| a & !1);
            assert_eq!(
                p,
                PassthroughNunchuk {
                    report: expected,
                    extension_connected: ext
                }
            );
            assert_eq!(p.to_bytes(), wire);
        }
    }
}

#[test]
fn interleaved_stream_alternates_gyro_and_nunchuk() {
    let gyro = MotionPlusReport {
        rate: [8190, 8200, 8185],
        slow: [true; 3],
        extension_connected: true,
    };
    let nun = NunchukReport {
        stick: [128, 129],
        accel: [512, 514, 716],
        c: false,
        z: false,
    };
    let stream: Vec<[u8; 6]> = (0..6)
        .map(|i| {
            if i % 2 == 0 {
                gyro.to_bytes().unwrap()
            } else {
                documented_nunchuk_passthrough(nun.to_bytes(), true)
            }
        })
        .collect();
    for (i, frame) in stream.iter().enumerate() {
        match Frame::decode(frame, PassthroughMode::Nunchuk).unwrap() {
            Frame::MotionPlus(g) => assert!(i % 2 == 0 && g == gyro),
            Frame::Nunchuk(n) => assert!(i % 2 == 1 && n.report == nun && n.extension_connected),
            Frame::Classic(_) => panic!("no classic data in Nunchuk mode"),
        }
    }
    // Extension data in a mode without pass-through is a layout error.
    assert_eq!(
        Frame::decode(&stream[1], PassthroughMode::None).unwrap_err(),
        Error::LayoutMismatch
    );
    assert_eq!(
        MotionPlusReport::decode(&stream[1]).unwrap_err(),
        Error::LayoutMismatch
    );
}

#[test]
fn classic_passthrough_restores_the_moved_bits() {
    // Original Classic bytes; the MotionPlus moves byte 5 bits 0–1 into bit 0 of bytes 0–1
    // (dropping those LSBs), puts its extension flag into byte 4 bit 0 and clears byte 5
    // bits 0–1.
    let original = [0b1010_1011u8, 0b0101_0100, 0x80, 0x81, 0xFF, 0b1111_1101];
    let mut wire = original;
    wire[0] = (original[0] & !1) | (original[5] & 1);
    wire[1] = (original[1] & !1) | ((original[5] >> 1) & 1);
    wire[4] &= !1;
    wire[5] &= !0b11;
    let Frame::Classic(c) = Frame::decode(&wire, PassthroughMode::Classic).unwrap() else {
        panic!("classic expected");
    };
    assert_eq!(c[5], original[5]);
    assert_eq!(c[4], original[4] | 1);
    assert_eq!(c[2..4], original[2..4]);
    // The stick LSBs are lost: bit 0 now repeats bit 1.
    assert_eq!(c[0] >> 1, original[0] >> 1);
    assert_eq!(c[0] & 1, (original[0] >> 1) & 1);
}

proptest! {
    #[test]
    fn any_bytes_decode_without_panic(bytes in proptest::collection::vec(any::<u8>(), 0..40)) {
        for mode in [PassthroughMode::None, PassthroughMode::Nunchuk, PassthroughMode::Classic] {
            let _ = Frame::decode(&bytes, mode);
        }
        let _ = MotionPlusReport::decode(&bytes);
        if let Ok(c) = MotionPlusCalibration::decode(&bytes) {
            let _ = c.value.rate_dps(&MotionPlusReport::default());
        }
    }

    #[test]
    fn report_round_trips(rate in proptest::array::uniform3(0u16..=0x3FFF), slow in proptest::array::uniform3(any::<bool>()), ext in any::<bool>()) {
        let r = MotionPlusReport { rate, slow, extension_connected: ext };
        let b = r.to_bytes().unwrap();
        prop_assert_eq!(MotionPlusReport::decode(&b).unwrap(), r);
        prop_assert_eq!(Frame::decode(&b, PassthroughMode::Nunchuk).unwrap(), Frame::MotionPlus(r));
    }

    #[test]
    fn calibration_round_trips(words in proptest::array::uniform12(any::<u16>()), d in proptest::array::uniform2(any::<u8>()), uid in proptest::array::uniform2(any::<u8>())) {
        let range = |w: &[u16], deg| RangeCalibration { zero: [w[0], w[1], w[2]], scale: [w[3], w[4], w[5]], degrees_div_6: deg };
        let c = MotionPlusCalibration { fast: range(&words[..6], d[0]), slow: range(&words[6..], d[1]), uid };
        let back = MotionPlusCalibration::from_bytes(&c.to_bytes());
        prop_assert!(back.checksum_ok);
        prop_assert_eq!(back.value, c);
    }
}
