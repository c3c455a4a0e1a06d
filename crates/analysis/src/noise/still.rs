//! What a recording must be for its Allan deviation to be noise: evenly sampled, varying,
//! and still. Each check refuses in one sentence naming what it saw, because an Allan curve
//! of a moving, constant or unevenly sampled recording is a curve of the motion, of nothing,
//! or of the wrong τ — and its terms would be printed as the sensor's noise.

use crate::error::noise::NoiseError;
use crate::input::columns::Sensor;
use crate::input::recording::Recording;
use crate::input::timecheck::TimeSteps;

/// Largest departure of the mean time step from the median one: beyond it samples are
/// missing (or the clock jumps) and each cluster's τ is not `m·τ₀`.
pub const MAX_STEP_MISMATCH: f64 = 0.05;

/// Largest angle, degrees, between a window's mean field (accelerometer: gravity,
/// magnetometer: the Earth's field) and the recording's median direction. A still sensor's
/// drift turns it by well under a degree (a few mg of thermal offset on 1 g is 0.2°); a
/// hand-held or rotated recording turns it by tens.
pub const MAX_TURN_DEG: f64 = 5.0;

/// Largest spread of a gyro's window means over their white-noise scatter. A still gyro's
/// bias wanders by a few to some tens of that scatter over hours (instability, warm-up); a
/// rotation moves it by thousands.
pub const MAX_GYRO_SPREAD: f64 = 1000.0;

/// Refuses `rec` when an axis is constant, it moved, or its time column is uneven.
pub fn check_still(rec: &Recording, sensor: Sensor, rate_hz: f64) -> Result<(), NoiseError> {
    for a in 0..3 {
        let first = rec.xyz.first().map_or(0.0, |v| v[a]);
        if rec.xyz.iter().all(|v| v[a] == first) {
            return Err(NoiseError::ConstantAxis {
                column: rec.axis_columns[a].clone(),
                value: first,
            });
        }
    }
    let win = window_of(rate_hz, rec.len());
    let means: Vec<[f64; 3]> = rec.xyz.chunks_exact(win).map(mean).collect();
    if means.len() < 2 {
        return Ok(());
    }
    let scatter = window_scatter(rec, win);
    let steps = rec.t.as_deref().and_then(TimeSteps::of);
    decide_still(&means, scatter, &rec.axis_columns, sensor, steps)
}

/// The window of the motion check, samples: one second, at least 10 and at most an eighth of
/// the `n` samples (so that a short recording still has eight windows).
pub fn window_of(rate_hz: f64, n: usize) -> usize {
    (rate_hz.round() as usize).clamp(10, (n / 8).max(10))
}

/// The motion and time checks of [`check_still`] from what they need: the window means (in
/// order), the white-noise scatter of a window mean ([`scatter_of`]), the time column's steps.
/// Fewer than two windows: nothing to compare, accepted.
pub fn decide_still(
    means: &[[f64; 3]],
    scatter: f64,
    columns: &[String; 3],
    sensor: Sensor,
    steps: Option<TimeSteps>,
) -> Result<(), NoiseError> {
    if means.len() < 2 {
        return Ok(());
    }
    let centre: [f64; 3] = std::array::from_fn(|a| median(means.iter().map(|m| m[a])));
    let turn = means
        .iter()
        .map(|m| angle_deg(m, &centre))
        .fold(0.0, f64::max);
    let norm = centre.iter().map(|c| c * c).sum::<f64>().sqrt();
    let spread = means
        .iter()
        .map(|m| (0..3).map(|a| (m[a] - centre[a]).abs()).fold(0.0, f64::max))
        .fold(0.0, f64::max);
    // A direction is defined when the mean field stands far above the noise.
    let field = matches!(sensor, Sensor::Accelerometer | Sensor::Magnetometer)
        || (sensor == Sensor::Unnamed && norm > 100.0 * scatter);
    let moved = if field {
        turn > MAX_TURN_DEG
    } else {
        scatter > 0.0 && spread > MAX_GYRO_SPREAD * scatter
    };
    if moved {
        return Err(NoiseError::Moving {
            columns: columns.join(","),
            why: if field {
                format!("their mean direction turns by {turn:.0}° (a still sensor's by under {MAX_TURN_DEG}°)")
            } else {
                format!(
                    "their 1-s means move by {:.0}× their noise (a still gyro's by under {MAX_GYRO_SPREAD:.0}×)",
                    spread / scatter
                )
            },
        });
    }
    // Motion first: a hand-held log is usually also unevenly stamped, and motion is the
    // reason it cannot be noise.
    if let Some(steps) = steps {
        let mismatch = steps.mean_s / steps.median_s - 1.0;
        if steps.repeats == 0 && mismatch.abs() > MAX_STEP_MISMATCH {
            return Err(NoiseError::UnevenTime {
                gaps: steps.gaps,
                median_ms: steps.median_s * 1e3,
                mean_ms: steps.mean_s * 1e3,
            });
        }
    }
    Ok(())
}

fn mean(v: &[[f64; 3]]) -> [f64; 3] {
    let n = v.len().max(1) as f64;
    std::array::from_fn(|a| v.iter().map(|s| s[a]).sum::<f64>() / n)
}

fn median(it: impl Iterator<Item = f64>) -> f64 {
    let v: Vec<f64> = it.collect();
    crate::stats::median(&v)
}

fn angle_deg(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let dot: f64 = (0..3).map(|i| a[i] * b[i]).sum();
    let na = a.iter().map(|x| x * x).sum::<f64>().sqrt();
    let nb = b.iter().map(|x| x * x).sum::<f64>().sqrt();
    if na == 0.0 || nb == 0.0 {
        return 0.0;
    }
    (dot / (na * nb)).clamp(-1.0, 1.0).acos().to_degrees()
}

/// The white-noise standard deviation of a `win`-sample mean, largest over the axes: from
/// the first differences (σ² = var(Δ)/2, robust: from their median absolute value), so that
/// a slow motion or drift does not count as noise.
fn window_scatter(rec: &Recording, win: usize) -> f64 {
    let per_axis = (0..3).map(|a| {
        let d: Vec<f64> = rec
            .xyz
            .windows(2)
            .map(|w| (w[1][a] - w[0][a]).abs())
            .collect();
        let med = crate::stats::median(&d);
        (
            med,
            if med > 0.0 {
                0.0
            } else {
                crate::stats::rms(&d)
            },
        )
    });
    scatter_of(per_axis, win)
}

/// The scatter of `window_scatter` from each axis's median |first difference| and, used only
/// where that median is 0, their RMS (the stream folds them without holding the differences).
pub fn scatter_of(per_axis: impl Iterator<Item = (f64, f64)>, win: usize) -> f64 {
    per_axis
        .map(|(med, rms)| {
            // For Gaussian Δ, median |Δ| = 0.6745·σ_Δ and σ = σ_Δ/√2.
            // Quantised quiet signals have mostly zero steps: the RMS step then.
            let sd = if med > 0.0 { med / 0.6745 } else { rms };
            let sigma = sd / std::f64::consts::SQRT_2;
            sigma / (win as f64).sqrt()
        })
        .fold(0.0, f64::max)
}
