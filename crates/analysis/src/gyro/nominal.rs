//! The nominal gyro sensitivity: from the columns' unit, estimated from the motions when no
//! datasheet value is given, and the checks that refuse an absurd given one.

use super::options::{GyroError, Result};
use crate::input::recording::Recording;
use wiical_core::gyro::GyroCalibration;
use wiical_core::gyro_fit::{motion_angle, Motion};

/// The gyro's sensitivity (rad/s per count, signed per axis) without a datasheet: the scale
/// whose integration best turns each static window's gravity direction into the next's (the
/// RMS of the motions' angle errors, the same error the fit minimises). A coarse search over
/// seven decades (10⁻⁷ to 1 rad/s per count, steps of 10^0.2 ≈ 58 %) with one scale for all
/// axes, then the sign of each axis (a flipped axis), then steps of 10^0.05 ≈ 12 % within two
/// coarse steps either side, then a golden-section refinement within the best fine step. The
/// candidate fits then adjust each axis from there. About 90 evaluations of the motions'
/// integration (each costs as much as the rest of a `--scale` run's fits share per
/// evaluation): the cost's minimum in log-scale is one smooth valley a decade wide on the
/// real recordings (docs/gyro.md), so the coarse grid cannot step over it.
pub fn estimate_nominal(motions: &[Motion<'_, f64>], bias: [f64; 3], dt: f64) -> Result<[f64; 3]> {
    let cost = |scale: [f64; 3]| -> f64 {
        let cal = GyroCalibration::nominal(bias, scale);
        let sq: f64 = motions
            .iter()
            .map(|m| motion_angle(m, &cal, dt).map_or(f64::INFINITY, |a| a * a))
            .sum();
        sq / motions.len() as f64
    };
    let at = |log_s: f64, sign: [f64; 3]| sign.map(|g| g * 10f64.powf(log_s));
    let best_of = |grid: &mut dyn Iterator<Item = f64>, signs: [f64; 3]| {
        grid.map(|l| (l, cost(at(l, signs))))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(l, _)| l)
            .ok_or(GyroError::GyroFitFailed(wiical_core::Error::NotConverged))
    };
    let coarse = best_of(&mut (0..=35).map(|i| -7.0 + 0.2 * f64::from(i)), [1.0; 3])?;
    // The sign of each axis, each combination's cost computed once.
    let signs: [f64; 3] = (0..8u32)
        .map(|k| std::array::from_fn(|a| if k >> a & 1 == 1 { -1.0 } else { 1.0 }))
        .map(|s: [f64; 3]| (cost(at(coarse, s)), s))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map_or([1.0; 3], |(_, s)| s);
    let best_log = best_of(
        &mut (-8..=8).map(|i| (coarse + 0.05 * f64::from(i)).clamp(-7.0, 0.0)),
        signs,
    )?;
    // Golden-section search on log₁₀(scale) within one fine step either side, one new
    // evaluation per iteration.
    let r = (5f64.sqrt() - 1.0) / 2.0;
    let (mut lo, mut hi) = (best_log - 0.05, best_log + 0.05);
    let (mut a, mut b) = (hi - r * (hi - lo), lo + r * (hi - lo));
    let (mut fa, mut fb) = (cost(at(a, signs)), cost(at(b, signs)));
    for _ in 0..28 {
        if fa < fb {
            (hi, b, fb) = (b, a, fa);
            a = hi - r * (hi - lo);
            fa = cost(at(a, signs));
        } else {
            (lo, a, fa) = (a, b, fb);
            b = lo + r * (hi - lo);
            fb = cost(at(b, signs));
        }
    }
    let s = at((lo + hi) / 2.0, signs);
    if !cost(s).is_finite() {
        return Err(GyroError::GyroFitFailed(wiical_core::Error::NotConverged));
    }
    Ok(s)
}

/// Refuses a given nominal whose integrated rotation is absurd next to the tilt the
/// accelerometer sees: over the motions that tilt by more than 20°, the median of
/// ∫|ω|dt / tilt must lie in [0.2, 50]. The path turned is at least the net tilt (ratio ≥ 1 for a
/// right nominal; turns about gravity raise it, rarely past 5), so a factor-of-five unit error is
/// still passed to the fit (which corrects it) while 10^±3 (a rad/deg or counts/LSB mix-up, a
/// typo in the exponent) is named here instead of ending in a singular matrix.
pub(super) fn check_nominal_plausible(
    motions: &[Motion<'_, f64>],
    bias: [f64; 3],
    scale: [f64; 3],
    dt: f64,
    source: &str,
) -> Result<()> {
    let mut ratios: Vec<f64> = motions
        .iter()
        .filter_map(|m| {
            let tilt = m.g_start.angle(&m.g_end);
            (tilt > 20f64.to_radians()).then(|| {
                let path: f64 = m
                    .samples
                    .iter()
                    .map(|s| {
                        (0..3)
                            .map(|a| ((s[a] - bias[a]) * scale[a]).powi(2))
                            .sum::<f64>()
                            .sqrt()
                    })
                    .sum::<f64>()
                    * dt;
                path / tilt
            })
        })
        .collect();
    if ratios.is_empty() {
        return Ok(());
    }
    ratios.sort_by(f64::total_cmp);
    let median = ratios[ratios.len() / 2];
    if (0.2..=50.0).contains(&median) {
        return Ok(());
    }
    Err(GyroError::GyroNominalImplausible {
        source_name: source.chars().take(60).collect(),
        ratio: median,
        motions: ratios.len(),
    })
}

/// A note per axis whose fitted sensitivity has the opposite sign of the nominal: the gyro
/// axis points the other way from the accelerometer's (a flipped axis, as in sunsided's
/// MPU-6050 logs); the fit has absorbed it, and a datasheet nominal would have missed it.
pub(super) fn flipped_axes(cal: &GyroCalibration<f64>, nominal: &[f64; 3]) -> Vec<String> {
    (0..3)
        .filter(|&a| cal.matrix[(a, a)] * nominal[a] < 0.0)
        .map(|a| {
            format!(
                "the {} gyro axis turns the other way from the accelerometer's (fitted sensitivity {:.4e} rad/s per count against the nominal {:.4e}): its sign is flipped",
                ["x", "y", "z"][a],
                cal.matrix[(a, a)],
                nominal[a]
            )
        })
        .collect()
}

/// Whether a nominal sensitivity a user gave (rad/s per count, per axis) can start the fit:
/// finite and non-zero on every axis (its sign is the axis's direction). The CLI's
/// `--scale` / `--counts-per-dps` and the Python package's `scale` / `counts_per_dps` both
/// refuse what fails it.
pub fn nominal_given_usable(s: &[f64; 3]) -> bool {
    s.iter().all(|x| x.is_finite() && *x != 0.0)
}

/// The gyro's nominal sensitivity from its columns' unit, when the names state one:
/// `deg/s` (`gyro_x_dps`) is 1 count = 1 °/s, `rad/s` 1 count = 1 rad/s. Returns the nominal
/// (rad/s per count) and a sentence saying where it came from.
pub fn nominal_from_columns(gyro: &Recording) -> Option<([f64; 3], String)> {
    let unit = crate::input::columns::triplet_unit(&gyro.axis_columns)?;
    let per_count = match unit {
        "deg/s" => 1f64.to_radians(),
        "rad/s" => 1.0,
        _ => return None,
    };
    Some((
        [per_count; 3],
        format!(
            "the columns' unit ({unit} in {}): 1 count = 1 {unit}",
            gyro.axis_columns.join(", ")
        ),
    ))
}

/// The nominal the fit starts from: estimated from the motions, or the given one after the
/// checks that refuse an absurd magnitude or wrong signs.
pub(super) fn choose(
    motions: &[Motion<'_, f64>],
    bias: [f64; 3],
    dt: f64,
    opts: &super::options::GyroOptions,
) -> Result<([f64; 3], String)> {
    if opts.estimate_nominal {
        let s = estimate_nominal(motions, bias, dt)?;
        let source = format!(
            "estimated from the motions ({:.4e}, {:.4e}, {:.4e} rad/s per count: the scale that best turns each window's gravity direction into the next's)",
            s[0], s[1], s[2]
        );
        return Ok((s, source));
    }
    let (scale, source) = (opts.nominal_rad_per_count, opts.nominal_source.clone());
    check_nominal_plausible(motions, bias, scale, dt, &source)?;
    check_nominal_signs(motions, bias, scale, dt, &source)?;
    Ok((scale, source))
}

/// Motion-angle RMS of the nominal `scale` with the bias from rest, rad.
fn nominal_rms(motions: &[Motion<'_, f64>], bias: [f64; 3], scale: [f64; 3], dt: f64) -> f64 {
    let cal = GyroCalibration::nominal(bias, scale);
    let sq: f64 = motions
        .iter()
        .map(|m| motion_angle(m, &cal, dt).map_or(f64::INFINITY, |a| a * a))
        .sum();
    (sq / motions.len().max(1) as f64).sqrt()
}

/// A given nominal whose signs are wrong gives far larger angle errors than the same
/// magnitudes with other signs. The fit starts from the nominal and a sign is the one thing a
/// local fit cannot flip (the scale would have to pass through zero), so it ends in a
/// calibration with held-out errors of tens of degrees. Refused when another choice of signs
/// brings the motions' RMS angle error below half the given one's and the given one's is above
/// 10° (a right sign with a magnitude 30 % off, IMU-TK's start value for its Xsens, gives 40°
/// where every wrong sign gives more than 100°): an axis mounted the other way is then named rather than fitted around. Only for a
/// nominal from a flag: the columns' unit says nothing about the axes' directions (the fit's
/// flipped-axis note covers those).
pub(super) fn check_nominal_signs(
    motions: &[Motion<'_, f64>],
    bias: [f64; 3],
    scale: [f64; 3],
    dt: f64,
    source: &str,
) -> Result<()> {
    if !source.starts_with("--") {
        return Ok(());
    }
    let given = nominal_rms(motions, bias, scale, dt);
    let (best, flips) = (1..8u32)
        .map(|k| {
            let flips: [bool; 3] = std::array::from_fn(|a| k >> a & 1 == 1);
            let s = std::array::from_fn(|a| if flips[a] { -scale[a] } else { scale[a] });
            (nominal_rms(motions, bias, s, dt), flips)
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap_or((f64::INFINITY, [false; 3]));
    if given > 10f64.to_radians() && best < given / 2.0 {
        let suggested: Vec<String> = (0..3)
            .map(|a| {
                let s = if flips[a] { -scale[a] } else { scale[a] };
                if source.starts_with("--counts-per-dps") {
                    format!("{:.4}", 1f64.to_radians() / s)
                } else {
                    format!("{s:.4e}")
                }
            })
            .collect();
        return Err(GyroError::GyroNominalSign {
            source_name: source.chars().take(60).collect(),
            axes: (0..3)
                .filter(|&a| flips[a])
                .map(|a| ["x", "y", "z"][a])
                .collect::<Vec<_>>()
                .join(", "),
            given_deg: given.to_degrees(),
            flipped_deg: best.to_degrees(),
            suggested: suggested.join(","),
        });
    }
    Ok(())
}
