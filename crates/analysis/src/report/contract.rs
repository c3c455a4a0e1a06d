//! The report types: the JSON contract of `wiical analyze` (keys `static_windows`,
//! `noise_floor_mg`, `base`, `effects`, `final`, …; renaming a field breaks users' scripts).

use serde::Serialize;
use wiical_core::Calibration;

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
    /// For a `thermal-lag` term: the held-out RMS with its axis's lag term at every time
    /// constant of the grid instead (each refitted on the model before it), ordered by τ;
    /// absent from the JSON for every other effect.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cv_profile: Option<Vec<CvPoint>>,
}

/// One point of a thermal-lag term's cross-validation profile over its time constant.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CvPoint {
    /// First-order lag time constant τ, s.
    pub time_constant_s: f64,
    /// Leave-one-window-out RMS of ‖a‖ − 1 g with the lag term at this τ, milli-g (`null`
    /// when the fit or its cross-validation failed).
    pub cv_rms_mg: Option<f64>,
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
    /// Windows short of what the candidate needs to be tested at all (`None`: it was
    /// tested). Not in the JSON (the note says it); the verdict lists the untested.
    #[serde(skip)]
    pub windows_short: Option<usize>,
    /// For a candidate that did not pass: the smallest size this recording would have shown
    /// at the step's level in 80 % of cases, in `detection_unit` ([`crate::search::limits`]);
    /// `null` when it passed, could not be tested, or (outliers) some window stood out.
    pub detection_limit: Option<f64>,
    /// What `detection_limit` measures: the effect's coefficient unit (`mg/g² (k2)`,
    /// `mg/°C`, …; worst axis), `mg RMS added to ‖a‖ − 1 beyond the current model` for
    /// several effects at once, one window's `‖a‖ − 1` offset in mg for outliers; `null`
    /// without a limit.
    pub detection_unit: Option<String>,
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
    /// Samples (`null` for a window-mean table without a count column).
    pub samples: Option<usize>,
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
    /// Accepted effects, in the order added (empty: none passed the rule).
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
    /// The open basis's accepted time and temperature terms, which the core calibration has
    /// no field for (`--out` writes them as the file's `host_terms`, schema
    /// `wiical-calibration/3`; the terms in `crate::report::host_term`); absent when there are none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub host_terms: Vec<crate::report::host_term::HostTerm>,
    /// The windows.
    pub windows: Vec<WindowInfo>,
    /// Six-position mode only.
    pub six_position: Option<SixPositionDetails>,
    /// What the final residual (‖a‖ − 1 per window) correlates with, strongest first
    /// ([`crate::search::correlates`]); absent when the residual agrees with the noise floor
    /// (the verdict's test) and in six-position mode.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub residual_correlates: Option<Vec<crate::report::correlate::ResidualCorrelate>>,
    /// Window-mean input only: how the table was read (absent for recordings of samples).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub window_input: Option<WindowInputInfo>,
    /// Window-mean input only: the van Hees et al. 2014 autocalibration (GGIR's method) of
    /// the same windows, for comparison; `--out` writes `calibration`, not this.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub autocalibration: Option<crate::autocal::AutocalReport>,
    /// Window-mean input only: the same method iterated to its fixed point (GGIR's stop
    /// criterion ends it early on thousands of epochs; see [`crate::autocal`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub autocalibration_converged: Option<crate::autocal::AutocalReport>,
    /// The log was polled faster than its sensor updates ([`crate::detect::polled`]): the
    /// noise floor is from the distinct samples; absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub polling: Option<crate::detect::polled::Polling>,
}

/// Six-position specifics of an [`AnalyzeReport`].
#[derive(Debug, Clone, Serialize)]
pub struct SixPositionDetails {
    /// Samples per pose (x+ x- y+ y- z+ z-).
    pub samples_per_pose: [u32; 6],
    /// Mean reading of each pose (x+ x- y+ y- z+ z-), raw units.
    pub pose_means_raw: [[f64; 3]; 6],
    /// Residual `K·(M − T̂Â)` in milli-g: rows = axes x, y, z; columns = poses x+ x- y+ y- z+ z-.
    pub pose_residual_mg: [[f64; 6]; 3],
    /// The same per ± pair (the + and − entries are equal): rows = axes, columns = pairs x, y, z.
    pub pair_residual_mg: [[f64; 3]; 3],
    /// ‖a‖ − 1 g per pose, milli-g.
    pub norm_residual_mg: [f64; 6],
    /// Own-pair contrast per axis converted to the quadratic it implies, k2 = −1.5·`R[a][a]`,
    /// mg/g².
    pub implied_k2_mg: [f64; 3],
    /// Other-pairs contrast per axis row, `R[a][j] − R[a][k]` (j < k the two other pairs), mg.
    pub misalignment_contrast_mg: [f64; 3],
    /// Noise std of one pose mean per axis (raw), when the file has sample blocks.
    pub pose_mean_std_raw: Option<[f64; 3]>,
    /// χ² (3 dof) of the own-pair contrasts against the noise, and its p-value.
    pub chi2_even: Option<f64>,
    /// p-value of `chi2_even`.
    pub p_even: Option<f64>,
    /// χ² (3 dof) of the other-pairs contrasts, and its p-value.
    pub chi2_misalignment: Option<f64>,
    /// p-value of `chi2_misalignment`.
    pub p_misalignment: Option<f64>,
    /// What six poses can and cannot identify, with this file's numbers.
    pub explanation: String,
}

/// How a window-mean table was read (reported with the analysis).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct WindowInputInfo {
    /// Rows read, one window each.
    pub rows: usize,
    /// The per-axis standard-deviation columns (x, y, z), if any.
    pub sd_columns: Option<[String; 3]>,
    /// The sample-count column, if any.
    pub count_column: Option<String>,
    /// True when the rows were taken as windows because the caller asked (`--windows`), not
    /// because of the header.
    pub forced: bool,
    /// One line saying so, e.g. "read as 10,958 window means (columns sdx,sdy,sdz): no
    /// static detection".
    pub description: String,
}
