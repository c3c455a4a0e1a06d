//! The detector, the noise survey's block measurement and `Welford3` as they were before
//! the per-sample work was made cheaper: kept verbatim (renamed) as the oracle of the tests
//! that the faster code gives the same results, bit for bit. Test builds only.
#![allow(dead_code, clippy::needless_range_loop)]

use super::{StaticDetectorConfig, StaticInterval};
use crate::estimators::Welford;
use crate::Error;

/// `Welford3` as it was: three scalar [`Welford`]s, the state copied per push.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ReferenceWelford3 {
    pub axes: [Welford; 3],
}

impl ReferenceWelford3 {
    pub const fn new() -> Self {
        Self {
            axes: [Welford::new(); 3],
        }
    }

    pub fn push(&mut self, x: [f32; 3]) -> Result<(), Error> {
        if !crate::all_finite(&x) {
            return Err(Error::NonFinite);
        }
        let mut next = self.axes;
        for (acc, v) in next.iter_mut().zip(x) {
            acc.push(v)?;
        }
        self.axes = next;
        Ok(())
    }

    pub const fn count(&self) -> u32 {
        self.axes[0].count()
    }

    pub fn mean(&self) -> Result<crate::Vec3, Error> {
        let [a, b, c] = &self.axes;
        Ok(crate::Vec3::new(a.mean()?, b.mean()?, c.mean()?))
    }

    pub fn variance(&self) -> Result<crate::Vec3, Error> {
        let [a, b, c] = &self.axes;
        Ok(crate::Vec3::new(
            a.variance()?,
            b.variance()?,
            c.variance()?,
        ))
    }

    pub fn reset(&mut self) {
        *self = Self::new();
    }
}

/// The survey's whole-number test as it was.
pub fn reference_whole(m: &[f32; 3]) -> bool {
    m.iter().all(|x| libm::truncf(*x) == *x)
}

/// `NoiseSurvey::measure_block` as it was.
pub fn reference_measure_block(samples: &[[f32; 3]]) -> Result<(crate::Vec3, bool), Error> {
    let mut w = ReferenceWelford3::new();
    let mut all_whole = true;
    for m in samples {
        w.push(*m)?;
        all_whole &= reference_whole(m);
    }
    Ok((w.variance()?, all_whole))
}

/// Streaming static-interval detector; `N` is the capacity of its sample ring, the upper bound
/// of the window length.
#[derive(Debug, Clone)]
pub struct ReferenceDetector<const N: usize> {
    cfg: StaticDetectorConfig,
    ring: Ring<N>,
    /// Number of samples pushed.
    pub count: u32,
    init: ReferenceWelford3,
    /// Sum of per-axis reference variances × threshold factor (set after the init period).
    pub threshold: Option<f32>,
    /// The static run being accumulated: start index and statistics.
    run: Option<(u32, ReferenceWelford3)>,
    /// A noise reference given up front ([`StaticDetector::with_reference`]) instead of an
    /// initial rest period.
    given_reference: Option<[f32; 3]>,
    /// Running sums over the current window.
    pub sums: WindowSums,
}

/// Running sums of `x − shift` and `(x − shift)²` over the window (see the module docs).
#[derive(Debug, Clone, Copy, Default)]
pub struct WindowSums {
    pub shift: [f32; 3],
    pub s1: [f32; 3],
    pub s2: [f32; 3],
    /// Largest total `s2` since the last exact recomputation.
    pub peak: f32,
    /// Samples added since the last exact recomputation.
    pub since: u32,
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

    fn total_s2(&self) -> f32 {
        self.s2[0] + self.s2[1] + self.s2[2]
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

impl<const N: usize> ReferenceDetector<N> {
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
            init: ReferenceWelford3::new(),
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
    pub fn push(&mut self, m: [f32; 3]) -> Result<Option<StaticInterval>, Error> {
        if !crate::all_finite(&m) {
            return Err(Error::NonFinite);
        }
        if self.count == u32::MAX {
            return Err(Error::CapacityExceeded);
        }
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
                let mut w = ReferenceWelford3::new();
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
        let (start, w) = self.run.take()?;
        if w.count() < self.cfg.min_static_samples {
            return None;
        }
        let mean = w.mean().ok()?;
        let var = w.variance().unwrap_or_else(|_| crate::Vec3::zeros());
        Some(StaticInterval {
            start,
            end,
            mean: [mean.x, mean.y, mean.z],
            variance: [var.x, var.y, var.z],
        })
    }

    /// Number of samples currently in the window.
    fn window_len(&self) -> usize {
        self.ring.len.min(self.cfg.window as usize)
    }

    /// Exact two-pass recomputation of the window sums about the window mean.
    fn recompute_sums(&mut self) {
        let n = self.window_len();
        let Some(first) = self.window_samples().next().copied() else {
            return;
        };
        let mut mean = [0.0f32; 3];
        for s in self.window_samples() {
            for a in 0..3 {
                mean[a] += s[a] - first[a];
            }
        }
        let mut sums = WindowSums {
            shift: [0.0; 3],
            ..Default::default()
        };
        for a in 0..3 {
            sums.shift[a] = first[a] + mean[a] / n as f32;
        }
        for s in self.window_samples() {
            sums.add(s);
        }
        sums.peak = sums.total_s2();
        self.sums = sums;
    }

    /// Sum over axes of the (population) variance of the samples in the window.
    fn window_variance_sum(&self) -> f32 {
        let n = self.window_len() as f32;
        if n == 0.0 {
            return 0.0;
        }
        let mut var = 0.0f32;
        for a in 0..3 {
            var += (self.sums.s2[a] - self.sums.s1[a] * self.sums.s1[a] / n).max(0.0);
        }
        var / n
    }

    /// The window variance recomputed exactly (two-pass), for tests of the running sums.
    fn exact_window_variance_sum(&self) -> f32 {
        let mut copy = self.clone();
        copy.recompute_sums();
        copy.window_variance_sum()
    }
}
