//! The motions' open basis: after the named motion candidates (`motion_search`),
//! generic terms of the calibrated rate, one coefficient on one gyro axis each
//! ([`RateTerm`]):
//!
//! | family | form, on gyro axis `a` | unit |
//! |---|---|---|
//! | `rate-product` | `ω_i·ω_j / 100 °/s` (the 6 products of two rates) | % of 100 °/s at 100 °/s |
//! | `cross-axis-asymmetry` | `abs(ω_j)`, `j ≠ a` (the named asymmetry is `abs(ω_a)`) | % |
//!
//! Integrating the motions for every term's refit would cost a full Gauss–Newton fit per term,
//! so a round **screens** first, linear in motions × terms (as the accelerometer's open basis
//! does): each term's column of the weighted residuals (central differences at the named
//! model's point) is appended to the named model's last linearisation, which gives its F
//! (one coefficient, against the reference variance, never below the floor), its
//! leave-one-motion-out RMS and, when it is not accepted, its detection limit. The best term by
//! F is then refitted with everything ([`super::motion::fit`]) and accepted by the window
//! rule: p below α / the terms screened (a Bonferroni factor over the basis) **and** the
//! held-out RMS angle down by [`CV_FACTOR`], with the in-sample angles not up.

use super::basis::finish;
use super::limits::limit_from;
use super::motion::{column, fit, Fit, Kind, MotionSet, RateForm, RateTerm};
use super::report::{BasisEffect, BasisRow, BasisStep, OpenBasis};
use crate::search::select::{ALPHA, CV_FACTOR, MAX_EFFECTS, MIN_DOF_TERM};
use crate::stats as st;
use nalgebra::{DMatrix, DVector, Matrix2, Vector2};

/// Every term of the basis: per gyro axis the 6 products and the 2 other axes' `|ω_j|`.
pub fn terms() -> Vec<RateTerm> {
    let mut out = Vec::new();
    for axis in 0..3u8 {
        for (i, j) in [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)] {
            out.push(RateTerm {
                axis,
                form: RateForm::Product(i, j),
            });
        }
        for j in (0..3u8).filter(|j| *j != axis) {
            out.push(RateTerm {
                axis,
                form: RateForm::Abs(j),
            });
        }
    }
    out
}

/// A term screened on the current linearisation.
struct Screened {
    term: RateTerm,
    f_stat: f64,
    p_value: f64,
    /// Leave-one-motion-out RMS angle, degrees.
    cv_deg: f64,
    /// Its coefficient's standard error (internal units).
    se: f64,
    dof: usize,
}

/// The reference variance of a fit (weighted: the floor is 1).
fn reference(f: &Fit) -> f64 {
    (f.rss / f.dof.max(1) as f64).max(1.0)
}

/// `z` appended to the linearisation of `cur`: F, held-out RMS and standard error.
fn screen(set: &MotionSet, cur: &Fit, term: RateTerm, z: &DVector<f64>) -> Option<Screened> {
    let (rows, cols) = cur.x.shape();
    let zp = z - &cur.x * (&cur.inv * (cur.x.transpose() * z));
    if zp.norm() <= 1e-6 * z.norm().max(1e-300) || rows < cols + 1 + MIN_DOF_TERM {
        return None;
    }
    let x = DMatrix::from_fn(
        rows,
        cols + 1,
        |r, c| if c < cols { cur.x[(r, c)] } else { z[r] },
    );
    let inv = (x.transpose() * &x).try_inverse()?;
    let e = &cur.r - &x * (&inv * (x.transpose() * &cur.r));
    let dof = rows - cols - 1;
    let rss = e.norm_squared();
    let var = (rss / dof as f64).max(1.0);
    let f_stat = ((cur.rss - rss) / var).max(0.0);
    let held: Vec<f64> = (0..set.span.len())
        .map(|i| {
            let xi = x.rows(2 * i, 2);
            let h = xi * &inv * xi.transpose();
            let ih = Matrix2::identity() - Matrix2::from_fn(|r, c| h[(r, c)]);
            let ei = Vector2::new(e[2 * i], e[2 * i + 1]);
            ih.try_inverse().map_or(ei, |m| m * ei).norm() * set.sigma[i]
        })
        .collect();
    Some(Screened {
        term,
        f_stat,
        p_value: st::f_sf(f_stat, 1.0, dof as f64),
        cv_deg: st::rms(&held).to_degrees(),
        se: (reference(cur) * inv[(cols, cols)]).sqrt(),
        dof,
    })
}

/// Runs the basis after the named model `cur` with `chosen` effects.
pub fn search(set: &MotionSet, chosen: &[Kind], cur: Fit) -> Option<OpenBasis> {
    let all = terms();
    let (mut kinds, mut cur) = (chosen.to_vec(), cur);
    let cv_start = st::rms(&cur.held).to_degrees();
    let (mut found, mut steps) = (Vec::new(), Vec::new());
    for _ in 0..MAX_EFFECTS {
        let mut tried: Vec<Screened> = all
            .iter()
            .filter(|t| !kinds.contains(&Kind::Rate(**t)))
            .filter_map(|t| {
                let z = column(set, &cur.point, &kinds, Kind::Rate(*t))?;
                screen(set, &cur, *t, &z)
            })
            .collect();
        if tried.is_empty() {
            break;
        }
        tried.sort_by(|a, b| b.f_stat.total_cmp(&a.f_stat));
        let level = ALPHA / tried.len() as f64;
        let cv0 = st::rms(&cur.held).to_degrees();
        let accepted = refit_best(set, &kinds, &cur, &tried[0], level, cv0);
        let rows = tried
            .iter()
            .map(|s| {
                row(
                    s,
                    &cur,
                    accepted.is_some() && s.term == tried[0].term,
                    level,
                )
            })
            .collect();
        steps.push(BasisStep {
            screened: tried.len(),
            level,
            accepted: accepted.as_ref().map(|_| Kind::Rate(tried[0].term).name()),
            candidates: rows,
        });
        let Some(new) = accepted else { break };
        found.push(found_effect(&cur, &new, tried[0].term, cv0));
        kinds.push(Kind::Rate(tried[0].term));
        cur = new;
    }
    let terms_reported: Vec<super::basis::Term> = all
        .iter()
        .map(|t| super::basis::Term {
            family: t.family(),
            form: t.form_name(),
            axis: t.axis as usize,
            unit: Kind::Rate(*t).unit(),
            column: Vec::new(),
        })
        .collect();
    let cv_final = st::rms(&cur.held).to_degrees();
    Some(finish(
        &terms_reported,
        found,
        steps,
        cv_start,
        cv_final,
        "°",
    ))
}

/// The best screened term refitted with everything; `Some` when it passes the rule.
fn refit_best(
    set: &MotionSet,
    kinds: &[Kind],
    cur: &Fit,
    best: &Screened,
    level: f64,
    cv0: f64,
) -> Option<Fit> {
    if best.p_value >= level {
        return None;
    }
    let mut with = kinds.to_vec();
    with.push(Kind::Rate(best.term));
    let new = fit(set, &with).filter(|f| f.dof >= MIN_DOF_TERM)?;
    let fs = ((cur.rss - new.rss) / reference(&new)).max(0.0);
    let p = st::f_sf(fs, 1.0, new.dof as f64);
    let cv = st::rms(&new.held).to_degrees();
    let angles_ok = st::rms(&new.angles) <= st::rms(&cur.angles);
    (p < level && cv * CV_FACTOR <= cv0 && angles_ok).then_some(new)
}

fn row(s: &Screened, cur: &Fit, passed: bool, level: f64) -> BasisRow {
    let k = Kind::Rate(s.term);
    let limit = (!passed)
        .then(|| {
            let rows = cur.x.nrows() as f64;
            let p0 = cur.x.ncols() as f64;
            let need = rows * (CV_FACTOR.powi(2) * (1.0 + (p0 + 1.0) / rows) - (1.0 + p0 / rows));
            limit_from(s.se, 1.0, s.dof as f64, level, need).map(|l| l * k.to_unit())
        })
        .flatten();
    BasisRow {
        name: k.name(),
        family: s.term.family().into(),
        unit: k.unit().into(),
        f_stat: s.f_stat,
        p_value: s.p_value,
        cv_rms: s.cv_deg,
        passed,
        detection_limit: limit,
    }
}

fn found_effect(cur: &Fit, new: &Fit, t: RateTerm, cv0: f64) -> BasisEffect {
    let k = Kind::Rate(t);
    let j = new.inv.nrows() - 1;
    let value = new.point.eff[j - new.free] * k.to_unit();
    let se = (reference(new) * new.inv[(j, j)]).sqrt() * k.to_unit();
    let fs = ((cur.rss - new.rss) / reference(new)).max(0.0);
    let p = st::f_sf(fs, 1.0, new.dof as f64);
    let cv = st::rms(&new.held).to_degrees();
    let axis = ["x", "y", "z"][t.axis as usize];
    BasisEffect {
        name: k.name(),
        family: t.family().into(),
        unit: k.unit().into(),
        value,
        std_error: se,
        evidence: format!(
            "something of the form {} on the gyro's {axis} axis: {value:.4} ± {se:.4} {}, F = {fs:.2} (1, {} dof), p {}; motion RMS {cv0:.4}° → {cv:.4}° held out",
            t.form_name(),
            k.unit(),
            new.dof,
            st::fmt_p(p)
        ),
        f_stat: fs,
        p_value: p,
        cv_rms_before: cv0,
        cv_rms: cv,
    }
}
