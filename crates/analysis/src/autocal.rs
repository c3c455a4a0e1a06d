//! Free-living autocalibration as GGIR does it: van Hees et al. (2014), "Autocalibration of
//! accelerometer data for free-living physical activity assessment using local gravity and
//! temperature: an evaluation on four continents", J Appl Physiol 117:738–744.
//!
//! # The method (in our words)
//!
//! The input is many still epochs collected over days of wear (10-s windows whose per-axis
//! SD is below a few tens of mg): their means `x` (g) should all lie on the unit sphere, since
//! only gravity acts on a still sensor. The model per axis `j` is
//!
//! ```text
//! a_j = s_j·(x_j + o_j) + k_j·(T − T̄)         (g; T the epoch's temperature, T̄ its mean)
//! ```
//!
//! with offset `o` (added *before* scaling, GGIR's convention), scale `s` and temperature
//! coefficient `k`. It is fitted by iterating two steps from `o = 0, s = 1, k = 0`:
//!
//! 1. calibrate every epoch with the current parameters and take, as its target, the closest
//!    point on the unit sphere (the calibrated vector divided by its norm);
//! 2. per axis, a weighted least-squares regression of the target on `[1, a_j, T − T̄]`;
//!    its intercept, slope and temperature slope are a correction composed onto the current
//!    parameters (`s ← s·slope`, `o ← o + intercept/s_new`, `k ← k·slope + temperature
//!    slope`).
//!
//! The weights make the fit robust to epochs that were not quite still or sat near a
//! temperature transient: each epoch's weight is `1 / max(d, 10 mg)`, `d` its distance from its
//! target after the step (so an epoch already on the sphere does not get an unbounded weight).
//! The iteration stops when the weighted mean squared distance changes by less than a
//! tolerance.
//!
//! Before fitting, the sphere must be covered: each axis must reach beyond ±0.3 g on both
//! sides, otherwise scale and offset are not separable and nothing is fitted. The result is
//! judged by the mean |‖a‖ − 1| over the epochs before and after.
//!
//! [`Autocal::to_calibration`] writes the result as wiical's [`Calibration`]
//! (`a = K·(m − b_eff)`, `b_eff = b + bias_temp·(θ − θ₀)`): `K = diag(s)`, `b = −o`,
//! `bias_temp = −k/s`, `θ₀ = T̄`, so `Calibration::correct` reproduces the model exactly.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;
use wiical_core::{Calibration, Effects};

/// Settings of the autocalibration (defaults: the paper's / GGIR's values).
#[derive(Debug, Clone)]
pub struct AutocalOptions {
    /// Each axis must reach beyond ±this on both sides, g (0.3).
    pub sphere_crit_g: f64,
    /// Smallest distance used in a weight, g (10 mg: weight at most 100).
    pub min_distance_g: f64,
    /// Most iterations (1000).
    pub max_iterations: usize,
    /// Stop when the weighted mean squared distance, divided by the number of epochs,
    /// changes by less than this between iterations, g² (1e-10, GGIR's criterion).
    pub tolerance_g2: f64,
    /// Fit the temperature coefficients when temperatures are given (true).
    pub use_temperature: bool,
}

impl AutocalOptions {
    /// Iterate to the fixed point (tolerance 1e-22 g², up to 20 000 iterations) instead of
    /// GGIR's stop: GGIR's tolerance is on a per-epoch average, so with thousands of epochs it
    /// stops after a few iterations, short of the least-squares solution (see
    /// docs/residuals.md for what that changes on GGIR's own example).
    pub fn converged() -> Self {
        Self {
            tolerance_g2: 1e-22,
            max_iterations: 20_000,
            ..Self::default()
        }
    }
}

impl Default for AutocalOptions {
    fn default() -> Self {
        Self {
            sphere_crit_g: 0.3,
            min_distance_g: 0.01,
            max_iterations: 1000,
            tolerance_g2: 1e-10,
            use_temperature: true,
        }
    }
}

/// Why the autocalibration was not done.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AutocalError {
    /// Too few epochs for the regressions.
    #[error("{found} still epochs; the autocalibration needs at least {needed}")]
    TooFewEpochs {
        /// Epochs given.
        found: usize,
        /// Epochs needed.
        needed: usize,
    },
    /// An axis does not reach beyond ±crit on both sides.
    #[error("the sphere is not covered: axis {axis} spans {min:.3} to {max:.3} g, it must reach beyond ±{crit} g on both sides")]
    SphereNotCovered {
        /// The axis.
        axis: &'static str,
        /// Its smallest mean, g.
        min: f64,
        /// Its largest mean, g.
        max: f64,
        /// The criterion, g.
        crit: f64,
    },
    /// A mean or temperature is not finite, or the lengths differ.
    #[error("the epochs hold non-finite values or temperatures of a different count")]
    BadInput,
    /// The means are not in g (the method's targets and thresholds are in g).
    #[error("the window means are in {units}, not g: the method works in g")]
    NotInG {
        /// The units inferred.
        units: &'static str,
    },
    /// A regression's normal matrix is singular (e.g. constant temperature with its term on).
    #[error("the per-axis regression is singular (an axis or the temperature does not vary)")]
    Singular,
}

/// The fitted autocalibration (GGIR's convention: `a = s∘(x + o) + k∘(T − T̄)`).
#[derive(Debug, Clone, PartialEq)]
pub struct Autocal {
    /// Offset `o`, g (added before scaling).
    pub offset: [f64; 3],
    /// Scale `s`.
    pub scale: [f64; 3],
    /// Temperature coefficient `k`, g/°C (zero without temperatures).
    pub temp_coef: [f64; 3],
    /// Mean temperature `T̄` of the epochs, °C (`None` without temperatures).
    pub temp_mean_c: Option<f64>,
    /// Standard errors of offset, scale and temperature coefficient (the fit as a weighted
    /// least-squares problem in ‖a‖ − 1, final weights).
    pub std_errors: AutocalStdErrors,
    /// Mean |‖x‖ − 1| before, g.
    pub error_before_g: f64,
    /// Mean |‖a‖ − 1| after, g.
    pub error_after_g: f64,
    /// Iterations run.
    pub iterations: usize,
    /// True when the stop criterion was met before the iteration limit.
    pub converged: bool,
    /// Epochs used.
    pub epochs: usize,
}

/// Standard errors of an [`Autocal`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct AutocalStdErrors {
    /// Of the offset, g.
    pub offset: [f64; 3],
    /// Of the scale.
    pub scale: [f64; 3],
    /// Of the temperature coefficient, g/°C.
    pub temp_coef: [f64; 3],
}

/// Fits the autocalibration to still-epoch means (g) and, optionally, their temperatures (°C).
pub fn autocalibrate(
    means: &[[f64; 3]],
    temps: Option<&[f64]>,
    opts: &AutocalOptions,
) -> Result<Autocal, AutocalError> {
    let temps = temps.filter(|_| opts.use_temperature);
    check_input(means, temps, opts)?;
    let n = means.len();
    let temp_mean = temps.map(|t| t.iter().sum::<f64>() / n as f64);
    let dt: Vec<f64> = match (temps, temp_mean) {
        (Some(t), Some(m)) => t.iter().map(|x| x - m).collect(),
        _ => vec![0.0; n],
    };
    let use_temp = temps.is_some();
    let mut p = Autocal {
        offset: [0.0; 3],
        scale: [1.0; 3],
        temp_coef: [0.0; 3],
        temp_mean_c: temp_mean,
        std_errors: AutocalStdErrors::default(),
        error_before_g: mean_abs_norm_error(means.iter().copied()),
        error_after_g: f64::NAN,
        iterations: 0,
        converged: false,
        epochs: n,
    };
    let mut weights = vec![1.0; n];
    let mut last = f64::INFINITY;
    for iter in 1..=opts.max_iterations {
        let cur: Vec<[f64; 3]> = (0..n).map(|i| p.apply_centred(means[i], dt[i])).collect();
        let target: Vec<[f64; 3]> = cur.iter().map(|a| unit(*a)).collect();
        let mut fitted = cur.clone();
        for j in 0..3 {
            let coef = weighted_regression(&cur, &target, &dt, &weights, j, use_temp)?;
            let new_scale = p.scale[j] * coef[1];
            p.offset[j] += coef[0] / new_scale;
            p.temp_coef[j] = p.temp_coef[j] * coef[1] + coef[2];
            p.scale[j] = new_scale;
            for (f, (c, d)) in fitted.iter_mut().zip(cur.iter().zip(&dt)) {
                f[j] = coef[0] + coef[1] * c[j] + coef[2] * d;
            }
        }
        let mut wsum = 0.0;
        let mut wss = 0.0;
        for i in 0..n {
            let d = dist(fitted[i], target[i]);
            wss += weights[i] * d * d;
            wsum += weights[i];
            weights[i] = 1.0 / d.max(opts.min_distance_g);
        }
        let res = wss / wsum / n as f64;
        p.iterations = iter;
        if (last - res).abs() < opts.tolerance_g2 {
            p.converged = true;
            break;
        }
        last = res;
    }
    p.std_errors = std_errors(&p, means, &dt, &weights, use_temp);
    p.error_after_g = mean_abs_norm_error((0..n).map(|i| p.apply_centred(means[i], dt[i])));
    Ok(p)
}

/// Enough epochs, finite values, and each axis beyond ±crit on both sides.
/// Fewest still epochs the autocalibration accepts (a handful of orientations is not a
/// sphere; GGIR asks for many more in practice).
pub const MIN_EPOCHS: usize = 10;

fn check_input(
    means: &[[f64; 3]],
    temps: Option<&[f64]>,
    opts: &AutocalOptions,
) -> Result<(), AutocalError> {
    if means.len() < MIN_EPOCHS {
        return Err(AutocalError::TooFewEpochs {
            found: means.len(),
            needed: MIN_EPOCHS,
        });
    }
    let finite = means.iter().flatten().all(|v| v.is_finite())
        && temps.is_none_or(|t| t.len() == means.len() && t.iter().all(|v| v.is_finite()));
    if !finite {
        return Err(AutocalError::BadInput);
    }
    for (a, axis) in ["x", "y", "z"].into_iter().enumerate() {
        let lo = means.iter().map(|m| m[a]).fold(f64::INFINITY, f64::min);
        let hi = means.iter().map(|m| m[a]).fold(f64::NEG_INFINITY, f64::max);
        if !(lo < -opts.sphere_crit_g && hi > opts.sphere_crit_g) {
            return Err(AutocalError::SphereNotCovered {
                axis,
                min: lo,
                max: hi,
                crit: opts.sphere_crit_g,
            });
        }
    }
    Ok(())
}

/// Weighted least squares of `target[j]` on `[1, cur[j], dt]` (the temperature column left
/// out, its coefficient 0, when `use_temp` is false).
fn weighted_regression(
    cur: &[[f64; 3]],
    target: &[[f64; 3]],
    dt: &[f64],
    w: &[f64],
    j: usize,
    use_temp: bool,
) -> Result<[f64; 3], AutocalError> {
    let mut xtwx = Matrix3::zeros();
    let mut xtwy = Vector3::zeros();
    for i in 0..cur.len() {
        let x = Vector3::new(1.0, cur[i][j], if use_temp { dt[i] } else { 0.0 });
        xtwx += w[i] * x * x.transpose();
        xtwy += w[i] * target[i][j] * x;
    }
    if !use_temp {
        xtwx[(2, 2)] = 1.0;
    }
    let beta = nalgebra::Cholesky::new(xtwx)
        .ok_or(AutocalError::Singular)?
        .solve(&xtwy);
    if !beta.iter().all(|b| b.is_finite()) {
        return Err(AutocalError::Singular);
    }
    Ok([beta[0], beta[1], beta[2]])
}

/// Standard errors of `o, s, k` from the final fit as a weighted nonlinear least-squares
/// problem in `r = ‖a‖ − 1` (its fixed point is that problem's solution): covariance
/// `σ²·(JᵀWJ)⁻¹` with `σ² = Σw·r²/(n − p)`. Zeros when the matrix is singular.
fn std_errors(
    p: &Autocal,
    means: &[[f64; 3]],
    dt: &[f64],
    w: &[f64],
    use_temp: bool,
) -> AutocalStdErrors {
    type M9 = nalgebra::SMatrix<f64, 9, 9>;
    type V9 = nalgebra::SVector<f64, 9>;
    let mut jtj = M9::zeros();
    let mut wss = 0.0;
    for i in 0..means.len() {
        let a = p.apply_centred(means[i], dt[i]);
        let norm = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        let mut g = V9::zeros();
        for j in 0..3 {
            let u = a[j] / norm;
            g[j] = u * p.scale[j];
            g[3 + j] = u * (means[i][j] + p.offset[j]);
            g[6 + j] = if use_temp { u * dt[i] } else { 0.0 };
        }
        jtj += w[i] * g * g.transpose();
        wss += w[i] * (norm - 1.0).powi(2);
    }
    let k = if use_temp { 9 } else { 6 };
    if !use_temp {
        for j in 6..9 {
            jtj[(j, j)] = 1.0;
        }
    }
    let sigma2 = wss / means.len().saturating_sub(k).max(1) as f64;
    let Some(inv) = jtj.try_inverse() else {
        return AutocalStdErrors::default();
    };
    let se = |r: usize| (sigma2 * inv[(r, r)]).max(0.0).sqrt();
    AutocalStdErrors {
        offset: [0, 1, 2].map(se),
        scale: [3, 4, 5].map(se),
        temp_coef: if use_temp {
            [6, 7, 8].map(se)
        } else {
            [0.0; 3]
        },
    }
}

fn unit(a: [f64; 3]) -> [f64; 3] {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    a.map(|v| v / n)
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Mean |‖a‖ − 1| over the vectors, g.
fn mean_abs_norm_error(it: impl Iterator<Item = [f64; 3]>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for a in it {
        s += ((a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt() - 1.0).abs();
        n += 1;
    }
    s / n.max(1) as f64
}

impl Autocal {
    /// Calibrates a mean `x` (g) at temperature `temp_c` (ignored without a temperature fit).
    pub fn apply(&self, x: [f64; 3], temp_c: Option<f64>) -> [f64; 3] {
        let dt = match (self.temp_mean_c, temp_c) {
            (Some(m), Some(t)) => t - m,
            _ => 0.0,
        };
        self.apply_centred(x, dt)
    }

    fn apply_centred(&self, x: [f64; 3], dt: f64) -> [f64; 3] {
        std::array::from_fn(|j| self.scale[j] * (x[j] + self.offset[j]) + self.temp_coef[j] * dt)
    }

    /// The same correction as wiical's [`Calibration`]: `K = diag(s)`, `b = −o`,
    /// `bias_temp = −k/s` (raw units per °C), `temp_ref_c = T̄`.
    pub fn to_calibration(&self) -> Calibration {
        let s = self.scale;
        Calibration {
            bias: self.offset.map(|o| (-o) as f32),
            matrix: [
                [s[0] as f32, 0.0, 0.0],
                [0.0, s[1] as f32, 0.0],
                [0.0, 0.0, s[2] as f32],
            ],
            effects: Effects {
                temp_ref_c: self.temp_mean_c.unwrap_or(0.0) as f32,
                bias_temp: std::array::from_fn(|j| (-self.temp_coef[j] / s[j]) as f32),
                ..Effects::default()
            },
        }
    }

    /// The result as reported (mg, mg/°C).
    pub fn report(&self) -> AutocalReport {
        let mg = |v: [f64; 3]| v.map(|x| x * 1e3);
        AutocalReport {
            method: METHOD,
            done: true,
            reason: None,
            offset_mg: Some(mg(self.offset)),
            scale: Some(self.scale),
            temp_offset_mg_per_c: self.temp_mean_c.map(|_| mg(self.temp_coef)),
            temp_mean_c: self.temp_mean_c,
            std_errors: Some(AutocalStdErrors {
                offset: mg(self.std_errors.offset),
                scale: self.std_errors.scale,
                temp_coef: mg(self.std_errors.temp_coef),
            }),
            error_before_mg: Some(self.error_before_g * 1e3),
            error_after_mg: Some(self.error_after_g * 1e3),
            iterations: Some(self.iterations),
            converged: Some(self.converged),
            epochs: self.epochs,
            calibration: Some(self.to_calibration()),
        }
    }
}

/// Name of the method in reports.
pub const METHOD: &str = "van Hees et al. 2014 (GGIR g.calibrate): sphere autocalibration";

/// The autocalibration as reported with `analyze` (JSON key `autocalibration`).
#[derive(Debug, Clone, Serialize)]
pub struct AutocalReport {
    /// The method's name.
    pub method: &'static str,
    /// False when the method could not run (see `reason`).
    pub done: bool,
    /// Why not.
    pub reason: Option<String>,
    /// Offset `o`, mg (GGIR's convention: added before scaling).
    pub offset_mg: Option<[f64; 3]>,
    /// Scale `s`.
    pub scale: Option<[f64; 3]>,
    /// Temperature coefficient `k`, mg/°C (`null` without temperatures).
    pub temp_offset_mg_per_c: Option<[f64; 3]>,
    /// Mean temperature `T̄`, °C.
    pub temp_mean_c: Option<f64>,
    /// Standard errors (offset mg, scale, temperature mg/°C).
    pub std_errors: Option<AutocalStdErrors>,
    /// Mean |‖a‖ − 1| over the epochs before, mg.
    pub error_before_mg: Option<f64>,
    /// … and after, mg.
    pub error_after_mg: Option<f64>,
    /// Iterations run.
    pub iterations: Option<usize>,
    /// Stop criterion met.
    pub converged: Option<bool>,
    /// Epochs given.
    pub epochs: usize,
    /// The same correction as a wiical calibration.
    pub calibration: Option<Calibration>,
}

impl AutocalReport {
    /// The report of a run that could not be done.
    pub fn not_done(epochs: usize, why: &AutocalError) -> Self {
        AutocalReport {
            method: METHOD,
            done: false,
            reason: Some(why.to_string()),
            offset_mg: None,
            scale: None,
            temp_offset_mg_per_c: None,
            temp_mean_c: None,
            std_errors: None,
            error_before_mg: None,
            error_after_mg: None,
            iterations: None,
            converged: None,
            epochs,
            calibration: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_distr::{Distribution, Normal};

    /// Epochs on the sphere in random orientations, with known offset, scale and temperature
    /// coefficient applied inversely, plus 1 mg noise per axis.
    fn simulated(n: usize, seed: u64) -> (Vec<[f64; 3]>, Vec<f64>, Autocal) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let normal = Normal::new(0.0, 1.0).unwrap();
        let noise = Normal::new(0.0, 1e-3).unwrap();
        let truth = Autocal {
            offset: [-0.0068, 0.0038, 0.0153],
            scale: [1.0009, 0.9952, 0.9977],
            temp_coef: [0.00099, 0.00038, 0.00134],
            temp_mean_c: None,
            std_errors: AutocalStdErrors::default(),
            error_before_g: 0.0,
            error_after_g: 0.0,
            iterations: 0,
            converged: true,
            epochs: n,
        };
        let mut means = Vec::new();
        let mut temps = Vec::new();
        for i in 0..n {
            let g = unit([0; 3].map(|_| normal.sample(&mut rng)));
            // Temperature: a daily cycle 18–32 °C, not aligned with orientation.
            let temp = 25.0 + 7.0 * (i as f64 * 0.013).sin() + rng.random_range(-0.5..0.5);
            temps.push(temp);
            means.push(g.map(|v| v)); // placeholder, filled below once T̄ is known
        }
        let tbar = temps.iter().sum::<f64>() / n as f64;
        for (m, t) in means.iter_mut().zip(&temps) {
            let a = *m;
            *m = std::array::from_fn(|j| {
                (a[j] - truth.temp_coef[j] * (t - tbar)) / truth.scale[j] - truth.offset[j]
                    + noise.sample(&mut rng)
            });
        }
        (
            means,
            temps,
            Autocal {
                temp_mean_c: Some(tbar),
                ..truth
            },
        )
    }

    #[test]
    fn recovers_known_offset_scale_and_temperature() {
        let (means, temps, truth) = simulated(3000, 7);
        let fit = autocalibrate(&means, Some(&temps), &AutocalOptions::converged()).unwrap();
        assert!(fit.converged, "{} iterations", fit.iterations);
        let se = fit.std_errors;
        for j in 0..3 {
            let z = |est: f64, tru: f64, s: f64| (est - tru).abs() / s;
            assert!(
                z(fit.offset[j], truth.offset[j], se.offset[j]) < 4.0,
                "{fit:?}"
            );
            assert!(
                z(fit.scale[j], truth.scale[j], se.scale[j]) < 4.0,
                "{fit:?}"
            );
            assert!(
                z(fit.temp_coef[j], truth.temp_coef[j], se.temp_coef[j]) < 4.0,
                "{fit:?}"
            );
            // The standard errors are of the size 1 mg noise over 3000 epochs implies.
            assert!(se.offset[j] > 1e-5 && se.offset[j] < 1e-4, "{se:?}");
        }
        assert!(fit.error_before_g > 0.005, "{}", fit.error_before_g);
        // After: what the 1 mg per-axis noise leaves (mean |N(0, 1 mg)| ≈ 0.8 mg).
        assert!(fit.error_after_g < 1.0e-3, "{}", fit.error_after_g);
    }

    #[test]
    fn calibration_reproduces_the_ggir_model() {
        let (means, temps, _) = simulated(500, 3);
        let fit = autocalibrate(&means, Some(&temps), &AutocalOptions::default()).unwrap();
        let cal = fit.to_calibration();
        for (m, t) in means.iter().zip(&temps).take(50) {
            let want = fit.apply(*m, Some(*t));
            let got = cal.correct(
                m.map(|v| v as f32),
                &wiical_core::Conditions {
                    time_s: 0.0,
                    temperature_c: Some(*t as f32),
                },
            );
            for j in 0..3 {
                assert!(
                    (f64::from(got[j]) - want[j]).abs() < 2e-6,
                    "{got:?} {want:?}"
                );
            }
        }
    }

    #[test]
    fn without_temperature_and_uncovered_sphere() {
        let (means, _, truth) = simulated(2000, 5);
        // No temperature given: offset and scale still found (the temperature effect, ±7 °C ×
        // ≤ 1.3 mg/°C, is left in the residual, so only roughly).
        let fit = autocalibrate(&means, None, &AutocalOptions::default()).unwrap();
        assert_eq!(fit.temp_coef, [0.0; 3]);
        assert!(fit.temp_mean_c.is_none());
        for j in 0..3 {
            assert!((fit.offset[j] - truth.offset[j]).abs() < 2e-3, "{fit:?}");
        }
        // Only the upper half of z: not covered.
        let upper: Vec<[f64; 3]> = means.iter().copied().filter(|m| m[2] > 0.0).collect();
        let e = autocalibrate(&upper, None, &AutocalOptions::default()).unwrap_err();
        assert!(
            matches!(e, AutocalError::SphereNotCovered { axis: "z", .. }),
            "{e}"
        );
        let e = autocalibrate(&means[..5], None, &AutocalOptions::default()).unwrap_err();
        assert!(matches!(e, AutocalError::TooFewEpochs { found: 5, .. }));
        let mut bad = means.clone();
        bad[3][1] = f64::NAN;
        assert_eq!(
            autocalibrate(&bad, None, &AutocalOptions::default()).unwrap_err(),
            AutocalError::BadInput
        );
    }
}
