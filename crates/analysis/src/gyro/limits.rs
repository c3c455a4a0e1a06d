//! Detection limits: the smallest coefficient of a candidate that this recording would have
//! shown at the step's level, in the candidate's unit ("no g-sensitivity above 0.02 °/s/g").
//!
//! A candidate is accepted when its F-test passes **and** its held-out RMS falls by the CV
//! factor, so its limit is the larger of the two sizes:
//!
//! * **F-test, 80 % power.** One coefficient `β` of standard error `SE` (from the step's
//!   design and reference variance σ²) adds the non-centrality `λ = (β/SE)²` to the block's
//!   F-test on `q` degrees of freedom. The limit is `√λ₈₀·SE_max`, with `λ₈₀` the
//!   non-centrality at which `P(χ²_q(λ) > q·F_crit) = 0.8` (Poisson mixture of central χ²)
//!   and `SE_max` the largest standard error among the candidate's coefficients (so the limit
//!   holds for every one of them).
//! * **Held-out RMS.** Leave-one-out residuals of a least-squares fit with `p` parameters on
//!   `N` windows have mean square ≈ `σ²(1 + p/N)`; a coefficient `β` left out adds
//!   `σ²β²/(3N·SE²)` to the mean square over the three axes. The factor is reached when
//!   `β ≥ SE·√(3N·(c²(1 + p₁/N) − (1 + p₀/N)))`.
//!
//! The simulation in the tests injects each effect at twice its limit and finds it in at
//! least 80 % of runs.

use super::design::{design, width, Candidate, WindowData};
use crate::search::select::{CV_FACTOR, MIN_DOF_TERM};
use crate::stats as st;

/// Power the limit is stated at.
pub const POWER: f64 = 0.8;

/// Upper critical value of the F distribution on (`d1`, `d2`) at `level` (bisection on the
/// survival function: monotone, so 100 halvings reach full precision).
fn f_critical(level: f64, d1: f64, d2: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, 1e6);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if st::f_sf(mid, d1, d2) > level {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// `P(χ²_q(λ) > c)`: the non-central χ² as a Poisson(λ/2) mixture of central χ²'s.
fn noncentral_sf(c: f64, q: f64, lambda: f64) -> f64 {
    let half = 0.5 * lambda;
    let mut sum = 0.0;
    let mut log_w = -half;
    // The Poisson weights are negligible beyond λ/2 + 40·√(λ/2): sum at least that far.
    let terms = (half + 40.0 * half.sqrt() + 100.0).min(1e7) as usize;
    for k in 0..terms {
        let kf = k as f64;
        if k > 0 {
            log_w += half.ln() - kf.ln();
        }
        let w = log_w.exp();
        sum += w * st::chi2_sf(c, q + 2.0 * kf);
        if kf > half && w < 1e-14 {
            break;
        }
    }
    sum.min(1.0)
}

/// The non-centrality at which the test with critical value `c` on `q` dof has [`POWER`].
fn lambda_for_power(c: f64, q: f64) -> f64 {
    // Bracket first (the power rises with λ), then halve the bracket.
    let mut hi = 1.0;
    while noncentral_sf(c, q, hi) < POWER && hi < 1e6 {
        hi *= 2.0;
    }
    let mut lo = 0.0;
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if noncentral_sf(c, q, mid) < POWER {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The detection limit of candidate `c` after `chosen`, in `c`'s unit, at the step's `level`
/// with reference variance `sigma2` ((°/s)²); `None` when the windows are too few to test it.
pub fn detection_limit(
    data: &WindowData,
    chosen: &[&Candidate],
    c: &Candidate,
    sigma2: f64,
    level: f64,
) -> Option<f64> {
    let n = data.rate_dps.len();
    let x = design(chosen, Some(c), n);
    let p1 = x.ncols();
    let p0 = p1 - width(c);
    if n < p1 + MIN_DOF_TERM {
        return None;
    }
    let inv = (x.transpose() * &x).try_inverse()?;
    let se_max = (p0..p1)
        .map(|j| (sigma2 * inv[(j, j)]).sqrt())
        .fold(0.0, f64::max);
    let q = (3 * width(c)) as f64;
    let d2 = (3 * (n - p1)) as f64;
    let nn = n as f64;
    let cv_need = 3.0 * nn * (CV_FACTOR.powi(2) * (1.0 + p1 as f64 / nn) - (1.0 + p0 as f64 / nn));
    limit_from(se_max, q, d2, level, cv_need)
}

/// The limit from the candidate's largest standard error `se_max`, its `q` coefficients (all
/// axes), the residual dof `d2` with it, the step's `level`, and `cv_need`: the squared
/// coefficient, in units of `se_max²`, at which the held-out RMS falls by the CV factor (module
/// docs; `rows·(c²(1 + p₁/m) − (1 + p₀/m))` with `m` the rows per parameter set).
pub fn limit_from(se_max: f64, q: f64, d2: f64, level: f64, cv_need: f64) -> Option<f64> {
    let crit = q * f_critical(level, q, d2);
    let beta_f = lambda_for_power(crit, q).sqrt() * se_max;
    let beta_cv = se_max * cv_need.max(0.0).sqrt();
    let limit = beta_f.max(beta_cv);
    limit.is_finite().then_some(limit)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The central case (λ = 0) is the test's level; a known value of the non-central χ²
    /// (R: `pchisq(3.84, 1, ncp = 7.85, lower = FALSE)` = 0.800).
    #[test]
    fn noncentral_chi2_against_known_values() {
        assert!((noncentral_sf(3.841_458_8, 1.0, 0.0) - 0.05).abs() < 1e-6);
        assert!((noncentral_sf(3.841_458_8, 1.0, 7.848_861) - 0.8).abs() < 1e-4);
        assert!((lambda_for_power(3.841_458_8, 1.0) - 7.848_861).abs() < 1e-3);
    }
}
