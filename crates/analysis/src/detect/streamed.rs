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
//! When the first pass's rows were kept, in memory or a temporary file
//! ([`TextSource::is_spilled`]), the two passes read each window's rows alone from them (once
//! per window that fits a read), windows on all cores.

use crate::detect::held::both_or_first_error;
use crate::detect::polled::Runs;
use crate::detect::windows::{
    adaptive_intervals, adaptive_rate, adc_range_of, axis_lattice, batch_spread, detector_scale,
    fixed_intervals, judge_polling, magnitude, run_pair_held, saturated_at, survey_held, to_levels,
    variance_of, DetectOptions, PairResult, Passes, WindowStats, Windows, BATCHES, MAX_WINDOW,
};
use crate::error::detect::DetectError;
use crate::error::Result;
use crate::input::recording::infer_units;
use crate::input::sample_summary::{Distinct, SummaryFold};
use crate::input::text_source::{Columns, Rows, TextSource, Want};
use crate::stats as st;
use wiical_core::static_detect::adaptive::{self, AdaptiveThresholds, NoiseSurvey};
use wiical_core::static_detect::{StaticDetector, StaticDetectorConfig, StaticInterval};

type CoreError = wiical_core::Error;

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
    let mut stats = window_stats(src, &intervals, range, fs)?;
    let polling = judge_polling(&mut stats, integer);
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
        polling,
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
    let found = adaptive_intervals(&InPieces { src, lattice }, src.len(), rate);
    src.check()?;
    let (intervals, reference) = found?;
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

/// The detector's view of every sample of a pass ([`view`]).
#[derive(Clone)]
pub(crate) struct Viewed<'a> {
    rows: Rows<'a>,
    lattice: Option<[(f64, f64); 3]>,
}

impl Iterator for Viewed<'_> {
    type Item = [f32; 3];

    fn next(&mut self) -> Option<[f32; 3]> {
        self.rows.next().map(|r| view(&r.xyz, &self.lattice))
    }
}

/// The adaptive detection's passes over a streamed file, a piece at a time: the pieces'
/// blocks surveyed on all cores and the two detectors of a pair fed each on its own core (the
/// same values in the same order as one sample at a time: the same thresholds and intervals).
struct InPieces<'a> {
    src: &'a TextSource,
    lattice: Option<[(f64, f64); 3]>,
}

impl<'a> Passes for InPieces<'a> {
    type Iter = Viewed<'a>;

    fn pass(&self) -> Viewed<'a> {
        Viewed {
            rows: self.src.rows(),
            lattice: self.lattice,
        }
    }

    /// Each piece's complete blocks measured on all cores and added in order, the rest carried
    /// to the next piece; the last incomplete block pushed sample by sample
    /// (`Held`'s survey, bit for bit).
    fn survey(&self, rate: f32) -> Result<AdaptiveThresholds, CoreError> {
        use rayon::prelude::*;
        if let Some(pieces) = self.in_place() {
            return survey_held(&pieces, rate);
        }
        let mut survey = NoiseSurvey::for_rate(rate)?;
        let block = survey.block_samples() as usize;
        let mut pending: Vec<[f32; 3]> = Vec::new();
        let mut failed = None;
        self.each_view(|viewed| {
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
                    Err(e) => {
                        failed = Some(e);
                        return false;
                    }
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
        if let Some(pieces) = self.in_place() {
            return run_pair_held(&pieces, cfgs, reference);
        }
        let mut lanes = [
            Lane::new(StaticDetector::with_reference(cfgs[0], reference)?),
            Lane::new(StaticDetector::with_reference(cfgs[1], reference)?),
        ];
        let mut failed = None;
        self.each_view(|viewed| {
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

impl InPieces<'_> {
    /// The detector's view of every sample in place, when it is the spill's (values on no
    /// lattice, the spill in memory with `f32` axes: [`TextSource::axes_f32_in_place`]): the
    /// passes then run as over held samples, with no copy and no step per piece.
    fn in_place(&self) -> Option<Vec<&[[f32; 3]]>> {
        self.lattice
            .is_none()
            .then(|| self.src.axes_f32_in_place())
            .flatten()
    }

    /// A pass over the detector's view of every sample, a piece at a time (`f` may stop it
    /// by returning `false`): values on no lattice read straight to `f32`, else their levels.
    fn each_view(&self, mut f: impl FnMut(&[[f32; 3]]) -> bool) {
        use rayon::prelude::*;
        if self.lattice.is_none() {
            return self.src.each_piece_f32(f);
        }
        let mut viewed = Vec::new();
        self.src.each_piece(Want::AXES, |cols| {
            let samples = cols.xyz.par_iter().map(|x| view(x, &self.lattice));
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

/// The per-axis quantiser lattice of `detect::windows::lattice_view` from the first pass's
/// distinct values: `None` for integers, continuous or non-finite values.
fn lattice(src: &TextSource) -> Option<[(f64, f64); 3]> {
    if src.summary.integer {
        return None;
    }
    let found;
    let distinct = match &src.summary.distinct {
        Distinct::Values(v) => v,
        Distinct::TooMany => return None,
        Distinct::NotKept => {
            found = distinct_in_a_pass(src)?;
            &found
        }
    };
    let mut out = [(0.0, 0.0); 3];
    for (a, v) in distinct.iter().enumerate() {
        if v.iter().any(|x| !x.is_finite()) {
            return None;
        }
        out[a] = axis_lattice(v)?;
    }
    Some(out)
}

/// Each axis's distinct values in a pass of their own (the first pass did not keep them:
/// [`Distinct::NotKept`]); `None` past `MAX_DISTINCT`, or when the pass ended early (which
/// [`TextSource::check`] after the detection reports).
fn distinct_in_a_pass(src: &TextSource) -> Option<[Vec<f64>; 3]> {
    let mut fold = SummaryFold::keeping();
    src.each_piece(Want::AXES, |cols| {
        fold.push(&cols.xyz, &[], &[]);
        true
    });
    let complete = src.check().is_ok();
    match fold.finish().distinct {
        Distinct::Values(v) if complete => Some(v),
        _ => None,
    }
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
/// bits of their total order 16 at a time ([`crate::stats::OrderCounts::median`]: a pass to
/// count them, three for the lower middle value, one for the upper), none stored.
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
    if let Some(stats) = window_stats_spilled(src, intervals, (&checked, &spans), range, fs) {
        return stats;
    }
    let mut accs: Vec<Acc> = spans.iter().map(|&span| Acc::new(span)).collect();
    let mut saturated: Option<(usize, DetectError)> = None;
    let (mut sat_cover, mut cover) = (Cover::new(&checked), Cover::new(&spans));
    for (i, r) in src.rows().enumerate() {
        if let Some((lo, hi)) = range {
            for &k in sat_cover.at(i) {
                if saturated.as_ref().is_some_and(|(first, _)| *first <= k) {
                    continue;
                }
                if let Some(a) = (0..3).find(|&a| r.xyz[a] <= lo || r.xyz[a] >= hi) {
                    saturated = Some((k, saturated_at(intervals, k, i, a, r.xyz[a])));
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
            accs[k].runs.push(&r.xyz, &means[k]);
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

/// A window's samples: the first and one past the last.
type Span = (usize, usize);

/// Rows a window reads from the spill at a time ([`window_stats_spilled`]).
const WINDOW_READ_ROWS: usize = 1 << 16;

/// [`window_stats`] from the rows the first pass wrote ([`TextSource::read_spilled`]): each
/// window's rows alone read back, on all cores, window by window (each window's sums in
/// sample order as the passes fold them: the same values). `checked`: the intervals' sample
/// spans, `spans`: those of at least two samples. `None` when the file has no spill, or a
/// read of it failed (the passes then read every sample).
fn window_stats_spilled(
    src: &TextSource,
    intervals: &[StaticInterval],
    (checked, spans): (&[Span], &[Span]),
    range: Option<(f64, f64)>,
    fs: f64,
) -> Option<Result<Vec<WindowStats>>> {
    use rayon::prelude::*;
    if !src.is_spilled() || !src.unchanged() {
        return None; // the passes say that the file changed
    }
    debug_assert_eq!(
        spans.len(),
        checked.iter().filter(|(s, e)| *e > s + 1).count()
    );
    let per_window = checked
        .par_iter()
        .map_init(Buffers::default, |buf, &span| {
            buf.window(src, span, range, fs)
        })
        .collect::<Option<Vec<_>>>()?;
    let saturated = per_window
        .iter()
        .enumerate()
        .find_map(|(k, (f, _))| f.map(|f| (k, f)));
    if let Some((k, (i, a, value))) = saturated {
        return Some(Err(saturated_at(intervals, k, i, a, value).into()));
    }
    // The windows of two samples or more, in order: `spans`'.
    let accs: Vec<Acc> = per_window.into_iter().filter_map(|(_, a)| a).collect();
    let t0 = time_of(src.summary.t_first, 0, fs);
    let (integer, has_temp) = (src.summary.integer, src.has_temp());
    Some(Ok(accs
        .iter()
        .map(|a| finish(a, t0, integer, has_temp))
        .collect()))
}

/// A window's read buffers.
#[derive(Default)]
struct Buffers {
    cols: Columns,
    scratch: Vec<u8>,
}

/// A window's first sample at an ADC limit: its index, axis and value.
type AtLimit = (usize, usize, f64);

impl Buffers {
    /// The window `span`'s first sample at an ADC limit of `range` (when given) and, when it
    /// has two samples or more, its sums: its rows read from the spill once (twice when
    /// longer than [`WINDOW_READ_ROWS`]); `None` when a read failed.
    fn window(
        &mut self,
        src: &TextSource,
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
        let read = self.fold(src, (s, e), |i, x, t, temp| {
            found = found.or_else(|| at_limit(i, x));
            if let Some(acc) = &mut acc {
                first_sums(acc, i, x, time_of(t, i, fs), temp);
            }
        });
        if !read {
            return None;
        }
        if let Some(acc) = &mut acc {
            let m = mean_of(acc);
            let add = |acc: &mut Acc, x: &[f64; 3]| {
                for ((q, x), m) in acc.sq.iter_mut().zip(x).zip(&m) {
                    *q += (x - m).powi(2);
                }
                acc.runs.push(x, &m);
            };
            if e - s <= WINDOW_READ_ROWS {
                // The rows read above, still in the buffer.
                self.cols.xyz.iter().for_each(|x| add(acc, x));
            } else if !self.fold(src, (s, e), |_, x, _, _| add(acc, x)) {
                return None;
            }
        }
        Some((found, acc))
    }

    /// `f(i, values, time, temperature)` on each sample `i` of `span`, in order, read from the
    /// spill [`WINDOW_READ_ROWS`] at a time; false when a read failed.
    fn fold(
        &mut self,
        src: &TextSource,
        (s, e): (usize, usize),
        mut f: impl FnMut(usize, &[f64; 3], Option<f64>, Option<f64>),
    ) -> bool {
        let mut from = s;
        while from < e {
            let to = e.min(from + WINDOW_READ_ROWS);
            if !src.read_spilled((from, to), &mut self.cols, &mut self.scratch) {
                return false;
            }
            let c = &self.cols;
            for (j, x) in c.xyz.iter().enumerate() {
                f(from + j, x, c.t.get(j).copied(), c.temp.get(j).copied());
            }
            from = to;
        }
        true
    }
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
        runs: Some({
            let mut r = a.runs.clone();
            r.close();
            r
        }),
        distinct: None,
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

/// A streamed file whose rows are kept in memory, on disk, or moved to disk as they are
/// written, or cannot be written to a temporary file (no such directory, a disk full from the
/// start or after a few blocks), or whose spill cannot be read back in the middle of a pass,
/// gives the rows, the windows and the clones of the text parsed again.
#[cfg(test)]
mod spill_tests {
    use crate::input::columns::LoadOptions;
    use crate::input::text_source::{Row, SpillTo, TextSource};

    /// A simulated recording of `cfg` written as CSV into a temporary directory (kept alive by
    /// the first value): the directory, the file, its rows.
    fn simulated_csv(
        cfg: crate::simulate::SimConfig,
    ) -> (tempfile::TempDir, std::path::PathBuf, usize) {
        let out = crate::simulate::simulate(&cfg).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.csv");
        std::fs::write(&path, crate::simulate::to_csv(&out.recording)).unwrap();
        (dir, path, out.recording.len())
    }

    fn rows_of(src: &TextSource) -> Vec<Row> {
        let rows: Vec<Row> = src.rows().collect();
        src.check().unwrap();
        rows
    }

    fn windows_of(src: &TextSource) -> String {
        let opts = crate::detect::windows::DetectOptions::default();
        let w = super::detect_windows_streamed(src, &opts).unwrap();
        format!(
            "{:?} {:?} {:?} {:?}",
            w.stats, w.clock, w.units, w.reference_variance
        )
    }

    #[test]
    #[allow(clippy::too_many_lines, reason = "a test reads top to bottom")]
    fn without_the_spill_the_text_is_read_again_alike() {
        let (dir, path, rows) = simulated_csv(crate::simulate::SimConfig {
            seed: 3,
            poses: 12,
            temp_column: true,
            ..Default::default()
        });
        let opts = LoadOptions::default();
        let open = |to: &SpillTo| {
            TextSource::open_with(&path, &opts, 4096, to, |_| true)
                .unwrap()
                .unwrap()
        };
        let on = SpillTo {
            on: true,
            dir: None,
            limit: u64::MAX,
            memory: 0,
        };
        let text = open(&SpillTo {
            on: false,
            ..on.clone()
        });
        assert!(!text.is_spilled());
        let (want_rows, want_windows) = (rows_of(&text), windows_of(&text));
        assert_eq!(want_rows.len(), rows);
        let spilled = open(&on);
        assert!(spilled.is_spilled() && !spilled.is_spill_in_memory());
        let no_dir = Some(dir.path().join("no such directory"));
        // (where, spilled, in memory)
        let cases = [
            (on.clone(), true, false),
            (
                SpillTo {
                    memory: u64::MAX,
                    ..on.clone()
                },
                true,
                true,
            ),
            // Moved to disk once past the memory kept.
            (
                SpillTo {
                    memory: 20_000,
                    ..on.clone()
                },
                true,
                false,
            ),
            (
                SpillTo {
                    dir: no_dir.clone(),
                    ..on.clone()
                },
                false,
                false,
            ),
            (
                SpillTo {
                    dir: no_dir.clone(),
                    memory: u64::MAX,
                    ..on.clone()
                },
                true,
                true,
            ),
            (
                SpillTo {
                    dir: no_dir.clone(),
                    memory: 20_000,
                    ..on.clone()
                },
                false,
                false,
            ),
            (
                SpillTo {
                    limit: 0,
                    ..on.clone()
                },
                false,
                false,
            ),
            (
                SpillTo {
                    limit: 20_000,
                    ..on.clone()
                },
                false,
                false,
            ),
            (
                SpillTo {
                    limit: 20_000,
                    memory: u64::MAX,
                    ..on.clone()
                },
                false,
                false,
            ),
        ];
        for (to, is_spilled, in_memory) in &cases {
            let src = open(to);
            assert_eq!(src.is_spilled(), *is_spilled, "{to:?}");
            assert_eq!(src.is_spill_in_memory(), *in_memory, "{to:?}");
            assert_eq!(rows_of(&src), want_rows, "{to:?}");
            assert_eq!(windows_of(&src), want_windows, "{to:?}");
        }
        // The spill emptied in the middle of a pass (and of a clone's): both go on from the
        // text at the same row; every later pass reads the text.
        let mut it = spilled.rows();
        let head: Vec<Row> = it.by_ref().take(1000).collect();
        let clone = it.clone();
        spilled.truncate_spill();
        let rest: Vec<Row> = it.collect();
        assert_eq!([head.clone(), rest].concat(), want_rows);
        assert_eq!([head, clone.collect()].concat(), want_rows);
        assert!(!spilled.is_spilled());
        assert_eq!(windows_of(&spilled), want_windows);
        spilled.check().unwrap();
    }

    /// The detector's view read straight to `f32` is every row's values as `f32`, from memory,
    /// from disk, from the text, and from a spill that fails in the middle of the pass (the
    /// pass going on from the text at the same row).
    #[test]
    fn the_f32_view_is_the_rows_whatever_the_spill() {
        let (_dir, path, rows) = simulated_csv(crate::simulate::SimConfig {
            seed: 5,
            poses: 9,
            ..Default::default()
        });
        let opts = LoadOptions::default();
        let disk = SpillTo {
            on: true,
            dir: None,
            limit: u64::MAX,
            memory: 0,
        };
        let cases = [
            (disk.clone(), false),
            (
                SpillTo {
                    memory: u64::MAX,
                    ..disk.clone()
                },
                false,
            ),
            (
                SpillTo {
                    on: false,
                    ..disk.clone()
                },
                false,
            ),
            (disk.clone(), true),
        ];
        for (to, fail) in cases {
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
            src.check().unwrap();
            assert!(pieces > 2, "{pieces} pieces");
            assert_eq!(got, want, "{to:?}, failing: {fail}");
            assert_eq!(src.is_spilled(), to.on && !fail);
        }
    }
}
