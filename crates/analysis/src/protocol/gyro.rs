//! The gyroscope's protocols: what `gyrofit` does when the recording is not today's (motions
//! between free poses), and what `calibrate` runs for a gyro.
//!
//! * `--table-rate R[,R…]` (°/s): known constant rates ([`super::rates`]): no clock needed.
//! * full turns of a known angle between rests, with a clock (Ferraris: [`super::rotations`]).
//! * otherwise the rests alone: the bias (the AHRS seed's gyro offset), scale and misalignment
//!   named as not measured, with what to record or give.

use super::faces::{window_face, zero_reading};
use super::g_sensitivity::{fit_g_sensitivity, GSensitivityFit, GyroRest};
use super::rates::{fit_rates, steady_runs, RateFit, SteadyMean};
use super::rotations::{fit_turns, turns, Turn, TurnFit, TurnInput, TurnSample};
use super::vec3::{norm, sub};
use crate::detect::windows::{detect_windows, time_of, DetectOptions, Windows};
use crate::source::RowSource;
use serde::Serialize;

impl GyroProtocolReport {
    /// The gyro calibration file of this report, `None` when only the bias was measured and
    /// no nominal scale is known. It has no held-out error (`cv_rms_deg` absent: the protocols'
    /// fits are exactly determined or judged against the rates, not by held-out motions).
    pub fn cal_file(&self) -> Option<crate::output::gyrocal::GyroCalFile> {
        Some(crate::output::gyrocal::GyroCalFile {
            model: self.method.to_string(),
            correction: wiical_core::gyro_correct::GyroCorrection {
                bias: self.bias,
                matrix: self.matrix?,
                effects: wiical_core::gyro_correct::GyroEffects {
                    g_sensitivity: self
                        .g_sensitivity
                        .as_ref()
                        .map_or([[0.0; 3]; 3], GSensitivityFit::rad_per_s_per_g),
                },
            },
            cv_rms_deg: f64::NAN,
        })
    }
}

/// Settings of the gyro's protocol methods.
#[derive(Debug, Clone)]
pub struct GyroProtocolOptions {
    /// The angle of each full turn, degrees (Ferraris: 360).
    pub rotation_deg: f64,
    /// Known table rates, °/s (0 for a rest); `None`: not a rate table.
    pub table_rates_dps: Option<Vec<f64>>,
    /// The still-window detector.
    pub detect: DetectOptions,
    /// The gyro's nominal rad/s per raw unit, when known (flags or column names).
    pub nominal_rad_per_raw: Option<[f64; 3]>,
}

impl Default for GyroProtocolOptions {
    fn default() -> Self {
        Self {
            rotation_deg: 360.0,
            table_rates_dps: None,
            detect: DetectOptions::default(),
            nominal_rad_per_raw: None,
        }
    }
}

/// What the gyro's protocol method found (`gyrofit --json` when it runs).
#[derive(Debug, Clone, Serialize)]
pub struct GyroProtocolReport {
    /// What was recognised, one line.
    pub protocol: String,
    /// `ferraris`, `rate-table`, `rate-shells` or `rest-bias`.
    pub method: &'static str,
    /// `b`, raw units.
    pub bias: [f64; 3],
    /// `K`, rad/s per raw unit (`ω = K·(m − b)`); the nominal when only the bias was measured
    /// (`null` entries when no nominal is known).
    pub matrix: Option<[[f64; 3]; 3]>,
    /// Rests (still windows) the bias came from, and their samples.
    pub rests: usize,
    /// Samples in the rests.
    pub rest_samples: usize,
    /// Standard error of the bias, raw units.
    pub bias_std_error: [f64; 3],
    /// The motions between rests, when a clock allowed integrating them.
    pub turns: Vec<Turn>,
    /// The Ferraris fit, when full turns about x, y and z were found.
    pub turn_fit: Option<TurnFit>,
    /// The known-rate fit.
    pub rate_fit: Option<RateFit>,
    /// Ferraris: the gyro's g-sensitivity and its bias at zero specific force, from the rests
    /// ([`super::g_sensitivity`]); absent otherwise. When present, `bias` is its `b` and the
    /// calibration file carries its `G`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub g_sensitivity: Option<GSensitivityFit>,
    /// Verdict: `good`, `unchecked` (exactly determined: nothing left to test it),
    /// `bias-only`, `unexplained-residual`.
    pub verdict: &'static str,
    /// The verdict's reasons and what could not be tested, one sentence each.
    pub notes: Vec<String>,
}

pub use crate::error::protocol::GyroProtocolError;

type Result<T> = std::result::Result<T, GyroProtocolError>;

/// Windows pooled: the count-weighted mean and per-sample variance, raw, and the samples.
struct Pooled {
    mean: [f64; 3],
    var: [f64; 3],
    samples: usize,
}

impl Pooled {
    /// Count-weighted over the windows `pick` of `ws`.
    fn of(ws: &Windows, pick: &[usize]) -> Self {
        let samples: usize = pick.iter().map(|i| ws.stats[*i].count.unwrap_or(1)).sum();
        let weighted = |field: fn(&crate::detect::windows::WindowStats) -> [f64; 3]| {
            std::array::from_fn(|a| {
                pick.iter()
                    .map(|i| ws.stats[*i].count.unwrap_or(1) as f64 * field(&ws.stats[*i])[a])
                    .sum::<f64>()
                    / samples.max(1) as f64
            })
        };
        Self {
            mean: weighted(|w| w.mean),
            var: weighted(|w| w.var),
            samples,
        }
    }

    /// The mean's standard error, raw (samples taken as independent).
    fn std_error(&self) -> [f64; 3] {
        self.var.map(|v| (v / self.samples.max(1) as f64).sqrt())
    }
}

/// Runs the gyro's protocol method on `gyro` (and the accelerometer `acc` of the same samples,
/// when the file has one): held recordings or large files read in passes, one code (whether
/// a file's pass failed is for the caller to ask after it: [`RowSource::check`]).
pub fn run<R: RowSource + ?Sized>(
    acc: Option<&R>,
    gyro: &R,
    opts: &GyroProtocolOptions,
) -> Result<GyroProtocolReport> {
    let gws = detect_windows(gyro, &opts.detect).map_err(GyroProtocolError::Detect)?;
    let rest_idx = rests_of(&gws);
    if let Some(rates) = &opts.table_rates_dps {
        return Ok(rate_table(gyro, &gws, &rest_idx, rates, opts));
    }
    if rest_idx.is_empty() {
        return Err(GyroProtocolError::NoRest);
    }
    let mut rep = rest_report(&gws, &rest_idx, opts);
    let bias = rep.bias;
    let levels = turning_levels(&gws, &rest_idx, bias);
    match (acc, gyro.has_time() || gyro.metadata_rate_hz().is_some()) {
        (Some(acc), true) => ferraris(acc, gyro, (&gws, &rest_idx), bias, opts, &mut rep),
        (_, false) => rep.notes.push(
            "the file has no clock (no time column, no Fs): turns between rests cannot be \
             integrated, so the gyro's scale cannot come from them; give --rate-hz, or known \
             table rates with --table-rate"
                .into(),
        ),
        (None, true) => {}
    }
    if rep.turn_fit.is_none() {
        rest_only_notes(&mut rep, levels);
    }
    Ok(rep)
}

/// The report of the rests alone: their pooled bias, the nominal scale when known.
fn rest_report(gws: &Windows, rests: &[usize], opts: &GyroProtocolOptions) -> GyroProtocolReport {
    let p = Pooled::of(gws, rests);
    GyroProtocolReport {
        protocol: String::new(),
        method: "rest-bias",
        bias: p.mean,
        matrix: opts.nominal_rad_per_raw.map(diag),
        rests: rests.len(),
        rest_samples: p.samples,
        bias_std_error: p.std_error(),
        turns: Vec::new(),
        turn_fit: None,
        rate_fit: None,
        g_sensitivity: None,
        verdict: "bias-only",
        notes: Vec::new(),
    }
}

fn diag(s: [f64; 3]) -> [[f64; 3]; 3] {
    [[s[0], 0.0, 0.0], [0.0, s[1], 0.0], [0.0, 0.0, s[2]]]
}

/// The windows at rest: within a few noise widths of the slowest window.
fn rests_of(ws: &Windows) -> Vec<usize> {
    let Some(slow) = (0..ws.stats.len())
        .min_by(|a, b| norm(ws.stats[*a].mean).total_cmp(&norm(ws.stats[*b].mean)))
    else {
        return Vec::new();
    };
    let origin = ws.stats[slow].mean;
    // The spread of a rest's samples: 5 per-sample standard deviations from the slowest
    // window is still a rest (the bias moves a little between rests); a turning window is far
    // beyond (a rate table's 25 °/s is ~100 standard deviations).
    let sd = norm(ws.stats[slow].var.map(f64::sqrt)).max(f64::MIN_POSITIVE);
    (0..ws.stats.len())
        .filter(|i| norm(sub(ws.stats[*i].mean, origin)) <= 5.0 * sd)
        .collect()
}

/// Distinct steady turning rates (magnitudes from the bias, raw units), clustered within 6 %.
fn turning_levels(ws: &Windows, rests: &[usize], bias: [f64; 3]) -> Vec<f64> {
    let mut mags: Vec<f64> = (0..ws.stats.len())
        .filter(|i| !rests.contains(i))
        .map(|i| norm(sub(ws.stats[i].mean, bias)))
        .collect();
    mags.sort_by(f64::total_cmp);
    let mut levels: Vec<(f64, usize)> = Vec::new();
    for m in mags {
        match levels.last_mut() {
            Some((l, k)) if m <= *l * 1.06 => {
                *l = (*l * *k as f64 + m) / (*k + 1) as f64;
                *k += 1;
            }
            _ => levels.push((m, 1)),
        }
    }
    // A level seen in at least two steady windows is a rate the table or turntable held.
    levels
        .into_iter()
        .filter(|(_, k)| *k >= 2)
        .map(|(l, _)| l)
        .collect()
}

fn rest_only_notes(rep: &mut GyroProtocolReport, levels: Vec<f64>) {
    if levels.is_empty() {
        rep.protocol = format!("{} rest(s), no steady turning rate", rep.rests);
        rep.notes.push(
            "scale and misalignment were not measured: only the bias at rest (the AHRS seed's \
             gyro offset); turn the sensor once about each axis between rests (Ferraris), or \
             record known table rates (--table-rate)"
                .into(),
        );
        return;
    }
    let shown: Vec<String> = levels.iter().map(|l| format!("{l:.4}")).collect();
    rep.protocol = format!(
        "{} rest(s) and steady turning at {} level(s) ({} raw, ratio {:.3})",
        rep.rests,
        levels.len(),
        shown.join(", "),
        levels.last().unwrap_or(&1.0) / levels[0]
    );
    rep.notes.push(format!(
        "a rate table or turntable was recognised (steady rates at {} levels): give their \
         rates with --table-rate (°/s, e.g. --table-rate 0,200,270 for 33⅓ and 45 RPM) to \
         measure scale and misalignment; without them only the bias is measured",
        levels.len()
    ));
}

/// Full turns between the accelerometer's rests, and the Ferraris fit when x, y, z turned.
fn ferraris<R: RowSource + ?Sized>(
    acc: &R,
    gyro: &R,
    (gws, rest_idx): (&Windows, &[usize]),
    bias: [f64; 3],
    opts: &GyroProtocolOptions,
    rep: &mut GyroProtocolReport,
) {
    // The rests are the gyro's own (a turn about the vertical leaves the accelerometer still:
    // its still windows would swallow the turn); the accelerometer's direction is read over
    // each rest's samples, the same rows of the same file.
    let mut rests: Vec<(usize, usize)> = rest_idx
        .iter()
        .map(|i| (gws.stats[*i].start, gws.stats[*i].end.min(acc.len())))
        .filter(|(s, e)| e > s)
        .collect();
    rests.sort_unstable();
    let (means, integer) = span_means(acc, &rests);
    let units = if integer { "raw" } else { "g" };
    let zero = zero_reading(&means, units);
    let dirs: Vec<[f64; 3]> = means
        .iter()
        .map(|m| window_face(*m, zero).direction)
        .collect();
    let raw_per_dps = opts
        .nominal_rad_per_raw
        .map(|s| 1f64.to_radians() / s[0].abs());
    let inp = TurnInput {
        rests: &rests,
        rest_directions: Some(&dirs),
        bias,
        raw_per_dps,
    };
    let fs = gyro
        .metadata_rate_hz()
        .unwrap_or(opts.detect.default_rate_hz);
    rep.turns = turns(samples(gyro, fs, None), gyro.len(), &inp);
    let full: Vec<&Turn> = rep.turns.iter().filter(|t| t.full_turn).collect();
    let axes: Vec<String> = full.iter().filter_map(|t| t.axis.clone()).collect();
    let full = full.len();
    match fit_turns(&rep.turns, bias, opts.rotation_deg) {
        Ok(fit) => {
            rep.protocol = format!(
                "{} rests, {} full turns (about {}) of {}° taken",
                rep.rests,
                full,
                axes.join(", "),
                opts.rotation_deg
            );
            let rests = (gws, rest_idx, means.as_slice());
            let fit = with_g_sensitivity((acc, gyro, fs), rests, &inp, fit, opts, rep);
            ferraris_verdict(fit, opts, rep);
        }
        Err(e) if full > 0 => rep.notes.push(e.to_string()),
        Err(_) => {}
    }
}

/// The mean of `src`'s rows over each of the sorted, disjoint `spans` (one pass, each sum in
/// row order), and whether every value is a whole number.
fn span_means<R: RowSource + ?Sized>(src: &R, spans: &[(usize, usize)]) -> (Vec<[f64; 3]>, bool) {
    // A sum of no terms as `Iterator::sum` starts it (the sign of an all-zero sum kept).
    let zero: f64 = std::iter::empty::<f64>().sum();
    let mut sums = vec![[zero; 3]; spans.len()];
    let (mut k, mut integer) = (0, true);
    for (i, r) in src.rows().enumerate() {
        integer &= r.xyz.iter().all(|v| v.fract() == 0.0);
        while spans.get(k).is_some_and(|s| s.1 <= i) {
            k += 1;
        }
        if spans.get(k).is_some_and(|s| s.0 <= i) {
            (0..3).for_each(|a| sums[k][a] += r.xyz[a]);
        }
    }
    let means = spans
        .iter()
        .zip(sums)
        .map(|((s, e), sum)| sum.map(|v| v / (e - s) as f64))
        .collect();
    (means, integer)
}

/// A gyro offset (raw) from the accelerometer's reading beside it.
type Offset<'a> = dyn Fn([f64; 3]) -> [f64; 3] + 'a;

/// The gyro's samples as the turns integrate them ([`TurnSample`]): the time of each row
/// (`fs` without a time column), and `off` of the accelerometer's row beside it (of zeros past
/// the accelerometer's rows; no offset without `off`).
fn samples<'a, R: RowSource + ?Sized>(
    gyro: &'a R,
    fs: f64,
    off: Option<(&'a R, &'a Offset<'a>)>,
) -> impl Iterator<Item = TurnSample> + 'a {
    let acc = off.map(|(a, _)| a.rows()).into_iter().flatten();
    let acc = acc.map(|r| r.xyz).chain(std::iter::repeat([0.0; 3]));
    gyro.rows().zip(acc).enumerate().map(move |(i, (r, a))| {
        let o = off.map_or([0.0; 3], |(_, f)| f(a));
        (time_of(r.t, i, fs), r.xyz, o)
    })
}

/// The Ferraris fit into the report, with its verdict.
fn ferraris_verdict(fit: TurnFit, opts: &GyroProtocolOptions, rep: &mut GyroProtocolReport) {
    rep.method = "ferraris";
    rep.matrix = Some(fit.matrix);
    rep.verdict = if fit.turns_per_axis.iter().all(|k| *k >= 2) {
        "good"
    } else {
        "unchecked"
    };
    if rep.verdict == "unchecked" {
        rep.notes.push(format!(
            "one full turn per axis fixes the scale and misalignment exactly (each turn \
             taken as {}°): nothing is left over to test them; a second turn about each \
             axis would, and a hand turn of 370° instead of 360° reads as a 2.8 % scale \
             error",
            opts.rotation_deg
        ));
    }
    if let Some((g, se)) = rep
        .g_sensitivity
        .as_ref()
        .and_then(GSensitivityFit::largest)
    {
        let gs = rep.g_sensitivity.as_ref().map_or(0, |f| f.rests);
        rep.notes.push(format!(
            "g-sensitivity G from the {gs} rests (the gyro's reading against the calibrated \
             gravity, imucal's K_ga): largest element {g:.4} °/s/g (standard error {se:.4}); \
             in the calibration file, applied as ω = K·(m − b) − G·a"
        ));
    }
    rep.turn_fit = Some(fit);
}

/// Ferraris: the gyro's g-sensitivity from its rests against the accelerometer's calibrated
/// reading ([`super::g_sensitivity`]; the rests' accelerometer means as [`span_means`] took
/// them), then the turns integrated again without it (each sample less `b + H·a(t)`, as
/// imucal integrates them) and `K` fitted again. When the rests or the accelerometer cannot
/// give it, `fit` is kept and a note says why.
fn with_g_sensitivity<R: RowSource + ?Sized>(
    (acc, gyro, fs): (&R, &R, f64),
    (gws, rest_idx, means): (&Windows, &[usize], &[[f64; 3]]),
    inp: &TurnInput,
    fit: TurnFit,
    opts: &GyroProtocolOptions,
    rep: &mut GyroProtocolReport,
) -> TurnFit {
    let Some(cal) = accel_calibration(acc, opts) else {
        rep.notes.push(
            "g-sensitivity not measured: the accelerometer gave no calibration to read \
             gravity with"
                .into(),
        );
        return fit;
    };
    // The rests with accelerometer rows, in time order: the ones `means` was taken over.
    let rests: Vec<GyroRest> = rest_idx
        .iter()
        .map(|i| &gws.stats[*i])
        .filter(|w| w.start < acc.len())
        .zip(means)
        .map(|(w, m)| GyroRest {
            mean: w.mean,
            var: w.var,
            samples: w.n().unwrap_or(1),
            specific_force_g: apply(&cal, *m),
        })
        .collect();
    let gf = match fit_g_sensitivity(&rests) {
        Ok(gf) => gf,
        Err(e) => {
            rep.notes.push(format!("g-sensitivity not measured: {e}"));
            return fit;
        }
    };
    let h = gf.raw_per_g;
    let offset = |m: [f64; 3]| -> [f64; 3] {
        let a = apply(&cal, m);
        std::array::from_fn(|r| (0..3).map(|c| h[r][c] * a[c]).sum())
    };
    let again = TurnInput {
        bias: gf.bias,
        ..*inp
    };
    let turned = turns(samples(gyro, fs, Some((acc, &offset))), gyro.len(), &again);
    let Ok(refit) = fit_turns(&turned, gf.bias, opts.rotation_deg) else {
        return fit;
    };
    rep.turns = turned;
    rep.bias = gf.bias;
    rep.bias_std_error = gf.bias_std_error;
    rep.g_sensitivity = Some(gf.with_matrix(&refit.matrix));
    refit
}

/// The accelerometer's calibration by its own protocol's method (the six faces of a Ferraris
/// session: the six-position method), `None` when it gives none.
fn accel_calibration<R: RowSource + ?Sized>(
    acc: &R,
    opts: &GyroProtocolOptions,
) -> Option<wiical_core::Calibration> {
    let ws = detect_windows(acc, &opts.detect).ok()?;
    let fit_opts = crate::fit::base::FitOptions {
        detect: opts.detect.clone(),
        ..Default::default()
    };
    let r = super::accel::fit_by_protocol(&ws, &fit_opts).ok()?;
    Some(r.report.calibration)
}

/// `K·(m − b)` of the accelerometer's linear calibration, in g.
fn apply(cal: &wiical_core::Calibration, m: [f64; 3]) -> [f64; 3] {
    let d: [f64; 3] = std::array::from_fn(|a| m[a] - f64::from(cal.bias[a]));
    std::array::from_fn(|r| (0..3).map(|c| f64::from(cal.matrix[r][c]) * d[c]).sum())
}

/// The known-rate method on the gyro's steady windows.
fn rate_table<R: RowSource + ?Sized>(
    gyro: &R,
    gws: &Windows,
    rests: &[usize],
    rates: &[f64],
    opts: &GyroProtocolOptions,
) -> GyroProtocolReport {
    let mut rep = rest_report(gws, rests, opts);
    rep.method = "rate-table";
    let rest_sd = Pooled::of(gws, rests).var.map(f64::sqrt);
    let steady: Vec<SteadyMean> = steady_runs(gyro.rows().map(|r| r.xyz), rep.bias, rest_sd);
    match fit_rates(&steady, rates) {
        Ok(fit) => {
            let turning = fit.windows.iter().filter(|w| w.rate_dps > 0.0).count();
            rep.protocol = format!(
                "rate table: {} steady parts at the rates given, {} at rest, {} at no rate given",
                turning,
                fit.windows.len() - turning,
                fit.left_out
            );
            rep.method = fit.method;
            rep.bias = fit.bias;
            rep.matrix = Some(fit.matrix);
            let explained = fit.rms_dps <= 3.0 * fit.noise_floor_dps;
            rep.verdict = if explained {
                "good"
            } else {
                "unexplained-residual"
            };
            rep.notes.push(format!(
                "|ω| after calibration is within {:.3} °/s RMS of the rates given (before: \
                 {:.3} °/s); the steady parts' own noise allows {:.3} °/s{}",
                fit.rms_dps,
                fit.rms_dps_before,
                fit.noise_floor_dps,
                if explained {
                    ""
                } else {
                    ": more is left than the noise explains (rates not exactly the ones given \
                     each way, an offset while turning, or a wobbling table)"
                }
            ));
            rep.rate_fit = Some(fit);
        }
        Err(e) => {
            rep.protocol = format!("{} steady part(s)", gws.stats.len());
            rep.notes.push(e.to_string());
        }
    }
    rep
}
