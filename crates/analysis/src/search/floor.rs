//! The noise floor: what averaging can achieve in each window, propagated through the
//! calibration to the residual ‖a‖ − 1 g, and the χ² of a model's residuals against it.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use crate::detect::windows::WindowStats;
use crate::fit::model::{self as am, Params, Win};
use crate::stats as st;

/// Per-window noise floor of the residual (g): var/n (NaN where n is unknown) (or, with `batch`, the batch-means
/// variance of the mean; NaN where a window is too short for it) propagated through ∂r/∂m.
pub fn floors(
    p: &Params,
    wins: &[Win],
    stats: &[WindowStats],
    scale: f64,
    batch: bool,
) -> Vec<f64> {
    wins.iter()
        .zip(stats)
        .map(|(w, s)| {
            let (_, g) = am::residual_and_grad(p, w);
            let v = if batch {
                match s.batch_var_of_mean {
                    Some(v) => v,
                    None => return f64::NAN,
                }
            } else {
                match s.n() {
                    Some(n) => s.var.map(|v| v / n as f64),
                    // Unknown sample count: the floor is unknown (NaN), not guessed.
                    None => return f64::NAN,
                }
            };
            // r depends on y = (m − c)/s exactly as on −b: ∂r/∂m = −∂r/∂b / s.
            (0..3)
                .map(|a| (g[am::BIAS + a] / scale).powi(2) * v[a])
                .sum::<f64>()
                .sqrt()
        })
        .collect()
}

/// Mean of the squared floors (g²) over the windows in use whose floor is finite and
/// positive; 0 when there is none. The residual variance a right model leaves (unweighted
/// least squares: `E[rss] ≈ Σ (1 − hᵢ) fᵢ²`, i.e. `dof` times about this mean).
pub fn mean_square_floor(floor: &[f64], used: &[bool]) -> f64 {
    let (sum, n) = floor
        .iter()
        .zip(used)
        .filter(|(f, u)| **u && **f > 0.0 && f.is_finite())
        .fold((0.0, 0usize), |(s, n), (f, _)| (s + f * f, n + 1));
    if n == 0 {
        0.0
    } else {
        sum / n as f64
    }
}

/// The variance every test of the search (F-tests of candidates and drop tests, the outlier
/// prediction-error test) refers its residuals to, g²: the fit's `rss/dof`, but never less
/// than [`mean_square_floor`] of the windows in `used`.
///
/// Why: under a model that is right, each residual still carries its window's sampling
/// noise, so `E[rss/dof] ≈ mean f²`, and the floor (hundreds of samples per window) is far
/// better determined than `rss/dof` (~20 dof). On ~20 dof `rss/dof` falls below half its
/// expectation in about one recording of a hundred; taken alone it then inflates every F
/// (and outlier t) by that factor, and a clean recording gained an effect or lost a window
/// in about one run of 150 (docs/residuals.md). With the floor as the lower bound the
/// F-distribution on the fit's dof is exact when `rss/dof` is taken and conservative when
/// the floor is. A residual above the floor (an effect the model lacks, or noise the floor
/// misses, such as drift inside the windows) is unaffected.
pub fn reference_variance(rss: f64, dof: f64, floor: &[f64], used: &[bool]) -> f64 {
    (rss / dof).max(mean_square_floor(floor, used)).max(1e-300)
}

/// χ², its degrees of freedom and its p-value for the windows in use with a positive floor
/// (`None`s when there are no more such windows than the `k` parameters).
pub fn chi2_summary(
    p: &Params,
    wins: &[Win],
    used: &[bool],
    floor: &[f64],
    k: usize,
) -> (Option<f64>, Option<usize>, Option<f64>) {
    let mut chi2 = 0.0;
    let mut n = 0usize;
    for ((w, u), f) in wins.iter().zip(used).zip(floor) {
        if !*u || !(*f > 0.0) {
            continue;
        }
        chi2 += (am::residual(p, w) / f).powi(2);
        n += 1;
    }
    if n <= k {
        return (None, None, None);
    }
    let dof = n - k;
    (Some(chi2), Some(dof), Some(st::chi2_sf(chi2, dof as f64)))
}
