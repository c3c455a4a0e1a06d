//! One sensor of a still recording through `wiical noise`'s folds, whatever holds its samples
//! ([`SampleSource`]: a held recording's slice, or a large file's rows read in passes): the
//! held and the large-file path are this one code, and differ only in how many overlapping
//! Allan clusters a long cluster size keeps ([`Overlap`]).
//!
//! **The Allan deviation ([`AllanStream`]).** The overlapping estimator of
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
use crate::noise::allan::{AllanCurve, MIN_CLUSTERS};
use crate::noise::still::{decide_still, scatter_of, window_of, CounterFold};
use crate::source::SampleSource;
use crate::stats::OrderCounts;
use std::collections::VecDeque;

/// Largest cluster size (samples) at which every overlapping cluster is used; beyond it the
/// cluster starts step by `m / FULL_OVERLAP_M` (module docs). 2¹³: 16 385 values of θ per
/// octave at most (128 KiB), and every point up to τ = 82 s at 100 Hz is the held one.
pub const FULL_OVERLAP_M: usize = 1 << 13;

/// Most distinct |first differences| per axis counted by value before the median is selected
/// by bits instead (2¹⁸ keys: ~10 MB per axis at most).
pub const MAX_COUNTED_STEPS: usize = 1 << 18;

/// One octave's running sum.
#[derive(Debug)]
struct Octave {
    /// Cluster size, samples.
    m: usize,
    /// Step between the cluster starts used (1 up to the full-overlap size).
    stride: usize,
    /// θ at the last `2m/stride + 1` multiples of the stride; empty for a stride of 1, whose
    /// octaves read the stream's shared ring of recent θ instead.
    ring: VecDeque<f64>,
    sum: f64,
    terms: usize,
}

/// The overlapping Allan deviation of one axis, fed sample by sample (module docs).
#[derive(Debug)]
pub struct AllanStream {
    tau0: f64,
    n: usize,
    pushed: usize,
    theta: f64,
    octaves: Vec<Octave>,
    /// θ of the recent samples, indexed by the sample number masked by `mask` (a power of two
    /// of at least `2m + BLOCK` for the widest octave with a stride of 1): the fully
    /// overlapping octaves read their three values from it.
    recent: Vec<f64>,
    mask: usize,
    /// Samples pushed but not yet summed by the fully overlapping octaves: they are summed a
    /// block at a time, octave by octave, so that each octave walks the ring in order (per
    /// sample and octave, the ring's far ends missed the cache: 35 % of `noise`'s time).
    pending: usize,
}

/// Samples summed at once by the fully overlapping octaves ([`AllanStream::pending`]).
const BLOCK: usize = 4096;

impl AllanStream {
    /// A stream for `n` samples at `rate_hz`, with full overlap up to `full_m` samples.
    pub fn new(n: usize, rate_hz: f64, full_m: usize) -> Self {
        let mut octaves = Vec::new();
        let mut m = 1usize;
        let mut widest_full = 0;
        // The held path's octaves: τ doubles while at least MIN_CLUSTERS clusters remain.
        while n / m >= MIN_CLUSTERS && 2 * m <= n {
            let stride = (m / full_m.max(1)).max(1);
            let mut ring = VecDeque::new();
            if stride == 1 {
                widest_full = m;
            } else {
                ring.reserve(2 * m / stride + 1);
                ring.push_back(0.0); // θ₀
            }
            octaves.push(Octave {
                m,
                stride,
                ring,
                sum: 0.0,
                terms: 0,
            });
            m *= 2;
        }
        // θ₀ = 0 sits at index 0 of the zeroed ring.
        let len = (2 * widest_full + BLOCK + 1).next_power_of_two();
        Self {
            tau0: 1.0 / rate_hz,
            n,
            pushed: 0,
            theta: 0.0,
            octaves,
            recent: vec![0.0; len],
            mask: len - 1,
            pending: 0,
        }
    }

    /// The next sample.
    pub fn push(&mut self, y: f64) {
        self.theta += y * self.tau0;
        self.pushed += 1;
        let (i, theta) = (self.pushed, self.theta);
        self.recent[i & self.mask] = theta;
        self.pending += 1;
        if self.pending == BLOCK {
            self.sum_pending();
        }
        for o in self.octaves.iter_mut().filter(|o| o.stride > 1) {
            if i % o.stride != 0 {
                continue;
            }
            let span = 2 * o.m / o.stride;
            if o.ring.len() > span {
                o.ring.pop_front();
            }
            o.ring.push_back(theta);
            if o.ring.len() == span + 1 {
                let d = o.ring[span] - 2.0 * o.ring[span / 2] + o.ring[0];
                o.sum += d * d;
                o.terms += 1;
            }
        }
    }

    /// The pending samples summed by every fully overlapping octave, in sample order.
    fn sum_pending(&mut self) {
        let (r, mask) = (&self.recent, self.mask);
        let last = self.pushed;
        let first = last + 1 - self.pending;
        for o in self.octaves.iter_mut().filter(|o| o.stride == 1) {
            let m = o.m;
            let mut i = first.max(2 * m);
            // In runs where none of θᵢ, θᵢ₋ₘ, θᵢ₋₂ₘ wraps round the ring: three slices
            // walked together, summed in sample order.
            while i <= last {
                let at = [i & mask, (i - m) & mask, (i - 2 * m) & mask];
                let run = at.iter().fold(last + 1 - i, |n, a| n.min(r.len() - a));
                let (now, mid, old) = (
                    &r[at[0]..at[0] + run],
                    &r[at[1]..at[1] + run],
                    &r[at[2]..at[2] + run],
                );
                for ((x, y), z) in now.iter().zip(mid).zip(old) {
                    let d = x - 2.0 * y + z;
                    o.sum += d * d;
                }
                o.terms += run;
                i += run;
            }
        }
        self.pending = 0;
    }

    /// The curve, as [`crate::noise::allan::overlapping_adev`] lays it out (the uncertainty
    /// of each point is the held path's formula).
    pub fn finish(mut self) -> AllanCurve {
        if self.pending > 0 {
            self.sum_pending();
        }
        let n = self.pushed.min(self.n);
        let mut curve = AllanCurve::default();
        for o in self.octaves.iter().filter(|o| o.terms > 0) {
            let tau = o.m as f64 * self.tau0;
            curve.tau_s.push(tau);
            curve
                .adev
                .push((o.sum / (2.0 * tau * tau * o.terms as f64)).sqrt());
            curve
                .adev_rel_err
                .push(1.0 / (2.0 * ((n / o.m) as f64 - 1.0)).sqrt());
        }
        curve
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::allan::overlapping_adev;

    /// With a small `full_m` the strided points are the fully overlapping ones up to it bit
    /// for bit, and within a fraction of their uncertainty beyond.
    #[test]
    fn the_strided_stream_is_near_the_full_one() {
        let y: Vec<f64> = (0..5000)
            .map(|i| ((i * 7919 % 104_729) as f64).sin() + (i as f64 * 1e-3).cos())
            .collect();
        let held = overlapping_adev(&y, 50.0);
        let run = |full_m: usize| {
            let mut s = AllanStream::new(y.len(), 50.0, full_m);
            y.iter().for_each(|v| s.push(*v));
            s.finish()
        };
        let strided = run(8);
        assert_eq!(strided.tau_s, held.tau_s);
        assert_eq!(strided.adev_rel_err, held.adev_rel_err);
        for i in 0..held.adev.len() {
            let rel = strided.adev[i] / held.adev[i] - 1.0;
            if held.tau_s[i] * 50.0 <= 8.0 {
                assert_eq!(strided.adev[i], held.adev[i]);
            }
            assert!(rel.abs() < 0.5 * held.adev_rel_err[i], "{i}: {rel}");
        }
    }
}
