//! Pairing the accelerometer's rows with the gyro's: by position when both files have the same
//! samples, by time when the gyro's rows are a subset (a capture whose rows alternate).

use super::options::{GyroError, Result};
use crate::input::recording::Recording;
use crate::input::timecheck::TimeSteps;

/// Rows of `acc` and `gyro` that belong together: all of them when the lengths agree (`None`),
/// else (a capture whose rows alternate between gyro and other data, so the loader skipped the
/// rows without gyro values) the accelerometer rows at the gyro rows' times, with those times.
type Aligned = (Vec<[f64; 3]>, Option<Vec<f64>>);

pub(super) fn align(acc: &Recording, gyro: &Recording) -> Result<Aligned> {
    let mismatch = || GyroError::GyroRowsMismatch {
        accel: acc.len(),
        gyro: gyro.len(),
    };
    if acc.len() == gyro.len() {
        // Rows pair by position, but only when both clocks agree on them (a shifted copy of
        // the gyro log must not be paired silently).
        if let (Some(ta), Some(tg)) = (&acc.t, &gyro.t) {
            let worst = ta
                .iter()
                .zip(tg)
                .map(|(a, g)| (a - g).abs())
                .fold(0.0, f64::max);
            let step = TimeSteps::of(ta).map_or(f64::INFINITY, |s| s.median_s);
            if worst > 0.5 * step {
                return Err(GyroError::GyroClocksDiffer { offset_s: worst });
            }
        }
        return Ok((acc.xyz.clone(), None));
    }
    let (Some(ta), Some(tg)) = (&acc.t, &gyro.t) else {
        return Err(mismatch());
    };
    // A subset of the rows (a capture whose rows alternate): it must span the recording, not
    // stop early (a cut-off gyro file would silently drop the rest of the accelerometer).
    let span = |t: &[f64]| t.last().copied().unwrap_or(0.0) - t.first().copied().unwrap_or(0.0);
    if span(tg) < 0.95 * span(ta) {
        return Err(GyroError::GyroSpanShort {
            gyro: (
                tg.first().copied().unwrap_or(0.0),
                tg.last().copied().unwrap_or(0.0),
            ),
            accel: (
                ta.first().copied().unwrap_or(0.0),
                ta.last().copied().unwrap_or(0.0),
            ),
        });
    }
    let mut out = Vec::with_capacity(tg.len());
    let mut i = 0;
    for t in tg {
        while i < ta.len() && ta[i] < *t {
            i += 1;
        }
        if i >= ta.len() || ta[i] != *t {
            return Err(mismatch());
        }
        out.push(acc.xyz[i]);
    }
    Ok((out, Some(tg.clone())))
}

/// The accelerometer rows that belong to the gyro's, as a recording with its clock.
pub(super) fn paired_accelerometer(acc: &Recording, gyro: &Recording) -> Result<Recording> {
    let (acc_xyz, subset_times) = align(acc, gyro)?;
    Ok(match subset_times {
        // A subset of the rows: the rate comes from their times, not from the file's Fs.
        Some(t) => Recording {
            xyz: acc_xyz,
            t: Some(t),
            ..Default::default()
        },
        None => Recording {
            xyz: acc_xyz,
            t: acc.t.clone(),
            temp: acc.temp.clone().or_else(|| gyro.temp.clone()),
            sample_rate_hz: acc.sample_rate_hz.or(gyro.sample_rate_hz),
            ..Default::default()
        },
    })
}
