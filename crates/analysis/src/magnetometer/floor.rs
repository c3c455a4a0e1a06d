//! The magnetometer's noise floor, measured from the recording itself: the short-term scatter
//! of each axis about a smooth track.
//!
//! Why second differences: a hand-held rotation moves the field by much more than the noise
//! between samples, but smoothly; `m[i+1] − 2·m[i] + m[i−1]` cancels a track that is locally a
//! straight line and leaves `6σ²` of white noise. Its median absolute value (÷ 0.6745 for a
//! Gaussian) ignores the few samples where the motion jerks. A quantised axis whose steps are
//! mostly zero has at least the rounding's `q/√12` (`q` its smallest step).

use super::design::Geo;

/// Each axis's white-noise standard deviation, raw units (see the module docs).
pub fn axis_noise(points: &[[f64; 3]]) -> [f64; 3] {
    std::array::from_fn(|a| {
        let d2: Vec<f64> = points
            .windows(3)
            .map(|w| (w[2][a] - 2.0 * w[1][a] + w[0][a]).abs())
            .collect();
        let med = crate::stats::median(&d2);
        let robust = if med > 0.0 {
            med / 0.6745 / 6f64.sqrt()
        } else {
            crate::stats::rms(&d2) / 6f64.sqrt()
        };
        let q = points
            .windows(2)
            .map(|w| (w[1][a] - w[0][a]).abs())
            .filter(|d| *d > 0.0)
            .fold(f64::INFINITY, f64::min);
        let rounding = if q.is_finite() { q / 12f64.sqrt() } else { 0.0 };
        if robust.is_finite() {
            robust.max(rounding)
        } else {
            rounding
        }
    })
}

/// The residual's noise floor, raw units: the axes' noise seen along each sample's radial
/// direction (`Wᵀn̂`), as an RMS over the samples.
pub fn residual_floor(geos: &[Geo], sigma: &[f64; 3]) -> f64 {
    if geos.is_empty() {
        return 0.0;
    }
    let s: f64 = geos
        .iter()
        .map(|g| (0..3).map(|a| (g.grad[a] * sigma[a]).powi(2)).sum::<f64>())
        .sum();
    (s / geos.len() as f64).sqrt()
}

/// Fewest noise standard deviations the points must spread over on some axis for a fit to
/// mean anything: a still sensor's blob spreads over ~1 (1.4 on the unmoved HMC5883L logs),
/// the noisiest and the sparsest real rotations here over 14 and 17.
pub const MIN_SPREAD_OVER_NOISE: f64 = 5.0;

/// `(largest axis spread, its noise)` when the points never leave a blob of their own noise
/// (the sensor was not rotated), `None` otherwise.
pub fn still_blob(points: &[[f64; 3]]) -> Option<(f64, f64)> {
    if points.len() < 3 {
        return None;
    }
    let sigma = axis_noise(points);
    let n = points.len() as f64;
    let spread: [f64; 3] = std::array::from_fn(|a| {
        let m = points.iter().map(|p| p[a]).sum::<f64>() / n;
        (points.iter().map(|p| (p[a] - m).powi(2)).sum::<f64>() / n).sqrt()
    });
    let (a, s) = spread.iter().enumerate().max_by(|x, y| {
        (x.1 / sigma[x.0].max(f64::MIN_POSITIVE))
            .total_cmp(&(y.1 / sigma[y.0].max(f64::MIN_POSITIVE)))
    })?;
    (*s < MIN_SPREAD_OVER_NOISE * sigma[a]).then_some((*s, sigma[a]))
}

/// How well the fitted directions cover the sphere: the smallest eigenvalue of the mean
/// `n̂·n̂ᵀ` (1/3 for a full sphere, 0 for a plane or a line).
pub fn coverage(geos: &[Geo]) -> f64 {
    let n = geos.len().max(1) as f64;
    let m =
        nalgebra::Matrix3::from_fn(|i, j| geos.iter().map(|g| g.u[i] * g.u[j]).sum::<f64>() / n);
    m.symmetric_eigenvalues().min()
}
