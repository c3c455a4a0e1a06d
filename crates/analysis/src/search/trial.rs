//! Candidate trials: each parametric candidate fitted jointly with the current model, its
//! F-test against the current model and its leave-one-window-out errors.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use crate::fit::model::{self as am, Fit, Mask, Term, Win};
use crate::report::contract::CandidateReport;
use crate::search::candidate::Candidate;
use crate::search::select::{cv_over, MIN_DOF_TERM};
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
    /// Which candidate (for a combination of several effects: its first).
    pub candidate: Candidate,
    /// The blocks it adds to the current model.
    pub terms: Vec<Term>,
}

impl CandSpec {
    /// A single effect (or the curved-drift diagnostic, which is one candidate of two blocks).
    pub fn single(candidate: Candidate, terms: Vec<Term>) -> Self {
        Self { candidate, terms }
    }

    /// Several effects added at once (`terms` in the order of [`Term::ALL`]).
    pub fn combination(terms: Vec<Term>) -> Self {
        Self {
            candidate: Candidate::of_term(terms[0]),
            terms,
        }
    }

    /// The report name: the candidate's, or the effects joined by `+`.
    pub fn name(&self) -> String {
        combination_name(self.candidate, &self.terms)
    }
}

/// The report name of a candidate adding `terms`: `quadratic`, `quadratic+temperature`, …
fn combination_name(candidate: Candidate, terms: &[Term]) -> String {
    if is_combination(candidate, terms) {
        terms.iter().map(|t| t.name()).collect::<Vec<_>>().join("+")
    } else {
        candidate.to_string()
    }
}

/// True when the candidate adds several effects (not the curved drift, which is one
/// candidate of two blocks).
fn is_combination(candidate: Candidate, terms: &[Term]) -> bool {
    candidate != Candidate::BiasDriftCurved && terms.len() > 1
}

/// The test that one member of a combination is needed: the combination against the same
/// combination without it.
#[derive(Debug, Clone, PartialEq)]
pub struct DropTest {
    /// The member.
    pub term: Term,
    /// F statistic of removing it (denominator: the combination's residual variance).
    pub f: f64,
    /// Its p-value.
    pub p: f64,
    /// Leave-one-window-out RMS without it (what the other members leave), g.
    pub cv_without: f64,
    /// Significant at the step's level and the CV without it at least the factor higher.
    pub passes: bool,
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
    /// Per-window noise floor of the residual (g; [`crate::search::floor::floors`] under the base
    /// model): what each window's mean scatters by from its own samples alone.
    pub floor: Vec<f64>,
}

impl State {
    /// Windows in use.
    pub fn n_used(&self) -> usize {
        self.used.iter().filter(|u| **u).count()
    }

    /// The variance the tests refer residuals to ([`crate::search::floor::reference_variance`] over
    /// the windows in use), g².
    pub fn reference_variance(&self, rss: f64, dof: f64) -> f64 {
        crate::search::floor::reference_variance(rss, dof, &self.floor, &self.used)
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
    /// For a combination: each member's drop test (empty for a single effect).
    pub drops: Vec<DropTest>,
}

impl TermTrial {
    /// The report name (see [`CandSpec::name`]).
    pub fn name(&self) -> String {
        combination_name(self.candidate, &self.terms)
    }

    /// True for several effects added at once.
    pub fn is_combination(&self) -> bool {
        is_combination(self.candidate, &self.terms)
    }

    /// True when the trial adds exactly the blocks `terms` (in any order).
    pub fn adds(&self, terms: &[Term]) -> bool {
        self.terms.len() == terms.len() && terms.iter().all(|t| self.terms.contains(t))
    }

    /// Every member of a combination passes its drop test (true for a single effect).
    pub fn members_pass(&self) -> bool {
        self.drops.iter().all(|d| d.passes)
    }
}

/// The drop tests of combination `c` (see [`DropTest`]): each member removed in turn, the
/// rest taken from `trials` (or, when only one member would be left out of nothing, from the
/// current model `state`). A member whose reduced model could not be fitted fails.
pub fn drop_tests(
    c: &TermTrial,
    trials: &[TermTrial],
    state: &State,
    level: f64,
    cv_factor: f64,
) -> Vec<DropTest> {
    let dof = c.fit.n.saturating_sub(c.fit.k).max(1) as f64;
    let s2 = state.reference_variance(c.fit.rss, dof);
    c.terms
        .iter()
        .map(|&term| {
            let rest: Vec<Term> = c.terms.iter().copied().filter(|t| *t != term).collect();
            let reduced = if rest.is_empty() {
                Some((state.fit.rss, cv_over(&state.loo, &state.used)))
            } else {
                trials
                    .iter()
                    .find(|t| t.adds(&rest) && t.candidate != Candidate::BiasDriftCurved)
                    .map(|t| (t.fit.rss, Some(t.cv)))
            };
            let Some((rss_without, Some(cv_without))) = reduced else {
                return DropTest {
                    term,
                    f: f64::NAN,
                    p: 1.0,
                    cv_without: f64::NAN,
                    passes: false,
                };
            };
            let f = ((rss_without - c.fit.rss).max(0.0) / 3.0) / s2;
            let p = st::f_sf(f, 3.0, dof);
            DropTest {
                term,
                f,
                p,
                cv_without,
                passes: p < level && c.cv * cv_factor <= cv_without,
            }
        })
        .collect()
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
        name: spec.name(),
        params: dp,
        rms_mg: None,
        cv_rms_mg: None,
        cv_rms_current_mg: cur_cv.map(|x| x * 1e3),
        f_stat: None,
        p_value: None,
        passed: false,
        note: String::new(),
        windows_short: None,
    };
    if n_used < k_new + MIN_DOF_TERM {
        rep.note = format!("too few windows ({n_used}) for {k_new} parameters");
        rep.windows_short = Some(k_new + MIN_DOF_TERM - n_used);
        return (rep, None);
    }
    let Some(f) = am::fit(&state.fit.p, &mask, wins, &state.used) else {
        rep.note = "not identifiable from these windows (singular fit)".into();
        return (rep, None);
    };
    rep.rms_mg = Some(f.rms() * 1e3);
    let dof = (n_used - k_new) as f64;
    let fstat =
        ((state.fit.rss - f.rss).max(0.0) / dp as f64) / state.reference_variance(f.rss, dof);
    let p = st::f_sf(fstat, dp as f64, dof);
    rep.f_stat = Some(fstat);
    rep.p_value = Some(p);
    let Some(loo) = crate::fit::press::loo(&f, &mask, wins, &state.used) else {
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
        drops: Vec::new(),
    };
    (rep, Some(trial))
}

/// The note of a term candidate's report row once the rule has judged it.
pub fn term_note(
    t: &TermTrial,
    (sig, cv_ok, storable): (bool, bool, bool),
    level: f64,
    cv_factor: f64,
) -> String {
    let weak: Vec<String> = t
        .drops
        .iter()
        .filter(|d| !d.passes)
        .map(|d| {
            format!(
                "{} is not needed (without it F = {:.1}, p {}, CV {:.3} mg)",
                d.term.name(),
                d.f,
                crate::stats::fmt_p(d.p),
                d.cv_without * 1e3
            )
        })
        .collect();
    if sig && cv_ok && !weak.is_empty() {
        return format!("passes as a whole, but {}", weak.join("; "));
    }
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
