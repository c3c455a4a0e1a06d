//! The JSON contract of `wiical gyrofit --json`: today's keys (`static_windows`, `motions`,
//! `bias`, `matrix`, `rms_deg_before`, `rms_deg_after`, `cv_rms_deg`, …) and the loop's, in the
//! shape of `analyze`'s (`noise_floor_*`, `base`, `effects`, `final`, `steps` with
//! `candidates`, `verdict`, `diagnostics`). The window models' numbers are in °/s (the gyro's
//! window means through the calibration), the motions' in degrees.

use super::models::{GyroModelRow, MotionRow};
use serde::Serialize;

/// A window model: the bias alone (`base`) or with the accepted effects (`final`).
#[derive(Debug, Clone, Serialize)]
pub struct GyroSummary {
    /// Parameters (3 for the bias, + 3 per regressor of each effect).
    pub params: usize,
    /// In-sample RMS of the window means about the model, °/s.
    pub rms_dps: f64,
    /// Leave-one-window-out RMS, °/s.
    pub cv_rms_dps: Option<f64>,
    /// Windows used.
    pub windows_used: usize,
    /// χ² of the residuals against the windows' noise floor.
    pub chi2: Option<f64>,
    /// Its degrees of freedom.
    pub chi2_dof: Option<usize>,
    /// P(χ² this large | only noise).
    pub chi2_p: Option<f64>,
}

/// One accepted effect.
#[derive(Debug, Clone, Serialize)]
pub struct GyroEffect {
    /// `g-sensitivity`, `bias-drift`, `temperature`.
    pub name: String,
    /// Parameters it adds.
    pub params: usize,
    /// Unit of `values`.
    pub unit: String,
    /// Fitted values, row-major per gyro axis (g-sensitivity: `G[axis][gravity component]`).
    pub values: Vec<f64>,
    /// Their standard errors.
    pub std_errors: Vec<f64>,
    /// Which pattern pointed to it, and the test results.
    pub evidence: String,
    /// F statistic.
    pub f_stat: Option<f64>,
    /// Its p-value (before the factor over candidates).
    pub p_value: Option<f64>,
    /// In-sample window RMS before adding it, °/s.
    pub rms_before_dps: f64,
    /// After, °/s.
    pub rms_dps: f64,
    /// Held-out window RMS before, °/s.
    pub cv_rms_before_dps: Option<f64>,
    /// After, °/s.
    pub cv_rms_dps: Option<f64>,
}

/// One candidate at one step.
#[derive(Debug, Clone, Serialize)]
pub struct GyroCandidate {
    /// Effect name.
    pub name: String,
    /// Parameters it would add.
    pub params: usize,
    /// Unit of its coefficients and of `detection_limit`.
    pub unit: String,
    /// In-sample window RMS with it, °/s.
    pub rms_dps: Option<f64>,
    /// Held-out window RMS with it, °/s.
    pub cv_rms_dps: Option<f64>,
    /// Held-out window RMS of the current model, °/s.
    pub cv_rms_current_dps: Option<f64>,
    /// F statistic.
    pub f_stat: Option<f64>,
    /// p-value (before the factor over candidates).
    pub p_value: Option<f64>,
    /// Passed both rules.
    pub passed: bool,
    /// Why not, or what it found.
    pub note: String,
    /// Not accepted: the smallest coefficient this recording would have shown at the step's
    /// level (80 % power), in `unit`; `null` when accepted or untestable.
    pub detection_limit: Option<f64>,
}

/// One greedy step.
#[derive(Debug, Clone, Serialize)]
pub struct GyroStep {
    /// Candidates tried.
    pub candidates: Vec<GyroCandidate>,
    /// Level each candidate was held to (α / candidates).
    pub level: f64,
    /// The one accepted, if any.
    pub accepted: Option<String>,
}

/// A motion model: the chosen calibration (refitted) with the motion effects so far.
#[derive(Debug, Clone, Serialize)]
pub struct MotionSummary {
    /// Parameters (the chosen model's free ones + the effects').
    pub params: usize,
    /// In-sample RMS angle error over the motions, degrees.
    pub rms_deg: f64,
    /// Leave-one-motion-out RMS angle error, degrees.
    pub cv_rms_deg: f64,
    /// Motions used.
    pub motions_used: usize,
    /// χ² of the residuals against the motions' noise floor (two axes per motion).
    pub chi2: f64,
    /// Its degrees of freedom.
    pub chi2_dof: usize,
    /// P(χ² this large | only noise).
    pub chi2_p: f64,
}

/// One accepted motion effect.
#[derive(Debug, Clone, Serialize)]
pub struct MotionEffect {
    /// `scale-asymmetry`, `scale-nonlinearity`, `time-offset`.
    pub name: String,
    /// Coefficients it adds.
    pub params: usize,
    /// Unit of `values` (`%`, `% at 100 °/s`, `s`).
    pub unit: String,
    /// Fitted values (per gyro axis x, y, z; one for the time offset).
    pub values: Vec<f64>,
    /// Their standard errors.
    pub std_errors: Vec<f64>,
    /// Which pattern pointed to it, and the test results.
    pub evidence: String,
    /// F statistic.
    pub f_stat: f64,
    /// Its p-value (before the factor over candidates).
    pub p_value: f64,
    /// In-sample RMS angle error before adding it, degrees.
    pub rms_before_deg: f64,
    /// After, degrees.
    pub rms_deg: f64,
    /// Held-out RMS angle error before, degrees.
    pub cv_rms_before_deg: f64,
    /// After, degrees.
    pub cv_rms_deg: f64,
}

/// One motion candidate at one step.
#[derive(Debug, Clone, Serialize)]
pub struct MotionCandidate {
    /// Effect name.
    pub name: String,
    /// Coefficients it would add.
    pub params: usize,
    /// Unit of its coefficients and of `detection_limit`.
    pub unit: String,
    /// In-sample RMS angle error with it, degrees.
    pub rms_deg: Option<f64>,
    /// Held-out RMS angle error with it, degrees.
    pub cv_rms_deg: Option<f64>,
    /// Held-out RMS angle error of the current model, degrees.
    pub cv_rms_current_deg: f64,
    /// F statistic.
    pub f_stat: Option<f64>,
    /// p-value (before the factor over candidates).
    pub p_value: Option<f64>,
    /// Passed both rules.
    pub passed: bool,
    /// Why not, or what it found.
    pub note: String,
    /// Not accepted: the smallest coefficient this recording would have shown at the step's
    /// level (80 % power), in `unit`; `null` when accepted or untestable.
    pub detection_limit: Option<f64>,
}

/// One greedy step over the motion candidates.
#[derive(Debug, Clone, Serialize)]
pub struct MotionStep {
    /// Candidates tried.
    pub candidates: Vec<MotionCandidate>,
    /// Level each candidate was held to (α / candidates).
    pub level: f64,
    /// The one accepted, if any.
    pub accepted: Option<String>,
}

/// The motions' part of the loop: the accepted window effects applied to the rates, then the
/// motion candidates by the same F + CV rule.
#[derive(Debug, Clone, Serialize)]
pub struct MotionLoop {
    /// The window effects applied to the motions' rates before the search (their deviations
    /// from their mean over the windows: the constant stays the calibration's bias).
    pub window_effects_applied: Vec<String>,
    /// The chosen calibration refitted on the rates with them.
    pub base: MotionSummary,
    /// Accepted motion effects, in the order added.
    pub effects: Vec<MotionEffect>,
    /// The motion model with them.
    #[serde(rename = "final")]
    pub final_model: MotionSummary,
    /// The greedy steps with every candidate.
    pub steps: Vec<MotionStep>,
    /// The motions' open basis after the named motion effects (generic terms of the rate:
    /// products of two rates, another axis's `|ω|`, per gyro axis); `null` when the motions
    /// are too few to fit it.
    pub open_basis: Option<OpenBasis>,
}

/// The verdict's class.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum GyroQuality {
    /// The held-out error agrees with the noise floor.
    Good,
    /// Above the floor, but none of the reasons that make it unusable.
    UnexplainedResidual,
    /// Do not use: see `reasons`.
    NotUsable,
}

/// The result (the JSON contract of `wiical gyrofit --json`).
#[derive(Debug, Clone, Serialize)]
pub struct GyroReport {
    /// Static windows found on the accelerometer.
    pub static_windows: usize,
    /// Motions between consecutive windows.
    pub motions: usize,
    /// Gyro bias of the chosen calibration, raw counts.
    pub bias: [f64; 3],
    /// `K` of the chosen calibration, raw → rad/s (`ω = K·(m − b)`), row-major.
    pub matrix: [[f64; 3]; 3],
    /// RMS angle error of the uncalibrated gyro over the motions, degrees.
    pub rms_deg_before: f64,
    /// In-sample RMS angle error of the chosen model, degrees.
    pub rms_deg_after: f64,
    /// Leave-one-motion-out RMS angle error of the chosen model, degrees.
    pub cv_rms_deg: f64,
    /// How the held-out angles were found: `"one-step"` (one Gauss–Newton step from the
    /// all-motion fit, then the held-out motion integrated exactly) or `"exact"` (a refit per
    /// motion, `--exact-held-out`).
    pub held_out_method: &'static str,
    /// The chosen model.
    pub model: &'static str,
    /// Every candidate.
    pub models: Vec<GyroModelRow>,
    /// Per motion, with the chosen model.
    pub motion_table: Vec<MotionRow>,
    /// Sample rate used, Hz.
    pub sample_rate_hz: f64,
    /// Nominal sensitivity, rad/s per count.
    pub nominal_rad_per_count: [f64; 3],
    /// Where the nominal came from: a flag (`--scale`, `--counts-per-dps`) or the gyro
    /// columns' unit (`deg/s` in `gyro_x_dps`: 1 count = 1 °/s).
    pub nominal_source: String,
    /// Bias from the first static window, raw counts.
    pub bias_from_rest: [f64; 3],
    /// Remarks on the choice (e.g. that the full model generalises worse than none).
    pub notes: Vec<String>,
    /// Noise floor of the motions' angle error: RMS over the motions of what the gyro's noise
    /// at rest and the accelerometer's tilt noise leave under a right calibration, degrees.
    pub noise_floor_deg: f64,
    /// The gyro's per-sample noise at rest through the calibration, °/s RMS.
    pub noise_floor_rate_dps: f64,
    /// RMS over the windows of the noise of the gyro's window mean, °/s (the floor of the
    /// window models).
    pub noise_floor_window_dps: f64,
    /// The window model with the bias alone.
    pub base: GyroSummary,
    /// Accepted effects, in the order added.
    pub effects: Vec<GyroEffect>,
    /// The window model with the effects.
    #[serde(rename = "final")]
    pub final_model: GyroSummary,
    /// The greedy steps with every candidate.
    pub steps: Vec<GyroStep>,
    /// `good`, `unexplained-residual` or `not-usable`.
    pub quality: GyroQuality,
    /// Why not usable (empty otherwise).
    pub reasons: Vec<String>,
    /// One-paragraph conclusion.
    pub verdict: String,
    /// Findings worth a sentence that are not effects (untested candidates, limits).
    pub diagnostics: Vec<String>,
    /// The chosen calibration with the accepted g-sensitivity, as a device applies it
    /// (`device::correction`); what `gyrofit --out` saves. Not in the JSON report
    /// (`bias`, `matrix` and `effects` are).
    #[serde(skip)]
    pub correction: wiical_core::gyro_correct::GyroCorrection<f64>,
    /// The motions' candidates (scale asymmetry, nonlinearity, time offset) after the window
    /// effects; `null` when the motions' model could not be fitted.
    pub motion_loop: Option<MotionLoop>,
    /// The static windows' open basis after the named window effects (generic terms: the
    /// gravity direction's quadratic monomials, time², temperature², per gyro axis); `null`
    /// when the windows are too few to fit it.
    pub open_basis: Option<OpenBasis>,
}

impl GyroReport {
    /// The gyro calibration file of this report (what `gyrofit --out` writes): the chosen
    /// model, its correction with the accepted g-sensitivity, its held-out error.
    pub fn cal_file(&self) -> crate::output::gyrocal::GyroCalFile {
        crate::output::gyrocal::GyroCalFile {
            model: self.model.to_string(),
            correction: self.correction,
            cv_rms_deg: self.cv_rms_deg,
        }
    }
}

/// One term of an open basis at one round.
#[derive(Debug, Clone, Serialize)]
pub struct BasisRow {
    /// The term, e.g. `g_x·g_z on y` (form, then the gyro axis it acts on).
    pub name: String,
    /// Its family, e.g. `gravity-quadratic`.
    pub family: String,
    /// Unit of its coefficient and of `detection_limit`.
    pub unit: String,
    /// F statistic of adding it (1 coefficient) to the current model.
    pub f_stat: f64,
    /// Its p-value (before the factor over the basis).
    pub p_value: f64,
    /// Held-out RMS with it (°/s for the windows, degrees for the motions).
    pub cv_rms: f64,
    /// Passed both rules at this round.
    pub passed: bool,
    /// Not accepted: the smallest coefficient this recording would have shown at the round's
    /// level (80 % power), in `unit`.
    pub detection_limit: Option<f64>,
}

/// One accepted term of an open basis.
#[derive(Debug, Clone, Serialize)]
pub struct BasisEffect {
    /// The term, e.g. `g_x·g_z on y`.
    pub name: String,
    /// Its family.
    pub family: String,
    /// Unit of `value`.
    pub unit: String,
    /// Fitted coefficient.
    pub value: f64,
    /// Its standard error.
    pub std_error: f64,
    /// "something of the form …", with the test results.
    pub evidence: String,
    /// F statistic.
    pub f_stat: f64,
    /// Its p-value (before the factor over the basis).
    pub p_value: f64,
    /// Held-out RMS before adding it (°/s for the windows, degrees for the motions).
    pub cv_rms_before: f64,
    /// After.
    pub cv_rms: f64,
}

/// One round of an open basis.
#[derive(Debug, Clone, Serialize)]
pub struct BasisStep {
    /// Terms tested (those not already in the model's span): the Bonferroni factor.
    pub screened: usize,
    /// Level each term was held to (α / screened).
    pub level: f64,
    /// The one accepted, if any.
    pub accepted: Option<String>,
    /// Every term tested.
    pub candidates: Vec<BasisRow>,
}

/// The largest detection limit of a family over its terms not accepted (every gyro axis).
#[derive(Debug, Clone, Serialize)]
pub struct FamilyLimit {
    /// Family, e.g. `gravity-quadratic`.
    pub family: String,
    /// Its forms in words, e.g. `g_i·g_j`.
    pub form: String,
    /// Unit.
    pub unit: String,
    /// The largest limit over the family's terms at the last round.
    pub detection_limit: f64,
}

/// An open basis: generic low-order terms beyond the named candidates, each one coefficient on
/// one gyro axis, tried by the same F + CV rule with a Bonferroni factor over the basis.
#[derive(Debug, Clone, Serialize)]
pub struct OpenBasis {
    /// The families in the basis.
    pub families: Vec<String>,
    /// Terms in the basis.
    pub terms: usize,
    /// Held-out RMS of the named model it starts from (°/s for the windows, degrees for the
    /// motions).
    pub cv_rms_start: f64,
    /// With the terms accepted.
    pub cv_rms_final: f64,
    /// Accepted terms, in order.
    pub found: Vec<BasisEffect>,
    /// The rounds.
    pub steps: Vec<BasisStep>,
    /// Per family, the largest limit of its terms at the last round.
    pub limits: Vec<FamilyLimit>,
    /// One sentence: what was found ("something of the form g_x·g_z on the gyro's y axis") or
    /// each family's limit.
    pub summary: String,
}
