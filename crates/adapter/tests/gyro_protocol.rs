//! The MotionPlus's gyro calibration on the adapter (issue 50 item 2): staged, judged by the
//! core's MotionPlus limits, committed beside the accelerometer's calibration in the
//! power-loss-safe store, reported, and nothing stored that was not committed. The gyro
//! record's decoder never panics on any bytes. (With the crate's `gyro-calibration` feature,
//! the default; without it the requests are refused: `gyro_unsupported.rs`.)
#![cfg(feature = "gyro-calibration")]

mod common;

use common::{block_on, CutFlash};
use proptest::prelude::*;
use wiical_adapter::store::{decode_gyro_record, encode_gyro_record, GYRO_RECORD_LEN};
use wiical_adapter::{BootLoad, CalibrationStore, DeviceInfo, IdealScale, Protocol};
use wiical_core::gyro_correct::GyroCorrection;
use wiical_core::Calibration;
use wiical_wire::{
    BootRecord, ErrorCode, GyroCalibrationState, Hello, Request, Response, WireGyroCalibration,
};

type Flash = CutFlash<4, 512, 4>;

fn boot(flash: &mut Flash) -> Protocol<&mut Flash> {
    let store = CalibrationStore::new(flash, 0..Flash::SIZE).unwrap();
    let info = DeviceInfo::new("test", [0; 8], 200_000);
    let mut p = block_on(Protocol::boot(store, info, IdealScale::default()));
    let hello = block_on(p.handle(Request::Hello(Hello::CURRENT)));
    assert!(matches!(hello, Response::Hello(_)));
    p
}

fn req(p: &mut Protocol<&mut Flash>, r: Request) -> Response {
    block_on(p.handle(r))
}

fn gyro_state(p: &mut Protocol<&mut Flash>) -> GyroCalibrationState {
    match req(p, Request::GetGyroCalibration) {
        Response::GyroCalibration(s) => s,
        other => panic!("expected the gyro state, got {other:?}"),
    }
}

/// A MotionPlus-like calibration in slow counts: `s` counts per °/s on the diagonal, small
/// misalignment, zeros near 8192 (within the core's MotionPlus limits, written out here).
fn motionplus(s: f32, zero: f32) -> WireGyroCalibration {
    let k = core::f32::consts::PI / 180.0 / s;
    WireGyroCalibration {
        bias: [zero, zero + 97.5, zero - 41.25],
        matrix: [
            [k, 0.012 * k, -0.004 * k],
            [-0.008 * k, 1.02 * k, 0.0],
            [0.003 * k, 0.0, 0.98 * k],
        ],
    }
}

fn same(a: &WireGyroCalibration, b: &WireGyroCalibration) -> bool {
    GyroCorrection::from(*a).bits() == GyroCorrection::from(*b).bits()
}

/// An accelerometer calibration (the Nunchuk's limits), to check the two records are
/// independent.
fn accel() -> Calibration {
    Calibration {
        bias: [505.0, 498.0, 519.0],
        matrix: [
            [1.0 / 203.0, 0.0, 0.0],
            [0.0, 1.0 / 196.0, 0.0],
            [0.0, 0.0, 1.0 / 207.0],
        ],
        effects: Default::default(),
    }
}

fn commit(p: &mut Protocol<&mut Flash>, g: WireGyroCalibration) {
    assert_eq!(req(p, Request::PutGyroCalibration(g)), Response::Ack);
    assert_eq!(req(p, Request::CommitGyroCalibration), Response::Ack);
}

/// Put, get (staged, bit for bit), commit, get (live), reboot: loaded bit for bit, and the
/// accelerometer's record committed before it is still there (and vice versa).
#[test]
fn a_committed_gyro_calibration_is_live_and_survives_a_reboot_beside_the_accelerometers() {
    let mut flash = Flash::new(1);
    let g = motionplus(18.2, 8100.0);
    {
        let mut p = boot(&mut flash);
        let s = gyro_state(&mut p);
        assert_eq!((s.live, s.staged, s.boot), (None, None, BootRecord::Empty));
        assert_eq!(
            req(&mut p, Request::PutCalibration(accel().into())),
            Response::Ack
        );
        assert_eq!(req(&mut p, Request::CommitCalibration), Response::Ack);
        assert_eq!(req(&mut p, Request::PutGyroCalibration(g)), Response::Ack);
        let s = gyro_state(&mut p);
        assert!(s.live.is_none() && same(&s.staged.unwrap(), &g));
        assert_eq!(req(&mut p, Request::CommitGyroCalibration), Response::Ack);
        let s = gyro_state(&mut p);
        assert!(s.staged.is_none() && same(&s.live.unwrap(), &g));
        assert_eq!(
            p.gyro_calibration().map(GyroCorrection::bits),
            Some(GyroCorrection::from(g).bits())
        );
    }
    flash.reboot();
    let mut p = boot(&mut flash);
    assert_eq!(p.gyro_boot(), BootLoad::Loaded);
    let s = gyro_state(&mut p);
    assert_eq!(s.boot, BootRecord::Loaded);
    assert!(same(&s.live.unwrap(), &g));
    let Response::Calibration(a) = req(&mut p, Request::GetCalibration) else {
        panic!("no calibration state")
    };
    assert!(a.stored && Calibration::from(a.live).bits_equal(&accel()));
    // A second gyro commit replaces the first and leaves the accelerometer's alone.
    let g2 = motionplus(19.0, 8250.0);
    commit(&mut p, g2);
    drop(p);
    let mut p = boot(&mut flash);
    assert!(same(&gyro_state(&mut p).live.unwrap(), &g2));
    let Response::Calibration(a) = req(&mut p, Request::GetCalibration) else {
        panic!("no calibration state")
    };
    assert!(Calibration::from(a.live).bits_equal(&accel()));
}

/// Nothing stored that was not committed: a put without commit is gone after a reboot, after
/// a new Hello and after the session's end; a bare commit then finds nothing staged.
#[test]
fn nothing_is_stored_that_was_not_committed() {
    let mut flash = Flash::new(2);
    let old = motionplus(18.0, 8192.0);
    {
        let mut p = boot(&mut flash);
        commit(&mut p, old);
        assert_eq!(
            req(
                &mut p,
                Request::PutGyroCalibration(motionplus(17.5, 8000.0))
            ),
            Response::Ack
        );
    }
    flash.reboot();
    let ops = flash.ops;
    let mut p = boot(&mut flash);
    let s = gyro_state(&mut p);
    assert!(s.staged.is_none() && same(&s.live.unwrap(), &old));
    for end in [Request::Hello(Hello::CURRENT), Request::EndSession] {
        assert_eq!(
            req(
                &mut p,
                Request::PutGyroCalibration(motionplus(17.5, 8000.0))
            ),
            Response::Ack
        );
        req(&mut p, end);
        req(&mut p, Request::Hello(Hello::CURRENT));
        assert_eq!(
            req(&mut p, Request::CommitGyroCalibration),
            Response::Error(ErrorCode::NothingStaged)
        );
        assert!(same(&gyro_state(&mut p).live.unwrap(), &old));
    }
    drop(p);
    // Only reads since the reboot: no word was programmed or erased.
    assert_eq!(flash.ops, ops);
}

/// Refused before it is staged: an implausible calibration (one fitted to an MPU, whose zero
/// is near 0 counts; an axis flipped: the accelerometer's frame, not the count axes) gets
/// `ImplausibleCalibration`, an unusable one (NaN, singular) `InvalidCalibration`; the staged
/// and live ones stay as they were.
#[test]
fn implausible_or_unusable_gyro_calibrations_are_refused_and_change_nothing() {
    let mut flash = Flash::new(3);
    let mut p = boot(&mut flash);
    let good = motionplus(18.6, 8192.0);
    commit(&mut p, good);
    let staged = motionplus(18.0, 8150.0);
    assert_eq!(
        req(&mut p, Request::PutGyroCalibration(staged)),
        Response::Ack
    );
    let mut mpu = good;
    mpu.bias = [-31.0, 12.5, 7.25];
    let mut flipped = good;
    flipped.matrix[1] = flipped.matrix[1].map(|x| -x);
    let mut nan = good;
    nan.matrix[2][2] = f32::NAN;
    let mut singular = good;
    singular.matrix[2] = singular.matrix[0];
    for (bad, code) in [
        (mpu, ErrorCode::ImplausibleCalibration),
        (flipped, ErrorCode::ImplausibleCalibration),
        (nan, ErrorCode::InvalidCalibration),
        (singular, ErrorCode::InvalidCalibration),
    ] {
        assert_eq!(
            req(&mut p, Request::PutGyroCalibration(bad)),
            Response::Error(code)
        );
        let s = gyro_state(&mut p);
        assert!(same(&s.live.unwrap(), &good) && same(&s.staged.unwrap(), &staged));
    }
}

/// A power cut at every word operation of a gyro commit: after the reboot the gyro record is
/// the old or the new calibration (the new one whenever the commit was acknowledged), never
/// a damaged one, and the accelerometer's calibration is untouched.
#[test]
fn a_power_cut_during_a_gyro_commit_leaves_the_old_or_the_new() {
    let old = motionplus(18.0, 8192.0);
    let new = motionplus(18.9, 8300.0);
    let setup = |flash: &mut Flash| {
        let mut p = boot(flash);
        assert_eq!(
            req(&mut p, Request::PutCalibration(accel().into())),
            Response::Ack
        );
        assert_eq!(req(&mut p, Request::CommitCalibration), Response::Ack);
        commit(&mut p, old);
    };
    let mut flash = Flash::new(4);
    setup(&mut flash);
    let base = flash.ops;
    commit(&mut boot(&mut flash), new);
    let per_commit = flash.ops - base;
    assert!(per_commit > 10, "{per_commit}");
    let mut acked_cuts = 0;
    for cut in 0..per_commit + 2 {
        let mut flash = Flash::new(100 + cut);
        setup(&mut flash);
        flash.cut_after = Some(cut);
        let acked = {
            let mut p = boot(&mut flash);
            assert_eq!(req(&mut p, Request::PutGyroCalibration(new)), Response::Ack);
            match req(&mut p, Request::CommitGyroCalibration) {
                Response::Ack => true,
                Response::Error(ErrorCode::StorageFailure) => {
                    assert!(same(&gyro_state(&mut p).live.unwrap(), &old), "cut {cut}");
                    false
                }
                other => panic!("cut {cut}: {other:?}"),
            }
        };
        acked_cuts += u32::from(acked);
        flash.reboot();
        let mut p = boot(&mut flash);
        let s = gyro_state(&mut p);
        assert_eq!(s.boot, BootRecord::Loaded, "cut {cut}");
        let live = s.live.unwrap();
        if acked {
            assert!(
                same(&live, &new),
                "cut {cut}: an acknowledged commit was lost"
            );
        } else {
            assert!(same(&live, &old) || same(&live, &new), "cut {cut}");
        }
        let Response::Calibration(a) = req(&mut p, Request::GetCalibration) else {
            panic!("no calibration state")
        };
        assert!(Calibration::from(a.live).bits_equal(&accel()), "cut {cut}");
    }
    // The cuts past the commit's last operation let it finish: the loop saw both outcomes.
    assert!(acked_cuts >= 1 && u64::from(acked_cuts) < per_commit + 2);
}

/// The record's layout, written out by hand from the store's module docs: magic, version 1,
/// payload 48, 12 little-endian floats, CRC-32/ISO-HDLC (an independent bitwise CRC here).
#[test]
fn the_gyro_record_is_laid_out_as_documented_and_every_flipped_bit_is_refused() {
    let g = GyroCorrection::from(motionplus(18.3, 8120.0));
    let rec = encode_gyro_record(&g);
    let mut want = b"WGYR".to_vec();
    want.extend(1u16.to_le_bytes());
    want.extend(48u16.to_le_bytes());
    for x in g.bias.iter().chain(g.matrix.as_flattened()) {
        want.extend(x.to_le_bytes());
    }
    let mut crc = 0xFFFF_FFFFu32;
    for &b in &want {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    want.extend((!crc).to_le_bytes());
    assert_eq!(rec.len(), GYRO_RECORD_LEN);
    assert_eq!(rec.to_vec(), want);
    assert_eq!(decode_gyro_record(&rec).map(|c| c.bits()), Ok(g.bits()));
    for bit in 0..8 * rec.len() {
        let mut r = rec;
        r[bit / 8] ^= 1 << (bit % 8);
        assert!(decode_gyro_record(&r).is_err(), "bit {bit}");
    }
}

/// Usable as the record's decoder documents it: finite and `K` invertible, judged as an
/// accelerometer calibration's linear part is (`Calibration::validate`).
fn usable(g: &GyroCorrection<f32>) -> bool {
    Calibration {
        bias: g.bias,
        matrix: g.matrix,
        effects: Calibration::identity().effects,
    }
    .validate()
    .is_ok()
}

proptest! {
    /// No panic on any bytes, and whatever decodes is usable (the decoder validates).
    #[test]
    fn the_gyro_record_decoder_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..80)) {
        if let Ok(c) = decode_gyro_record(&bytes) {
            prop_assert!(usable(&c));
        }
    }

    /// Any record with a valid header and CRC but arbitrary floats: decoded bit for bit when
    /// usable, refused otherwise; never a panic.
    #[test]
    fn a_well_framed_record_of_any_floats_decodes_exactly_or_is_refused(
        bits in prop::collection::vec(any::<u32>(), 12),
    ) {
        let f: Vec<f32> = bits.iter().map(|b| f32::from_bits(*b)).collect();
        let g = GyroCorrection::from_floats(&f);
        let rec = encode_gyro_record(&g);
        match decode_gyro_record(&rec) {
            Ok(back) => prop_assert!(usable(&g) && back.bits() == g.bits()),
            Err(_) => prop_assert!(!usable(&g)),
        }
    }
}
