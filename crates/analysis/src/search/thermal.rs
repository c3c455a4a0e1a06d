//! The open basis's thermal-lag and temperature-rate regressors: per-window
//! values computed from the recording's per-sample temperature, for
//! [`crate::search::open_basis_screening::host_terms`].
//!
//! * **Thermal lag**: the sensing element follows the measured (case) temperature through a
//!   first-order lag of time constant τ; the regressor is the window mean of
//!   `T_lag += (1 − e^{−Δt/τ})·(T − T_lag)` (the exact discretisation for uneven sample
//!   times, started at the first sample's temperature), for every τ of [`lag_grid`].
//! * **Temperature rate**: dT/dt in °C/s, the least-squares slope of the temperature over the
//!   window widened to at least [`RATE_SPAN_S`] about its centre (clamped to the recording).
//!
//! Both are folded in one pass over the recording's rows, held or read from a large file
//! alike ([`SampleTemps::of`]): per window the mean of each lagged temperature (the lag run
//! over every sample for each time constant, summed over the window's samples in order, from
//! the sum `Iterator::sum` starts from) and the rate (the samples of the window's widened span
//! buffered while the pass is inside it, then the least-squares slope). Memory is the windows
//! and the spans open at once.

/// Number of time constants tried.
pub const LAG_GRID_LEN: usize = 10;
/// Shortest time constant tried, s.
pub const LAG_MIN_S: f64 = 10.0;
/// Shortest span over which dT/dt is fitted, s.
pub const RATE_SPAN_S: f64 = 30.0;

use crate::detect::windows::{sample_clock, DetectOptions, Windows};
use crate::source::RowSource;

/// The thermal regressors' per-window values, folded in one pass over the recording's rows
/// (module docs) whether they are held or read from a large file.
#[derive(Debug, Clone)]
pub struct SampleTemps {
    /// Every window lies in the samples and holds at least two (windows read from a
    /// window-mean table are single rows: no per-sample temperature history), and every time
    /// and temperature is finite; when not, nothing else is filled (the terms are left out).
    pub usable: bool,
    /// Per time constant of [`lag_grid`] (s): the window means of the lagged temperature.
    pub lagged: Vec<(f64, Vec<f64>)>,
    /// dT/dt per window, °C/s (`None` when a window's widened span has no time spread).
    pub rates: Option<Vec<f64>>,
}

impl SampleTemps {
    /// The regressors of the windows `ws` from the rows of `src` (times as the detection with
    /// `detect` took them) for the time constants `taus` (s); a pass that found the file
    /// changed or unreadable says so.
    pub fn of<R: RowSource + ?Sized>(
        src: &R,
        ws: &Windows,
        detect: &DetectOptions,
        taus: &[f64],
    ) -> crate::Result<Self> {
        let time = sample_clock(src, detect);
        let rows = src.rows().enumerate();
        let samples = rows.map(|(i, r)| (time(r.t, i), r.temp.unwrap_or(f64::NAN)));
        let spans: Vec<Span> = (ws.stats.iter())
            .map(|w| ((w.start, w.end), (w.t_first, w.t_last)))
            .collect();
        let temps = fold(samples, src.len(), &spans, taus);
        src.check()?;
        Ok(temps)
    }
}

/// The temperature `temp` (°C, at `times`, s) through a first-order lag of `tau_s`, per
/// sample: `T_lag += (1 − e^{−Δt/τ})·(T − T_lag)`, started at the first sample's temperature
/// (module docs).
pub fn lagged(times: &[f64], temp: &[f64], tau_s: f64) -> Vec<f64> {
    let mut lagged = Vec::with_capacity(temp.len());
    let mut y = temp.first().copied().unwrap_or(0.0);
    let mut prev_t = times.first().copied().unwrap_or(0.0);
    for (&t, &x) in times.iter().zip(temp) {
        let dt = (t - prev_t).max(0.0);
        y += (1.0 - (-dt / tau_s).exp()) * (x - y);
        lagged.push(y);
        prev_t = t;
    }
    lagged
}

/// dT/dt per sample, °C/s: the least-squares slope of the temperature over the samples
/// within ±[`RATE_SPAN_S`]/2 of each (clamped to the recording), the window rates'
/// ([`SampleTemps::rates`]) span for a window of one sample; `None` where that span has no time spread. From running
/// sums (about the first sample, so that they stay small), not one fit per sample: a
/// 400-Hz recording has 12 000 samples in a span. The sums' rounding leaves ~1e-8 relative
/// on a 5-minute recording (tested), far below the `f32` correction it feeds.
pub fn sample_rates(times: &[f64], temp: &[f64]) -> Vec<Option<f64>> {
    let (t0, y0) = (
        times.first().copied().unwrap_or(0.0),
        temp.first().copied().unwrap_or(0.0),
    );
    // Prefix sums of 1, t, y, t², t·y (t and y about the first sample).
    let mut pre = vec![[0.0f64; 5]; times.len() + 1];
    for (i, (&t, &y)) in times.iter().zip(temp).enumerate() {
        let (t, y) = (t - t0, y - y0);
        let add = [1.0, t, y, t * t, t * y];
        pre[i + 1] = std::array::from_fn(|k| pre[i][k] + add[k]);
    }
    let half = 0.5 * RATE_SPAN_S;
    times
        .iter()
        .map(|&c| {
            let lo = times.partition_point(|&t| t < c - half);
            let hi = times.partition_point(|&t| t <= c + half);
            let [n, st, sy, stt, sty]: [f64; 5] = std::array::from_fn(|k| pre[hi][k] - pre[lo][k]);
            let sxx = stt - st * st / n;
            let sxy = sty - st * sy / n;
            (n > 0.0 && sxx > 1e-12 * stt.max(1e-300)).then(|| sxy / sxx)
        })
        .collect()
}

/// Least-squares slope of `y` on `x`; `None` without spread in `x`.
pub(crate) fn slope(x: &[f64], y: &[f64]) -> Option<f64> {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The time constants tried, s: [`LAG_GRID_LEN`] log-spaced values from [`LAG_MIN_S`] to
/// `max_s` (empty when `max_s` is shorter than the first).
pub fn lag_grid(max_s: f64) -> Vec<f64> {
    if max_s.is_nan() || max_s <= LAG_MIN_S {
        return Vec::new();
    }
    let step = (max_s / LAG_MIN_S).ln() / (LAG_GRID_LEN - 1) as f64;
    (0..LAG_GRID_LEN)
        .map(|k| LAG_MIN_S * (step * k as f64).exp())
        .collect()
}

/// The mean of `v` (0 when empty): the origin [`centred`] takes `v` about.
pub fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// `v` centred on its mean and divided by `scale` (the normalised window temperature's
/// `(θ − θ̄)/Θ`); `None` when `v` has no spread.
pub fn centred(v: &[f64], scale: f64) -> Option<Vec<f64>> {
    let m = mean(v);
    let spread = v.iter().map(|x| (x - m).abs()).fold(0.0, f64::max);
    (spread > 0.0 && scale > 0.0).then(|| v.iter().map(|x| (x - m) / scale).collect())
}

/// RMS spread of `v` about its mean.
pub fn rms_spread(v: &[f64]) -> f64 {
    let m = v.iter().sum::<f64>() / v.len().max(1) as f64;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// A window as the fold reads it: its sample span (first, one past the last) and the times
/// of its first and last samples, s.
type Span = ((usize, usize), (f64, f64));

/// A window's widened span for the rate ([`crate::search::thermal`]): its samples are those
/// from the first whose time reaches `lo_t` (or the window's first sample) to the last whose
/// time is within `hi_t` (or the window's last sample).
struct RateSpan {
    lo_t: f64,
    hi_t: f64,
    span: (usize, usize),
    buf: Vec<(f64, f64)>,
    state: u8,
    /// The slope, once the span is done.
    slope: Option<f64>,
}

const WAITING: u8 = 0;
const OPEN: u8 = 1;
const DONE: u8 = 2;

/// Folds the samples' `(time s, temperature °C)` (`n` of them, in time order) over the
/// windows `ws` for the time constants `taus`. Not [`SampleTemps::usable`] (nothing folded)
/// when a window lies outside the samples or holds fewer than two (a window-mean table's
/// rows), or when a time or temperature is not finite.
fn fold(
    samples: impl Iterator<Item = (f64, f64)>,
    n: usize,
    ws: &[Span],
    taus: &[f64],
) -> SampleTemps {
    let mut out = SampleTemps {
        usable: !ws.is_empty() && ws.iter().all(|&((s, e), _)| e >= s + 2 && e <= n),
        lagged: Vec::new(),
        rates: None,
    };
    if !out.usable {
        return out;
    }
    let spans: Vec<(usize, usize)> = ws.iter().map(|w| w.0).collect();
    let zero: f64 = std::iter::empty::<f64>().sum();
    let mut sums = vec![vec![zero; ws.len()]; taus.len()];
    let mut lag = Lag {
        y: vec![0.0f64; taus.len()],
        prev_t: 0.0,
        taus,
    };
    let mut rates = Rates::new(ws);
    let mut cover = crate::detect::windows::Cover::new(&spans);
    let mut finite = true;
    for (i, (t, x)) in samples.enumerate() {
        finite &= t.is_finite() && x.is_finite();
        lag.push(i, t, x);
        for &k in cover.at(i) {
            for (j, v) in lag.y.iter().enumerate() {
                sums[j][k] += v;
            }
        }
        rates.push(i, t, x);
    }
    if !finite {
        out.usable = false;
        return out;
    }
    out.lagged = taus
        .iter()
        .zip(sums)
        .map(|(&tau, s)| {
            let means = s
                .iter()
                .zip(&spans)
                .map(|(v, &(a, b))| v / (b - a) as f64)
                .collect();
            (tau, means)
        })
        .collect();
    out.rates = rates.finish();
    out
}

/// The lagged temperature of every time constant, sample by sample
/// ([`crate::search::thermal::lagged`]).
struct Lag<'a> {
    y: Vec<f64>,
    prev_t: f64,
    taus: &'a [f64],
}

impl Lag<'_> {
    fn push(&mut self, i: usize, t: f64, x: f64) {
        if i == 0 {
            self.y.iter_mut().for_each(|v| *v = x);
            self.prev_t = t;
        }
        let dt = (t - self.prev_t).max(0.0);
        for (v, tau) in self.y.iter_mut().zip(self.taus) {
            *v += (1.0 - (-dt / tau).exp()) * (x - *v);
        }
        self.prev_t = t;
    }
}

/// The rate spans of every window, filled as the pass goes through them.
struct Rates {
    spans: Vec<RateSpan>,
    by_start: Vec<usize>,
    by_time: Vec<usize>,
    next_start: usize,
    next_time: usize,
    open: Vec<usize>,
}

impl Rates {
    fn new(ws: &[Span]) -> Self {
        let rate_spans: Vec<RateSpan> = ws.iter().map(rate_span).collect();
        let mut by_start: Vec<usize> = (0..ws.len()).collect();
        by_start.sort_by_key(|&k| ws[k].0 .0);
        let mut by_time: Vec<usize> = (0..ws.len()).collect();
        by_time.sort_by(|&a, &b| rate_spans[a].lo_t.total_cmp(&rate_spans[b].lo_t));
        Self {
            spans: rate_spans,
            by_start,
            by_time,
            next_start: 0,
            next_time: 0,
            open: Vec::new(),
        }
    }

    /// Sample `i` (time `t`, temperature `x`) into the spans holding it.
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // The span's end: a partition point's
                                                // predicate negated (true for NaN).
    fn push(&mut self, i: usize, t: f64, x: f64) {
        // Spans that begin here: by their first sample, or by time.
        while let Some(&k) = self.by_start.get(self.next_start) {
            if self.spans[k].span.0 > i {
                break;
            }
            open_span(&mut self.spans[k], k, &mut self.open);
            self.next_start += 1;
        }
        while let Some(&k) = self.by_time.get(self.next_time) {
            if t < self.spans[k].lo_t {
                break;
            }
            open_span(&mut self.spans[k], k, &mut self.open);
            self.next_time += 1;
        }
        let spans = &mut self.spans;
        self.open.retain(|&k| {
            let r = &mut spans[k];
            if i >= r.span.1 && !(t <= r.hi_t) {
                // Its samples are all in: the slope now, the buffer freed.
                r.state = DONE;
                r.slope = rate_of(&std::mem::take(&mut r.buf));
                return false;
            }
            r.buf.push((t, x));
            true
        });
    }

    /// The slope over each span (those open at the end of the samples end there).
    fn finish(self) -> Option<Vec<f64>> {
        self.spans
            .iter()
            .map(|r| match r.state {
                DONE => r.slope,
                _ => rate_of(&r.buf),
            })
            .collect()
    }
}

/// The least-squares slope of the buffered `(time, temperature)` samples.
fn rate_of(buf: &[(f64, f64)]) -> Option<f64> {
    let (ts, temps): (Vec<f64>, Vec<f64>) = buf.iter().copied().unzip();
    slope(&ts, &temps)
}

/// The widened span of window `w`: at least [`RATE_SPAN_S`] about its centre
/// ([`crate::search::thermal`]).
fn rate_span(&(span, (t_first, t_last)): &Span) -> RateSpan {
    let centre = 0.5 * (t_first + t_last);
    let half = (0.5 * (t_last - t_first)).max(0.5 * RATE_SPAN_S);
    RateSpan {
        lo_t: centre - half,
        hi_t: centre + half,
        span,
        buf: Vec::new(),
        state: WAITING,
        slope: None,
    }
}

fn open_span(r: &mut RateSpan, k: usize, open: &mut Vec<usize>) {
    if r.state == WAITING {
        r.state = OPEN;
        open.push(k);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fold over `times` and `temp` of windows `spans`, for the time constants `taus`.
    fn fold_of(times: &[f64], temp: &[f64], spans: &[(usize, usize)], taus: &[f64]) -> SampleTemps {
        let ws: Vec<Span> = (spans.iter())
            .map(|&(s, e)| ((s, e), (times[s], times[e - 1])))
            .collect();
        let samples = times.iter().copied().zip(temp.iter().copied());
        fold(samples, times.len(), &ws, taus)
    }

    /// A step of 1 °C at t = 0 through the lag: at t = τ the lagged value is 1 − 1/e,
    /// whatever the (uneven) sample times; a window's value is its samples' mean.
    #[test]
    fn the_lag_follows_a_step_exactly_on_uneven_times() {
        let mut times = vec![-1.0];
        let mut t = 0.0;
        while t < 100.0 {
            times.push(t);
            t += if times.len() % 2 == 0 { 0.7 } else { 1.3 };
        }
        times.push(100.0);
        let temp: Vec<f64> = times
            .iter()
            .map(|&t| if t < 0.0 { 0.0 } else { 1.0 })
            .collect();
        let last = *lagged(&times, &temp, 100.0).last().unwrap();
        // The step reaches the filter at the first sample after it (t = 0, Δt = 1 s).
        let expect = 1.0 - (-101.0f64 / 100.0).exp();
        assert!((last - expect).abs() < 1e-12, "{last} vs {expect}");
        let s = fold_of(&times, &temp, &[(0, 2)], &[100.0]);
        assert!(s.usable);
        let first_two = 0.5 * (1.0 - (-1.0f64 / 100.0).exp());
        assert!((s.lagged[0].1[0] - first_two).abs() < 1e-15);
    }

    /// A temperature ramp of 0.01 °C/s with a 2 s window: the rate is the ramp's slope, fitted
    /// over the 30 s about the window; a window of one sample, or a temperature not finite,
    /// leaves the terms out.
    #[test]
    fn the_rate_of_a_ramp_is_its_slope() {
        let times: Vec<f64> = (0..1000).map(|i| i as f64 * 0.1).collect();
        let mut temp: Vec<f64> = times.iter().map(|t| 20.0 + 0.01 * t).collect();
        for r in fold_of(&times, &temp, &[(500, 520), (0, 20)], &[])
            .rates
            .unwrap()
        {
            assert!((r - 0.01).abs() < 1e-12, "{r}");
        }
        assert!(!fold_of(&times, &temp, &[(500, 501)], &[]).usable);
        temp[900] = f64::NAN;
        assert!(!fold_of(&times, &temp, &[(500, 520)], &[]).usable);
        let g = lag_grid(200.0);
        assert_eq!(g.len(), LAG_GRID_LEN);
        assert!((g[0] - 10.0).abs() < 1e-9 && (g[9] - 200.0).abs() < 1e-9);
        assert!(lag_grid(5.0).is_empty());
    }

    /// The per-sample rate from running sums is the direct least-squares slope over the
    /// same ±15 s (a warm-up curve at 50 Hz, 300 s from t = 1000 s), to 1e-7 relative (the
    /// running sums' rounding; the correction is `f32`, 6e-8); at
    /// the ends the span is clamped to the recording.
    #[test]
    fn per_sample_rates_are_the_slope_over_the_span() {
        let times: Vec<f64> = (0..15_000).map(|i| 1000.0 + i as f64 * 0.02).collect();
        let temp: Vec<f64> = times
            .iter()
            .map(|t| 25.0 + 8.0 * (1.0 - (-(t - 1000.0) / 90.0).exp()) + 0.01 * (t * 7.0).sin())
            .collect();
        let rates = sample_rates(&times, &temp);
        for i in [0, 1, 700, 7_500, 14_999] {
            let c = times[i];
            let lo = times.partition_point(|&t| t < c - 15.0);
            let hi = times.partition_point(|&t| t <= c + 15.0);
            let want = slope(&times[lo..hi], &temp[lo..hi]).unwrap();
            let got = rates[i].unwrap();
            assert!(
                (got - want).abs() <= 1e-7 * want.abs().max(1e-3),
                "{i}: {got} vs {want}"
            );
        }
        // One sample: no spread in time.
        assert_eq!(sample_rates(&[0.0], &[20.0]), vec![None]);
        // The per-sample lag is the one the window means are taken of.
        let s = fold_of(&times, &temp, &[(0, 15_000)], &[60.0]);
        let l = lagged(&times, &temp, 60.0);
        let m = l.iter().sum::<f64>() / l.len() as f64;
        assert_eq!(s.lagged, vec![(60.0, vec![m])]);
    }
}
