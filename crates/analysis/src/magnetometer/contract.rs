//! The magnetometer loop's JSON contract, the shape of `analyze`'s
//! ([`crate::report::contract`]): `noise_floor_*`, `base`, `effects`, `final`, `steps` with
//! `candidates`, `verdict` with its `reasons`, `diagnostics`. Magnitudes are in the
//! recording's own unit (`unit`: raw counts, gauss, µT — whatever the file holds), not mg.

use serde::Serialize;

/// A model's fit to the residual.
#[derive(Debug, Clone, Serialize)]
pub struct MagModelSummary {
    /// Independent parameters.
    pub params: usize,
    /// RMS of `‖W(m − c)‖ − R` after the model, file units.
    pub rms: f64,
    /// Leave-one-block-out RMS (10 consecutive time blocks), file units.
    pub cv_rms: Option<f64>,
    /// χ² of the residual against the noise floor, its degrees of freedom and p-value.
    pub chi2: f64,
    /// Degrees of freedom of `chi2`.
    pub chi2_dof: usize,
    /// p-value of `chi2`.
    pub chi2_p: f64,
}

/// An accepted effect.
#[derive(Debug, Clone, Serialize)]
pub struct MagEffect {
    /// Candidate name.
    pub name: String,
    /// Parameters it added.
    pub params: usize,
    /// In-sample RMS after adding it.
    pub rms: f64,
    /// Held-out RMS after adding it.
    pub cv_rms: Option<f64>,
    /// Held-out RMS before it.
    pub cv_rms_before: Option<f64>,
    /// One line: what, how much, when, and before → after.
    pub evidence: String,
    /// F statistic.
    pub f_stat: f64,
    /// p-value (with the factor for the positions scanned).
    pub p_value: f64,
    /// Its coefficients (per axis for a centre that moves), in `unit`.
    pub values: Vec<f64>,
    /// Their standard errors.
    pub std_errors: Vec<f64>,
    /// Unit of `values`.
    pub unit: String,
    /// When it happens (a step's time), else null.
    pub at: Option<f64>,
}

/// One candidate at one step.
#[derive(Debug, Clone, Serialize)]
pub struct MagCandidate {
    /// Name.
    pub name: String,
    /// Parameters it would add.
    pub params: usize,
    /// In-sample RMS with it.
    pub rms: f64,
    /// Held-out RMS with it.
    pub cv_rms: Option<f64>,
    /// Held-out RMS of the current model.
    pub cv_rms_current: Option<f64>,
    /// F statistic against the current model.
    pub f_stat: Option<f64>,
    /// p-value (with the factor for the positions scanned).
    pub p_value: Option<f64>,
    /// Passed both the F-test and the held-out rule.
    pub passed: bool,
    /// Why it passed or not, in words.
    pub note: String,
    /// The smallest magnitude this recording would have shown at this step's level and
    /// held-out rule (in `detection_unit`, in the worst direction), for a candidate not
    /// accepted; null otherwise.
    pub detection_limit: Option<f64>,
    /// Unit of `detection_limit`.
    pub detection_unit: String,
}

/// One greedy step.
#[derive(Debug, Clone, Serialize)]
pub struct MagStep {
    /// Every candidate tried.
    pub candidates: Vec<MagCandidate>,
    /// The step's family-wise level, split over the candidates.
    pub level: f64,
    /// The candidate added, if any.
    pub accepted: Option<String>,
}

/// The magnetometer loop's result.
#[derive(Debug, Clone, Serialize)]
pub struct MagAnalysis {
    /// The residual's noise floor, file units (each axis's short-term scatter along the radius).
    pub noise_floor: f64,
    /// Each axis's short-term scatter, file units.
    pub noise_floor_axes: [f64; 3],
    /// How the directions cover the sphere: smallest eigenvalue of mean `n̂n̂ᵀ` (1/3 full).
    pub coverage: f64,
    /// The chosen fit refined by one linear step.
    pub base: MagModelSummary,
    /// Effects accepted, in order.
    pub effects: Vec<MagEffect>,
    /// The final model.
    #[serde(rename = "final")]
    pub final_model: MagModelSummary,
    /// Every step's candidates.
    pub steps: Vec<MagStep>,
    /// `good`, `unexplained-residual` or `not-usable`.
    pub verdict: String,
    /// Why, one sentence each.
    pub reasons: Vec<String>,
    /// What could not be tested, and what would make it testable.
    pub diagnostics: Vec<String>,
}
