//! `wiical analyze`: residual analysis of a multi-position recording. Finds what the linear
//! model leaves unexplained, traces it to an effect the model lacks, adds that effect and
//! reports the error before and after, in-sample and under cross-validation.
//!
//! Pipeline (multi-position; a file with a `pose` column goes to [`crate::analyze_six`]):
//! 1. Static windows are detected and the base 9-parameter model fitted exactly as `wiical fit`
//!    does (the core's streaming detector and `f32` Levenberg–Marquardt). Non-integer input
//!    (already in g or m/s²) is rescaled for the detector only, so that its quantisation floor
//!    (a variance of 1/12 raw unit²) does not swamp the noise reference.
//! 2. The base model is refined in `f64` ([`crate::analyze_model`]); each window's residual is
//!    `‖a‖ − 1 g`. The noise floor is what averaging can achieve: each window's per-axis
//!    sample variance / n, propagated through the calibration to ‖a‖. A chi-square test says
//!    whether the residual is above that floor. (A batch-means floor, from the scatter of ten
//!    sub-block means per window, is reported too: it also sees slow noise that var/n misses.)
//! 3. Candidate effects — `quadratic`, `cubic`, `bias-drift`, `temperature`,
//!    `temperature-scale` (3 parameters each, fitted jointly with the base 9), `outliers`
//!    (windows that were not still: a robust screen, then a Bonferroni-corrected
//!    prediction-error test) and, as a diagnostic only (the core cannot store it),
//!    `bias-drift-curved` (bias linear + quadratic in time) — are tried greedily. A candidate
//!    is accepted only if
//!    * its in-sample improvement passes an F-test at level α/m (m = candidates tried at that
//!      step; α = 10⁻³ by default), and
//!    * its leave-one-window-out cross-validated RMS of ‖a‖ − 1 g improves by the factor
//!      `cv_factor` (1.1 by default);
//!
//!    the passing candidate with the lowest CV RMS wins, compared head to head with the
//!    runner-up by a paired t-test on the held-out squared errors (inseparable pairs, e.g. time
//!    against a temperature that rises with time, are named in the evidence).
//! 4. The final model is stored in the core's `f32` [`Calibration`] (`effects`), so that
//!    `Calibration::correct(m, &Conditions { time_s: t − t₀, temperature_c })` reproduces it,
//!    with `t₀` the time of the first sample ([`AnalyzeReport::time_origin_s`]).

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use crate::analyze_model::{self as am, Fit, Mask, Normalisation, Params, Term, Win};
use crate::analyze_stats as st;
use crate::fit_cmd::{self, FitOptions};
use crate::input::Recording;
use anyhow::{anyhow, bail, Result};
use serde::Serialize;
use std::fmt::Write as _;
use wiical_core::multipos::{self, MultiPosConfig, MultiPosModel};
use wiical_core::Calibration;

/// Settings of the analysis.
#[derive(Debug, Clone)]
pub struct AnalyzeOptions {
    /// Detection and base-fit settings (as `wiical fit`).
    pub fit: FitOptions,
    /// Family-wise significance level per greedy step (Bonferroni over the candidates tried).
    pub alpha: f64,
    /// A candidate must divide the cross-validated RMS by at least this factor.
    pub cv_factor: f64,
    /// At most this many effects are added.
    pub max_effects: usize,
    /// At most this fraction of the windows may be rejected as outliers.
    pub max_outlier_fraction: f64,
    /// Restrict the candidates to these names (`None`: all).
    pub candidates: Option<Vec<String>>,
}

impl Default for AnalyzeOptions {
    fn default() -> Self {
        Self {
            fit: FitOptions::default(),
            alpha: 1e-3,
            cv_factor: 1.1,
            max_effects: 3,
            max_outlier_fraction: 0.2,
            candidates: None,
        }
    }
}

/// Names of every candidate effect, as accepted by [`AnalyzeOptions::candidates`].
pub const CANDIDATE_NAMES: [&str; 7] = [
    "quadratic",
    "cubic",
    "bias-drift",
    "temperature",
    "temperature-scale",
    "outliers",
    "bias-drift-curved",
];

/// Error summary of a model.
#[derive(Debug, Clone, Serialize)]
pub struct ModelSummary {
    /// Free parameters (base 9, + 3 per effect, + 1 per rejected window).
    pub params: usize,
    /// In-sample RMS of ‖a‖ − 1 g over the windows used, milli-g.
    pub rms_mg: f64,
    /// Leave-one-window-out RMS of ‖a‖ − 1 g over the windows used, milli-g (`null` when it
    /// cannot be computed, e.g. six poses).
    pub cv_rms_mg: Option<f64>,
    /// Windows used (all but the rejected ones).
    pub windows_used: usize,
    /// χ² of the residuals against the per-window noise floor.
    pub chi2: Option<f64>,
    /// Its degrees of freedom (windows used − parameters).
    pub chi2_dof: Option<usize>,
    /// P(χ² this large | only noise): small means residual above the floor.
    pub chi2_p: Option<f64>,
}

/// One accepted effect.
#[derive(Debug, Clone, Serialize)]
pub struct EffectReport {
    /// `quadratic`, `cubic`, `bias-drift`, `temperature`, `temperature-scale`, `outliers`,
    /// `pose-misalignment` (six-position only).
    pub name: String,
    /// Parameters it adds.
    pub params: usize,
    /// In-sample RMS after adding it, milli-g.
    pub rms_mg: f64,
    /// Cross-validated RMS after adding it, milli-g.
    pub cv_rms_mg: Option<f64>,
    /// Cross-validated RMS before adding it (same windows), milli-g.
    pub cv_rms_before_mg: Option<f64>,
    /// Which residual pattern pointed to it, and the test results.
    pub evidence: String,
    /// F statistic of the in-sample improvement (or the outlier test's).
    pub f_stat: Option<f64>,
    /// Its p-value (Bonferroni-corrected over windows for outliers, not over candidates).
    pub p_value: Option<f64>,
    /// Fitted per-axis values (units in `unit`), when the effect has them.
    pub values: Option<[f64; 3]>,
    /// Their standard errors.
    pub std_errors: Option<[f64; 3]>,
    /// Unit of `values`.
    pub unit: Option<String>,
    /// Rejected windows (1-based, as in the window table), for `outliers`.
    pub rejected_windows: Option<Vec<usize>>,
}

/// One candidate tried at one greedy step.
#[derive(Debug, Clone, Serialize)]
pub struct CandidateReport {
    /// Effect name.
    pub name: String,
    /// Parameters it would add.
    pub params: usize,
    /// In-sample RMS with it, milli-g.
    pub rms_mg: Option<f64>,
    /// Cross-validated RMS with it, milli-g (over the windows it keeps, for outliers).
    pub cv_rms_mg: Option<f64>,
    /// Cross-validated RMS of the current model over the same windows, milli-g.
    pub cv_rms_current_mg: Option<f64>,
    /// F statistic.
    pub f_stat: Option<f64>,
    /// p-value (before the Bonferroni factor over candidates).
    pub p_value: Option<f64>,
    /// Passed both rules.
    pub passed: bool,
    /// Why not, or what it found.
    pub note: String,
}

/// One greedy step.
#[derive(Debug, Clone, Serialize)]
pub struct StepReport {
    /// Candidates tried.
    pub candidates: Vec<CandidateReport>,
    /// Significance level each candidate was held to (α / candidates).
    pub level: f64,
    /// The one accepted, if any.
    pub accepted: Option<String>,
}

/// One static window.
#[derive(Debug, Clone, Serialize)]
pub struct WindowInfo {
    /// 1-based index.
    pub index: usize,
    /// Start, s (recording time).
    pub t_start: f64,
    /// End, s.
    pub t_end: f64,
    /// Mean sample time, s since the first sample.
    pub t_centre: f64,
    /// Samples.
    pub samples: usize,
    /// Mean temperature, °C.
    pub temp: Option<f64>,
    /// Mean reading, raw units.
    pub mean: [f64; 3],
    /// Residual ‖a‖ − 1 g under the base model, milli-g.
    pub residual_base_mg: f64,
    /// Residual under the final model, milli-g.
    pub residual_final_mg: f64,
    /// Held-out residual under the base model, milli-g.
    pub cv_base_mg: Option<f64>,
    /// Held-out residual under the final model, milli-g (`null` for rejected windows).
    pub cv_final_mg: Option<f64>,
    /// Noise floor of this window's residual (var/n through the calibration), milli-g.
    pub floor_mg: f64,
    /// Rejected as an outlier.
    pub rejected: bool,
    /// Fitted contribution of the first accepted effect (its residual signature), milli-g.
    pub signature_mg: Option<f64>,
}

/// Six-position details (see [`crate::analyze_six`]).
pub use crate::analyze_six::SixPositionDetails;

/// The analysis result (JSON keys `static_windows`, `noise_floor_mg`, `base`, `effects`,
/// `final` are the CLI contract).
#[derive(Debug, Clone, Serialize)]
pub struct AnalyzeReport {
    /// `multi-position` or `six-position`.
    pub mode: &'static str,
    /// Input units as detected: `raw`, `g` or `m/s^2`.
    pub units: &'static str,
    /// Samples in the recording.
    pub samples: usize,
    /// Static windows (poses) found.
    pub static_windows: usize,
    /// Noise floor: RMS over the windows of what averaging can achieve, milli-g (`null` when
    /// the file gives no sample noise, e.g. one averaged row per pose).
    pub noise_floor_mg: Option<f64>,
    /// Batch-means noise floor (sees slow noise too), milli-g.
    pub noise_floor_batch_mg: Option<f64>,
    /// The base model.
    pub base: ModelSummary,
    /// Accepted effects, in the order added (empty: nothing is missing).
    pub effects: Vec<EffectReport>,
    /// The final model.
    #[serde(rename = "final")]
    pub final_model: ModelSummary,
    /// The greedy steps with every candidate tried.
    pub steps: Vec<StepReport>,
    /// One-paragraph conclusion.
    pub verdict: String,
    /// Time of the first sample, s: `Conditions::time_s` is measured from here.
    pub time_origin_s: f64,
    /// Correlation of window time and temperature (when there is a temperature column).
    pub time_temp_correlation: Option<f64>,
    /// Findings that pass the rules but cannot be stored in the calibration (e.g. a curved
    /// bias drift).
    pub diagnostics: Vec<String>,
    /// Final calibration (what `--out` writes).
    pub calibration: Calibration,
    /// The windows.
    pub windows: Vec<WindowInfo>,
    /// Six-position mode only.
    pub six_position: Option<SixPositionDetails>,
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
    /// Mean temperature.
    pub temp: Option<f64>,
}

impl WindowStats {
    /// Samples.
    pub fn n(&self) -> usize {
        self.end - self.start
    }
}

/// Detected windows and context.
pub struct Windows {
    /// The windows.
    pub stats: Vec<WindowStats>,
    /// Sample times (recording clock), s.
    pub times: Vec<f64>,
    /// Detected units.
    pub units: &'static str,
}

fn is_integer_data(rec: &Recording) -> bool {
    rec.xyz.iter().all(|s| s.iter().all(|v| v.fract() == 0.0))
}

/// Detects the static windows (the core's detector via [`fit_cmd::detect`]) and computes their
/// f64 statistics.
pub fn detect_windows(rec: &Recording, opts: &FitOptions) -> Result<Windows> {
    let integer = is_integer_data(rec);
    let rate = rec.estimated_rate_hz().unwrap_or(opts.default_rate_hz);
    let det = if integer {
        fit_cmd::detect(rec, opts)?
    } else {
        // Scale so that the init period's quietest axis has unit std: the detector's
        // quantisation floor (1/12) then sits well below the noise.
        let init = ((opts.init_s * rate) as usize).clamp(2, rec.len().max(2));
        let head = &rec.xyz[..init.min(rec.len())];
        let mut sd_min = f64::INFINITY;
        for a in 0..3 {
            let m = head.iter().map(|s| s[a]).sum::<f64>() / head.len().max(1) as f64;
            let v = head.iter().map(|s| (s[a] - m).powi(2)).sum::<f64>()
                / (head.len().max(2) - 1) as f64;
            sd_min = sd_min.min(v.sqrt());
        }
        let mut mags: Vec<f64> = rec
            .xyz
            .iter()
            .map(|s| (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt())
            .collect();
        let med = st::median(&mags);
        mags.clear();
        let k = if sd_min > 0.0 && sd_min.is_finite() {
            1.0 / sd_min
        } else {
            1e4 / med.max(1e-30)
        };
        let scaled = Recording {
            xyz: rec.xyz.iter().map(|s| s.map(|v| v * k)).collect(),
            t: rec.t.clone(),
            temp: None,
            labels: None,
            sample_rate_hz: rec.sample_rate_hz,
            axis_columns: rec.axis_columns.clone(),
            skipped_empty_rows: rec.skipped_empty_rows,
        };
        fit_cmd::detect(&scaled, opts)?
    };
    let range = opts.adc_range.or_else(|| fit_cmd::infer_adc_range(rec));
    fit_cmd::check_saturation(rec, &det.intervals, range)?;
    let t0 = det.times.first().copied().unwrap_or(0.0);
    let mut stats = Vec::with_capacity(det.intervals.len());
    for iv in &det.intervals {
        let (s, e) = (iv.start as usize, (iv.end as usize).min(rec.len()));
        if e <= s + 1 {
            continue;
        }
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
        for x in xs {
            for a in 0..3 {
                var[a] += (x[a] - mean[a]).powi(2);
            }
        }
        var = var.map(|v| {
            let v = v / (n - 1.0);
            if integer {
                v.max(1.0 / 12.0)
            } else {
                v
            }
        });
        const B: usize = 10;
        let batch_var_of_mean = (xs.len() >= 5 * B).then(|| {
            let len = xs.len() / B;
            let mut bm = [[0.0; 3]; B];
            for (b, m) in bm.iter_mut().enumerate() {
                for x in &xs[b * len..(b + 1) * len] {
                    for a in 0..3 {
                        m[a] += x[a] / len as f64;
                    }
                }
            }
            let mut out = [0.0; 3];
            for a in 0..3 {
                let mu = bm.iter().map(|m| m[a]).sum::<f64>() / B as f64;
                let v = bm.iter().map(|m| (m[a] - mu).powi(2)).sum::<f64>() / (B - 1) as f64;
                out[a] = v / B as f64;
            }
            out
        });
        let t_centre = det.times[s..e].iter().sum::<f64>() / n - t0;
        let temp = rec.temp.as_ref().map(|tc| tc[s..e].iter().sum::<f64>() / n);
        stats.push(WindowStats {
            start: s,
            end: e,
            mean,
            var,
            batch_var_of_mean,
            t_centre,
            temp,
        });
    }
    let norms: Vec<f64> = stats
        .iter()
        .map(|w| (w.mean[0].powi(2) + w.mean[1].powi(2) + w.mean[2].powi(2)).sqrt())
        .collect();
    let med = st::median(&norms);
    let units = if integer {
        "raw"
    } else if (0.8..1.25).contains(&med) {
        "g"
    } else if (7.8..12.3).contains(&med) {
        "m/s^2"
    } else {
        "raw"
    };
    Ok(Windows {
        stats,
        times: det.times,
        units,
    })
}

/// A parametric candidate: one or more effect blocks added together.
struct CandSpec {
    name: &'static str,
    terms: Vec<Term>,
    /// False for diagnostics the core's `Effects` cannot hold (never accepted).
    storable: bool,
}

/// Current state of the greedy search.
struct State {
    terms: Vec<Term>,
    used: Vec<bool>,
    fit: Fit,
    loo: Vec<Option<f64>>,
}

fn base_mask(model: MultiPosModel) -> Mask {
    let mut m = am::mask_of(&[]);
    if model == MultiPosModel::Diagonal {
        m[am::KMAT + 1] = false;
        m[am::KMAT + 2] = false;
        m[am::KMAT + 4] = false;
    }
    m
}

fn mask_for(model: MultiPosModel, terms: &[Term]) -> Mask {
    let mut m = am::mask_of(terms);
    m[..9].copy_from_slice(&base_mask(model)[..9]);
    m
}

/// RMS of the held-out residuals over the windows selected by `sel`, g.
fn cv_over(loo: &[Option<f64>], sel: &[bool]) -> Option<f64> {
    let v: Vec<f64> = loo
        .iter()
        .zip(sel)
        .filter(|(_, s)| **s)
        .map(|(e, _)| *e)
        .collect::<Option<Vec<f64>>>()?;
    (!v.is_empty()).then(|| st::rms(&v))
}

/// Per-window noise floor of the residual (g): var/n propagated through ∂r/∂m.
fn floors(p: &Params, wins: &[Win], stats: &[WindowStats], scale: f64, batch: bool) -> Vec<f64> {
    wins.iter()
        .zip(stats)
        .map(|(w, s)| {
            let (_, g) = am::residual_and_grad(p, w);
            let v = if batch {
                match s.batch_var_of_mean {
                    Some(v) => v,
                    None => return f64::NAN,
                }
            } else {
                s.var.map(|v| v / s.n() as f64)
            };
            // r depends on y = (m − c)/s exactly as on −b: ∂r/∂m = −∂r/∂b / s.
            (0..3)
                .map(|a| (g[am::BIAS + a] / scale).powi(2) * v[a])
                .sum::<f64>()
                .sqrt()
        })
        .collect()
}

fn chi2_summary(
    p: &Params,
    wins: &[Win],
    used: &[bool],
    floor: &[f64],
    k: usize,
) -> (Option<f64>, Option<usize>, Option<f64>) {
    let mut chi2 = 0.0;
    let mut n = 0usize;
    for ((w, u), f) in wins.iter().zip(used).zip(floor) {
        if !*u || !(*f > 0.0) {
            continue;
        }
        chi2 += (am::residual(p, w) / f).powi(2);
        n += 1;
    }
    if n <= k {
        return (None, None, None);
    }
    let dof = n - k;
    (Some(chi2), Some(dof), Some(st::chi2_sf(chi2, dof as f64)))
}

/// Paired comparison of two sets of held-out residuals on the common windows: returns the
/// two-sided p-value of a paired t-test on the squared errors.
fn paired_p(a: &[Option<f64>], b: &[Option<f64>], sel: &[bool]) -> Option<f64> {
    let d: Vec<f64> = a
        .iter()
        .zip(b)
        .zip(sel)
        .filter(|(_, s)| **s)
        .filter_map(|((x, y), _)| Some(x.as_ref()?.powi(2) - y.as_ref()?.powi(2)))
        .collect();
    if d.len() < 3 {
        return None;
    }
    let n = d.len() as f64;
    let m = d.iter().sum::<f64>() / n;
    let v = d.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    if v <= 0.0 {
        return Some(if m == 0.0 { 1.0 } else { 0.0 });
    }
    Some(st::t_two_sided(m / (v / n).sqrt(), n - 1.0))
}

struct TermTrial {
    name: &'static str,
    terms: Vec<Term>,
    storable: bool,
    passes_rules: bool,
    dp: usize,
    fit: Fit,
    loo: Vec<Option<f64>>,
    f: f64,
    p: f64,
    cv: f64,
}

struct OutlierTrial {
    rejected: Vec<usize>,
    p_values: Vec<f64>,
    f_stats: Vec<f64>,
    fit: Fit,
    loo: Vec<Option<f64>>,
    used: Vec<bool>,
}

/// Outlier screening and test under the current model.
///
/// 1. A robust refit (Tukey biweight, c = 4.685, scale = 1.4826·median |r|, iteratively
///    reweighted) finds the windows the bulk of the data disagrees with; those beyond 3 robust
///    scales are the suspects. (A plain least-squares screen fails here: a few windows that
///    were not still pull the fit towards themselves and inflate the scale, masking each other.)
/// 2. Each suspect is tested against the fit on the other windows: its prediction error
///    `e` has variance `σ²(1 + h)` (σ² from that fit, `h` the leverage), so
///    `t = e/(σ√(1 + h))` is Student-t; the two-sided p-value is multiplied by the number of
///    windows searched (Bonferroni) and compared with `level`. Suspects that fail are put
///    back and the test repeated until the rejected set is stable.
fn find_outliers(
    st_: &State,
    mask: &Mask,
    wins: &[Win],
    level: f64,
    max_reject: usize,
) -> Option<OutlierTrial> {
    let n_all = wins.len();
    let used0 = &st_.used;
    let n = used0.iter().filter(|u| **u).count();
    let k = st_.fit.k;
    if n < k + 4 {
        return None;
    }
    // 1. Robust screening.
    let mut p = st_.fit.p;
    let mut w: Vec<f64> = used0.iter().map(|u| if *u { 1.0 } else { 0.0 }).collect();
    let mut scale = 0.0;
    for _ in 0..50 {
        let r: Vec<f64> = (0..n_all)
            .filter(|i| used0[*i])
            .map(|i| am::residual(&p, &wins[i]).abs())
            .collect();
        scale = 1.4826 * st::median(&r);
        if !(scale > 0.0) {
            return None;
        }
        let c = 4.685 * scale;
        let new_w: Vec<f64> = (0..n_all)
            .map(|i| {
                if !used0[i] {
                    return 0.0;
                }
                let u = am::residual(&p, &wins[i]) / c;
                if u.abs() >= 1.0 {
                    0.0
                } else {
                    (1.0 - u * u).powi(2)
                }
            })
            .collect();
        if new_w.iter().filter(|x| **x > 0.0).count() < k + 2 {
            break;
        }
        let change = new_w
            .iter()
            .zip(&w)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        w = new_w;
        match am::fit_weighted(&p, mask, wins, &w) {
            Some(f) => p = f.p,
            None => break,
        }
        if change < 1e-6 {
            break;
        }
    }
    let mut suspects: Vec<(usize, f64)> = (0..n_all)
        .filter(|i| used0[*i])
        .map(|i| (i, am::residual(&p, &wins[i])))
        .filter(|(_, r)| r.abs() > 3.0 * scale)
        .collect();
    suspects.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
    suspects.truncate(max_reject);
    if suspects.is_empty() {
        return None;
    }
    // 2. Test each suspect against the fit on the others; iterate to a stable set.
    let mut rejected: Vec<usize> = suspects.iter().map(|s| s.0).collect();
    let mut result = None;
    for _ in 0..10 {
        let mut used = used0.clone();
        for &i in &rejected {
            used[i] = false;
        }
        let clean = am::fit(&p, mask, wins, &used)?;
        let dof = clean.n.saturating_sub(clean.k);
        if dof < 3 {
            return None;
        }
        let sigma2 = clean.rss / dof as f64;
        let mut keep = Vec::new();
        let mut pv = Vec::new();
        let mut ts = Vec::new();
        for &(i, _) in &suspects {
            // Suspects currently rejected are outside the fit; the others are tested by their
            // deletion residual (refit without them).
            let (e, h, s2) = if used[i] {
                let mut u2 = used.clone();
                u2[i] = false;
                let f2 = am::fit(&clean.p, mask, wins, &u2)?;
                let d2 = f2.n.saturating_sub(f2.k).max(1);
                (
                    am::residual(&f2.p, &wins[i]),
                    am::leverage(&f2.p, mask, wins, &u2, i)?,
                    f2.rss / d2 as f64,
                )
            } else {
                (
                    am::residual(&clean.p, &wins[i]),
                    am::leverage(&clean.p, mask, wins, &used, i)?,
                    sigma2,
                )
            };
            let t = e / (s2 * (1.0 + h)).max(1e-300).sqrt();
            let pval = (st::t_two_sided(t, dof as f64) * n as f64).min(1.0);
            if pval < level {
                keep.push(i);
                pv.push(pval);
                ts.push(t * t);
            }
        }
        let stable = {
            let mut a = keep.clone();
            let mut b = rejected.clone();
            a.sort_unstable();
            b.sort_unstable();
            a == b
        };
        if stable {
            result = Some((keep, pv, ts, clean, used));
            break;
        }
        if keep.is_empty() {
            return None;
        }
        rejected = keep;
    }
    let (rejected, p_values, f_stats, fit, used) = result?;
    if rejected.is_empty() {
        return None;
    }
    let loo = am::loo(&fit, mask, wins, &used)?;
    Some(OutlierTrial {
        rejected,
        p_values,
        f_stats,
        fit,
        loo,
        used,
    })
}

fn fmt_vec(v: &[f64; 3], prec: usize) -> String {
    format!("[{:.p$}, {:.p$}, {:.p$}]", v[0], v[1], v[2], p = prec)
}

fn fmt_p(p: f64) -> String {
    if p < 1e-15 {
        "< 1e-15".into()
    } else {
        format!("= {p:.1e}")
    }
}

/// Per-axis values of a term in reporting units: (values, std errors, unit).
fn term_values(
    t: Term,
    nrm: &Normalisation,
    p: &Params,
    se: &Params,
    duration: f64,
) -> ([f64; 3], [f64; 3], String) {
    let raw = nrm.raw(p);
    // Standard errors scale like the values (each is a fixed multiple of its parameter).
    let ratio = |v: f64, q: f64, s: f64| if q != 0.0 { (v / q * s).abs() } else { 0.0 };
    let o = t.offset();
    let k = raw.matrix;
    // Raw-unit bias terms are reported in mg via the diagonal of K (g per raw unit).
    let (vals, unit) = match t {
        Term::Quadratic => (raw.quadratic.map(|x| x * 1e3), "mg/g² (k2)".to_string()),
        Term::Cubic => (raw.cubic.map(|x| x * 1e3), "mg/g³ (k3)".to_string()),
        Term::Drift => (
            std::array::from_fn(|a| raw.drift[a] * k[a][a] * 1e3 * duration),
            format!("mg of bias change over {duration:.0} s"),
        ),
        Term::BiasTemp => (
            std::array::from_fn(|a| raw.bias_temp[a] * k[a][a] * 1e3),
            "mg/°C".to_string(),
        ),
        Term::ScaleTemp => (raw.scale_temp.map(|x| x * 1e6), "ppm/°C".to_string()),
        Term::Drift2 => (
            std::array::from_fn(|a| p[am::DRIFT2 + a] * nrm.scale * k[a][a] * 1e3),
            "mg of curvature (bias at the ends minus the middle, normalised time)".to_string(),
        ),
    };
    let ses = std::array::from_fn(|a| ratio(vals[a], p[o + a], se[o + a]));
    (vals, ses, unit)
}

/// Runs the analysis (see the module docs).
pub fn analyze(rec: &Recording, opts: &AnalyzeOptions) -> Result<AnalyzeReport> {
    if !(opts.alpha > 0.0 && opts.alpha < 1.0 && opts.cv_factor >= 1.0) {
        bail!("alpha must be in (0, 1) and the CV factor at least 1");
    }
    if let Some(c) = &opts.candidates {
        for n in c {
            if !CANDIDATE_NAMES.contains(&n.as_str()) {
                bail!(
                    "unknown candidate effect '{n}'; known: {}",
                    CANDIDATE_NAMES.join(", ")
                );
            }
        }
    }
    if rec.labels.is_some() {
        return crate::analyze_six::run(rec, opts);
    }
    let ws = detect_windows(rec, &opts.fit)?;
    let n = ws.stats.len();
    let model = opts.fit.model;
    let means32: Vec<[f32; 3]> = ws.stats.iter().map(|w| w.mean.map(|x| x as f32)).collect();
    let cfg = MultiPosConfig {
        model,
        ..Default::default()
    };
    let core_fit = multipos::fit(&means32, &cfg).map_err(|e| match e {
        wiical_core::Error::TooFewPoses { needed, got } => anyhow!(
            "found {got} static windows but the model needs at least {needed}: hold the sensor still in more orientations (or lower --min-static-s / raise --threshold)"
        ),
        wiical_core::Error::DegenerateGeometry => anyhow!(
            "the {n} static poses do not spread over enough orientations (e.g. all in one plane): turn the sensor so that each axis points up and down"
        ),
        other => anyhow!("multi-position fit failed: {other}"),
    })?;

    let means: Vec<[f64; 3]> = ws.stats.iter().map(|w| w.mean).collect();
    let times: Vec<f64> = ws.stats.iter().map(|w| w.t_centre).collect();
    let temps: Option<Vec<f64>> = ws.stats.iter().map(|w| w.temp).collect();
    let nrm = Normalisation::of(&means, &times, temps.as_deref());
    let wins: Vec<Win> = ws
        .stats
        .iter()
        .map(|w| nrm.window(&w.mean, w.t_centre, w.temp))
        .collect();
    let p0 = nrm.params_from(&core_fit.calibration);
    let bmask = base_mask(model);
    let all = vec![true; n];
    let base_fit = am::fit(&p0, &bmask, &wins, &all)
        .ok_or_else(|| anyhow!("the f64 refinement of the base fit failed (degenerate poses)"))?;
    let base_loo = am::loo(&base_fit, &bmask, &wins, &all);
    let floor = floors(&base_fit.p, &wins, &ws.stats, nrm.scale, false);
    let floor_batch = floors(&base_fit.p, &wins, &ws.stats, nrm.scale, true);
    let noise_floor = st::rms(&floor);
    let fb: Vec<f64> = floor_batch
        .iter()
        .copied()
        .filter(|x| x.is_finite())
        .collect();
    let noise_floor_batch = (!fb.is_empty()).then(|| st::rms(&fb));

    let duration =
        ws.times.last().copied().unwrap_or(0.0) - ws.times.first().copied().unwrap_or(0.0);
    let temp_info = temps.as_ref().map(|t| {
        let lo = t.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = t.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (hi - lo, st::correlation(&times, t))
    });
    let temp_range = temp_info.map_or(0.0, |x| x.0);
    let time_temp_r = temp_info.map(|x| x.1);

    let allowed = |name: &str| {
        opts.candidates
            .as_ref()
            .is_none_or(|c| c.iter().any(|x| x == name))
    };
    let mut state = State {
        terms: Vec::new(),
        used: all.clone(),
        fit: base_fit.clone(),
        loo: base_loo.clone().unwrap_or_else(|| vec![None; n]),
    };
    let mut effects: Vec<EffectReport> = Vec::new();
    let mut steps: Vec<StepReport> = Vec::new();
    let mut first_signature: Option<Vec<f64>> = None;
    let mut outliers_done = false;
    let mut diagnostics: Vec<String> = Vec::new();
    let cv_possible = base_loo.is_some();

    while cv_possible && effects.len() < opts.max_effects {
        let n_used = state.used.iter().filter(|u| **u).count();
        let mut specs: Vec<CandSpec> = Vec::new();
        for t in Term::ALL {
            if state.terms.contains(&t) || !allowed(t.name()) {
                continue;
            }
            if t.needs_temperature() && !(temp_range > 0.05) {
                continue;
            }
            if t == Term::Drift && !(duration > 0.0) {
                continue;
            }
            specs.push(CandSpec {
                name: t.name(),
                terms: vec![t],
                storable: true,
            });
        }
        if duration > 0.0 && allowed("bias-drift-curved") && !state.terms.contains(&Term::Drift2) {
            let terms = if state.terms.contains(&Term::Drift) {
                vec![Term::Drift2]
            } else {
                vec![Term::Drift, Term::Drift2]
            };
            specs.push(CandSpec {
                name: "bias-drift-curved",
                terms,
                storable: false,
            });
        }
        let try_outliers = !outliers_done && allowed("outliers");
        let m = specs.len() + usize::from(try_outliers);
        if m == 0 {
            break;
        }
        let level = opts.alpha / m as f64;
        let cur_cv_all = cv_over(&state.loo, &state.used);
        let mut reports = Vec::new();
        let mut term_trials: Vec<TermTrial> = Vec::new();
        for spec in &specs {
            let dp = 3 * spec.terms.len();
            let mut terms = state.terms.clone();
            terms.extend(spec.terms.iter().copied());
            let mask = mask_for(model, &terms);
            let k_new = mask.iter().filter(|x| **x).count();
            let mut rep = CandidateReport {
                name: spec.name.into(),
                params: dp,
                rms_mg: None,
                cv_rms_mg: None,
                cv_rms_current_mg: cur_cv_all.map(|x| x * 1e3),
                f_stat: None,
                p_value: None,
                passed: false,
                note: String::new(),
            };
            if n_used < k_new + 3 {
                rep.note = format!("too few windows ({n_used}) for {k_new} parameters");
                reports.push(rep);
                continue;
            }
            let Some(f) = am::fit(&state.fit.p, &mask, &wins, &state.used) else {
                rep.note = "not identifiable from these windows (singular fit)".into();
                reports.push(rep);
                continue;
            };
            rep.rms_mg = Some(f.rms() * 1e3);
            let dof = (n_used - k_new) as f64;
            let fstat = ((state.fit.rss - f.rss).max(0.0) / dp as f64) / (f.rss / dof).max(1e-300);
            let p = st::f_sf(fstat, dp as f64, dof);
            rep.f_stat = Some(fstat);
            rep.p_value = Some(p);
            let Some(loo) = am::loo(&f, &mask, &wins, &state.used) else {
                rep.note =
                    "cross-validation refit failed (a held-out window leaves it undetermined)"
                        .into();
                reports.push(rep);
                continue;
            };
            let cv = cv_over(&loo, &state.used).unwrap_or(f64::INFINITY);
            rep.cv_rms_mg = Some(cv * 1e3);
            let cv_ok = cur_cv_all.is_some_and(|c0| cv * opts.cv_factor <= c0);
            let sig = p < level;
            rep.passed = sig && cv_ok && spec.storable;
            rep.note = match (sig, cv_ok) {
                (true, true) if spec.storable => "passes".into(),
                (true, true) => {
                    "passes, but diagnostic only: the calibration cannot store a curved drift"
                        .into()
                }
                (false, true) => format!("F-test not significant at {level:.1e}"),
                (true, false) => format!("CV not improved by the factor {:.2}", opts.cv_factor),
                (false, false) => "neither significant nor better under CV".into(),
            };
            reports.push(rep);
            term_trials.push(TermTrial {
                name: spec.name,
                terms: spec.terms.clone(),
                storable: spec.storable,
                passes_rules: sig && cv_ok,
                fit: f,
                loo,
                f: fstat,
                p,
                cv,
                dp,
            });
        }
        let mut out_trial: Option<OutlierTrial> = None;
        if try_outliers {
            let max_reject = ((opts.max_outlier_fraction * n_used as f64).floor() as usize).max(1);
            let cur_mask = mask_for(model, &state.terms);
            let tr = find_outliers(&state, &cur_mask, &wins, level, max_reject);
            let mut rep = CandidateReport {
                name: "outliers".into(),
                params: 0,
                rms_mg: None,
                cv_rms_mg: None,
                cv_rms_current_mg: None,
                f_stat: None,
                p_value: None,
                passed: false,
                note: "no window stands out (robust screen + Bonferroni prediction-error test)"
                    .into(),
            };
            if let Some(tr) = tr {
                let cv_kept = cv_over(&tr.loo, &tr.used).unwrap_or(f64::INFINITY);
                let cur_kept = cv_over(&state.loo, &tr.used);
                rep.params = tr.rejected.len();
                rep.rms_mg = Some(tr.fit.rms() * 1e3);
                rep.cv_rms_mg = Some(cv_kept * 1e3);
                rep.cv_rms_current_mg = cur_kept.map(|x| x * 1e3);
                rep.f_stat = tr.f_stats.iter().copied().reduce(f64::min);
                rep.p_value = tr.p_values.iter().copied().reduce(f64::max);
                let cv_ok = cur_kept.is_some_and(|c0| cv_kept * opts.cv_factor <= c0);
                rep.passed = cv_ok;
                rep.note = format!(
                    "windows {} stand out{}",
                    tr.rejected
                        .iter()
                        .map(|i| (i + 1).to_string())
                        .collect::<Vec<_>>()
                        .join(", "),
                    if cv_ok {
                        String::new()
                    } else {
                        format!(
                            ", but rejecting them does not improve the CV of the others by {:.2}",
                            opts.cv_factor
                        )
                    }
                );
                out_trial = Some(tr);
            }
            reports.push(rep);
        }

        // Choose: the passing candidate with the lowest CV on a common window set.
        let best_term = term_trials
            .iter()
            .filter(|t| t.passes_rules && t.storable)
            .min_by(|a, b| a.cv.total_cmp(&b.cv));
        let out_pass = reports.iter().any(|r| r.name == "outliers" && r.passed);
        let choose_outliers = match (&out_trial, out_pass, best_term) {
            (Some(ot), true, Some(bt)) => {
                // Compare on the windows the outlier candidate keeps.
                let cv_t = cv_over(&bt.loo, &ot.used).unwrap_or(f64::INFINITY);
                let cv_o = cv_over(&ot.loo, &ot.used).unwrap_or(f64::INFINITY);
                cv_o < cv_t
            }
            (Some(_), true, None) => true,
            _ => false,
        };
        // A diagnostic-only candidate that beats everything storable is worth saying.
        let diag_best = term_trials
            .iter()
            .filter(|t| t.passes_rules && !t.storable)
            .min_by(|a, b| a.cv.total_cmp(&b.cv));
        if let Some(d) = diag_best {
            if best_term.is_none_or(|b| d.cv < b.cv) && !choose_outliers {
                diagnostics.push(format!(
                    "{} would pass (CV {:.3} → {:.3} mg, F({},{}) = {:.1}, p {}) but the core's Effects cannot store it",
                    d.name,
                    cur_cv_all.unwrap_or(f64::NAN) * 1e3,
                    d.cv * 1e3,
                    d.dp,
                    d.fit.n - d.fit.k,
                    d.f,
                    fmt_p(d.p)
                ));
            }
        }
        let mut step = StepReport {
            candidates: reports,
            level,
            accepted: None,
        };

        if choose_outliers {
            let Some(ot) = out_trial else { break };
            let cv_before = cv_over(&state.loo, &ot.used);
            let cv_after = cv_over(&ot.loo, &ot.used);
            let list: Vec<String> = ot
                .rejected
                .iter()
                .zip(&ot.p_values)
                .map(|(&i, p)| {
                    let w = &ws.stats[i];
                    format!(
                        "{} (t = {:.1}–{:.1} s, held-out residual {:+.2} mg, p {})",
                        i + 1,
                        ws.times[w.start],
                        ws.times[w.end - 1],
                        state.loo[i].unwrap_or(f64::NAN) * 1e3,
                        fmt_p(*p)
                    )
                })
                .collect();
            let smooth = best_term
                .map(|bt| {
                    format!(
                        "; the best smooth effect ({}) leaves CV {:.3} mg on the other windows against {:.3} mg with rejection",
                        bt.name,
                        cv_over(&bt.loo, &ot.used).unwrap_or(f64::NAN) * 1e3,
                        cv_after.unwrap_or(f64::NAN) * 1e3
                    )
                })
                .unwrap_or_else(|| "; no smooth effect explains them (none passes its test)".into());
            let evidence = format!(
                "{} window(s) sit far outside the held-out spread of the others (robust biweight screen, then a prediction-error t-test against the fit on the others, Bonferroni over windows): {}{}; CV of the kept windows {:.3} → {:.3} mg",
                ot.rejected.len(),
                list.join("; "),
                smooth,
                cv_before.unwrap_or(f64::NAN) * 1e3,
                cv_after.unwrap_or(f64::NAN) * 1e3,
            );
            if first_signature.is_none() {
                first_signature = Some(
                    (0..n)
                        .map(|i| {
                            if ot.rejected.contains(&i) {
                                am::residual(&state.fit.p, &wins[i]) * 1e3
                            } else {
                                0.0
                            }
                        })
                        .collect(),
                );
            }
            effects.push(EffectReport {
                name: "outliers".into(),
                params: ot.rejected.len(),
                rms_mg: ot.fit.rms() * 1e3,
                cv_rms_mg: cv_after.map(|x| x * 1e3),
                cv_rms_before_mg: cv_before.map(|x| x * 1e3),
                evidence,
                f_stat: ot.f_stats.iter().copied().reduce(f64::min),
                p_value: ot.p_values.iter().copied().reduce(f64::max),
                values: None,
                std_errors: None,
                unit: None,
                rejected_windows: Some(ot.rejected.iter().map(|i| i + 1).collect()),
            });
            step.accepted = Some("outliers".into());
            steps.push(step);
            state.used = ot.used;
            state.fit = ot.fit;
            state.loo = ot.loo;
            outliers_done = true;
            continue;
        }
        let Some(bt) = best_term else {
            steps.push(step);
            break;
        };
        let term = bt.terms[0];
        // Evidence: what the effect explains, and how it compares with the runner-up.
        let r_cur: Vec<f64> = (0..n)
            .filter(|i| state.used[*i])
            .map(|i| am::residual(&state.fit.p, &wins[i]))
            .collect();
        let r_new: Vec<f64> = (0..n)
            .filter(|i| state.used[*i])
            .map(|i| am::residual(&bt.fit.p, &wins[i]))
            .collect();
        let sig: Vec<f64> = r_cur.iter().zip(&r_new).map(|(a, b)| a - b).collect();
        let r_sig = st::correlation(&r_cur, &sig);
        let explained = 1.0 - bt.fit.rss / state.fit.rss.max(1e-300);
        let pattern = match term {
            Term::Quadratic => "residual follows the odd, cubic-in-direction pattern of a per-axis quadratic nonlinearity (k2·u²)",
            Term::Cubic => "residual follows the even, 4th-order-in-direction pattern of a per-axis cubic nonlinearity (k3·u³)",
            Term::Drift | Term::Drift2 => "residual correlates with window time (bias moving along a fixed direction)",
            Term::BiasTemp => "residual correlates with window temperature (bias moving along a fixed direction)",
            Term::ScaleTemp => "residual correlates with window temperature through the scale factors",
        };
        let mut new_terms = state.terms.clone();
        new_terms.extend(bt.terms.iter().copied());
        let mask = mask_for(model, &new_terms);
        let se = am::standard_errors(&bt.fit, &mask, &wins, &state.used);
        let (vals, ses, unit) = term_values(term, &nrm, &bt.fit.p, &se, duration);
        let mut evidence = format!(
            "{pattern}: r = {r_sig:.2}, explains {:.0}% of the residual variance; CV {:.3} → {:.3} mg, F({},{}) = {:.1}, p {}; fitted {} ± {} {unit}",
            100.0 * explained,
            cur_cv_all.unwrap_or(f64::NAN) * 1e3,
            bt.cv * 1e3,
            bt.dp,
            bt.fit.n - bt.fit.k,
            bt.f,
            fmt_p(bt.p),
            fmt_vec(&vals, 3),
            fmt_vec(&ses, 3),
        );
        // Head to head with the runner-up: the best other candidate that also passes, else
        // the best other one by CV; and always time against temperature when one of them won.
        let time_like = |t: &[Term]| t.iter().any(|x| matches!(x, Term::Drift | Term::Drift2));
        let temp_like = |t: &[Term]| {
            t.iter()
                .any(|x| matches!(x, Term::BiasTemp | Term::ScaleTemp))
        };
        let others = || term_trials.iter().filter(|t| t.name != bt.name);
        let runner = others()
            .filter(|t| t.passes_rules && t.storable)
            .min_by(|a, b| a.cv.total_cmp(&b.cv))
            .or_else(|| others().min_by(|a, b| a.cv.total_cmp(&b.cv)));
        let counterpart = if time_like(&bt.terms) {
            others().find(|t| t.terms == [Term::BiasTemp])
        } else if temp_like(&bt.terms) {
            others().find(|t| t.terms == [Term::Drift])
        } else {
            None
        };
        let mut compared: Vec<&TermTrial> = runner.into_iter().collect();
        if let Some(c) = counterpart {
            if !compared.iter().any(|t| t.name == c.name) {
                compared.push(c);
            }
        }
        let mut said_corr = false;
        for (k, ru) in compared.iter().enumerate() {
            let pp = paired_p(&bt.loo, &ru.loo, &state.used);
            let _ = write!(
                evidence,
                "; {} {}: CV {:.3} mg (paired test on held-out errors p {})",
                if k == 0 { "runner-up" } else { "against" },
                ru.name,
                ru.cv * 1e3,
                pp.map_or("n/a".into(), fmt_p)
            );
            let related = (time_like(&bt.terms) && temp_like(&ru.terms))
                || (temp_like(&bt.terms) && time_like(&ru.terms));
            if related && !said_corr {
                if let Some(r) = time_temp_r {
                    let _ = write!(
                        evidence,
                        "; window time and temperature correlate r = {r:.2}"
                    );
                    said_corr = true;
                }
            }
            if ru.passes_rules && pp.is_some_and(|p| p > 0.05) {
                let _ = write!(
                    evidence,
                    "; {} and {} are NOT separable by these data (both pass; their held-out errors do not differ significantly): chose {} by its lower CV",
                    bt.name, ru.name, bt.name
                );
            }
        }
        if first_signature.is_none() {
            first_signature = Some(
                (0..n)
                    .map(|i| {
                        (am::residual(&state.fit.p, &wins[i]) - am::residual(&bt.fit.p, &wins[i]))
                            * 1e3
                    })
                    .collect(),
            );
        }
        effects.push(EffectReport {
            name: bt.name.into(),
            params: bt.dp,
            rms_mg: bt.fit.rms() * 1e3,
            cv_rms_mg: Some(bt.cv * 1e3),
            cv_rms_before_mg: cur_cv_all.map(|x| x * 1e3),
            evidence,
            f_stat: Some(bt.f),
            p_value: Some(bt.p),
            values: Some(vals),
            std_errors: Some(ses),
            unit: Some(unit),
            rejected_windows: None,
        });
        step.accepted = Some(bt.name.into());
        steps.push(step);
        state.terms = new_terms;
        state.fit = bt.fit.clone();
        state.loo = bt.loo.clone();
    }

    // Summaries.
    let final_mask = mask_for(model, &state.terms);
    let k_base = bmask.iter().filter(|x| **x).count();
    let k_final =
        final_mask.iter().filter(|x| **x).count() + state.used.iter().filter(|u| !**u).count();
    let (c2b, dofb, pb) = chi2_summary(&base_fit.p, &wins, &all, &floor, k_base);
    let (c2f, doff, pf) = chi2_summary(
        &state.fit.p,
        &wins,
        &state.used,
        &floor,
        final_mask.iter().filter(|x| **x).count(),
    );
    let base = ModelSummary {
        params: k_base,
        rms_mg: base_fit.rms() * 1e3,
        cv_rms_mg: base_loo
            .as_ref()
            .and_then(|l| cv_over(l, &all))
            .map(|x| x * 1e3),
        windows_used: n,
        chi2: c2b,
        chi2_dof: dofb,
        chi2_p: pb,
    };
    let final_model = ModelSummary {
        params: k_final,
        rms_mg: state.fit.rms() * 1e3,
        cv_rms_mg: if cv_possible {
            cv_over(&state.loo, &state.used).map(|x| x * 1e3)
        } else {
            None
        },
        windows_used: state.used.iter().filter(|u| **u).count(),
        chi2: c2f,
        chi2_dof: doff,
        chi2_p: pf,
    };
    let calibration = nrm.to_calibration(&state.fit.p);
    calibration
        .validate()
        .map_err(|e| anyhow!("the final calibration is not valid: {e}"))?;
    let t0 = ws.times.first().copied().unwrap_or(0.0);
    let windows: Vec<WindowInfo> = ws
        .stats
        .iter()
        .enumerate()
        .map(|(i, w)| WindowInfo {
            index: i + 1,
            t_start: ws.times[w.start],
            t_end: ws.times[w.end - 1],
            t_centre: w.t_centre,
            samples: w.n(),
            temp: w.temp,
            mean: w.mean,
            residual_base_mg: am::residual(&base_fit.p, &wins[i]) * 1e3,
            residual_final_mg: am::residual(&state.fit.p, &wins[i]) * 1e3,
            cv_base_mg: base_loo.as_ref().and_then(|l| l[i]).map(|x| x * 1e3),
            cv_final_mg: state.loo.get(i).copied().flatten().map(|x| x * 1e3),
            floor_mg: floor[i] * 1e3,
            rejected: !state.used[i],
            signature_mg: first_signature.as_ref().map(|s| s[i]),
        })
        .collect();
    let mut verdict = verdict_text(
        &base,
        &final_model,
        &effects,
        noise_floor * 1e3,
        noise_floor_batch.map(|x| x * 1e3),
        opts.alpha,
        cv_possible,
    );
    for d in &diagnostics {
        let _ = write!(verdict, " Diagnostic: {d}.");
    }
    Ok(AnalyzeReport {
        mode: "multi-position",
        units: ws.units,
        samples: rec.len(),
        static_windows: n,
        noise_floor_mg: Some(noise_floor * 1e3),
        noise_floor_batch_mg: noise_floor_batch.map(|x| x * 1e3),
        base,
        effects,
        final_model,
        steps,
        verdict,
        time_origin_s: t0,
        time_temp_correlation: time_temp_r,
        diagnostics,
        calibration,
        windows,
        six_position: None,
    })
}

fn verdict_text(
    base: &ModelSummary,
    fin: &ModelSummary,
    effects: &[EffectReport],
    floor_mg: f64,
    batch_mg: Option<f64>,
    alpha: f64,
    cv_possible: bool,
) -> String {
    let mut s = String::new();
    let above = base.chi2_p.is_some_and(|p| p < alpha);
    let _ = write!(
        s,
        "Base model: RMS {:.3} mg (CV {}) against a noise floor of {:.3} mg{}: ",
        base.rms_mg,
        base.cv_rms_mg
            .map_or("n/a".into(), |x| format!("{x:.3} mg")),
        floor_mg,
        batch_mg.map_or(String::new(), |b| format!(" ({b:.3} mg from batch means)"))
    );
    let _ = write!(
        s,
        "{}. ",
        if above {
            format!(
                "the residual is above the floor (χ² = {:.0} on {} dof, p {})",
                base.chi2.unwrap_or(f64::NAN),
                base.chi2_dof.unwrap_or(0),
                fmt_p(base.chi2_p.unwrap_or(f64::NAN))
            )
        } else {
            format!(
                "the residual is consistent with the floor (χ² = {:.1} on {} dof, p {})",
                base.chi2.unwrap_or(f64::NAN),
                base.chi2_dof.unwrap_or(0),
                fmt_p(base.chi2_p.unwrap_or(f64::NAN))
            )
        }
    );
    if !cv_possible {
        s.push_str("Cross-validation is not possible with these windows (a held-out window leaves the model undetermined), so no effect was tested.");
        return s;
    }
    if effects.is_empty() {
        s.push_str("No candidate effect passes both the F-test and the cross-validation rule: nothing the candidates describe is missing.");
        if above {
            s.push_str(" The excess over the floor is not explained by any candidate (slow noise, imperfect stillness, or an effect outside the library).");
        }
    } else {
        let names: Vec<&str> = effects.iter().map(|e| e.name.as_str()).collect();
        let _ = write!(
            s,
            "Added {}: RMS {:.3} → {:.3} mg, CV {} → {} mg (×{:.1} lower).",
            names.join(" + "),
            base.rms_mg,
            fin.rms_mg,
            base.cv_rms_mg.map_or("n/a".into(), |x| format!("{x:.3}")),
            fin.cv_rms_mg.map_or("n/a".into(), |x| format!("{x:.3}")),
            match (base.cv_rms_mg, fin.cv_rms_mg) {
                (Some(a), Some(b)) if b > 0.0 => a / b,
                _ => f64::NAN,
            }
        );
        if let Some(p) = fin.chi2_p {
            if p < alpha {
                s.push_str(" The final residual is still above the floor.");
            } else {
                s.push_str(" The final residual is consistent with the noise floor.");
            }
        }
    }
    s
}

/// Human-readable report.
pub fn render_text(rep: &AnalyzeReport, file: &str) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "Residual analysis of {file} ({} samples, {} mode, units {}): {} static windows",
        rep.samples, rep.mode, rep.units, rep.static_windows
    );
    if let Some(six) = &rep.six_position {
        o.push_str(&crate::analyze_six::render(six));
    } else {
        let _ = writeln!(
            o,
            "\n  #   t_start    t_end  samples  temp°C   base(mg)  final(mg)  floor(mg)"
        );
        for w in &rep.windows {
            let _ = writeln!(
                o,
                "{:>3} {:>9.2} {:>8.2} {:>8} {:>7} {:>10.3} {:>10.3} {:>10.3}{}",
                w.index,
                w.t_start,
                w.t_end,
                w.samples,
                w.temp.map_or("-".into(), |t| format!("{t:.2}")),
                w.residual_base_mg,
                w.residual_final_mg,
                w.floor_mg,
                if w.rejected { "  rejected" } else { "" }
            );
        }
    }
    let line = |name: &str, m: &ModelSummary| {
        format!(
            "{name:<6} params {:>3}  RMS {:>9.4} mg  CV {:>10}  windows {:>3}  χ²/dof {}",
            m.params,
            m.rms_mg,
            m.cv_rms_mg.map_or("n/a".into(), |x| format!("{x:.4} mg")),
            m.windows_used,
            match (m.chi2, m.chi2_dof) {
                (Some(c), Some(d)) => format!(
                    "{:.2} (p {})",
                    c / d.max(1) as f64,
                    fmt_p(m.chi2_p.unwrap_or(f64::NAN))
                ),
                _ => "n/a".into(),
            }
        )
    };
    let _ = writeln!(
        o,
        "\nnoise floor {} mg{}",
        rep.noise_floor_mg
            .map_or("n/a".into(), |x| format!("{x:.4}")),
        rep.noise_floor_batch_mg
            .map_or(String::new(), |x| format!(" (batch means {x:.4} mg)"))
    );
    let _ = writeln!(o, "{}", line("base", &rep.base));
    let _ = writeln!(o, "{}", line("final", &rep.final_model));
    if !rep.steps.is_empty() {
        let _ = writeln!(o, "\nCandidates per step (level = α / candidates):");
        for (k, s) in rep.steps.iter().enumerate() {
            let _ = writeln!(
                o,
                "  step {} (level {:.1e}) → {}",
                k + 1,
                s.level,
                s.accepted.as_deref().unwrap_or("none accepted")
            );
            for c in &s.candidates {
                let _ = writeln!(
                    o,
                    "    {:<18} CV {:>10} (current {:>10})  F {:>8}  p {:>9}  {}",
                    c.name,
                    c.cv_rms_mg.map_or("-".into(), |x| format!("{x:.4}")),
                    c.cv_rms_current_mg
                        .map_or("-".into(), |x| format!("{x:.4}")),
                    c.f_stat.map_or("-".into(), |x| format!("{x:.2}")),
                    c.p_value.map_or("-".into(), |x| format!("{x:.1e}")),
                    c.note
                );
            }
        }
    }
    if rep.effects.is_empty() {
        let _ = writeln!(o, "\nEffects added: none");
    } else {
        let _ = writeln!(o, "\nEffects added:");
        for e in &rep.effects {
            let _ = writeln!(
                o,
                "  {} (+{} params): CV {} mg\n    {}",
                e.name,
                e.params,
                e.cv_rms_mg.map_or("n/a".into(), |x| format!("{x:.4}")),
                e.evidence
            );
        }
    }
    let _ = writeln!(o, "\n{}", rep.verdict);
    o
}
