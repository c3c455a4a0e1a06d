//! The magnetometer loop's greedy search: at each step every remaining candidate is fitted
//! jointly with the current model, tested by F against the residual variance (never below
//! the noise floor, as `analyze` does: [`crate::search::floor::reference_variance`]'s rule) at
//! the accelerometer's level ([`crate::search::select::ALPHA`], Bonferroni over the
//! candidates), and must divide the held-out RMS by [`crate::search::select::CV_FACTOR`]; the
//! passing candidate with the lowest held-out RMS is added. Up to
//! [`crate::search::select::MAX_EFFECTS`] steps.

use super::candidates::{Cand, Kind, Layout};
use super::contract::{MagCandidate, MagEffect, MagStep};
use super::design::{fit, schur, total, Fit, Normal};
use crate::search::select::{CV_FACTOR, MAX_EFFECTS};
use crate::stats;

/// What the search found.
pub struct Found {
    /// The base fit.
    pub base: Fit,
    /// The final fit and its columns.
    pub last: Fit,
    /// Accepted effects.
    pub effects: Vec<MagEffect>,
    /// Every step.
    pub steps: Vec<MagStep>,
}

/// One candidate measured against the current model.
struct Tried {
    alt: usize,
    fit: Fit,
    q: usize,
    f: Option<f64>,
    p: Option<f64>,
    passed: bool,
}

/// The reference variance: the fit's `rss/dof`, never below the floor's square.
fn ref_var(f: &Fit, n: usize, floor: f64) -> f64 {
    let dof = n.saturating_sub(f.rank).max(1) as f64;
    (f.rss / dof).max(floor * floor).max(1e-300)
}

fn try_cand(
    c: &Cand,
    lay: &Layout,
    tot: &Normal,
    cur: &[usize],
    cf: &Fit,
    floor: f64,
    level: f64,
) -> Tried {
    let n = tot.n;
    let mut best: Option<(usize, Fit)> = None;
    for (i, (cols, _)) in c.alts.iter().enumerate() {
        let all: Vec<usize> = cur.iter().chain(cols).copied().collect();
        let f = fit(&lay.blocks, tot, &all);
        if best.as_ref().is_none_or(|(_, b)| f.rss < b.rss) {
            best = Some((i, f));
        }
    }
    let (alt, f) = best.expect("a candidate has an alternative");
    let q = f.rank.saturating_sub(cf.rank);
    let (fs, p) = if q == 0 || n <= f.rank {
        (None, None)
    } else {
        let fs = ((cf.rss - f.rss).max(0.0) / q as f64) / ref_var(&f, n, floor);
        let p = (stats::f_sf(fs, q as f64, (n - f.rank) as f64) * c.alts.len() as f64).min(1.0);
        (Some(fs), Some(p))
    };
    let cv_ok = matches!((f.cv, cf.cv), (Some(a), Some(b)) if a * CV_FACTOR <= b);
    let passed = p.is_some_and(|p| p < level) && cv_ok;
    Tried {
        alt,
        fit: f,
        q,
        f: fs,
        p,
        passed,
    }
}

/// Runs the search over `lay` with the residual floor `floor` and family level `alpha`.
pub fn search(lay: &Layout, floor: f64, alpha: f64) -> Found {
    let tot = total(&lay.blocks);
    let mut cur: Vec<usize> = (0..lay.base).collect();
    let base = fit(&lay.blocks, &tot, &cur);
    let mut cf = base.clone();
    let mut left: Vec<usize> = (0..lay.cands.len()).collect();
    let (mut effects, mut steps) = (Vec::new(), Vec::new());
    while effects.len() < MAX_EFFECTS && !left.is_empty() {
        let level = alpha / left.len() as f64;
        let tried: Vec<Tried> = left
            .iter()
            .map(|&c| try_cand(&lay.cands[c], lay, &tot, &cur, &cf, floor, level))
            .collect();
        let pick = tried
            .iter()
            .enumerate()
            .filter(|(_, t)| t.passed)
            .min_by(|a, b| {
                a.1.fit
                    .cv
                    .unwrap_or(f64::MAX)
                    .total_cmp(&b.1.fit.cv.unwrap_or(f64::MAX))
            })
            .map(|(i, _)| i);
        let mut cands: Vec<MagCandidate> = left
            .iter()
            .zip(&tried)
            .map(|(&c, t)| row(&lay.cands[c], t, &cf, level, tot.n))
            .collect();
        let Some(k) = pick else {
            for (cand, &c) in cands.iter_mut().zip(&left) {
                let lim = limit(&lay.cands[c], &tot, &cur, &cf, floor, level);
                cand.detection_limit = lim;
            }
            steps.push(MagStep {
                candidates: cands,
                level,
                accepted: None,
            });
            break;
        };
        let c = &lay.cands[left[k]];
        let t = &tried[k];
        effects.push(effect(c, t, &cf, &cur, floor, tot.n));
        cur.extend(&c.alts[t.alt].0);
        cf = t.fit.clone();
        steps.push(MagStep {
            candidates: cands,
            level,
            accepted: Some(c.name.clone()),
        });
        left.remove(k);
    }
    Found {
        base,
        last: cf,
        effects,
        steps,
    }
}

fn row(c: &Cand, t: &Tried, cf: &Fit, level: f64, n: usize) -> MagCandidate {
    let note = match (t.p, t.passed) {
        (None, _) => "not testable: its columns are already in the model".into(),
        (_, true) => "passes the F-test and lowers the held-out error".into(),
        (Some(p), false) if p >= level => {
            format!("F-test p {} ≥ level {level:.1e}", stats::fmt_p(p))
        }
        _ => format!("held-out error not lowered by {CV_FACTOR}×"),
    };
    MagCandidate {
        name: c.name.clone(),
        params: t.q,
        rms: (t.fit.rss / n.max(1) as f64).sqrt(),
        cv_rms: t.fit.cv,
        cv_rms_current: cf.cv,
        f_stat: t.f,
        p_value: t.p,
        passed: t.passed,
        note,
        detection_limit: None,
        detection_unit: if c.kind == Kind::Shape {
            format!("{} RMS", c.unit)
        } else {
            c.unit.clone()
        },
    }
}

/// The accepted effect's report: coefficients, standard errors, one line of evidence.
fn effect(c: &Cand, t: &Tried, before: &Fit, cur: &[usize], floor: f64, n: usize) -> MagEffect {
    let s2 = ref_var(&t.fit, n, floor);
    let k0 = cur.len();
    let (values, errs): (Vec<f64>, Vec<f64>) = match c.kind {
        Kind::Centre => (0..3)
            .map(|a| {
                (
                    t.fit.beta[k0 + a],
                    (t.fit.cov_unit[(k0 + a, k0 + a)] * s2).sqrt(),
                )
            })
            .unzip(),
        Kind::Shape => {
            let added = ((before.rss - t.fit.rss).max(0.0) / n as f64).sqrt();
            (vec![added], vec![floor / (n as f64).sqrt()])
        }
    };
    let at = c.alts[t.alt].1;
    let fmt3 = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:.3e}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let what = match c.kind {
        Kind::Centre => format!("centre moves by ({}) {}", fmt3(&values), c.unit),
        Kind::Shape => format!(
            "the surface departs from the ellipsoid by {:.3e} {} RMS",
            values[0], c.unit
        ),
    };
    let when = at.map_or(String::new(), |t| format!(" at t = {t:.6}"));
    let cvs = |f: &Fit| f.cv.map_or("—".into(), |v| format!("{v:.4e}"));
    MagEffect {
        name: c.name.clone(),
        params: t.q,
        rms: (t.fit.rss / n as f64).sqrt(),
        cv_rms: t.fit.cv,
        cv_rms_before: before.cv,
        evidence: format!(
            "{what}{when}; F = {:.1}, p {}; held-out RMS {} → {}",
            t.f.unwrap_or(f64::NAN),
            t.p.map_or("—".into(), stats::fmt_p),
            cvs(before),
            cvs(&t.fit)
        ),
        f_stat: t.f.unwrap_or(f64::NAN),
        p_value: t.p.unwrap_or(f64::NAN),
        values,
        std_errors: errs,
        unit: c.unit.clone(),
        at,
    }
}

/// The detection limit of a candidate against the current model (module docs of
/// [`super`]): the magnitude at which, in its worst direction and at its worst scanned
/// position, both the F-test at `level` and the held-out rule would pass.
fn limit(c: &Cand, tot: &Normal, cur: &[usize], cf: &Fit, floor: f64, level: f64) -> Option<f64> {
    let n = tot.n;
    let cv = cf.cv?;
    let s2 = ref_var(cf, n, floor);
    let mut worst: Option<f64> = None;
    for (cols, _) in &c.alts {
        let q = cols.len() as f64;
        let d = n.checked_sub(cf.rank + cols.len())?.max(1) as f64;
        // Δrss an effect must add: enough for the F-test, and for the held-out RMS to
        // rise by the CV factor.
        let need = (q * stats::f_critical(level / c.alts.len() as f64, q, d) * s2)
            .max((CV_FACTOR * CV_FACTOR - 1.0) * cv * cv * n as f64);
        let lim = match c.kind {
            Kind::Shape => (need / n as f64).sqrt(),
            Kind::Centre => {
                let s = schur(tot, cur, cols);
                let lmin = s.symmetric_eigenvalues().min();
                // Not positive, or NaN: the column cannot be separated.
                if lmin.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                    return None;
                }
                (need / lmin).sqrt()
            }
        };
        worst = Some(worst.map_or(lim, |w: f64| w.max(lim)));
    }
    worst
}
