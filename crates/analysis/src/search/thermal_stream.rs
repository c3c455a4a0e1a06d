//! The thermal regressors of [`crate::search::thermal`] folded in one pass over a
//! recording's rows, held or read from a large file alike: per window the mean of each lagged
//! temperature (the first-order lag run over every sample for each time constant, summed over
//! the window's samples in order, from the sum `Iterator::sum` starts from) and the temperature
//! rate (the samples of the window's widened span buffered while the pass is inside it, then
//! the least-squares slope). Memory is the windows and the spans open at once.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // The span bounds are a partition point's
                                             // predicate negated.

use crate::search::thermal::{slope, SampleTemps, RATE_SPAN_S};

/// A window as the fold reads it: its sample span (first, one past the last) and the times
/// of its first and last samples, s.
pub type Span = ((usize, usize), (f64, f64));

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
pub fn fold(
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
