//! The path a calibration takes through the project, across crates: a factory calibration
//! decoded from real Nunchuk bytes becomes a core `Calibration`, travels host → adapter in a
//! wire frame, comes back bit-identical, and corrects a real Nunchuk report the same way the
//! factory formula does.

use wiical_core::{Calibration, Mat3, Vec3};
use wiical_extbus::nunchuk::{CalibrationBlock, NunchukReport};
use wiical_wire::{encode_frame, DefaultFrameDecoder, Request, WireCalibration, MAX_FRAME_LEN};

/// The real Nunchuk block (windmeadow dump, see ../shared/data/wii_calibration_bytes) and the
/// report read from the same device. These few bytes are written as literals here as the
/// decoders' fixtures; the data folder's tests read the files themselves.
const BLOCK: [u8; 16] = [
    0x7C, 0x7D, 0x7B, 0x09, 0xAF, 0xAE, 0xAD, 0x13, 0xDF, 0x18, 0x81, 0xE3, 0x20, 0x81, 0xEB, 0x40,
];
const REPORT: [u8; 6] = [0x81, 0x81, 0xAD, 0x7F, 0x7B, 0xBF];

fn factory_calibration() -> (CalibrationBlock, Calibration) {
    let block = CalibrationBlock::decode(&BLOCK).unwrap();
    assert!(block.checksum_ok);
    let b = block.value;
    let span = b.counts_per_g();
    // Factory model: m = diag(one_g − zero)·a + zero.
    let d = Mat3::from_diagonal(&Vec3::new(span[0] as f32, span[1] as f32, span[2] as f32));
    let bias = Vec3::new(b.zero[0] as f32, b.zero[1] as f32, b.zero[2] as f32);
    (b, Calibration::from_forward(&d, &bias).unwrap())
}

#[test]
fn factory_calibration_corrects_like_the_factory_formula() {
    let (block, cal) = factory_calibration();
    let report = NunchukReport::decode(&REPORT).unwrap();
    let raw = report.accel.map(f32::from);
    let ours = cal.correct_linear(raw);
    let factory = block.accel_to_g(report.accel).unwrap();
    for a in 0..3 {
        assert!(
            (ours[a] - factory[a]).abs() < 1e-5,
            "{ours:?} vs {factory:?}"
        );
    }
    // The device lay with +X up (SOURCE.md): about 1 g on x, ≈ 0 on y and z.
    let norm = (ours[0] * ours[0] + ours[1] * ours[1] + ours[2] * ours[2]).sqrt();
    assert!((norm - 1.0).abs() < 0.1 && ours[0] > 0.9, "{ours:?}");
}

#[test]
fn calibration_survives_the_wire_bit_identical() {
    let (_, mut cal) = factory_calibration();
    cal.effects.quadratic = [1e-3, -2e-3, 5e-4];
    cal.effects.temp_ref_c = 25.0;
    let req = Request::PutCalibration(WireCalibration::from(cal));
    let mut buf = [0u8; MAX_FRAME_LEN];
    let frame = encode_frame(&req, &mut buf).unwrap().to_vec();
    // Deliver in awkward chunks, with line noise before the frame.
    let mut stream = vec![0x13, 0x37, 0x00];
    stream.extend_from_slice(&frame);
    let mut dec = DefaultFrameDecoder::new();
    let mut got = Vec::new();
    for chunk in stream.chunks(3) {
        // Errors here are the line noise being rejected; keep the decoded messages.
        got.extend(dec.feed::<Request>(chunk).flatten());
    }
    assert_eq!(got.len(), 1);
    let Request::PutCalibration(w) = &got[0] else {
        panic!("wrong message {:?}", got[0]);
    };
    let back = Calibration::from(*w);
    assert_eq!(back.bias.map(f32::to_bits), cal.bias.map(f32::to_bits));
    assert_eq!(
        back.matrix.map(|r| r.map(f32::to_bits)),
        cal.matrix.map(|r| r.map(f32::to_bits))
    );
    assert_eq!(back.effects, cal.effects);
    // And through the host's JSON file format too.
    let json = serde_json::to_string(&cal).unwrap();
    let from_json: Calibration = serde_json::from_str(&json).unwrap();
    assert_eq!(from_json, cal);
}
