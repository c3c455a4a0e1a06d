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
//! The formula is the one every search states its limits by ([`crate::stats::limit_from`]);
//! this module gives it the gyro's design. The simulation in the tests injects each effect at
//! twice its limit and finds it in at least 80 % of runs.

use super::design::{design, width, Candidate, WindowData};
use crate::search::select::{CV_FACTOR, MIN_DOF_TERM};
pub use crate::stats::{limit_from, POWER};

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
