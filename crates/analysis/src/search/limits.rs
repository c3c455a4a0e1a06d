//! Detection limits of the accelerometer's candidates: for a candidate a step did not accept,
//! the smallest size this recording would have shown at the step's level ("no bias-drift
//! above 0.031 mg of bias change over 508 s"), by the rule every search states its limits by
//! ([`crate::stats::limit_from`]: the F-test at 80 % power **and** the held-out RMS lowered
//! by the CV factor, whichever needs more).
//!
//! What the size measures depends on the candidate:
//!
//! * **One effect** (a block, one axis of it, the curved drift): its coefficient in the unit
//!   its fitted value is reported in ([`crate::search::evidence::unit_factors`]), on its
//!   worst-determined axis (so the limit holds on every axis). The standard errors are those
//!   of the current model with the candidate's parameters freed, linearised at the current
//!   fit (the effect at zero), with the step's reference variance
//!   ([`crate::search::floor::reference_variance`]).
//! * **Several effects at once** (a combination): no single unit, so the RMS over the windows
//!   of what it would add to ‖a‖ − 1 beyond what the current model absorbs, mg. Its F-test
//!   sees exactly that: the non-centrality is the squared norm of that part over σ².
//! * **Outliers**: one window's held-out ‖a‖ − 1, mg, at the pose where a wrong window is
//!   hardest to see. The window must pass the robust screen (3 robust scales, taken as the
//!   residual σ, plus the 80 % quantile of its noise), its prediction-error t-test at the
//!   step's level over the windows (Bonferroni), and its rejection must lower the other
//!   windows' held-out RMS by the CV factor. A window of leverage `h` moves each other
//!   window's held-out prediction by `δ·hᵢⱼ/(1 − hᵢᵢ)`, adding `δ²h(1 − h)/((n − 1)(1 − h̄)²)`
//!   to their mean square (`Σᵢ hᵢⱼ² = h(1 − h)`): a low-leverage pose hardly disturbs the
//!   others, so it must be far off before rejecting it pays; the limit is the largest over
//!   the windows in use.
//!
//! The simulation test (`crates/analysis/tests/detection_limits.rs`) injects each simulated
//! effect at twice the limit a clean recording states and finds it in at least 80 % of runs.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use crate::fit::model::{self as am, Mask, Normalisation, Part, Term, Win, NP};
use crate::search::candidate::Candidate;
use crate::search::evidence::unit_factors;
use crate::search::select::MIN_SPARE_OUTLIER;
use crate::search::trial::{mask_for, State, TermTrial};
use crate::stats as st;
use nalgebra::DMatrix;
use wiical_core::multipos::MultiPosModel;

/// Unit of a combination's limit.
pub const COMBINATION_UNIT: &str = "mg RMS added to ‖a‖ − 1 beyond the current model";

/// Unit of the outlier candidate's limit.
pub const OUTLIER_UNIT: &str = "mg off in one window's ‖a‖ − 1 (at the least influential pose)";

/// Robust scales beyond which a window is a suspect ([`crate::search::outliers`]'s screen).
const SUSPECT_SCALES: f64 = 3.0;

/// The standard normal's 80 % quantile: a window's error exceeds the screen's threshold in
/// 80 % of cases when its mean is this many σ beyond it.
const Z_POWER: f64 = 0.841_621_233_572_914_3;

/// What the limits need of the analysis.
pub struct LimitContext<'a> {
    /// The base model (full or diagonal).
    pub model: MultiPosModel,
    /// The windows.
    pub wins: &'a [Win],
    /// The normalisation (for the reporting units).
    pub nrm: &'a Normalisation,
    /// Recording duration, s (the bias drift's unit).
    pub duration: f64,
    /// The factor the held-out RMS must fall by.
    pub cv_factor: f64,
}

/// The current model's free-parameter count, its residual dof and the step's reference
/// variance (g²); `None` without residual dof.
fn current(ctx: &LimitContext<'_>, state: &State) -> Option<(usize, usize, f64)> {
    let k0 = count(&mask_for(ctx.model, &state.parts));
    let n = state.n_used();
    let dof = n.checked_sub(k0).filter(|d| *d > 0)?;
    Some((k0, n, state.reference_variance(state.fit.rss, dof as f64)))
}

fn count(mask: &Mask) -> usize {
    mask.iter().filter(|m| **m).count()
}

/// The limit of parametric candidate `t` (not accepted) at `level` (its share of the step's
/// level already applied): the size and its unit; `None` when it cannot be stated (no
/// residual dof, a singular design).
pub fn term_limit(
    ctx: &LimitContext<'_>,
    state: &State,
    t: &TermTrial,
    level: f64,
) -> Option<(f64, String)> {
    let (k0, n, s2) = current(ctx, state)?;
    let mut parts = state.parts.clone();
    parts.extend(t.parts.iter().copied());
    let mask = mask_for(ctx.model, &parts);
    let k1 = count(&mask);
    let d2 = n.checked_sub(k1).filter(|d| *d > 0)? as f64;
    let need = st::cv_need(n as f64, k1 as f64, k0 as f64, ctx.cv_factor);
    let q = t.dp as f64;
    if t.is_combination() {
        let se = (s2 / n as f64).sqrt() * 1e3;
        let l = st::limit_from(se, q, d2, level, need)?;
        return Some((l, COMBINATION_UNIT.to_string()));
    }
    // The coefficient the limit is stated for: the curved drift's curvature, else the part.
    let part = if t.candidate == Candidate::BiasDriftCurved {
        *t.parts.iter().find(|p| p.term == Term::Drift2)?
    } else {
        t.parts[0]
    };
    let se = standard_errors(&state.fit.p, &mask, ctx.wins, &state.used, s2)?;
    let (factor, unit) = unit_factors(part.term, ctx.nrm, &state.fit.p, ctx.duration);
    let se_max = worst_axis(part, &factor, &se);
    let l = st::limit_from(se_max, q, d2, level, need)?;
    Some((l, unit))
}

/// The largest standard error, in the reporting unit, over the axes `part` frees.
fn worst_axis(part: Part, factor: &[f64; 3], se: &[f64; NP]) -> f64 {
    (0..3)
        .filter(|a| part.axes[*a])
        .map(|a| (factor[a] * se[part.term.offset() + a]).abs())
        .fold(0.0, f64::max)
}

/// The free parameters' Jacobian rows (one per window in use) at `p`.
fn jacobian(p: &am::Params, mask: &Mask, wins: &[Win], used: &[bool]) -> DMatrix<f64> {
    let free: Vec<usize> = (0..NP).filter(|i| mask[*i]).collect();
    let rows: Vec<&Win> = wins
        .iter()
        .zip(used)
        .filter(|(_, u)| **u)
        .map(|(w, _)| w)
        .collect();
    DMatrix::from_fn(rows.len(), free.len(), |i, j| {
        am::residual_and_grad(p, rows[i]).1[free[j]]
    })
}

/// `(JᵀJ)⁻¹` over the free parameters (`None` when singular).
fn normal_inverse(j: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    (j.transpose() * j).cholesky().map(|c| c.inverse())
}

/// Standard errors `√(σ²·(JᵀJ)⁻¹)` of the free parameters at `p`, in the order of the full
/// parameter vector (0 for fixed ones).
fn standard_errors(
    p: &am::Params,
    mask: &Mask,
    wins: &[Win],
    used: &[bool],
    s2: f64,
) -> Option<[f64; NP]> {
    let inv = normal_inverse(&jacobian(p, mask, wins, used))?;
    let mut out = [0.0; NP];
    for (a, i) in (0..NP).filter(|i| mask[*i]).enumerate() {
        out[i] = (s2 * inv[(a, a)]).max(0.0).sqrt();
    }
    Some(out)
}

/// The outlier candidate's limit (module docs) at the step's `level`, mg; `None` when the
/// windows are too few for the screen or the design is singular.
pub fn outlier_limit(ctx: &LimitContext<'_>, state: &State, level: f64) -> Option<f64> {
    let (k, n, s2_ref) = current(ctx, state)?;
    if n < k + MIN_SPARE_OUTLIER {
        return None;
    }
    let mask = mask_for(ctx.model, &state.parts);
    let j = jacobian(&state.fit.p, &mask, ctx.wins, &state.used);
    let inv = normal_inverse(&j)?;
    let s2 = state.fit.rss / (n - k) as f64;
    let (nf, kf) = (n as f64, k as f64);
    let h_bar = kf / nf;
    let c2 = ctx.cv_factor.powi(2);
    // The others' held-out mean square must rise by this (in σ² units) before rejection pays.
    let gain = (c2 * (1.0 + kf / (nf - 1.0)) - (1.0 + kf / nf)).max(0.0);
    let mut worst: Option<f64> = None;
    for i in 0..j.nrows() {
        let g = j.row(i);
        let h = (g * &inv * g.transpose())[(0, 0)].clamp(1e-12, 1.0 - 1e-12);
        let se = (s2_ref / (1.0 - h)).sqrt();
        let need = s2 / s2_ref * (nf - 1.0) * (1.0 - h_bar).powi(2) / h * gain;
        let test = st::limit_from(se, 1.0, nf - kf - 1.0, level / nf, need)?;
        let screen = (SUSPECT_SCALES + Z_POWER) * (s2 / (1.0 - h)).sqrt();
        let l = test.max(screen) * 1e3;
        worst = Some(worst.map_or(l, |w: f64| w.max(l)));
    }
    worst
}

/// A candidate not found, in words, from its report row's name, limit and unit: "no quadratic
/// above 0.0523 mg/g² (k2)", "no quadratic+cubic adding more than 0.011 mg RMS to ‖a‖ − 1
/// beyond the current model", "no window off by more than 0.61 mg (at the least influential
/// pose)". Three significant digits: the limit rests on a variance estimated from tens of
/// windows, good to a few per cent at best.
pub fn phrase(name: &str, limit: f64, unit: &str) -> String {
    let l = st::sig3(limit);
    if unit == OUTLIER_UNIT {
        format!("no window off by more than {l} mg (at the least influential pose)")
    } else if unit == COMBINATION_UNIT {
        format!("no {name} adding more than {l} {unit}").replace("mg RMS added to", "mg RMS to")
    } else {
        format!("no {name} above {l} {unit}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phrases_say_what_each_limit_measures() {
        assert_eq!(
            phrase("quadratic", 0.052_34, "mg/g² (k2)"),
            "no quadratic above 0.0523 mg/g² (k2)"
        );
        assert_eq!(
            phrase("quadratic+cubic", 0.011, COMBINATION_UNIT),
            "no quadratic+cubic adding more than 0.0110 mg RMS to ‖a‖ − 1 beyond the current model"
        );
        assert_eq!(
            phrase("outliers", 612.4, OUTLIER_UNIT),
            "no window off by more than 612 mg (at the least influential pose)"
        );
    }
}
