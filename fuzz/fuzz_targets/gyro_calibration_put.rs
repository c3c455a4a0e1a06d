//! Gyro calibration → `device put` → adapter (issue 50 item 2), and the adapter's gyro record
//! decoder. The first byte chooses: arbitrary bytes as a stored gyro record
//! (`decode_gyro_record`: never a panic, and whatever decodes is usable); arbitrary text as a
//! gyro file; or a gyro file written by `gyrocal` from a MotionPlus-like calibration perturbed
//! by the input (accepted and refused ones near the limits). Whatever parses is turned into
//! the MotionPlus's count axes (`for_motionplus`) and sent to the adapter's protocol as
//! `device put --force` would, then committed: the adapter must never panic, must accept
//! exactly what the core's `Acceptance::check_gyro` accepts, must keep its old gyro
//! calibration when it refuses, and once it accepts must report it back bit for bit.
#![no_main]

use embassy_futures::block_on;
use libfuzzer_sys::fuzz_target;

#[path = "ram_flash.rs"]
mod ram_flash;
use ram_flash::{RamFlash, PAGE, PAGES};
use wiical_adapter::store::decode_gyro_record;
use wiical_adapter::{CalibrationStore, DeviceInfo, IdealScale, Protocol};
use wiical_analysis::output::gyrocal::{self, GyroCalFile};
use wiical_core::acceptance::Acceptance;
use wiical_core::gyro_correct::{GyroCorrection, GyroEffects};
use wiical_wire::{Hello, Request, Response, WireGyroCalibration};

/// A MotionPlus-like calibration in a Wii Remote accelerometer's frame (yaw about −z, roll
/// about +y, pitch about −x), each term perturbed by one input byte.
fn near_motionplus(bytes: &[u8]) -> GyroCorrection<f64> {
    let mut b = bytes
        .iter()
        .map(|&x| f64::from(x as i8))
        .chain(core::iter::repeat(0.0));
    let mut next = || b.next().unwrap_or(0.0);
    let s = std::f64::consts::PI / 180.0 / 18.618;
    let mut kc = [[0.0; 3]; 3];
    let mut bias = [0.0; 3];
    for (i, (row, b)) in kc.iter_mut().zip(bias.iter_mut()).enumerate() {
        *b = 8192.0 + 10.0 * next();
        for (j, x) in row.iter_mut().enumerate() {
            *x = if i == j {
                s * (1.0 + next() / 200.0)
            } else {
                s * next() / 400.0
            };
        }
    }
    let mut k = [[0.0; 3]; 3];
    for (i, (a, sign)) in [(2usize, -1.0), (1, 1.0), (0, -1.0)].iter().enumerate() {
        k[*a] = kc[i].map(|x| sign * x);
    }
    let mut effects = GyroEffects::default();
    effects.g_sensitivity[0][0] = next() * 1e-4;
    GyroCorrection {
        bias,
        matrix: k,
        effects,
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let text = match mode % 3 {
        0 => {
            if let Ok(c) = decode_gyro_record(rest) {
                let linear = wiical_core::Calibration {
                    bias: c.bias,
                    matrix: c.matrix,
                    effects: wiical_core::Calibration::identity().effects,
                };
                assert!(linear.validate().is_ok(), "a decoded gyro record is usable");
            }
            return;
        }
        1 => match std::str::from_utf8(rest) {
            Ok(t) => t.to_string(),
            Err(_) => return,
        },
        _ => {
            let f = GyroCalFile {
                model: "full+bias".into(),
                correction: near_motionplus(rest),
                cv_rms_deg: 0.5,
            };
            match gyrocal::to_text(&f) {
                Ok(t) => t,
                Err(_) => return,
            }
        }
    };
    let Ok(file) = gyrocal::parse(&text) else {
        return;
    };
    let Ok(m) = gyrocal::for_motionplus(&file.correction) else {
        return;
    };
    let cal = m.device;
    let plausible = Acceptance::motionplus().check_gyro(&cal).is_ok();
    block_on(async {
        let store =
            CalibrationStore::new(RamFlash(vec![0xFF; PAGE * PAGES]), 0..(PAGE * PAGES) as u32)
                .expect("store configuration");
        let info = DeviceInfo::new("fuzz", [0; 8], 200_000);
        let mut p = Protocol::boot(store, info, IdealScale::default()).await;
        assert!(matches!(
            p.handle(Request::Hello(Hello::CURRENT)).await,
            Response::Hello(_)
        ));
        let wire = WireGyroCalibration::from(cal);
        let put = p.handle(Request::PutGyroCalibration(wire)).await;
        let commit = p.handle(Request::CommitGyroCalibration).await;
        let accepted = put == Response::Ack && commit == Response::Ack;
        assert_eq!(
            accepted, plausible,
            "adapter and core disagree: put {put:?}, commit {commit:?}"
        );
        let live = p.gyro_calibration().map(GyroCorrection::bits);
        if accepted {
            assert_eq!(
                live,
                Some(cal.bits()),
                "the live gyro calibration is the one sent"
            );
        } else {
            assert_eq!(live, None, "a refused gyro calibration became live");
        }
    });
});
