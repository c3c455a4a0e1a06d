//! Motion inside the "static" windows: a check, not an effect.
//!
//! A window taken while the sensor still turns slowly averages gravity over an arc, and the
//! mean of unit vectors spread with covariance Σ (in g) is shorter than 1 g by about
//! tr(Σ)/2. The multi-position fit then sees windows that are too short by an amount that
//! follows their spread: the common part is absorbed into the scale factors, the rest stays
//! in the residual. The within-window covariance is known (the window statistics), so the
//! shortening each window should show is predicted with no parameter: `dᵢ = tr(K·(Σᵢ −
//! Σ_ref)₊·Kᵀ)/2`, with `K` the fitted correction matrix and `Σ_ref` the detector's reference
//! (the sensor's own noise, which does not shorten a mean). When the base residuals follow
//! `−dᵢ` significantly, the windows are not still and the report says so, with the size.
//!
//! This is not a calibration term (no sensor correction undoes hand motion during a
//! recording); the cure is a recording with stiller holds. Seen on real data: sunsided's
//! full-sphere MPU-6050 log (continuous rotation with brief pauses) and CK-Explorer's
//! `acc_mag_log.csv` (continuous tumbling, meant for the magnetometer).

use crate::detect::windows::WindowStats;
use crate::stats as st;

/// What the check found.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionCheck {
    /// Median predicted shortening over the windows, mg.
    pub median_shortening_mg: f64,
    /// Largest predicted shortening, mg.
    pub max_shortening_mg: f64,
    /// Correlation of the base residual with the predicted `−dᵢ`.
    pub correlation: f64,
    /// Its two-sided p-value (Student's t, n − 2 degrees of freedom).
    pub p_value: f64,
}

/// Predicted shortening of each window's mean, g: `tr(K·(Σᵢ − Σ_ref)₊·Kᵀ)/2` with the
/// per-axis variances (raw²) of the window and of the reference. Cross-covariances are not
/// kept by the window statistics; for the near-orthogonal `K` of an accelerometer the
/// diagonal carries the trace.
pub fn predicted_shortening(k: &[[f64; 3]; 3], var: [f64; 3], reference_var: [f64; 3]) -> f64 {
    let excess = [0, 1, 2].map(|a| (var[a] - reference_var[a]).max(0.0));
    let mut tr = 0.0;
    for row in k {
        for (c, e) in excess.iter().enumerate() {
            tr += row[c] * row[c] * e;
        }
    }
    tr / 2.0
}

/// The reference variance: per axis the smallest window variance (raw²), i.e. the
/// stillest window's noise. Self-contained and in the windows' own units, whatever detector
/// (or none, for window-mean input) produced them.
pub fn reference_variance(stats: &[WindowStats]) -> [f64; 3] {
    [0, 1, 2].map(|a| stats.iter().map(|w| w.var[a]).fold(f64::INFINITY, f64::min))
}

/// Correlates the base residuals (g, one per window) with the predicted shortening.
/// `None` with fewer than 5 windows or no spread in the prediction.
pub fn check(
    k: &[[f64; 3]; 3],
    stats: &[WindowStats],
    reference_var: [f64; 3],
    residuals: &[f64],
) -> Option<MotionCheck> {
    let n = stats.len().min(residuals.len());
    if n < 5 {
        return None;
    }
    let d: Vec<f64> = stats[..n]
        .iter()
        .map(|w| predicted_shortening(k, w.var, reference_var))
        .collect();
    let minus_d: Vec<f64> = d.iter().map(|x| -x).collect();
    let r = st::correlation(&residuals[..n], &minus_d);
    if r == 0.0 {
        return None;
    }
    let nu = (n - 2) as f64;
    let t = r * (nu / (1.0 - r * r).max(1e-300)).sqrt();
    Some(MotionCheck {
        median_shortening_mg: st::median(&d) * 1e3,
        max_shortening_mg: d.iter().copied().fold(0.0, f64::max) * 1e3,
        correlation: r,
        p_value: st::t_two_sided(t, nu),
    })
}

/// The diagnostic sentence when the residual follows the motion (positive correlation
/// significant at `alpha`) and the median shortening is at least `floor_mg` (below the noise
/// floor it could not matter).
pub fn diagnostic(m: &MotionCheck, alpha: f64, floor_mg: f64) -> Option<String> {
    if !(m.correlation > 0.0 && m.p_value < alpha && m.median_shortening_mg >= floor_mg) {
        return None;
    }
    Some(format!(
        "the windows are not still: their spread beyond the sensor's own noise shortens their means by a median {:.2} mg (up to {:.1} mg; a mean over an arc is shorter than 1 g by tr(Σ)/2), and the base residual follows it (r = {:.2}, p {}); no calibration term can undo motion during the recording: record again with stiller holds",
        m.median_shortening_mg,
        m.max_shortening_mg,
        m.correlation,
        st::fmt_p(m.p_value)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn window(var_g2: f64) -> WindowStats {
        WindowStats {
            start: 0,
            end: 100,
            mean: [0.0, 0.0, 1.0],
            var: [var_g2; 3],
            batch_var_of_mean: None,
            t_centre: 0.0,
            t_first: 0.0,
            t_last: 0.0,
            temp: None,
            count: None,
            runs: None,
            distinct: None,
        }
    }

    const I: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

    /// Exact for a unit vector spread by small rotations: the mean of (sin θ, 0, cos θ)
    /// over θ uniform in ±a has length sin(a)/a ≈ 1 − a²/6, and the x variance is a²/3 −
    /// O(a⁴), so tr(Σ)/2 = a²/6 to leading order.
    #[test]
    fn shortening_of_an_arc_matches_the_exact_mean_length() {
        let a: f64 = 0.2;
        let n = 2001;
        let pts: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                let th = -a + 2.0 * a * i as f64 / (n - 1) as f64;
                [th.sin(), 0.0, th.cos()]
            })
            .collect();
        let mean = [0, 1, 2].map(|c| pts.iter().map(|p| p[c]).sum::<f64>() / n as f64);
        let var = [0, 1, 2]
            .map(|c| pts.iter().map(|p| (p[c] - mean[c]).powi(2)).sum::<f64>() / (n - 1) as f64);
        let exact = 1.0 - (mean[0].powi(2) + mean[2].powi(2)).sqrt();
        let predicted = predicted_shortening(&I, var, [0.0; 3]);
        assert!(
            (predicted - exact).abs() < 0.02 * exact,
            "{predicted} vs {exact}"
        );
    }

    /// Residuals made of the predicted shortening plus noise are flagged; independent
    /// residuals of the same size are not, nor is motion below the floor.
    #[test]
    fn flags_residuals_that_follow_the_motion_only() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let stats: Vec<WindowStats> = (0..30)
            .map(|_| window(rng.random_range(1e-4..4e-3)))
            .collect();
        let d: Vec<f64> = stats
            .iter()
            .map(|w| predicted_shortening(&I, w.var, [1e-5; 3]))
            .collect();
        let following: Vec<f64> = d
            .iter()
            .map(|x| -x + 2e-4 * rng.random_range(-1.0..1.0))
            .collect();
        let m = check(&I, &stats, [1e-5; 3], &following).unwrap();
        assert!(m.correlation > 0.9, "{m:?}");
        assert!(diagnostic(&m, 0.01, 0.1).unwrap().contains("not still"));
        assert!(diagnostic(&m, 0.01, 100.0).is_none(), "below the floor");
        let unrelated: Vec<f64> = (0..30)
            .map(|_| 3e-3 * rng.random_range(-1.0..1.0))
            .collect();
        let m = check(&I, &stats, [1e-5; 3], &unrelated).unwrap();
        assert!(diagnostic(&m, 0.01, 0.1).is_none(), "{m:?}");
    }
}
