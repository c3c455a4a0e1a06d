//! The recording as the gyro fit reads it: both sensors' rows paired ([`Imu`]), each a
//! [`RowSource`] (held in memory: one chunk read in place; a large text file: read in passes),
//! read by one code. What the fit needs of the samples is folded here in sample order: the
//! gyro's mean and per-sample variance over each static window (its bias at rest and its
//! noise), the samples of each motion with [`super::MOTION_MARGIN_S`] either side (the only
//! samples the fit integrates, [`Kept`]), the dead-axis check, the static-log test. So a large
//! file gives the held file's report bit for bit, and memory is the windows and the motions,
//! not the rows.

use super::options::{GyroError, Result};
use crate::detect::windows::{detect_windows, sample_clock, Cover, DetectOptions, Windows};
use crate::error::Error;
use crate::input::timecheck::TimeSteps;
use crate::source::RowSource;
use std::cell::RefCell;
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

/// The paired recording of the two sensors as the fit passes over it: the accelerometer's
/// rows and the gyro's of the same samples, row by row.
pub(super) struct Imu<'a, R> {
    acc: &'a R,
    gyro: &'a R,
    /// The largest difference between the two time columns on one row, s (0 without both,
    /// [`clocks`]); `None` when the rows were paired by their times (a subset of the
    /// accelerometer's), which does not pair the other way round.
    worst_clock_s: Option<f64>,
    /// A source's failure (a file changed or unreadable) that the detection found, kept for
    /// the caller: the check that finds it clears it.
    failed: &'a RefCell<Option<Error>>,
}

impl<'a, R: RowSource> Imu<'a, R> {
    /// The accelerometer's rows `acc` and the gyro's `gyro`, the same samples in order.
    pub(super) fn new(
        (acc, gyro): (&'a R, &'a R),
        worst_clock_s: Option<f64>,
        failed: &'a RefCell<Option<Error>>,
    ) -> Self {
        Self {
            acc,
            gyro,
            worst_clock_s,
            failed,
        }
    }

    /// Rows (samples of each sensor).
    pub(super) fn len(&self) -> usize {
        self.acc.len()
    }

    /// The sample rate the accelerometer's rows state or their clock gives.
    pub(super) fn rate_hz(&self) -> Option<f64> {
        self.acc.estimated_rate_hz()
    }

    /// The gyro's column names.
    pub(super) fn gyro_columns(&self) -> &[String; 3] {
        self.gyro.axis_columns()
    }

    /// Every gyro value an integer (raw counts: a variance is at least 1/12 count²).
    pub(super) fn gyro_is_integer(&self) -> bool {
        self.gyro.integer()
    }

    /// The accelerometer's static windows, as `wiical fit` finds them on the same samples; a
    /// pass that ended early keeps the file's error for the caller.
    pub(super) fn windows(&self, opts: &DetectOptions) -> Result<Windows> {
        let found = detect_windows(self.acc, opts);
        if let Err(e) = self.acc.check() {
            self.failed.borrow_mut().get_or_insert(e);
            return Err(ended_early());
        }
        Ok(found?)
    }

    /// The steps of the accelerometer's time column (`None` without one).
    pub(super) fn time_steps(&self) -> Option<TimeSteps> {
        self.acc.time_steps()
    }

    /// One pass over the rows in order, `visit(i, row)`; the clock without a time column
    /// runs at the stated rate, else `default_rate_hz` (the detection's [`sample_clock`]).
    pub(super) fn pass(
        &self,
        default_rate_hz: f64,
        visit: &mut dyn FnMut(usize, &Row),
    ) -> Result<()> {
        let opts = DetectOptions {
            default_rate_hz,
            ..Default::default()
        };
        let clock = sample_clock(self.acc, &opts);
        let mut rows = 0;
        for (i, (a, g)) in self.acc.rows().zip(self.gyro.rows()).enumerate() {
            let row = Row {
                acc: a.xyz,
                gyro: g.xyz,
                t: clock(a.t, i),
                temp: a.temp,
            };
            visit(i, &row);
            rows += 1;
        }
        self.whole(rows)
    }

    /// One pass over the gyro's samples only.
    pub(super) fn gyro_pass(&self, visit: &mut dyn FnMut(usize, &[f64; 3])) -> Result<()> {
        let mut rows = 0;
        for (i, g) in self.gyro.rows().enumerate() {
            visit(i, &g.xyz);
            rows += 1;
        }
        self.whole(rows)
    }

    /// Counts a pass's rows: short of the rows, the pass ended early.
    fn whole(&self, rows: usize) -> Result<()> {
        if rows == self.len() {
            Ok(())
        } else {
            Err(ended_early())
        }
    }

    /// The same rows with the two sensors' roles swapped; `None` when the rows were paired by
    /// time or the clocks differ by more than the gyro's [`clock_tolerance`].
    pub(super) fn swapped(&self) -> Option<Self> {
        (self.worst_clock_s? <= clock_tolerance(self.gyro)).then_some(Self {
            acc: self.gyro,
            gyro: self.acc,
            ..*self
        })
    }
}

impl<R> Clone for Imu<'_, R> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<R> Copy for Imu<'_, R> {}

/// Half the median step of `src`'s time column, s: the most the two clocks may differ on a
/// row (infinite without a step).
fn clock_tolerance(src: &impl RowSource) -> f64 {
    0.5 * src.time_steps().map_or(f64::INFINITY, |s| s.median_s)
}

/// The largest difference of the two time columns on one row, s (0 unless both have one),
/// in a pass; refused above the accelerometer's [`clock_tolerance`]: a shifted copy of the
/// gyro log must not be paired silently.
pub(super) fn clocks<R: RowSource>(acc: &R, gyro: &R) -> Result<f64> {
    if !(acc.has_time() && gyro.has_time()) {
        return Ok(0.0);
    }
    let mut rows = 0;
    let worst = acc
        .rows()
        .zip(gyro.rows())
        .inspect(|_| rows += 1)
        .map(|(a, g)| (a.t.unwrap_or(f64::NAN) - g.t.unwrap_or(f64::NAN)).abs())
        .fold(0.0, f64::max);
    if rows != acc.len() {
        return Err(ended_early());
    }
    if worst > clock_tolerance(acc) {
        return Err(GyroError::GyroClocksDiffer { offset_s: worst });
    }
    Ok(worst)
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
    imu: &Imu<'_, impl RowSource>,
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
        return Err(GyroError::GyroMotionsTooLong { samples, limit });
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
    imu: &Imu<'_, impl RowSource>,
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
/// when the gyro's source knows it: [`RowSource::constant`]).
pub(super) fn reads(imu: &Imu<'_, impl RowSource>, default_rate_hz: f64) -> Result<Option<Reads>> {
    if imu.gyro.constant().is_some_and(|c| !c.contains(&true)) {
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
    imu: &Imu<'_, impl RowSource>,
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
/// read): the run on large files returns the file's own error, which its source keeps.
pub(super) fn ended_early() -> GyroError {
    GyroError::GyroFitFailed(wiical_core::Error::InvalidParameter)
}
