//! Candidate gyro effects seen in the static windows alone: while the sensor rests the gyro
//! should read its bias, the same in every pose. Its window means (through the calibration,
//! °/s) are regressed on what could move them: the gravity direction (g-sensitivity, a 3×3
//! matrix `G` in °/s per g, so that `b(a) = b₀ + G·a` can later be applied per sample), the
//! window's time (bias drift, °/s per hour) and its temperature (°/s per °C). Each candidate
//! is accepted by the accelerometer's rule ([`crate::search::select::select`]: F-test at
//! α / candidates against [`crate::search::floor::reference_variance`] **and** the held-out
//! window RMS down by [`crate::search::select::CV_FACTOR`]), greedily, up to
//! [`crate::search::select::MAX_EFFECTS`] steps. Every candidate not accepted gets its
//! detection limit ([`super::limits`]).

use super::design::{design, width};
pub use super::design::{Candidate, WindowData};
use super::limits::detection_limit;
use super::report::{GyroCandidate, GyroEffect, GyroStep, GyroSummary};
use crate::search::floor::reference_variance;
use crate::search::select::{self, Choice, TermScore, ALPHA, CV_FACTOR, MAX_EFFECTS};
use crate::stats as st;
use nalgebra::{DMatrix, DVector};

/// A least-squares fit of the three axes on one design.
pub(super) struct Fit {
    /// Coefficients, one column per axis.
    pub(super) beta: DMatrix<f64>,
    /// Residual sum of squares over all axes.
    rss: f64,
    /// Leave-one-window-out residuals, all axes.
    loo: Vec<f64>,
    /// `(XᵀX)⁻¹`.
    pub(super) inv: DMatrix<f64>,
    /// Residual degrees of freedom over all axes.
    dof: usize,
}

impl Fit {
    /// Residual sum of squares over all axes, (°/s)².
    pub(super) fn rss(&self) -> f64 {
        self.rss
    }

    /// Residual degrees of freedom over all axes.
    pub(super) fn dof(&self) -> usize {
        self.dof
    }

    /// Leave-one-window-out residuals, all axes, °/s.
    pub(super) fn loo(&self) -> &[f64] {
        &self.loo
    }
}

pub(super) fn fit(x: &DMatrix<f64>, data: &WindowData) -> Option<Fit> {
    let (n, p) = x.shape();
    if n <= p {
        return None;
    }
    let inv = (x.transpose() * x).try_inverse()?;
    let hat_diag: Vec<f64> = (0..n)
        .map(|i| (x.row(i) * &inv * x.row(i).transpose())[(0, 0)])
        .collect();
    let mut beta = DMatrix::zeros(p, 3);
    let (mut rss, mut loo) = (0.0, Vec::with_capacity(3 * n));
    for a in 0..3 {
        let y = DVector::from_iterator(n, data.rate_dps.iter().map(|r| r[a]));
        let b = &inv * x.transpose() * &y;
        let e = &y - x * &b;
        rss += e.norm_squared();
        loo.extend((0..n).map(|i| e[i] / (1.0 - hat_diag[i]).max(1e-12)));
        beta.set_column(a, &b);
    }
    Some(Fit {
        beta,
        rss,
        loo,
        inv,
        dof: 3 * (n - p),
    })
}

/// The summary of a window model: in-sample and held-out RMS, χ² against the floor.
fn summary(f: &Fit, data: &WindowData, params: usize) -> GyroSummary {
    let n = data.rate_dps.len();
    let floor_var: f64 = data.mean_var.iter().flatten().sum::<f64>() / (3 * n) as f64;
    let chi2 = (floor_var > 0.0).then(|| f.rss / floor_var);
    GyroSummary {
        params,
        rms_dps: (f.rss / (3 * n) as f64).sqrt(),
        cv_rms_dps: Some(st::rms(&f.loo)),
        windows_used: n,
        chi2,
        chi2_dof: Some(f.dof),
        chi2_p: chi2.map(|c| st::chi2_sf(c, f.dof as f64)),
    }
}

/// The search's outcome.
pub struct Search {
    /// The bias-only window model.
    pub base: GyroSummary,
    /// Accepted effects in order.
    pub effects: Vec<GyroEffect>,
    /// The window model with them.
    pub final_model: GyroSummary,
    /// Every step with every candidate.
    pub steps: Vec<GyroStep>,
    /// The final window model's constant per gyro axis, °/s: the bias the windows leave at
    /// the regressors' reference (gravity zero, mean window time and temperature).
    pub intercept_dps: [f64; 3],
}

/// Runs the greedy search over `cands` on the window data.
pub fn search(data: &WindowData, cands: &[Candidate]) -> Option<Search> {
    search_from(data, cands, None)
}

/// [`search`] with `pre` (a bias step, [`super::bias_step`]) in the model before the first
/// step: its row is the first effect, tested against the bias-only model.
pub fn search_from(
    data: &WindowData,
    cands: &[Candidate],
    pre: Option<&Candidate>,
) -> Option<Search> {
    let n = data.rate_dps.len();
    let floors: Vec<f64> = data.mean_var.iter().flatten().map(|v| v.sqrt()).collect();
    let used = vec![true; floors.len()];
    let base_fit = fit(&design(&[], None, n), data)?;
    let base = summary(&base_fit, data, 3);
    let (mut chosen, mut effects, mut current) = match pre {
        Some(c) => pre_effect(data, c, &base_fit, &floors).map(|(f, r)| (vec![c], vec![r], f))?,
        None => (Vec::new(), Vec::new(), base_fit),
    };
    let mut steps = Vec::new();
    for _ in 0..MAX_EFFECTS {
        let open: Vec<&Candidate> = cands
            .iter()
            .filter(|c| !chosen.iter().any(|k| k.name == c.name))
            .collect();
        if open.is_empty() {
            break;
        }
        let sigma2 = reference_variance(current.rss, current.dof as f64, &floors, &used);
        let cv0 = st::rms(&current.loo);
        let fits: Vec<Option<Fit>> = open
            .iter()
            .map(|c| fit(&design(&chosen, Some(c), n), data))
            .collect();
        let tested = fits
            .iter()
            .filter(|f| {
                f.as_ref()
                    .is_some_and(|f| f.dof >= 3 * select::MIN_DOF_TERM)
            })
            .count()
            .max(1);
        let level = ALPHA / tested as f64;
        let scores: Vec<TermScore> = open
            .iter()
            .zip(&fits)
            .map(|(c, f)| score(c, f.as_ref(), &current, &floors, &used))
            .collect();
        let sel = select::select(&scores, None, Some(cv0), level, CV_FACTOR);
        let ctx = StepContext {
            data,
            chosen: &chosen,
            current: &current,
            sigma2,
            level,
            floors: &floors,
        };
        let rows: Vec<GyroCandidate> = open
            .iter()
            .zip(&fits)
            .zip(&scores)
            .enumerate()
            .map(|(i, ((c, f), s))| candidate_row(&ctx, c, f.as_ref(), s, &sel, i))
            .collect();
        let accepted = match sel.choice {
            Choice::Term(i) => Some(i),
            _ => None,
        };
        steps.push(GyroStep {
            candidates: rows,
            level,
            accepted: accepted.map(|i| open[i].name.to_string()),
        });
        let Some(i) = accepted else { break };
        let Some(new_fit) = fits.into_iter().nth(i).flatten() else {
            break;
        };
        effects.push(effect_report(&ctx, open[i], &new_fit, &scores[i]));
        chosen.push(open[i]);
        current = new_fit;
    }
    let params = 3 + chosen.iter().map(|c| 3 * width(c)).sum::<usize>();
    let final_model = summary(&current, data, params);
    Some(Search {
        base,
        effects,
        final_model,
        steps,
        intercept_dps: std::array::from_fn(|a| current.beta[(0, a)]),
    })
}

/// The fit with `c` added to the bias-only model `base` and its effect row.
fn pre_effect(
    data: &WindowData,
    c: &Candidate,
    base: &Fit,
    floors: &[f64],
) -> Option<(Fit, GyroEffect)> {
    let used = vec![true; floors.len()];
    let f = fit(&design(&[], Some(c), data.rate_dps.len()), data)?;
    let sc = score(c, Some(&f), base, floors, &used);
    let ctx = StepContext {
        data,
        chosen: &[],
        current: base,
        // The step's standard errors from the model with it (the bias-only model's variance
        // holds the step itself).
        sigma2: reference_variance(f.rss, f.dof as f64, floors, &used),
        level: ALPHA,
        floors,
    };
    let row = effect_report(&ctx, c, &f, &sc);
    Some((f, row))
}

/// Everything a step's rows are written from.
struct StepContext<'a> {
    data: &'a WindowData,
    chosen: &'a [&'a Candidate],
    current: &'a Fit,
    sigma2: f64,
    level: f64,
    /// Noise of each window mean and axis, °/s.
    floors: &'a [f64],
}

/// F-test and held-out RMS of one candidate against the current model.
fn score(
    c: &Candidate,
    f: Option<&Fit>,
    current: &Fit,
    floors: &[f64],
    used: &[bool],
) -> TermScore {
    let Some(f) = f.filter(|f| f.dof >= 3 * select::MIN_DOF_TERM) else {
        return TermScore {
            p_value: 1.0,
            weight: 1.0,
            cv: f64::INFINITY,
            cv_on_kept: None,
            storable: true,
            members_pass: false,
        };
    };
    let q = 3 * width(c);
    let var = reference_variance(f.rss, f.dof as f64, floors, used);
    let fstat = ((current.rss - f.rss) / q as f64 / var).max(0.0);
    TermScore {
        p_value: st::f_sf(fstat, q as f64, f.dof as f64),
        weight: 1.0,
        cv: st::rms(&f.loo),
        cv_on_kept: None,
        storable: true,
        members_pass: true,
    }
}

/// The F statistic of `c` against the current model, referred to the same variance as
/// [`score`]'s p-value ([`TermScore`] keeps only the p-value).
fn f_stat(c: &Candidate, f: &Fit, current: &Fit, floors: &[f64]) -> f64 {
    let q = 3 * width(c);
    let used = vec![true; floors.len()];
    let var = reference_variance(f.rss, f.dof as f64, floors, &used);
    ((current.rss - f.rss) / q as f64 / var).max(0.0)
}

fn candidate_row(
    ctx: &StepContext<'_>,
    c: &Candidate,
    f: Option<&Fit>,
    s: &TermScore,
    sel: &select::Selection,
    i: usize,
) -> GyroCandidate {
    let passed = matches!(sel.choice, Choice::Term(j) if j == i);
    let limit = (!passed)
        .then(|| detection_limit(ctx.data, ctx.chosen, c, ctx.sigma2, ctx.level))
        .flatten();
    let note = match (f, passed) {
        (None, _) => "too few windows to test it".to_string(),
        (Some(_), true) => format!("accepted: {}", c.pattern),
        (Some(_), false) if !sel.significant[i] => format!(
            "not significant (p {} against {:.1e})",
            st::fmt_p(s.p_value),
            ctx.level
        ),
        (Some(_), false) => "significant, but the held-out RMS does not fall by 10 %".into(),
    };
    GyroCandidate {
        name: c.name.into(),
        params: 3 * width(c),
        unit: c.unit.into(),
        rms_dps: f.map(|f| (f.rss / f.loo.len() as f64).sqrt()),
        cv_rms_dps: f.map(|f| st::rms(&f.loo)),
        cv_rms_current_dps: Some(st::rms(&ctx.current.loo)),
        f_stat: f.map(|f| f_stat(c, f, ctx.current, ctx.floors)),
        p_value: f.map(|_| s.p_value),
        passed,
        note,
        detection_limit: limit,
    }
}

fn effect_report(ctx: &StepContext<'_>, c: &Candidate, f: &Fit, s: &TermScore) -> GyroEffect {
    let k = width(c);
    let first = 1 + ctx.chosen.iter().map(|c| width(c)).sum::<usize>();
    let var = ctx.sigma2;
    // Row-major per gyro axis: value (axis a, regressor j) = β[first + j, a].
    let values: Vec<f64> = (0..3)
        .flat_map(|a| (0..k).map(move |j| (a, j)))
        .map(|(a, j)| f.beta[(first + j, a)])
        .collect();
    let std_errors: Vec<f64> = (0..3)
        .flat_map(|_| 0..k)
        .map(|j| (var * f.inv[(first + j, first + j)]).sqrt())
        .collect();
    let n = ctx.data.rate_dps.len() as f64;
    let (rb, ra) = (
        (ctx.current.rss / (3.0 * n)).sqrt(),
        (f.rss / (3.0 * n)).sqrt(),
    );
    let (cb, ca) = (st::rms(&ctx.current.loo), st::rms(&f.loo));
    let fs = f_stat(c, f, ctx.current, ctx.floors);
    GyroEffect {
        name: c.name.into(),
        params: 3 * k,
        unit: c.unit.into(),
        values,
        std_errors,
        evidence: format!(
            "{}: F = {fs:.2} ({}, {} dof), p {}; window RMS {rb:.4} → {ra:.4} °/s in-sample, {cb:.4} → {ca:.4} °/s held out",
            c.pattern,
            3 * k,
            f.dof,
            st::fmt_p(s.p_value)
        ),
        f_stat: Some(fs),
        p_value: Some(s.p_value),
        rms_before_dps: rb,
        rms_dps: ra,
        cv_rms_before_dps: Some(cb),
        cv_rms_dps: Some(ca),
    }
}
