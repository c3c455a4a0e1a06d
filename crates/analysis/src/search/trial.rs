//! Candidate trials: each parametric candidate fitted jointly with the current model, its
//! F-test against the current model and its leave-one-window-out errors.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use crate::fit::model::{self as am, Fit, Mask, Part, Term, Win};
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

/// Mask of the base model plus effect parts (whole blocks or single axes).
pub fn mask_for(model: MultiPosModel, parts: &[Part]) -> Mask {
    let mut m = am::mask_of_parts(parts);
    m[..9].copy_from_slice(&base_mask(model)[..9]);
    m
}

/// A parametric candidate: one or more effect parts (whole blocks or single axes) added
/// together.
#[derive(Debug, Clone)]
pub struct CandSpec {
    /// Which candidate (for a combination of several effects: its first).
    pub candidate: Candidate,
    /// The parts it adds to the current model.
    pub parts: Vec<Part>,
}

impl CandSpec {
    /// A single effect: a block, one axis of it, or the curved-drift diagnostic (one candidate
    /// of two blocks).
    pub fn single(candidate: Candidate, parts: Vec<Part>) -> Self {
        Self { candidate, parts }
    }

    /// Several effects added at once (`parts` in the order of [`Term::ALL`]).
    pub fn combination(parts: Vec<Part>) -> Self {
        Self {
            candidate: parts[0].term.effect(),
            parts,
        }
    }

    /// The report name: the part's (`quadratic`, `quadratic (z)`), the diagnostic's, or the
    /// effects joined by `+`.
    pub fn name(&self) -> String {
        combination_name(self.candidate, &self.parts)
    }

    /// True for several effects added at once.
    pub fn is_combination(&self) -> bool {
        is_combination(self.candidate, &self.parts)
    }

    /// Parameters it adds.
    pub fn params(&self) -> usize {
        self.parts.iter().map(|p| p.count()).sum()
    }
}

/// The report name of a candidate adding `parts`: `quadratic`, `quadratic (z)`,
/// `quadratic+temperature`, …
fn combination_name(candidate: Candidate, parts: &[Part]) -> String {
    if candidate == Candidate::BiasDriftCurved {
        candidate.to_string()
    } else {
        parts.iter().map(|p| p.name()).collect::<Vec<_>>().join("+")
    }
}

/// True when the candidate adds several effects (not the curved drift, which is one
/// candidate of two blocks).
fn is_combination(candidate: Candidate, parts: &[Part]) -> bool {
    candidate != Candidate::BiasDriftCurved && parts.len() > 1
}

/// True when the candidate adds a single axis of a block whose other missing axes are tried
/// as the block too (`quadratic (z)` next to `quadratic`).
pub fn is_axis_member(candidate: Candidate, parts: &[Part], state: &State) -> bool {
    !is_combination(candidate, parts)
        && candidate != Candidate::BiasDriftCurved
        && parts[0].count() == 1
        && state.missing_axes(parts[0].term) > 1
}

/// The test that one member of a combination is needed: the combination against the same
/// combination without it.
#[derive(Debug, Clone, PartialEq)]
pub struct DropTest {
    /// The member.
    pub part: Part,
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
    /// Effect parts in the model (whole blocks or single axes).
    pub parts: Vec<Part>,
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

    /// The axes of block `t` the model has (from every part of it added so far).
    pub fn axes_of(&self, t: Term) -> [bool; 3] {
        let mut have = [false; 3];
        for p in self.parts.iter().filter(|p| p.term == t) {
            for (h, a) in have.iter_mut().zip(p.axes) {
                *h |= a;
            }
        }
        have
    }

    /// How many axes of block `t` the model does not have yet.
    pub fn missing_axes(&self, t: Term) -> usize {
        self.axes_of(t).iter().filter(|a| !**a).count()
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
    /// The parts it adds.
    pub parts: Vec<Part>,
    /// One axis of a block also tried whole ([`is_axis_member`]).
    pub axis_member: bool,
    /// Its share of the step's level ([`bonferroni_weights`]): its F-test passes at
    /// `level × weight`.
    pub weight: f64,
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
        combination_name(self.candidate, &self.parts)
    }

    /// True for several effects added at once.
    pub fn is_combination(&self) -> bool {
        is_combination(self.candidate, &self.parts)
    }

    /// True when the trial adds exactly the parts `parts` (in any order).
    pub fn adds(&self, parts: &[Part]) -> bool {
        self.parts.len() == parts.len() && parts.iter().all(|t| self.parts.contains(t))
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
    level_of: impl Fn(Term) -> f64,
    cv_factor: f64,
) -> Vec<DropTest> {
    let dof = c.fit.n.saturating_sub(c.fit.k).max(1) as f64;
    let s2 = state.reference_variance(c.fit.rss, dof);
    c.parts
        .iter()
        .map(|&part| {
            let rest: Vec<Part> = c.parts.iter().copied().filter(|t| *t != part).collect();
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
                    part,
                    f: f64::NAN,
                    p: 1.0,
                    cv_without: f64::NAN,
                    passes: false,
                };
            };
            let q = part.count() as f64;
            let f = ((rss_without - c.fit.rss).max(0.0) / q) / s2;
            let p = st::f_sf(f, q, dof);
            DropTest {
                part,
                f,
                p,
                cv_without,
                passes: p < level_of(part.term) && c.cv * cv_factor <= cv_without,
            }
        })
        .collect()
}

/// Free parameters of the current model plus candidate `spec`.
pub fn params_with(spec: &CandSpec, state: &State, model: MultiPosModel) -> usize {
    let mut parts = state.parts.clone();
    parts.extend(spec.parts.iter().copied());
    mask_for(model, &parts).iter().filter(|x| **x).count()
}

/// True when the windows in use are enough to test `spec` ([`MIN_DOF_TERM`] beyond its
/// parameters): the candidates the step's Bonferroni level counts.
pub fn testable(spec: &CandSpec, state: &State, model: MultiPosModel) -> bool {
    state.n_used() >= params_with(spec, state, model) + MIN_DOF_TERM
}

/// The step's Bonferroni split (weighted): the number of hypothesis families the level α/m
/// is divided by, and each candidate's share of α/m. A family is an effect (its block and,
/// for a nonlinearity, its single axes), the curved-drift diagnostic, or the outliers,
/// counted when the windows are enough to test any of it. Within a nonlinearity's family the
/// block takes half and its single axes share the other half (all of it when the block cannot
/// be tested), so adding the single axes leaves every other effect's level where it was; a
/// combination is tested at the smallest share of its members (each member's drop test at its
/// own). Sum of the levels ≤ α, so the family-wise false-positive rate per step stays ≤ α.
pub fn bonferroni_weights(
    specs: &[CandSpec],
    state: &State,
    model: MultiPosModel,
) -> (usize, Vec<f64>) {
    let ok: Vec<bool> = specs.iter().map(|s| testable(s, state, model)).collect();
    let single = |s: &CandSpec| !s.is_combination() && s.candidate != Candidate::BiasDriftCurved;
    let member = |s: &CandSpec| single(s) && is_axis_member(s.candidate, &s.parts, state);
    // Per block: is it testable, how many of its single axes are.
    let family = |t: Term| {
        let mut block_ok = false;
        let mut axes_ok = 0usize;
        for (s, &k) in specs.iter().zip(&ok) {
            if single(s) && s.parts[0].term == t && k {
                if member(s) {
                    axes_ok += 1;
                } else {
                    block_ok = true;
                }
            }
        }
        (block_ok, axes_ok)
    };
    let block_weight = |t: Term| match family(t) {
        (true, a) if a > 0 => 0.5,
        _ => 1.0,
    };
    let weights = specs
        .iter()
        .map(|s| {
            if s.candidate == Candidate::BiasDriftCurved {
                1.0
            } else if s.is_combination() {
                s.parts
                    .iter()
                    .map(|p| block_weight(p.term))
                    .fold(1.0, f64::min)
            } else if member(s) {
                let (block_ok, a) = family(s.parts[0].term);
                (if block_ok { 0.5 } else { 1.0 }) / a.max(1) as f64
            } else {
                block_weight(s.parts[0].term)
            }
        })
        .collect();
    let mut families = 0;
    for t in Term::ALL {
        let (b, a) = family(t);
        families += usize::from(b || a > 0);
    }
    families += specs
        .iter()
        .zip(&ok)
        .filter(|(s, k)| **k && s.candidate == Candidate::BiasDriftCurved)
        .count();
    (families, weights)
}

/// The share of the level of block `t` in a step's [`bonferroni_weights`] (1 when it is not
/// among the candidates).
pub fn block_weight(t: Term, specs: &[CandSpec], weights: &[f64], state: &State) -> f64 {
    specs
        .iter()
        .zip(weights)
        .find(|(s, _)| {
            !s.is_combination()
                && s.candidate != Candidate::BiasDriftCurved
                && s.parts[0].term == t
                && !is_axis_member(s.candidate, &s.parts, state)
        })
        .map_or(1.0, |(_, w)| *w)
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
    let dp = spec.params();
    let n_used = state.n_used();
    let k_new = params_with(spec, state, model);
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
        detection_limit: None,
        detection_unit: None,
    };
    if n_used < k_new + MIN_DOF_TERM {
        rep.note = format!("too few windows ({n_used}) for {k_new} parameters");
        rep.windows_short = Some(k_new + MIN_DOF_TERM - n_used);
        return (rep, None);
    }
    let mut parts = state.parts.clone();
    parts.extend(spec.parts.iter().copied());
    let mask = mask_for(model, &parts);
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
        parts: spec.parts.clone(),
        axis_member: is_axis_member(spec.candidate, &spec.parts, state),
        weight: 1.0,
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
                d.part.name(),
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
        (false, true) => format!("F-test not significant at {:.1e}", level * t.weight),
        (true, false) => format!("CV not improved by the factor {cv_factor:.2}"),
        (false, false) => "neither significant nor better under CV".into(),
    }
}
