//! What a recording must be for its Allan deviation to be noise: evenly sampled, varying,
//! and still. Each check refuses in one sentence naming what it saw, because an Allan curve
//! of a moving, constant or unevenly sampled recording is a curve of the motion, of nothing,
//! or of the wrong τ — and its terms would be printed as the sensor's noise.

use crate::error::noise::NoiseError;
use crate::input::columns::Sensor;
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

/// Share of an axis's successive changes (its nonzero first differences, zeros skipped) that
/// repeat the change before at or above which the axis is a counter. A counter (`i mod 256`,
/// a sample index, a value stepping up every other sample) repeats its step at every change
/// but its wrap-arounds; a still sensor's noise turns back (white noise: a step up is
/// mostly followed by one down) or wanders (a random walk repeats half its steps).
pub const COUNTER_REPEATS: f64 = 0.9;

/// Least share of first differences that are changes for the counter test: a quantised,
/// quiet sensor that drifts one step at a time, rarely, is not taken for a counter.
pub const COUNTER_MIN_CHANGES: f64 = 0.25;

/// The counter test ([`COUNTER_REPEATS`]) of three axes, fed sample by sample by the noise
/// pass ([`crate::noise::pass`]).
#[derive(Debug, Clone, Default)]
pub struct CounterFold {
    prev: Option<[f64; 3]>,
    last_step: [Option<f64>; 3],
    steps: usize,
    changes: [usize; 3],
    repeats: [usize; 3],
}

impl CounterFold {
    /// The next sample.
    pub fn push(&mut self, v: [f64; 3]) {
        if let Some(p) = self.prev.replace(v) {
            self.steps += 1;
            for a in 0..3 {
                let d = v[a] - p[a];
                if d == 0.0 || !d.is_finite() {
                    continue;
                }
                self.changes[a] += 1;
                if self.last_step[a].replace(d) == Some(d) {
                    self.repeats[a] += 1;
                }
            }
        }
    }

    /// Refuses the first axis that steps like a counter, naming its column.
    pub fn verdict(&self, columns: &[String; 3]) -> Result<(), NoiseError> {
        for (a, column) in columns.iter().enumerate() {
            let changes = self.changes[a];
            let pairs = changes.saturating_sub(1);
            if pairs == 0 || (changes as f64) < COUNTER_MIN_CHANGES * self.steps as f64 {
                continue;
            }
            let share = self.repeats[a] as f64 / pairs as f64;
            if share >= COUNTER_REPEATS {
                return Err(NoiseError::CounterAxis {
                    column: column.clone(),
                    step: self.last_step[a].unwrap_or(0.0),
                    percent: 100.0 * share,
                });
            }
        }
        Ok(())
    }
}

/// The window of the motion check, samples: one second, at least 10 and at most an eighth of
/// the `n` samples (so that a short recording still has eight windows).
pub fn window_of(rate_hz: f64, n: usize) -> usize {
    (rate_hz.round() as usize).clamp(10, (n / 8).max(10))
}

/// The motion and time checks from what they need: the window means (in
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
    let centre: [f64; 3] = std::array::from_fn(|a| {
        let axis: Vec<f64> = means.iter().map(|m| m[a]).collect();
        crate::stats::median(&axis)
    });
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

fn angle_deg(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let dot: f64 = (0..3).map(|i| a[i] * b[i]).sum();
    let na = a.iter().map(|x| x * x).sum::<f64>().sqrt();
    let nb = b.iter().map(|x| x * x).sum::<f64>().sqrt();
    if na == 0.0 || nb == 0.0 {
        return 0.0;
    }
    (dot / (na * nb)).clamp(-1.0, 1.0).acos().to_degrees()
}

/// The white-noise standard deviation of a `win`-sample mean, largest over the axes, from each
/// axis's median |first difference| and, used only where that median is 0, their RMS
/// (σ² = var(Δ)/2, robust: a slow motion or drift does not count as noise; the noise pass
/// folds the differences without holding them).
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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    fn verdict(samples: impl Iterator<Item = f64>) -> Result<(), NoiseError> {
        let mut f = CounterFold::default();
        samples.for_each(|x| f.push([x, 0.0, 0.0]));
        f.verdict(&["x".into(), "y".into(), "z".into()])
    }

    /// Counters of every kind are refused naming the column; quantised white noise, a
    /// quantised random walk and a rare one-step drift are not counters.
    #[test]
    fn counters_are_told_from_quantised_noise() {
        for (name, counter) in [
            (
                "8-bit",
                (0..20_000).map(|i| (i % 256) as f64).collect::<Vec<_>>(),
            ),
            ("index", (0..20_000).map(f64::from).collect()),
            (
                "every other sample",
                (0..20_000).map(|i| (i / 2) as f64).collect(),
            ),
            (
                "down by 4",
                (0..20_000).map(|i| -4.0 * f64::from(i % 100)).collect(),
            ),
        ] {
            let e = verdict(counter.into_iter()).unwrap_err();
            assert!(matches!(e, NoiseError::CounterAxis { .. }), "{name}: {e}");
            assert!(e.to_string().starts_with("column x counts"), "{e}");
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut g = move || -> f64 { StandardNormal.sample(&mut rng) };
        let white: Vec<f64> = (0..20_000).map(|_| (512.0 + 1.5 * g()).round()).collect();
        let mut level = 0.0;
        let walk: Vec<f64> = (0..20_000)
            .map(|_| {
                level += g();
                level.round()
            })
            .collect();
        let drift: Vec<f64> = (0..20_000).map(|i| f64::from(i / 500)).collect();
        for (name, still) in [("white", white), ("walk", walk), ("drift", drift)] {
            assert!(verdict(still.into_iter()).is_ok(), "{name}");
        }
    }
}
