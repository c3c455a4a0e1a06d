//! The gyro's bias step: a knock that shifts the gyro's bias between two rests, searched on
//! the static windows before the named window candidates ([`super::effects`]) so that it is
//! named as a step and not absorbed by the bias drift or the temperature (a step halfway
//! through a recording looks to a drift like a slope with half the step left at each end).
//!
//! The family: per gap between consecutive kept windows `k−1 | k` with at least
//! [`MIN_SIDE`] windows each side, one column `H − 1` (−1 before the gap, 0 after) on all three
//! gyro axes (the window design is shared by the axes, as the named candidates'): its three
//! coefficients are the step, bias after minus bias before, °/s, and the window model's
//! constant is the bias after it.
//!
//! The rule, the accelerometer's (`crate::search::bias_step`): the step with the largest F
//! against the bias-only window model must have p below α divided by the gaps tried, bring the
//! held-out window RMS down by [`CV_FACTOR`], and have a held-out RMS [`CV_FACTOR`] below each
//! smooth alternative fitted instead (each named candidate alone, and the drift and the
//! temperature with their squares). One step at most.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use super::design::{design, Candidate, WindowData};
use super::effects::{fit, Fit};
use super::report::GyroEffect;
use crate::search::floor::reference_variance;
use crate::search::select::{ALPHA, CV_FACTOR};
use crate::stats as st;

/// Windows each side of a step at least.
pub const MIN_SIDE: usize = 3;

/// The step's candidate name ([`crate::report::effect_names::BIAS_STEP`]).
pub const NAME: &str = crate::report::effect_names::BIAS_STEP;

/// An accepted step: its candidate (the window column) and where it is.
#[derive(Debug, Clone)]
pub struct Found {
    /// The column `H − 1` as a candidate named [`NAME`].
    pub candidate: Candidate,
    /// The first window after the step, 0-based among the kept windows.
    pub after: usize,
    /// The gap in words: `between windows 7 and 8 (t = 41.2–44.0 s)`.
    pub place: String,
    /// The middle of the gap, s (recording clock): the motions' samples from it on have the
    /// bias after the step ([`Found::regressor`]).
    pub t_step: f64,
    /// The evidence of the search (the alternatives' held-out RMS).
    pub evidence: String,
}

/// The step column of gap `k` among `n` windows.
fn column(n: usize, k: usize) -> Vec<Vec<f64>> {
    (0..n)
        .map(|i| vec![if i < k { -1.0 } else { 0.0 }])
        .collect()
}

/// The smooth alternatives: each named candidate alone, and the drift and the temperature
/// with their squares (the square of the centred column).
fn alternatives(cands: &[Candidate]) -> Vec<Candidate> {
    let mut out: Vec<Candidate> = cands.to_vec();
    for c in cands
        .iter()
        .filter(|c| matches!(c.name, "bias-drift" | "temperature"))
    {
        let columns = c.columns.iter().map(|r| vec![r[0], r[0] * r[0]]).collect();
        out.push(Candidate {
            columns,
            ..c.clone()
        });
    }
    out
}

/// Held-out window RMS of a fit, °/s.
fn cv(f: &Fit) -> f64 {
    st::rms(f.loo())
}

/// Searches the gaps of the kept windows (`times`: first and last sample time of each, s)
/// for a step of the gyro's bias; `None` when none passes the module's rule.
pub fn find(data: &WindowData, cands: &[Candidate], times: &[(f64, f64)]) -> Option<Found> {
    let n = data.rate_dps.len();
    if n < 2 * MIN_SIDE || times.len() != n {
        return None;
    }
    let floors: Vec<f64> = data.mean_var.iter().flatten().map(|v| v.sqrt()).collect();
    let used = vec![true; floors.len()];
    let base = fit(&design(&[], None, n), data)?;
    let mut best: Option<(f64, usize, Fit, Candidate)> = None;
    let gaps: Vec<usize> = (MIN_SIDE..=n - MIN_SIDE).collect();
    for &k in &gaps {
        let c = Candidate {
            name: NAME,
            unit: "°/s",
            columns: column(n, k),
            pattern: "the windows' gyro means jump between two rests and stay",
        };
        let Some(f) = fit(&design(&[], Some(&c), n), data) else {
            continue;
        };
        let var = reference_variance(f.rss(), f.dof() as f64, &floors, &used);
        let fstat = ((base.rss() - f.rss()) / 3.0 / var).max(0.0);
        if best.as_ref().is_none_or(|b| fstat > b.0) {
            best = Some((fstat, k, f, c));
        }
    }
    let (fstat, k, f, c) = best?;
    let p = st::f_sf(fstat, 3.0, f.dof() as f64);
    let level = ALPHA / gaps.len() as f64;
    let (cv0, cv1) = (cv(&base), cv(&f));
    if !(p < level && cv1 * CV_FACTOR <= cv0) {
        return None;
    }
    let mut smooth = Vec::new();
    for alt in alternatives(cands) {
        let a = fit(&design(&[], Some(&alt), n), data).map_or(f64::INFINITY, |f| cv(&f));
        if !(cv1 * CV_FACTOR <= a) {
            return None;
        }
        smooth.push(format!("{} {a:.4}", alt_name(&alt)));
    }
    let place = format!(
        "between windows {k} and {} (t = {:.1}–{:.1} s)",
        k + 1,
        times[k - 1].1,
        times[k].0
    );
    let evidence = format!(
        "the largest F of {} gaps tried: F = {fstat:.1}, p {} < {level:.1e} (α/{}); held-out \
         window RMS {cv0:.4} → {cv1:.4} °/s, against (°/s) {} with a smooth term in its place",
        gaps.len(),
        st::fmt_p(p),
        gaps.len(),
        smooth.join(", ")
    );
    Some(Found {
        candidate: c,
        after: k,
        place,
        t_step: 0.5 * (times[k - 1].1 + times[k].0),
        evidence,
    })
}

impl Found {
    /// The step's regressor at time `t` (s, recording clock): −1 before the gap's middle, 0
    /// from it on (the motion the knock happened in is split at the middle: when in it the
    /// knock came is not known).
    pub fn regressor(&self, t: f64) -> f64 {
        if t >= self.t_step {
            0.0
        } else {
            -1.0
        }
    }
}

/// An alternative's name: the candidate's, `²` added for the squared pair.
fn alt_name(c: &Candidate) -> String {
    if c.columns.first().map_or(0, Vec::len) == 2 && c.name != "g-sensitivity" {
        format!("{} + its square", c.name)
    } else {
        c.name.to_string()
    }
}

/// The step's report row from the final window model (the step and the accepted named
/// effects fitted together): its name with the place, its values and standard errors, and
/// the search's evidence before the row's own.
pub fn finish(row: &mut GyroEffect, found: &Found, data: &WindowData, chosen: &[&Candidate]) {
    let n = data.rate_dps.len();
    let mut all: Vec<&Candidate> = vec![&found.candidate];
    all.extend(chosen.iter().copied());
    if let Some(f) = fit(&design(&all, None, n), data) {
        let floors: Vec<f64> = data.mean_var.iter().flatten().map(|v| v.sqrt()).collect();
        let used = vec![true; floors.len()];
        let var = reference_variance(f.rss(), f.dof() as f64, &floors, &used);
        row.values = (0..3).map(|a| f.beta[(1, a)]).collect();
        let se = (var * f.inv[(1, 1)]).sqrt();
        row.std_errors = vec![se; 3];
    }
    let v: Vec<String> = row.values.iter().map(|x| format!("{x:+.4}")).collect();
    row.name = format!("{NAME} ({})", found.place);
    row.evidence = format!(
        "step of the gyro's bias by ({}) ± {:.4} °/s from window {} on; {}; {}",
        v.join(", "),
        row.std_errors.first().copied().unwrap_or(f64::NAN),
        found.after + 1,
        found.evidence,
        row.evidence
    );
}
