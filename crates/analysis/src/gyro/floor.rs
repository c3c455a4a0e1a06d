//! The gyro's noise floor, measured from the recording itself: what angle error a perfect
//! calibration would still leave on each motion, given the gyro's own noise in the static
//! windows and the accelerometer's tilt noise at the motion's two ends.
//!
//! Per motion of duration `T` sampled every `dt`, with `σω²` the gyro's per-sample variance
//! (rad/s)² at rest (mean over the axes, through the calibration `K`) and `n₀` the samples of
//! the first window (the uncalibrated bias is its mean):
//!
//! * white rate noise integrates to an angle random walk, variance `σω²·dt·T` per axis;
//! * the bias taken from a window mean is off by `σω/√n₀`, i.e. `σω²·T²/n₀` per axis;
//! * each end's gravity direction is a window mean of the accelerometer: tilt variance
//!   `σa²/(n·g²)` per axis, `σa²` through the accelerometer's calibration.
//!
//! The reported angle is between two unit vectors, so two axes (those across gravity) count:
//! the expected squared angle is twice the per-axis sum. Integer (counted) data never read a
//! variance below the quantisation's 1/12 count², so that is the least taken.

use super::segment::Segmentation;

/// Per-sample variance of the gyro over one window, raw counts² per axis: `var` (from
/// [`super::samples::window_variances`]) floored at `quantum`.
fn gyro_variance(var: &[f64; 3], quantum: f64) -> [f64; 3] {
    var.map(|v| v.max(quantum))
}

/// Mean over the axes of `K·diag(var)·Kᵀ`'s diagonal: the per-axis rate variance in the
/// calibrated frame, (rad/s)² (or g² for the accelerometer).
fn through(k: &[[f64; 3]; 3], var: [f64; 3]) -> f64 {
    (0..3)
        .map(|r| (0..3).map(|c| k[r][c].powi(2) * var[c]).sum::<f64>())
        .sum::<f64>()
        / 3.0
}

/// The floors of one recording.
#[derive(Debug, Clone)]
pub struct Floors {
    /// Expected RMS angle error of each motion under a right calibration, rad.
    pub motion_rad: Vec<f64>,
    /// Per window and axis: the variance of the gyro's window mean, (rad/s)² (what the
    /// static-window candidates' residuals cannot go below).
    pub window_mean_var: Vec<[f64; 3]>,
    /// RMS over the windows of the gyro's per-sample noise, rad/s.
    pub rate_noise: f64,
}

/// The floors for the gyro's per-sample variance `var` in each window of the segmentation
/// `seg` (raw counts², [`super::samples::window_variances`]; `integer`: the gyro reads whole
/// counts), the gyro calibration `k` (raw → rad/s), sampling step `dt` (s).
pub(super) fn floors(
    var: &[[f64; 3]],
    integer: bool,
    seg: &Segmentation,
    k: &[[f64; 3]; 3],
    dt: f64,
) -> Floors {
    let quantum = if integer { 1.0 / 12.0 } else { 0.0 };
    let gyro_var: Vec<f64> = var
        .iter()
        .map(|v| through(k, gyro_variance(v, quantum)))
        .collect();
    let acc_k: [[f64; 3]; 3] = seg.accel.matrix.map(|r| r.map(f64::from));
    let acc_quantum = if seg
        .windows
        .iter()
        .all(|w| w.mean.iter().all(|m| m.fract() == 0.0))
    {
        1.0 / 12.0
    } else {
        0.0
    };
    let gravity = seg.gravity();
    let tilt_var: Vec<f64> = seg
        .windows
        .iter()
        .zip(&gravity)
        .map(|(w, g)| {
            let n = (w.end - w.start).max(1) as f64;
            let g2 = g.iter().map(|x| x * x).sum::<f64>().max(1e-300);
            through(&acc_k, w.var.map(|v| v.max(acc_quantum))) / (n * g2)
        })
        .collect();
    let n0 = (seg.windows[0].end - seg.windows[0].start).max(1) as f64;
    let motion_rad = seg
        .spans
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let t = f64::from(s.end - s.start) * dt;
            let rate_var = 0.5 * (gyro_var[i] + gyro_var[i + 1]);
            let per_axis =
                rate_var * dt * t + rate_var * t * t / n0 + tilt_var[i] + tilt_var[i + 1];
            (2.0 * per_axis).sqrt()
        })
        .collect();
    let window_mean_var = seg
        .windows
        .iter()
        .zip(var)
        .map(|(w, v)| {
            let n = (w.end - w.start).max(1) as f64;
            let v = gyro_variance(v, quantum);
            std::array::from_fn(|r| (0..3).map(|c| k[r][c].powi(2) * v[c]).sum::<f64>() / n)
        })
        .collect();
    let rate_noise = (gyro_var.iter().sum::<f64>() / gyro_var.len().max(1) as f64).sqrt();
    Floors {
        motion_rad,
        window_mean_var,
        rate_noise,
    }
}
