//! Window detection, written once over a recording's rows ([`RowSource`]: held in memory, or
//! a large text file re-read per pass, never held; a held recording is the case of one chunk
//! in place, and a file's [`Windows`] are the held recording's bit for bit): the core's
//! streaming static detector (the same `f32` code the adapter firmware runs,
//! [`crate::detect::detector`]), the ADC-saturation check, and the `f64` statistics of each
//! static window (mean, variance, batch means, centre time, temperature) that the analysis
//! works from.
//!
//! The same functions run on the same values in the same order: the detector's view (the
//! quantiser lattice from the distinct values, or the fixed detector's scale from the rest
//! period and, only when that is constant, the median ‖a‖ selected exactly in passes), the
//! core's detector over a pass per setting (samples in place — held, levels computed once,
//! a spill's `f32` axes — on all cores as held pieces, else a piece at a time: blocks surveyed
//! in parallel, the two detectors of a pair on two cores), the ADC range from the extremes.
//! Then each window's rows read where they are kept (a held recording's slices, a spill's
//! rows), windows on all cores: the first sweep sums the means, times, temperatures and
//! batch means and checks saturation; the second, with the means known, the squared
//! deviations. A read of a file's spill that failed gives no windows (the failure is kept for
//! [`RowSource::check`], which every caller asks after the detection).
//! Times are kept per window (first, last, centre), not per sample.

use crate::detect::detector::{
    adaptive_intervals, adaptive_rate, adc_range_of, axis_lattice, detector_scale, fixed_intervals,
    run_pair_held, survey_held, to_levels, PairResult, Passes,
};
use crate::detect::held::both_or_first_error;
use crate::detect::polled::{Polling, Runs};
use crate::error::detect::DetectError;
use crate::input::recording::infer_units;
use crate::input::text_source::Row;
use crate::source::{RowBuf, RowSource};
use crate::stats as st;
use wiical_core::static_detect::adaptive::{self, AdaptiveThresholds, NoiseSurvey};
use wiical_core::static_detect::{StaticDetector, StaticDetectorConfig, StaticInterval};

pub use crate::detect::detector::{
    all_whole, check_adc_range, check_duration_s, check_rate_hz, check_threshold, DetectOptions,
    RangeError, SettingError, ADAPTIVE_MIN_WINDOWS, DURATION_RANGE_S, MAX_WINDOW,
    MIN_SAMPLE_RATE_HZ,
};

type CoreError = wiical_core::Error;
type Result<T, E = DetectError> = std::result::Result<T, E>;

/// The time of sample `i` whose time column gives `t` (without one: `i / fs`, the metadata's
/// rate else the detection's, as [`crate::input::recording::Recording::times`]).
pub(crate) fn time_of(t: Option<f64>, i: usize, fs: f64) -> f64 {
    t.unwrap_or_else(|| i as f64 / fs)
}

/// The time of sample `i` whose time column gives `t`, as the detection with `opts` takes it
/// (`Recording::times` at the detection's rate).
pub fn sample_clock<R: RowSource + ?Sized>(
    src: &R,
    opts: &DetectOptions,
) -> impl Fn(Option<f64>, usize) -> f64 {
    let rate = src.estimated_rate_hz().unwrap_or(opts.default_rate_hz);
    let fs = src.metadata_rate_hz().unwrap_or(rate);
    move |t, i| time_of(t, i, fs)
}

/// The sum `Iterator::sum` starts from (its result on no values), so that sums folded by hand
/// are the ones of `sum()` bit for bit.
fn sum_start() -> f64 {
    std::iter::empty::<f64>().sum()
}

/// Intervals, reference variance and rate of the adaptive detection
/// (`detector::adaptive_intervals` over the detector's view of `src`).
pub(crate) fn detect_adaptive<R: RowSource + ?Sized>(
    src: &R,
    opts: &DetectOptions,
    integer: bool,
) -> Result<(Vec<StaticInterval>, [f32; 3], f64)> {
    use rayon::prelude::*;
    let rate = adaptive_rate(src.estimated_rate_hz(), opts)?;
    let lattice = lattice(src, integer);
    // Held values on a lattice: their levels computed once, on all cores.
    let levels: Option<Vec<[f32; 3]>> = lattice.and_then(|l| {
        let xyz = src.held()?;
        Some(xyz.par_iter().map(|x| view(x, &Some(l))).collect())
    });
    let passes = InPieces {
        src,
        lattice,
        levels: levels.as_deref(),
    };
    let (intervals, reference) = adaptive_intervals(&passes, src.len(), rate)?;
    Ok((intervals, reference, rate))
}

/// A sample as the adaptive detector sees it: its quantiser levels on `lattice`, else its
/// values, in `f32`.
fn view(x: &[f64; 3], lattice: &Option<[(f64, f64); 3]>) -> [f32; 3] {
    match lattice {
        Some(l) => to_levels(x, l).map(|v| v as f32),
        None => x.map(|v| v as f32),
    }
}

/// One pass over the detector's view of every sample: in place (levels, held values), else
/// viewed row by row.
#[derive(Clone)]
pub(crate) enum Pass<'a, I> {
    /// Levels in place.
    Levels(std::slice::Iter<'a, [f32; 3]>),
    /// Held values on no lattice.
    Values(std::slice::Iter<'a, [f64; 3]>),
    /// Rows read, viewed on the lattice if any.
    Rows(I, Option<[(f64, f64); 3]>),
}

impl<I: Iterator<Item = Row>> Iterator for Pass<'_, I> {
    type Item = [f32; 3];

    #[inline]
    fn next(&mut self) -> Option<[f32; 3]> {
        match self {
            Pass::Levels(it) => it.next().copied(),
            Pass::Values(it) => it.next().map(|x| x.map(|v| v as f32)),
            Pass::Rows(rows, lattice) => rows.next().map(|r| view(&r.xyz, lattice)),
        }
    }
}

/// The detector's view of every sample in place, in pieces.
enum InPlace<'a> {
    F32(Vec<&'a [[f32; 3]]>),
    F64(&'a [[f64; 3]]),
}

/// The adaptive detection's passes over `src`'s detector view: in place as held pieces
/// ([`InPlace`]: a held recording, its levels, a spill's `f32` axes) by the held functions,
/// else a piece at a time: the pieces' blocks surveyed on all cores and the two detectors of a
/// pair fed each on its own core (the same values in the same order as one sample at a time:
/// the same thresholds and intervals).
struct InPieces<'a, R: RowSource + ?Sized> {
    src: &'a R,
    lattice: Option<[(f64, f64); 3]>,
    /// A held recording's levels on `lattice`.
    levels: Option<&'a [[f32; 3]]>,
}

impl<'a, R: RowSource + ?Sized> Passes for InPieces<'a, R> {
    type Iter = Pass<'a, R::Rows<'a>>;

    fn pass(&self) -> Self::Iter {
        if let Some(l) = self.levels {
            return Pass::Levels(l.iter());
        }
        match self.src.held() {
            Some(xyz) if self.lattice.is_none() => Pass::Values(xyz.iter()),
            _ => Pass::Rows(self.src.rows(), self.lattice),
        }
    }

    /// Each piece's complete blocks measured on all cores and added in order, the rest carried
    /// to the next piece; the last incomplete block pushed sample by sample
    /// ([`survey_held`]'s survey, bit for bit).
    fn survey(&self, rate: f32) -> Result<AdaptiveThresholds, CoreError> {
        use rayon::prelude::*;
        match self.in_place() {
            Some(InPlace::F32(pieces)) => return survey_held(&pieces, rate),
            Some(InPlace::F64(xyz)) => return survey_held(&[xyz], rate),
            None => {}
        }
        let mut survey = NoiseSurvey::for_rate(rate)?;
        let block = survey.block_samples() as usize;
        let mut pending: Vec<[f32; 3]> = Vec::new();
        let mut failed = None;
        self.each_view(&mut |viewed| {
            pending.extend_from_slice(viewed);
            let full = pending.len() / block * block;
            // Four blocks at a time (`NoiseSurvey::measure_four_blocks`), on all cores.
            let measured: Vec<_> = pending[..full]
                .par_chunks(4 * block)
                .flat_map_iter(|four| {
                    let mut blocks = four.chunks(block);
                    let slices = [(); 4].map(|_| blocks.next().unwrap_or(&[]));
                    let n = four.len() / block;
                    NoiseSurvey::measure_four_blocks(slices).into_iter().take(n)
                })
                .collect();
            pending.drain(..full);
            for m in measured {
                match m {
                    Ok(m) => survey.add_measured(m),
                    Err(e) => return fail_with(&mut failed, e),
                }
            }
            true
        });
        if let Some(e) = failed {
            return Err(e);
        }
        for m in pending {
            survey.push(m)?;
        }
        survey.thresholds(adaptive::DEFAULT_QUANTILE)
    }

    /// Each piece fed to the two detectors on two cores at once; the error is the one met
    /// first in sample order (the first setting's on the same sample).
    fn run_pair(&self, cfgs: [StaticDetectorConfig; 2], reference: [f32; 3]) -> PairResult {
        match self.in_place() {
            Some(InPlace::F32(pieces)) => return run_pair_held(&pieces, cfgs, reference),
            Some(InPlace::F64(xyz)) => return run_pair_held(&[xyz], cfgs, reference),
            None => {}
        }
        let mut lanes = [
            Lane::new(StaticDetector::with_reference(cfgs[0], reference)?),
            Lane::new(StaticDetector::with_reference(cfgs[1], reference)?),
        ];
        let mut failed = None;
        self.each_view(&mut |viewed| {
            let [a, b] = &mut lanes;
            let (ra, rb) = rayon::join(|| a.feed(viewed), || b.feed(viewed));
            match both_or_first_error(ra, rb) {
                Ok(_) => true,
                Err(e) => fail_with(&mut failed, e),
            }
        });
        if let Some(e) = failed {
            return Err(e);
        }
        Ok(lanes.map(|Lane(mut det, mut out)| {
            out.extend(det.finish());
            out
        }))
    }
}

/// One detector of a pair and its intervals, aligned to a cache line pair of its own: the two
/// run on two cores at once, and side by side in one array the end of the first and the start
/// of the second (each written on every sample) shared a line, which the cores then took from
/// each other on every sample (the pass ran several times slower than the two detectors of
/// the held path, each on its own thread's stack).
#[repr(align(128))]
struct Lane(StaticDetector<MAX_WINDOW>, Vec<StaticInterval>);

impl Lane {
    fn new(det: StaticDetector<MAX_WINDOW>) -> Self {
        Lane(det, Vec::new())
    }

    /// `samples` fed to the detector, its intervals kept; the error with the index of the
    /// sample that met it.
    fn feed(&mut self, samples: &[[f32; 3]]) -> std::result::Result<(), (usize, CoreError)> {
        let Lane(det, out) = self;
        det.push_slice(samples, |iv| out.push(iv))
    }
}

impl<R: RowSource + ?Sized> InPieces<'_, R> {
    /// The detector's view of every sample in place: the held levels, else on no lattice a
    /// held recording's values or a spill's `f32` axes in memory
    /// ([`RowSource::f32_in_place`]): the passes then run as over held samples, with no copy
    /// and no step per piece.
    fn in_place(&self) -> Option<InPlace<'_>> {
        if let Some(l) = self.levels {
            return Some(InPlace::F32(vec![l]));
        }
        if self.lattice.is_some() {
            return None;
        }
        match self.src.held() {
            Some(xyz) => Some(InPlace::F64(xyz)),
            None => self.src.f32_in_place().map(InPlace::F32),
        }
    }

    /// A pass over the detector's view of every sample, a piece at a time (`f` may stop it
    /// by returning `false`): values on no lattice read straight to `f32`, else their levels.
    fn each_view(&self, f: &mut dyn FnMut(&[[f32; 3]]) -> bool) {
        use rayon::prelude::*;
        if self.lattice.is_none() {
            return self.src.each_piece_f32(f);
        }
        let mut viewed = Vec::new();
        self.src.each_piece(&mut |xyz| {
            let samples = xyz.par_iter().map(|x| view(x, &self.lattice));
            samples.collect_into_vec(&mut viewed);
            f(&viewed)
        });
    }
}

/// `e` kept as the pass's error; false (the pass stops).
fn fail_with(failed: &mut Option<CoreError>, e: CoreError) -> bool {
    *failed = Some(e);
    false
}

/// The per-axis quantiser lattices `(origin, step)` of non-integer values on one (counts
/// converted by a constant scale and offset; `windows::axis_lattice`): `None` for integers,
/// continuous or non-finite values (`integer`: every value of `src` is whole).
///
/// Why: the adaptive detector's noise survey bins block variances on a log scale at absolute
/// positions and floors integer data at the quantisation variance 1/12, so the same recording
/// in counts and in g would be detected with slightly different references (window edges a
/// sample apart). In levels it is the counts recording up to an offset, which a variance
/// does not see: the same windows, whatever unit or scale the counts were converted to.
pub(crate) fn lattice<R: RowSource + ?Sized>(src: &R, integer: bool) -> Option<[(f64, f64); 3]> {
    if integer {
        return None;
    }
    let distinct = src.distinct()?;
    let mut out = [(0.0, 0.0); 3];
    for (a, v) in distinct.iter().enumerate() {
        if v.iter().any(|x| !x.is_finite()) {
            return None;
        }
        out[a] = axis_lattice(v)?;
    }
    Some(out)
}

/// Intervals, reference variance and rate of the fixed (IMU-TK) detector
/// (`detector::fixed_intervals`) on the detector's view: non-integer values rescaled
/// (`detector::detector_scale`; `integer`: every value of `src` is whole).
pub(crate) fn detect_fixed<R: RowSource + ?Sized>(
    src: &R,
    opts: &DetectOptions,
    integer: bool,
) -> Result<(Vec<StaticInterval>, [f32; 3], f64)> {
    let rate = src.estimated_rate_hz().unwrap_or(opts.default_rate_hz);
    let n = src.len();
    let k = (!integer).then(|| {
        let rows = || src.rows().map(|r| r.xyz);
        detector_scale(rows, n, rate, opts, || {
            median_of(|| src.rows().map(|r| magnitude(&r.xyz)), n)
        })
    });
    let samples = src.rows().map(|r| match k {
        Some(k) => r.xyz.map(|v| v * k),
        None => r.xyz,
    });
    let (intervals, reference) = fixed_intervals(samples, n, rate, opts)?;
    Ok((intervals, reference, rate))
}

/// `stats::median` of the `n` values `values` yields afresh on every call, selected by the
/// bits of their total order 16 at a time ([`crate::stats::OrderCounts::median`]: a pass to
/// count them, three for both middle values), none stored.
fn median_of<I: Iterator<Item = f64>>(values: impl Fn() -> I, n: usize) -> f64 {
    use crate::stats::{from_order_key, order_key, OrderCounts};
    let keys = |key: &mut dyn FnMut(u64)| {
        values().for_each(|v| key(order_key(v)));
        Ok::<(), std::convert::Infallible>(())
    };
    let mut counts = OrderCounts::new(0);
    let Ok(()) = keys(&mut |k| counts.push(k));
    debug_assert_eq!(counts.len, n, "the values of every call");
    let Ok(m) = counts.median(from_order_key, keys);
    m
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
    /// Runs of identical samples, folded in the second pass (the mean known).
    runs: Runs,
}

impl Acc {
    /// No sample of the window `span` yet.
    fn new(span: (usize, usize)) -> Self {
        let zero = sum_start();
        Acc {
            span,
            sum: [0.0; 3],
            sq: [0.0; 3],
            t_sum: zero,
            temp_sum: zero,
            t_first: f64::NAN,
            t_last: f64::NAN,
            batches: [[0.0; 3]; BATCHES],
            runs: Runs::default(),
        }
    }

    /// Sample `x` into the second pass's sums, the mean `m` known.
    fn second(&mut self, x: &[f64; 3], m: &[f64; 3]) {
        for ((q, x), m) in self.sq.iter_mut().zip(x).zip(m) {
            *q += (x - m).powi(2);
        }
        self.runs.push(x, m);
    }
}

/// A window's samples: the first and one past the last.
type Span = (usize, usize);

/// The windows of at least two samples of `intervals` and their statistics, `fs` the clock
/// of rows without times, variances floored for `integer` counts; a sample of any interval
/// at an ADC limit of `range` refused: the first such sample of the first such window, in
/// recording order. Each window's rows are read where they are kept ([`RowSource::span`]: a
/// held recording's slices, a file's spill), on all cores, window by window (each window's
/// sums in sample order). A read that failed gives no windows: the failure is kept for
/// [`RowSource::check`], which the callers ask after the detection.
pub(crate) fn window_stats<R: RowSource + ?Sized>(
    src: &R,
    intervals: &[StaticInterval],
    range: Option<(f64, f64)>,
    fs: f64,
    integer: bool,
) -> Result<Vec<WindowStats>> {
    use rayon::prelude::*;
    let n = src.len();
    let ends = |iv: &StaticInterval| (iv.start as usize, (iv.end as usize).min(n));
    let checked: Vec<Span> = intervals.iter().map(ends).collect();
    let Some(per_window) = checked
        .par_iter()
        .map_init(RowBuf::default, |buf, &span| {
            window(src, buf, span, range, fs)
        })
        .collect::<Option<Vec<_>>>()
    else {
        return Ok(Vec::new());
    };
    let saturated = per_window
        .iter()
        .enumerate()
        .find_map(|(k, (f, _))| f.map(|f| (k, f)));
    if let Some((k, (i, a, value))) = saturated {
        return Err(saturated_at(intervals, k, i, a, value));
    }
    let t0 = time_of(src.time_ends().0, 0, fs);
    let has_temp = src.has_temp();
    // The windows of two samples or more, in order.
    Ok(per_window
        .iter()
        .filter_map(|(_, a)| a.as_ref())
        .map(|a| finish(a, t0, integer, has_temp))
        .collect())
}

/// A window's first sample at an ADC limit: its index, axis and value.
type AtLimit = (usize, usize, f64);

/// The window `span`'s first sample at an ADC limit of `range` (when given) and, when it has
/// two samples or more, its sums: its rows read where they are kept, twice (a held slice, a
/// spill's rows still in `buf` when they fit one read); `None` when a read failed.
fn window<R: RowSource + ?Sized>(
    src: &R,
    buf: &mut RowBuf,
    (s, e): Span,
    range: Option<(f64, f64)>,
    fs: f64,
) -> Option<(Option<AtLimit>, Option<Acc>)> {
    let e = e.max(s);
    let at_limit = |i: usize, x: &[f64; 3]| {
        let (lo, hi) = range?;
        let a = (0..3).find(|&a| x[a] <= lo || x[a] >= hi)?;
        Some((i, a, x[a]))
    };
    let mut found = None;
    let mut acc = (e > s + 1).then(|| Acc::new((s, e)));
    fold_span(src, buf, (s, e), |i, x, t, temp| {
        if range.is_some() && found.is_none() {
            found = at_limit(i, x);
        }
        if let Some(acc) = &mut acc {
            first_sums(acc, i, x, time_of(t, i, fs), temp);
        }
    })?;
    if let Some(acc) = &mut acc {
        let m = mean_of(acc);
        fold_span(src, buf, (s, e), |_, x, _, _| acc.second(x, &m))?;
    }
    Some((found, acc))
}

/// `f(i, values, time, temperature)` on each sample `i` of `span`, in order, read where kept
/// ([`RowSource::span`]); `None` when a read failed.
fn fold_span<R: RowSource + ?Sized>(
    src: &R,
    buf: &mut RowBuf,
    (s, e): Span,
    mut f: impl FnMut(usize, &[f64; 3], Option<f64>, Option<f64>),
) -> Option<()> {
    let mut from = s;
    while from < e {
        let c = src.span((from, e), buf)?;
        if c.xyz.is_empty() {
            return None;
        }
        for (j, x) in c.xyz.iter().enumerate() {
            f(from + j, x, c.t.map(|t| t[j]), c.temp.map(|t| t[j]));
        }
        from += c.xyz.len();
    }
    Some(())
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

/// The window's statistics from its sums: mean, variance (floored for `integer` counts),
/// batch means' spread, centre time from `t0`, mean temperature.
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
        runs: Some({
            let mut r = a.runs.clone();
            r.close();
            r
        }),
        distinct: None,
    }
}

/// Detects the static windows of the rows of `src` (held, or a large text file read in
/// passes: one code, the same windows bit for bit; the core's detector on the detector's
/// view), refuses saturated ones, computes their f64 statistics and infers the input units.
/// A file's pass that ended early is for the caller to ask after ([`RowSource::check`]).
pub fn detect_windows<R: RowSource + ?Sized>(src: &R, opts: &DetectOptions) -> Result<Windows> {
    let integer = src.integer();
    let (intervals, reference_variance, rate) = if opts.adaptive {
        detect_adaptive(src, opts, integer)?
    } else {
        detect_fixed(src, opts, integer)?
    };
    let range = opts.adc_range.or_else(|| {
        let (lo, hi) = integer.then(|| src.extremes())?;
        adc_range_of(lo, hi)
    });
    let fs = src.metadata_rate_hz().unwrap_or(rate);
    let mut stats = window_stats(src, &intervals, range, fs, integer)?;
    let polling = judge_polling(&mut stats, integer);
    let norms: Vec<f64> = stats.iter().map(|w| magnitude(&w.mean)).collect();
    let n = src.len();
    let (first, last) = src.time_ends();
    Ok(Windows {
        units: infer_units(integer, st::median(&norms)),
        stats,
        clock: (n > 0).then(|| (time_of(first, 0, fs), time_of(last, n - 1, fs))),
        reference_variance,
        polling,
    })
}

/// Window `k` of `intervals` refused for its sample `i` (from 0) whose axis `a` reads
/// `value`, at an ADC limit.
pub(crate) fn saturated_at(
    intervals: &[StaticInterval],
    k: usize,
    i: usize,
    a: usize,
    value: f64,
) -> DetectError {
    let iv = &intervals[k];
    DetectError::Saturated {
        window: k + 1,
        start: iv.start,
        end: iv.end,
        axis: ["x", "y", "z"][a],
        value,
        sample: i + 1,
    }
}

/// Statistics of one detected window, computed in f64 from the samples.
#[derive(Debug, Clone)]
pub struct WindowStats {
    /// First sample index.
    pub start: usize,
    /// One past the last.
    pub end: usize,
    /// Mean, raw.
    pub mean: [f64; 3],
    /// Per-axis sample variance, raw² (floored at 1/12 for integer data).
    pub var: [f64; 3],
    /// Per-axis variance of the mean from 10 batch means, raw² (`None` if too short).
    pub batch_var_of_mean: Option<[f64; 3]>,
    /// Mean time, s since the first sample.
    pub t_centre: f64,
    /// Time of the window's first sample, s (recording clock).
    pub t_first: f64,
    /// Time of the window's last sample, s (recording clock).
    pub t_last: f64,
    /// Mean temperature.
    pub temp: Option<f64>,
    /// Samples averaged: the span for detected windows; for windows read from a window-mean
    /// table ([`crate::input::window_means`]) the file's count column, `None` when it has none (the
    /// noise floor var/n is then unknown, not guessed).
    pub count: Option<usize>,
    /// The window's runs of identical consecutive samples ([`crate::detect::polled`]):
    /// counted for detected windows, `None` for a window-mean table's rows.
    pub runs: Option<Runs>,
    /// The sensor's distinct samples in the window when the log was found polled faster than
    /// the sensor updates ([`Windows::polling`]); `var` is then theirs too. `None` otherwise.
    pub distinct: Option<usize>,
}

impl WindowStats {
    /// Independent samples behind the mean, when known: the samples averaged
    /// ([`WindowStats::count`]), or for a polled log the sensor's distinct samples among them
    /// (a reading logged four times is one sample: `var/n` over the rows would understate the
    /// noise of the mean by half).
    pub fn n(&self) -> Option<usize> {
        self.distinct.or(self.count)
    }
}

/// Detected windows and context.
pub struct Windows {
    /// The windows.
    pub stats: Vec<WindowStats>,
    /// Times of the recording's first and last sample, s (recording clock); `None` without
    /// samples.
    pub clock: Option<(f64, f64)>,
    /// Detected units.
    pub units: &'static str,
    /// The detector's per-axis reference variance.
    pub reference_variance: [f32; 3],
    /// The log was polled faster than its sensor updates: the windows' `var` and
    /// [`WindowStats::n`] are the distinct samples' ([`crate::detect::polled`]).
    pub polling: Option<Polling>,
}

/// Judges from the windows' runs whether the log was polled faster than its sensor updates
/// ([`crate::detect::polled::judge`]) and, if so, takes each window's variance and sample
/// count from its distinct samples. Windows without runs (a table's rows) are left alone.
pub(crate) fn judge_polling(stats: &mut [WindowStats], integer: bool) -> Option<Polling> {
    let runs: Vec<&Runs> = stats.iter().filter_map(|w| w.runs.as_ref()).collect();
    let samples: usize = stats
        .iter()
        .filter(|w| w.runs.is_some())
        .map(|w| w.end - w.start)
        .sum();
    // The windows' own clock: each spans `(count − 1)` sample steps.
    let (steps, seconds) = stats
        .iter()
        .filter(|w| w.runs.is_some() && w.end > w.start + 1)
        .fold((0usize, 0.0), |(n, s), w| {
            (n + w.end - w.start - 1, s + (w.t_last - w.t_first))
        });
    let polling = crate::detect::polled::judge(
        &runs,
        samples,
        seconds * samples as f64 / steps.max(1) as f64,
    )?;
    for w in stats.iter_mut() {
        let Some(r) = &w.runs else { continue };
        if r.distinct >= 2 {
            w.var = variance_of(r.sq_about_own_mean(), r.distinct as f64, integer);
            w.distinct = Some(r.distinct);
        }
    }
    Some(polling)
}

/// ‖s‖ of one sample.
pub(crate) fn magnitude(s: &[f64; 3]) -> f64 {
    (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt()
}

/// Batch means per window: the window split into this many blocks.
pub(crate) const BATCHES: usize = 10;

/// Per-axis variance of the mean from the [`BATCHES`] batch means `bm`.
pub(crate) fn batch_spread(bm: &[[f64; 3]; BATCHES]) -> [f64; 3] {
    const B: usize = BATCHES;
    let mut out = [0.0; 3];
    for a in 0..3 {
        let mu = bm.iter().map(|m| m[a]).sum::<f64>() / B as f64;
        let v = bm.iter().map(|m| (m[a] - mu).powi(2)).sum::<f64>() / (B - 1) as f64;
        out[a] = v / B as f64;
    }
    out
}

/// The sample variance from the sums of squared deviations `sq` of `n` samples, floored at
/// the quantisation's 1/12 for `integer` counts.
pub(crate) fn variance_of(sq: [f64; 3], n: f64, integer: bool) -> [f64; 3] {
    sq.map(|v| {
        let v = v / (n - 1.0);
        if integer {
            v.max(1.0 / 12.0)
        } else {
            v
        }
    })
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
    use crate::input::recording::Recording;

    /// The samples as quantiser levels on their lattice ([`lattice`] of them held).
    fn lattice_view(xyz: &[[f64; 3]]) -> Option<Vec<[f64; 3]>> {
        let rec = Recording {
            xyz: xyz.to_vec(),
            ..Default::default()
        };
        let lattice = lattice(&rec, all_whole(xyz))?;
        Some(xyz.iter().map(|s| to_levels(s, &lattice)).collect())
    }

    /// The windows' statistics of `rec` at 100 Hz, refused when saturated in `range`.
    fn check_saturation(
        rec: &Recording,
        intervals: &[StaticInterval],
        range: Option<(f64, f64)>,
    ) -> Result<()> {
        window_stats(rec, intervals, range, 100.0, true).map(|_| ())
    }

    #[test]
    fn counts_converted_by_scale_and_offset_are_mapped_back_to_levels() {
        let counts: Vec<[f64; 3]> = (0..200)
            .map(|i| {
                let i = i as f64;
                [500.0 + (i * 7.0) % 13.0, 300.0 + (i * 3.0) % 5.0, 700.0]
            })
            .collect();
        // Integers are levels already.
        assert!(lattice_view(&counts).is_none());
        let in_g: Vec<[f64; 3]> = counts
            .iter()
            .map(|c| {
                [
                    (c[0] - 512.0) / 105.0,
                    (c[1] - 512.0) / 98.5,
                    (c[2] - 512.0) / 101.0,
                ]
            })
            .collect();
        let levels = lattice_view(&in_g).unwrap();
        for (l, c) in levels.iter().zip(&counts) {
            // The counts up to each axis's offset (its smallest value); a constant axis is 0.
            assert_eq!(*l, [c[0] - 500.0, c[1] - 300.0, 0.0]);
        }
        // Scaled again (g → m/s²): the same levels.
        let ms2: Vec<[f64; 3]> = in_g.iter().map(|v| v.map(|x| x * 9.80665)).collect();
        assert_eq!(lattice_view(&ms2).unwrap(), levels);
    }

    /// The refusal names the first saturated sample of the first saturated window, as a scan
    /// of the windows in order would, although the windows are checked on all cores.
    #[test]
    fn saturation_names_the_first_saturated_sample_in_recording_order() {
        let mut xyz = vec![[100.0, 200.0, 300.0]; 4000];
        for (i, a) in [(3500, 0), (1210, 2), (1205, 1), (1290, 0)] {
            xyz[i][a] = 1023.0;
        }
        let rec = Recording {
            xyz,
            ..Default::default()
        };
        let iv = |start: u32, end: u32| StaticInterval {
            start,
            end,
            mean: [0.0; 3],
            variance: [0.0; 3],
        };
        let many: Vec<StaticInterval> = (0..40).map(|k| iv(100 * k, 100 * k + 90)).collect();
        let e = check_saturation(&rec, &many, Some((0.0, 1023.0))).unwrap_err();
        let DetectError::Saturated {
            window,
            sample,
            axis,
            ..
        } = e
        else {
            panic!("{e}")
        };
        assert_eq!((window, sample, axis), (13, 1206, "y"));
        assert!(check_saturation(&rec, &many[..12], Some((0.0, 1023.0))).is_ok());
        assert!(check_saturation(&rec, &many, None).is_ok());
    }

    #[test]
    fn continuous_values_are_left_alone() {
        let cont: Vec<[f64; 3]> = (0..200)
            .map(|i| {
                let x = (i as f64 * 12.9898).sin() * 0.01;
                [x, 1.0 + x * x, -x]
            })
            .collect();
        assert!(lattice_view(&cont).is_none());
        assert!(lattice_view(&[[f64::NAN, 0.5, 0.5]]).is_none());
    }

    /// A 100 Hz recording whose time column is in milliseconds reads as 0.1 Hz: refused with
    /// the question, not analysed with holds of a fraction of a sample.
    #[test]
    fn millisecond_times_are_refused_with_the_question() {
        let rec = Recording {
            t: Some((0..3000).map(|i| i as f64 * 10.0).collect()),
            xyz: (0..3000)
                .map(|i| [0.0, 0.0, 1.0 + 1e-3 * (i % 7) as f64])
                .collect(),
            ..Default::default()
        };
        let e = detect_windows(&rec, &DetectOptions::default())
            .err()
            .expect("refused");
        assert!(
            matches!(e, DetectError::RateTooLow { rate_hz } if rate_hz == 0.1),
            "{e:?}"
        );
        assert!(e.to_string().contains("milliseconds"), "{e}");
    }

    /// Fewer samples than the adaptive detector's noise survey: the error names the survey
    /// (not an initial rest period, which the adaptive detector does not need).
    #[test]
    fn too_short_for_the_survey_says_so() {
        let rec = Recording {
            xyz: vec![[0.0, 0.0, 1.0]; 10],
            sample_rate_hz: Some(100.0),
            ..Default::default()
        };
        let e = detect_windows(&rec, &DetectOptions::default())
            .err()
            .expect("refused");
        assert!(
            matches!(e, DetectError::TooShortForSurvey { samples: 10, .. }),
            "{e:?}"
        );
        assert!(e.to_string().contains("noise survey"), "{e}");
    }

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
            assert_eq!(got.to_bits(), crate::stats::median(v).to_bits(), "{v:?}");
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

/// A streamed file whose rows are kept in memory, on disk, or moved to disk as they are
/// written gives the same rows, windows and clones; one whose rows cannot be written to a
/// temporary file (no such directory, a disk full from the start or after a few blocks) is
/// refused with the sentence that says to set TMPDIR; a spill that cannot be read back in the
/// middle of a pass ends it, which `check` then says.
#[cfg(test)]
mod spill_tests {
    use crate::input::columns::LoadOptions;
    use crate::input::text_source::{Row, SpillTo, TextSource};

    /// A simulated recording of `cfg` written as CSV into a temporary directory (kept alive by
    /// the first value): the directory, the file, its rows.
    fn simulated_csv(cfg: wiical_sim::SimConfig) -> (tempfile::TempDir, std::path::PathBuf, usize) {
        let out = wiical_sim::simulate(&cfg).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.csv");
        std::fs::write(&path, wiical_sim::to_csv(&out.recording)).unwrap();
        (dir, path, out.recording.len())
    }

    fn rows_of(src: &TextSource) -> Vec<Row> {
        let rows: Vec<Row> = src.rows().collect();
        src.check().unwrap();
        rows
    }

    fn windows_of(src: &TextSource) -> String {
        let opts = crate::detect::windows::DetectOptions::default();
        let w = crate::detect::windows::detect_windows(src, &opts).unwrap();
        src.check().unwrap();
        format!(
            "{:?} {:?} {:?} {:?}",
            w.stats, w.clock, w.units, w.reference_variance
        )
    }

    #[test]
    fn wherever_the_rows_are_kept_they_read_alike() {
        let (dir, path, rows) = simulated_csv(wiical_sim::SimConfig {
            seed: 3,
            poses: 12,
            temp_column: true,
            ..Default::default()
        });
        let opts = LoadOptions::default();
        let open = |to: &SpillTo| TextSource::open_with(&path, &opts, 4096, to, |_| true);
        let disk = SpillTo {
            dir: None,
            limit: u64::MAX,
            memory: 0,
        };
        let in_memory = open(&SpillTo {
            memory: u64::MAX,
            ..disk.clone()
        });
        let in_memory = in_memory.unwrap().unwrap();
        assert!(in_memory.is_spill_in_memory());
        let (want_rows, want_windows) = (rows_of(&in_memory), windows_of(&in_memory));
        assert_eq!(want_rows.len(), rows);
        let no_dir = Some(dir.path().join("no such directory"));
        let with = |dir: &Option<std::path::PathBuf>, limit, memory| SpillTo {
            dir: dir.clone(),
            limit,
            memory,
        };
        // On disk, moved to disk once past the memory kept, in memory with no directory.
        for to in [
            disk.clone(),
            with(&None, u64::MAX, 20_000),
            with(&no_dir, u64::MAX, u64::MAX),
        ] {
            let src = open(&to).unwrap().unwrap();
            assert_eq!(src.is_spill_in_memory(), to.memory == u64::MAX, "{to:?}");
            assert_eq!(rows_of(&src), want_rows, "{to:?}");
            assert_eq!(windows_of(&src), want_windows, "{to:?}");
        }
        // Bound for a directory that is not there, or for a disk full from the start or
        // after a few blocks.
        for to in [
            with(&no_dir, u64::MAX, 0),
            with(&no_dir, u64::MAX, 20_000),
            with(&None, 0, 0),
            with(&None, 20_000, 0),
            with(&None, 20_000, u64::MAX),
        ] {
            let e = open(&to).unwrap_err().to_string();
            assert!(
                e.starts_with("its rows are kept in a temporary file in ")
                    && e.contains("set TMPDIR to a writable directory with room for them"),
                "{to:?}: {e}"
            );
        }
        // The spill emptied in the middle of a pass (and of a clone's): both end there, and
        // `check` names the file and says why.
        let spilled = open(&disk).unwrap().unwrap();
        let mut it = spilled.rows();
        let head: Vec<Row> = it.by_ref().take(1000).collect();
        let clone = it.clone();
        spilled.truncate_spill();
        assert!(head.len() + it.count() < rows);
        assert!(clone.count() < rows - head.len());
        let e = spilled.check().unwrap_err().full_message();
        assert!(
            e.contains("r.csv") && e.contains("reading them back failed"),
            "{e}"
        );
    }

    /// The detector's view read straight to `f32` is every row's values as `f32`, from memory
    /// and from disk; a spill that fails in the middle of the pass ends it, which `check` says.
    #[test]
    fn the_f32_view_is_the_rows_whatever_the_spill() {
        let (_dir, path, rows) = simulated_csv(wiical_sim::SimConfig {
            seed: 5,
            poses: 9,
            ..Default::default()
        });
        let opts = LoadOptions::default();
        let disk = SpillTo {
            dir: None,
            limit: u64::MAX,
            memory: 0,
        };
        let memory = SpillTo {
            memory: u64::MAX,
            ..disk.clone()
        };
        for (to, fail) in [(disk.clone(), false), (memory, false), (disk, true)] {
            let src = TextSource::open_with(&path, &opts, 4096, &to, |_| true)
                .unwrap()
                .unwrap();
            let want: Vec<[u32; 3]> = rows_of(&src)
                .iter()
                .map(|r| r.xyz.map(|v| (v as f32).to_bits()))
                .collect();
            assert_eq!(want.len(), rows);
            let (mut got, mut pieces) = (Vec::new(), 0);
            src.each_piece_f32(|v| {
                got.extend(v.iter().map(|x| x.map(f32::to_bits)));
                pieces += 1;
                if fail && pieces == 2 {
                    src.truncate_spill();
                }
                true
            });
            if fail {
                assert!(src.check().is_err());
                assert!(got.len() < want.len() && want.starts_with(&got));
            } else {
                src.check().unwrap();
                assert!(pieces > 2, "{pieces} pieces");
                assert_eq!(got, want, "{to:?}");
            }
        }
    }
}
