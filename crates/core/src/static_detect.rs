//! Static-interval detection on a stream of 3-axis samples.
//!
//! The method of IMU-TK (Tedaldi et al., ICRA 2014): a recording starts with the sensor at
//! rest for `init_samples` samples; the per-axis variance of that period is the sensor's noise
//! reference. Afterwards each sample is classified by the variance of a window centred on it:
//! static when the sum of the per-axis window variances is at most `threshold_factor` times the
//! sum of the reference variances. Runs of static samples at least `min_static_samples` long are
//! reported as [`StaticInterval`]s with their mean and variance.
//!
//! The initial rest period is itself a static pose and is reported like the others.
//!
//! Streaming and memory: the detector keeps a ring of the last `N` samples (`N` = window
//! length, a const generic, odd) and decides sample `k − (N−1)/2` when sample `k` arrives, so
//! results lag by half a window. The window variance comes from running sums of deviations from
//! a shift (O(1) per sample). Plain running sums of squares would cancel catastrophically in
//! `f32` on raw counts in the tens of thousands, so the sums are taken about the window mean of
//! the last exact two-pass recomputation, and that recomputation is redone once per window
//! length, whenever the sum of squares has fallen a thousandfold since it (motion has just
//! left the window: the rounding error left behind by large values would otherwise dominate the
//! small static variance), and whenever the window mean has moved so far from the shift that
//! `s2 − s1²/n` would cancel a thousandfold. Amortised cost: O(1) per sample.

use crate::estimators::Welford3;
use crate::Error;

pub mod adaptive;
#[cfg(test)]
mod identity;
#[cfg(test)]
mod reference;
mod spans;
pub use adaptive::{AdaptiveDetection, AdaptiveThresholds, NoiseSurvey};
pub use spans::{spans_are_exact, SpanDetector, StaticSpan, EXACT_SPAN_ABS};

/// Detector settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StaticDetectorConfig {
    /// Length of the centred variance window in samples: odd, ≥ 3, at most the detector's
    /// capacity `N`.
    pub window: u16,
    /// Length of the initial rest period used as the noise reference, in samples.
    pub init_samples: u32,
    /// A sample is static when its window variance ≤ this × the reference variance.
    pub threshold_factor: f32,
    /// Shortest static run to report, in samples.
    pub min_static_samples: u32,
    /// Floor on the per-axis reference variance (raw units²), so that a quantised sensor
    /// whose rest readings do not change (variance 0) still gets a usable threshold.
    /// A uniform quantiser of step 1 has variance 1/12.
    pub min_variance: f32,
}

impl StaticDetectorConfig {
    /// Settings for a sample rate: a window of `window_s` seconds (rounded to an odd count),
    /// an init period of `init_s` seconds, a minimum static run of `min_static_s` seconds,
    /// threshold factor 6 and the quantisation floor of a unit step.
    pub fn for_rate(rate_hz: f32, window_s: f32, init_s: f32, min_static_s: f32) -> Self {
        let w = (rate_hz * window_s) as u32;
        Self {
            window: (w | 1).clamp(3, u16::MAX as u32 - 1) as u16,
            init_samples: (rate_hz * init_s) as u32,
            threshold_factor: 6.0,
            min_static_samples: (rate_hz * min_static_s) as u32,
            min_variance: 1.0 / 12.0,
        }
    }
}

/// One detected static interval (a pose).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StaticInterval {
    /// Index of the first static sample.
    pub start: u32,
    /// Index one past the last static sample.
    pub end: u32,
    /// Mean of the samples in the interval.
    pub mean: [f32; 3],
    /// Per-axis unbiased variance of the samples in the interval.
    pub variance: [f32; 3],
}

impl StaticInterval {
    /// Number of samples.
    pub fn len(&self) -> u32 {
        self.end - self.start
    }

    /// True for an empty interval (never reported by the detector).
    pub fn is_empty(&self) -> bool {
        self.end == self.start
    }

    /// The interval of the static run `start..end` whose samples `stats` holds, pushed in
    /// order (as the detector pushes them): its mean and unbiased variance (zeros for a single
    /// sample); `None` for no sample. With [`SpanDetector`]'s spans, the detector's own
    /// intervals, bit for bit.
    #[inline]
    pub fn of_run(start: u32, end: u32, stats: &Welford3) -> Option<Self> {
        let mean = stats.mean().ok()?;
        let var = stats.variance().unwrap_or_else(|_| crate::Vec3::zeros());
        Some(StaticInterval {
            start,
            end,
            mean: [mean.x, mean.y, mean.z],
            variance: [var.x, var.y, var.z],
        })
    }
}

/// Streaming static-interval detector; `N` is the capacity of its sample ring, the upper bound
/// of the window length.
#[derive(Debug, Clone)]
pub struct StaticDetector<const N: usize> {
    cfg: StaticDetectorConfig,
    ring: Ring<N>,
    /// Number of samples pushed.
    count: u32,
    init: Welford3,
    /// Sum of per-axis reference variances × threshold factor (set after the init period).
    threshold: Option<f32>,
    /// The static run being accumulated: start index and statistics.
    run: Option<(u32, Welford3)>,
    /// A noise reference given up front ([`StaticDetector::with_reference`]) instead of an
    /// initial rest period.
    given_reference: Option<[f32; 3]>,
    /// Running sums over the current window.
    sums: WindowSums,
}

/// Running sums of `x − shift` and `(x − shift)²` over the window (see the module docs).
#[derive(Debug, Clone, Copy, Default)]
struct WindowSums {
    shift: [f32; 3],
    s1: [f32; 3],
    s2: [f32; 3],
    /// Largest total `s2` since the last exact recomputation.
    peak: f32,
    /// Samples added since the last exact recomputation.
    since: u32,
}

impl WindowSums {
    /// Adds a sample entering the window.
    #[allow(clippy::needless_range_loop)] // four arrays indexed by the same axis
    #[inline]
    fn add(&mut self, x: &[f32; 3]) {
        for a in 0..3 {
            let d = x[a] - self.shift[a];
            self.s1[a] += d;
            self.s2[a] += d * d;
        }
    }

    /// Takes out a sample leaving the window: the same operations as adding it with the
    /// opposite sign (`s + (−d) = s − d` exactly in IEEE arithmetic).
    #[allow(clippy::needless_range_loop)] // four arrays indexed by the same axis
    #[inline]
    fn remove(&mut self, x: &[f32; 3]) {
        for a in 0..3 {
            let d = x[a] - self.shift[a];
            self.s1[a] -= d;
            self.s2[a] -= d * d;
        }
    }

    #[inline]
    fn total_s2(&self) -> f32 {
        self.s2[0] + self.s2[1] + self.s2[2]
    }

    /// Sum over axes of the (population) variance of the `n` samples in the window.
    #[inline]
    fn variance_sum(&self, n: f32) -> f32 {
        let mut var = 0.0f32;
        for a in 0..3 {
            var += (self.s2[a] - self.s1[a] * self.s1[a] / n).max(0.0);
        }
        var / n
    }
}

/// The steady state's constants ([`StaticDetector::steady_consts`]).
#[derive(Debug, Clone, Copy)]
struct SteadyConsts {
    window: usize,
    half: usize,
    /// The window's length as the divisor of the variance.
    n: f32,
    threshold: f32,
    min_static: u32,
}

/// Ring positions of a full window, advanced one sample at a time: where the next sample
/// goes, the window's oldest sample before that write (the one leaving) and the window's
/// centre after it.
#[derive(Debug, Clone, Copy)]
struct Positions {
    next: usize,
    oldest: usize,
    centre: usize,
}

impl Positions {
    /// The positions for a ring of capacity `N` whose next write goes to `next`.
    #[inline]
    fn new<const N: usize>(next: usize, k: &SteadyConsts) -> Self {
        // Each sum is below 2N (next < N, window ≤ N, 1 + half ≤ window).
        let wrap = |i: usize| if i >= N { i - N } else { i };
        let oldest = wrap(next + N - k.window);
        Self {
            next,
            oldest,
            centre: wrap(oldest + 1 + k.half),
        }
    }

    /// One sample on (after the write and the reads of the oldest and the centre).
    #[inline(always)]
    fn advance<const N: usize>(&mut self) {
        let step = |i: usize| if i + 1 == N { 0 } else { i + 1 };
        self.next = step(self.next);
        self.oldest = step(self.oldest);
        self.centre = step(self.centre);
    }
}

/// The last `N` samples in a fixed array used as a ring (on the stack, like the rest of the
/// detector). Written by hand rather than with `heapless::HistoryBuf` so that the window's
/// samples are found by one index computation, not by splitting the buffer per access: the
/// detector reads two of them per sample.
#[derive(Debug, Clone)]
struct Ring<const N: usize> {
    buf: [[f32; 3]; N],
    /// Where the next sample goes.
    next: usize,
    /// Samples held (at most `N`).
    len: usize,
}

impl<const N: usize> Ring<N> {
    const fn new() -> Self {
        Self {
            buf: [[0.0; 3]; N],
            next: 0,
            len: 0,
        }
    }

    #[inline]
    fn write(&mut self, m: [f32; 3]) {
        self.buf[self.next] = m;
        self.next = if self.next + 1 == N { 0 } else { self.next + 1 };
        self.len = (self.len + 1).min(N);
    }

    /// The `i`-th (0 = oldest) of the latest `w` samples; `i < w ≤ len`.
    #[inline]
    fn at(&self, w: usize, i: usize) -> [f32; 3] {
        // next + N − w + i < 2N since i < w.
        let k = self.next + N - w + i;
        self.buf[if k >= N { k - N } else { k }]
    }

    /// The latest `w` samples (`w ≤ len`), oldest first, as at most two contiguous pieces.
    fn latest(&self, w: usize) -> (&[[f32; 3]], &[[f32; 3]]) {
        if w <= self.next {
            (&self.buf[self.next - w..self.next], &[])
        } else {
            (&self.buf[N - (w - self.next)..], &self.buf[..self.next])
        }
    }
}

impl<const N: usize> StaticDetector<N> {
    /// Creates a detector. The window must be odd, ≥ 3 and ≤ `N`; `init_samples` ≥ window;
    /// factors positive.
    pub fn new(cfg: StaticDetectorConfig) -> Result<Self, Error> {
        let w = cfg.window as usize;
        let valid = w >= 3
            && w % 2 == 1
            && w <= N
            && cfg.init_samples as usize >= w
            && cfg.threshold_factor.is_finite()
            && cfg.threshold_factor > 0.0
            && cfg.min_variance.is_finite()
            && cfg.min_variance >= 0.0
            && cfg.min_static_samples >= 1;
        if !valid {
            return Err(Error::InvalidParameter);
        }
        Ok(Self {
            cfg,
            ring: Ring::new(),
            count: 0,
            init: Welford3::new(),
            threshold: None,
            run: None,
            given_reference: None,
            sums: WindowSums::default(),
        })
    }

    /// Creates a detector whose noise reference is known before the first sample (e.g. from
    /// [`AdaptiveThresholds`], measured on the recording itself), so that no initial rest period
    /// is needed: every sample, from the first full window on, is classified against
    /// `threshold_factor × Σ_axes max(reference_variance, min_variance)`; `init_samples` is not
    /// used (it must still be ≥ the window for [`StaticDetector::new`]'s checks).
    pub fn with_reference(
        cfg: StaticDetectorConfig,
        reference_variance: [f32; 3],
    ) -> Result<Self, Error> {
        if !reference_variance
            .iter()
            .all(|v| v.is_finite() && *v >= 0.0)
        {
            return Err(Error::InvalidParameter);
        }
        let mut det = Self::new(cfg)?;
        let floored = reference_variance.map(|v| v.max(cfg.min_variance));
        det.threshold = Some((floored[0] + floored[1] + floored[2]) * cfg.threshold_factor);
        det.given_reference = Some(floored);
        Ok(det)
    }

    /// Half the window: how many samples the decisions lag behind the input.
    pub fn half(&self) -> usize {
        (self.cfg.window as usize - 1) / 2
    }

    /// The latest `window` samples (fewer at the start), oldest first.
    fn window_samples(&self) -> impl Iterator<Item = &[f32; 3]> + '_ {
        let (a, b) = self.ring.latest(self.window_len());
        a.iter().chain(b)
    }

    /// The noise reference (per-axis variance of the init period, floored), once known.
    pub fn reference_variance(&self) -> Option<[f32; 3]> {
        if self.given_reference.is_some() {
            return self.given_reference;
        }
        self.threshold?;
        let v = self
            .init
            .variance()
            .unwrap_or_else(|_| crate::Vec3::zeros());
        Some([v.x, v.y, v.z].map(|x| x.max(self.cfg.min_variance)))
    }

    /// True while a static run is open: the noise reference is known and the latest window
    /// centre was still (a live view's "still / moving"; the run becomes a pose only once it
    /// has lasted `min_static_samples` and ended).
    pub fn is_still(&self) -> bool {
        self.threshold.is_some() && self.run.is_some()
    }

    /// Number of samples pushed so far.
    pub fn samples_seen(&self) -> u32 {
        self.count
    }

    /// Feeds one sample. Returns a static interval when one has just ended.
    /// Non-finite samples are refused (`Error::NonFinite`) and leave the state unchanged.
    #[inline]
    pub fn push(&mut self, m: [f32; 3]) -> Result<Option<StaticInterval>, Error> {
        if !crate::all_finite(&m) {
            return Err(Error::NonFinite);
        }
        if self.count == u32::MAX {
            return Err(Error::CapacityExceeded);
        }
        if self.steady() {
            return self.steady_one(&m);
        }
        self.step(m)
    }

    /// Feeds `samples` in order, as many [`Self::push`]es would (the same operations on the
    /// same values: the same intervals, bit for bit), calling `on_interval` for each static
    /// interval that ends. Stops at the first sample `push` would refuse or fail on, with
    /// `Err((its index in samples, the error))`, the samples before it fed. The finiteness
    /// and counter checks are made once for the slice, and the detector's state stays in
    /// locals through it: cheaper per sample than `push`.
    pub fn push_slice(
        &mut self,
        samples: &[[f32; 3]],
        mut on_interval: impl FnMut(StaticInterval),
    ) -> Result<(), (usize, Error)> {
        let (fed, refused) = self.acceptable(samples);
        let mut i = 0;
        while i < fed && !self.steady() {
            if let Some(iv) = self.step(samples[i]).map_err(|e| (i, e))? {
                on_interval(iv);
            }
            i += 1;
        }
        if i < fed {
            self.steady_run(&samples[i..fed], &mut on_interval)
                .map_err(|(k, e)| (i + k, e))?;
        }
        refused.map_or(Ok(()), Err)
    }

    /// How many of `samples` [`Self::push`] would take before the first it refuses, and that
    /// refusal (its index in `samples` and the error), if any.
    fn acceptable(&self, samples: &[[f32; 3]]) -> (usize, Option<(usize, Error)>) {
        // `push` tests finiteness first, then the counter.
        let room = (u32::MAX - self.count) as usize;
        match samples.iter().position(|m| !crate::all_finite(m)) {
            Some(i) if i <= room => (i, Some((i, Error::NonFinite))),
            _ if samples.len() > room => (room, Some((room, Error::CapacityExceeded))),
            _ => (samples.len(), None),
        }
    }

    /// True once the threshold is known and the window full: every later sample takes
    /// [`Self::steady_run`]'s path.
    #[inline]
    fn steady(&self) -> bool {
        self.threshold.is_some() && self.count as usize >= self.cfg.window as usize
    }

    /// [`Self::step`] for samples that are finite, fit the counter, and arrive in the steady
    /// state ([`Self::steady`]), by [`Self::steady_sample`] on the sums, the run and the
    /// counter held in locals (registers) through the slice, written back at its end or at
    /// the sample that failed.
    fn steady_run(
        &mut self,
        samples: &[[f32; 3]],
        on_interval: &mut impl FnMut(StaticInterval),
    ) -> Result<(), (usize, Error)> {
        let Some(k) = self.steady_consts() else {
            return Ok(());
        };
        let (mut sums, mut run, mut count) = (self.sums, self.run, self.count);
        let mut at = Positions::new::<N>(self.ring.next, &k);
        let mut failed = None;
        for (i, m) in samples.iter().enumerate() {
            let sample = Self::steady_sample(
                &mut self.ring,
                &mut at,
                (&mut sums, &mut run, &mut count),
                &k,
                m,
            );
            match sample {
                Ok(Some(iv)) => on_interval(iv),
                Ok(None) => {}
                Err(e) => {
                    failed = Some((i, e));
                    break;
                }
            }
        }
        let fed = failed.map_or(samples.len(), |(i, _)| i + 1);
        self.ring.next = at.next;
        self.ring.len = (self.ring.len + fed).min(N);
        (self.sums, self.run, self.count) = (sums, run, count);
        failed.map_or(Ok(()), Err)
    }

    /// One sample in the steady state, on the detector's own fields (no copies).
    #[inline]
    fn steady_one(&mut self, m: &[f32; 3]) -> Result<Option<StaticInterval>, Error> {
        let Some(k) = self.steady_consts() else {
            return Ok(None);
        };
        let mut at = Positions::new::<N>(self.ring.next, &k);
        let state = (&mut self.sums, &mut self.run, &mut self.count);
        let out = Self::steady_sample(&mut self.ring, &mut at, state, &k, m);
        self.ring.next = at.next;
        self.ring.len = (self.ring.len + 1).min(N);
        out
    }

    /// What the steady state's per-sample work reads and never changes (`None` before the
    /// threshold is known).
    #[inline]
    fn steady_consts(&self) -> Option<SteadyConsts> {
        let window = self.cfg.window as usize;
        Some(SteadyConsts {
            window,
            half: self.half(),
            n: window as f32,
            threshold: self.threshold?,
            min_static: self.cfg.min_static_samples,
        })
    }

    /// [`Self::step`]'s operations in the steady state, in the same order: the window's
    /// length is the constant `k.window`, its oldest sample (leaving) and its centre are at
    /// positions that advance with the ring (`at`) instead of a modular index each, and the
    /// threshold is known. A run can no longer start at sample 0 here (the first centre
    /// decided in the steady state is sample `half + 1`). `ring.next` is brought up to date
    /// only for a recomputation (the caller stores `at.next` after the last sample).
    #[inline(always)]
    fn steady_sample(
        ring: &mut Ring<N>,
        at: &mut Positions,
        (sums, run, count): (&mut WindowSums, &mut Option<(u32, Welford3)>, &mut u32),
        k: &SteadyConsts,
        m: &[f32; 3],
    ) -> Result<Option<StaticInterval>, Error> {
        // The centre is never where `m` goes (it lies inside the window): read before the write.
        let centre = ring.buf[at.centre];
        let variance = Self::steady_window(ring, at, (sums, count), k, m);
        let centre_index = *count - 1 - k.half as u32;
        if variance <= k.threshold {
            let (_, w) = run.get_or_insert((centre_index, Welford3::new()));
            w.push_inlined(centre)?;
            Ok(None)
        } else {
            Ok(Self::close(run, centre_index, k.min_static))
        }
    }

    /// The window's part of [`Self::steady_sample`]: `m` written to the ring, the oldest
    /// sample taken out of the sums and `m` put in, the sums recomputed when stale; the
    /// window's variance sum after it (what the centre's decision compares).
    #[inline(always)]
    fn steady_window(
        ring: &mut Ring<N>,
        at: &mut Positions,
        (sums, count): (&mut WindowSums, &mut u32),
        k: &SteadyConsts,
        m: &[f32; 3],
    ) -> f32 {
        let outgoing = ring.buf[at.oldest];
        ring.buf[at.next] = *m;
        at.advance::<N>();
        *count += 1;
        sums.remove(&outgoing);
        sums.add(m);
        sums.since += 1;
        let total = sums.total_s2();
        sums.peak = sums.peak.max(total);
        let mut variance = sums.variance_sum(k.n);
        let spread = variance * k.n;
        if sums.since as usize >= k.window || total < 1e-3 * sums.peak || spread < 1e-3 * total {
            ring.next = at.next;
            if let Some(fresh) = Self::exact_sums(ring, k.window) {
                *sums = fresh;
            }
            variance = sums.variance_sum(k.n);
        }
        variance
    }

    /// One sample, finite and within the counter, in any state (the warm-up: window filling,
    /// init period).
    fn step(&mut self, m: [f32; 3]) -> Result<Option<StaticInterval>, Error> {
        let window = self.cfg.window as usize;
        let outgoing = (self.ring.len >= window).then(|| self.ring.at(window, 0));
        self.ring.write(m);
        self.count += 1;
        if let Some(o) = outgoing {
            self.sums.remove(&o);
        }
        self.sums.add(&m);
        self.sums.since += 1;
        let total = self.sums.total_s2();
        self.sums.peak = self.sums.peak.max(total);
        // Recompute when the sums are stale (once per window), when large values have left the
        // window (rounding they left behind), or when the shift is far from the window mean
        // (variance = s2 − s1²/n would cancel). The window variance depends on the sums alone,
        // so it is computed once here and again only after a recomputation.
        let mut variance = self.window_variance_sum();
        let spread = variance * self.window_len() as f32;
        if self.sums.since as usize >= window
            || total < 1e-3 * self.sums.peak
            || spread < 1e-3 * total
        {
            self.recompute_sums();
            variance = self.window_variance_sum();
        }
        if self.threshold.is_none() {
            self.init.push(m)?;
            if self.count >= self.cfg.init_samples {
                let v = self
                    .init
                    .variance()
                    .unwrap_or_else(|_| crate::Vec3::zeros());
                let reference: f32 = v.iter().map(|x| x.max(self.cfg.min_variance)).sum();
                self.threshold = Some(reference * self.cfg.threshold_factor);
            }
        }
        let half = self.half();
        if (self.count as usize) < window {
            return Ok(None);
        }
        // Decide the centre sample of the full window. Before the threshold is known, the
        // init period is static by definition.
        let centre_index = self.count - 1 - half as u32;
        let centre = self.ring.at(window, half);
        let is_static = match self.threshold {
            None => true,
            Some(th) => variance <= th,
        };
        let mut ended = None;
        if is_static {
            if self.run.is_none() {
                // The first HALF samples of the recording are only ever seen as window edges;
                // the init period covers them, so start the run at 0 if that is where we are.
                let start = if centre_index as usize == half {
                    0
                } else {
                    centre_index
                };
                let mut w = Welford3::new();
                if start == 0 {
                    for s in self.window_samples().take(half) {
                        w.push(*s)?;
                    }
                }
                self.run = Some((start, w));
            }
            if let Some((_, w)) = self.run.as_mut() {
                w.push(centre)?;
            }
        } else {
            ended = self.close_run(centre_index);
        }
        Ok(ended)
    }

    /// Ends the stream: returns the static interval still open, if long enough. The last
    /// `half()` samples (never at a window centre) are not included.
    pub fn finish(&mut self) -> Option<StaticInterval> {
        let end = self.count.saturating_sub(self.half() as u32);
        self.close_run(end)
    }

    fn close_run(&mut self, end: u32) -> Option<StaticInterval> {
        Self::close(&mut self.run, end, self.cfg.min_static_samples)
    }

    /// Ends the open `run` at `end`: its interval when it has at least `min_static` samples.
    #[inline]
    fn close(
        run: &mut Option<(u32, Welford3)>,
        end: u32,
        min_static: u32,
    ) -> Option<StaticInterval> {
        let (start, w) = run.take()?;
        if w.count() < min_static {
            return None;
        }
        StaticInterval::of_run(start, end, &w)
    }

    /// Number of samples currently in the window.
    fn window_len(&self) -> usize {
        self.ring.len.min(self.cfg.window as usize)
    }

    /// Exact two-pass recomputation of the window sums about the window mean.
    fn recompute_sums(&mut self) {
        if let Some(sums) = Self::exact_sums(&self.ring, self.window_len()) {
            self.sums = sums;
        }
    }

    /// The sums of the latest `n` samples of `ring` about their mean, by two passes (`None`
    /// for an empty window). Each pass walks the ring's two contiguous pieces in order.
    fn exact_sums(ring: &Ring<N>, n: usize) -> Option<WindowSums> {
        let pieces = ring.latest(n);
        let first = *pieces.0.first().or(pieces.1.first())?;
        let mut mean = [0.0f32; 3];
        // Piece by piece rather than through a chained iterator: no test per sample of
        // which piece it is in (the same additions in the same order).
        for piece in [pieces.0, pieces.1] {
            for s in piece {
                for a in 0..3 {
                    mean[a] += s[a] - first[a];
                }
            }
        }
        let mut sums = WindowSums {
            shift: [0.0; 3],
            ..Default::default()
        };
        for a in 0..3 {
            sums.shift[a] = first[a] + mean[a] / n as f32;
        }
        for piece in [pieces.0, pieces.1] {
            for s in piece {
                sums.add(s);
            }
        }
        sums.peak = sums.total_s2();
        Some(sums)
    }

    /// Sum over axes of the (population) variance of the samples in the window.
    fn window_variance_sum(&self) -> f32 {
        let n = self.window_len() as f32;
        if n == 0.0 {
            return 0.0;
        }
        self.sums.variance_sum(n)
    }

    /// The window variance recomputed exactly (two-pass), for tests of the running sums.
    #[cfg(test)]
    fn exact_window_variance_sum(&self) -> f32 {
        let mut copy = self.clone();
        copy.recompute_sums();
        copy.window_variance_sum()
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops mirror the matrix notation
mod tests {
    use super::*;

    fn cfg() -> StaticDetectorConfig {
        StaticDetectorConfig {
            window: 51,
            init_samples: 200,
            threshold_factor: 6.0,
            min_static_samples: 50,
            min_variance: 1.0 / 12.0,
        }
    }

    /// Deterministic pseudo-noise (xorshift), ±amp, so the test needs no RNG crate.
    struct Noise(u32);
    impl Noise {
        fn next(&mut self, amp: f32) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 17;
            self.0 ^= self.0 << 5;
            (self.0 as f32 / u32::MAX as f32 - 0.5) * 2.0 * amp
        }
    }

    #[test]
    fn finds_poses_separated_by_motion() {
        let mut det: StaticDetector<51> = StaticDetector::new(cfg()).unwrap();
        let mut noise = Noise(12345);
        let poses = [
            [33000.0, 33300.0, 36400.0],
            [29000.0, 33200.0, 32300.0],
            [33100.0, 29200.0, 32300.0],
        ];
        let mut found = heapless::Vec::<StaticInterval, 8>::new();
        let mut idx = 0u32;
        for (p, pose) in poses.iter().enumerate() {
            let len = if p == 0 { 400 } else { 300 };
            for _ in 0..len {
                let s = [
                    pose[0] + noise.next(3.0),
                    pose[1] + noise.next(3.0),
                    pose[2] + noise.next(3.0),
                ];
                if let Some(iv) = det.push(s).unwrap() {
                    found.push(iv).unwrap();
                }
                idx += 1;
            }
            // Motion between poses: a large swing over 100 samples.
            for k in 0..100 {
                let ph = k as f32 * 0.2;
                let s = [
                    pose[0] + 3000.0 * libm::sinf(ph),
                    pose[1] + 2000.0 * libm::cosf(ph),
                    pose[2],
                ];
                if let Some(iv) = det.push(s).unwrap() {
                    found.push(iv).unwrap();
                }
                idx += 1;
            }
        }
        assert_eq!(det.samples_seen(), idx);
        if let Some(iv) = det.finish() {
            found.push(iv).unwrap();
        }
        assert_eq!(found.len(), 3, "{found:?}");
        assert_eq!(found[0].start, 0);
        for (iv, pose) in found.iter().zip(poses.iter()) {
            for a in 0..3 {
                assert!((iv.mean[a] - pose[a]).abs() < 1.0, "{iv:?}");
            }
            assert!(iv.len() >= 200);
        }
    }

    #[test]
    fn rejects_bad_config_and_nan() {
        assert!(StaticDetector::<49>::new(cfg()).is_err());
        let mut even = cfg();
        even.window = 50;
        assert!(StaticDetector::<64>::new(even).is_err());
        let mut c = cfg();
        c.threshold_factor = f32::NAN;
        assert!(StaticDetector::<51>::new(c).is_err());
        let mut d: StaticDetector<51> = StaticDetector::new(cfg()).unwrap();
        assert_eq!(d.push([f32::NAN, 0.0, 0.0]), Err(Error::NonFinite));
        assert_eq!(d.samples_seen(), 0);
    }

    /// The running sums agree with an exact recomputation at every sample, through rest,
    /// large motion and back to rest, on raw counts in the tens of thousands.
    #[test]
    fn running_window_variance_matches_exact() {
        let mut d: StaticDetector<51> = StaticDetector::new(cfg()).unwrap();
        let mut noise = Noise(99);
        for k in 0..3000u32 {
            let phase = (k / 250) % 2;
            let s = if phase == 0 {
                [
                    33000.0 + noise.next(3.0),
                    29000.0 + noise.next(3.0),
                    36000.0,
                ]
            } else {
                let t = k as f32 * 0.05;
                [
                    33000.0 + 4000.0 * libm::sinf(t),
                    29000.0 + 3000.0 * libm::cosf(t),
                    36000.0,
                ]
            };
            d.push(s).unwrap();
            if k >= 50 {
                let run = d.window_variance_sum();
                let exact = d.exact_window_variance_sum();

                assert!(
                    (run - exact).abs() <= 1e-3 * exact + 0.05,
                    "sample {k}: running {run} vs exact {exact}"
                );
            }
        }
    }

    #[test]
    fn constant_quantised_signal_is_static() {
        // A 10-bit sensor at rest may read the same count every time: variance 0. The
        // min_variance floor keeps the threshold positive, so this is one static interval.
        let mut c = cfg();
        c.window = 21;
        let mut d: StaticDetector<64> = StaticDetector::new(c).unwrap();
        for _ in 0..1000 {
            assert_eq!(d.push([512.0, 500.0, 620.0]).unwrap(), None);
        }
        let iv = d.finish().unwrap();
        assert_eq!((iv.start, iv.end), (0, 990));
        assert_eq!(iv.mean, [512.0, 500.0, 620.0]);
    }
}
