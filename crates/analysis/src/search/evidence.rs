//! Evidence: the sentences that say why an effect was added (which residual pattern, the
//! tests, the runner-up and whether the two are separable) and the verdict paragraph. Numbers
//! are formatted here once, so the report and the text output agree.

use crate::fit::model::{self as am, Blocks, Fit, Normalisation, Params, Part, Term, Win};
use crate::report::contract::{EffectReport, ModelSummary};
use crate::search::outliers::OutlierTrial;
use crate::search::select::{cv_over, paired_p};
use crate::search::trial::{DropTest, TermTrial};
use crate::stats as st;
use std::fmt::Write as _;

/// `[a, b, c]` with `prec` decimals.
pub fn fmt_vec(v: &[f64; 3], prec: usize) -> String {
    format!("[{:.p$}, {:.p$}, {:.p$}]", v[0], v[1], v[2], p = prec)
}

pub use crate::stats::fmt_p;

/// Per-axis values of a part in reporting units: (values, std errors, unit); the axes the
/// part does not free are 0 (a single-axis part reports its one axis).
pub fn term_values(
    part: Part,
    nrm: &Normalisation,
    p: &Params,
    se: &Params,
    duration: f64,
) -> ([f64; 3], [f64; 3], String) {
    let (vals, ses, unit) = block_values(part.term, nrm, p, se, duration);
    let keep = |v: [f64; 3]| std::array::from_fn(|a| if part.axes[a] { v[a] } else { 0.0 });
    (keep(vals), keep(ses), unit)
}

/// Per-axis values of a whole block in reporting units: (values, std errors, unit).
fn block_values(
    t: Term,
    nrm: &Normalisation,
    p: &Params,
    se: &Params,
    duration: f64,
) -> ([f64; 3], [f64; 3], String) {
    let (pt, set) = (Blocks::of(p).term(t), Blocks::of(se).term(t));
    let (factor, unit) = unit_factors(t, nrm, p, duration);
    // Standard errors scale like the values (each is a fixed multiple of its parameter).
    let vals = std::array::from_fn(|a| factor[a] * pt[a]);
    let ses = std::array::from_fn(|a| (factor[a] * set[a]).abs());
    (vals, ses, unit)
}

/// Per axis, the factor from block `t`'s normalised parameter to its reporting unit, and the
/// unit (linear in the parameter: the fitted value's and its standard error's, and a
/// detection limit's, [`crate::search::limits`]). Raw-unit bias terms are reported in mg via
/// the diagonal of K at `p` (g per raw unit).
pub fn unit_factors(t: Term, nrm: &Normalisation, p: &Params, duration: f64) -> ([f64; 3], String) {
    let k = nrm.raw(p).matrix;
    let s = nrm.scale;
    let kd: [f64; 3] = std::array::from_fn(|a| k[a][a]);
    match t {
        Term::Quadratic => ([1e3; 3], "mg/g² (k2)".to_string()),
        Term::Cubic => ([1e3; 3], "mg/g³ (k3)".to_string()),
        Term::Drift => (
            kd.map(|x| s / nrm.t_scale * x * 1e3 * duration),
            format!("mg of bias change over {duration:.0} s"),
        ),
        Term::BiasTemp => (
            kd.map(|x| s / nrm.temp_scale * x * 1e3),
            "mg/°C".to_string(),
        ),
        Term::ScaleTemp => ([1e6 / nrm.temp_scale; 3], "ppm/°C".to_string()),
        Term::Drift2 => (
            kd.map(|x| s * x * 1e3),
            "mg of curvature (bias at the ends minus the middle, normalised time)".to_string(),
        ),
    }
}

/// The noise floor a verdict compares with, milli-g (NaN: unknown).
pub struct Floor {
    /// From the windows' variances.
    pub mg: f64,
    /// From batch means, when computed.
    pub batch_mg: Option<f64>,
}

/// What the last step leaves unknown or bounds, for the verdict.
pub struct NotFound<'a> {
    /// Candidates the windows were too few to test at all, with how many more windows each
    /// needs — the verdict then never says that nothing is missing.
    pub untested: &'a [(String, usize)],
    /// The whole effects' detection limits in words ([`crate::search::limits::phrase`]):
    /// what a search that found nothing can say instead of "nothing is missing".
    pub limits: &'a [String],
}

/// The one-paragraph conclusion of a multi-position analysis.
pub fn verdict_text(
    base: &ModelSummary,
    fin: &ModelSummary,
    effects: &[EffectReport],
    floor: &Floor,
    alpha: f64,
    cv_possible: bool,
    not_found: &NotFound<'_>,
) -> String {
    let untested = not_found.untested;
    let above = base.chi2_p.is_some_and(|p| p < alpha);
    let mut s = base_sentence(base, floor, above);
    if !cv_possible {
        s.push_str("Cross-validation is not possible with these windows (a held-out window leaves the model undetermined), so no effect was tested.");
        return s;
    }
    if effects.is_empty() {
        s.push_str(&nothing_found(untested, not_found.limits));
        if above {
            s.push_str(" The excess over the floor is not explained by any candidate (slow noise, imperfect stillness, or an effect outside the library).");
        }
    } else {
        let names: Vec<&str> = effects.iter().map(|e| e.name.as_str()).collect();
        let untested_note = untested_sentence(untested);
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
        if let Some(u) = untested_note {
            s.push(' ');
            s.push_str(&u);
        }
    }
    s
}

/// The base model against the noise floor: "Base model: RMS … (CV …) against a noise floor of
/// …: the residual is above / consistent with the floor (χ² …)." (or: the floor is unknown).
fn base_sentence(base: &ModelSummary, floor: &Floor, above: bool) -> String {
    let (floor_mg, batch_mg) = (floor.mg, floor.batch_mg);
    let mut s = String::new();
    if !floor_mg.is_finite() {
        // Window means without their sample counts (a window-mean table): var/n is unknown.
        let _ = write!(
            s,
            "Base model: RMS {:.3} mg (CV {}); the noise floor is unknown (the windows' sample counts are not given), so the residual is not compared with it. ",
            base.rms_mg,
            base.cv_rms_mg
                .map_or("n/a".into(), |x| format!("{x:.3} mg")),
        );
    } else {
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
    }
    s
}

/// The sentence when no candidate was added: how large each could still be (its detection
/// limit), and which could not be tested at all.
fn nothing_found(untested: &[(String, usize)], limits: &[String]) -> String {
    let bounds = if limits.is_empty() {
        String::new()
    } else {
        format!(
            ": {} (detection limits: the smallest each would have shown in 80 % of recordings like this one)",
            limits.join(", ")
        )
    };
    match untested_sentence(untested) {
        None => format!("No candidate effect passes both the F-test and the cross-validation rule{bounds}."),
        Some(u) => format!("No candidate effect that could be tested passes both the F-test and the cross-validation rule{bounds}. {u}"),
    }
}

/// "Not tested: … (needs N more windows), …: nothing is known about them." (`None` when every
/// candidate was tested.)
fn untested_sentence(untested: &[(String, usize)]) -> Option<String> {
    if untested.is_empty() {
        return None;
    }
    let list: Vec<String> = untested
        .iter()
        .map(|(name, k)| {
            format!(
                "{name} (needs {k} more window{})",
                if *k == 1 { "" } else { "s" }
            )
        })
        .collect();
    Some(format!(
        "Not tested, too few windows: {}; whether they are missing is not known (hold more poses to test them).",
        list.join(", ")
    ))
}

/// Which residual pattern points to a term.
fn pattern(term: Term) -> &'static str {
    match term {
        Term::Quadratic => "residual follows the odd, cubic-in-direction pattern of a per-axis quadratic nonlinearity (k2·u²)",
        Term::Cubic => "residual follows the even, 4th-order-in-direction pattern of a per-axis cubic nonlinearity (k3·u³)",
        Term::Drift | Term::Drift2 => "residual correlates with window time (bias moving along a fixed direction)",
        Term::BiasTemp => "residual correlates with window temperature (bias moving along a fixed direction)",
        Term::ScaleTemp => "residual correlates with window temperature through the scale factors",
    }
}

fn time_like(t: &[Part]) -> bool {
    t.iter()
        .any(|x| matches!(x.term, Term::Drift | Term::Drift2))
}

fn temp_like(t: &[Part]) -> bool {
    t.iter()
        .any(|x| matches!(x.term, Term::BiasTemp | Term::ScaleTemp))
}

/// What the current model and the step know, for the evidence of an accepted term.
pub struct TermContext<'a> {
    /// The current model's fit.
    pub current: &'a Fit,
    /// Windows in use.
    pub used: &'a [bool],
    /// The windows.
    pub wins: &'a [Win],
    /// The current CV over the windows in use, g.
    pub cur_cv: Option<f64>,
    /// Correlation of window time and temperature.
    pub time_temp_r: Option<f64>,
}

/// Evidence for the accepted term `bt`: the pattern and its strength, the tests, the fitted
/// values, and the comparison with the runner-up (and with the time/temperature counterpart,
/// which the data may not separate).
pub fn term_evidence(
    ctx: &TermContext<'_>,
    bt: &TermTrial,
    trials: &[TermTrial],
    (vals, ses, unit): (&[f64; 3], &[f64; 3], &str),
) -> String {
    let used_idx = || (0..ctx.wins.len()).filter(|i| ctx.used[*i]);
    let r_cur: Vec<f64> = used_idx()
        .map(|i| am::residual(&ctx.current.p, &ctx.wins[i]))
        .collect();
    let r_new: Vec<f64> = used_idx()
        .map(|i| am::residual(&bt.fit.p, &ctx.wins[i]))
        .collect();
    let sig: Vec<f64> = r_cur.iter().zip(&r_new).map(|(a, b)| a - b).collect();
    let r_sig = st::correlation(&r_cur, &sig);
    let explained = 1.0 - bt.fit.rss / ctx.current.rss.max(1e-300);
    let mut evidence = format!(
        "{}: r = {r_sig:.2}, explains {:.0}% of the residual variance; CV {:.3} → {:.3} mg, F({},{}) = {:.1}, p {}; fitted {} ± {} {unit}",
        pattern(bt.parts[0].term),
        100.0 * explained,
        ctx.cur_cv.unwrap_or(f64::NAN) * 1e3,
        bt.cv * 1e3,
        bt.dp,
        bt.fit.n - bt.fit.k,
        bt.f,
        fmt_p(bt.p),
        fmt_vec(vals, 3),
        fmt_vec(ses, 3),
    );
    compare_with_others(ctx, bt, trials, &mut evidence);
    evidence
}

/// Head to head with the runner-up: the best other candidate that also passes, else the best
/// other one by CV; and always time against temperature when one of them won.
fn compare_with_others(
    ctx: &TermContext<'_>,
    bt: &TermTrial,
    trials: &[TermTrial],
    evidence: &mut String,
) {
    let others = || {
        trials
            .iter()
            .filter(|t| t.candidate != bt.candidate && !t.is_combination())
    };
    let runner = others()
        .filter(|t| t.passes_rules && t.candidate.storable())
        .min_by(|a, b| a.cv.total_cmp(&b.cv))
        .or_else(|| others().min_by(|a, b| a.cv.total_cmp(&b.cv)));
    // The whole block of a term (the effect as one candidate, not one of its axes).
    let block_of = |term: Term| {
        trials.iter().find(|t| {
            !t.is_combination()
                && !t.axis_member
                && t.candidate.storable()
                && t.parts[0].term == term
        })
    };
    let counterpart = if time_like(&bt.parts) {
        block_of(Term::BiasTemp)
    } else if temp_like(&bt.parts) {
        block_of(Term::Drift)
    } else {
        None
    };
    // A single axis is also compared with its whole block: is the effect on the other axes too?
    let whole = bt.axis_member.then(|| block_of(bt.parts[0].term)).flatten();
    let mut compared: Vec<&TermTrial> = runner.into_iter().collect();
    for c in counterpart.into_iter().chain(whole) {
        if !compared.iter().any(|t| t.name() == c.name()) {
            compared.push(c);
        }
    }
    let mut said_corr = false;
    for (k, ru) in compared.iter().enumerate() {
        let pp = paired_p(&bt.loo, &ru.loo, ctx.used);
        let _ = write!(
            evidence,
            "; {} {}: CV {:.3} mg (paired test on held-out errors p {})",
            if k == 0 { "runner-up" } else { "against" },
            ru.name(),
            ru.cv * 1e3,
            pp.map_or("n/a".into(), fmt_p)
        );
        let related = (time_like(&bt.parts) && temp_like(&ru.parts))
            || (temp_like(&bt.parts) && time_like(&ru.parts));
        if related && !said_corr {
            if let Some(r) = ctx.time_temp_r {
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
                bt.name(),
                ru.name(),
                bt.name()
            );
        }
    }
}

/// What an accepted combination's member is judged against.
pub struct MemberContext<'a> {
    /// The fit with the other members only (the current model when there is no other).
    pub without: &'a Fit,
    /// Windows in use.
    pub used: &'a [bool],
    /// The windows.
    pub wins: &'a [Win],
    /// Correlation of window time and temperature.
    pub time_temp_r: Option<f64>,
}

/// Evidence for one member of an accepted combination `combo`: the pattern it explains in
/// what the other members leave, its drop test, its fitted values, and — for a time- or
/// temperature-like member — the same combination with its counterpart instead.
pub fn member_evidence(
    ctx: &MemberContext<'_>,
    combo: &TermTrial,
    d: &DropTest,
    trials: &[TermTrial],
    (vals, ses, unit): (&[f64; 3], &[f64; 3], &str),
) -> String {
    let mut evidence = member_summary(ctx, combo, d, (vals, ses, unit));
    let counterpart = match d.part.term {
        Term::Drift => Some(Term::BiasTemp),
        Term::BiasTemp => Some(Term::Drift),
        _ => None,
    };
    if let Some(c) = counterpart.filter(|c| !combo.parts.iter().any(|p| p.term == *c)) {
        against_counterpart(ctx, combo, d, trials, c, &mut evidence);
    }
    evidence
}

/// The first sentence of [`member_evidence`]: the other members, the pattern the member
/// explains in the residual they leave (share of variance and correlation), its drop test and
/// its fitted values. Apart so that the counterpart comparison reads on its own.
fn member_summary(
    ctx: &MemberContext<'_>,
    combo: &TermTrial,
    d: &DropTest,
    (vals, ses, unit): (&[f64; 3], &[f64; 3], &str),
) -> String {
    let used_idx = || (0..ctx.wins.len()).filter(|i| ctx.used[*i]);
    let r_rest: Vec<f64> = used_idx()
        .map(|i| am::residual(&ctx.without.p, &ctx.wins[i]))
        .collect();
    let r_all: Vec<f64> = used_idx()
        .map(|i| am::residual(&combo.fit.p, &ctx.wins[i]))
        .collect();
    let sig: Vec<f64> = r_rest.iter().zip(&r_all).map(|(a, b)| a - b).collect();
    let r_sig = st::correlation(&r_rest, &sig);
    let explained = 1.0 - combo.fit.rss / ctx.without.rss.max(1e-300);
    let others: Vec<String> = combo
        .parts
        .iter()
        .filter(|t| **t != d.part)
        .map(|t| t.name())
        .collect();
    format!(
        "found together with {} ({} at once): {}: the others leave CV {:.3} mg, with it {:.3} mg; it explains {:.0}% of the residual variance they leave (r = {r_sig:.2}); without it F({},{}) = {:.1}, p {}; fitted {} ± {} {unit}",
        others.join(" + "),
        combo.name(),
        pattern(d.part.term),
        d.cv_without * 1e3,
        combo.cv * 1e3,
        100.0 * explained,
        d.part.count(),
        combo.fit.n - combo.fit.k,
        d.f,
        fmt_p(d.p),
        fmt_vec(vals, 3),
        fmt_vec(ses, 3),
    )
}

/// Appends to `evidence` the comparison of a time- or temperature-like member with its
/// counterpart `c` (the same combination with `c` in its place, when it was tried): their CVs
/// and the paired test on held-out errors, the window time–temperature correlation, and a
/// warning when both pass and the data cannot tell them apart (drift and temperature look
/// alike when the temperature rises steadily).
fn against_counterpart(
    ctx: &MemberContext<'_>,
    combo: &TermTrial,
    d: &DropTest,
    trials: &[TermTrial],
    c: Term,
    evidence: &mut String,
) {
    let swapped: Vec<Part> = combo
        .parts
        .iter()
        .map(|t| {
            if *t == d.part {
                Part {
                    term: c,
                    axes: t.axes,
                }
            } else {
                *t
            }
        })
        .collect();
    let Some(alt) = trials.iter().find(|t| t.adds(&swapped)) else {
        return;
    };
    let pp = paired_p(&combo.loo, &alt.loo, ctx.used);
    let _ = write!(
        evidence,
        "; against {}: CV {:.3} mg (paired test on held-out errors p {})",
        alt.name(),
        alt.cv * 1e3,
        pp.map_or("n/a".into(), fmt_p)
    );
    if let Some(r) = ctx.time_temp_r {
        let _ = write!(
            evidence,
            "; window time and temperature correlate r = {r:.2}"
        );
    }
    if alt.passes_rules && pp.is_some_and(|p| p > 0.05) {
        let _ = write!(
            evidence,
            "; {} and {} are NOT separable by these data (both pass; their held-out errors do not differ significantly): chose {} by its lower CV",
            d.part.name(),
            c.name(),
            d.part.name()
        );
    }
}

/// Evidence for rejecting the outlier candidate's windows. `window_times`: each window's
/// first and last sample's time, s; `current_loo`: the current model's held-out
/// residuals (g); `best_term`: the best smooth effect that passes, if any.
pub fn outlier_evidence(
    ot: &OutlierTrial,
    current_loo: &[Option<f64>],
    window_times: &[(f64, f64)],
    best_term: Option<&TermTrial>,
) -> String {
    let cv_before = cv_over(current_loo, &ot.used);
    let cv_after = cv_over(&ot.loo, &ot.used);
    let list: Vec<String> = ot
        .rejected
        .iter()
        .zip(&ot.p_values)
        .map(|(&i, p)| {
            let (first, last) = window_times[i];
            format!(
                "{} (t = {:.1}–{:.1} s, held-out residual {:+.2} mg, p {})",
                i + 1,
                first,
                last,
                current_loo[i].unwrap_or(f64::NAN) * 1e3,
                fmt_p(*p)
            )
        })
        .collect();
    let smooth = best_term
        .map(|bt| {
            format!(
                "; the best smooth effect ({}) leaves CV {:.3} mg on the other windows against {:.3} mg with rejection",
                bt.name(),
                cv_over(&bt.loo, &ot.used).unwrap_or(f64::NAN) * 1e3,
                cv_after.unwrap_or(f64::NAN) * 1e3
            )
        })
        .unwrap_or_else(|| "; no smooth effect explains them (none passes its test)".into());
    let under = ot
        .screened_with
        .as_ref()
        .map_or(String::new(), |n| {
            let (after, before) = ot.judged_cv.unwrap_or((f64::NAN, None));
            format!(
                " (screened with {n} added to the model, which the windows hide from its own test: with it the kept windows' CV goes {:.3} → {:.3} mg on rejection)",
                before.unwrap_or(f64::NAN) * 1e3,
                after * 1e3
            )
        });
    format!(
        "{} window(s) sit far outside the held-out spread of the others (robust biweight screen, then a prediction-error t-test against the fit on the others, Bonferroni over windows){under}: {}{}; CV of the kept windows {:.3} → {:.3} mg",
        ot.rejected.len(),
        list.join("; "),
        smooth,
        cv_before.unwrap_or(f64::NAN) * 1e3,
        cv_after.unwrap_or(f64::NAN) * 1e3,
    )
}

/// The sentence for a diagnostic-only candidate that would pass.
pub fn diagnostic_text(d: &TermTrial, cur_cv: Option<f64>) -> String {
    format!(
        "{} would pass (CV {:.3} → {:.3} mg, F({},{}) = {:.1}, p {}) but the core's Effects cannot store it",
        d.name(),
        cur_cv.unwrap_or(f64::NAN) * 1e3,
        d.cv * 1e3,
        d.dp,
        d.fit.n - d.fit.k,
        d.f,
        fmt_p(d.p)
    )
}

/// The note of the outlier candidate's report row.
pub fn outlier_note(rejected: &[usize], cv_ok: bool, cv_factor: f64) -> String {
    format!(
        "windows {} stand out{}",
        rejected
            .iter()
            .map(|i| (i + 1).to_string())
            .collect::<Vec<_>>()
            .join(", "),
        if cv_ok {
            String::new()
        } else {
            format!(", but rejecting them does not improve the CV of the others by {cv_factor:.2}")
        }
    )
}
