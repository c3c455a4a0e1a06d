//! Window detection and statistics in passes over samples streamed from a file
//! ([`TextSource`]: a large text file re-read per pass), never held: the same [`Windows`] as
//! [`crate::detect::windows::detect_windows`] gives for the file's recording held whole, bit
//! for bit.
//!
//! The same functions run on the same values in the same order: the detector's view (the
//! quantiser lattice from the first pass's distinct values, or the fixed detector's scale
//! from the rest period and, only when that is constant, the median ‖a‖ selected exactly in
//! passes), the core's detector over a pass per setting, the ADC range from the first pass's
//! extremes. Then two passes over the windows' samples: the first sums the means, times,
//! temperatures and batch means and checks saturation; the second, with the means known, sums
//! the squared deviations. Times are kept per window (first, last, centre), not per sample.

use crate::detect::windows::{
    adaptive_intervals, adaptive_rate, adc_range_of, axis_lattice, batch_spread, detector_scale,
    fixed_intervals, magnitude, to_levels, variance_of, DetectOptions, Streamed, WindowStats,
    Windows, BATCHES,
};
use crate::error::detect::DetectError;
use crate::error::Result;
use crate::input::recording::infer_units;
use crate::input::text_source::TextSource;
use crate::stats as st;
use wiical_core::static_detect::StaticInterval;

/// The time of sample `i` of `src` whose time column gives `t` (without one: `i / Fs`, the
/// metadata's rate else the detection's, as [`crate::input::recording::Recording::times`]).
fn time_of(t: Option<f64>, i: usize, fs: f64) -> f64 {
    t.unwrap_or_else(|| i as f64 / fs)
}

/// The time of sample `i` whose time column gives `t`, as the detection with `opts` takes it
/// (`Recording::times` at the detection's rate).
pub fn sample_clock(src: &TextSource, opts: &DetectOptions) -> impl Fn(Option<f64>, usize) -> f64 {
    let rate = src.estimated_rate_hz().unwrap_or(opts.default_rate_hz);
    let fs = clock_rate(src, rate);
    move |t, i| time_of(t, i, fs)
}

/// The rate of [`time_of`] for a source detected at `rate`.
fn clock_rate(src: &TextSource, rate: f64) -> f64 {
    src.meta.sample_rate_hz.unwrap_or(rate)
}

/// The sum `Iterator::sum` starts from (its result on no values), so that sums folded by hand
/// are the ones of `sum()` bit for bit.
fn sum_start() -> f64 {
    std::iter::empty::<f64>().sum()
}

/// [`crate::detect::windows::detect_windows`] on the samples of `src`, in passes.
pub fn detect_windows_streamed(src: &TextSource, opts: &DetectOptions) -> Result<Windows> {
    let integer = src.summary.integer;
    let (intervals, reference_variance, rate) = if opts.adaptive {
        detect_adaptive(src, opts)?
    } else {
        detect_fixed(src, opts)?
    };
    let range = opts.adc_range.or_else(|| {
        let s = &src.summary;
        integer.then(|| adc_range_of(s.lo, s.hi)).flatten()
    });
    let fs = clock_rate(src, rate);
    let stats = window_stats(src, &intervals, range, fs)?;
    let norms: Vec<f64> = stats.iter().map(|w| magnitude(&w.mean)).collect();
    let n = src.len();
    let first = time_of(src.summary.t_first, 0, fs);
    let last = time_of(src.summary.t_last, n.saturating_sub(1), fs);
    Ok(Windows {
        units: infer_units(integer, st::median(&norms)),
        stats,
        times: Vec::new(),
        clock: (n > 0).then_some((first, last)),
        reference_variance,
    })
}

/// Intervals, reference variance and rate of
/// [`crate::detect::windows::detect_adaptive`].
fn detect_adaptive(
    src: &TextSource,
    opts: &DetectOptions,
) -> Result<(Vec<StaticInterval>, [f32; 3], f64)> {
    let rate = adaptive_rate(src.estimated_rate_hz(), opts)?;
    let lattice = lattice(src);
    let samples = src.rows().map(move |r| match &lattice {
        Some(l) => to_levels(&r.xyz, l).map(|v| v as f32),
        None => r.xyz.map(|v| v as f32),
    });
    let found = adaptive_intervals(&Streamed(samples), src.len(), rate);
    src.check()?;
    let (intervals, reference) = found?;
    Ok((intervals, reference, rate))
}

/// The per-axis quantiser lattice of `detect::windows::lattice_view` from the first pass's
/// distinct values: `None` for integers, continuous or non-finite values.
fn lattice(src: &TextSource) -> Option<[(f64, f64); 3]> {
    if src.summary.integer {
        return None;
    }
    let distinct = src.summary.distinct.as_ref()?;
    let mut out = [(0.0, 0.0); 3];
    for (a, v) in distinct.iter().enumerate() {
        if v.iter().any(|x| !x.is_finite()) {
            return None;
        }
        out[a] = axis_lattice(v)?;
    }
    Some(out)
}

/// Intervals, reference variance and rate of [`crate::detect::windows::detect`] on the
/// detector's view (`detector_view`: non-integer values rescaled).
fn detect_fixed(
    src: &TextSource,
    opts: &DetectOptions,
) -> Result<(Vec<StaticInterval>, [f32; 3], f64)> {
    let rate = src.estimated_rate_hz().unwrap_or(opts.default_rate_hz);
    let n = src.len();
    let k = if src.summary.integer {
        None
    } else {
        let rows = || src.rows().map(|r| r.xyz);
        let k = detector_scale(rows, n, rate, opts, || {
            median_of(|| src.rows().map(|r| magnitude(&r.xyz)), n)
        });
        src.check()?;
        Some(k)
    };
    let samples = src.rows().map(|r| match k {
        Some(k) => r.xyz.map(|v| v * k),
        None => r.xyz,
    });
    let found = fixed_intervals(samples, n, rate, opts);
    src.check()?;
    let (intervals, reference) = found?;
    Ok((intervals, reference, rate))
}

/// `stats::median` of the `n` values `values` yields afresh on every call, selected by the
/// bits of their total order 16 at a time (four passes per order statistic), none stored.
fn median_of<I: Iterator<Item = f64>>(values: impl Fn() -> I, n: usize) -> f64 {
    if n == 0 {
        return f64::NAN;
    }
    // The `total_cmp` order as unsigned integers.
    let key = |x: f64| {
        let b = x.to_bits() as i64;
        ((b ^ (((b >> 63) as u64) >> 1) as i64) as u64) ^ (1 << 63)
    };
    let kth = |k: usize| {
        let mut top = vec![0usize; 1 << 16];
        values().for_each(|x| top[(key(x) >> 48) as usize] += 1);
        let Ok(b) = crate::stats::kth_key_by_digits(&top, k, |shift, prefix, hist| {
            for b in values().map(key).filter(|b| b >> (shift + 16) == prefix) {
                hist[((b >> shift) & 0xffff) as usize] += 1;
            }
            Ok::<(), std::convert::Infallible>(())
        });
        let b = b ^ (1 << 63);
        f64::from_bits(b ^ ((((b as i64) >> 63) as u64) >> 1))
    };
    if n % 2 == 1 {
        kth(n / 2)
    } else {
        0.5 * (kth(n / 2 - 1) + kth(n / 2))
    }
}

/// One window's sums as the passes fold them.
#[derive(Debug, Clone)]
struct Acc {
    span: (usize, usize),
    sum: [f64; 3],
    sq: [f64; 3],
    t_sum: f64,
    temp_sum: f64,
    t_first: f64,
    t_last: f64,
    batches: [[f64; 3]; BATCHES],
}

/// The windows of at least two samples, their statistics folded over two passes of `src`;
/// a sample of any interval at an ADC limit of `range` is refused as
/// `detect::windows::check_saturation` refuses it.
fn window_stats(
    src: &TextSource,
    intervals: &[StaticInterval],
    range: Option<(f64, f64)>,
    fs: f64,
) -> Result<Vec<WindowStats>> {
    let n = src.len();
    let ends = |iv: &StaticInterval| (iv.start as usize, (iv.end as usize).min(n));
    let checked: Vec<(usize, usize)> = intervals.iter().map(ends).collect();
    let spans: Vec<(usize, usize)> = checked
        .iter()
        .copied()
        .filter(|(s, e)| *e > s + 1)
        .collect();
    let zero = sum_start();
    let mut accs: Vec<Acc> = spans
        .iter()
        .map(|&span| Acc {
            span,
            sum: [0.0; 3],
            sq: [0.0; 3],
            t_sum: zero,
            temp_sum: zero,
            t_first: f64::NAN,
            t_last: f64::NAN,
            batches: [[0.0; 3]; BATCHES],
        })
        .collect();
    let mut saturated: Option<(usize, DetectError)> = None;
    let (mut sat_cover, mut cover) = (Cover::new(&checked), Cover::new(&spans));
    for (i, r) in src.rows().enumerate() {
        if let Some((lo, hi)) = range {
            for &k in sat_cover.at(i) {
                if saturated.as_ref().is_some_and(|(first, _)| *first <= k) {
                    continue;
                }
                if let Some(a) = (0..3).find(|&a| r.xyz[a] <= lo || r.xyz[a] >= hi) {
                    let iv = &intervals[k];
                    saturated = Some((
                        k,
                        DetectError::Saturated {
                            window: k + 1,
                            start: iv.start,
                            end: iv.end,
                            axis: ["x", "y", "z"][a],
                            value: r.xyz[a],
                            sample: i + 1,
                        },
                    ));
                }
            }
        }
        let t = time_of(r.t, i, fs);
        for &k in cover.at(i) {
            first_sums(&mut accs[k], i, &r.xyz, t, r.temp);
        }
    }
    src.check()?;
    if let Some((_, e)) = saturated {
        return Err(e.into());
    }
    let mut cover = Cover::new(&spans);
    let means: Vec<[f64; 3]> = accs.iter().map(mean_of).collect();
    for (i, r) in src.rows().enumerate() {
        for &k in cover.at(i) {
            let sq = &mut accs[k].sq;
            for ((q, x), m) in sq.iter_mut().zip(&r.xyz).zip(&means[k]) {
                *q += (x - m).powi(2);
            }
        }
    }
    src.check()?;
    let t0 = time_of(src.summary.t_first, 0, fs);
    let (integer, has_temp) = (src.summary.integer, src.has_temp());
    Ok(accs
        .iter()
        .map(|a| finish(a, t0, integer, has_temp))
        .collect())
}

fn mean_of(a: &Acc) -> [f64; 3] {
    let n = (a.span.1 - a.span.0) as f64;
    a.sum.map(|v| v / n)
}

/// Sample `i` (values `x`, time `t`, temperature `temp`) into its window's first-pass sums.
fn first_sums(a: &mut Acc, i: usize, x: &[f64; 3], t: f64, temp: Option<f64>) {
    let (s, e) = a.span;
    for (v, x) in a.sum.iter_mut().zip(x) {
        *v += x;
    }
    a.t_sum += t;
    if let Some(temp) = temp {
        a.temp_sum += temp;
    }
    if i == s {
        a.t_first = t;
    }
    if i + 1 == e {
        a.t_last = t;
    }
    let len = (e - s) / BATCHES;
    if e - s >= 5 * BATCHES && i < s + BATCHES * len {
        let m = &mut a.batches[(i - s) / len];
        for (v, x) in m.iter_mut().zip(x) {
            *v += x / len as f64;
        }
    }
}

/// The window's statistics from its sums, as `detect::windows::window_stats` computes them.
fn finish(a: &Acc, t0: f64, integer: bool, has_temp: bool) -> WindowStats {
    let (s, e) = a.span;
    let n = (e - s) as f64;
    WindowStats {
        start: s,
        end: e,
        mean: mean_of(a),
        var: variance_of(a.sq, n, integer),
        batch_var_of_mean: (e - s >= 5 * BATCHES).then(|| batch_spread(&a.batches)),
        t_centre: a.t_sum / n - t0,
        t_first: a.t_first,
        t_last: a.t_last,
        temp: has_temp.then(|| a.temp_sum / n),
        count: Some(e - s),
    }
}

/// Which of a list of sample spans `(first, one past the last)` hold sample `i`, for `i`
/// ascending: the spans in order of their first sample, those begun and not yet ended kept.
pub(crate) struct Cover {
    order: Vec<usize>,
    spans: Vec<(usize, usize)>,
    next: usize,
    open: Vec<usize>,
}

impl Cover {
    /// A cover of `spans` (any order, may overlap).
    pub(crate) fn new(spans: &[(usize, usize)]) -> Self {
        let mut order: Vec<usize> = (0..spans.len()).collect();
        order.sort_by_key(|&k| spans[k].0);
        Self {
            order,
            spans: spans.to_vec(),
            next: 0,
            open: Vec::new(),
        }
    }

    /// The spans holding sample `i` (ascending indices), `i` at least the last asked.
    pub(crate) fn at(&mut self, i: usize) -> &[usize] {
        let mut opened = false;
        while let Some(&k) = self.order.get(self.next) {
            if self.spans[k].0 > i {
                break;
            }
            self.open.push(k);
            self.next += 1;
            opened = true;
        }
        if opened {
            self.open.sort_unstable();
        }
        let spans = &self.spans;
        self.open.retain(|&k| spans[k].1 > i);
        &self.open
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The median selected in passes is the sorted median, for odd and even counts, with
    /// repeats, negative zero and values of every magnitude.
    #[test]
    fn the_median_in_passes_is_the_sorted_median() {
        let sets: Vec<Vec<f64>> = vec![
            vec![3.0],
            vec![2.0, 1.0],
            vec![1e-300, 5.0, 5.0, 1e300, -0.0, 0.0, 7.5],
            (0..1001)
                .map(|i| ((i * 7919) % 1001) as f64 * 0.37)
                .collect(),
            (0..1000).map(|i| (i as f64).sqrt()).collect(),
        ];
        for v in &sets {
            let got = median_of(|| v.iter().copied(), v.len());
            assert_eq!(got.to_bits(), st::median(v).to_bits(), "{v:?}");
        }
        assert!(median_of(std::iter::empty, 0).is_nan());
    }

    /// The cover lists exactly the spans holding each sample, for overlapping spans given
    /// out of order.
    #[test]
    fn the_cover_holds_each_sample_in_its_spans() {
        let spans = [(5, 9), (0, 3), (2, 6), (7, 8), (20, 21)];
        let mut cover = Cover::new(&spans);
        for i in 0..25 {
            let want: Vec<usize> = (0..spans.len())
                .filter(|&k| spans[k].0 <= i && i < spans[k].1)
                .collect();
            assert_eq!(cover.at(i), &want[..], "sample {i}");
        }
    }
}
