//! The open basis of the static windows: after the named window candidates
//! (`effects`), generic low-order terms of what moves the gyro's window means, one
//! coefficient on one gyro axis each, tried by the same rule (F-test at α / the terms tested,
//! a Bonferroni factor over the basis, **and** the held-out window RMS down by
//! [`CV_FACTOR`]), greedily.
//!
//! | family | form, per gyro axis | unit |
//! |---|---|---|
//! | `gravity-quadratic` | `g_i·g_j` (6 monomials of the gravity direction, unit vector) | °/s/g² |
//! | `drift-quadratic` | `t²` (window time from the windows' mean, h) | °/s/h² |
//! | `temperature-quadratic` | `T²` (from the windows' mean, °C; when it changes) | °/s/°C² |
//!
//! The gravity direction is normalised so that `g_x² + g_y² + g_z² = 1` exactly: once two
//! squares are in the model the third is in its span and is not counted (a term whose
//! projection off the current design keeps less than 10⁻⁶ of its norm is left out). Each axis
//! has its own design (the named model's regressors, shared, plus the basis terms accepted on
//! that axis), so the fit is per axis and the totals are summed. A term not accepted gets its
//! detection limit by [`super::limits::limit_from`] with one coefficient; the report gives each
//! family's largest.

use super::design::{design, Candidate, WindowData};
use super::limits::limit_from;
use super::report::{BasisEffect, BasisRow, BasisStep, FamilyLimit, OpenBasis};
use crate::search::floor::reference_variance;
use crate::search::select::{self, Choice, TermScore, ALPHA, CV_FACTOR, MAX_EFFECTS};
use crate::stats as st;
use nalgebra::{DMatrix, DVector};

/// Gyro axis names.
const AXES: [&str; 3] = ["x", "y", "z"];

/// One term of a basis: a regressor on one gyro axis.
#[derive(Debug, Clone)]
pub struct Term {
    /// Family name.
    pub family: &'static str,
    /// The form in words, e.g. `g_x·g_z`.
    pub form: String,
    /// Gyro axis it acts on.
    pub axis: usize,
    /// Unit of its coefficient.
    pub unit: &'static str,
    /// Its regressor per window (or per motion row, for the motions).
    pub column: Vec<f64>,
}

impl Term {
    /// `g_x·g_z on y`.
    pub fn name(&self) -> String {
        format!("{} on {}", self.form, AXES[self.axis])
    }
}

/// The families' forms in words and units, for the limits line.
pub(super) fn family_form(family: &str) -> &'static str {
    match family {
        "gravity-quadratic" => "g_i·g_j",
        "drift-quadratic" => "t²",
        "temperature-quadratic" => "T²",
        "rate-product" => "ω_i·ω_j",
        _ => "|ω_j| (another axis's rate)",
    }
}

/// The window basis from the named candidates' regressors (gravity, time, temperature per
/// window, as `effects` has them).
pub fn window_terms(cands: &[Candidate]) -> Vec<Term> {
    let col = |name: &str| cands.iter().find(|c| c.name == name).map(|c| &c.columns);
    let mut forms: Vec<(&'static str, String, &'static str, Vec<f64>)> = Vec::new();
    if let Some(g) = col("g-sensitivity") {
        let unit: Vec<[f64; 3]> = g
            .iter()
            .map(|v| {
                let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-300);
                [v[0] / n, v[1] / n, v[2] / n]
            })
            .collect();
        for (i, j) in [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)] {
            let form = format!("g_{}·g_{}", AXES[i], AXES[j]);
            let x = unit.iter().map(|u| u[i] * u[j]).collect();
            forms.push(("gravity-quadratic", form, "°/s/g²", x));
        }
    }
    for (name, family, form, unit) in [
        ("bias-drift", "drift-quadratic", "t²", "°/s/h²"),
        ("temperature", "temperature-quadratic", "T²", "°/s/°C²"),
    ] {
        if let Some(c) = col(name) {
            let x = c.iter().map(|r| r[0] * r[0]).collect();
            forms.push((family, form.into(), unit, x));
        }
    }
    (0..3)
        .flat_map(|axis| {
            forms.iter().map(move |(family, form, unit, x)| Term {
                family,
                form: form.clone(),
                axis,
                unit,
                column: x.clone(),
            })
        })
        .collect()
}

/// A per-axis least-squares fit.
#[derive(Clone)]
struct AxisFit {
    rss: f64,
    loo: Vec<f64>,
    inv: DMatrix<f64>,
    beta: DVector<f64>,
    p: usize,
}

fn fit_axis(x: &DMatrix<f64>, y: &DVector<f64>) -> Option<AxisFit> {
    let (n, p) = x.shape();
    if n <= p {
        return None;
    }
    let inv = (x.transpose() * x).try_inverse()?;
    let beta = &inv * x.transpose() * y;
    let e = y - x * &beta;
    let loo = (0..n)
        .map(|i| {
            let h = (x.row(i) * &inv * x.row(i).transpose())[(0, 0)];
            e[i] / (1.0 - h).max(1e-12)
        })
        .collect();
    Some(AxisFit {
        rss: e.norm_squared(),
        loo,
        inv,
        beta,
        p,
    })
}

/// `x` with `z` appended as a last column.
fn with_column(x: &DMatrix<f64>, z: &[f64]) -> DMatrix<f64> {
    let (n, p) = x.shape();
    DMatrix::from_fn(n, p + 1, |r, c| if c < p { x[(r, c)] } else { z[r] })
}

/// Whether `z` is (numerically) in the span of `x`'s columns.
fn in_span(x: &DMatrix<f64>, inv: &DMatrix<f64>, z: &[f64]) -> bool {
    let zv = DVector::from_column_slice(z);
    let perp = &zv - x * (inv * (x.transpose() * &zv));
    perp.norm() <= 1e-6 * zv.norm().max(1e-300)
}

/// The state of the search: per axis its design and fit.
struct State {
    x: [DMatrix<f64>; 3],
    fits: [AxisFit; 3],
    y: [DVector<f64>; 3],
}

impl State {
    fn rss(&self) -> f64 {
        self.fits.iter().map(|f| f.rss).sum()
    }
    fn dof(&self, n: usize) -> usize {
        self.fits.iter().map(|f| n.saturating_sub(f.p)).sum()
    }
    /// Every held-out residual, with axis `a`'s replaced by `alt`'s.
    fn loo_with(&self, a: usize, alt: Option<&AxisFit>) -> Vec<f64> {
        (0..3)
            .flat_map(|k| match alt.filter(|_| k == a) {
                Some(f) => f.loo.clone(),
                None => self.fits[k].loo.clone(),
            })
            .collect()
    }
}

/// One tested term: its fit on its axis and score.
struct Tried {
    term: usize,
    fit: AxisFit,
    f_stat: f64,
    p_value: f64,
    cv: f64,
    dof: usize,
}

/// Runs the window basis after the named model `chosen` on `data`.
pub fn search(data: &WindowData, chosen: &[&Candidate], terms: &[Term]) -> Option<OpenBasis> {
    let n = data.rate_dps.len();
    let x0 = design(chosen, None, n);
    let y: [DVector<f64>; 3] =
        std::array::from_fn(|a| DVector::from_iterator(n, data.rate_dps.iter().map(|r| r[a])));
    let fits = [
        fit_axis(&x0, &y[0])?,
        fit_axis(&x0, &y[1])?,
        fit_axis(&x0, &y[2])?,
    ];
    let mut s = State {
        x: [x0.clone(), x0.clone(), x0],
        fits,
        y,
    };
    let floors: Vec<f64> = data.mean_var.iter().flatten().map(|v| v.sqrt()).collect();
    let used = vec![true; floors.len()];
    let cv_start = st::rms(&s.loo_with(0, None));
    let (mut found, mut steps, mut taken) = (Vec::new(), Vec::new(), Vec::<usize>::new());
    for _ in 0..MAX_EFFECTS {
        let tried = try_terms(&s, terms, &taken, n, (&floors, &used));
        if tried.is_empty() {
            break;
        }
        let level = ALPHA / tried.len() as f64;
        let cv0 = st::rms(&s.loo_with(0, None));
        let scores: Vec<TermScore> = tried.iter().map(term_score).collect();
        let sel = select::select(&scores, None, Some(cv0), level, CV_FACTOR);
        let accepted = match sel.choice {
            Choice::Term(i) => Some(i),
            _ => None,
        };
        let sigma2 = reference_variance(s.rss(), s.dof(n) as f64, &floors, &used);
        let rows = tried
            .iter()
            .enumerate()
            .map(|(i, t)| row(&s, &terms[t.term], t, accepted == Some(i), sigma2, level, n))
            .collect();
        steps.push(BasisStep {
            screened: tried.len(),
            level,
            accepted: accepted.map(|i| terms[tried[i].term].name()),
            candidates: rows,
        });
        let Some(i) = accepted else { break };
        let t = &tried[i];
        let term = &terms[t.term];
        let var = reference_variance(
            s.rss() - s.fits[term.axis].rss + t.fit.rss,
            t.dof as f64,
            &floors,
            &used,
        );
        let cv = st::rms(&s.loo_with(term.axis, Some(&t.fit)));
        found.push(found_effect(term, t, var, cv0, cv));
        s.x[term.axis] = with_column(&s.x[term.axis], &term.column);
        s.fits[term.axis] = t.fit.clone();
        taken.push(t.term);
    }
    let cv_final = st::rms(&s.loo_with(0, None));
    Some(finish(terms, found, steps, cv_start, cv_final, "°/s"))
}

/// Every term not taken and not in its axis's span, fitted on its axis.
fn try_terms(
    s: &State,
    terms: &[Term],
    taken: &[usize],
    n: usize,
    (floors, used): (&[f64], &[bool]),
) -> Vec<Tried> {
    let (rss0, dof0) = (s.rss(), s.dof(n));
    terms
        .iter()
        .enumerate()
        .filter(|(k, t)| {
            !taken.contains(k) && !in_span(&s.x[t.axis], &s.fits[t.axis].inv, &t.column)
        })
        .filter_map(|(k, t)| {
            let cur = &s.fits[t.axis];
            let f = fit_axis(&with_column(&s.x[t.axis], &t.column), &s.y[t.axis])?;
            if n < f.p + select::MIN_DOF_TERM {
                return None;
            }
            let dof = dof0.checked_sub(1)?;
            let rss = rss0 - cur.rss + f.rss;
            let var = reference_variance(rss, dof as f64, floors, used);
            let f_stat = ((cur.rss - f.rss) / var).max(0.0);
            let cv = st::rms(&s.loo_with(t.axis, Some(&f)));
            Some(Tried {
                term: k,
                p_value: st::f_sf(f_stat, 1.0, dof as f64),
                fit: f,
                f_stat,
                cv,
                dof,
            })
        })
        .collect()
}

fn term_score(t: &Tried) -> TermScore {
    TermScore {
        p_value: t.p_value,
        weight: 1.0,
        cv: t.cv,
        cv_on_kept: None,
        storable: true,
        members_pass: true,
    }
}

/// A term's row, with its detection limit when not accepted: one coefficient of standard
/// error `√(σ²·(XᵀX)⁻¹_last)` on its axis; the held-out rule with the mean parameter count
/// over the three axes ([`super::limits`]'s module docs).
fn row(
    s: &State,
    term: &Term,
    t: &Tried,
    passed: bool,
    sigma2: f64,
    level: f64,
    n: usize,
) -> BasisRow {
    let limit = (!passed)
        .then(|| {
            let last = t.fit.p - 1;
            let se = (sigma2 * t.fit.inv[(last, last)]).sqrt();
            let nn = n as f64;
            let p0 = s.fits.iter().map(|f| f.p as f64).sum::<f64>() / 3.0;
            let need =
                3.0 * nn * (CV_FACTOR.powi(2) * (1.0 + (p0 + 1.0 / 3.0) / nn) - (1.0 + p0 / nn));
            limit_from(se, 1.0, t.dof as f64, level, need)
        })
        .flatten();
    BasisRow {
        name: term.name(),
        family: term.family.into(),
        unit: term.unit.into(),
        f_stat: t.f_stat,
        p_value: t.p_value,
        cv_rms: t.cv,
        passed,
        detection_limit: limit,
    }
}

fn found_effect(term: &Term, t: &Tried, var: f64, cv0: f64, cv: f64) -> BasisEffect {
    let last = t.fit.p - 1;
    let (value, se) = (t.fit.beta[last], (var * t.fit.inv[(last, last)]).sqrt());
    BasisEffect {
        name: term.name(),
        family: term.family.into(),
        unit: term.unit.into(),
        value,
        std_error: se,
        evidence: format!(
            "something of the form {} on the gyro's {} axis: {value:.4} ± {se:.4} {}, F = {:.2} (1, {} dof), p {}; window RMS {cv0:.4} → {cv:.4} °/s held out",
            term.form,
            AXES[term.axis],
            term.unit,
            t.f_stat,
            t.dof,
            st::fmt_p(t.p_value)
        ),
        f_stat: t.f_stat,
        p_value: t.p_value,
        cv_rms_before: cv0,
        cv_rms: cv,
    }
}

/// The report: the families, their largest limits at the last round, the summary sentence.
pub(super) fn finish(
    terms: &[Term],
    found: Vec<BasisEffect>,
    steps: Vec<BasisStep>,
    cv_start: f64,
    cv_final: f64,
    cv_unit: &str,
) -> OpenBasis {
    let mut families: Vec<String> = Vec::new();
    for t in terms {
        if !families.iter().any(|f| f == t.family) {
            families.push(t.family.into());
        }
    }
    let last = steps.last().map_or(&[][..], |s| &s.candidates[..]);
    let limits: Vec<FamilyLimit> = families
        .iter()
        .filter_map(|fam| {
            let rows = last.iter().filter(|r| &r.family == fam && !r.passed);
            let l = rows
                .filter_map(|r| r.detection_limit)
                .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))))?;
            let unit = last.iter().find(|r| &r.family == fam)?.unit.clone();
            Some(FamilyLimit {
                family: fam.clone(),
                form: family_form(fam).into(),
                unit,
                detection_limit: l,
            })
        })
        .collect();
    let summary = summary_sentence(terms.len(), &found, &limits, cv_start, cv_final, cv_unit);
    OpenBasis {
        families,
        terms: terms.len(),
        cv_rms_start: cv_start,
        cv_rms_final: cv_final,
        found,
        steps,
        limits,
        summary,
    }
}

fn summary_sentence(
    terms: usize,
    found: &[BasisEffect],
    limits: &[FamilyLimit],
    cv_start: f64,
    cv_final: f64,
    cv_unit: &str,
) -> String {
    let lims: Vec<String> = limits
        .iter()
        .map(|l| {
            format!(
                "{} above {} {}",
                l.form,
                crate::stats::sig3(l.detection_limit),
                l.unit
            )
        })
        .collect();
    let lim_text = if lims.is_empty() {
        String::new()
    } else {
        format!(
            "; no other term of the form {} on any axis",
            lims.join(", ")
        )
    };
    if found.is_empty() {
        return format!(
            "open basis ({terms} generic terms, one gyro axis each): nothing beyond the named candidates{lim_text}"
        );
    }
    let what: Vec<&str> = found.iter().map(|f| f.evidence.as_str()).collect();
    format!(
        "open basis ({terms} generic terms, one gyro axis each): {}; held out {cv_start:.4} → {cv_final:.4} {cv_unit}{lim_text}",
        what.join("; then ")
    )
}
