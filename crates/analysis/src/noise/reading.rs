//! The IEEE 952 *reading* of an Allan deviation curve: each term read off the part of the
//! curve where its own slope is seen, as datasheets and allan_variance_ros report them.
//!
//! Why a reading and not only a joint fit ([`crate::noise::allan::fit_terms`]): on real logs
//! the short-τ end is coloured (the sensor's internal filter), and a fit of the five terms to
//! the whole curve lets that colouring pull N down and push B up (the ADIS16405's gx: the fit
//! gave N = 0.034 °/s/√Hz where the −½ line sits at 0.040–0.041, and B = 0.0146 °/s where
//! σ_min/0.664 is 0.010). The joint fit stays in the report as a cross-check.
//!
//! **The rules.** The local slope of each segment between neighbouring points (in log-log) is
//! matched to the five slopes −1 (Q), −½ (N), +½ (K), +1 (R) within ±¼ (half the spacing of
//! the slopes, so a segment matches at most one). A term is seen where at least
//! [`MIN_SEGMENTS`] consecutive segments match; a line of that fixed slope is fitted (in log,
//! equal weights: the geometric mean of `σ·τ^(−slope)`) through the points of that run (the
//! run nearest the reference τ when there are several) and read at:
//! - N: τ = 1 s on the −½ line (`σ = N/√τ`), unit/√Hz;
//! - K: τ = 3 s on the +½ line (`σ = K·√(τ/3)`), unit/√s;
//! - Q: the −1 line `σ = √3·Q/τ`, unit·s; R: the +1 line `σ = R·τ/√2`, unit/s.
//!
//! B is `σ_min / 0.664` (the flat part's value, `√(2 ln 2/π) = 0.664`) with the τ of the
//! minimum, reported when the minimum is inside the curve, or at its last point with the last
//! segment flat (slope ≥ −¼); not at the first point (the curve only rises) nor at a last
//! point reached while still falling (the flat part is not seen).

use crate::noise::allan::{AllanCurve, NoiseTerms};

/// Consecutive segments whose slope must match for a term to be seen (three points: two
/// octaves; one segment alone is within the scatter of the long-τ points).
pub const MIN_SEGMENTS: usize = 2;

/// How far a segment's slope may be from a term's and still match it: half the spacing
/// between the terms' slopes.
pub const SLOPE_TOLERANCE: f64 = 0.25;

/// How far from its reference τ (octaves, either side) a term's line is read.
pub const READ_OCTAVES: f64 = 2.0;

/// `σ_min = BIAS_FACTOR · B` on the flat part: `√(2 ln 2 / π)`.
pub const BIAS_FACTOR: f64 = 0.664;

/// The five terms read off `curve` by the rules of the module docs; `None` where not seen.
pub fn read_terms(curve: &AllanCurve) -> NoiseTerms {
    let line = |slope: f64, tau_ref: f64| line_at(curve, slope, tau_ref);
    let (b, b_tau_s) = flat_minimum(curve).map_or((None, None), |(s, t)| (Some(s), Some(t)));
    NoiseTerms {
        n: line(-0.5, 1.0),
        b,
        b_tau_s,
        k: line(0.5, 3.0),
        q: line(-1.0, curve.tau_s.first().copied().unwrap_or(1.0)).map(|s| s / 3f64.sqrt()),
        r: line(1.0, 1.0).map(|s| s * std::f64::consts::SQRT_2),
    }
}

/// The line `σ = c·τ^slope` fitted through the run of matching segments nearest `tau_ref`
/// (log distance): σ on it at `tau_ref` for the ±½ slopes (N and K are defined as σ at 1 s
/// and 3 s on their lines), `c` itself for the ±1 slopes (the caller scales it to Q or R).
/// `None` when no run of [`MIN_SEGMENTS`] segments matches.
fn line_at(curve: &AllanCurve, slope: f64, tau_ref: f64) -> Option<f64> {
    let pts: Vec<(f64, f64)> = curve
        .tau_s
        .iter()
        .zip(&curve.adev)
        .filter(|(t, s)| **t > 0.0 && **s > 0.0 && t.is_finite() && s.is_finite())
        .map(|(t, s)| (t.ln(), s.ln()))
        .collect();
    let matches: Vec<bool> = pts
        .windows(2)
        .map(|w| ((w[1].1 - w[0].1) / (w[1].0 - w[0].0) - slope).abs() <= SLOPE_TOLERANCE)
        .collect();
    // Runs of matching segments as point ranges [first, last].
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut start = None;
    for (i, m) in matches.iter().chain(std::iter::once(&false)).enumerate() {
        match (*m, start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                if i - s >= MIN_SEGMENTS {
                    runs.push((s, i));
                }
                start = None;
            }
            _ => {}
        }
    }
    let lr = tau_ref.ln();
    let dist = |r: &(usize, usize)| {
        if lr < pts[r.0].0 {
            pts[r.0].0 - lr
        } else {
            (lr - pts[r.1].0).max(0.0)
        }
    };
    let run = runs.iter().min_by(|a, b| dist(a).total_cmp(&dist(b)))?;
    let pick = near_reference(&pts[run.0..=run.1], lr);
    let ln_c = pick.iter().map(|(t, s)| s - slope * t).sum::<f64>() / pick.len() as f64;
    // N and K are σ on their line at their reference τ; Q and R take c itself.
    let at_ref = ln_c + slope * lr;
    Some(if slope.abs() == 0.5 { at_ref } else { ln_c }.exp())
}

/// The points of a run that the line is fitted through: when the reference τ (`lr` = ln τ_ref)
/// lies inside the run, those within [`READ_OCTAVES`] of it (at least `MIN_SEGMENTS + 1`,
/// the nearest); otherwise the whole run. A run can reach the knee where the next term bends
/// the curve (slopes up to ±¼ away still match), and points far from τ_ref would pull the
/// line there.
fn near_reference(run: &[(f64, f64)], lr: f64) -> Vec<(f64, f64)> {
    let inside = run.first().is_some_and(|p| p.0 <= lr) && run.last().is_some_and(|p| p.0 >= lr);
    if !inside {
        return run.to_vec();
    }
    let reach = READ_OCTAVES * std::f64::consts::LN_2;
    let near: Vec<(f64, f64)> = run
        .iter()
        .copied()
        .filter(|p| (p.0 - lr).abs() <= reach)
        .collect();
    if near.len() > MIN_SEGMENTS {
        return near;
    }
    let mut by_distance = run.to_vec();
    by_distance.sort_by(|a, b| (a.0 - lr).abs().total_cmp(&(b.0 - lr).abs()));
    by_distance.truncate(MIN_SEGMENTS + 1);
    by_distance
}

/// `(σ_min / 0.664, τ at the minimum)` when the minimum is an inner point of the curve, or
/// its last point reached on a flat segment (slope within the tolerance of 0).
fn flat_minimum(curve: &AllanCurve) -> Option<(f64, f64)> {
    let (i, s) = curve
        .adev
        .iter()
        .enumerate()
        .filter(|(_, s)| s.is_finite())
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    let last = curve.adev.len() - 1;
    // At the last point the curve is flat when its last segment's slope matches 0.
    let flat_end = i == last
        && i > 0
        && (curve.adev[i] / curve.adev[i - 1]).ln() / (curve.tau_s[i] / curve.tau_s[i - 1]).ln()
            >= -SLOPE_TOLERANCE;
    (i > 0 && (i < last || flat_end) && *s > 0.0).then(|| (s / BIAS_FACTOR, curve.tau_s[i]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::allan::model_adev;

    /// A curve made of the terms' formulas, where each term dominates over several octaves,
    /// is read back within the few per cent its neighbours add on its line.
    #[test]
    fn exact_curves_are_read_back() {
        // Q dominates below ~5 ms, N from there to ~1.5 h, the flat part to ~15 days, K
        // beyond: each over several octaves, so the others add little on its line.
        let tau: Vec<f64> = (0..45).map(|k| 1e-5 * 2f64.powi(k)).collect();
        let truth = NoiseTerms {
            n: Some(0.05),
            b: Some(1e-3),
            b_tau_s: None,
            k: Some(1e-6),
            q: Some(2e-3),
            r: None,
        };
        let curve = AllanCurve {
            adev: tau.iter().map(|t| model_adev(&truth, *t)).collect(),
            adev_rel_err: vec![0.05; tau.len()],
            tau_s: tau,
        };
        let got = read_terms(&curve);
        for (name, g, w, tol) in [
            ("N", got.n, truth.n, 0.05),
            ("K", got.k, truth.k, 0.15),
            ("Q", got.q, truth.q, 0.05),
        ] {
            let (g, w) = (g.unwrap_or_else(|| panic!("{name} not seen")), w.unwrap());
            assert!((g / w - 1.0).abs() < tol, "{name}: {g} vs {w}");
        }
        // The minimum of the sum lies above the flat part's own 0.664·B: B reads high, never low.
        let b = got.b.expect("flat part seen");
        assert!((1e-3..2e-3).contains(&b), "B = {b}");
        assert_eq!(got.r, None);
    }

    /// A monotonically falling curve has no flat part: B is not read.
    #[test]
    fn a_falling_curve_has_no_bias_instability() {
        let tau: Vec<f64> = (0..10).map(|k| 0.01 * 2f64.powi(k)).collect();
        let curve = AllanCurve {
            adev: tau.iter().map(|t| 0.1 / t.sqrt()).collect(),
            adev_rel_err: vec![0.05; tau.len()],
            tau_s: tau,
        };
        let got = read_terms(&curve);
        assert_eq!((got.b, got.b_tau_s, got.k), (None, None, None));
        assert!((got.n.unwrap() - 0.1).abs() < 1e-12);
    }
}
