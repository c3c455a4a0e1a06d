//! One sensor of a still recording through `wiical noise`'s folds, whatever holds its samples
//! ([`SampleSource`]: a held recording's slice, or a large file's rows read in passes): the
//! held and the large-file path are this one code, and differ only in how many overlapping
//! Allan clusters a long cluster size keeps ([`Overlap`]).
//!
//! **The Allan deviation ([`AllanStream`], [`crate::noise::allan`]).** The overlapping estimator of
//! [`crate::noise::allan::overlapping_adev`] needs `θₖ`, `θ_{k+m}` and `θ_{k+2m}` together: a
//! stream keeps the last `2m + 1` values of `θ` per octave. Held samples use every `k` at every
//! octave (memory of the order of the samples, as holding them takes anyway): the estimator
//! itself (`overlapping_adev` is this stream fed from a slice). A file read in passes uses
//! every `k` up to `m = FULL_OVERLAP_M` samples (those points are the held ones bit for bit);
//! beyond, `k` steps by `m / FULL_OVERLAP_M` (still `FULL_OVERLAP_M` cluster starts per
//! `m`, where fully overlapping has `m`): memory `2·FULL_OVERLAP_M + 1` values per octave. The
//! point's estimate then differs from the fully overlapping one by a small fraction of its
//! uncertainty (`adev_rel_err`, which is kept as the held path's): overlapping clusters whose
//! starts are `s ≪ m` apart are nearly the same cluster, so leaving them out loses almost no
//! information (tested against the held path on simulated white noise and random walk).
//!
//! **The stillness checks** of [`crate::noise::still`] from the same pass: the constant-axis
//! and counter checks, the 1-s window means (one per window: a week at 100 Hz is 604 800), the
//! accelerometer mean, and the median |first difference| per axis exactly as a sort gives it —
//! counted by value while there are few distinct values (quantised data: a handful), else
//! selected by its bits (`OrderCounts`) in a few more passes.
//!
//! **Polling** ([`crate::detect::polled`]): the runs of identical samples are counted in the
//! same pass; a log polled faster than its sensor updates gets its curves from a second pass
//! over its distinct samples, at the sensor's own rate.

use crate::detect::polled::{judge, Polling, Runs};
use crate::error::noise::NoiseError;
use crate::error::Result;
use crate::input::columns::Sensor;
use crate::input::timecheck::TimeSteps;
use crate::noise::allan::{AllanCurve, AllanStream};
use crate::noise::still::{decide_still, scatter_of, window_of, CounterFold};
use crate::source::SampleSource;
use crate::stats::OrderCounts;

/// Largest cluster size (samples) at which every overlapping cluster is used; beyond it the
/// cluster starts step by `m / FULL_OVERLAP_M` (module docs). 2¹³: 16 385 values of θ per
/// octave at most (128 KiB), and every point up to τ = 82 s at 100 Hz is the held one.
pub const FULL_OVERLAP_M: usize = 1 << 13;

/// Most distinct |first differences| per axis counted by value before the median is selected
/// by bits instead (2¹⁸ keys: ~10 MB per axis at most).
pub const MAX_COUNTED_STEPS: usize = 1 << 18;

/// |First differences| of one axis counted for their median (module docs).
#[derive(Debug)]
struct StepCounts {
    /// Counted by their bits (non-negative floats order as their bits).
    order: OrderCounts,
    sum_sq: f64,
    count: usize,
}

impl StepCounts {
    fn new() -> Self {
        Self {
            order: OrderCounts::new(MAX_COUNTED_STEPS),
            sum_sq: 0.0,
            count: 0,
        }
    }

    fn push(&mut self, d: f64) {
        self.sum_sq += d * d;
        self.count += 1;
        self.order.push(d.to_bits());
    }
}

/// How many of the overlapping Allan clusters a long cluster size keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Overlap {
    /// Every cluster at every size: the estimator of `overlapping_adev` bit for bit (held
    /// samples: its rings hold about two values per sample and axis).
    Full,
    /// Every cluster up to [`FULL_OVERLAP_M`] samples, every `(m/FULL_OVERLAP_M)`-th beyond
    /// (a file read in passes: memory bounded whatever its length).
    Bounded,
}

impl Overlap {
    /// The largest cluster size whose every cluster is used.
    fn full_m(self) -> usize {
        match self {
            Overlap::Full => usize::MAX,
            Overlap::Bounded => FULL_OVERLAP_M,
        }
    }
}

/// One sensor's samples and what is known of them besides.
pub struct SensorSamples<'a, S: SampleSource + ?Sized> {
    /// The samples, read in as many passes as the checks need.
    pub samples: &'a S,
    /// Their number.
    pub len: usize,
    /// The three columns (named in refusals).
    pub columns: &'a [String; 3],
    /// The time column's steps, when there is one (the evenness check).
    pub steps: Option<TimeSteps>,
    /// How many overlapping clusters the curves keep.
    pub overlap: Overlap,
}

/// Everything one pass over a sensor's samples gives.
struct SensorFold {
    allan: [AllanStream; 3],
    first: Option<[f64; 3]>,
    varies: [bool; 3],
    win: usize,
    in_win: usize,
    win_sum: [f64; 3],
    means: Vec<[f64; 3]>,
    total: [f64; 3],
    prev: Option<[f64; 3]>,
    steps: [StepCounts; 3],
    counters: CounterFold,
    runs: Runs,
}

impl SensorFold {
    fn new(n: usize, rate_hz: f64, overlap: Overlap) -> Self {
        Self {
            allan: std::array::from_fn(|_| AllanStream::new(n, rate_hz, overlap.full_m())),
            first: None,
            varies: [false; 3],
            win: window_of(rate_hz, n),
            in_win: 0,
            win_sum: [0.0; 3],
            means: Vec::new(),
            total: [0.0; 3],
            prev: None,
            steps: std::array::from_fn(|_| StepCounts::new()),
            counters: CounterFold::default(),
            runs: Runs::default(),
        }
    }

    fn push(&mut self, v: [f64; 3]) {
        let first = *self.first.get_or_insert(v);
        for a in 0..3 {
            self.allan[a].push(v[a]);
            self.varies[a] |= v[a] != first[a];
            self.win_sum[a] += v[a];
            self.total[a] += v[a];
        }
        self.counters.push(v);
        self.runs.push(&v, &[0.0; 3]);
        self.in_win += 1;
        if self.in_win == self.win {
            let w = self.win as f64;
            self.means.push(self.win_sum.map(|s| s / w));
            (self.in_win, self.win_sum) = (0, [0.0; 3]);
        }
        if let Some(p) = self.prev.replace(v) {
            for a in 0..3 {
                self.steps[a].push((v[a] - p[a]).abs());
            }
        }
    }
}

/// The median |first difference| of each axis, as `crate::stats::median` of them gives it:
/// from the counts by value, else selected by their bits in passes over `src`
/// ([`OrderCounts::median`]).
fn median_steps(src: &(impl SampleSource + ?Sized), steps: &[StepCounts; 3]) -> Result<[f64; 3]> {
    let mut out = [0.0; 3];
    for (a, counts) in steps.iter().enumerate() {
        out[a] = counts.order.median(f64::from_bits, |key| {
            let mut prev: Option<f64> = None;
            src.each(&mut |v| {
                if let Some(p) = prev.replace(v[a]) {
                    key((v[a] - p).abs().to_bits());
                }
            })
        })?;
    }
    Ok(out)
}

/// One sensor's noise: its three curves, its mean, and how it was polled when it was.
pub struct SensorNoise {
    /// Each axis's curve (of the distinct samples at the sensor's rate when polled).
    pub curves: [AllanCurve; 3],
    /// The mean of each axis (the accelerometer's unit is read off its magnitude).
    pub mean: [f64; 3],
    /// The log was polled faster than the sensor updates.
    pub polling: Option<Polling>,
}

/// One pass over the samples (a few more for a median step of data with many distinct steps,
/// one more for a polled log): the curves, after the checks of [`crate::noise::still`]
/// (constant or counter axis, motion, uneven time), refused in their sentences.
pub fn sensor_noise<S: SampleSource + ?Sized>(
    input: &SensorSamples<'_, S>,
    sensor: Sensor,
    rate_hz: f64,
) -> Result<SensorNoise> {
    let (src, n, columns) = (input.samples, input.len, input.columns);
    let mut fold = SensorFold::new(n, rate_hz, input.overlap);
    src.each(&mut |v| fold.push(*v))?;
    fold.runs.close();
    for a in 0..3 {
        if !fold.varies[a] {
            return Err(NoiseError::ConstantAxis {
                column: columns[a].clone(),
                value: fold.first.map_or(0.0, |v| v[a]),
            }
            .into());
        }
    }
    fold.counters.verdict(columns)?;
    if fold.means.len() >= 2 {
        let median = median_steps(src, &fold.steps)?;
        let per_axis = (0..3).map(|a| {
            let s = &fold.steps[a];
            // The RMS step serves only where the median step is 0 (quantised, quiet data).
            let rms = if s.count == 0 || median[a] > 0.0 {
                0.0
            } else {
                (s.sum_sq / s.count as f64).sqrt()
            };
            (median[a], rms)
        });
        let scatter = scatter_of(per_axis, fold.win);
        decide_still(&fold.means, scatter, columns, sensor, input.steps)?;
    }
    let polling = judge(&[&fold.runs], n, n as f64 / rate_hz);
    let curves = match &polling {
        Some(p) => distinct_curves(src, p, input.overlap)?,
        None => fold.allan.map(|s| s.finish()),
    };
    let nf = n.max(1) as f64;
    Ok(SensorNoise {
        curves,
        mean: fold.total.map(|s| s / nf),
        polling,
    })
}

/// The curves of a polled log's distinct samples (each run's first) at the sensor's own rate.
fn distinct_curves(
    src: &(impl SampleSource + ?Sized),
    polling: &Polling,
    overlap: Overlap,
) -> Result<[AllanCurve; 3]> {
    let mut allan: [AllanStream; 3] = std::array::from_fn(|_| {
        AllanStream::new(polling.distinct, polling.sensor_hz, overlap.full_m())
    });
    let mut prev: Option<[f64; 3]> = None;
    src.each(&mut |v| {
        if prev.as_ref() != Some(v) {
            prev = Some(*v);
            (0..3).for_each(|a| allan[a].push(v[a]));
        }
    })?;
    Ok(allan.map(|s| s.finish()))
}
