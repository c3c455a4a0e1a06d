//! The open basis: after the greedy search over the candidates
//! (`crate::search::analyze`), single terms of physically motivated families are added one
//! at a time, each by the same rule as a candidate (an F-test at a Bonferroni level and the
//! leave-one-window-out RMS at least `cv_factor` lower).
//!
//! A round has two parts.
//!
//! 1. **Screening**, linear in windows × terms: every basis term's first-order pattern in the
//!    window residual at the fitted gravity direction `g` (`correlates::slot_pattern`: a cross term on
//!    output axis `i` with monomial `u_j·u_k` gives `g_i·g_j·g_k`) is projected off the
//!    current model's span (the projection of the correlates,
//!    `correlates::Projector`, over the columns of `correlates::span_of`) and scored by
//!    its partial correlation with the residual. Terms inside the span (the projection leaves
//!    less than 10⁻⁶ of the pattern) are not counted.
//! 2. **Refit**: the best-scoring term only is put into a free open slot of the f64 model
//!    ([`crate::fit::model::Slot`]) and refitted with everything else; it is accepted when its
//!    F-test has p below α divided by the number of terms screened (Bonferroni over the
//!    basis: the screening looked at all of them) and its held-out RMS
//!    ([`crate::fit::press::loo`], the candidates' own) is at least `cv_factor` lower.
//!
//! Families: orientation ([`orientation_terms`], stored in the core's `Effects` cross terms)
//! and time and temperature ([`host_terms`]: the core's `Effects` has no field for them, so
//! they travel in the calibration file's `host_terms` ([`crate::output::host_term_checks`]), each
//! about its regressor's origin, where it vanishes; the core calibration alone is the model
//! at those origins).
//!
//! Rounds repeat until a term fails or the slots ([`am::OPEN_SLOTS`]) or the residual degrees
//! of freedom run out. The orientation family cannot tell output axes apart to first order:
//! `‖a‖` sees a correction only through `g·Δa`, so `z: x·y`, `x: y·z` and `y: x·z` all give
//! `g_x·g_y·g_z`. The basis holds one representative per pattern, on the highest output axis
//! the pattern contains, and the evidence names the terms it stands for.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use crate::fit::model::{self as am, Fit, Slot, Win};
use crate::report::contract::{CvPoint, EffectReport};
use crate::report::effect_names as names;
use crate::report::host_term::{HostReference, HostTerm};
use crate::search::correlates::{slot_pattern, span_of, Projector};
use crate::search::options::AnalyzeOptions;
use crate::search::select::{cv_over, MIN_DOF_TERM};
use crate::search::thermal;
use crate::search::trial::{mask_for, State};
use crate::stats as st;
use wiical_core::multipos::MultiPosModel;

/// One term of the open basis.
#[derive(Debug, Clone, PartialEq)]
pub struct BasisTerm {
    /// Family name ([`crate::report::effect_names`]).
    pub family: &'static str,
    /// What it acts on, e.g. `z: x·y`.
    pub target: String,
    /// The slot it takes (for a cross term: the same in every window).
    pub slot: Slot,
    /// Unit of its coefficient.
    pub unit: String,
    /// The other terms with the same first-order pattern, e.g. `x: y·z, y: x·z`.
    pub same_pattern: Vec<String>,
    /// For a bias or scale term: its regressor per window (normalised time or temperature
    /// powers, [`Win::tau`], [`Win::theta`]); `None` for a cross term.
    pub xs: Option<Vec<f64>>,
    /// Factor from the model's coefficient to the reported value in `unit`.
    pub factor: f64,
    /// For a thermal-lag term: its time constant, s.
    pub time_constant_s: Option<f64>,
    /// For a host term (time or temperature): the raw regressor's origin, where the term
    /// vanishes (the mean window time, temperature, lagged temperature or rate;
    /// [`crate::output::host_term_checks`]); `None` for a cross term.
    pub reference: Option<HostReference>,
}

impl BasisTerm {
    /// The report name, `<family> (<target>)`.
    pub fn name(&self) -> String {
        format!("{} ({})", self.family, self.target)
    }

    /// The slot in window `i`.
    fn slot_at(&self, i: usize) -> Slot {
        let x = self.xs.as_ref().map_or(0.0, |xs| xs[i]);
        match self.slot {
            Slot::Bias { axis, .. } => Slot::Bias { axis, x },
            Slot::Scale { axis, .. } => Slot::Scale { axis, x },
            s => s,
        }
    }

    /// Output axis.
    fn axis(&self) -> usize {
        match self.slot {
            Slot::Bias { axis, .. } | Slot::Scale { axis, .. } | Slot::Cross { axis, .. } => {
                axis as usize
            }
            Slot::Empty => 0,
        }
    }
}

/// `u_x^ex·u_y^ey·u_z^ez` as text: `x·y`, `x²·z`.
fn monomial_name(exps: [u8; 3]) -> String {
    let mut parts = Vec::new();
    for (a, &e) in exps.iter().enumerate() {
        let ax = names::AXES[a];
        match e {
            0 => {}
            1 => parts.push(ax.to_string()),
            2 => parts.push(format!("{ax}²")),
            _ => parts.push(format!("{ax}³")),
        }
    }
    parts.join("·")
}

/// The orientation family: one representative per first-order pattern `g^G` of degree 3
/// (cross-quadratic) and 4 (cross-cubic) that is not a single axis's power (the candidates'
/// quadratic and cubic): output axis `i` the highest axis in `G`, monomial `G − e_i`.
pub fn orientation_terms() -> Vec<BasisTerm> {
    let mut out = Vec::new();
    for (degree, family, unit) in [
        (3u8, names::CROSS_QUADRATIC, "1/g"),
        (4u8, names::CROSS_CUBIC, "1/g²"),
    ] {
        for gx in (0..=degree).rev() {
            for gy in (0..=degree - gx).rev() {
                let g = [gx, gy, degree - gx - gy];
                if g.contains(&degree) {
                    continue;
                }
                let label = |i: usize| {
                    let mut m = g;
                    m[i] -= 1;
                    (m, format!("{}: {}", names::AXES[i], monomial_name(m)))
                };
                let Some(i) = (0..3).rev().find(|&i| g[i] > 0) else {
                    continue;
                };
                let (exps, target) = label(i);
                // Other output axes in the pattern whose monomial is a cross term (not the
                // axis's own power).
                let same_pattern = (0..3)
                    .filter(|&j| j != i && g[j] > 0 && g[j] < degree)
                    .map(|j| label(j).1)
                    .collect();
                out.push(BasisTerm {
                    family,
                    target,
                    slot: Slot::Cross {
                        axis: i as u8,
                        exps,
                    },
                    unit: unit.to_string(),
                    same_pattern,
                    xs: None,
                    factor: 1.0,
                    time_constant_s: None,
                    reference: None,
                });
            }
        }
    }
    out
}

/// What the recording allows of the time and temperature families.
#[derive(Debug, Clone, Copy)]
pub struct HostContext<'a> {
    /// The normalisation (time and temperature scales, raw scale).
    pub nrm: &'a am::Normalisation,
    /// The windows span a time (the recording lasts).
    pub has_time: bool,
    /// The recording has a temperature column with a range worth testing.
    pub has_temp: bool,
    /// Units of the window means (`raw`, `g`, …).
    pub units: &'static str,
    /// The per-sample temperature for the thermal-lag and temperature-rate terms (`None`, or
    /// not [`thermal::SampleTemps::usable`], leaves them out).
    pub samples: Option<&'a thermal::SampleTemps>,
}

/// A polynomial host family: (family, scale term?, power, on temperature?, factor to the
/// unit, unit).
type PolyFamily = (&'static str, bool, i32, bool, f64, String);

/// The polynomial time and temperature families the recording allows ([`host_terms`]).
fn poly_families(hc: &HostContext<'_>) -> Vec<PolyFamily> {
    let (t, th, s) = (hc.nrm.t_scale, hc.nrm.temp_scale, hc.nrm.scale);
    let u = hc.units;
    let mut families: Vec<PolyFamily> = Vec::new();
    if hc.has_time {
        families.push((names::SCALE_DRIFT, true, 1, false, 1.0 / t, "1/s".into()));
        families.push((
            names::SCALE_DRIFT_CURVED,
            true,
            2,
            false,
            1.0 / (t * t),
            "1/s²".into(),
        ));
    }
    if hc.has_temp {
        families.push((
            names::TEMPERATURE_SQUARED,
            false,
            2,
            true,
            s / th.powi(2),
            format!("{u}/°C²"),
        ));
        families.push((
            names::TEMPERATURE_CUBED,
            false,
            3,
            true,
            s / th.powi(3),
            format!("{u}/°C³"),
        ));
        families.push((
            names::TEMPERATURE_SCALE_SQUARED,
            true,
            2,
            true,
            1.0 / th.powi(2),
            "1/°C²".into(),
        ));
        families.push((
            names::TEMPERATURE_SCALE_CUBED,
            true,
            3,
            true,
            1.0 / th.powi(3),
            "1/°C³".into(),
        ));
    }
    families
}

/// The time and temperature families, per axis: scale linear and quadratic in time
/// (`scale-drift`, `scale-drift-curved`, about the mean window time) and, with a temperature
/// column, bias and scale quadratic and cubic in temperature about the mean window
/// temperature (the calibration's `temp_ref_c`), then the thermal-lag and rate terms. Host
/// terms: the core's `Effects` has no field for them; each carries its origin.
pub fn host_terms(wins: &[Win], hc: &HostContext<'_>) -> Vec<BasisTerm> {
    let families = poly_families(hc);
    let time_ref = HostReference {
        time_s: Some(hc.nrm.t_mean),
        ..Default::default()
    };
    let temp_ref = HostReference {
        temperature_c: Some(hc.nrm.temp_mean),
        ..Default::default()
    };
    let mut out = Vec::new();
    for (family, scale, power, temp, factor, unit) in families {
        let xs: Vec<f64> = wins
            .iter()
            .map(|w| if temp { w.theta } else { w.tau }.powi(power))
            .collect();
        for axis in 0..3u8 {
            out.push(BasisTerm {
                family,
                target: names::AXES[axis as usize].to_string(),
                slot: if scale {
                    Slot::Scale { axis, x: 0.0 }
                } else {
                    Slot::Bias { axis, x: 0.0 }
                },
                unit: unit.clone(),
                same_pattern: Vec::new(),
                xs: Some(xs.clone()),
                factor,
                time_constant_s: None,
                reference: Some(if temp { temp_ref } else { time_ref }),
            });
        }
    }
    if hc.has_temp {
        if let Some(st) = hc.samples.filter(|s| s.usable) {
            out.extend(thermal_terms(st, hc));
        }
    }
    out
}

/// The thermal-lag terms (per axis, per time constant of [`thermal::lag_grid`] up to
/// [`LAG_MAX_FRACTION`] times the duration) and the temperature-rate terms (per axis), from the
/// per-sample temperature. The lagged window temperature is centred and scaled like ϑ (the
/// value is in raw units/°C like `temperature`); the rate is centred and scaled by its RMS
/// spread over the windows.
fn thermal_terms(st: &thermal::SampleTemps, hc: &HostContext<'_>) -> Vec<BasisTerm> {
    let (th, s, u) = (hc.nrm.temp_scale, hc.nrm.scale, hc.units);
    let bias =
        |family, target: String, (xs, r): (Vec<f64>, HostReference), factor, unit: String, tau| {
            (0..3u8).map(move |axis| BasisTerm {
                family,
                target: format!("{}{target}", names::AXES[axis as usize]),
                slot: Slot::Bias { axis, x: 0.0 },
                unit: unit.clone(),
                same_pattern: Vec::new(),
                xs: Some(xs.clone()),
                factor,
                time_constant_s: tau,
                reference: Some(r),
            })
        };
    let mut out = Vec::new();
    for &(tau, ref lagged) in &st.lagged {
        if let Some(xs) = thermal::centred(lagged, th) {
            let target = format!(", τ = {} s", fmt_tau(tau));
            let r = HostReference {
                temperature_c: Some(thermal::mean(lagged)),
                ..Default::default()
            };
            out.extend(bias(
                names::THERMAL_LAG,
                target,
                (xs, r),
                s / th,
                format!("{u}/°C"),
                Some(tau),
            ));
        }
    }
    if let Some(rates) = &st.rates {
        let r = thermal::rms_spread(rates);
        if let Some(xs) = thermal::centred(rates, r) {
            let unit = format!("{u}/(°C/s)");
            let origin = HostReference {
                rate_c_per_s: Some(thermal::mean(rates)),
                ..Default::default()
            };
            out.extend(bias(
                names::TEMPERATURE_RATE,
                String::new(),
                (xs, origin),
                s / r,
                unit,
                None,
            ));
        }
    }
    out
}

/// Longest thermal-lag time constant tried, as a multiple of the recording's duration. Twice
/// the duration, not half: a sensor that lags by about a recording's length (the simulator's
/// 300 s in a 250-s recording) is the case the term is for, and its lagged temperature is
/// still told apart from time and temperature (the CV over τ has its minimum near the truth,
/// `tests/open_basis_lag.rs`); with the grid stopped at half the duration it is never named.
pub const LAG_MAX_FRACTION: f64 = 2.0;

/// A time constant as text, to two significant digits (`10`, `46`, `210`).
fn fmt_tau(tau: f64) -> String {
    let mag = 10f64.powi(tau.log10().floor() as i32 - 1).max(1.0);
    format!("{:.0}", (tau / mag).round() * mag)
}

/// The terms' screening scores against the current model: each term's partial correlation
/// with the residual (0 for a term inside the model's span), and how many were screened.
pub(crate) fn screen(
    terms: &[BasisTerm],
    state: &State,
    mask: &am::Mask,
    wins: &[Win],
) -> Option<(Vec<f64>, usize)> {
    let screening = Screening::new(state, mask, wins)?;
    let mut screened = 0;
    let scores = terms
        .iter()
        .map(|t| {
            let s = screening.score(t);
            screened += usize::from(s.is_some());
            s.unwrap_or(0.0)
        })
        .collect();
    Some((scores, screened))
}

/// What scoring a term against the current model needs, made once for any number of terms:
/// the windows in use, their gravity directions, the projector off the model's span and the
/// residual projected. Terms are then scored one at a time ([`Screening::score`]), so a
/// caller with many terms (the bias step's, one per gap and axis: 3·n of n values each) can
/// make each when it scores it instead of holding them all (memory O(n), not O(n²)).
pub(crate) struct Screening {
    used: Vec<usize>,
    dirs: Vec<[f64; 3]>,
    proj: Projector,
    res: Vec<f64>,
    ss_res: f64,
}

impl Screening {
    /// `None` when the projector off the model's span cannot be made.
    pub(crate) fn new(state: &State, mask: &am::Mask, wins: &[Win]) -> Option<Self> {
        let used: Vec<usize> = (0..wins.len()).filter(|&i| state.used[i]).collect();
        let dirs: Vec<[f64; 3]> = used
            .iter()
            .map(|&i| {
                let a = am::corrected(&state.fit.p, &wins[i]);
                let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt().max(1e-300);
                a.map(|x| x / n)
            })
            .collect();
        let spans: Vec<Vec<f64>> = used
            .iter()
            .zip(&dirs)
            .map(|(&i, g)| span_of(mask, *g, &wins[i]))
            .collect();
        let refs: Vec<&[f64]> = spans.iter().map(|s| s.as_slice()).collect();
        let proj = Projector::new(&refs)?;
        let res = proj.project(
            used.iter()
                .map(|&i| am::residual(&state.fit.p, &wins[i]))
                .collect(),
        );
        let ss_res: f64 = res.iter().map(|x| x * x).sum();
        Some(Self {
            used,
            dirs,
            proj,
            res,
            ss_res,
        })
    }

    /// A term's partial correlation with the residual; `None` when it is not screened (inside
    /// the model's span, or no residual).
    pub(crate) fn score(&self, t: &BasisTerm) -> Option<f64> {
        let xs: Vec<f64> = self
            .used
            .iter()
            .zip(&self.dirs)
            .map(|(&i, g)| slot_pattern(&t.slot_at(i), *g))
            .collect();
        let mean = xs.iter().sum::<f64>() / xs.len().max(1) as f64;
        let total: f64 = xs.iter().map(|x| (x - mean).powi(2)).sum();
        let xp = self.proj.project(xs);
        let ss_x: f64 = xp.iter().map(|x| x * x).sum();
        if !(ss_x > 1e-6 * total && self.ss_res > 0.0) {
            return None;
        }
        let sxy: f64 = xp.iter().zip(&self.res).map(|(x, y)| x * y).sum();
        Some((sxy / (ss_x * self.ss_res).sqrt()).abs())
    }
}

/// A basis term fitted into the model.
pub(crate) struct OpenTrial {
    /// The fit with the term.
    pub(crate) fit: Fit,
    /// Its held-out residuals.
    pub(crate) loo: Vec<Option<f64>>,
    /// The windows with the term in its slot.
    pub(crate) wins: Vec<Win>,
    /// The free parameters.
    mask: am::Mask,
    /// The open slot the term took.
    pub(crate) slot: usize,
    /// Its F statistic and p-value against the model without it.
    pub(crate) f: f64,
    /// See `f`.
    pub(crate) p: f64,
    /// The held-out RMS with it, g.
    pub(crate) cv: f64,
}

/// Fits `term` into the first free slot on top of `state`; `None` when no slot is free, the
/// windows are too few, or the fit or its cross-validation fails.
pub(crate) fn try_open(
    term: &BasisTerm,
    state: &State,
    model: MultiPosModel,
    wins: &[Win],
) -> Option<OpenTrial> {
    let slot = wins.first()?.slots.iter().position(|s| *s == Slot::Empty)?;
    let mut new_wins = wins.to_vec();
    for (i, w) in new_wins.iter_mut().enumerate() {
        w.slots[slot] = term.slot_at(i);
    }
    let mask = am::with_open(mask_for(model, &state.parts), &new_wins);
    let k_new = mask.iter().filter(|m| **m).count();
    let n_used = state.n_used();
    if n_used < k_new + MIN_DOF_TERM {
        return None;
    }
    let fit = am::fit(&state.fit.p, &mask, &new_wins, &state.used)?;
    let dof = (n_used - k_new) as f64;
    let f = (state.fit.rss - fit.rss).max(0.0) / state.reference_variance(fit.rss, dof);
    let p = st::f_sf(f, 1.0, dof);
    let loo = crate::fit::press::loo(&fit, &mask, &new_wins, &state.used)?;
    let cv = cv_over(&loo, &state.used).unwrap_or(f64::INFINITY);
    Some(OpenTrial {
        fit,
        loo,
        wins: new_wins,
        mask,
        slot,
        f,
        p,
        cv,
    })
}

/// What the open-basis stage accepted.
#[derive(Debug, Default)]
pub struct Extension {
    /// One effect row per accepted term, in the order accepted.
    pub effects: Vec<EffectReport>,
    /// The accepted time and temperature terms as the calibration file stores them (raw
    /// units, about their origins; [`crate::output::host_term_checks`]).
    pub host_terms: Vec<HostTerm>,
}

/// Runs the open-basis stage on the final model of the greedy search: adds accepted terms to
/// `state` and their slots to `wins`, and returns their effect rows and host terms (empty,
/// and `state` and `wins` untouched, when nothing is accepted).
pub fn extend(
    state: &mut State,
    wins: &mut Vec<Win>,
    model: MultiPosModel,
    opts: &AnalyzeOptions,
    hc: &HostContext<'_>,
) -> Extension {
    let mut terms = orientation_terms();
    terms.extend(host_terms(wins, hc));
    let mut out = Extension::default();
    let effects = &mut out.effects;
    let mut taken = vec![false; terms.len()];
    while effects.len() < am::OPEN_SLOTS {
        let mask = am::with_open(mask_for(model, &state.parts), wins);
        let Some((scores, screened)) = screen(&terms, state, &mask, wins) else {
            break;
        };
        let best = (0..terms.len())
            .filter(|&t| !taken[t] && scores[t] > 0.0)
            .max_by(|&a, &b| scores[a].total_cmp(&scores[b]));
        let (Some(b), true) = (best, screened > 0) else {
            break;
        };
        let level = opts.alpha / screened as f64;
        let cur_cv = cv_over(&state.loo, &state.used);
        let Some(tr) = try_open(&terms[b], state, model, wins) else {
            break;
        };
        let cv_ok = cur_cv.is_some_and(|c| tr.cv * opts.cv_factor <= c);
        if !(tr.p < level && cv_ok) {
            break;
        }
        taken[b] = true;
        let mut row = effect_row(&terms[b], &tr, state, (level, screened, scores[b], cur_cv));
        if let Some(profile) = lag_profile(&terms, b, state, model, wins) {
            row.evidence.push_str(&lag_profile_text(&profile));
            row.cv_profile = Some(profile);
        }
        out.host_terms.extend(host_term(&terms[b], &row));
        effects.push(row);
        state.fit = tr.fit;
        state.loo = tr.loo;
        *wins = tr.wins;
    }
    out
}

/// An accepted time or temperature term as the calibration file stores it: the effect row's
/// value (already in `unit` per raw regressor) about the term's origin; `None` for a cross
/// term.
fn host_term(term: &BasisTerm, row: &EffectReport) -> Option<HostTerm> {
    let reference = term.reference?;
    let axis = term.axis();
    Some(HostTerm {
        name: term.name(),
        family: term.family.to_string(),
        axis: axis as u8,
        value: row.values?[axis],
        unit: term.unit.clone(),
        reference,
        time_constant_s: term.time_constant_s,
    })
}

/// For an accepted thermal-lag term: the held-out RMS with its axis's term at every time
/// constant of the grid instead (each refitted on the model before it, so the accepted τ's
/// point is the row's own CV), in the grid's order (increasing τ); `None` for other terms.
fn lag_profile(
    terms: &[BasisTerm],
    b: usize,
    state: &State,
    model: MultiPosModel,
    wins: &[Win],
) -> Option<Vec<CvPoint>> {
    terms[b].time_constant_s?;
    let points = terms
        .iter()
        .filter(|t| t.family == terms[b].family && t.axis() == terms[b].axis())
        .filter_map(|t| {
            let time_constant_s = t.time_constant_s?;
            let cv_rms_mg = try_open(t, state, model, wins)
                .map(|tr| tr.cv * 1e3)
                .filter(|cv| cv.is_finite());
            Some(CvPoint {
                time_constant_s,
                cv_rms_mg,
            })
        })
        .collect();
    Some(points)
}

/// The profile as evidence text (`NaN` where the fit failed).
fn lag_profile_text(points: &[CvPoint]) -> String {
    let cells: Vec<String> = points
        .iter()
        .map(|p| {
            let cv = p.cv_rms_mg.unwrap_or(f64::NAN);
            format!("{} s {cv:.3}", fmt_tau(p.time_constant_s))
        })
        .collect();
    format!("; CV (mg) over τ: {}", cells.join(", "))
}

/// The report row of an accepted term: value (on its output axis) with its standard error
/// and unit, and the evidence line.
fn effect_row(
    term: &BasisTerm,
    tr: &OpenTrial,
    state: &State,
    (level, screened, r, cur_cv): (f64, usize, f64, Option<f64>),
) -> EffectReport {
    let se = am::standard_errors(&tr.fit, &tr.mask, &tr.wins, &state.used);
    let (value, err) = (
        tr.fit.p[am::OPEN + tr.slot] * term.factor,
        se[am::OPEN + tr.slot] * term.factor.abs(),
    );
    let mut values = [0.0; 3];
    let mut errs = [0.0; 3];
    values[term.axis()] = value;
    errs[term.axis()] = err;
    let before = cur_cv.map_or("?".to_string(), |c| format!("{:.3}", c * 1e3));
    let mut evidence = format!(
        "open basis: strongest of {screened} terms screened (partial r = {r:.2} with the \
         residual); coefficient {value:.4e} ± {err:.1e} {}; F = {:.1}, p {} < {level:.1e} \
         (α/{screened}); CV {before} → {:.3} mg",
        term.unit,
        tr.f,
        st::fmt_p(tr.p),
        tr.cv * 1e3
    );
    if term.xs.is_some() {
        evidence.push_str(
            "; a host term (time or temperature): stored in the calibration file's host_terms \
             (schema wiical-calibration/3) about its origin, applied by `wiical correct`, not \
             by the adapter",
        );
    }
    if !term.same_pattern.is_empty() {
        evidence.push_str(&format!(
            "; ‖a‖ cannot tell it from {} (same first-order pattern)",
            term.same_pattern.join(", ")
        ));
    }
    EffectReport {
        values: Some(values),
        std_errors: Some(errs),
        ..trial_row(term, tr, cur_cv, evidence)
    }
}

/// The report row of one open term's trial: its fit's RMS, held-out RMS against `cur_cv`
/// (the model's before it, in g), F and p, unit and evidence line; no value yet (the accepted
/// term's value is added by [`effect_row`], a bias step's after the joint refit).
pub(crate) fn trial_row(
    term: &BasisTerm,
    tr: &OpenTrial,
    cur_cv: Option<f64>,
    evidence: String,
) -> EffectReport {
    EffectReport {
        name: term.name(),
        params: 1,
        rms_mg: tr.fit.rms() * 1e3,
        cv_rms_mg: Some(tr.cv * 1e3),
        cv_rms_before_mg: cur_cv.map(|x| x * 1e3),
        evidence,
        f_stat: Some(tr.f),
        p_value: Some(tr.p),
        values: None,
        std_errors: None,
        unit: Some(term.unit.clone()),
        rejected_windows: None,
        cv_profile: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 7 patterns of degree 3 and 12 of degree 4 that are not a single axis's power; the
    /// triple product is represented on z by x·y and stands for the other two axes.
    #[test]
    fn the_orientation_basis_has_one_term_per_pattern() {
        let t = orientation_terms();
        let count = |f: &str| t.iter().filter(|x| x.family == f).count();
        assert_eq!(count(names::CROSS_QUADRATIC), 7);
        assert_eq!(count(names::CROSS_CUBIC), 12);
        let xyz = t
            .iter()
            .find(|x| x.name() == "cross-quadratic (z: x·y)")
            .expect("the triple product");
        assert_eq!(xyz.same_pattern, vec!["x: y·z", "y: x·z"]);
        // Every representative is a cross term the core can store (not the axis's own power).
        for x in &t {
            let Slot::Cross { axis, exps } = x.slot else {
                panic!("{x:?}")
            };
            let deg: u8 = exps.iter().sum();
            assert!(exps[axis as usize] < deg, "{x:?}");
        }
    }
}
