//! Static detection whose thresholds come from the recording itself: no initial rest period,
//! and short holds accepted when the recording has nothing longer.
//!
//! ## Why
//! The IMU-TK detector ([`super::StaticDetector::new`]) takes its noise reference from an
//! initial rest period. A recording that starts moving (or never rests for the first seconds)
//! gets a reference made of motion, a threshold hundreds of times too high, and "static"
//! windows that average over motion; a recording whose holds last ~1 s has none of 2 s.
//!
//! ## How
//! 1. **Noise survey** ([`NoiseSurvey`], one streaming pass, fixed memory): the samples are cut
//!    into blocks of [`SURVEY_BLOCK_S`] (0.25 s; short, so that blocks fit inside even 0.5 s
//!    holds) and each block's summed per-axis variance goes into a logarithmic histogram
//!    ([`BINS_PER_OCTAVE`] bins per octave, 2⁻⁸⁰…2⁴⁸ units², 512 bins, ~8 KB). The reference is
//!    the [`DEFAULT_QUANTILE`] (20 %) quantile of the block variances — the noise of the quietest
//!    fifth of the recording, which for any recording that holds still at least a fifth of the
//!    time is the static noise itself (motion only adds variance), and the per-axis reference is
//!    the mean per-axis variance of the blocks in that quantile's bin. A quantile, not the
//!    minimum: a few blocks of a quantised sensor that happen not to toggle would make the
//!    minimum zero. Integer-valued data get the quantisation floor `1/12` (a uniform quantiser of
//!    step 1), floating-point data none.
//! 2. **Detection** with that reference ([`super::StaticDetector::with_reference`]) and the
//!    usual threshold factor 6, trying the hold lengths of [`HOLD_SCHEDULE`] from the longest
//!    (1 s window, 2 s holds: the IMU-TK defaults) down to 0.25 s windows and 0.5 s holds, and
//!    keeping the first that yields at least the caller's `min_windows` static windows (the
//!    most windows when none does). [`detect_fitted`] also requires the setting's windows to
//!    give a multi-position fit, so that windows spanning too few orientations or including
//!    motion (no finite solution, [`Error::Diverged`]) give way to the next setting — IMU-TK's
//!    idea of letting the fit choose among detector settings.
//!
//! On the device the survey runs on a first recording pass (or on a previous session's data);
//! on the host [`detect`] / [`detect_fitted`] run all passes over a slice (an iterator that
//! can be cloned). Measured on every accelerometer recording in the shared data:
//! `docs/solver-and-detection.md`.

use super::{StaticDetector, StaticDetectorConfig, StaticInterval};
use crate::estimators::Welford3;
use crate::Error;

/// Histogram resolution of the survey: 4 bins per octave, so a quantile is known to ±9 %.
pub const BINS_PER_OCTAVE: i32 = 4;
const LOG2_LO: i32 = -80;
const LOG2_HI: i32 = 48;
const BINS: usize = ((LOG2_HI - LOG2_LO) * BINS_PER_OCTAVE) as usize;

/// Length of a survey block, seconds.
pub const SURVEY_BLOCK_S: f32 = 0.25;
/// Quantile of the block variances taken as the noise reference.
pub const DEFAULT_QUANTILE: f32 = 0.2;
/// Threshold factor on the reference (as IMU-TK's default and `wiical fit`'s).
pub const THRESHOLD_FACTOR: f32 = 6.0;
/// Fewest survey blocks for a meaningful quantile.
pub const MIN_SURVEY_BLOCKS: u32 = 8;
/// `(window_s, min_static_s)` pairs tried in order by [`detect`]: the IMU-TK defaults first,
/// then shorter holds.
pub const HOLD_SCHEDULE: [(f32, f32); 3] = [(1.0, 2.0), (0.5, 1.0), (0.25, 0.5)];

/// Streaming noise survey (see the module docs).
#[derive(Debug, Clone)]
pub struct NoiseSurvey {
    block: u32,
    current: Welford3,
    counts: [u32; BINS],
    axis_sums: [[f32; 3]; BINS],
    blocks: u32,
    all_integer: bool,
}

/// Noise reference measured on the recording.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveThresholds {
    /// Per-axis noise variance of a static block, raw units².
    pub reference_variance: [f32; 3],
    /// Floor of the per-axis reference (1/12 for integer data, 0 otherwise).
    pub min_variance: f32,
    /// Blocks surveyed.
    pub blocks: u32,
}

/// True when every value of a sample is a whole number (the survey's test for integer data).
///
/// `truncf(x) == x` without the rounding call: every `f32` of magnitude ≥ 2²³ is whole, and
/// below that [`whole_value`] tests it exactly. The same answer for every value (NaN: false,
/// infinities: true), and branch-free over the three values.
#[inline]
fn whole(m: &[f32; 3]) -> bool {
    whole_value(m[0]) & whole_value(m[1]) & whole_value(m[2])
}

/// [`whole`] of one value, without a conversion to an integer (a saturating one, that the
/// compiler cannot apply to several values at once): below 2²³ in magnitude, adding 2²³
/// rounds `|x|` to an integer (round to nearest, the only mode Rust runs in) and subtracting
/// it again gives `|x|` back exactly when `|x|` was one; NaN is neither.
#[inline(always)]
fn whole_value(x: f32) -> bool {
    const TWO_23: f32 = 8_388_608.0;
    let a = libm::fabsf(x);
    (a >= TWO_23) | ((a + TWO_23) - TWO_23 == a)
}

/// True when every value of `samples` is whole ([`whole`] of each sample), tested over the
/// values as one flat run (several values per operation, where a loop over samples of three
/// tested one at a time).
fn all_whole(samples: &[[f32; 3]]) -> bool {
    samples
        .as_flattened()
        .iter()
        .fold(true, |all, &x| all & whole_value(x))
}

/// Bin of a block variance (0 for zero or underflow, the last bin for overflow).
fn bin_of(v: f32) -> usize {
    // Zero, negative rounding residue or NaN: the lowest bin.
    if v.partial_cmp(&0.0) != Some(core::cmp::Ordering::Greater) {
        return 0;
    }
    let x =
        libm::floorf(libm::log2f(v) * BINS_PER_OCTAVE as f32) as i32 - LOG2_LO * BINS_PER_OCTAVE;
    x.clamp(0, BINS as i32 - 1) as usize
}

impl NoiseSurvey {
    /// A survey with blocks of `block_samples` (≥ 3) samples.
    pub fn new(block_samples: u32) -> Result<Self, Error> {
        if block_samples < 3 {
            return Err(Error::InvalidParameter);
        }
        Ok(Self {
            block: block_samples,
            current: Welford3::new(),
            counts: [0; BINS],
            axis_sums: [[0.0; 3]; BINS],
            blocks: 0,
            all_integer: true,
        })
    }

    /// A survey with blocks of [`SURVEY_BLOCK_S`] at `rate_hz` (at least 5 samples).
    pub fn for_rate(rate_hz: f32) -> Result<Self, Error> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(Error::InvalidParameter);
        }
        Self::new(((rate_hz * SURVEY_BLOCK_S) as u32).max(5))
    }

    /// Feeds one sample (non-finite samples are refused and leave the state unchanged).
    pub fn push(&mut self, m: [f32; 3]) -> Result<(), Error> {
        self.current.push_inlined(m)?;
        self.all_integer &= whole(&m);
        if self.current.count() >= self.block {
            let v = self.current.variance()?;
            self.add_block(v);
            self.current.reset();
        }
        Ok(())
    }

    /// Samples per block.
    pub fn block_samples(&self) -> u32 {
        self.block
    }

    /// The variance of one complete block of samples as [`NoiseSurvey::push`] measures it,
    /// and whether all its values are whole numbers: for a caller that measures the blocks of
    /// a recording on several cores, then gives them to [`NoiseSurvey::add_measured`] in
    /// order (the histogram's sums are then added in the same order, bit for bit).
    pub fn measure_block(samples: &[[f32; 3]]) -> Result<(crate::Vec3, bool), Error> {
        let mut w = Welford3::new();
        w.push_slice(samples).map_err(|(_, e)| e)?;
        Ok((w.variance()?, all_whole(samples)))
    }

    /// [`NoiseSurvey::measure_block`] of four blocks at once (their accumulators filled in
    /// step, [`Welford3::of_four`]: the same results bit for bit, in less time than four
    /// calls).
    pub fn measure_four_blocks(
        blocks: [&[[f32; 3]]; 4],
    ) -> [Result<(crate::Vec3, bool), Error>; 4] {
        let stats = Welford3::of_four(blocks);
        let mut lane = 0;
        stats.map(|w| {
            let samples = blocks[lane];
            lane += 1;
            Ok((w?.variance()?, all_whole(samples)))
        })
    }

    /// Adds a block measured by [`NoiseSurvey::measure_block`] (of [`Self::block_samples`]
    /// samples, the next of the recording; no sample may have been pushed since the last
    /// complete block).
    pub fn add_measured(&mut self, (variance, all_whole): (crate::Vec3, bool)) {
        self.all_integer &= all_whole;
        self.add_block(variance);
    }

    /// A complete block's variance into the histogram.
    fn add_block(&mut self, v: crate::Vec3) {
        let total = v.x + v.y + v.z;
        let b = bin_of(total);
        self.counts[b] = self.counts[b].saturating_add(1);
        for a in 0..3 {
            self.axis_sums[b][a] += v[a];
        }
        self.blocks += 1;
    }

    /// Complete blocks surveyed so far.
    pub fn blocks(&self) -> u32 {
        self.blocks
    }

    /// The noise reference at `quantile` (0 < q < 1) of the block variances:
    /// [`Error::TooFewSamples`] below [`MIN_SURVEY_BLOCKS`] blocks.
    pub fn thresholds(&self, quantile: f32) -> Result<AdaptiveThresholds, Error> {
        if !(quantile > 0.0 && quantile < 1.0) {
            return Err(Error::InvalidParameter);
        }
        if self.blocks < MIN_SURVEY_BLOCKS {
            return Err(Error::TooFewSamples {
                needed: MIN_SURVEY_BLOCKS * self.block,
                got: self.blocks * self.block,
            });
        }
        let rank = libm::ceilf(quantile * self.blocks as f32).max(1.0) as u32;
        let mut seen = 0u32;
        let mut bin = BINS - 1;
        for (b, &c) in self.counts.iter().enumerate() {
            seen += c;
            if seen >= rank {
                bin = b;
                break;
            }
        }
        let n = self.counts[bin].max(1) as f32;
        Ok(AdaptiveThresholds {
            reference_variance: self.axis_sums[bin].map(|s| s / n),
            min_variance: if self.all_integer { 1.0 / 12.0 } else { 0.0 },
            blocks: self.blocks,
        })
    }
}

impl AdaptiveThresholds {
    /// Surveys `samples` (one pass) at `rate_hz` with the default block and quantile.
    pub fn from_samples<I: IntoIterator<Item = [f32; 3]>>(
        samples: I,
        rate_hz: f32,
    ) -> Result<Self, Error> {
        let mut survey = NoiseSurvey::for_rate(rate_hz)?;
        for m in samples {
            survey.push(m)?;
        }
        survey.thresholds(DEFAULT_QUANTILE)
    }

    /// Detector settings for windows of `window_s` and holds of at least `min_static_s` at
    /// `rate_hz`, threshold factor [`THRESHOLD_FACTOR`], this reference's floor; use with
    /// [`StaticDetector::with_reference`]`(cfg, self.reference_variance)`.
    pub fn detector_config(
        &self,
        rate_hz: f32,
        window_s: f32,
        min_static_s: f32,
    ) -> StaticDetectorConfig {
        let mut cfg = StaticDetectorConfig::for_rate(rate_hz, window_s, window_s, min_static_s);
        cfg.init_samples = cfg.init_samples.max(cfg.window as u32);
        cfg.min_static_samples = cfg.min_static_samples.max(1);
        cfg.threshold_factor = THRESHOLD_FACTOR;
        cfg.min_variance = self.min_variance;
        cfg
    }
}

/// What [`detect`] chose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveDetection {
    /// The noise reference measured on the recording.
    pub thresholds: AdaptiveThresholds,
    /// The detector settings used (window, shortest hold, threshold factor, floor).
    pub config: StaticDetectorConfig,
    /// Static windows found with them.
    pub windows: u32,
}

/// Runs one detector over `samples`, calling `on_interval` for each static interval.
pub fn run<const N: usize, I: IntoIterator<Item = [f32; 3]>>(
    samples: I,
    cfg: StaticDetectorConfig,
    reference_variance: [f32; 3],
    mut on_interval: impl FnMut(StaticInterval),
) -> Result<u32, Error> {
    let mut det: StaticDetector<N> = StaticDetector::with_reference(cfg, reference_variance)?;
    let mut count = 0;
    for m in samples {
        if let Some(iv) = det.push(m)? {
            on_interval(iv);
            count += 1;
        }
    }
    if let Some(iv) = det.finish() {
        on_interval(iv);
        count += 1;
    }
    Ok(count)
}

/// The whole adaptive detection (module docs): survey, then the [`HOLD_SCHEDULE`] from the
/// longest holds down until one gives at least `min_windows` windows (else the one giving the
/// most), then a last pass reporting that setting's intervals to `on_interval`. Settings whose
/// window exceeds the capacity `N` are skipped ([`Error::InvalidParameter`] if all are).
pub fn detect<const N: usize, I>(
    samples: I,
    rate_hz: f32,
    min_windows: u32,
    on_interval: impl FnMut(StaticInterval),
) -> Result<AdaptiveDetection, Error>
where
    I: Iterator<Item = [f32; 3]> + Clone,
{
    let thresholds = AdaptiveThresholds::from_samples(samples.clone(), rate_hz)?;
    let (config, _) = choose::<N, I>(&samples, rate_hz, &thresholds, |_, count| {
        count >= min_windows
    })?;
    finish::<N, I>(samples, thresholds, config, on_interval)
}

/// [`detect`], where a setting is accepted only when its windows also give a multi-position
/// fit (`multipos::fit_weighted` with `fit_cfg`): like IMU-TK's threshold sweep, the fit
/// decides, so that a setting whose windows include motion or span too few orientations
/// (no finite solution) gives way to the next. `scratch` holds the window means of one
/// setting (a setting with more windows than `scratch` is accepted on its count). Falls back
/// to [`detect`]'s count rule when no setting fits. Returns the detection and the fit of the
/// chosen windows (or why it failed).
pub fn detect_fitted<const N: usize, I>(
    samples: I,
    rate_hz: f32,
    min_windows: u32,
    fit_cfg: &crate::multipos::MultiPosConfig,
    scratch: &mut [[f32; 3]],
    on_interval: impl FnMut(StaticInterval),
) -> Result<
    (
        AdaptiveDetection,
        Result<crate::multipos::MultiPosFit, Error>,
    ),
    Error,
>
where
    I: Iterator<Item = [f32; 3]> + Clone,
{
    let (chosen, _) = detect_fitted_each::<N, I>(
        samples.clone(),
        rate_hz,
        min_windows,
        fit_cfg,
        scratch,
        |_, _| {},
    )?;
    let (thresholds, config) = (chosen.thresholds, chosen.config);
    let mut n = 0usize;
    let mut on_interval = on_interval;
    let detection = finish::<N, I>(samples, thresholds, config, |iv| {
        if let Some(slot) = scratch.get_mut(n) {
            *slot = iv.mean;
        }
        n += 1;
        on_interval(iv);
    })?;
    let fit = if n > scratch.len() {
        Err(Error::CapacityExceeded)
    } else {
        crate::multipos::fit(&scratch[..n], fit_cfg)
    };
    Ok((detection, fit))
}

/// [`detect_fitted`]'s choice without its final pass: each setting tried reports its
/// intervals as it runs, to `on_interval(setting, interval)` (`setting` the index in
/// [`HOLD_SCHEDULE`]), and the result names the chosen setting's index. A caller that can
/// keep the intervals of every setting tried (the host, with memory to spare) keeps the
/// chosen one's and saves a pass over the samples; [`detect_fitted`] (no storage on the
/// device) runs the chosen setting once more instead.
pub fn detect_fitted_each<const N: usize, I>(
    samples: I,
    rate_hz: f32,
    min_windows: u32,
    fit_cfg: &crate::multipos::MultiPosConfig,
    scratch: &mut [[f32; 3]],
    mut on_interval: impl FnMut(usize, StaticInterval),
) -> Result<(AdaptiveDetection, usize), Error>
where
    I: Iterator<Item = [f32; 3]> + Clone,
{
    let thresholds = AdaptiveThresholds::from_samples(samples.clone(), rate_hz)?;
    // One pass per setting: its count and its window means (in `scratch`) together, so a
    // setting costs one detector pass (before: one to count, one for the means).
    let mut tried: [Option<(StaticDetectorConfig, u32)>; HOLD_SCHEDULE.len()] =
        [None; HOLD_SCHEDULE.len()];
    let mut accepted = None;
    for (setting, (window_s, min_static_s)) in HOLD_SCHEDULE.into_iter().enumerate() {
        let cfg = thresholds.detector_config(rate_hz, window_s, min_static_s);
        if cfg.window as usize > N {
            continue;
        }
        let mut n = 0usize;
        let count = run::<N, _>(samples.clone(), cfg, thresholds.reference_variance, |iv| {
            if let Some(m) = scratch.get_mut(n) {
                *m = iv.mean;
            }
            n += 1;
            on_interval(setting, iv);
        })?;
        tried[setting] = Some((cfg, count));
        // A setting with more windows than `scratch` holds is accepted on its count.
        if count >= min_windows
            && (n > scratch.len() || crate::multipos::fit(&scratch[..n], fit_cfg).is_ok())
        {
            accepted = Some(setting);
            break;
        }
    }
    // No setting fits: the count rule of [`detect`] over the counts already known.
    let setting = match accepted {
        Some(s) => s,
        None => by_count(&tried, min_windows).ok_or(Error::InvalidParameter)?,
    };
    let (config, windows) = tried[setting].ok_or(Error::InvalidParameter)?;
    Ok((
        AdaptiveDetection {
            thresholds,
            config,
            windows,
        },
        setting,
    ))
}

/// [`choose`]'s rule on settings already run (their index): the first with at least
/// `min_windows` windows, else the one with the most windows (ties: the earlier, i.e. the
/// longer holds).
fn by_count(tried: &[Option<(StaticDetectorConfig, u32)>], min_windows: u32) -> Option<usize> {
    let known = || {
        tried
            .iter()
            .enumerate()
            .filter_map(|(i, t)| t.map(|(_, count)| (i, count)))
    };
    if let Some((i, _)) = known().find(|(_, count)| *count >= min_windows) {
        return Some(i);
    }
    let mut best: Option<(usize, u32)> = None;
    for (i, count) in known() {
        if best.is_none_or(|(_, c)| count > c) {
            best = Some((i, count));
        }
    }
    best.map(|(i, _)| i)
}

/// The first setting of the schedule that `accept(config, window count)` takes (`true` with
/// it), else the one with the most windows (ties: the longer holds; `false`). Only settings
/// whose window fits `N` count; `accept` is not called for the others.
fn choose<const N: usize, I>(
    samples: &I,
    rate_hz: f32,
    thresholds: &AdaptiveThresholds,
    mut accept: impl FnMut(StaticDetectorConfig, u32) -> bool,
) -> Result<(StaticDetectorConfig, bool), Error>
where
    I: Iterator<Item = [f32; 3]> + Clone,
{
    let mut best: Option<(StaticDetectorConfig, u32)> = None;
    let mut any_accepted = false;
    for (window_s, min_static_s) in HOLD_SCHEDULE {
        let cfg = thresholds.detector_config(rate_hz, window_s, min_static_s);
        if cfg.window as usize > N {
            continue;
        }
        let count = run::<N, _>(samples.clone(), cfg, thresholds.reference_variance, |_| {})?;
        if accept(cfg, count) {
            best = Some((cfg, count));
            any_accepted = true;
            break;
        }
        if best.is_none_or(|(_, c)| count > c) {
            best = Some((cfg, count));
        }
    }
    best.map(|(cfg, _)| (cfg, any_accepted))
        .ok_or(Error::InvalidParameter)
}

fn finish<const N: usize, I>(
    samples: I,
    thresholds: AdaptiveThresholds,
    config: StaticDetectorConfig,
    on_interval: impl FnMut(StaticInterval),
) -> Result<AdaptiveDetection, Error>
where
    I: Iterator<Item = [f32; 3]> + Clone,
{
    let windows = run::<N, _>(samples, config, thresholds.reference_variance, on_interval)?;
    Ok(AdaptiveDetection {
        thresholds,
        config,
        windows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::vec::Vec;

    /// Deterministic pseudo-noise (xorshift), ±amp.
    struct Noise(u32);
    impl Noise {
        fn next(&mut self, amp: f32) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 17;
            self.0 ^= self.0 << 5;
            (self.0 as f32 / u32::MAX as f32 - 0.5) * 2.0 * amp
        }
    }

    /// A recording that starts moving, then alternates 1-s holds (4 orientations) and 0.5-s
    /// turns, at 100 Hz, in g with noise 1e-3 g (uniform ±1.7e-3).
    fn short_holds() -> Vec<[f32; 3]> {
        let mut noise = Noise(99);
        let poses = [
            [0.0f32, 0.0, 1.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [
                0.0,
                -core::f32::consts::FRAC_1_SQRT_2,
                core::f32::consts::FRAC_1_SQRT_2,
            ],
        ];
        let mut out = Vec::new();
        // 3 s of motion first: no rest period at the start.
        for k in 0..300 {
            let ph = k as f32 * 0.05;
            out.push([libm::sinf(ph), libm::cosf(ph), 0.3 * libm::sinf(2.0 * ph)]);
        }
        for rep in 0..6 {
            for (i, p) in poses.iter().enumerate() {
                for _ in 0..100 {
                    out.push(p.map(|x| x + noise.next(1.7e-3)));
                }
                let q = poses[(i + 1) % poses.len()];
                for k in 0..50 {
                    let t = k as f32 / 50.0 + 0.01 * rep as f32;
                    out.push(
                        [0, 1, 2].map(|a| p[a] + (q[a] - p[a]) * t + 0.05 * libm::sinf(7.0 * t)),
                    );
                }
            }
        }
        out
    }

    #[test]
    fn survey_measures_static_noise_despite_motion_at_start() {
        let xs = short_holds();
        let th = AdaptiveThresholds::from_samples(xs.iter().copied(), 100.0).unwrap();
        // Uniform ±a has variance a²/3 = 9.6e-7 per axis; the quantile's bin is ±9 %, and
        // block variances scatter ~±30 % (25 samples).
        for v in th.reference_variance {
            assert!(v > 0.5e-6 && v < 1.5e-6, "{:?}", th.reference_variance);
        }
        assert_eq!(th.min_variance, 0.0);
    }

    #[test]
    fn short_holds_are_found_when_nothing_longer_exists() {
        let xs = short_holds();
        let mut found = Vec::new();
        let d = detect::<101, _>(xs.iter().copied(), 100.0, 12, |iv| found.push(iv)).unwrap();
        assert_eq!(d.windows as usize, found.len());
        // 24 holds of 1 s: the 2-s and 1-s settings find none, the 0.5-s one all of them.
        assert_eq!(found.len(), 24, "{d:?}");
        assert_eq!(d.config.window, 25);
        for iv in &found {
            let n = (iv.mean[0].powi(2) + iv.mean[1].powi(2) + iv.mean[2].powi(2)).sqrt();
            assert!((n - 1.0).abs() < 2e-3, "{iv:?}");
            assert!(iv.len() >= 50 && iv.len() <= 100, "{iv:?}");
        }
    }

    /// The single pass per setting of [`detect_fitted`] chooses what the documented rule
    /// chooses when every setting is run on its own: the first setting with enough windows
    /// that fit, else (none fits) the count rule; the fit is the chosen windows' fit. Checked
    /// on holds only the 0.5-s setting finds, with a scratch too small for them (accepted on
    /// their count) and big enough (fitted), and with a fit that cannot succeed (3 windows
    /// asked for the 9-parameter model's 9 is fine, but 40 windows asked: count rule).
    #[test]
    fn one_pass_per_setting_chooses_as_separate_runs_would() {
        let xs = short_holds();
        let th = AdaptiveThresholds::from_samples(xs.iter().copied(), 100.0).unwrap();
        let fit_cfg = crate::multipos::MultiPosConfig::default();
        // Reference: every setting run separately, its windows collected, the rule applied.
        let per_setting: Vec<(StaticDetectorConfig, Vec<StaticInterval>)> = HOLD_SCHEDULE
            .iter()
            .map(|&(w, h)| {
                let cfg = th.detector_config(100.0, w, h);
                let mut ivs = Vec::new();
                run::<101, _>(xs.iter().copied(), cfg, th.reference_variance, |iv| {
                    ivs.push(iv)
                })
                .unwrap();
                (cfg, ivs)
            })
            .collect();
        for (min_windows, scratch_len) in [(12u32, 4096usize), (12, 5), (40, 4096)] {
            let fits = |ivs: &[StaticInterval]| {
                let means: Vec<[f32; 3]> = ivs.iter().map(|iv| iv.mean).collect();
                ivs.len() >= min_windows as usize
                    && (ivs.len() > scratch_len || crate::multipos::fit(&means, &fit_cfg).is_ok())
            };
            let want = per_setting
                .iter()
                .find(|(_, ivs)| fits(ivs))
                .or_else(|| {
                    per_setting
                        .iter()
                        .find(|(_, ivs)| ivs.len() >= min_windows as usize)
                })
                .or_else(|| per_setting.iter().rev().max_by_key(|(_, ivs)| ivs.len()))
                .unwrap();
            let mut scratch = std::vec![[0.0f32; 3]; scratch_len];
            let mut got = Vec::new();
            let (d, fit) = detect_fitted::<101, _>(
                xs.iter().copied(),
                100.0,
                min_windows,
                &fit_cfg,
                &mut scratch,
                |iv| got.push(iv),
            )
            .unwrap();
            let ctx = (min_windows, scratch_len);
            assert_eq!(d.config, want.0, "{ctx:?}");
            assert_eq!(got, want.1, "{ctx:?}");
            // Without the final pass: the chosen setting's intervals as they were found.
            let mut each = std::vec![Vec::new(); HOLD_SCHEDULE.len()];
            let (d_each, setting) = detect_fitted_each::<101, _>(
                xs.iter().copied(),
                100.0,
                min_windows,
                &fit_cfg,
                &mut scratch,
                |s, iv| each[s].push(iv),
            )
            .unwrap();
            assert_eq!(d_each, d, "{ctx:?}");
            assert_eq!(each[setting], got, "{ctx:?}");
            let means: Vec<[f32; 3]> = got.iter().map(|iv| iv.mean).collect();
            if got.len() <= scratch_len {
                assert_eq!(fit, crate::multipos::fit(&means, &fit_cfg), "{ctx:?}");
            } else {
                assert_eq!(fit.err(), Some(Error::CapacityExceeded), "{ctx:?}");
            }
        }
    }

    /// Blocks measured apart (as on several cores) and added in order give the survey of
    /// the samples pushed one by one, bit for bit, for float and integer data.
    #[test]
    fn measured_blocks_survey_as_pushed_samples() {
        let mut ints = Noise(5);
        let counts: Vec<[f32; 3]> = (0..1013)
            .map(|_| [libm::roundf(512.0 + ints.next(3.0)), 500.0, 300.0])
            .collect();
        for xs in [short_holds(), counts] {
            let mut pushed = NoiseSurvey::for_rate(100.0).unwrap();
            for m in &xs {
                pushed.push(*m).unwrap();
            }
            let mut measured = NoiseSurvey::for_rate(100.0).unwrap();
            let block = measured.block_samples() as usize;
            let full = xs.len() / block * block;
            for chunk in xs[..full].chunks(block) {
                measured.add_measured(NoiseSurvey::measure_block(chunk).unwrap());
            }
            for m in &xs[full..] {
                measured.push(*m).unwrap();
            }
            assert_eq!(measured.blocks(), pushed.blocks());
            assert_eq!(measured.thresholds(0.2), pushed.thresholds(0.2));
        }
        assert_eq!(
            NoiseSurvey::measure_block(&[[0.0; 3], [f32::NAN, 0.0, 0.0], [0.0; 3]]),
            Err(Error::NonFinite)
        );
    }

    /// The whole-number test against `truncf(x) == x` on the values where rounding could go
    /// wrong (halves near 2²², 2²³, 2²⁴, subnormals, zeros, infinities, NaN) and on every
    /// 4099th bit pattern of `f32`.
    #[test]
    fn whole_value_is_truncation_without_a_conversion() {
        let two = |e: i32| libm::ldexpf(1.0, e);
        let mut edge = std::vec![0.0f32, -0.0, 0.5, 1.5, 2.5, f32::MIN_POSITIVE / 2.0];
        for e in [22, 23, 24] {
            for d in [-1.5f32, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5, 2.0] {
                edge.push(two(e) + d);
            }
        }
        edge.extend([f32::MAX, f32::INFINITY, f32::NAN, 1e30, 0.999_999_94]);
        let sweep = (0..u32::MAX / 4099).map(|k| f32::from_bits(k * 4099));
        for x in edge
            .clone()
            .into_iter()
            .chain(edge.iter().map(|v| -v))
            .chain(sweep)
        {
            let truncated = libm::truncf(x) == x;
            assert_eq!(whole_value(x), truncated, "{x:e} ({:#x})", x.to_bits());
        }
    }

    #[test]
    fn integer_data_get_the_quantisation_floor_and_bad_input_is_typed() {
        let mut s = NoiseSurvey::new(10).unwrap();
        for k in 0..200 {
            s.push([512.0, 500.0 + (k % 2) as f32, 300.0]).unwrap();
        }
        let th = s.thresholds(0.2).unwrap();
        assert_eq!(th.min_variance, 1.0 / 12.0);
        assert!(th.reference_variance[1] > 0.2 && th.reference_variance[1] < 0.3);
        assert_eq!(NoiseSurvey::new(2).err(), Some(Error::InvalidParameter));
        assert_eq!(s.thresholds(1.0).err(), Some(Error::InvalidParameter));
        let few = NoiseSurvey::new(10).unwrap();
        assert!(matches!(
            few.thresholds(0.2),
            Err(Error::TooFewSamples { .. })
        ));
        assert_eq!(s.push([f32::NAN, 0.0, 0.0]), Err(Error::NonFinite));
    }
}
