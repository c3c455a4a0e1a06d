//! The detector's decisions alone: where [`StaticDetector`]'s static runs begin and end,
//! without the statistics it keeps of each run as it goes.
//!
//! ## Why
//! The detector pushes every static sample into its run's [`Welford3`]: a division and a chain
//! of dependent additions per sample, the longest chain of its loop, which then runs at the
//! latency of that chain rather than at the speed of its arithmetic. A caller that holds the
//! samples (the host's analysis of a recording in memory) needs the statistics of only some
//! runs, and can measure those once the detection is over, several runs at once (independent
//! chains, on several cores): the spans, then [`StaticInterval::of_run`] of each run's samples,
//! are the detector's intervals bit for bit.
//!
//! ## Exactness
//! The same window arithmetic on the same values, in the same order (the detector's own code);
//! a span ends wherever the detector reports an interval, and a sample is refused wherever the
//! detector refuses it. The one difference: the detector also fails when a run's statistics
//! overflow `f32` ([`Error::NonFinite`] from a square beyond `f32::MAX`), which a span detector
//! does not compute. That never happens while every value is at most [`EXACT_SPAN_ABS`] in
//! magnitude ([`spans_are_exact`]): a caller that wants the detector's result exactly checks
//! that first.

use super::{Positions, StaticDetector, StaticDetectorConfig};
use crate::estimators::Welford3;
use crate::Error;

/// Largest magnitude of a value for which a run's statistics never overflow (2⁴⁰): a run of
/// at most `u32::MAX` samples of magnitude ≤ 2⁴⁰ has deviations below 2⁴², squared deviations
/// below 2⁸⁴ and a sum of them below 2¹¹⁶, far from `f32::MAX` (≈ 2¹²⁸).
pub const EXACT_SPAN_ABS: f32 = 1_099_511_627_776.0;

/// True when every value of `samples` is at most [`EXACT_SPAN_ABS`] in magnitude (NaN: false),
/// so that [`SpanDetector`]'s spans are exactly [`StaticDetector`]'s intervals.
pub fn spans_are_exact(samples: &[[f32; 3]]) -> bool {
    // A fold without early exit: one compare per value, no branch per sample.
    samples.iter().fold(true, |ok, m| {
        ok & m
            .iter()
            .fold(true, |o, v| o & (libm::fabsf(*v) <= EXACT_SPAN_ABS))
    })
}

/// A static run as [`StaticDetector`] decides it: samples `start..end` (indices in the stream,
/// `end` exclusive), at least `min_static_samples` long.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StaticSpan {
    /// Index of the first static sample.
    pub start: u32,
    /// Index one past the last static sample.
    pub end: u32,
}

impl StaticSpan {
    /// Number of samples.
    pub fn len(&self) -> u32 {
        self.end - self.start
    }

    /// True for an empty span (never reported).
    pub fn is_empty(&self) -> bool {
        self.end == self.start
    }
}

/// A [`StaticDetector`] that reports its runs' bounds ([`StaticSpan`]) instead of its
/// intervals (see the module docs); its noise reference given up front, as
/// [`StaticDetector::with_reference`]'s.
#[derive(Debug, Clone)]
pub struct SpanDetector<const N: usize> {
    det: StaticDetector<N>,
}

impl<const N: usize> SpanDetector<N> {
    /// The detector of [`StaticDetector::with_reference`] (the same checks of `cfg` and of
    /// the reference variance, per axis, raw units²).
    pub fn with_reference(
        cfg: StaticDetectorConfig,
        reference_variance: [f32; 3],
    ) -> Result<Self, Error> {
        StaticDetector::with_reference(cfg, reference_variance).map(|det| Self { det })
    }

    /// Feeds `samples` in order, as [`StaticDetector::push_slice`] does, calling `on_span` for
    /// each run that ends where the detector would report an interval; stops at the sample the
    /// detector would refuse (`Err((its index in samples, the error))`), the samples before it
    /// fed.
    pub fn push_slice(
        &mut self,
        samples: &[[f32; 3]],
        mut on_span: impl FnMut(StaticSpan),
    ) -> Result<(), (usize, Error)> {
        let (fed, refused) = self.det.acceptable(samples);
        let mut i = 0;
        // The warm-up (the window filling) by the detector's own step: at most a window.
        while i < fed && !self.det.steady() {
            if let Some(iv) = self.det.step(samples[i]).map_err(|e| (i, e))? {
                on_span(StaticSpan {
                    start: iv.start,
                    end: iv.end,
                });
            }
            i += 1;
        }
        if i < fed {
            self.steady_spans(&samples[i..fed], &mut on_span);
        }
        refused.map_or(Ok(()), Err)
    }

    /// The detector's steady state ([`StaticDetector::steady_run`]) with the run's start
    /// alone: a run's length is its sample count (the detector pushes each of its samples
    /// once), compared with `min_static_samples` as the detector compares its count.
    fn steady_spans(&mut self, samples: &[[f32; 3]], on_span: &mut impl FnMut(StaticSpan)) {
        let det = &mut self.det;
        let Some(k) = det.steady_consts() else {
            return;
        };
        let (mut sums, mut count) = (det.sums, det.count);
        let mut start = det.run.as_ref().map(|(s, _)| *s);
        let mut at = Positions::new::<N>(det.ring.next, &k);
        for m in samples {
            let state = (&mut sums, &mut count);
            let variance = StaticDetector::steady_window(&mut det.ring, &mut at, state, &k, m);
            let centre = count - 1 - k.half as u32;
            if variance <= k.threshold {
                start.get_or_insert(centre);
            } else if let Some(s) = start.take() {
                if centre - s >= k.min_static {
                    on_span(StaticSpan {
                        start: s,
                        end: centre,
                    });
                }
            }
        }
        det.ring.next = at.next;
        det.ring.len = (det.ring.len + samples.len()).min(N);
        (det.sums, det.count) = (sums, count);
        // The run's statistics are not kept: only its start is read from here on.
        det.run = start.map(|s| (s, Welford3::new()));
    }

    /// Ends the stream: the run still open, when long enough ([`StaticDetector::finish`]).
    pub fn finish(&mut self) -> Option<StaticSpan> {
        let end = self.det.count.saturating_sub(self.det.half() as u32);
        let (start, _) = self.det.run.take()?;
        (end - start >= self.det.cfg.min_static_samples).then_some(StaticSpan { start, end })
    }

    /// Number of samples pushed so far.
    pub fn samples_seen(&self) -> u32 {
        self.det.samples_seen()
    }
}
