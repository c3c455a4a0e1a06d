//! What the accelerometer says about the recording: the static windows, the motions between
//! them with their gravity directions, and the checks on the gyro that need them.

use super::options::{GyroError, GyroOptions, Result};
use super::samples::{self, Collected, Imu};
use crate::detect::windows::WindowStats;
use crate::fit::base::{run_windows, FitOptions};
use crate::input::timecheck::TimeSteps;
use crate::source::RowSource;
use wiical_core::gyro_fit;
use wiical_core::static_detect::StaticInterval;
use wiical_core::Calibration;

/// What the accelerometer says: the windows `wiical fit` finds on the same file and settings
/// (as the core's intervals) and the motions between them with `fit`'s gravity directions.
pub(super) struct Segmentation {
    pub(super) intervals: Vec<StaticInterval>,
    pub(super) spans: Vec<gyro_fit::MotionSpan>,
    /// The accelerometer's statistics per window (mean, variance, centre time, temperature).
    pub(super) windows: Vec<WindowStats>,
    /// The accelerometer calibration `fit` finds (gravity directions, tilt noise).
    pub(super) accel: Calibration,
}

impl Segmentation {
    /// The motions between the windows, with the gyro's samples `col` kept.
    pub(super) fn motions<'a>(&self, col: &'a Collected) -> Vec<gyro_fit::Motion<'a, f64>> {
        self.spans
            .iter()
            .zip(samples::motion_samples(&self.spans, col))
            .map(|(s, samples)| gyro_fit::Motion {
                samples,
                g_start: nalgebra::Vector3::from(s.g_start).cast(),
                g_end: nalgebra::Vector3::from(s.g_end).cast(),
            })
            .collect()
    }

    /// Calibrated specific force of each window, reference units (g): gravity in the
    /// sensor frame while the sensor rests.
    pub(super) fn gravity(&self) -> Vec<[f64; 3]> {
        self.windows
            .iter()
            .map(|w| {
                self.accel
                    .correct_linear(w.mean.map(|x| x as f32))
                    .map(f64::from)
            })
            .collect()
    }
}

pub(super) fn segment(imu: &Imu<'_, impl RowSource>, opts: &GyroOptions) -> Result<Segmentation> {
    let ws = imu.windows(&opts.detect)?;
    let fit_opts = FitOptions {
        detect: opts.detect.clone(),
        model: opts.accel_model,
    };
    let accel = run_windows(&ws, &fit_opts)?.calibration;
    let intervals: Vec<StaticInterval> = ws
        .stats
        .iter()
        .map(|w| StaticInterval {
            start: w.start as u32,
            end: w.end as u32,
            mean: w.mean.map(|x| x as f32),
            variance: w.var.map(|x| x as f32),
        })
        .collect();
    let spans: Vec<gyro_fit::MotionSpan> = gyro_fit::motion_spans(&intervals, &accel)
        .collect::<std::result::Result<_, _>>()
        .map_err(GyroError::GyroFitFailed)?;
    if spans.len() < 2 {
        return Err(GyroError::TooFewMotions {
            found: spans.len(),
            needed: 2,
        });
    }
    Ok(Segmentation {
        intervals,
        spans,
        windows: ws.stats,
        accel,
    })
}

/// Refuses a "gyro" that is an accelerometer (the same file twice, or accelerometer columns
/// given as the gyro's): a gyro's mean over the still windows is its bias, the same
/// in every pose, while gravity's points a different way in each. Refused when the spread of
/// the window means is more than half the RMS of the signal during the motions.
pub(super) fn check_not_gravity(
    columns: &[String; 3],
    seg: &Segmentation,
    col: &Collected,
) -> Result<()> {
    let means = &col.window_mean;
    let n = means.len() as f64;
    let centre: [f64; 3] = std::array::from_fn(|a| means.iter().map(|m| m[a]).sum::<f64>() / n);
    let sq = |v: [f64; 3]| (0..3).map(|a| (v[a] - centre[a]).powi(2)).sum::<f64>();
    let spread = (means.iter().map(|m| sq(*m)).sum::<f64>() / n).sqrt();
    let (mut acc, mut count) = (0.0, 0usize);
    for samples in samples::motion_samples(&seg.spans, col) {
        for v in samples {
            acc += sq(*v);
            count += 1;
        }
    }
    let motion_rms = (acc / count.max(1) as f64).sqrt();
    if spread > 0.5 * motion_rms {
        return Err(GyroError::GyroLooksLikeGravity {
            columns: columns.join(","),
            spread,
            motion_rms,
        });
    }
    Ok(())
}

/// Refuses gyro columns that read nothing: an axis with one value on every row (all zeros from
/// a gyro that was never enabled, a column the logger leaves empty) cannot be integrated, and
/// saying so is clearer than what the fit would say later. The accelerometer's mean magnitude
/// is quoted so that the sentence shows the other sensor was working.
pub(super) fn check_gyro_reads(imu: &Imu<'_, impl RowSource>, default_rate_hz: f64) -> Result<()> {
    let Some(r) = samples::reads(imu, default_rate_hz)? else {
        return Ok(());
    };
    let n = imu.len().max(1) as f64;
    let columns = imu.gyro_columns();
    Err(GyroError::GyroReadsNothing {
        columns: r
            .dead
            .iter()
            .map(|&a| columns[a].clone())
            .collect::<Vec<_>>()
            .join(", "),
        value: r.first[r.dead[0]],
        rows: imu.len(),
        accel_norm: r.acc_norm_sum / n,
    })
}

/// After the accelerometer's stages failed on `imu` (or the gyro turned out to move with
/// gravity): whether the two recordings were given in swapped order, i.e. the "gyro" has the
/// poses of an accelerometer and the "accelerometer" passes the gyro's gravity check. Returns
/// the error that says so, or `None` (then the original error stands).
pub(super) fn swapped(imu: &Imu<'_, impl RowSource>, opts: &GyroOptions) -> Option<GyroError> {
    let as_acc = imu.swapped()?;
    let seg = segment(&as_acc, opts).ok()?;
    let col = samples::collect(
        &as_acc,
        (&seg.intervals, &seg.spans),
        0,
        opts.detect.default_rate_hz,
    )
    .ok()?;
    check_not_gravity(as_acc.gyro_columns(), &seg, &col).ok()?;
    Some(GyroError::GyroFilesSwapped {
        windows: seg.intervals.len(),
    })
}

/// A recording whose accelerometer direction moves less than this (degrees, 1-s means) never
/// turns: a still log, refused as static.
pub(super) const STATIC_TILT_DEG: f64 = 5.0;

/// The static-only refusal, when the accelerometer's 1-s means (at `rate` Hz) all point within
/// [`STATIC_TILT_DEG`] of their overall mean direction.
pub(super) fn static_only(
    imu: &Imu<'_, impl RowSource>,
    rate: f64,
    default_rate_hz: f64,
) -> Option<GyroError> {
    let block = (rate.max(1.0).round() as usize).max(1);
    let means = samples::block_directions(imu, block, default_rate_hz).ok()?;
    let all = means
        .iter()
        .sum::<nalgebra::Vector3<f64>>()
        .try_normalize(0.0)?;
    let max_tilt_deg = means
        .iter()
        .map(|m| m.angle(&all).to_degrees())
        .fold(0.0, f64::max);
    (max_tilt_deg < STATIC_TILT_DEG).then_some(GyroError::GyroStaticOnly { max_tilt_deg })
}

/// The gyro's mean at rest (the mean of the window means `means`) against the fitted bias:
/// the difference and the window means' spread (standard deviation over the windows), raw
/// counts.
pub(super) fn bias_against_rest(means: &[[f64; 3]], bias: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let n = means.len() as f64;
    let centre: [f64; 3] = std::array::from_fn(|a| means.iter().map(|m| m[a]).sum::<f64>() / n);
    let spread = std::array::from_fn(|a| {
        (means
            .iter()
            .map(|m| (m[a] - centre[a]).powi(2))
            .sum::<f64>()
            / (n - 1.0).max(1.0))
        .sqrt()
    });
    (std::array::from_fn(|a| bias[a] - centre[a]), spread)
}

/// Why the recording's timestamps cannot be integrated at one rate, if they cannot: they come
/// in bursts (the logger stamps FIFO reads, not samples, so where the samples lie in time is
/// unknown and any lost between bursts go unnoticed) or have gaps.
pub(super) fn timestamp_problem(steps: Option<TimeSteps>) -> Option<String> {
    let steps = steps?;
    if steps.bursty() {
        return Some(format!(
            "the timestamps come in bursts ({} of {} steps are gaps of more than {}× the median step): the samples' times are not known, so the motions cannot be integrated at one rate (log the sensor's own sample counter or a steady rate)",
            steps.gaps,
            steps.steps,
            crate::input::timecheck::GAP_FACTOR
        ));
    }
    None
}
