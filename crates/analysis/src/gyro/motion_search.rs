//! The motion candidates ([`super::motion::Kind`]) tried greedily by the accelerometer's rule
//! ([`crate::search::select::select`]: the F-test at α / candidates against the reference
//! variance, which is never below the motions' noise floor, **and** the leave-one-motion-out
//! RMS angle down by [`CV_FACTOR`]), each reported with its evidence line, unit and before →
//! after in-sample and held out; every candidate not accepted gets its detection limit
//! ([`super::limits::limit_from`]).

use super::limits::limit_from;
use super::motion::{fit, Fit, Kind, MotionSet};
use super::report::{MotionCandidate, MotionEffect, MotionLoop, MotionStep, MotionSummary};
use crate::search::select::{self, Choice, TermScore, ALPHA, CV_FACTOR, MAX_EFFECTS};
use crate::stats as st;

/// The summary of a motion model.
fn summary(f: &Fit) -> MotionSummary {
    let chi2 = f.rss;
    MotionSummary {
        params: f.inv.nrows(),
        rms_deg: st::rms(&f.angles).to_degrees(),
        cv_rms_deg: st::rms(&f.held).to_degrees(),
        motions_used: f.angles.len(),
        chi2,
        chi2_dof: f.dof,
        chi2_p: st::chi2_sf(chi2, f.dof as f64),
    }
}

/// The reference variance of a fit (weighted units: the floor is 1).
fn reference(f: &Fit) -> f64 {
    (f.rss / f.dof.max(1) as f64).max(1.0)
}

/// F statistic and p-value of adding `q` coefficients from `cur` to `new`.
fn f_test(cur: &Fit, new: &Fit, q: usize) -> (f64, f64) {
    let fs = ((cur.rss - new.rss) / q as f64 / reference(new)).max(0.0);
    (fs, st::f_sf(fs, q as f64, new.dof as f64))
}

/// Runs the search on the motions; `applied` names the window effects already in the rates.
pub fn search(set: &MotionSet, applied: Vec<String>) -> Option<MotionLoop> {
    let mut chosen: Vec<Kind> = Vec::new();
    let mut current = fit(set, &[])?;
    let base = summary(&current);
    let (mut effects, mut steps) = (Vec::new(), Vec::new());
    for _ in 0..MAX_EFFECTS {
        let open: Vec<Kind> = Kind::ALL
            .into_iter()
            .filter(|k| !chosen.contains(k))
            .collect();
        if open.is_empty() {
            break;
        }
        let fits: Vec<Option<Fit>> = open
            .iter()
            .map(|k| {
                let mut kinds = chosen.clone();
                kinds.push(*k);
                fit(set, &kinds).filter(|f| f.dof >= select::MIN_DOF_TERM)
            })
            .collect();
        let tested = fits.iter().flatten().count().max(1);
        let level = ALPHA / tested as f64;
        let cv0 = st::rms(&current.held);
        let scores: Vec<TermScore> = open
            .iter()
            .zip(&fits)
            .map(|(k, f)| score(&current, f.as_ref(), k.width()))
            .collect();
        let sel = select::select(&scores, None, Some(cv0), level, CV_FACTOR);
        let accepted = match sel.choice {
            Choice::Term(i) => Some(i),
            _ => None,
        };
        let rows = open
            .iter()
            .zip(&fits)
            .enumerate()
            .map(|(i, (k, f))| {
                let passed = accepted == Some(i);
                row(&current, *k, f.as_ref(), passed, sel.significant[i], level)
            })
            .collect();
        steps.push(MotionStep {
            candidates: rows,
            level,
            accepted: accepted.map(|i| open[i].name()),
        });
        let Some(i) = accepted else { break };
        let Some(new) = fits.into_iter().nth(i).flatten() else {
            break;
        };
        effects.push(effect(&current, &new, open[i], &chosen));
        chosen.push(open[i]);
        current = new;
    }
    let final_model = summary(&current);
    Some(MotionLoop {
        window_effects_applied: applied,
        base,
        effects,
        final_model,
        steps,
        open_basis: super::motion_basis::search(set, &chosen, current),
    })
}

/// The rule's inputs for one candidate.
fn score(cur: &Fit, f: Option<&Fit>, q: usize) -> TermScore {
    // The in-sample angles are integrated exactly: a candidate that does not lower them is
    // outside the linearisation's reach and is not taken, whatever its linear statistics say.
    let (p_value, cv, ok) = match f {
        Some(f) => (
            f_test(cur, f, q).1,
            st::rms(&f.held),
            st::rms(&f.angles) <= st::rms(&cur.angles),
        ),
        None => (1.0, f64::INFINITY, false),
    };
    TermScore {
        p_value,
        weight: 1.0,
        cv,
        cv_on_kept: None,
        storable: true,
        members_pass: ok,
    }
}

/// Columns of kind `k` in a fit over `chosen` then `k` (after the free calibration ones).
fn columns(f: &Fit, chosen: &[Kind], k: Kind) -> std::ops::Range<usize> {
    let first = f.free + chosen.iter().map(|c| c.width()).sum::<usize>();
    first..first + k.width()
}

/// Standard errors of kind `k`'s coefficients in its unit.
fn std_errors(f: &Fit, chosen: &[Kind], k: Kind) -> Vec<f64> {
    let var = reference(f);
    columns(f, chosen, k)
        .map(|j| (var * f.inv[(j, j)]).sqrt() * k.to_unit())
        .collect()
}

fn row(
    cur: &Fit,
    k: Kind,
    f: Option<&Fit>,
    passed: bool,
    significant: bool,
    level: f64,
) -> MotionCandidate {
    let ft = f.map(|f| f_test(cur, f, k.width()));
    let limit = f.filter(|_| !passed).and_then(|f| {
        let kinds_before = f.inv.nrows() - f.free - k.width();
        // The chosen kinds' widths sum to `kinds_before`; only the last block is `k`.
        let first = f.free + kinds_before;
        let var = reference(cur);
        let se_max = (first..first + k.width())
            .map(|j| (var * f.inv[(j, j)]).sqrt())
            .fold(0.0, f64::max);
        let rows = (2 * f.angles.len()) as f64;
        let (p1, p0) = (f.inv.nrows() as f64, (f.inv.nrows() - k.width()) as f64);
        let cv_need = rows * (CV_FACTOR.powi(2) * (1.0 + p1 / rows) - (1.0 + p0 / rows));
        limit_from(se_max, k.width() as f64, f.dof as f64, level, cv_need).map(|l| l * k.to_unit())
    });
    let note = match (f, passed) {
        (None, _) => "too few motions to test it".to_string(),
        (Some(_), true) => format!("accepted: {}", k.pattern()),
        (Some(_), false) if !significant => format!(
            "not significant (p {} against {level:.1e})",
            st::fmt_p(ft.map_or(1.0, |t| t.1))
        ),
        (Some(_), false) => "significant, but the held-out RMS does not fall by 10 %".into(),
    };
    MotionCandidate {
        name: k.name(),
        params: k.width(),
        unit: k.unit().into(),
        rms_deg: f.map(|f| st::rms(&f.angles).to_degrees()),
        cv_rms_deg: f.map(|f| st::rms(&f.held).to_degrees()),
        cv_rms_current_deg: st::rms(&cur.held).to_degrees(),
        f_stat: ft.map(|t| t.0),
        p_value: ft.map(|t| t.1),
        passed,
        note,
        detection_limit: limit,
    }
}

fn effect(cur: &Fit, new: &Fit, k: Kind, chosen: &[Kind]) -> MotionEffect {
    let (fs, p) = f_test(cur, new, k.width());
    let values: Vec<f64> = columns(new, chosen, k)
        .map(|j| new.point.eff[j - new.free] * k.to_unit())
        .collect();
    let (rb, ra) = (
        st::rms(&cur.angles).to_degrees(),
        st::rms(&new.angles).to_degrees(),
    );
    let (cb, ca) = (
        st::rms(&cur.held).to_degrees(),
        st::rms(&new.held).to_degrees(),
    );
    MotionEffect {
        name: k.name(),
        params: k.width(),
        unit: k.unit().into(),
        values,
        std_errors: std_errors(new, chosen, k),
        evidence: format!(
            "{}: F = {fs:.2} ({}, {} dof), p {}; motion RMS {rb:.4}° → {ra:.4}° in-sample, {cb:.4}° → {ca:.4}° held out",
            k.pattern(),
            k.width(),
            new.dof,
            st::fmt_p(p)
        ),
        f_stat: fs,
        p_value: p,
        rms_before_deg: rb,
        rms_deg: ra,
        cv_rms_before_deg: cb,
        cv_rms_deg: ca,
    }
}
