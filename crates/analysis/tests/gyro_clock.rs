//! A gyro whose rows lag their own timestamps (issue 49: `gyrofit xsens_acc.mat GYRO` with the
//! gyro 10 s late gave a held-out error of 87° called "usable with that error"). The test data
//! is the real IMU-TK Xsens pair with the gyro's values shifted in the test: row `i` of the
//! gyro holds the values of row `i − shift` (the first rows repeat the first value, a rest), its
//! timestamps unchanged. The expectation is the shift itself: the lag found must be the one
//! made, to the 0.1-s blocks the estimate works in, and the verdict must say it. (Some offsets,
//! -5 s here, are refused earlier, before any verdict: the shifted gyro moves with
//! gravity in the rests. That refusal does not name the lag yet.)

mod common;

use common::data_dir;
use wiical_analysis::gyro::{run, GyroOptions, GyroQuality, GyroReport};
use wiical_analysis::{load, LoadOptions, Recording};

/// IMU-TK's nominal gyro scale for this sensor, rad/s per count.
const SCALE: f64 = 1.0 / 6258.0;

fn xsens() -> (Recording, Recording) {
    let dir = data_dir().join("imu_tk_xsens");
    let acc = load(&dir.join("xsens_acc.mat"), &LoadOptions::default()).unwrap();
    let gyro = load(&dir.join("xsens_gyro.mat"), &LoadOptions::default()).unwrap();
    (acc, gyro)
}

/// `gyro` with its values `shift` rows late (negative: early), its timestamps kept.
fn shifted(gyro: &Recording, shift: isize) -> Recording {
    let n = gyro.len() as isize;
    let mut out = gyro.clone();
    out.xyz = (0..n)
        .map(|i| gyro.xyz[(i - shift).clamp(0, n - 1) as usize])
        .collect();
    out
}

/// The lag the report's first reason names, s (positive: the gyro lags).
fn named_lag(rep: &GyroReport) -> Option<f64> {
    let r = rep.reasons.first()?;
    let (way, rest) = if let Some(rest) = r.strip_prefix("the gyro lags the accelerometer by ") {
        (1.0, rest)
    } else {
        (
            -1.0,
            r.strip_prefix("the gyro leads the accelerometer by ")?,
        )
    };
    let secs: f64 = rest.split(" s").next()?.parse().ok()?;
    Some(way * secs)
}

#[test]
fn a_gyro_seconds_off_its_timestamps_is_named_and_not_usable() {
    let (acc, gyro) = xsens();
    let opts = GyroOptions::new([SCALE; 3]);
    // The pair as recorded: no clock reason (the aligned pair is the one that calibrates).
    let aligned = run(&acc, &gyro, &opts).unwrap();
    assert_eq!(named_lag(&aligned), None, "{:?}", aligned.reasons);
    assert_ne!(
        aligned.quality,
        GyroQuality::NotUsable,
        "{}",
        aligned.verdict
    );
    let rate = aligned.sample_rate_hz;
    // The case: a report, its first reason the lag made.
    let shift = (10.0 * rate).round() as isize;
    let rep = run(&acc, &shifted(&gyro, shift), &opts).unwrap();
    let made = shift as f64 / rate;
    let found = named_lag(&rep).unwrap_or_else(|| panic!("{:?}", rep.reasons));
    assert!(
        (found - made).abs() <= 0.15,
        "made {made} s, found {found} s"
    );
    assert_eq!(rep.quality, GyroQuality::NotUsable, "{}", rep.verdict);
    assert!(
        !rep.verdict.contains("usable with that error"),
        "{}",
        rep.verdict
    );
    // Other offsets either way: never a usable calibration. Some are refused before the
    // verdict (the shifted gyro moves with gravity in the accelerometer's rests); when there
    // is a report, its first reason is the lag made.
    for made_s in [3.0, -5.0] {
        let shift = (made_s * rate).round() as isize;
        let made = shift as f64 / rate;
        match run(&acc, &shifted(&gyro, shift), &opts) {
            Err(e) => eprintln!("{made} s: refused: {e}"),
            Ok(rep) => {
                let found = named_lag(&rep).unwrap_or_else(|| panic!("{:?}", rep.reasons));
                assert!(
                    (found - made).abs() <= 0.15,
                    "made {made} s, found {found} s"
                );
                assert_eq!(rep.quality, GyroQuality::NotUsable, "{}", rep.verdict);
            }
        }
    }
}
