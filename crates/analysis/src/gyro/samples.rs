//! The recording as the gyro fit reads it: both sensors' samples row by row, in passes
//! ([`Imu`]), held in memory ([`Held`]) or read from a file per pass
//! ([`super::stream::Streamed`]). What the fit needs of the samples is folded here, by one
//! code for both, in sample order with the same operations as before: the gyro's mean and
//! per-sample variance over each static window (its bias at rest and its noise), the samples
//! of each motion with [`super::MOTION_MARGIN_S`] either side (the only samples the
//! fit integrates, [`Kept`]), the dead-axis check, the static-log test. So a streamed file
//! gives the held file's report bit for bit, and memory is the windows and the motions, not
//! the rows.

use super::options::Result;
use crate::detect::windows::Cover;
use crate::detect::windows::{detect_windows_untimed, DetectOptions, Windows};
use crate::input::recording::Recording;
use crate::input::timecheck::TimeSteps;
use wiical_core::gyro_fit::MotionSpan;
use wiical_core::static_detect::StaticInterval;

/// Both sensors at one instant.
#[derive(Debug, Clone, Copy)]
pub(super) struct Row {
    /// The accelerometer, as read.
    pub(super) acc: [f64; 3],
    /// The gyro, as read (raw counts).
    pub(super) gyro: [f64; 3],
    /// The time the detection gives the sample, s: the time column's, else its index over the
    /// sample rate (`Recording::times`).
    pub(super) t: f64,
    /// The temperature, when the recording has one.
    pub(super) temp: Option<f64>,
}

/// The paired recording of the two sensors as the fit passes over it.
pub(super) trait Imu: Sized {
    /// Rows (samples of each sensor).
    fn len(&self) -> usize;
    /// The sample rate the paired accelerometer recording states or its clock gives.
    fn rate_hz(&self) -> Option<f64>;
    /// The gyro's column names.
    fn gyro_columns(&self) -> &[String; 3];
    /// Every gyro value an integer (raw counts: a variance is at least 1/12 count²).
    fn gyro_is_integer(&self) -> bool;
    /// The accelerometer's static windows, as `wiical fit` finds them on the same samples.
    fn windows(&self, opts: &DetectOptions) -> Result<Windows>;
    /// The steps of the accelerometer's time column (`None` without one).
    fn time_steps(&self) -> Option<TimeSteps>;
    /// The gyro axes reading one value on every row, when known without a pass.
    fn constant_axes(&self) -> Option<Vec<usize>> {
        None
    }
    /// One pass over the rows in order, `visit(i, row)`; the clock without a time column
    /// runs at the stated rate, else `default_rate_hz`.
    fn pass(&self, default_rate_hz: f64, visit: &mut dyn FnMut(usize, &Row)) -> Result<()>;
    /// One pass over the gyro's samples only.
    fn gyro_pass(&self, visit: &mut dyn FnMut(usize, &[f64; 3])) -> Result<()>;
    /// The same rows with the two sensors' roles swapped (`None` when they cannot be paired
    /// that way).
    fn swapped(&self) -> Option<Self>;
}

/// The two recordings held in memory.
pub(super) struct Held<'a> {
    /// The accelerometer's rows that belong to the gyro's, with its clock.
    acc: Recording,
    /// The accelerometer as given.
    acc_given: &'a Recording,
    gyro: &'a Recording,
}

impl<'a> Held<'a> {
    /// The accelerometer's rows paired with the gyro's ([`super::align`]).
    pub(super) fn pair(acc: &'a Recording, gyro: &'a Recording) -> Result<Self> {
        Ok(Self {
            acc: super::align::paired_accelerometer(acc, gyro)?,
            acc_given: acc,
            gyro,
        })
    }
}

impl Imu for Held<'_> {
    fn len(&self) -> usize {
        self.acc.len()
    }

    fn rate_hz(&self) -> Option<f64> {
        self.acc.estimated_rate_hz()
    }

    fn gyro_columns(&self) -> &[String; 3] {
        &self.gyro.axis_columns
    }

    fn gyro_is_integer(&self) -> bool {
        self.gyro.is_integer()
    }

    fn windows(&self, opts: &DetectOptions) -> Result<Windows> {
        Ok(detect_windows_untimed(&self.acc, opts)?)
    }

    fn time_steps(&self) -> Option<TimeSteps> {
        TimeSteps::of(self.acc.t.as_deref()?)
    }

    fn pass(&self, default_rate_hz: f64, visit: &mut dyn FnMut(usize, &Row)) -> Result<()> {
        let fs = self.acc.sample_rate_hz.unwrap_or(default_rate_hz);
        let (t, temp) = (self.acc.t.as_deref(), self.acc.temp.as_deref());
        for (i, (acc, gyro)) in self.acc.xyz.iter().zip(&self.gyro.xyz).enumerate() {
            let row = Row {
                acc: *acc,
                gyro: *gyro,
                t: t.map_or(i as f64 / fs, |t| t[i]),
                temp: temp.map(|t| t[i]),
            };
            visit(i, &row);
        }
        Ok(())
    }

    fn gyro_pass(&self, visit: &mut dyn FnMut(usize, &[f64; 3])) -> Result<()> {
        self.gyro
            .xyz
            .iter()
            .enumerate()
            .for_each(|(i, g)| visit(i, g));
        Ok(())
    }

    fn swapped(&self) -> Option<Self> {
        Held::pair(self.gyro, self.acc_given).ok()
    }
}

/// The sum `Iterator::sum` starts from, so that sums folded by hand are `sum()`'s bit for bit.
fn sum_start() -> f64 {
    std::iter::empty::<f64>().sum()
}

/// One motion's samples and [`super::MOTION_MARGIN_S`] either side: what the fit integrates
/// and the motion candidates shift, with what their correction needs.
#[derive(Debug, Clone, Default)]
pub(super) struct Kept {
    /// Row of the first sample kept.
    pub(super) lo: usize,
    /// The gyro, raw counts.
    pub(super) gyro: Vec<[f64; 3]>,
    /// The accelerometer, as read.
    pub(super) acc: Vec<[f64; 3]>,
    /// Times, s (the detection's clock).
    pub(super) t: Vec<f64>,
    /// Temperatures (empty without a temperature).
    pub(super) temp: Vec<f64>,
}

impl Kept {
    fn push(&mut self, r: &Row) {
        self.gyro.push(r.gyro);
        self.acc.push(r.acc);
        self.t.push(r.t);
        if let Some(x) = r.temp {
            self.temp.push(x);
        }
    }
}

/// What one pass over the rows gives for a segmentation: the gyro's window means and the
/// motions' samples.
#[derive(Debug, Clone)]
pub(super) struct Collected {
    /// Per static window, the gyro's mean, raw counts (its bias at rest in that pose).
    pub(super) window_mean: Vec<[f64; 3]>,
    /// Per motion, its samples with the margin.
    pub(super) kept: Vec<Kept>,
    /// Whether the rows carry a temperature.
    pub(super) has_temp: bool,
}

impl Collected {
    /// Motion `m`'s kept samples and the index of row `j` in them.
    pub(super) fn at(&self, m: usize, j: usize) -> (&Kept, usize) {
        let k = &self.kept[m];
        (k, j - k.lo)
    }

    /// The time of row `j` of motion `m`, s.
    pub(super) fn time(&self, m: usize, j: usize) -> f64 {
        let (k, i) = self.at(m, j);
        k.t.get(i).copied().unwrap_or(f64::NAN)
    }
}

/// The sample ranges `(first, one past the last)` of the static windows.
fn window_ranges(intervals: &[StaticInterval]) -> Vec<(usize, usize)> {
    intervals
        .iter()
        .map(|iv| (iv.start as usize, iv.end as usize))
        .collect()
}

/// One pass over `imu`: the gyro's mean over each static window of `intervals` and the
/// samples of each motion of `spans` with `margin` rows either side; a pass that ended early
/// (a file changed while read) is an error.
pub(super) fn collect(
    imu: &impl Imu,
    (intervals, spans): (&[StaticInterval], &[MotionSpan]),
    margin: usize,
    default_rate_hz: f64,
) -> Result<Collected> {
    let n = imu.len();
    let windows = window_ranges(intervals);
    let ranges: Vec<(usize, usize)> = spans
        .iter()
        .map(|s| {
            let lo = (s.start as usize).saturating_sub(margin);
            (lo, (s.end as usize + margin).min(n))
        })
        .collect();
    let samples: usize = ranges.iter().map(|(lo, hi)| hi - lo).sum();
    let limit = crate::input::front_door::MAX_HELD_SAMPLES;
    if samples > limit {
        return Err(crate::error::gyro::GyroError::GyroMotionsTooLong { samples, limit });
    }
    let zero = sum_start();
    let mut sums = vec![[zero; 3]; windows.len()];
    let mut kept: Vec<Kept> = ranges
        .iter()
        .map(|&(lo, _)| Kept {
            lo,
            ..Default::default()
        })
        .collect();
    let (mut wc, mut kc) = (Cover::new(&windows), Cover::new(&ranges));
    let mut has_temp = false;
    imu.pass(default_rate_hz, &mut |i, row| {
        for &k in wc.at(i) {
            for (s, g) in sums[k].iter_mut().zip(&row.gyro) {
                *s += g;
            }
        }
        for &k in kc.at(i) {
            kept[k].push(row);
        }
        has_temp = row.temp.is_some();
    })?;
    let whole = kept
        .iter()
        .zip(&ranges)
        .all(|(k, (lo, hi))| k.gyro.len() == hi - lo);
    if !whole {
        return Err(ended_early());
    }
    let window_mean = sums
        .iter()
        .zip(&windows)
        .map(|(s, (a, b))| {
            let n = (b - a) as f64;
            s.map(|v| v / n)
        })
        .collect();
    Ok(Collected {
        window_mean,
        kept,
        has_temp,
    })
}

/// The gyro's per-sample variance over each static window, raw counts² per axis (sum of
/// squared deviations from the window's `means` over n − 1), in a pass over the gyro.
pub(super) fn window_variances(
    imu: &impl Imu,
    intervals: &[StaticInterval],
    means: &[[f64; 3]],
) -> Result<Vec<[f64; 3]>> {
    let windows = window_ranges(intervals);
    let zero = sum_start();
    let mut sq = vec![[zero; 3]; windows.len()];
    let mut cover = Cover::new(&windows);
    imu.gyro_pass(&mut |i, g| {
        for &k in cover.at(i) {
            for ((q, x), m) in sq[k].iter_mut().zip(g).zip(&means[k]) {
                *q += (x - m).powi(2);
            }
        }
    })?;
    Ok(sq
        .iter()
        .zip(&windows)
        .map(|(q, (a, b))| {
            let n = (b - a).max(2) as f64;
            q.map(|v| v / (n - 1.0))
        })
        .collect())
}

/// Gyro axes with one value on every row, the first row's gyro and the accelerometer's mean
/// magnitude (its sum over the rows in order): [`super::segment::check_gyro_reads`]'s numbers.
pub(super) struct Reads {
    pub(super) dead: Vec<usize>,
    pub(super) first: [f64; 3],
    pub(super) acc_norm_sum: f64,
}

/// [`Reads`] in a pass over the rows; `None` when no axis is constant (known without a pass
/// when `imu` knows it).
pub(super) fn reads(imu: &impl Imu, default_rate_hz: f64) -> Result<Option<Reads>> {
    if imu.constant_axes().is_some_and(|d| d.is_empty()) {
        return Ok(None);
    }
    let mut first = None;
    let mut same = [true; 3];
    let mut acc_norm_sum = sum_start();
    imu.pass(default_rate_hz, &mut |_, r| {
        let f = *first.get_or_insert(r.gyro);
        for (s, (v, f)) in same.iter_mut().zip(r.gyro.iter().zip(&f)) {
            *s &= v == f;
        }
        let a = r.acc;
        acc_norm_sum += (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    })?;
    let dead: Vec<usize> = (0..3).filter(|&a| same[a]).collect();
    Ok((!dead.is_empty()).then(|| Reads {
        dead,
        first: first.unwrap_or([0.0; 3]),
        acc_norm_sum,
    }))
}

/// The accelerometer's mean direction over each block of `block` rows (the last one
/// possibly shorter), those that have one, in a pass.
pub(super) fn block_directions(
    imu: &impl Imu,
    block: usize,
    default_rate_hz: f64,
) -> Result<Vec<nalgebra::Vector3<f64>>> {
    let mut out = Vec::new();
    let (mut sum, mut count) = (nalgebra::Vector3::zeros(), 0usize);
    imu.pass(default_rate_hz, &mut |_, r| {
        sum += nalgebra::Vector3::from(r.acc);
        count += 1;
        if count == block {
            out.extend(sum.try_normalize(0.0));
            (sum, count) = (nalgebra::Vector3::zeros(), 0);
        }
    })?;
    if count > 0 {
        out.extend(sum.try_normalize(0.0));
    }
    Ok(out)
}

/// The gyro's samples of every motion of `spans` (raw counts), from what `col` kept.
pub(super) fn motion_samples<'c>(
    spans: &[MotionSpan],
    col: &'c Collected,
) -> impl Iterator<Item = &'c [[f64; 3]]> + 'c {
    let spans: Vec<(usize, usize)> = spans
        .iter()
        .map(|s| (s.start as usize, s.end as usize))
        .collect();
    col.kept
        .iter()
        .zip(spans)
        .map(|(k, (s, e))| &k.gyro[s - k.lo..e - k.lo])
}

/// Stands in for the error of a pass that ended early (a file changed or unreadable while
/// read): the streamed run returns the file's own error, which its source keeps, instead.
pub(super) fn ended_early() -> super::options::GyroError {
    super::options::GyroError::GyroFitFailed(wiical_core::Error::InvalidParameter)
}
