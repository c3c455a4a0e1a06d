//! The static-window detector: its settings ([`DetectOptions`], the ranges every door checks
//! them against), the core's detectors over the detector's view of the samples (the adaptive
//! one's survey and hold schedule, the fixed IMU-TK one), over samples in place (held pieces:
//! the pair by spans where exact, the survey four blocks at a time) or any pass (`Passes`),
//! and the view's lattice and scale. [`crate::detect::windows`] runs them over a recording's
//! rows.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use crate::detect::held::{
    both_or_first_error, feed_held, four_slices, piece_starts, samples_between, DetectorSample,
};
use crate::detect::spans;
use crate::error::detect::{DetectError, Setting};
use crate::input::sample_summary::is_whole;
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
/// quantiser levels or values, `f32`): samples in place are passed over by both cores at
/// once; a file's read a piece at a time, on all cores too (`windows::InPieces`).
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

/// The adaptive detection's intervals and reference variance from the `n` samples of `passes`.
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

/// Most quantiser levels per axis a lattice has (`windows::lattice`): a 16-bit ADC has 65 536;
/// beyond it the values are taken as continuous (and f32 still holds every level exactly).
pub(crate) const MAX_LATTICE_LEVELS: usize = 1 << 17;

/// How far (in steps) a value may sit from its lattice point and still count as on it: a
/// count converted to g and printed with 7 significant digits is ~10⁻⁵ step off.
const LATTICE_TOLERANCE: f64 = 1e-3;

/// A sample as quantiser levels of the per-axis lattices `(origin, step)` (`windows::lattice`).
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

/// The fixed (IMU-TK) detector's intervals and reference variance from the `n` samples `samples` yields (as
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

/// [`crate::input::recording::Recording::is_integer`] of samples `xyz` (every value whole: `v.fract() == 0`), on all
/// cores and without `fract`'s call to `trunc` (a library call on x86-64 without SSE4.1):
/// the streamed summary's test of each value (`is_whole`).
pub fn all_whole(xyz: &[[f64; 3]]) -> bool {
    use rayon::prelude::*;
    xyz.par_iter().all(|s| s.iter().all(|v| is_whole(*v)))
}

/// The ADC range holding every value from `lo` to `hi`, when the values are whole numbers:
/// 10-bit (0..1023), 8-bit (0..255), signed 16-bit or unsigned 16-bit.
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

/// The scale of the fixed detector's view of non-integer values (`windows::detect_fixed`): the
/// detector floors variances at the quantisation variance of integer counts (1/12), so values
/// already in g or m/s² are rescaled, for the detector only, so that the rest period's
/// quietest axis has unit std and the floor sits well below the noise. The scale for the `n`
/// samples `samples` yields afresh on every call (only the rest period's head is read): one over the quietest axis's std over the rest period,
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
