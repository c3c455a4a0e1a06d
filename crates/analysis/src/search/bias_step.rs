//! The bias step: a knock or a jolt that shifts one axis's bias at an unknown moment of the
//! recording, searched before the candidates so that it is named as a step and not absorbed
//! by a smooth term (a linear drift fits a mid-recording step with half its size left at the
//! ends and the middle; a temperature term does the same when the temperature rises steadily).
//!
//! The family: per axis `j` and per gap between consecutive windows `k−1 | k` (with at least
//! [`MIN_SIDE`] windows on each side, so that leaving one window out cannot make the step
//! unidentifiable), a bias on `j` whose regressor is `H − 1` (−1 before the gap, 0 after): its
//! coefficient is the step, bias after minus bias before, and the core calibration is the
//! sensor after the step (the state it is left in and will be used in).
//!
//! The rule, stricter than the open basis's (a step is an event, so it must win against the
//! smooth explanations, not merely be significant):
//! 1. the family is screened against the base model (`open_basis_screening::screen`) and its
//!    best term fitted into a free open slot;
//! 2. its F-test p must be below α divided by the number of step terms screened (Bonferroni
//!    over axes × gaps), and its held-out RMS `cv_factor` lower than the model's;
//! 3. its held-out RMS must be [`BEAT_FACTOR`] lower than that of each smooth alternative on
//!    the same axis fitted instead (bias linear and quadratic in time, and with a temperature
//!    column linear and quadratic in temperature) and than the model's with its worst window
//!    left out (one window that was not still).
//!
//! An accepted step stays in its open slot through the candidate search (fixed there: the
//! candidates' fits free the base and effect blocks only) and the open basis; at the end
//! [`refit_jointly`] frees everything together and the step's row takes the joint value and
//! standard error. Up to [`MAX_STEPS`] steps, one per round. The step is reported, not stored:
//! the calibration file holds the sensor after it.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use crate::detect::windows::WindowStats;
use crate::fit::model::{self as am, Normalisation, Slot, Win};
use crate::report::contract::EffectReport;
use crate::report::effect_names as names;
use crate::search::open_basis_screening::{trial_row, try_open, BasisTerm, OpenTrial, Screening};
use crate::search::options::AnalyzeOptions;
use crate::search::select::cv_over;
use crate::search::trial::{mask_for, State};
use crate::stats as st;
use wiical_core::multipos::MultiPosModel;

/// Windows each side of a step at least.
pub const MIN_SIDE: usize = 3;

/// Steps named at most in one recording.
pub const MAX_STEPS: usize = 2;

/// Factor by which a step's held-out RMS must be below each alternative's (a smooth bias, one
/// window left out). Twice, not the candidates' 1.1: an unmodelled pair of smooth effects
/// (quadratic with a drift) or one window that was not still can let a step beat a single
/// smooth term by a little (the simulator's pairs and outliers did at 1.1); a knock worth
/// naming beats them by far more (5× on a 12 mg step in MPU-9150 unit 0).
pub const BEAT_FACTOR: f64 = 2.0;

/// What the step search reads of the recording.
pub struct StepContext<'a> {
    /// The normalisation (raw scale; normalised time and temperature per window).
    pub nrm: &'a Normalisation,
    /// The windows' statistics (their times on the recording clock).
    pub stats: &'a [WindowStats],
    /// Units of the window means (`raw`, `g`, …).
    pub units: &'static str,
    /// The recording has a temperature column with a range worth testing.
    pub has_temp: bool,
    /// The search settings (α, `cv_factor`).
    pub opts: &'a AnalyzeOptions,
    /// The accelerometer model.
    pub model: MultiPosModel,
}

/// One accepted step: its open slot and where it happened.
#[derive(Debug, Clone, Copy)]
pub struct Step {
    /// The open slot it holds.
    pub slot: usize,
    /// Output axis.
    pub axis: usize,
    /// First window after the step (0-based).
    pub after: usize,
}

/// The gaps a step may sit at (the index of the first window after it): [`MIN_SIDE`]
/// windows each side.
fn gaps(n: usize) -> std::ops::RangeInclusive<usize> {
    MIN_SIDE..=n.saturating_sub(MIN_SIDE)
}

/// The step term at gap `k` on `axis`: the bias regressor −1 before the gap, 0 after. Made
/// when it is scored and dropped after, not held for every gap (3·n terms of n values each
/// were 48·n² bytes: 1 GiB at 4,700 windows).
fn step_term(sc: &StepContext<'_>, k: usize, axis: u8) -> BasisTerm {
    let n = sc.stats.len();
    let (before, after) = (&sc.stats[k - 1], &sc.stats[k]);
    let target = format!(
        "{}, between windows {k} and {} (t = {:.1}–{:.1} s)",
        names::AXES[axis as usize],
        k + 1,
        before.t_last,
        after.t_first
    );
    BasisTerm {
        family: names::BIAS_STEP,
        target,
        slot: Slot::Bias { axis, x: 0.0 },
        unit: sc.units.to_string(),
        same_pattern: Vec::new(),
        xs: Some((0..n).map(|i| if i < k { -1.0 } else { 0.0 }).collect()),
        factor: sc.nrm.scale,
        time_constant_s: None,
        reference: None,
    }
}

/// The step term with the largest positive screening score (the last of equals, in gap then
/// axis order), its gap and score, and how many were screened.
fn strongest_step(
    sc: &StepContext<'_>,
    screening: &Screening,
) -> (Option<(BasisTerm, usize, f64)>, usize) {
    let mut best: Option<(usize, u8, f64)> = None;
    let mut screened = 0;
    for k in gaps(sc.stats.len()) {
        for axis in 0..3u8 {
            let Some(score) = screening.score(&step_term(sc, k, axis)) else {
                continue;
            };
            screened += 1;
            if score > 0.0 && best.is_none_or(|(.., b)| score.total_cmp(&b).is_ge()) {
                best = Some((k, axis, score));
            }
        }
    }
    (
        best.map(|(k, axis, score)| (step_term(sc, k, axis), k, score)),
        screened,
    )
}

/// The smooth alternatives to a step on `axis`: each a list of bias terms fitted together
/// (time, time + time², and with a temperature column temperature, temperature + its square).
fn alternatives(sc: &StepContext<'_>, wins: &[Win], axis: u8) -> Vec<Vec<BasisTerm>> {
    let term = |xs: Vec<f64>| BasisTerm {
        family: names::BIAS_STEP,
        target: String::new(),
        slot: Slot::Bias { axis, x: 0.0 },
        unit: String::new(),
        same_pattern: Vec::new(),
        xs: Some(xs),
        factor: 1.0,
        time_constant_s: None,
        reference: None,
    };
    let tau = |p: i32| term(wins.iter().map(|w| w.tau.powi(p)).collect());
    let theta = |p: i32| term(wins.iter().map(|w| w.theta.powi(p)).collect());
    let mut out = vec![vec![tau(1)], vec![tau(1), tau(2)]];
    if sc.has_temp {
        out.push(vec![theta(1)]);
        out.push(vec![theta(1), theta(2)]);
    }
    out
}

/// The held-out RMS of the model with `terms` added one after the other (`None` when a fit
/// fails or no slot is free).
fn cv_with(terms: &[BasisTerm], state: &State, model: MultiPosModel, wins: &[Win]) -> Option<f64> {
    let mut cur = State {
        parts: state.parts.clone(),
        used: state.used.clone(),
        fit: state.fit.clone(),
        loo: state.loo.clone(),
        floor: state.floor.clone(),
    };
    let mut cur_wins = wins.to_vec();
    let mut cv = None;
    for t in terms {
        let tr = try_open(t, &cur, model, &cur_wins)?;
        cv = Some(tr.cv);
        cur.fit = tr.fit;
        cur.loo = tr.loo;
        cur_wins = tr.wins;
    }
    cv
}

/// The model's held-out RMS over the windows in use but the one with the largest held-out
/// residual: what leaving out one window that was not still would give (`∞` when unknown).
fn cv_without_worst(state: &State) -> f64 {
    let worst = (0..state.loo.len())
        .filter(|&i| state.used[i])
        .filter_map(|i| state.loo[i].map(|r| (i, r.abs())))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i);
    let Some(w) = worst else {
        return f64::INFINITY;
    };
    let mut used = state.used.clone();
    used[w] = false;
    cv_over(&state.loo, &used).unwrap_or(f64::INFINITY)
}

/// One round: the best step if it passes the module's rule, with its trial and the numbers
/// of its evidence.
fn round(
    sc: &StepContext<'_>,
    state: &State,
    wins: &[Win],
) -> Option<(OpenTrial, BasisTerm, usize, String)> {
    let mask = am::with_open(mask_for(sc.model, &state.parts), wins);
    let (best, screened) = strongest_step(sc, &Screening::new(state, &mask, wins)?);
    let (term, after, score) = best?;
    let level = sc.opts.alpha / screened.max(1) as f64;
    let cur_cv = cv_over(&state.loo, &state.used)?;
    let tr = try_open(&term, state, sc.model, wins)?;
    if !(tr.p < level && tr.cv * sc.opts.cv_factor <= cur_cv) {
        return None;
    }
    let axis = match term.slot {
        Slot::Bias { axis, .. } => axis,
        _ => return None,
    };
    let mut beaten = Vec::new();
    for alt in alternatives(sc, wins, axis) {
        let cv_alt = cv_with(&alt, state, sc.model, wins).unwrap_or(f64::INFINITY);
        if !(tr.cv * BEAT_FACTOR <= cv_alt) {
            return None;
        }
        beaten.push(cv_alt);
    }
    if !(tr.cv * BEAT_FACTOR <= cv_without_worst(state)) {
        return None;
    }
    let smooth: Vec<String> = beaten.iter().map(|c| format!("{:.3}", c * 1e3)).collect();
    let evidence = format!(
        "bias step: strongest of {screened} step terms screened (partial r = {:.2} with the \
         residual); F = {:.1}, p {} < {level:.1e} (α/{screened}); CV {:.3} → {:.3} mg, against \
         {} mg with a smooth bias in its place ({})",
        score,
        tr.f,
        st::fmt_p(tr.p),
        cur_cv * 1e3,
        tr.cv * 1e3,
        smooth.join(", "),
        if sc.has_temp {
            "time, time², temperature, temperature²"
        } else {
            "time, time²"
        }
    );
    Some((tr, term, after, evidence))
}

/// Searches for up to [`MAX_STEPS`] bias steps on top of `state` (the base model): each
/// accepted step takes an open slot in `wins` and its fit becomes `state`'s. Returns the
/// steps and their report rows (empty, and `state` and `wins` untouched, when none passes).
pub fn search(
    sc: &StepContext<'_>,
    state: &mut State,
    wins: &mut Vec<Win>,
) -> (Vec<Step>, Vec<EffectReport>) {
    let mut steps = Vec::new();
    let mut rows = Vec::new();
    while steps.len() < MAX_STEPS {
        let Some((tr, term, after, evidence)) = round(sc, state, wins) else {
            break;
        };
        let cur_cv = cv_over(&state.loo, &state.used);
        let axis = match term.slot {
            Slot::Bias { axis, .. } => axis as usize,
            _ => break,
        };
        let row = trial_row(&term, &tr, cur_cv, evidence);
        steps.push(Step {
            slot: tr.slot,
            axis,
            after,
        });
        rows.push(row);
        state.fit = tr.fit;
        state.loo = tr.loo;
        *wins = tr.wins;
    }
    (steps, rows)
}

/// Refits the final model with every open slot free (the steps were held fixed through the
/// candidate search) and writes each step's joint value and standard error, in the
/// recording's units and in mg through the fitted scale, into its row. Leaves `state` as it
/// was when the joint fit fails.
pub fn refit_jointly(
    sc: &StepContext<'_>,
    state: &mut State,
    wins: &[Win],
    steps: &[Step],
    rows: &mut [EffectReport],
) {
    let mask = am::with_open(mask_for(sc.model, &state.parts), wins);
    let Some(fit) = am::fit(&state.fit.p, &mask, wins, &state.used) else {
        return;
    };
    let se = am::standard_errors(&fit, &mask, wins, &state.used);
    if let Some(loo) = crate::fit::press::loo(&fit, &mask, wins, &state.used) {
        state.loo = loo;
    }
    let k = sc.nrm.to_calibration(&fit.p).matrix;
    for (s, row) in steps.iter().zip(rows.iter_mut()) {
        let value = fit.p[am::OPEN + s.slot] * sc.nrm.scale;
        let err = se[am::OPEN + s.slot] * sc.nrm.scale;
        let mut values = [0.0; 3];
        let mut errs = [0.0; 3];
        values[s.axis] = value;
        errs[s.axis] = err;
        // The scale's diagonal, g per raw unit: the step in mg for the sentence.
        let g_per_unit = f64::from(k[s.axis][s.axis]);
        row.evidence = format!(
            "step of {}'s bias by {:.2} ± {:.2} mg ({value:.4e} ± {err:.1e} {}) from window {} \
             on; {}",
            names::AXES[s.axis],
            value * g_per_unit * 1e3,
            err * g_per_unit.abs() * 1e3,
            sc.units,
            s.after + 1,
            row.evidence
        );
        row.values = Some(values);
        row.std_errors = Some(errs);
    }
    state.fit = fit;
}
