//! Candidate trials: each parametric candidate fitted jointly with the current model, its
//! F-test against the current model and its leave-one-window-out errors.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use crate::candidate::Candidate;
use crate::model::{self as am, Fit, Mask, Term, Win};
use crate::report::CandidateReport;
use crate::select::{cv_over, MIN_DOF_TERM};
use crate::stats as st;
use wiical_core::multipos::MultiPosModel;

/// Mask of the base model's free parameters (the diagonal model fixes the three
/// non-orthogonality entries of K).
pub fn base_mask(model: MultiPosModel) -> Mask {
    let mut m = am::mask_of(&[]);
    if model == MultiPosModel::Diagonal {
        for i in am::K_OFF_DIAGONAL {
            m[i] = false;
        }
    }
    m
}

/// Mask of the base model plus effect terms.
pub fn mask_for(model: MultiPosModel, terms: &[Term]) -> Mask {
    let mut m = am::mask_of(terms);
    m[..9].copy_from_slice(&base_mask(model)[..9]);
    m
}

/// A parametric candidate: one or more effect blocks added together.
#[derive(Debug, Clone)]
pub struct CandSpec {
    /// Which candidate.
    pub candidate: Candidate,
    /// The blocks it adds to the current model.
    pub terms: Vec<Term>,
}

/// The current model of the greedy search.
#[derive(Debug, Clone)]
pub struct State {
    /// Effect terms in the model.
    pub terms: Vec<Term>,
    /// Windows in use (false: rejected as outliers).
    pub used: Vec<bool>,
    /// The fit.
    pub fit: Fit,
    /// Its held-out residuals, g.
    pub loo: Vec<Option<f64>>,
}

impl State {
    /// Windows in use.
    pub fn n_used(&self) -> usize {
        self.used.iter().filter(|u| **u).count()
    }
}

/// A parametric candidate that could be fitted and cross-validated.
#[derive(Debug, Clone)]
pub struct TermTrial {
    /// Which candidate.
    pub candidate: Candidate,
    /// The blocks it adds.
    pub terms: Vec<Term>,
    /// Parameters it adds.
    pub dp: usize,
    /// The fit with it.
    pub fit: Fit,
    /// Held-out residuals with it, g.
    pub loo: Vec<Option<f64>>,
    /// F statistic of the improvement.
    pub f: f64,
    /// Its p-value.
    pub p: f64,
    /// Leave-one-window-out RMS over the windows in use, g.
    pub cv: f64,
    /// Passed the rule (significance and CV), whether or not storable.
    pub passes_rules: bool,
    /// Index of its row in the step's candidate reports.
    pub report: usize,
}

/// Fits one candidate on top of `state`. Returns its report row (without the verdict, which
/// the selection rule fills in) and, when it could be fitted and cross-validated, the trial.
pub fn try_term(
    spec: &CandSpec,
    state: &State,
    model: MultiPosModel,
    wins: &[Win],
    cur_cv: Option<f64>,
) -> (CandidateReport, Option<TermTrial>) {
    let dp = 3 * spec.terms.len();
    let n_used = state.n_used();
    let mut terms = state.terms.clone();
    terms.extend(spec.terms.iter().copied());
    let mask = mask_for(model, &terms);
    let k_new = mask.iter().filter(|x| **x).count();
    let mut rep = CandidateReport {
        name: spec.candidate.to_string(),
        params: dp,
        rms_mg: None,
        cv_rms_mg: None,
        cv_rms_current_mg: cur_cv.map(|x| x * 1e3),
        f_stat: None,
        p_value: None,
        passed: false,
        note: String::new(),
    };
    if n_used < k_new + MIN_DOF_TERM {
        rep.note = format!("too few windows ({n_used}) for {k_new} parameters");
        return (rep, None);
    }
    let Some(f) = am::fit(&state.fit.p, &mask, wins, &state.used) else {
        rep.note = "not identifiable from these windows (singular fit)".into();
        return (rep, None);
    };
    rep.rms_mg = Some(f.rms() * 1e3);
    let dof = (n_used - k_new) as f64;
    let fstat = ((state.fit.rss - f.rss).max(0.0) / dp as f64) / (f.rss / dof).max(1e-300);
    let p = st::f_sf(fstat, dp as f64, dof);
    rep.f_stat = Some(fstat);
    rep.p_value = Some(p);
    let Some(loo) = am::loo(&f, &mask, wins, &state.used) else {
        rep.note =
            "cross-validation refit failed (a held-out window leaves it undetermined)".into();
        return (rep, None);
    };
    let cv = cv_over(&loo, &state.used).unwrap_or(f64::INFINITY);
    rep.cv_rms_mg = Some(cv * 1e3);
    let trial = TermTrial {
        candidate: spec.candidate,
        terms: spec.terms.clone(),
        dp,
        fit: f,
        loo,
        f: fstat,
        p,
        cv,
        passes_rules: false,
        report: 0,
    };
    (rep, Some(trial))
}

/// The note of a term candidate's report row once the rule has judged it.
pub fn term_note(sig: bool, cv_ok: bool, storable: bool, level: f64, cv_factor: f64) -> String {
    match (sig, cv_ok) {
        (true, true) if storable => "passes".into(),
        (true, true) => {
            "passes, but diagnostic only: the calibration cannot store a curved drift".into()
        }
        (false, true) => format!("F-test not significant at {level:.1e}"),
        (true, false) => format!("CV not improved by the factor {cv_factor:.2}"),
        (false, false) => "neither significant nor better under CV".into(),
    }
}
