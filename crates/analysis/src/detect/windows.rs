//! Window detection: the core's streaming static detector over a recording (the same `f32`
//! code the adapter firmware runs), the ADC-saturation check, and the `f64` statistics of each
//! static window (mean, variance, batch means, centre time, temperature) that the analysis
//! works from.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use crate::detect::held::{
    both_or_first_error, feed_held, four_slices, piece_starts, samples_between, DetectorSample,
};
use crate::detect::polled::{Polling, Runs};
use crate::detect::spans;
use crate::error::detect::{DetectError, Setting};
use crate::input::recording::{infer_units, Recording};
use crate::input::sample_summary::is_whole;
use crate::stats as st;
use wiical_core::multipos::MultiPosConfig;
use wiical_core::static_detect::adaptive;
use wiical_core::static_detect::{StaticDetector, StaticDetectorConfig, StaticInterval};

type Result<T, E = DetectError> = std::result::Result<T, E>;

/// Settings of the static-window detection.
#[derive(Debug, Clone)]
pub struct DetectOptions {
    /// Thresholds from the recording's own noise, no rest period needed, shorter holds when
    /// the recording has no long ones (the core's `static_detect::adaptive`, the default);
    /// false: the IMU-TK detector with the settings below (any detector flag turns it on).
    pub adaptive: bool,
    /// Variance window, seconds.
    pub window_s: f64,
    /// Initial rest period used as the noise reference, seconds.
    pub init_s: f64,
    /// Shortest static interval, seconds.
    pub min_static_s: f64,
    /// Static when window variance ≤ this × reference variance.
    pub threshold_factor: f64,
    /// Sample rate to assume when the file has neither a time column nor metadata.
    pub default_rate_hz: f64,
    /// ADC limits (lo, hi): a static interval touching them is refused as saturated.
    /// `None`: inferred from the data (integer counts in 10-bit or 16-bit ranges).
    pub adc_range: Option<(f64, f64)>,
}

impl DetectOptions {
    /// The options a user's settings describe (the CLI's flags, the Python package's keyword
    /// arguments): giving any of the four IMU-TK settings switches from the adaptive detector
    /// to IMU-TK's, with the defaults for the ones not given.
    pub fn from_settings(
        window_s: Option<f64>,
        init_s: Option<f64>,
        min_static_s: Option<f64>,
        threshold_factor: Option<f64>,
        default_rate_hz: f64,
        adc_range: Option<(f64, f64)>,
    ) -> Self {
        let d = Self::default();
        Self {
            adaptive: window_s.is_none()
                && init_s.is_none()
                && min_static_s.is_none()
                && threshold_factor.is_none(),
            window_s: window_s.unwrap_or(d.window_s),
            init_s: init_s.unwrap_or(d.init_s),
            min_static_s: min_static_s.unwrap_or(d.min_static_s),
            threshold_factor: threshold_factor.unwrap_or(d.threshold_factor),
            default_rate_hz,
            adc_range,
        }
    }
}

impl Default for DetectOptions {
    fn default() -> Self {
        Self {
            adaptive: true,
            window_s: 1.0,
            init_s: 2.0,
            min_static_s: 2.0,
            threshold_factor: 6.0,
            default_rate_hz: 100.0,
            adc_range: None,
        }
    }
}

/// Why a user's setting (a CLI flag, a Python keyword argument) is refused: one range per
/// kind of setting, shared by every door so that none accepts what another refuses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum RangeError {
    /// Zero, negative, NaN or infinite.
    #[error("must be a finite number above 0")]
    NotPositive,
    /// A duration outside [`DURATION_RANGE_S`].
    #[error("give a duration from 0.001 to 1000000 s")]
    Duration,
    /// A sample rate outside [`crate::input::bounded::MIN_RATE_HZ`] to
    /// [`crate::input::bounded::MAX_RATE_HZ`].
    #[error("give a sample rate from 0.001 to 1000000 Hz")]
    Rate,
    /// A family-wise significance level outside [`crate::search::select::ALPHA_RANGE`].
    #[error("give a significance level from 0.000001 to 0.5")]
    Alpha,
    /// A CV factor outside [`crate::search::select::CV_FACTOR_RANGE`].
    #[error("give a factor from 1 to 100")]
    CvFactor,
    /// A threshold outside (1, 10⁶].
    #[error("give a threshold above 1 and at most 1000000 (times the rest variance)")]
    Threshold,
    /// An ADC range whose ends are not finite with LO < HI.
    #[error("need finite LO < HI")]
    AdcRange,
}

/// Durations a setting may take, s: a window of 1e-300 s would silently become the detector's
/// 3-sample minimum, one of 1e300 s never ends.
pub const DURATION_RANGE_S: (f64, f64) = (1e-3, 1e6);

fn positive(v: f64) -> Result<f64, RangeError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(RangeError::NotPositive)
    }
}

/// A duration setting (window, rest, hold), s: within [`DURATION_RANGE_S`].
pub fn check_duration_s(v: f64) -> Result<f64, RangeError> {
    let v = positive(v)?;
    let (lo, hi) = DURATION_RANGE_S;
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(RangeError::Duration)
    }
}

/// A sample rate, Hz: 1 mHz to 1 MHz (inertial sensors stop at a few kHz; 1e300 Hz would make
/// every window one sample, and 1e-300 Hz turns `noise`'s averaging times into 1e232 s
/// printed as results: no sensor is read once in more than 1000 s).
pub fn check_rate_hz(v: f64) -> Result<f64, RangeError> {
    use crate::input::bounded::{MAX_RATE_HZ, MIN_RATE_HZ};
    if (MIN_RATE_HZ..=MAX_RATE_HZ).contains(&positive(v)?) {
        Ok(v)
    } else {
        Err(RangeError::Rate)
    }
}

/// A variance-ratio threshold: above 1 (at or below the rest variance nothing is ever still),
/// at most 10⁶.
pub fn check_threshold(v: f64) -> Result<f64, RangeError> {
    if positive(v)? > 1.0 && v <= 1e6 {
        Ok(v)
    } else {
        Err(RangeError::Threshold)
    }
}

/// An ADC range `(lo, hi)` in counts: finite, lo < hi.
pub fn check_adc_range((lo, hi): (f64, f64)) -> Result<(f64, f64), RangeError> {
    if lo.is_finite() && hi.is_finite() && lo < hi {
        Ok((lo, hi))
    } else {
        Err(RangeError::AdcRange)
    }
}

/// A setting refused by its range check, named as the caller named it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{name} = {value}: {why}")]
pub struct SettingError {
    /// The setting's name (`window_s`, `rate_hz`, …).
    pub name: &'static str,
    /// The value given, as text.
    pub value: String,
    /// Its range.
    pub why: RangeError,
}

impl DetectOptions {
    /// [`DetectOptions::from_settings`] after every given setting passed its range check
    /// (the checks the CLI's flag parsers make); the error names the setting by its keyword
    /// (`window_s`, `init_s`, `min_static_s`, `threshold`, `rate_hz`, `adc_range`).
    pub fn checked_settings(
        window_s: Option<f64>,
        init_s: Option<f64>,
        min_static_s: Option<f64>,
        threshold_factor: Option<f64>,
        default_rate_hz: f64,
        adc_range: Option<(f64, f64)>,
    ) -> std::result::Result<Self, SettingError> {
        fn check<T: Copy + std::fmt::Debug>(
            name: &'static str,
            v: Option<T>,
            f: fn(T) -> Result<T, RangeError>,
        ) -> std::result::Result<(), SettingError> {
            if let Some(x) = v {
                f(x).map_err(|why| SettingError {
                    name,
                    value: format!("{x:?}"),
                    why,
                })?;
            }
            Ok(())
        }
        check("window_s", window_s, check_duration_s)?;
        check("init_s", init_s, check_duration_s)?;
        check("min_static_s", min_static_s, check_duration_s)?;
        check("threshold", threshold_factor, check_threshold)?;
        check("rate_hz", Some(default_rate_hz), check_rate_hz)?;
        check("adc_range", adc_range, check_adc_range)?;
        Ok(Self::from_settings(
            window_s,
            init_s,
            min_static_s,
            threshold_factor,
            default_rate_hz,
            adc_range,
        ))
    }
}

/// Capacity of the detector's window ring (samples). At 100 Hz this allows windows up to 5 s.
/// (The span pair's tests take the same ring.)
pub const MAX_WINDOW: usize = 511;

/// Detected static intervals plus the noise reference.
pub struct Detection {
    /// Intervals in sample indices.
    pub intervals: Vec<StaticInterval>,
    /// Per-axis reference variance (raw units²).
    pub reference_variance: [f32; 3],
    /// The sample rate the detection took, Hz: the clock of a recording without a time
    /// column ([`Recording::times`] at this rate).
    pub rate_hz: f64,
}

/// Windows the adaptive detection asks for before it settles on a hold length: the full
/// model's 9 parameters plus 3 degrees of freedom.
pub const ADAPTIVE_MIN_WINDOWS: u32 = 12;

/// Below this rate (Hz) the adaptive detector's shortest hold (0.5 s) is a single sample: a
/// recording of samples that slow is far more likely a time column in milliseconds, or a
/// table of window means read as samples.
pub const MIN_SAMPLE_RATE_HZ: f64 = 2.0;

/// Window means the adaptive detection's fit check holds (a setting with more windows is
/// accepted on its count).
const ADAPTIVE_SCRATCH: usize = 4096;

/// The core's adaptive detection (`static_detect::adaptive::detect_fitted_each`): the noise
/// reference is a low quantile of the recording's block variances, and the hold lengths are
/// tried from the IMU-TK defaults (1 s windows, 2 s holds) down to 0.25 s / 0.5 s until one
/// gives at least [`ADAPTIVE_MIN_WINDOWS`] windows that a multi-position fit accepts.
pub fn detect_adaptive(rec: &Recording, opts: &DetectOptions) -> Result<Detection> {
    detect_adaptive_of(rec, opts, all_whole(&rec.xyz))
}

/// [`detect_adaptive`] on a recording whose values are all whole numbers or not (`integer`,
/// [`Recording::is_integer`]), known to the caller.
fn detect_adaptive_of(rec: &Recording, opts: &DetectOptions, integer: bool) -> Result<Detection> {
    use rayon::prelude::*;
    let rate = adaptive_rate(rec.estimated_rate_hz(), opts)?;
    // Quantiser levels are computed once, in parallel, rather than on every pass; other
    // values are cast as they are passed over (no copy of the recording).
    let (intervals, reference_variance) = match lattice_of(&rec.xyz, integer) {
        Some(l) => {
            let levels: Vec<[f32; 3]> = rec
                .xyz
                .par_iter()
                .map(|s| to_levels(s, &l).map(|v| v as f32))
                .collect();
            adaptive_intervals(&Held(&levels[..]), rec.len(), rate)?
        }
        None => adaptive_intervals(&Held(&rec.xyz[..]), rec.len(), rate)?,
    };
    Ok(Detection {
        intervals,
        reference_variance,
        rate_hz: rate,
    })
}

/// The sample rate the detection takes (`estimated`: the recording's, when known), refused
/// when it is not a positive number or slower than [`MIN_SAMPLE_RATE_HZ`].
pub(crate) fn adaptive_rate(estimated: Option<f64>, opts: &DetectOptions) -> Result<f64> {
    let rate = estimated.unwrap_or(opts.default_rate_hz);
    if !(rate.is_finite() && rate > 0.0) {
        return Err(DetectError::NoSampleRate);
    }
    if rate < MIN_SAMPLE_RATE_HZ {
        return Err(DetectError::RateTooLow {
            rate_hz: (rate * 1e6).round() / 1e6,
        });
    }
    Ok(rate)
}

/// The passes the adaptive detection makes over its samples (as the detector sees them:
/// quantiser levels or values, `f32`): samples held in memory are passed over by both cores at
/// once; samples streamed from a file (`detect::streamed`) a piece at a time, on all cores too.
pub(crate) trait Passes {
    /// One pass over the samples.
    type Iter: Iterator<Item = [f32; 3]> + Clone;
    /// A fresh pass.
    fn pass(&self) -> Self::Iter;
    /// The noise survey (`AdaptiveThresholds::from_samples`).
    fn survey(&self, rate: f32) -> Result<adaptive::AdaptiveThresholds, CoreError> {
        adaptive::AdaptiveThresholds::from_samples(self.pass(), rate)
    }
    /// The intervals of two detector settings with the same reference (`adaptive::run` of each).
    fn run_pair(&self, cfgs: [StaticDetectorConfig; 2], reference: [f32; 3]) -> PairResult;
}

/// Intervals of two detector settings ([`Passes::run_pair`]).
pub(crate) type PairResult = std::result::Result<[Vec<StaticInterval>; 2], CoreError>;

type CoreError = wiical_core::Error;

/// One setting's intervals (`adaptive::run`).
fn run_one<I: Iterator<Item = [f32; 3]>>(
    samples: I,
    cfg: StaticDetectorConfig,
    reference: [f32; 3],
) -> std::result::Result<Vec<StaticInterval>, CoreError> {
    let mut out = Vec::new();
    adaptive::run::<MAX_WINDOW, _>(samples, cfg, reference, |iv| out.push(iv))?;
    Ok(out)
}

/// One setting's intervals over held samples, in consecutive pieces: [`run_one`] by slices
/// (`StaticDetector::push_slice`, the same intervals and error, [`feed_held`]); the error with
/// the index of the sample that met it.
pub(crate) fn run_held<S: DetectorSample>(
    pieces: &[&[S]],
    cfg: StaticDetectorConfig,
    reference: [f32; 3],
) -> std::result::Result<Vec<StaticInterval>, (usize, CoreError)> {
    let mut det =
        StaticDetector::<MAX_WINDOW>::with_reference(cfg, reference).map_err(|e| (0, e))?;
    let mut out = Vec::new();
    feed_held(pieces, |xs| det.push_slice(xs, |iv| out.push(iv)))?;
    out.extend(det.finish());
    Ok(out)
}

/// [`Passes::run_pair`] over held samples in consecutive pieces: by spans ([`spans::pair`]:
/// the detector's result in about half its time) unless a sample is beyond their exact range,
/// else the two detectors; the two settings on two cores at once, the error the one met first
/// in sample order (the first setting's on the same sample).
pub(crate) fn run_pair_held<S: DetectorSample>(
    pieces: &[&[S]],
    cfgs: [StaticDetectorConfig; 2],
    reference: [f32; 3],
) -> PairResult {
    spans::pair::<MAX_WINDOW, S>(pieces, cfgs, reference).unwrap_or_else(|| {
        let (a, b) = rayon::join(
            || run_held(pieces, cfgs[0], reference),
            || run_held(pieces, cfgs[1], reference),
        );
        both_or_first_error(a, b).map(|(a, b)| [a, b])
    })
}

/// [`Passes::survey`] of held samples in consecutive pieces: every complete block's variances
/// measured on all cores, four blocks at a time (a block across two pieces gathered), added to
/// the histogram in order, the last incomplete block pushed sample by sample (the survey of
/// the samples pushed one by one, bit for bit).
pub(crate) fn survey_held<S: DetectorSample>(
    pieces: &[&[S]],
    rate: f32,
) -> Result<adaptive::AdaptiveThresholds, CoreError> {
    use rayon::prelude::*;
    let mut survey = adaptive::NoiseSurvey::for_rate(rate)?;
    let block = survey.block_samples() as usize;
    let starts = piece_starts(pieces);
    let total = starts[pieces.len()];
    let blocks = total / block;
    let measured: Vec<_> = (0..blocks.div_ceil(4))
        .into_par_iter()
        .map_init(
            || [(); 4].map(|_| Vec::new()),
            |bufs, g| {
                let js = g * 4..((g + 1) * 4).min(blocks);
                let n = js.len();
                let ranges = js.map(|j| (j * block, (j + 1) * block));
                let slices = four_slices(pieces, &starts, ranges, bufs);
                let four = adaptive::NoiseSurvey::measure_four_blocks(slices);
                four.into_iter().take(n).collect::<Vec<_>>()
            },
        )
        .flatten_iter()
        .collect();
    for m in measured {
        survey.add_measured(m?);
    }
    for m in samples_between(pieces, &starts, blocks * block, total) {
        survey.push(m.f32s())?;
    }
    survey.thresholds(adaptive::DEFAULT_QUANTILE)
}

/// A pass over held samples, each in `f32`.
#[derive(Clone)]
pub(crate) struct AsF32<'a, S>(std::slice::Iter<'a, S>);

impl<S: DetectorSample> Iterator for AsF32<'_, S> {
    type Item = [f32; 3];

    #[inline]
    fn next(&mut self) -> Option<[f32; 3]> {
        self.0.next().map(S::f32s)
    }
}

/// Samples held in memory.
pub(crate) struct Held<'a, S>(pub(crate) &'a [S]);

impl<'a, S: DetectorSample> Passes for Held<'a, S> {
    type Iter = AsF32<'a, S>;

    fn pass(&self) -> Self::Iter {
        AsF32(self.0.iter())
    }

    /// The blocks' variances measured on all cores ([`survey_held`]).
    fn survey(&self, rate: f32) -> Result<adaptive::AdaptiveThresholds, CoreError> {
        survey_held(&[self.0], rate)
    }

    /// The two settings on the two cores at once ([`run_pair_held`]).
    fn run_pair(&self, cfgs: [StaticDetectorConfig; 2], reference: [f32; 3]) -> PairResult {
        run_pair_held(&[self.0], cfgs, reference)
    }
}

/// [`detect_adaptive`]'s intervals and reference variance from the `n` samples of `passes`.
///
/// The common case in two passes: the survey, then the first setting of the schedule and the
/// gap-filling one ([`FILL_SETTING`]) together; when the first is accepted (the core's rule,
/// [`accepted`]) its intervals filled from the second's are the result, when only the second
/// is, the second's. Otherwise the core's whole schedule ([`adaptive_schedule`]), which
/// decides every other case as it always has.
pub(crate) fn adaptive_intervals(
    passes: &impl Passes,
    n: usize,
    rate: f64,
) -> Result<(Vec<StaticInterval>, [f32; 3])> {
    let survey_error = |e| match e {
        CoreError::TooFewSamples { needed, .. } => DetectError::TooShortForSurvey {
            samples: n,
            needed,
            survey_s: f64::from(adaptive::SURVEY_BLOCK_S) * f64::from(adaptive::MIN_SURVEY_BLOCKS),
            rate_hz: rate,
        },
        other => DetectError::DetectorSettings(other),
    };
    let thresholds = passes.survey(rate as f32).map_err(survey_error)?;
    let cfg = |setting: usize| {
        let (window_s, min_static_s) = adaptive::HOLD_SCHEDULE[setting];
        thresholds.detector_config(rate as f32, window_s, min_static_s)
    };
    let cfgs = [cfg(0), cfg(FILL_SETTING)];
    let reference = thresholds.reference_variance;
    if cfgs.iter().all(|c| c.window as usize <= MAX_WINDOW) {
        let [first, fill] = passes
            .run_pair(cfgs, reference)
            .map_err(DetectError::DetectorSettings)?;
        if accepted(&first) {
            return Ok((fill_holds(first, &fill), reference));
        }
        // The first rejected, the schedule's second setting is tried next: the fill setting.
        if FILL_SETTING == 1 && accepted(&fill) {
            return Ok((fill, reference));
        }
    }
    adaptive_schedule(passes, rate).map_err(survey_error)
}

/// The core's acceptance of a setting's intervals (`adaptive::detect_fitted_each`): at least
/// [`ADAPTIVE_MIN_WINDOWS`], and a multi-position fit of their means unless there are more of
/// them than its scratch ([`ADAPTIVE_SCRATCH`]) holds.
fn accepted(intervals: &[StaticInterval]) -> bool {
    let n = intervals.len();
    if (n as u32) < ADAPTIVE_MIN_WINDOWS {
        return false;
    }
    if n > ADAPTIVE_SCRATCH {
        return true;
    }
    let means: Vec<[f32; 3]> = intervals.iter().map(|iv| iv.mean).collect();
    wiical_core::multipos::fit(&means, &MultiPosConfig::default()).is_ok()
}

/// The core's whole schedule (`adaptive::detect_fitted_each`), then the gap-filling pass when
/// a longer setting was chosen.
fn adaptive_schedule(
    passes: &impl Passes,
    rate: f64,
) -> std::result::Result<(Vec<StaticInterval>, [f32; 3]), CoreError> {
    let mut scratch = vec![[0.0f32; 3]; ADAPTIVE_SCRATCH];
    // The intervals of every setting tried, kept as found: the chosen one's are the result,
    // with no final pass over the samples (`detect_fitted_each`).
    let mut per_setting = vec![Vec::new(); adaptive::HOLD_SCHEDULE.len()];
    let (det, chosen) = adaptive::detect_fitted_each::<MAX_WINDOW, _>(
        passes.pass(),
        rate as f32,
        ADAPTIVE_MIN_WINDOWS,
        &MultiPosConfig::default(),
        &mut scratch,
        |setting, iv| per_setting[setting].push(iv),
    )?;
    let mut intervals = std::mem::take(&mut per_setting[chosen]);
    if chosen < FILL_SETTING {
        let (window_s, min_static_s) = adaptive::HOLD_SCHEDULE[FILL_SETTING];
        let cfg = det
            .thresholds
            .detector_config(rate as f32, window_s, min_static_s);
        let short = run_one(passes.pass(), cfg, det.thresholds.reference_variance)?;
        intervals = fill_holds(intervals, &short);
    }
    Ok((intervals, det.thresholds.reference_variance))
}

/// The [`adaptive::HOLD_SCHEDULE`] setting (0.5 s windows, 1 s holds) whose holds fill the
/// gaps of a longer chosen setting.
const FILL_SETTING: usize = 1;

/// The chosen setting's intervals plus every interval of the shorter setting `short` that
/// overlaps none of them, in time order.
///
/// Why: the adaptive detection stops at the first setting that gives enough windows for a
/// fit, which on most recordings is IMU-TK's 1 s window with 2 s holds. A centred 1 s window
/// only calls a sample static when the whole second around it is still, so a hold must have
/// 3 s of still samples to give a 2 s interval: on brisk recordings (holds of 2–4 s) a third
/// of the holds were dropped although they average noise just as well per sample. The 0.5 s
/// setting finds every hold with ≥ 1.5 s of still samples; where the long setting already has
/// a window its window is kept (the same windows as before on recordings with long holds), and
/// only holds it has none in are added. A short window's own noise (its variance over its
/// sample count) is its noise floor in `analyze` (`noise::floors`), so it counts for what it is.
///
/// Both lists come from one detector pass each, so each is in time order without overlaps;
/// one sweep through `chosen` for all of `short` finds the overlaps (linear, where a search of
/// all of `chosen` for each short interval was quadratic: 0.03 s for 5,000 windows).
fn fill_holds(mut chosen: Vec<StaticInterval>, short: &[StaticInterval]) -> Vec<StaticInterval> {
    let overlaps = |a: &StaticInterval, b: &StaticInterval| a.start < b.end && b.start < a.end;
    let in_order = |v: &[StaticInterval]| v.windows(2).all(|p| p[0].end <= p[1].start);
    let extra: Vec<StaticInterval> = if in_order(&chosen) && in_order(short) {
        let mut next = 0;
        short
            .iter()
            .filter(|s| {
                // Chosen intervals ending at or before this one's start overlap no later one.
                while chosen.get(next).is_some_and(|c| c.end <= s.start) {
                    next += 1;
                }
                !chosen.get(next).is_some_and(|c| overlaps(c, s))
            })
            .copied()
            .collect()
    } else {
        short
            .iter()
            .filter(|s| !chosen.iter().any(|c| overlaps(c, s)))
            .copied()
            .collect()
    };
    chosen.extend(extra);
    chosen.sort_by_key(|iv| iv.start);
    chosen
}

/// Most quantiser levels per axis [`lattice_view`] recognises: a 16-bit ADC has 65 536;
/// beyond it the values are taken as continuous (and f32 still holds every level exactly).
pub(crate) const MAX_LATTICE_LEVELS: usize = 1 << 17;

/// How far (in steps) a value may sit from its lattice point and still count as on it: a
/// count converted to g and printed with 7 significant digits is ~10⁻⁵ step off.
const LATTICE_TOLERANCE: f64 = 1e-3;

/// The samples as quantiser levels (`round((v − v_min)/q)` per axis) when non-integer input
/// lies on a lattice of step `q` per axis (counts converted to g or m/s² by a constant scale
/// and offset); `None` for integer input (already levels) and for continuous values.
///
/// Why: the adaptive detector's noise survey bins block variances on a log scale at absolute
/// positions and floors integer data at the quantisation variance 1/12, so the same recording
/// in counts and in g would be detected with slightly different references (window edges a
/// sample apart). In levels it is the counts recording up to an offset, which a variance
/// does not see: the same windows, whatever unit or scale the counts were converted to.
#[cfg(test)]
fn lattice_view(xyz: &[[f64; 3]]) -> Option<Vec<[f64; 3]>> {
    let lattice = lattice_of(xyz, all_whole(xyz))?;
    Some(xyz.iter().map(|s| to_levels(s, &lattice)).collect())
}

/// [`lattice_view`]'s per-axis lattices `(origin, step)` of `xyz` (whose values are all
/// whole numbers or not: `integer`), `None` when it has none. The checks and sorts run on all
/// cores (a sort of values equal under `total_cmp` is the same stable or not: they are the
/// same bits).
fn lattice_of(xyz: &[[f64; 3]], integer: bool) -> Option<[(f64, f64); 3]> {
    use rayon::prelude::*;
    if integer {
        return None;
    }
    let mut lattice = [(0.0, 0.0); 3];
    for (a, axis) in lattice.iter_mut().enumerate() {
        let mut v: Vec<f64> = xyz.par_iter().map(|s| s[a]).collect();
        if v.par_iter().any(|x| !x.is_finite()) {
            return None;
        }
        v.par_sort_unstable_by(f64::total_cmp);
        v.dedup();
        *axis = axis_lattice(&v)?;
    }
    Some(lattice)
}

/// A sample as quantiser levels of the per-axis lattices `(origin, step)` ([`lattice_view`]).
pub(crate) fn to_levels(s: &[f64; 3], lattice: &[(f64, f64); 3]) -> [f64; 3] {
    std::array::from_fn(|a| ((s[a] - lattice[a].0) / lattice[a].1).round())
}

/// One axis's lattice `(origin, step)` from its distinct values `v` (finite, ascending, no
/// repeats): `None` when they are too many levels ([`MAX_LATTICE_LEVELS`]) or off a lattice.
pub(crate) fn axis_lattice(v: &[f64]) -> Option<(f64, f64)> {
    if v.is_empty() || v.len() > MAX_LATTICE_LEVELS {
        return None;
    }
    let span = v[v.len() - 1] - v[0];
    // The smallest gap that is not float noise is the step candidate.
    let q = v
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|g| *g > 1e-9 * span.max(v[0].abs()))
        .fold(f64::INFINITY, f64::min);
    let step = if q.is_finite() { q } else { 1.0 };
    let on_lattice = v.iter().all(|x| {
        let k = (x - v[0]) / step;
        (k - k.round()).abs() <= LATTICE_TOLERANCE
    });
    if !on_lattice || span / step > MAX_LATTICE_LEVELS as f64 {
        return None;
    }
    Some((v[0], step))
}

/// Runs the core's streaming static detector over a recording.
pub fn detect(rec: &Recording, opts: &DetectOptions) -> Result<Detection> {
    let rate = rec.estimated_rate_hz().unwrap_or(opts.default_rate_hz);
    let samples = rec.xyz.iter().copied();
    let (intervals, reference_variance) = fixed_intervals(samples, rec.len(), rate, opts)?;
    Ok(Detection {
        intervals,
        reference_variance,
        rate_hz: rate,
    })
}

/// [`detect`]'s intervals and reference variance from the `n` samples `samples` yields (as
/// the detector sees them), at `rate` Hz.
pub(crate) fn fixed_intervals(
    samples: impl Iterator<Item = [f64; 3]>,
    n: usize,
    rate: f64,
    opts: &DetectOptions,
) -> Result<(Vec<StaticInterval>, [f32; 3])> {
    if !(rate.is_finite() && rate > 0.0) {
        return Err(DetectError::NoSampleRate);
    }
    let mut cfg = StaticDetectorConfig::for_rate(
        rate as f32,
        opts.window_s as f32,
        opts.init_s as f32,
        opts.min_static_s as f32,
    );
    cfg.threshold_factor = opts.threshold_factor as f32;
    if cfg.window as usize > MAX_WINDOW {
        return Err(DetectError::WindowTooLong {
            samples: cfg.window as usize,
            max: MAX_WINDOW,
        });
    }
    if (n as u32) < cfg.init_samples.max(cfg.window as u32) {
        return Err(DetectError::TooShort {
            samples: n,
            needed: cfg.init_samples,
            init_s: opts.init_s,
            rate_hz: rate,
        });
    }
    check_detector_settings(&cfg, rate)?;
    let mut det: StaticDetector<MAX_WINDOW> =
        StaticDetector::new(cfg).map_err(DetectError::DetectorSettings)?;
    let mut intervals = Vec::new();
    for (i, s) in samples.enumerate() {
        let m = [s[0] as f32, s[1] as f32, s[2] as f32];
        if let Some(iv) = det.push(m).map_err(|cause| DetectError::Sample {
            index: i + 1,
            cause,
        })? {
            intervals.push(iv);
        }
    }
    if let Some(iv) = det.finish() {
        intervals.push(iv);
    }
    Ok((intervals, det.reference_variance().unwrap_or([0.0; 3])))
}

/// ADC limits inferred from integer-valued data: 10-bit (0..1023), 8-bit (0..255),
/// signed 16-bit or unsigned 16-bit. `None` for non-integer (already scaled) data.
pub fn infer_adc_range(rec: &Recording) -> Option<(f64, f64)> {
    adc_range_if(&rec.xyz, all_whole(&rec.xyz))
}

/// [`infer_adc_range`] of `xyz`, whose values are all whole numbers or not (`integer`). The
/// extremes are found on all cores (`min`/`max` do not depend on the order; a `−0` for a `0`
/// compares equal in [`adc_range_of`]).
fn adc_range_if(xyz: &[[f64; 3]], integer: bool) -> Option<(f64, f64)> {
    use rayon::prelude::*;
    if !integer {
        return None;
    }
    let (lo, hi) = xyz
        .par_iter()
        .fold(
            || (f64::INFINITY, f64::NEG_INFINITY),
            |(lo, hi), s| {
                let (l, h) = s.iter().fold((lo, hi), |(l, h), v| (l.min(*v), h.max(*v)));
                (l, h)
            },
        )
        .reduce(
            || (f64::INFINITY, f64::NEG_INFINITY),
            |a, b| (a.0.min(b.0), a.1.max(b.1)),
        );
    adc_range_of(lo, hi)
}

/// [`Recording::is_integer`] of samples `xyz` (every value whole: `v.fract() == 0`), on all
/// cores and without `fract`'s call to `trunc` (a library call on x86-64 without SSE4.1):
/// the streamed summary's test of each value ([`is_whole`]).
pub(crate) fn all_whole(xyz: &[[f64; 3]]) -> bool {
    use rayon::prelude::*;
    xyz.par_iter().all(|s| s.iter().all(|v| is_whole(*v)))
}

/// The ADC range holding every value from `lo` to `hi` ([`infer_adc_range`]).
pub(crate) fn adc_range_of(lo: f64, hi: f64) -> Option<(f64, f64)> {
    [
        (0.0, 255.0),
        (0.0, 1023.0),
        (-32768.0, 32767.0),
        (0.0, 65535.0),
    ]
    .into_iter()
    .find(|(a, b)| lo >= *a && hi <= *b)
}

/// Refuses static intervals with a sample at an ADC limit: the first such sample of the first
/// such window, in recording order. The windows are checked on all cores (each window's scan
/// is independent), and the first failure in window order is the one reported, as a scan of
/// the windows one after another would.
pub fn check_saturation(
    rec: &Recording,
    intervals: &[StaticInterval],
    range: Option<(f64, f64)>,
) -> Result<()> {
    use rayon::prelude::*;
    let Some(range) = range else {
        return Ok(());
    };
    let found = intervals
        .par_iter()
        .enumerate()
        .filter_map(|(k, iv)| saturated_sample(rec, iv, range).map(|s| (k, s)))
        .find_first(|_| true);
    match found {
        None => Ok(()),
        Some((k, (i, a, value))) => Err(saturated_at(intervals, k, i, a, value)),
    }
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

/// The first sample of `iv` (its index, axis and value) at or beyond the ADC limits `(lo, hi)`.
fn saturated_sample(
    rec: &Recording,
    iv: &StaticInterval,
    (lo, hi): (f64, f64),
) -> Option<(usize, usize, f64)> {
    let span = iv.start as usize..(iv.end as usize).min(rec.len());
    let xyz = rec.xyz.get(span.clone())?;
    xyz.iter().zip(span).find_map(|(s, i)| {
        let a = s.iter().position(|v| *v <= lo || *v >= hi)?;
        Some((i, a, s[a]))
    })
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
    /// Sample times (recording clock), s: every sample's for a recording held in memory
    /// ([`detect_windows`]: `analyze`'s thermal regressors read them); empty for samples
    /// streamed from a file ([`crate::detect::streamed`]) and for `fit` and `gyrofit`, which
    /// read the windows' own times.
    pub times: Vec<f64>,
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

/// The recording as the detector should see it. The detector floors variances at the
/// quantisation variance of integer counts (1/12); non-integer input (already in g or m/s²)
/// is therefore rescaled, for the detector only, so that the rest period's quietest axis has
/// unit std and the floor sits well below the noise.
fn detector_view(rec: &Recording, opts: &DetectOptions) -> Option<Recording> {
    if rec.is_integer() {
        return None;
    }
    let rate = rec.estimated_rate_hz().unwrap_or(opts.default_rate_hz);
    let k = detector_scale(
        || rec.xyz.iter().copied(),
        rec.len(),
        rate,
        opts,
        || {
            let mags: Vec<f64> = rec.xyz.iter().map(magnitude).collect();
            st::median(&mags)
        },
    );
    Some(Recording {
        xyz: rec.xyz.iter().map(|s| s.map(|v| v * k)).collect(),
        t: rec.t.clone(),
        temp: None,
        labels: None,
        sample_rate_hz: rec.sample_rate_hz,
        axis_columns: rec.axis_columns.clone(),
        skipped_empty_rows: rec.skipped_empty_rows,
        notes: Vec::new(),
        info: Vec::new(),
    })
}

/// ‖s‖ of one sample.
pub(crate) fn magnitude(s: &[f64; 3]) -> f64 {
    (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt()
}

/// [`detector_view`]'s scale for the `n` samples `samples` yields afresh on every call (only
/// the rest period's head is read): one over the quietest axis's std over the rest period,
/// else (a constant head) 10⁴ over the median ‖a‖ (`median_mag`, asked only then).
pub(crate) fn detector_scale<I: Iterator<Item = [f64; 3]>>(
    samples: impl Fn() -> I,
    n: usize,
    rate: f64,
    opts: &DetectOptions,
    median_mag: impl FnOnce() -> f64,
) -> f64 {
    let init = ((opts.init_s * rate) as usize).clamp(2, n.max(2));
    let len = init.min(n);
    let mut sd_min = f64::INFINITY;
    for a in 0..3 {
        let m = samples().take(len).map(|s| s[a]).sum::<f64>() / len.max(1) as f64;
        let v =
            samples().take(len).map(|s| (s[a] - m).powi(2)).sum::<f64>() / (len.max(2) - 1) as f64;
        sd_min = sd_min.min(v.sqrt());
    }
    if sd_min > 0.0 && sd_min.is_finite() {
        1.0 / sd_min
    } else {
        1e4 / median_mag().max(1e-30)
    }
}

/// Names the setting the core's detector would refuse with a bare "invalid parameter": the
/// rest period shorter than the window, a zero minimum static duration, a threshold that is
/// not positive. At a sample rate under 2 Hz the message suggests millisecond times.
fn check_detector_settings(cfg: &StaticDetectorConfig, rate: f64) -> Result<()> {
    // Rounded for the message (a rate from a time column is 100.00000000000213 Hz).
    let rate_hz = (rate * 1e6).round() / 1e6;
    let hint = if rate < 2.0 {
        format!(" (the sample rate is {rate_hz} Hz: is the time column in milliseconds rather than seconds?)")
    } else {
        String::new()
    };
    if cfg.init_samples < u32::from(cfg.window) {
        return Err(DetectError::DetectorSetting {
            setting: Setting::InitialRest,
            why: format!(
                "{} samples at {rate_hz} Hz, fewer than the {}-sample variance window{hint}",
                cfg.init_samples, cfg.window
            ),
        });
    }
    if cfg.min_static_samples < 1 {
        return Err(DetectError::DetectorSetting {
            setting: Setting::MinStatic,
            why: format!("less than one sample at {rate_hz} Hz{hint}"),
        });
    }
    if !(cfg.threshold_factor.is_finite() && cfg.threshold_factor > 0.0) {
        return Err(DetectError::DetectorSetting {
            setting: Setting::Threshold,
            why: format!("{} is not a positive number", cfg.threshold_factor),
        });
    }
    Ok(())
}

/// Batch means per window: the window split into this many blocks.
pub(crate) const BATCHES: usize = 10;

/// Per-axis variance of the mean from [`BATCHES`] batch means (sees slow noise that var/n
/// misses); `None` when the window is shorter than 5 samples per batch.
fn batch_var_of_mean(xs: &[[f64; 3]]) -> Option<[f64; 3]> {
    const B: usize = BATCHES;
    if xs.len() < 5 * B {
        return None;
    }
    let len = xs.len() / B;
    let mut bm = [[0.0; 3]; B];
    for (b, m) in bm.iter_mut().enumerate() {
        for x in &xs[b * len..(b + 1) * len] {
            for a in 0..3 {
                m[a] += x[a] / len as f64;
            }
        }
    }
    Some(batch_spread(&bm))
}

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

/// The times of a held recording's samples as [`Recording::times`] gives them at the
/// detection's rate, read where needed instead of copied whole (a week's time column is
/// hundreds of megabytes; `fit` reads only the windows' times).
#[derive(Clone, Copy)]
struct Clock<'a> {
    /// The time column, when the file has one.
    t: Option<&'a [f64]>,
    /// Otherwise sample `i` is at `i / fs` s.
    fs: f64,
    /// Samples.
    n: usize,
}

impl<'a> Clock<'a> {
    /// The clock of `rec` detected at `rate_hz`.
    fn of(rec: &'a Recording, rate_hz: f64) -> Self {
        Clock {
            t: rec.t.as_deref(),
            fs: rec.sample_rate_hz.unwrap_or(rate_hz),
            n: rec.len(),
        }
    }

    /// Time of sample `i` (< `n`), s.
    fn at(&self, i: usize) -> f64 {
        match self.t {
            Some(t) => t[i],
            None => i as f64 / self.fs,
        }
    }

    /// The sum of the times of samples `s..e`, added in order as `times[s..e].iter().sum()`.
    fn sum(&self, (s, e): (usize, usize)) -> f64 {
        match self.t {
            Some(t) => t[s..e].iter().sum(),
            None => (s..e).map(|i| i as f64 / self.fs).sum(),
        }
    }

    /// Times of the first and the last sample; `None` without samples.
    fn ends(&self) -> Option<(f64, f64)> {
        match self.t {
            Some(t) => t.first().zip(t.last()).map(|(a, b)| (*a, *b)),
            None => (self.n > 0).then(|| (self.at(0), self.at(self.n - 1))),
        }
    }

    /// Every sample's time ([`Recording::times`]).
    fn to_vec(self) -> Vec<f64> {
        match self.t {
            Some(t) => t.to_vec(),
            None => (0..self.n).map(|i| self.at(i)).collect(),
        }
    }
}

/// The f64 statistics of samples `s..e` (at least two). `t0`: time of the first sample.
fn window_stats(
    rec: &Recording,
    (s, e): (usize, usize),
    clock: &Clock,
    t0: f64,
    integer: bool,
) -> WindowStats {
    let xs = &rec.xyz[s..e];
    let n = xs.len() as f64;
    let mut mean = [0.0; 3];
    for x in xs {
        for a in 0..3 {
            mean[a] += x[a];
        }
    }
    mean = mean.map(|v| v / n);
    let mut var = [0.0; 3];
    let mut runs = Runs::default();
    for x in xs {
        for a in 0..3 {
            var[a] += (x[a] - mean[a]).powi(2);
        }
        runs.push(x, &mean);
    }
    runs.close();
    var = variance_of(var, n, integer);
    WindowStats {
        start: s,
        end: e,
        mean,
        var,
        batch_var_of_mean: batch_var_of_mean(xs),
        t_centre: clock.sum((s, e)) / n - t0,
        t_first: clock.at(s),
        t_last: clock.at(e - 1),
        temp: rec.temp.as_ref().map(|tc| tc[s..e].iter().sum::<f64>() / n),
        count: Some(e - s),
        runs: Some(runs),
        distinct: None,
    }
}

/// Detects the static windows (the core's detector via [`detect`]), refuses saturated ones,
/// computes their f64 statistics and infers the input units.
pub fn detect_windows(rec: &Recording, opts: &DetectOptions) -> Result<Windows> {
    detect_windows_timed(rec, opts, true)
}

/// [`detect_windows`] without every sample's time in [`Windows::times`] (left empty, as for
/// a streamed file): for `fit` and `gyrofit`, which read the windows' own times only.
pub(crate) fn detect_windows_untimed(rec: &Recording, opts: &DetectOptions) -> Result<Windows> {
    detect_windows_timed(rec, opts, false)
}

/// [`detect_windows`], keeping every sample's time when `keep_times`.
fn detect_windows_timed(
    rec: &Recording,
    opts: &DetectOptions,
    keep_times: bool,
) -> Result<Windows> {
    let integer = all_whole(&rec.xyz);
    let det = if opts.adaptive {
        detect_adaptive_of(rec, opts, integer)?
    } else {
        match detector_view(rec, opts) {
            None => detect(rec, opts)?,
            Some(scaled) => detect(&scaled, opts)?,
        }
    };
    let range = opts.adc_range.or_else(|| adc_range_if(&rec.xyz, integer));
    check_saturation(rec, &det.intervals, range)?;
    let clock = Clock::of(rec, det.rate_hz);
    let t0 = clock.ends().map_or(0.0, |(first, _)| first);
    // Each window's statistics depend on its samples alone: computed on all cores, kept in
    // window order.
    let mut stats: Vec<WindowStats> = {
        use rayon::prelude::*;
        det.intervals
            .par_iter()
            .map(|iv| (iv.start as usize, (iv.end as usize).min(rec.len())))
            .filter(|(s, e)| *e > s + 1)
            .map(|span| window_stats(rec, span, &clock, t0, integer))
            .collect()
    };
    let polling = judge_polling(&mut stats, integer);
    let norms: Vec<f64> = stats
        .iter()
        .map(|w| (w.mean[0].powi(2) + w.mean[1].powi(2) + w.mean[2].powi(2)).sqrt())
        .collect();
    Ok(Windows {
        polling,
        units: infer_units(integer, st::median(&norms)),
        stats,
        clock: clock.ends(),
        times: if keep_times {
            clock.to_vec()
        } else {
            Vec::new()
        },
        reference_variance: det.reference_variance,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

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

    /// The chosen setting's windows are kept as they are; a shorter-setting interval is added
    /// only where it overlaps none of them, and the result is in time order.
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

    /// The sweep of [`fill_holds`] against the definition (every short interval overlapping no
    /// chosen one), on many random pairs of ordered interval lists.
    #[test]
    fn fill_holds_sweep_keeps_exactly_the_short_holds_overlapping_nothing() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = |m: u32| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % u64::from(m)) as u32
        };
        let ordered = |count: u32, next: &mut dyn FnMut(u32) -> u32| {
            let mut at = 0;
            (0..count)
                .map(|_| {
                    let start = at + next(40);
                    at = start + 1 + next(60);
                    StaticInterval {
                        start,
                        end: at,
                        mean: [0.0; 3],
                        variance: [0.0; 3],
                    }
                })
                .collect::<Vec<_>>()
        };
        for _ in 0..500 {
            let (c, s) = (next(12), next(20));
            let (chosen, short) = (ordered(c, &mut next), ordered(s, &mut next));
            let overlaps =
                |a: &StaticInterval, b: &StaticInterval| a.start < b.end && b.start < a.end;
            let mut want: Vec<StaticInterval> = chosen.clone();
            want.extend(
                short
                    .iter()
                    .filter(|s| !chosen.iter().any(|c| overlaps(c, s))),
            );
            want.sort_by_key(|iv| iv.start);
            assert_eq!(fill_holds(chosen, &short), want);
        }
    }

    #[test]
    fn fill_holds_adds_only_the_holds_without_a_window() {
        let iv = |start: u32, end: u32| StaticInterval {
            start,
            end,
            mean: [start as f32; 3],
            variance: [0.0; 3],
        };
        let chosen = vec![iv(0, 300), iv(600, 900)];
        let short = [iv(10, 290), iv(350, 500), iv(550, 610), iv(950, 1100)];
        let got = fill_holds(chosen, &short);
        assert_eq!(
            got,
            vec![iv(0, 300), iv(350, 500), iv(600, 900), iv(950, 1100)]
        );
    }

    /// The whole-number check is `fract() == 0` for every kind of value.
    #[test]
    fn whole_numbers_are_those_without_a_fraction() {
        let two52 = 4_503_599_627_370_496.0f64;
        let values = [
            0.0,
            -0.0,
            1.0,
            -32768.0,
            0.5,
            -1e-300,
            two52 - 0.5,
            two52,
            -two52 - 2.0,
            9.3e18,
            1e300,
            f64::MAX,
            f64::MIN_POSITIVE,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for v in values {
            assert_eq!(all_whole(&[[0.0, v, 1.0]]), v.fract() == 0.0, "{v}");
        }
        assert!(all_whole(&[]));
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
}
