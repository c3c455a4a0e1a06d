//! `wiical capture` of a Wii Remote with a MotionPlus, then `wiical gyrofit` on the capture's CSV,
//! against a simulation with known truth (issue 50, item 3).
//!
//! The body (`wiical_sim::gyro`: rests and smooth turns, the gyro's true matrix
//! and bias in **slow-range counts**) is played through the scripted fake remote
//! (`wiical_capture::replay`): the remote's accelerometer as 10-bit counts (`REMOTE`'s model of
//! the shared capture fixtures), the MotionPlus's three rates as 14-bit counts, each axis in the
//! slow range below 400 °/s and in the fast range above it, a fast count being what the
//! device's own calibration block maps back onto the slow scale (`m = zero_slow + (raw −
//! zero_fast)·c_slow/c_fast`, the adapter's `RangeMap`). With a Nunchuk in the MotionPlus's
//! port every other report is the Nunchuk's (the gyro cells of its row are empty).
//!
//! `gyrofit` must read the capture as written: the `gx,gy,gz` counts with their `*_slow` bits,
//! the block in the `# motionplus_cal:` header line, rows without gyro. Its calibration is
//! compared with the truth.

mod common;
#[path = "../../crates/capture/tests/support/mod.rs"]
mod support;

use common::wiical;
use serde_json::Value;
use support::{real_blocks, tmp, REMOTE};
use wiical_capture::replay::{report_0x35_ext, EndOfScript, ReplayWiimote};
use wiical_capture::{capture, CaptureMode, CaptureOptions, CollectUi};
use wiical_extbus::motionplus::PassthroughNunchuk;
use wiical_extbus::motionplus::{MotionPlusCalibration, MotionPlusReport, RangeCalibration};
use wiical_extbus::NunchukReport;
use wiical_sim::gyro::{simulate_gyro, GyroSimOptions, GyroTruth};

/// Slow-range sensitivity of the simulated MotionPlus, counts per °/s (WiiBrew's ≈ 20, the
/// driver's 18.6).
const SLOW_CPD: f64 = 19.2;
/// Slow counts per fast count (WiiBrew's 2000/440 ≈ 4.5).
const FAST_TO_SLOW: f64 = 4.6;
/// Above this rate an axis reports in the fast range, °/s.
const SLOW_LIMIT_DPS: f64 = 400.0;

/// The truth in rad/s per slow count, `gx,gy,gz` = pitch, roll, yaw counts against the Wii
/// Remote accelerometer's x, y, z: scale errors of a few %, misalignment of about 1 %, roll
/// counting against the accelerometer's y (as the MotionPlus's stored yaw and pitch spans are
/// negative: a sign is part of the truth), bias tens of counts off 8192.
fn truth() -> GyroTruth {
    let s = 1f64.to_radians() / SLOW_CPD;
    GyroTruth {
        matrix: [
            [s * 1.03, s * 0.012, -s * 0.006],
            [s * 0.009, -s * 0.97, s * 0.011],
            [-s * 0.007, s * 0.008, s * 1.015],
        ],
        bias: [8192.0 + 37.0, 8192.0 - 58.0, 8192.0 + 21.0],
        ..GyroTruth::default()
    }
}

/// The device's block (yaw, roll, pitch): slow zeros near but not at the true bias (as a
/// factory block is), fast zeros 12 counts off 8192, sensitivities with the ratio
/// [`FAST_TO_SLOW`]; degrees 270 slow and 1200 fast as Dolphin's block states.
fn device_block() -> MotionPlusCalibration {
    let slow_zero14 = [8192.0 + 15.0, 8192.0 - 40.0, 8192.0 + 30.0];
    let fast_zero14 = [8192.0 + 12.0; 3];
    let range = |zero14: [f64; 3], cpd: f64, deg: f64| RangeCalibration {
        zero: zero14.map(|z| (z * 4.0).round() as u16),
        scale: zero14.map(|z| ((z + cpd * deg) * 4.0).round() as u16),
        degrees_div_6: (deg / 6.0) as u8,
    };
    MotionPlusCalibration {
        fast: range(fast_zero14, SLOW_CPD / FAST_TO_SLOW, 1200.0),
        slow: range(slow_zero14, SLOW_CPD, 270.0),
        uid: [0x3A, 0xC5],
    }
}

/// The MotionPlus report of slow-range counts `m` (`gx,gy,gz`): per axis the slow count, or
/// above [`SLOW_LIMIT_DPS`] the fast count the block maps back onto `m`.
fn report(m: [f64; 3], block: &MotionPlusCalibration, extension: bool) -> MotionPlusReport {
    // Block order yaw, roll, pitch = gz, gy, gx.
    let pick = [2usize, 1, 0];
    let mut r = MotionPlusReport {
        extension_connected: extension,
        ..Default::default()
    };
    for (i, &axis) in pick.iter().enumerate() {
        let zs = block.slow.zero_14bit()[i] as f64;
        let zf = block.fast.zero_14bit()[i] as f64;
        let ratio = f64::from(block.slow.counts_per_dps().unwrap()[i])
            / f64::from(block.fast.counts_per_dps().unwrap()[i]);
        let rate_dps = (m[axis] - zs) / SLOW_CPD;
        let slow = rate_dps.abs() < SLOW_LIMIT_DPS;
        let count = if slow {
            m[axis]
        } else {
            zf + (m[axis] - zs) / ratio
        };
        r.rate[i] = count.round().clamp(0.0, 16383.0) as u16;
        r.slow[i] = slow;
    }
    r
}

/// Plays the simulation through the fake remote, captures it, returns the CSV path and the
/// number of samples in the fast range (some axis).
fn capture_simulation(name: &str, nunchuk: bool) -> (std::path::PathBuf, usize, usize) {
    let opts = GyroSimOptions {
        seed: 7,
        rate_hz: 200.0,
        poses: 22,
        rest_s: 2.0,
        turn_s: 0.4,
        turn_deg: (70.0, 190.0),
        accel_noise_g: 0.004,
        gyro_noise: 0.08f64.to_radians(),
        truth: truth(),
    };
    let sim = simulate_gyro(&opts);
    let block = device_block();
    let (w, n) = real_blocks();
    let mut dev = ReplayWiimote::new()
        .with_eeprom(0x16, &w)
        .with_eeprom(0x20, &w)
        .with_motionplus(&block.to_bytes())
        .with_end(EndOfScript::Silence);
    if nunchuk {
        dev = dev.with_nunchuk(&n);
    }
    let nun = PassthroughNunchuk {
        report: NunchukReport {
            stick: [128, 128],
            accel: [512, 498, 716],
            c: false,
            z: false,
        },
        extension_connected: true,
    };
    let (mut fast, mut gyro_rows) = (0, 0);
    let t = sim.accel.t.as_ref().unwrap();
    for (k, (a, m)) in sim.accel.xyz.iter().zip(&sim.gyro.xyz).enumerate() {
        let acc: [u16; 3] = std::array::from_fn(|i| {
            (REMOTE.bias[i] + REMOTE.sens[i] * a[i])
                .round()
                .clamp(0.0, 1023.0) as u16
        });
        let ext = if nunchuk && k % 2 == 1 {
            nun.to_bytes()
        } else {
            let r = report(*m, &block, nunchuk);
            fast += usize::from(r.slow.iter().any(|s| !s));
            gyro_rows += 1;
            r.to_bytes().unwrap()
        };
        dev.push_report(t[k], report_0x35_ext(acc, ext));
    }
    let out = tmp(name);
    let copts = CaptureOptions {
        out: out.clone(),
        mode: CaptureMode::Duration(t[t.len() - 1] - 0.005),
        ..Default::default()
    };
    capture(&mut dev, &copts, &mut CollectUi::default()).unwrap();
    (out, fast, gyro_rows)
}

/// `gyrofit --json` on the capture: the fit against the truth.
fn fit_and_check(csv: &std::path::Path) -> Value {
    let (ok, stdout, stderr) = wiical(&["gyrofit", csv.to_str().unwrap(), "--json"]);
    assert!(ok, "gyrofit failed: {stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    let t = truth();
    let k: Vec<Vec<f64>> = v["matrix"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            r.as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect()
        })
        .collect();
    let b: Vec<f64> = v["bias"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let s = 1f64.to_radians() / SLOW_CPD;
    assert!(k.len() == 3 && k.iter().all(|r| r.len() == 3), "{k:?}");
    let worst_k = k
        .iter()
        .zip(&t.matrix)
        .flat_map(|(got, want)| got.iter().zip(want).map(|(g, w)| (g - w).abs() / s))
        .fold(0f64, f64::max);
    let worst_b = (0..3)
        .map(|i| (b[i] - t.bias[i]).abs())
        .fold(0f64, f64::max);
    eprintln!(
        "{}: K worst {:.2e} of the scale, bias worst {worst_b:.2} counts, held-out {} deg (before {})",
        csv.display(),
        worst_k,
        v["cv_rms_deg"],
        v["rms_deg_before"]
    );
    // The capture's accelerometer has 9–10 significant bits (≈ 100 counts per g, Y and Z
    // without bit 0), so the poses' gravity directions are good to ≈ 0.5°: the bounds are
    // that instrument's, not the simulated gyro noise's.
    assert!(
        worst_k < 0.01,
        "K off the truth by {worst_k:.3e} of the scale: {k:?}"
    );
    assert!(
        worst_b < 3.0,
        "bias off the truth by {worst_b:.2} counts: {b:?}"
    );
    v
}

#[test]
fn a_motionplus_capture_with_fast_turns_calibrates_against_the_truth() {
    let (csv, fast, gyro_rows) = capture_simulation("mp_gyrofit_alone.csv", false);
    assert!(
        fast > 100,
        "the simulation must use the fast range ({fast} samples)"
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let header = text.lines().find(|l| !l.starts_with('#')).unwrap();
    assert_eq!(header, "t,x,y,z,gx,gy,gz,gx_slow,gy_slow,gz_slow");
    assert!(gyro_rows > 10_000);
    fit_and_check(&csv);
}

#[test]
fn a_motionplus_capture_with_a_nunchuk_passed_through_calibrates_against_the_truth() {
    let (csv, fast, _) = capture_simulation("mp_gyrofit_nunchuk.csv", true);
    assert!(
        fast > 50,
        "the simulation must use the fast range ({fast} samples)"
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let header = text.lines().find(|l| !l.starts_with('#')).unwrap();
    assert_eq!(
        header,
        "t,x,y,z,ext_x,ext_y,ext_z,gx,gy,gz,gx_slow,gy_slow,gz_slow"
    );
    fit_and_check(&csv);
}
